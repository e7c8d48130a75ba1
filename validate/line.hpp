// The line in time for `candp2 validate` (docs/validate.md "The line", docs/profibus.md "The line
// in time"): the bus cycle a configuration will get, predicted from the same arithmetic the plant's
// timed line runs (profibus_sim/fdl/line_timing.hpp), and the line's checks: every station's GSD
// supports the baud rate and its MaxTsdr fits max_tsdr_bits, cycle_ms against the predicted cycle.
// The watchdogs' problems (the watchdog rule, profibus_sim/fdl/watchdog_rule.hpp) are added by the
// caller, which knows the daemon configuration, on the ideal line too. Pure: no files.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gsd/gsd.hpp"
#include "profibus_sim/fdl/line_timing.hpp"
#include "validate/warning.hpp"

namespace candp2::validate {

struct LineStation {
  std::string name;
  std::string json_path;  // "$.gateways[0]"
  std::uint8_t address = 0;
  std::size_t outputs = 0, inputs = 0;  // Data_Exchange bytes (the Chk_Cfg)
  const gsd::Model* gsd = nullptr;      // its GSD, when known
  std::string gsd_name;                 // for messages: "the GSD x.gsd"
  // Without a GSD: the latest it answers at the line's rate, when known otherwise (a CAN-DP/2's
  // own, gateway/line_limits.hpp).
  std::optional<std::uint32_t> max_tsdr_bits;
};

struct LineProblem {
  bool error = false;     // the line cannot work (an unsupported rate); else a warning
  std::string json_path;  // where in the configuration
  std::string message;
  std::string station;  // the json_path of the station it is about ("$.gateways[0]"), or ""
};

struct LineReport {
  std::optional<std::uint32_t> baud;  // none: the ideal line (its problems: the watchdogs')
  fdl::BusParameters params;
  std::uint32_t cycle_ms = 0;
  fdl::CyclePrediction cycle;
  std::vector<LineProblem> problems;
  std::size_t warnings() const;
  bool valid() const;
};

struct LineInput {
  std::uint32_t baud = 0;
  std::string baud_path = "$.master.baud";
  std::string bus_parameters_path = "$.master.bus_parameters";
  fdl::BusParameters params;
  std::uint8_t master_address = 1;
  std::uint32_t cycle_ms = 10;
  std::string cycle_path = "$.master.cycle_ms";
  std::vector<LineStation> stations;
};

LineReport check_line(const LineInput& in);

// The line's problems about the station at `station_path`, as the station's block lists them too
// (an error with Warning::error).
std::vector<Warning> station_warnings(const LineReport& r, const std::string& station_path);

}  // namespace candp2::validate
