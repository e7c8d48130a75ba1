// `candp2d --print-modbus-map --json`: the Modbus/TCP map of a configuration as JSON, the one
// machine-readable source of every register number, value code and diagnosis bit that a client
// needs (docs/modbus.md "The map as JSON"). The candp2 Python package (python/, docs/python.md)
// reads it instead of carrying its own copy of the numbers.
//
// Built only from the constants and tables the server itself uses (modbus_map.hpp,
// faults/can_fault.hpp, faults/drive_fault.hpp, the DP diagnosis constants), so the printed map
// and the served map cannot disagree. Pure: a configuration in, text out.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "config/config.hpp"

namespace candp2::modbus {

// The whole map: the generic tables (image, status block, control and fault registers, drive
// fault registers, exceptions, value names, LED codes, diagnosis layout) and the configuration's
// gateways (unit IDs, slots with their PLC addresses and registers) and drives (unit IDs).
nlohmann::ordered_json map_json(const config::DaemonConfig& config);

// map_json() as indented text with a final newline.
std::string map_json_text(const config::DaemonConfig& config);

}  // namespace candp2::modbus
