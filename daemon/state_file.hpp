// The daemon's state file (docs/configuration.md `state_file`): the gateways' stored wake-up and
// SYNC values across restarts of candp2d (docs/dp-slave.md "User parameters"):
//   {"gateways": {"5": {"wakeup_s": 0, "sync_ms": 100}}}
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "common/log.hpp"
#include "plant/plant.hpp"

namespace candp2::daemon {

using StoredMap = std::map<std::uint8_t, plant::StoredValues>;

// Nothing stored yet: an empty map. An unreadable file is logged and ignored (the configured
// values are used).
StoredMap load_state(const std::string& path, const Logger& log);
// The folder of a file candp2d writes (the state file, the CAN log, the capture) exists, created
// with its parents when it can be, and is writable; else false with the reason. Under systemd the
// unit's StateDirectory/LogsDirectory exist already; started by hand they may not
// (docs/daemon.md "Started by hand").
bool prepare_folder_of(const std::string& path, std::string* why);
// Atomic: written to PATH.tmp, then renamed, so a crash never leaves half a file.
bool save_state(const std::string& path, const StoredMap& state, std::string* error);

}  // namespace candp2::daemon
