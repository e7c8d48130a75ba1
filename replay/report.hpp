// What `candp2 replay` writes: the readable report, JUnit XML for CI, the CAN traffic as a candump
// log. All three are pure functions of the scenario and its run (byte-identical every run).
#pragma once

#include <string>

#include "config/config.hpp"
#include "replay/runner.hpp"
#include "replay/scenario.hpp"

namespace candp2::replay {

struct ReportOptions {
  bool verbose = false;  // the log lines of each step under it
  bool traffic = false;  // every CAN frame under the step that saw it
};

std::string format_report(const Scenario& sc, const RunResult& r, const ReportOptions& o = {});
// JUnit XML: one testsuite per scenario, one testcase per expectation step.
std::string format_junit(const Scenario& sc, const RunResult& r);
// A scenario that could not be read, as a JUnit testsuite with one error.
std::string format_junit_error(const std::string& file, const config::ConfigError& e);
// candump -l lines "(0.040000) can0 201#0102..." with the virtual time as the time stamp.
std::string format_can_log(const RunResult& r, const std::string& interface);
// Every frame under its own bus's interface name (the SocketCAN interface, else the bus's
// exported name; version 1: the gateway's "bus", else "can0").
std::string format_can_log(const Scenario& sc, const RunResult& r);
std::string bus_interface(const Scenario& sc, std::size_t bus);
// The first bus's interface name (the only one of a version-1 scenario).
std::string log_interface(const Scenario& sc);

}  // namespace candp2::replay
