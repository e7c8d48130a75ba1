// How the DP master reaches one slave station: a link that carries one DP service request at a
// time and completes it with the slave's response, or with "no response". Asynchronous, so the
// same master (profibus_sim/master/dp_master.hpp) works whether the answer comes at once (the
// in-process link below, a dp::DpSlave in the same process) or later over a wire (fdl::FdlMaster's
// remote stations, profibus_sim/fdl/fdl_master.hpp). Pure: time passed in, no I/O.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string_view>
#include <vector>

#include "common/time.hpp"
#include "profibus_sim/dp/dp_slave.hpp"

namespace candp2::dp {

// The DP-V0 services a class 1 master sends (EN 50170 vol. 2; emulator-spec §10 "DP services over
// FDL").
enum class Service : std::uint8_t {
  SlaveDiag,  // SAP 60: answer = the diagnosis bytes (6..244; the CAN-DP/2: 11, emulator-spec §3)
  SetPrm,     // SAP 61, data = the whole Set_Prm telegram: answer = acknowledge
  ChkCfg,     // SAP 62, data = Chk_Cfg bytes: answer = acknowledge
  GetCfg,     // SAP 59: answer = the configuration bytes
  DataExchange,   // default SAP, data = output bytes: answer = input bytes
  GlobalControl,  // SAP 58, data = Control_Command, Group_Select: unacknowledged (SDN)
};
std::string_view to_string(Service s);

struct Request {
  Service service = Service::SlaveDiag;
  std::uint8_t master = 1;         // the requesting master's address
  std::vector<std::uint8_t> data;  // Set_Prm / Chk_Cfg / output bytes / Global_Control bytes
};

struct Response {
  enum class Status : std::uint8_t {
    Ok,          // answered positively; `data` holds the answer's bytes (none for an acknowledge)
    Refused,     // answered negatively: the service is not active (FDL RS/RR/UE/NR), e.g.
                 // Data_Exchange to a slave that is not in Data_Exch
    NoResponse,  // no (valid) answer within the slot time after all retries: station lost
  };
  Status status = Status::NoResponse;
  std::vector<std::uint8_t> data;
  bool diag_pending = false;  // Data_Exchange answered with DH: new diagnosis to read
};
std::string_view to_string(Response::Status s);

using Completion = std::function<void(const Response&, Time now)>;

class SlaveLink {
 public:
  virtual ~SlaveLink() = default;
  virtual std::uint8_t address() const = 0;
  // Starts a request; `done` runs exactly once, with the response (now or later, from the
  // link's own time source: within this call for the in-process link, from advance()/on_bytes()
  // for a wire). A caller has at most one request outstanding per link.
  virtual void request(Request req, Time now, Completion done) = 0;
};

// The in-process link: calls the DpSlave's services directly and completes before returning. A
// slave that is offline (DpSlave::set_offline) gives no response.
class InProcessLink final : public SlaveLink {
 public:
  explicit InProcessLink(DpSlave& slave) : slave_(slave) {}
  std::uint8_t address() const override { return slave_.info().address; }
  void request(Request req, Time now, Completion done) override;
  DpSlave& slave() { return slave_; }

 private:
  DpSlave& slave_;
};

}  // namespace candp2::dp
