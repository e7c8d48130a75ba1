// One readable line per FDL telegram (docs/profibus.md), for logs and `candp2 sniff`: addresses,
// SAPs, frame control, the DP service derived from the SAPs and the direction, and the payload of
// generic DP-V0 services decoded (Set_Prm standard fields, Chk_Cfg entries, Slave_Diag status bits,
// Global_Control, Data_Exchange bytes). A response names its service only through the request
// before it, so the describer takes an optional previous request (or keeps it: Describer).
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "profibus_sim/dp/dp_service.hpp"
#include "profibus_sim/fdl/fdl.hpp"

namespace candp2::fdl {

enum class Service : std::uint8_t {
  Unknown,
  FdlStatus,
  DataExchange,
  SetSlaveAdd,
  RdInp,
  RdOutp,
  GlobalControl,
  GetCfg,
  SlaveDiag,
  SetPrm,
  ChkCfg,
  OtherSap,  // an FDL SAP outside the DP slave's set (e.g. 54 master-master)
  Token,
  Ack,  // short acknowledge without a known request
};
// The DP service a telegram kind is (nullopt for FDL_Status, tokens, acknowledges, other SAPs).
std::optional<dp::Service> dp_service(Service s);
// A DP service by its dp::to_string name; "FDL_Status", "SAP", "Token", "Ack", "?" otherwise.
std::string_view to_string(Service s);

// Request function / response status name of an FC byte ("SRD_high", "DL", ...).
std::string fc_name(std::uint8_t fc);

// The DP service a telegram belongs to. `request` is the request the response answers, if known.
Service service_of(const Telegram& t, const Telegram* request = nullptr);

// True when `response` can be the answer to `request` (addresses swapped, or an SC).
bool answers(const Telegram& response, const Telegram& request);

struct Description {
  Service service = Service::Unknown;
  bool request = false;  // a request (FC bit 6) — false for responses, SC and tokens
  std::string text;      // one line, no newline
};

Description describe(const Telegram& t, const Telegram* request = nullptr);

// Payload decoders (also used by tools that add device-specific decoding on top).
std::string describe_set_prm(std::span<const std::uint8_t> du);  // the standard 7 bytes + user
std::string describe_cfg(std::span<const std::uint8_t> cfg);     // Chk_Cfg / Get_Cfg entries
std::string describe_diag(std::span<const std::uint8_t> diag);   // Slave_Diag bytes
std::string describe_global_control(std::span<const std::uint8_t> du);

// Keeps the last request so responses are named after it.
class Describer {
 public:
  Description describe(const Telegram& t);
  // The latest request described (responses are matched against it).
  const std::optional<Telegram>& last_request() const { return last_request_; }

 private:
  std::optional<Telegram> last_request_;
};

}  // namespace candp2::fdl
