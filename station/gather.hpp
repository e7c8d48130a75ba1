// A station's status (station/status.hpp) gathered from the plant: what every station shares
// (its DP address, the master's view of it, its line group, the master's missed cycles) and what
// a local gateway adds (its counters, its CAN fault layer, its socketcand client). The Modbus
// face (modbus/plant_faces.hpp) and replay's expect_counters read stations through these.
#pragma once

#include <cstdint>

#include "plant/plant.hpp"
#include "plant/slave_line.hpp"
#include "station/status.hpp"

namespace candp2::station {

// The line group from the plant's line figures.
Status::Line line_status(const plant::LineStatus& l);

// What every station's status shares (docs/modbus.md): its DP address, the master's view of it
// (state, parameterizations, addressed, Data_Exchanges), its line group (profibus role slaves: the
// FDL slave side; role master: the FDL master's figures) and the master's missed cycles.
Status common_status(plant::Plant& plant, std::uint8_t address);

// A local gateway's own part: its status (counters, states, its own Data_Exchanges), its CAN
// fault layer (docs/faults.md) and its socketcand client's reconnections. Not its diagnosis.
void add_gateway(Status& s, const plant::GatewayUnit& unit);

}  // namespace candp2::station
