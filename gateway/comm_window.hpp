// The Communication Window (manual §5.3, docs/communication-window.md): 16 output bytes carry a
// command from the PLC, 16 input bytes carry the acknowledge and received frames; a 255-frame
// receive FIFO for the identifiers enabled with command 4. Pure; the Gateway feeds it once per
// Data_Exchange.
//
// Wire formats: CwRequest is the window the PLC writes (manual table 5.3.1), CwReply the window it
// reads (manual table 5.3.2). Both have a pure decode and encode; CommWindow is the state machine.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "can/frame.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "gateway/tx_port.hpp"

namespace candp2::gw {

inline constexpr std::size_t kCwLen = 16;            // manual §5.3.1: always 16 bytes
inline constexpr std::size_t kCwFifoCapacity = 255;  // manual §5.3.3.2 command 3: 255 CAN frames

// Byte positions, both directions (manual tables 5.3.1 and 5.3.2).
inline constexpr std::size_t kCwIdent = 0;        // bytes 0..3: identifier
                                                  // (docs/communication-window.md)
inline constexpr std::size_t kCwData = 4;         // bytes 4..11: data bytes 0..7
inline constexpr std::size_t kCwLength = 12;      // Tx data length / number of received bytes
inline constexpr std::size_t kCwCounter = 13;     // PLC loop counter / its echo
inline constexpr std::size_t kCwSubCommand = 14;  // sub-command / its echo
inline constexpr std::size_t kCwCommand = 15;     // write: command
inline constexpr std::size_t kCwError = 15;       // read: error code (docs/communication-window.md)

inline constexpr std::uint8_t kCwNoFrame = 0xEE;     // manual §5.3.3.2: 'EEEE' while no data
inline constexpr std::uint8_t kCwIdExtended = 0x20;  // byte 2 bit 5 flags a 29-bit id
                                                     // (docs/communication-window.md)

// Commands (manual table 5.4.3; 0 = no-op, docs/communication-window.md).
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

// Byte 15 of the read window (docs/communication-window.md; the manual leaves it "not supported
// yet").
enum CwError : std::uint8_t {
  kCwOk = 0,
  kCwErrLength = 1,           // data length > 8
  kCwErrIdentifier = 2,       // bytes 0..3 are no valid 11- or 29-bit identifier
  kCwErrCommand = 3,          // unknown command
  kCwErrSyncUnavailable = 4,  // command 20 while not CANopen master
  kCwErrNotReleased = 5,      // CAN transmission not yet released (wake-up, pre-operational)
};
std::string_view cw_error_text(std::uint8_t error);

// Identifier in window bytes 0..3 (docs/communication-window.md). 11-bit: id >> 8, id & 0xFF, 0, 0.
// 29-bit: (id >> 8) & 0xFF, id & 0xFF, 0x20 | (id >> 24), (id >> 16) & 0xFF.
void cw_encode_ident(const can::Ident& id, std::span<std::uint8_t> bytes4);
// nullopt for byte 2 bits 7-6 set, an 11-bit value above 0x7FF, or a byte 3 without the 29-bit
// flag.
std::optional<can::Ident> cw_decode_ident(std::span<const std::uint8_t> bytes4);

// The window the PLC writes (manual table 5.3.1). Identifier bytes are kept raw: whether they
// matter, and so whether a bad encoding is an error, depends on the command.
struct CwRequest {
  std::array<std::uint8_t, 4> ident{};
  std::array<std::uint8_t, 8> data{};
  std::uint8_t length = 0;  // byte 12
  std::uint8_t counter = 0;
  std::uint8_t sub_command = 0;
  std::uint8_t command = kCwNop;

  std::optional<can::Ident> identifier() const { return cw_decode_ident(ident); }
  void set_identifier(const can::Ident& id) { cw_encode_ident(id, ident); }
  // Command 20: SYNC time from data bytes 0-1, big-endian ms (docs/communication-window.md, manual
  // §8.2 FB4).
  std::uint16_t sync_ms() const { return static_cast<std::uint16_t>((data[0] << 8) | data[1]); }

