// `candp2d --print-modbus-map` (docs/modbus.md): where each slot's bytes appear in the Modbus
// tables of a configuration, the unit IDs, the status block, the control and fault registers.
#pragma once

#include <string>

#include "config/config.hpp"

namespace candp2::modbus {

std::string map_text(const config::DaemonConfig& config);

}  // namespace candp2::modbus
