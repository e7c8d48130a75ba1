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
#include "profibus_sim/dp/dp_service.hpp"
#include "profibus_sim/dp/dp_slave.hpp"

namespace candp2::dp {

// The simulated master requests the class 1 services (Slave_Diag .. Global_Control of
// dp::Service); the in-process link refuses the class 2 services.
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
