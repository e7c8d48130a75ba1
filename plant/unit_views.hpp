// What the faces read of the plant's units beyond a station's status (docs/architecture.md "One
// vocabulary"): plain views of a gateway, a drive and a generic slave, built by the units
// (GatewayUnit::view(), DriveUnit::status(), SlaveUnit::view(), plant/unit_views.cpp), so that no
// face reaches an engine.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "drive_sim/unitek_drive.hpp"  // drive::ControlMode
#include "gateway/gateway.hpp"
#include "gsd_slave/gsd_slave.hpp"

namespace candp2::plant {

// What a face shows of a gateway beyond its station::Status (docs/architecture.md "One
// vocabulary"): plain data read through its unit, not the engine. The references are the engine's
// own data, valid until the plant next runs.
struct GatewayView {
  using SlotStats = gw::SlotEngine::SlotStats;  // one slot's frames and when it last had one
  std::uint8_t address = 0;                     // its DP address
  // Set_Prm user parameters (manual §5.1.2): the accepted ones (`accepted`), else the configured.
  bool accepted = false;
  const gw::UserPrm& parameters;
  const std::optional<gw::SlotConfig>& slot_config;  // from Chk_Cfg; none before
  gw::PageMode::State page_state = gw::PageMode::State::WaitInit;
  std::uint64_t pages_processed = 0;
  std::span<const SlotStats> slot_stats;  // by slot index
};

// What a face shows of a drive (docs/daemon.md "HTTP face"): read through its unit, not the
// engine.
struct DriveStatus {
  bool enabled = false;
  drive::ControlMode mode = drive::ControlMode::Speed;
  std::int16_t speed = 0;     // actual speed
  std::int32_t position = 0;  // actual position
  std::uint32_t status = 0;   // the status register
};

// What a face shows of a generic slave beyond its station::Status (docs/slaves.md "Front panel
// and HTTP API"): plain data read through its unit, not the engine. The references and spans
// are the slave's own data, valid until the plant next runs.
struct SlaveView {
  std::uint8_t address = 0;  // its DP address
  const gsd_slave::Profile& profile;
  const gsd_slave::Configuration& configuration;
  dp::SlaveState dp_state = dp::SlaveState::WaitPrm;
  // Its faults (docs/slaves.md "Faults"): on the bus, the forced ones, the device's alarm.
  bool online = false;
  bool prm_fault_forced = false;
  bool cfg_fault_forced = false;
  const std::optional<std::vector<std::uint8_t>>& device_diagnosis;
  const std::string& prm_problem;  // why the last Set_Prm was refused; empty: it was not
  const std::string& cfg_problem;  // likewise Chk_Cfg
  std::size_t input_length = 0;
  std::size_t output_length = 0;
  // The field side (docs/slaves.md "Field side") and the master's last outputs as on the wire.
  std::span<const std::uint8_t> field_inputs;
  std::span<const std::uint8_t> field_outputs;
  std::span<const std::uint8_t> received_outputs;
};

}  // namespace candp2::plant
