// pcapng blocks (draft-ietf-opsawg-pcapng: §4.1 Section Header Block, §4.2 Interface
// Description Block, §4.3 Enhanced Packet Block, §3.5 options).
#include "capture/pcapng.hpp"

#include <algorithm>
#include <array>

namespace candp2::capture::pcapng {

namespace {

void le16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v));
  out.push_back(static_cast<std::uint8_t>(v >> 8));
}
void le32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void be16(std::vector<std::uint8_t>& out, std::uint16_t v) {
  out.push_back(static_cast<std::uint8_t>(v >> 8));
  out.push_back(static_cast<std::uint8_t>(v));
}
void put_le32(std::vector<std::uint8_t>& out, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void pad4(std::vector<std::uint8_t>& out, std::size_t from) {
  while ((out.size() - from) % 4) out.push_back(0);
}

// Options carry at most 65535 value bytes; a longer text is cut (comments, names).
constexpr std::size_t kMaxOptionLen = 0xFFF0;

void option(std::vector<std::uint8_t>& out, std::uint16_t code, std::span<const std::uint8_t> v) {
  const std::size_t n = std::min(v.size(), kMaxOptionLen);
  le16(out, code);
  le16(out, static_cast<std::uint16_t>(n));
  const std::size_t start = out.size();
  out.insert(out.end(), v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n));
  pad4(out, start);
}
void option(std::vector<std::uint8_t>& out, std::uint16_t code, std::string_view text) {
  option(out, code, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}
void end_of_options(std::vector<std::uint8_t>& out) {
  le16(out, kOptEndOfOpt);
  le16(out, 0);
}

// Block Type, Block Total Length (patched by close_block), body, Block Total Length.
std::size_t open_block(std::vector<std::uint8_t>& out, std::uint32_t type) {
  const std::size_t start = out.size();
  le32(out, type);
  le32(out, 0);
  return start;
}
void close_block(std::vector<std::uint8_t>& out, std::size_t start) {
  pad4(out, start);
  const auto total = static_cast<std::uint32_t>(out.size() - start + 4);
  le32(out, total);
  put_le32(out, start + 4, total);
}

}  // namespace

std::vector<std::uint8_t> section_header(std::string_view application, std::string_view os) {
  std::vector<std::uint8_t> out;
  const std::size_t b = open_block(out, kSectionHeaderBlock);
  le32(out, kByteOrderMagic);
  le16(out, 1);                                     // major version
  le16(out, 0);                                     // minor version
  for (int i = 0; i < 8; ++i) out.push_back(0xFF);  // section length -1: not given
  if (!os.empty()) option(out, kShbOs, os);
  if (!application.empty()) option(out, kShbUserAppl, application);
  end_of_options(out);
  close_block(out, b);
  return out;
}

std::vector<std::uint8_t> interface_description(std::uint16_t linktype, std::string_view name,
                                                std::string_view description, std::uint64_t speed) {
  std::vector<std::uint8_t> out;
  const std::size_t b = open_block(out, kInterfaceDescriptionBlock);
  le16(out, linktype);
  le16(out, 0);  // reserved
  le32(out, 0);  // snaplen: no limit
  if (!name.empty()) option(out, kIfName, name);
  if (!description.empty()) option(out, kIfDescription, description);
  if (speed != 0) {
    std::array<std::uint8_t, 8> v{};
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<std::uint8_t>(speed >> (8 * i));
    option(out, kIfSpeed, v);
  }
  const std::uint8_t tsresol = 9;  // 10^-9 s
  option(out, kIfTsresol, std::span(&tsresol, 1));
  end_of_options(out);
  close_block(out, b);
  return out;
}

void enhanced_packet(std::vector<std::uint8_t>& out, std::uint32_t interface_id,
                     std::uint64_t time_ns, std::span<const std::uint8_t> data, Direction direction,
                     std::string_view comment) {
  const std::size_t b = open_block(out, kEnhancedPacketBlock);
  le32(out, interface_id);
  le32(out, static_cast<std::uint32_t>(time_ns >> 32));
  le32(out, static_cast<std::uint32_t>(time_ns));
  le32(out, static_cast<std::uint32_t>(data.size()));  // captured length
  le32(out, static_cast<std::uint32_t>(data.size()));  // original length
  const std::size_t at = out.size();
  out.insert(out.end(), data.begin(), data.end());
  pad4(out, at);
  if (!comment.empty()) option(out, kOptComment, comment);
  if (direction != Direction::Unknown) {
    std::vector<std::uint8_t> flags;
    le32(flags, static_cast<std::uint32_t>(direction));
    option(out, kEpbFlags, flags);
  }
  if (!comment.empty() || direction != Direction::Unknown) end_of_options(out);
  close_block(out, b);
}

