// Runs a replay scenario in virtual time: the scenario's installation assembled as candp2d
// assembles it (plant::Plant: gateways behind their fault layers, drives, the DP master with the
// PLC process image), the optional Page-Mode driver (plc::PageDriver) and, on every bus, a node
// that injects the scenario's frames. No clock, no threads, no randomness: the same scenario gives
// the same result every run.
//
// Time model: the master cycles at 0, cycle, 2 × cycle, ... (the PLC program scans, then the
// Data_Exchange); the gateway's own timers fire at the times it announces; CAN frames are
// delivered at once. Advancing to time T runs every event at or before T; a step then runs at T.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "can/frame.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "replay/scenario.hpp"

namespace candp2::replay {

struct StepResult {
  std::size_t index = 0;  // 1-based step number
  const Step* step = nullptr;
  bool expectation = false;
  bool passed = true;
  std::string detail;  // what was seen (failures say why)
  Time start{0}, end{0};
  std::size_t log_begin = 0, log_end = 0;  // log lines written while the step ran
};

struct Traffic {
  Time time{0};
  can::Frame frame;
  bool from_gateway = false;
  std::string gateway;  // the gateway that sent it (from_gateway)
  std::string drive;  // the simulated drive that sent it; empty for the gateway and injected frames
  std::size_t bus = 0;  // index into the installation's buses
};

struct LogEntry {
  Time time{0};
  LogLevel level = LogLevel::Info;
  std::string component;
  std::string message;
};

struct RunResult {
  std::vector<StepResult> steps;
  std::vector<Traffic> traffic;
  std::vector<LogEntry> log;
  Time end{0};
  std::size_t expectations() const;
  std::size_t failures() const;
  bool passed() const { return failures() == 0; }
};

// Log lines below `level` are not recorded.
RunResult run(const Scenario& scenario, LogLevel level = LogLevel::Info);

}  // namespace candp2::replay
