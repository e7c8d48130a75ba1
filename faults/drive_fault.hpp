// A simulated Unitek drive with its injected faults (docs/faults.md): it can stop
// answering, carry error and warning bits in ERR_BITMAP1 (REGID 0x8F) and restart. One
// implementation for the daemon's Modbus drive registers (modbus/modbus_map.hpp, DriveFace) and
// the replay steps drive_mute / drive_error_bits / drive_warning_bits / drive_restart
// (docs/replay-format.md).
// Pure: frames through a can::FrameSink, time passed in; the caller owns the bus and the clock.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "can/channel.hpp"
#include "can/frame.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "drive_sim/parameter_store.hpp"
#include "drive_sim/unitek_drive.hpp"

namespace candp2::faults {

// The drive's Modbus holding registers (docs/faults.md): 0 mute, 1 error bits, 2 warning bits,
// 3 restart.
inline constexpr std::uint16_t kDriveMute = 0;
inline constexpr std::uint16_t kDriveErrorBits = 1;
inline constexpr std::uint16_t kDriveWarningBits = 2;
inline constexpr std::uint16_t kDriveRestart = 3;

class FaultyDrive {
 public:
  // Throws std::invalid_argument as drive::UnitekDrive does. `store` may be null.
  FaultyDrive(drive::UnitekDrive::Options options, LogSink* log = nullptr,
              drive::ParameterStore* store = nullptr);

  // The drive engine; the same object across restarts (pointers to it stay valid).
  drive::UnitekDrive& drive() { return *drive_; }
  const drive::UnitekDrive& drive() const { return *drive_; }

  // The bus side. A muted drive ignores frames and sends nothing (no cyclic transmissions).
  void on_frame(const can::Frame& frame, Time now, can::FrameSink& out);
  void advance(Time now, can::FrameSink& out);
  std::optional<Time> next_deadline() const;

  // Faults. `origin` ends the log line ("requested over Modbus", "replay step").
  // Muted, the drive neither receives nor sends; its time runs on (the motor model, the cyclic
  // transmissions' schedule), so answering again does not send the replies missed meanwhile.
  void set_muted(bool muted, Time now, can::FrameSink& out, std::string_view origin);
  // ERR_BITMAP1 0x8F: errors in bits 0..15, warnings in bits 16..31. Any bit drops ready (0xE2)
  // and disables the drive; REGID 0x8E (FUN_ERRCANCEL) clears them as on the real drive.
  void set_error_bits(std::uint16_t bits, Time now, can::FrameSink& out);
  void set_warning_bits(std::uint16_t bits, Time now, can::FrameSink& out);
  // The power-on state: stored parameters reloaded, cyclic requests (0x3D with a time) lost,
  // error and warning bits 0, not muted. The Unitek manuals define no boot message; none is sent.
  void restart(std::string_view origin);

  bool muted() const { return muted_; }
  std::uint16_t error_bits() const { return errors_; }
  std::uint16_t warning_bits() const { return warnings_; }

  // The Modbus holding registers 0..3 (reads of 3 give 0; writes to 3 other than 1 do nothing).
  std::uint16_t fault_register(std::uint16_t index) const;
  void set_fault_register(std::uint16_t index, std::uint16_t value, Time now, can::FrameSink& out,
                          std::string_view origin);

 private:
  drive::UnitekDrive::Options options_;
  LogSink* log_sink_;
  drive::ParameterStore* store_;
  std::optional<drive::UnitekDrive> drive_;
  bool muted_ = false;
  std::uint16_t errors_ = 0, warnings_ = 0;
};

}  // namespace candp2::faults
