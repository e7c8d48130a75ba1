// The Communication Window (manual §5.3, emulator-spec §5): 16 output bytes carry a command from
// the PLC, 16 input bytes carry the acknowledge and received frames; a 255-frame receive FIFO for
// the identifiers enabled with command 4. Pure; the Gateway feeds it once per Data_Exchange.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <optional>
#include <span>
#include <vector>

#include "common/time.hpp"
#include "gateway/tx_port.hpp"

namespace candp2::gw {

inline constexpr std::size_t kCwLen = 16;            // manual §5.3.1
inline constexpr std::size_t kCwFifoCapacity = 255;  // manual §5.3.3.2 command 3

// Commands (manual table 5.4.3).
enum CwCommand : std::uint8_t {
  kCwNop = 0,
  kCwSend = 1,
  kCwRead = 3,
  kCwEnable = 4,
  kCwDisable = 5,
  kCwSendRtr = 6,
  kCwEnableAndRtr = 7,
  kCwSyncTime = 20,
};

// Byte 15 of the read window (emulator-spec §5).
enum CwError : std::uint8_t {
  kCwOk = 0,
  kCwErrLength = 1,
  kCwErrIdentifier = 2,
  kCwErrCommand = 3,
  kCwErrSyncUnavailable = 4,
  kCwErrNotReleased = 5,
};

// What the window needs from the gateway besides sending frames.
class CwHost : public TxPort {
 public:
  virtual bool can_released() const = 0;  // error 5 when not
  // Command 20; false when the gateway is not a CANopen master (error 4).
  virtual bool set_sync_time(std::uint16_t ms, Time now) = 0;
};

class CommWindow {
 public:
  void reset();
  // The 16 bytes the PLC wrote in this Data_Exchange. A command runs once per loop-counter change.
  void on_write(std::span<const std::uint8_t> window, Time now, CwHost& host);
  // The 16 bytes the PLC reads.
  void read(std::span<std::uint8_t> window) const;
  // A received frame: true when its identifier is enabled (it then takes precedence over slots).
  bool on_frame(const can::Frame& frame);

  std::uint32_t msg_lost() const { return msg_lost_; }
  std::size_t fifo_level() const { return fifo_.size(); }
  std::size_t fifo_high_water() const { return fifo_high_water_; }
  bool is_enabled(const can::Ident& id) const;
  std::size_t enabled_count() const { return enabled_.size(); }

 private:
  std::array<std::uint8_t, kCwLen> read_{};
  std::uint8_t last_counter_ = 0;
  bool armed_ = false;                  // command 3 waiting for a frame
  std::vector<std::uint32_t> enabled_;  // ident keys
  std::deque<can::Frame> fifo_;
  std::size_t fifo_high_water_ = 0;
  std::uint32_t msg_lost_ = 0;
};

// Identifier in window bytes 0..3 (emulator-spec §5).
void cw_encode_ident(const can::Ident& id, std::span<std::uint8_t> bytes4);
std::optional<can::Ident> cw_decode_ident(std::span<const std::uint8_t> bytes4);

}  // namespace candp2::gw
