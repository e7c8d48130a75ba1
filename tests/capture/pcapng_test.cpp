// pcapng blocks and payloads (capture/pcapng.hpp) byte for byte, against the layouts of
// draft-ietf-opsawg-pcapng (§4.1 SHB, §4.2 IDB, §4.3 EPB), LINKTYPE_CAN_SOCKETCAN and Wireshark's
// exported-PDU tags.
#include "capture/pcapng.hpp"

#include <gtest/gtest.h>

#include "common/hex.hpp"

namespace candp2::capture::pcapng {
namespace {

std::string H(std::span<const std::uint8_t> b) {
  return hex_bytes(b);
}
std::uint32_t le32_at(const std::vector<std::uint8_t>& b, std::size_t at) {
  return b[at] | (b[at + 1] << 8) | (b[at + 2] << 16) | (std::uint32_t{b[at + 3]} << 24);
}
std::span<const std::uint8_t> text(std::string_view s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

TEST(Pcapng, SectionHeader) {
  const auto b = section_header("candp2");
  // type, length 44, magic, version 1.0, section length -1, shb_userappl "candp2" (padded to 8),
  // end of options, length again.
  EXPECT_EQ(H(b),
            "0A 0D 0D 0A 2C 00 00 00 4D 3C 2B 1A 01 00 00 00 FF FF FF FF FF FF FF FF "
            "04 00 06 00 63 61 6E 64 70 32 00 00 00 00 00 00 2C 00 00 00");
}

TEST(Pcapng, InterfaceDescriptionWithNameAndNanoseconds) {
  const auto b = interface_description(kLinktypeCanSocketcan, "can0");
  // type 1, length 40, linktype 227, reserved, snaplen 0, if_name "can0", if_tsresol 9 (padded),
  // end of options, length.
  EXPECT_EQ(H(b),
            "01 00 00 00 28 00 00 00 E3 00 00 00 00 00 00 00 02 00 04 00 63 61 6E 30 "
            "09 00 01 00 09 00 00 00 00 00 00 00 28 00 00 00");
  const auto d = interface_description(kLinktypeWiresharkUpperPdu, "in-process", "PROFIBUS");
  EXPECT_EQ(le32_at(d, 4), d.size());
  EXPECT_EQ(le32_at(d, d.size() - 4), d.size());
  EXPECT_EQ(d[8], 252);
  EXPECT_EQ(d.size() % 4, 0u);
}

TEST(Pcapng, EnhancedPacketWithDirectionAndComment) {
  std::vector<std::uint8_t> b;
  const std::uint64_t ns = 1'700'000'000'123'456'789ull;
  const std::uint8_t data[] = {0xE5};
  enhanced_packet(b, 2, ns, data, Direction::Outbound, "note");
  // type 6, length, interface 2, time high/low, captured 1, original 1, data padded to 4,
  // opt_comment "note", epb_flags 2 (outbound), end of options, length.
  EXPECT_EQ(H(b),
            "06 00 00 00 38 00 00 00 02 00 00 00 " +
                H(std::vector<std::uint8_t>{
                    static_cast<std::uint8_t>(ns >> 32), static_cast<std::uint8_t>(ns >> 40),
                    static_cast<std::uint8_t>(ns >> 48), static_cast<std::uint8_t>(ns >> 56),
                    static_cast<std::uint8_t>(ns), static_cast<std::uint8_t>(ns >> 8),
                    static_cast<std::uint8_t>(ns >> 16), static_cast<std::uint8_t>(ns >> 24)}) +
                " 01 00 00 00 01 00 00 00 E5 00 00 00 01 00 04 00 6E 6F 74 65 "
                "02 00 04 00 02 00 00 00 00 00 00 00 38 00 00 00");
  // Without direction and comment: no options at all.
  std::vector<std::uint8_t> plain;
  enhanced_packet(plain, 0, 0, data, Direction::Unknown);
  EXPECT_EQ(plain.size(), 32u + 4u);
  EXPECT_EQ(le32_at(plain, 4), 36u);
  // Appends: a second block follows the first.
  enhanced_packet(b, 0, 0, data, Direction::Inbound);
  EXPECT_EQ(le32_at(b, 56), kEnhancedPacketBlock);
}

TEST(Pcapng, SocketcanHeader) {
  const auto std_frame = can::Frame::std_data(0x201, std::vector<std::uint8_t>{0x51, 0, 0, 0, 0});
  EXPECT_EQ(H(socketcan(std_frame)), "00 00 02 01 05 00 00 00 51 00 00 00 00 00 00 00");
  const auto ext = can::Frame::ext_data(0x1234567, std::vector<std::uint8_t>{1, 2});
  EXPECT_EQ(H(socketcan(ext)), "81 23 45 67 02 00 00 00 01 02 00 00 00 00 00 00");
  const auto rtr = can::Frame::rtr(0x181, false, 6);
  EXPECT_EQ(H(socketcan(rtr)), "40 00 01 81 06 00 00 00 00 00 00 00 00 00 00 00");
}

// docs/capture.md "Error frames": linux/can/error.h's classes and data bytes, TEC and REC in
// data[6..7].
TEST(Pcapng, SocketcanErrorFrames) {
  using E = can::TimedBus::Error;
  const auto err = [](can::BusError e) { return H(socketcan_error(e)); };
  EXPECT_EQ(err({.error = E::Ack, .tec = 120}), "20 00 00 28 08 00 00 00 00 00 80 19 00 00 78 00");
  EXPECT_EQ(err({.error = E::WrongBitrate, .tec = 8, .rec = 3}),
            "20 00 00 08 08 00 00 00 00 00 04 03 00 00 08 03");
  EXPECT_EQ(err({.error = E::Injected, .tec = 300}),
            "20 00 00 08 08 00 00 00 00 00 01 08 00 00 FF 00");
  EXPECT_EQ(err({.state = can::BusState::Warning, .tec = 96}),
            "20 00 00 04 08 00 00 00 00 08 00 00 00 00 60 00");
  EXPECT_EQ(err({.state = can::BusState::Warning, .rec = 96}),
            "20 00 00 04 08 00 00 00 00 04 00 00 00 00 00 60");
  EXPECT_EQ(err({.state = can::BusState::ErrorPassive, .tec = 128}),
            "20 00 00 04 08 00 00 00 00 20 00 00 00 00 80 00");
  EXPECT_EQ(err({.state = can::BusState::ErrorPassive, .tec = 8, .rec = 128}),
            "20 00 00 04 08 00 00 00 00 10 00 00 00 00 08 80");
  EXPECT_EQ(err({.state = can::BusState::BusOff, .tec = 256}),
            "20 00 00 40 08 00 00 00 00 00 00 00 00 00 FF 00");
  EXPECT_EQ(err({.state = can::BusState::Ok, .recovered = true}),
            "20 00 01 04 08 00 00 00 00 40 00 00 00 00 00 00");
  EXPECT_EQ(err({.state = can::BusState::Ok, .tec = 95}),
            "20 00 00 04 08 00 00 00 00 40 00 00 00 00 5F 00");
}

TEST(Pcapng, ExportedPduTags) {
  std::vector<std::uint8_t> b;
  const std::uint8_t sc[] = {0xE5};
  exported_pdu(b, "fdl", sc);
  // tag 12, length 4, "fdl\0", end tag, the PDU.
  EXPECT_EQ(H(b), "00 0C 00 04 66 64 6C 00 00 00 00 00 E5");
  b.clear();
  exported_pdu(b, "candp2", text("hi"), "candp2");
  EXPECT_EQ(H(b),
            "00 0C 00 08 63 61 6E 64 70 32 00 00 00 21 00 08 63 61 6E 64 70 32 00 00 00 00 00 00 "
            "68 69");
}

}  // namespace
}  // namespace candp2::capture::pcapng
