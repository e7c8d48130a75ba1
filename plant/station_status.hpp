// A station's status (station/status.hpp) gathered from the plant: what every station shares
// (its DP address, the master's view of it, its line group, the master's missed cycles), what a
// local gateway adds (its counters, its CAN fault layer, its socketcand client), a remote
// station's and a generic slave's own. Every face reads stations through these: the Modbus face
// (modbus/plant_faces.hpp), the HTTP face (http/plant_sources.hpp) and replay's expect_counters.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "common/time.hpp"
#include "plant/plant.hpp"
#include "plant/slave_line.hpp"
#include "station/status.hpp"

namespace candp2::station {

// What every station's status shares (docs/modbus.md): its DP address, the master's view of it
// (state, parameterizations, addressed, Data_Exchanges), its line group (profibus role slaves: the
// FDL slave side; role master: the FDL master's figures) and the master's missed cycles.
Status common_status(plant::Plant& plant, std::uint8_t address);

// A local gateway's own part: its status (counters, states, its own Data_Exchanges), its CAN
// fault layer (docs/faults.md) and its socketcand client's reconnections. Not its diagnosis.
void add_gateway(Status& s, const plant::GatewayUnit& unit);

// The CAN bit rate group of local gateway `index` (the daemon's SocketCAN supervisor), if any.
using BitrateFn = std::function<std::optional<BitrateStatus>(std::size_t gateway)>;

// A local gateway's whole status: the common part, its own, its diagnosis' first 11 bytes and its
// bit rate group from `bitrate` (none when empty).
Status gateway_status(plant::Plant& plant, plant::GatewayUnit& unit, Time now,
                      const BitrateFn& bitrate = {});
// A remote station in profibus role master (docs/profibus.md): DP state and diagnosis as the master
// last read them, CAN fields 0.
Status remote_status(plant::Plant& plant, std::uint8_t address);
// A generic DP-V0 slave (docs/slaves.md "Modbus"): its DP state, the first 11 diagnosis bytes, no
// CAN-DP/2 front plate (LEDs 0), CAN fields 0.
Status slave_status(plant::Plant& plant, plant::SlaveUnit& unit, Time now);
// A generic slave's whole diagnosis: 6 standard bytes and the Ext_Diag_Data (docs/slaves.md
// "Diagnosis").
std::vector<std::uint8_t> slave_diagnosis(plant::SlaveUnit& unit, Time now);
// A local gateway's whole diagnosis: its Slave_Diag answer (docs/dp-slave.md "Diagnosis").
std::vector<std::uint8_t> gateway_diagnosis(plant::GatewayUnit& unit, Time now);

}  // namespace candp2::station
