#include "drive_sim/regid_protocol.hpp"

namespace candp2::drive {

std::string_view to_string(Reject r) {
  switch (r) {
    case Reject::Remote:
      return "remote frame (RTR is ignored, FW 378 §1)";
    case Reject::Extended:
      return "29-bit identifier (the REGID protocol uses 11-bit identifiers)";
    case Reject::BadDlc:
      return "DLC is neither 3 (16-bit command) nor 5..8 (32-bit command)";
  }
  return "?";
}

Decoded decode_command(const can::Frame& frame) {
  Decoded d;
  if (frame.remote) {
    d.reject = Reject::Remote;
    return d;
  }
  if (frame.extended) {
    d.reject = Reject::Extended;
    return d;
  }
  Command c;
  c.regid = frame.data[0];
  if (frame.dlc == kCommandDlc16) {
    c.data = static_cast<std::uint32_t>(frame.data[1]) | static_cast<std::uint32_t>(frame.data[2])
                                                             << 8;
    c.wide = false;
  } else if (frame.dlc >= kCommandDlc32 && frame.dlc <= can::kMaxDlc) {
    // German manual §5.1: longer packets are evaluated as 5-byte packets; bytes 5..7 are dropped.
    c.data = static_cast<std::uint32_t>(frame.data[1]) |
             static_cast<std::uint32_t>(frame.data[2]) << 8 |
             static_cast<std::uint32_t>(frame.data[3]) << 16 |
             static_cast<std::uint32_t>(frame.data[4]) << 24;
    c.wide = true;
  } else {
    d.reject = Reject::BadDlc;
    return d;
  }
  d.command = c;
  return d;
}

std::uint32_t value_for_register(const Command& command, Width width) {
  if (width == Width::W16) return command.data & 0xFFFFu;
  if (command.wide) return command.data;
  // FW 378 §1: "the value will be zero / sign extended as required" — sign extension throughout.
  return static_cast<std::uint32_t>(
      static_cast<std::int32_t>(static_cast<std::int16_t>(command.data & 0xFFFFu)));
}

can::Frame encode_reply(std::uint32_t tx_id, std::uint8_t regid, std::uint32_t value, Width width) {
  std::uint8_t bytes[kReplyDlc32] = {regid,
                                     static_cast<std::uint8_t>(value),
                                     static_cast<std::uint8_t>(value >> 8),
                                     kStuffByte,
                                     kStuffByte,
                                     kStuffByte};
  if (width == Width::W32) {
    bytes[3] = static_cast<std::uint8_t>(value >> 16);
    bytes[4] = static_cast<std::uint8_t>(value >> 24);
    return can::Frame::std_data(tx_id, {bytes, kReplyDlc32});
  }
  return can::Frame::std_data(tx_id, {bytes, kReplyDlc16});
}

bool is_well_formed_reply(const can::Frame& frame) {
  if (frame.extended || frame.remote || frame.id > can::kMaxStdId) return false;
  if (frame.dlc != kReplyDlc16 && frame.dlc != kReplyDlc32) return false;
  if (frame.data[frame.dlc - 1] != kStuffByte) return false;
  for (std::size_t i = frame.dlc; i < frame.data.size(); ++i)
    if (frame.data[i] != 0) return false;
  return true;
}

}  // namespace candp2::drive
