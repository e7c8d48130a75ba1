// The plant's control surface (docs/faults.md): every operator action, whether it comes over
// Modbus (modbus/plant_faces.hpp), from a replay step (replay/steps.cpp) or from the Python
// package through Modbus. Each is logged with its origin (`origin` ends the log line: "over
// Modbus", "by a replay step") and shown on the tap as a note. plant::Plant implements it
// (plant/control.cpp); a face that only acts needs no more of the plant than this.
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

#include "common/time.hpp"
#include "plant/can_fault.hpp"
#include "plant/line_fault.hpp"

namespace candp2::plant {

class GatewayUnit;
class SlaveUnit;
class DriveUnit;

class ControlSurface {
 public:
  virtual ~ControlSurface() = default;
  // Holding register 8193 semantics: 0 real state, 1 warning, 2 error-passive, 3 bus-off; false
  // (nothing changes) for other values.
  virtual bool force_can_state(GatewayUnit& g, std::uint16_t code, Time now,
                               std::string_view origin) = 0;
  virtual void drop_rx(GatewayUnit& g, std::uint32_t n, Time now, std::string_view origin) = 0;
  virtual void power_cycle(GatewayUnit& g, Time now, std::string_view origin) = 0;
  // The built-in master parameterizes the station at `address` again (a gateway, or a remote
  // station in role master). False when no built-in master drives it (role slaves: an external
  // master parameterizes; the reason is logged).
  virtual bool reparameterize(std::uint8_t address, Time now, std::string_view origin) = 0;
  // The master stops addressing the station (false) or addresses it again (true).
  virtual void set_addressed(std::uint8_t address, bool addressed, Time now,
                             std::string_view origin) = 0;
  // A drive's fault register (faults::kDriveMute .. kDriveRestart).
  virtual void set_drive_fault(DriveUnit& d, std::uint16_t index, std::uint16_t value, Time now,
                               std::string_view origin) = 0;
  // A generic slave's faults (docs/slaves.md "Faults"): it leaves the bus (no answer at all) or
  // comes back; a diagnosis alarm (a device-related Ext_Diag block; empty: cleared); a Prm or Cfg
  // fault forced (every Set_Prm / Chk_Cfg refused while on); a power cycle (back to Wait_Prm).
  virtual void set_slave_online(SlaveUnit& s, bool online, Time now, std::string_view origin) = 0;
  virtual bool set_slave_alarm(SlaveUnit& s, std::vector<std::uint8_t> bytes, Time now,
                               std::string_view origin) = 0;
  virtual void force_slave_fault(SlaveUnit& s, bool prm, bool on, Time now,
                                 std::string_view origin) = 0;
  virtual void power_cycle(SlaveUnit& s, Time now, std::string_view origin) = 0;
  // A note on the tap without any action (replay's "note" steps, the daemon's start and stop).
  virtual void note(std::string_view text, Time now) = 0;
  // Faults on cue on the line in time (docs/faults.md "Line faults"): a station's answers, or
  // noise on the whole line. False (the reason logged) without a timed line or such a station.
  virtual bool line_fault(const LineFault& fault, Time now, std::string_view origin) = 0;
  // Faults on cue on a CAN bus in time (docs/faults.md "CAN faults"): error frames, a node
  // unplugged or at a wrong bit rate, noise. False (the reason logged) without a timed bus or
  // such a node.
  virtual bool can_fault(const CanFault& fault, Time now, std::string_view origin) = 0;
};

}  // namespace candp2::plant
