// Every station's watchdog of a daemon configuration against the one watchdog rule
// (profibus_sim/fdl/watchdog_rule.hpp, docs/validate.md "The watchdog rule"): the findings
// candp2d warns about (--check and at start) and `candp2 validate` lists, in the same words.
#pragma once

#include <string>
#include <vector>

#include "config/config.hpp"
#include "profibus_sim/fdl/watchdog_rule.hpp"

namespace candp2::config {

// The line as the rule sees it: $.master.baud's line in time, else the ideal line (with a
// profibus line in role master too: the real line is not predicted); the master cycle late by up
// to host_stall_ms (candp2d's guard; nothing bounds it with a profibus line). Stations: the
// gateways, then the generic slaves.
fdl::WatchdogLine watchdog_line(const DaemonConfig& c);

struct WatchdogProblem {
  std::string station;    // "$.gateways[0]"
  std::string json_path;  // where the watchdog is set: "$.gateways[0].parameters.watchdog_ms"
  fdl::WatchdogVerdict verdict = fdl::WatchdogVerdict::WillExpire;
  std::string message;
};
// Every watchdog that does not hold; none with a profibus line in role slaves (the foreign
// master's cycle is not known here).
std::vector<WatchdogProblem> check_watchdogs(const DaemonConfig& c);

}  // namespace candp2::config
