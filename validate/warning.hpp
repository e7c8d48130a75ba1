// A warning of `candp2 validate` (docs/validate.md "Warnings"): behaviour the emulated device
// accepts but a user rarely wants. Shared by the gateway and the generic-slave checks.
#pragma once

#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace candp2::validate {

enum class WarningKind {
  AddressClamped,  // manual §2.1: DP address outside 3..124
  DuplicateRx,     // manual §5.2.1: the later input slot wins, the earlier never receives
  DuplicateTx,     // docs/slots.md "Chk_Cfg slots": accepted, two slots send the same identifier
  InputCycle,      // docs/slots.md "Chk_Cfg slots": cycle bytes on an input slot are ignored
  Overlap,         // docs/modbus.md: PLC addresses overlap (one PLC image for all gateways)
  GsdEncoding,     // --gsd: the GSD encodes the parameters differently from the built-in encoding
  Line,            // docs/validate.md "The line": a line warning about this station, listed in its
                   // block too (counted once, in the line section)
};
std::string_view to_string(WarningKind k);  // "duplicate-rx", ...

struct Warning {
  WarningKind kind;
  std::string json_path;  // where in the configuration ("$.gateways[0].slots[2]")
  std::string message;
  bool error = false;  // a line error about the station (docs/validate.md "The watchdog rule")
};

// A station's warnings as its block lists them (text and --json): its own, then the line's
// about it (`line`, WarningKind::Line); the line's errors about it in the text only ("error: "),
// the JSON has them in the line's `problems`.
void format_warnings(std::ostream& os, const std::vector<Warning>& own,
                     const std::vector<Warning>& line);
nlohmann::ordered_json warnings_json(const std::vector<Warning>& own,
                                     const std::vector<Warning>& line);

}  // namespace candp2::validate