std::array<std::uint8_t, kSocketcanLen> socketcan(const can::Frame& frame) {
  std::array<std::uint8_t, kSocketcanLen> out{};
  std::uint32_t id = frame.id;
  if (frame.extended) id |= kCanEffFlag;
  if (frame.remote) id |= kCanRtrFlag;
  for (int i = 0; i < 4; ++i) out[i] = static_cast<std::uint8_t>(id >> (24 - 8 * i));
  out[4] = std::min<std::uint8_t>(frame.dlc, 8);
  if (!frame.remote) std::copy_n(frame.data.begin(), out[4], out.begin() + 8);
  return out;
}

// linux/can/error.h: an ACK error (CAN_ERR_ACK, on transmission, location ACK slot); a sender at a
// wrong bit rate breaks the stuffing rule near the start of frame (CAN_ERR_PROT, stuff error); an
// error on cue (noise) seen at the CRC (CAN_ERR_PROT, bit error, CRC sequence). A change of state:
// bus-off (CAN_ERR_BUSOFF), its recovery (CAN_ERR_RESTARTED and active), warning and passive on the
// counter that passed the limit (CAN_ERR_CRTL), back to error active (CAN_ERR_CRTL_ACTIVE).
// The counters in data[6..7] as drivers give them (without CAN_ERR_CNT, which Wireshark 4.0 calls
// reserved).
std::array<std::uint8_t, kSocketcanLen> socketcan_error(const can::BusError& e) {
  using Error = can::TimedBus::Error;
  std::array<std::uint8_t, kSocketcanLen> out{};
  std::array<std::uint8_t, 8> data{};
  std::uint32_t id = kCanErrFlag;
  switch (e.error) {
    case Error::Ack:
      id |= kCanErrAck | kCanErrProt;
      data[2] = kCanErrProtTx;  // the transmitter sees it
      data[3] = kCanErrProtLocAck;
      break;
    case Error::WrongBitrate:
      id |= kCanErrProt;
      data[2] = kCanErrProtStuff;
      data[3] = kCanErrProtLocSof;
      break;
    case Error::Injected:
      id |= kCanErrProt;
      data[2] = kCanErrProtBit;
      data[3] = kCanErrProtLocCrcSeq;
      break;
    case Error::None: {
      const bool tx = e.tec >= e.rec;
      switch (e.state) {
        case can::BusState::BusOff:
          id |= kCanErrBusoff;
          break;
        case can::BusState::ErrorPassive:
          id |= kCanErrCrtl;
          data[1] = tx ? kCanErrCrtlTxPassive : kCanErrCrtlRxPassive;
          break;
        case can::BusState::Warning:
          id |= kCanErrCrtl;
          data[1] = tx ? kCanErrCrtlTxWarning : kCanErrCrtlRxWarning;
          break;
        case can::BusState::Ok:
          id |= kCanErrCrtl | (e.recovered ? kCanErrRestarted : 0);
          data[1] = kCanErrCrtlActive;
          break;
      }
      break;
    }
  }
  data[6] = static_cast<std::uint8_t>(std::min<std::uint32_t>(e.tec, 255));
  data[7] = static_cast<std::uint8_t>(std::min<std::uint32_t>(e.rec, 255));
  for (int i = 0; i < 4; ++i) out[i] = static_cast<std::uint8_t>(id >> (24 - 8 * i));
  out[4] = 8;
  std::copy(data.begin(), data.end(), out.begin() + 8);
  return out;
}

void exported_pdu(std::vector<std::uint8_t>& out, std::string_view dissector,
                  std::span<const std::uint8_t> pdu, std::string_view protocol_column) {
  // Each tag: type and length big-endian, the value padded with zero bytes to 4 (the padding
  // counts in the length; readers strip trailing zero bytes of strings).
  auto tag = [&](std::uint16_t type, std::string_view value) {
    const std::size_t padded = (value.size() + 3) / 4 * 4;
    be16(out, type);
    be16(out, static_cast<std::uint16_t>(padded));
    out.insert(out.end(), value.begin(), value.end());
    out.insert(out.end(), padded - value.size(), 0);
  };
  tag(kExpPduDissectorName, dissector);
  if (!protocol_column.empty()) tag(kExpPduColProtText, protocol_column);
  be16(out, kExpPduEndOfOpt);
  be16(out, 0);
  out.insert(out.end(), pdu.begin(), pdu.end());
}

}  // namespace candp2::capture::pcapng
