// The Unitek REGID wire format (Unitek CAN-BUS manual V1 1011, "CAN Format" and "DLC-Bits"; the
// short description FW 378 §1-§3; German manual §5.1, §5.5, §5.6). Pure functions, no state.
//
//   command (master -> drive, on the drive's Rx ID):  REGID d0 d1            DLC 3, 16-bit data
//                                                      REGID d0 d1 d2 d3      DLC 5, 32-bit data
//   reply   (drive -> master, on the drive's Tx ID):  REGID d0 d1 00         DLC 4
//                                                      REGID d0 d1 d2 d3 00   DLC 6
// Data is little-endian. Replies end with one stuff byte, 0x00 in this product (CAN manual examples
// 11 and 12 print it as 00).
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "can/frame.hpp"
#include "drive_sim/registers.hpp"

namespace candp2::drive {

// CAN manual "DLC-Bits": receive 3 (REGID + 16 bit) or 5 (REGID + 32 bit); German manual §5.1:
// "up to 8-byte packets can be received, they are evaluated as 5-byte packets".
inline constexpr std::uint8_t kCommandDlc16 = 3;
inline constexpr std::uint8_t kCommandDlc32 = 5;
// CAN manual "DLC-Bits": transmit 4 (REGID + 16 bit + dummy) or 6 (REGID + 32 bit + dummy).
inline constexpr std::uint8_t kReplyDlc16 = 4;
inline constexpr std::uint8_t kReplyDlc32 = 6;
inline constexpr std::uint8_t kStuffByte = 0x00;

// The READ command 0x3D: data byte 0 is the REGID to send, data byte 1 the time (CAN manual
// example 10; FW 378 §8: 0x00 once/immediately, 1..254 ms cyclic, 0xFF suspend).
inline constexpr std::uint8_t kReadOnce = 0x00;
inline constexpr std::uint8_t kReadStop = 0xFF;

struct Command {
  std::uint8_t regid = 0;
  std::uint32_t data = 0;  // little-endian data bytes as received (16 or 32 significant bits)
  bool wide = false;       // 32-bit command (DLC 5..8) rather than 16-bit (DLC 3)
  std::uint8_t byte(int i) const { return static_cast<std::uint8_t>(data >> (8 * i)); }
};

// Why a frame on the drive's Rx ID was not a command. Such frames get no reply.
enum class Reject : std::uint8_t { Remote, Extended, BadDlc };
std::string_view to_string(Reject r);

struct Decoded {
  std::optional<Command> command;
  Reject reject = Reject::BadDlc;  // meaningful when !command
};

// Decodes a frame already known to be addressed to the drive (identifier matched by the caller).
// RTR frames are ignored (FW 378 §1); DLC 0, 1, 2 and 4 carry neither a 16- nor a 32-bit value.
Decoded decode_command(const can::Frame& frame);

// The value a command stores into a register of the given width (FW 378 §1): 16-bit data into a
// 32-bit register is sign-extended; 32-bit data into a 16-bit register loses its upper half.
std::uint32_t value_for_register(const Command& command, Width width);

// A reply frame: REGID, the value's 2 or 4 little-endian bytes, the stuff byte.
can::Frame encode_reply(std::uint32_t tx_id, std::uint8_t regid, std::uint32_t value, Width width);

// True when `frame` has the shape of a drive reply: 11-bit data frame, DLC 4 or 6, stuff byte 0x00.
bool is_well_formed_reply(const can::Frame& frame);

}  // namespace candp2::drive