  friend bool operator==(const CwRequest&, const CwRequest&) = default;
};

CwRequest decode_cw_request(std::span<const std::uint8_t, kCwLen> window);
std::array<std::uint8_t, kCwLen> encode_cw_request(const CwRequest& request);

// The window the PLC reads (manual table 5.3.2).
struct CwReply {
  std::optional<can::Frame> frame;  // nullopt: EE EE 00 00, data 0, length 0
  std::uint8_t counter = 0;         // echo of the loop counter of the last executed command
  std::uint8_t sub_command = 0;     // echo of its sub-command
  std::uint8_t error = kCwOk;

  friend bool operator==(const CwReply&, const CwReply&) = default;
};

std::array<std::uint8_t, kCwLen> encode_cw_reply(const CwReply& reply);
// nullopt when the bytes cannot come from a gateway (bad identifier encoding, length > 8, data past
// the length not zero, or EE EE with non-zero frame bytes).
std::optional<CwReply> decode_cw_reply(std::span<const std::uint8_t, kCwLen> window);

// The receive FIFO (manual §5.3.3.2 command 3): a fixed ring of 255 frames, no allocation.
class CwFifo {
 public:
  // false (and nothing stored) when full: the caller counts MSG_LOST.
  bool push(const can::Frame& frame) {
    if (size_ == kCwFifoCapacity) return false;
    std::size_t tail = head_ + size_;
    if (tail >= kCwFifoCapacity) tail -= kCwFifoCapacity;
    buf_[tail] = frame;
    ++size_;
    return true;
  }
  std::optional<can::Frame> pop() {
    if (size_ == 0) return std::nullopt;
    const can::Frame f = buf_[head_];
    if (++head_ == kCwFifoCapacity) head_ = 0;
    --size_;
    return f;
  }
  void clear() { head_ = size_ = 0; }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  bool full() const { return size_ == kCwFifoCapacity; }
  static constexpr std::size_t capacity() { return kCwFifoCapacity; }

 private:
  std::array<can::Frame, kCwFifoCapacity> buf_{};
  std::size_t head_ = 0;
  std::size_t size_ = 0;
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
  CommWindow() { reset(); }
  explicit CommWindow(Logger log) : log_(std::move(log)) { reset(); }
  void set_logger(Logger log) { log_ = std::move(log); }

  // Power-on state: nothing enabled, FIFO empty, counters 0, read window EE EE.
  void reset();
  // The 16 bytes the PLC wrote in this Data_Exchange. A command runs once per loop-counter change.
  void on_write(std::span<const std::uint8_t> window, Time now, CwHost& host);
  // The 16 bytes the PLC reads.
  void read(std::span<std::uint8_t> window) const;
  // A received frame: true when its identifier is enabled (it then takes precedence over slots,
  // docs/slots.md "Data exchange in normal mode"), also when the FIFO was full and the frame was
  // dropped.
  bool on_frame(const can::Frame& frame);

  const CwReply& reply() const { return reply_; }
  std::uint32_t msg_lost() const { return msg_lost_; }
  std::size_t fifo_level() const { return fifo_.size(); }
  std::size_t fifo_high_water() const { return fifo_high_water_; }
  bool read_armed() const { return armed_; }
  bool is_enabled(const can::Ident& id) const;
  std::size_t enabled_count() const { return enabled_.size(); }
  std::vector<can::Ident> enabled() const;

 private:
  std::uint8_t execute(const CwRequest& req, Time now, CwHost& host);
  std::uint8_t fail(const CwRequest& req, std::uint8_t error, std::string_view why) const;
  void enable(const can::Ident& id);
  void disable(const can::Ident& id);
  void deliver(const can::Frame& frame);

  Logger log_;
  CwReply reply_;
  std::array<std::uint8_t, kCwLen> read_{};  // encode_cw_reply(reply_)
  std::uint8_t last_counter_ = 0;            // docs/communication-window.md: initially 0
  bool armed_ = false;                       // command 3 waiting for a frame
  bool dropping_ = false;                    // within a run of MSG_LOST drops (logs once per run)
  std::vector<std::uint32_t> enabled_;       // ident keys (tx_port.hpp), sorted
  CwFifo fifo_;
  std::size_t fifo_high_water_ = 0;
  std::uint32_t msg_lost_ = 0;
};

}  // namespace candp2::gw
