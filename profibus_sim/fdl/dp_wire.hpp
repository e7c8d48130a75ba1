// DP-V0 services as FDL telegrams (EN 50170 vol. 2 DP mapped onto IEC 61158-4-3 FDL;
// docs/decisions.md "FDL on the wire"): which SAPs and function codes a class 1 master's request
// and a slave's answer carry, and the FCB/FCV sequence a master keeps per station. One place for
// the master station (fdl_master.hpp), the slave front end (fdl_slave.hpp) and the in-process
// link's wire image (WireImageLink below, for pcapng captures: docs/capture.md "The in-process
// side"). Pure: no I/O, no clock.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "common/time.hpp"
#include "profibus_sim/dp/slave_link.hpp"
#include "profibus_sim/fdl/fdl.hpp"

namespace candp2::fdl {

// The master's SSAP for every DP service (EN 50170 vol. 2: SAP 62 on the master side).
inline constexpr std::uint8_t kMasterSap = kSapChkCfg;

// The slave's SAP of a DP service; nullopt for Data_Exchange (the default SAP: no address
// extension).
std::optional<std::uint8_t> dsap_of(dp::Service s);

// A master's FCB/FCV towards one station (IEC 61158-4-3 frame count bit): after FDL_Status the
// first SRD carries FCB=1 FCV=0, every later one FCV=1 and the toggled FCB; a repetition of an
// unanswered request keeps its FCB (the slave then resends its last answer).
struct FcbSequence {
  bool fcb = true;
  bool fcv = false;
  void restart() { *this = FcbSequence{}; }  // after FDL_Status
  void advance() {                           // after an answered SRD
    fcb = !fcb;
    fcv = true;
  }
};

// ---- Requests (the master's side) ----------------------------------------------------------
// Request FDL Status: SD1 FC 0x49 (no FCB/FCV), before the first DP request to a station.
Telegram fdl_status_request(std::uint8_t station, std::uint8_t master);
void fdl_status_request_to(Telegram& out, std::uint8_t station, std::uint8_t master);
// The telegram of a DP request from `master` to `station`: SRD_high with the sequence's FCB/FCV,
// DSAP = the service's SAP and SSAP 62 (none for Data_Exchange); Global_Control is SDN_high
// without FCB/FCV (no answer). The sequence is only read.
Telegram dp_request(const dp::Request& req, std::uint8_t station, std::uint8_t master,
                    const FcbSequence& seq);
// The same into `out`, its storage kept (a line that builds one telegram after the other).
void dp_request_to(Telegram& out, const dp::Request& req, std::uint8_t station, std::uint8_t master,
                   const FcbSequence& seq);

// ---- Answers (the slave's side) ------------------------------------------------------------
// An SD1 with no data, addresses swapped: FDL_Status OK, RS ("no service activated"), DH.
Telegram short_answer(const Telegram& request, std::uint8_t function);
// An answer with data and the request's SAPs swapped (DSAP = the master's SSAP, SSAP = the
// service's SAP); SD1 when there is neither a SAP nor data (an SD2 needs LE >= 4).
Telegram data_answer(const Telegram& request, std::uint8_t function,
                     std::span<const std::uint8_t> data);
// The answer to a Data_Exchange: DL (DH while a new diagnosis is pending) with the input bytes;
// without input bytes SC, or SD1 DH when a diagnosis is pending (an SC cannot say "high").
Telegram data_exchange_answer(const Telegram& request, std::span<const std::uint8_t> inputs,
                              bool diag_pending);
// The answer a slave sends to the DP request `request` (built by dp_request) that ended with
// `response`: Slave_Diag/Get_Cfg DL with the bytes, Set_Prm/Chk_Cfg SC, Data_Exchange as above,
// a refusal RS. nullopt when nothing travels: SDN (Global_Control) or no response.
std::optional<Telegram> dp_answer(const Telegram& request, dp::Service service,
                                  const dp::Response& response);
// The same into `out`, its storage kept; false when nothing travels.
bool dp_answer_to(Telegram& out, const Telegram& request, dp::Service service,
                  const dp::Response& response);

// ---- The in-process link's wire image ------------------------------------------------------
// A dp::SlaveLink in front of another (dp::InProcessLink) that reports every DP service as the
// FDL telegrams a class 1 master and the slave would exchange on a line: FDL_Status and its
// answer before the first request to the station (and after reset()), then each request with
// the FCB sequence above and the slave's answer. The master and the slave see nothing of it.
// The request is reported before the inner link runs (so what the slave does meanwhile — CAN
// frames — comes after it in time order), the answer when the inner link completes.
class WireImageLink final : public dp::SlaveLink {
 public:
  // One telegram's bytes; from_master: the master's request (else the slave's answer).
  using Observer =
      std::function<void(std::span<const std::uint8_t> telegram, bool from_master, Time now)>;

  WireImageLink(dp::SlaveLink& inner, Observer observer)
      : inner_(inner), observer_(std::move(observer)) {}

  std::uint8_t address() const override { return inner_.address(); }
  void request(dp::Request req, Time now, dp::Completion done) override;
  // The next request starts with FDL_Status again (the station restarted).
  void reset() { known_ = false; }
  const FcbSequence& sequence() const { return seq_; }

 private:
  void report(const Telegram& t, bool from_master, Time now);

  dp::SlaveLink& inner_;
  Observer observer_;
  bool known_ = false;
  FcbSequence seq_;
  std::vector<std::uint8_t> buf_;
};

}  // namespace candp2::fdl
