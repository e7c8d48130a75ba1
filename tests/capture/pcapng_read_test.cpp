// Reading pcapng (capture/pcapng_read.hpp): what the block writers of capture/pcapng.hpp produce
// reads back field for field; a big-endian section (draft-ietf-opsawg-pcapng §4.1: the byte-order
// magic decides); a cut or damaged file keeps the packets before the damage; time resolutions.
#include "capture/pcapng_read.hpp"

#include <gtest/gtest.h>

#include "capture/pcapng.hpp"

namespace candp2::capture::pcapng {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes two_interfaces() {
  Bytes f = section_header("test");
  const Bytes idb = interface_description(kLinktypeWiresharkUpperPdu, "pty:/tmp/pb", "", 1'500'000);
  const Bytes can = interface_description(kLinktypeCanSocketcan, "can0");
  f.insert(f.end(), idb.begin(), idb.end());
  f.insert(f.end(), can.begin(), can.end());
  Bytes pdu;
  const std::uint8_t sc[] = {0xE5};
  exported_pdu(pdu, "fdl", sc);
  enhanced_packet(f, 0, 1'700'000'000'123'456'789ull, pdu, Direction::Inbound, "a comment");
  enhanced_packet(f, 1, 5, Bytes{1, 2, 3}, Direction::Unknown);
  return f;
}

TEST(PcapngRead, WhatTheWritersWriteReadsBack) {
  const Bytes f = two_interfaces();
  ASSERT_TRUE(is_pcapng(f));
  const Capture c = read(f);
  ASSERT_TRUE(c.ok) << c.error;
  EXPECT_EQ(c.sections, 1u);
  ASSERT_EQ(c.interfaces.size(), 2u);
  EXPECT_EQ(c.interfaces[0].linktype, kLinktypeWiresharkUpperPdu);
  EXPECT_EQ(c.interfaces[0].name, "pty:/tmp/pb");
  EXPECT_EQ(c.interfaces[0].speed, std::optional<std::uint64_t>(1'500'000));
  EXPECT_EQ(c.interfaces[0].tsresol, std::optional<std::uint8_t>(9));
  EXPECT_EQ(c.interfaces[1].linktype, kLinktypeCanSocketcan);
  EXPECT_FALSE(c.interfaces[1].speed);
  ASSERT_EQ(c.packets.size(), 2u);
  EXPECT_EQ(c.packets[0].interface, 0u);
  EXPECT_EQ(c.packets[0].time, 1'700'000'000'123'456'789ull);
  EXPECT_EQ(c.packets[0].comment, "a comment");
  EXPECT_EQ(c.packets[0].flags, std::optional<std::uint32_t>(1));
  const auto pdu = parse_exported_pdu(c.packets[0].data);
  ASSERT_TRUE(pdu);
  EXPECT_EQ(pdu->dissector, "fdl");
  EXPECT_EQ(Bytes(pdu->pdu.begin(), pdu->pdu.end()), Bytes{0xE5});
  EXPECT_EQ(c.packets[1].interface, 1u);
  EXPECT_EQ(c.packets[1].data, (Bytes{1, 2, 3}));
  EXPECT_FALSE(c.packets[1].flags);
}

TEST(PcapngRead, ACutOrDamagedFileKeepsWhatCameBefore) {
  const Bytes f = two_interfaces();
  const Capture whole = read(f);
  for (std::size_t cut = 0; cut < f.size(); ++cut) {  // at a block boundary a file is whole
    const Capture c = read(std::span(f).first(cut));
    EXPECT_EQ(c.ok, c.error.empty()) << cut;
    EXPECT_LE(c.packets.size(), whole.packets.size());
  }
  Bytes last;
  enhanced_packet(last, 1, 5, Bytes{1, 2, 3}, Direction::Unknown);
  for (std::size_t cut = f.size() - last.size() + 1; cut < f.size(); ++cut) {
    const Capture c = read(std::span(f).first(cut));
    EXPECT_FALSE(c.ok) << cut;
    EXPECT_NE(c.error.find("cut block"), std::string::npos) << c.error;
    EXPECT_EQ(c.packets.size(), 1u) << "the packets before the cut block";
  }
  Bytes bad = f;
  bad[bad.size() - 1] ^= 0x04;  // the last block's second length
  const Capture c = read(bad);
  EXPECT_FALSE(c.ok);
  EXPECT_EQ(c.packets.size(), 1u);
  EXPECT_NE(c.error.find("lengths differ"), std::string::npos) << c.error;
  // Any one byte changed: read without a fault, what it reads stays inside the file.
  for (std::size_t i = 0; i < f.size(); ++i)
    for (const std::uint8_t v : {0x00, 0xFF, 0x80, 0x7F}) {
      Bytes x = f;
      x[i] = v;
      const Capture c = read(x);
      EXPECT_EQ(c.ok, c.error.empty());
      for (const Packet& p : c.packets) {
        EXPECT_LT(p.interface, c.interfaces.size());
        EXPECT_LE(p.data.size(), x.size());
        if (c.interfaces[p.interface].linktype == kLinktypeWiresharkUpperPdu)
          parse_exported_pdu(p.data);  // bounds-checked (ASan builds would see otherwise)
      }
    }
  // A packet on an interface nobody described.
  Bytes orphan = section_header("x");
  enhanced_packet(orphan, 3, 0, Bytes{1}, Direction::Unknown);
  EXPECT_FALSE(read(orphan).ok);
  EXPECT_FALSE(is_pcapng(Bytes{0x10, 0x03, 0x02, 0x49}));
  EXPECT_FALSE(read(Bytes{0x10, 0x03, 0x02, 0x49}).ok);
}

TEST(PcapngRead, ABigEndianSection) {
  // SHB (28 bytes), IDB LINKTYPE 257 without options (20), EPB with 1 byte (36), big-endian.
  const Bytes f = {
      0x0A, 0x0D, 0x0D, 0x0A, 0,    0,    0,    28,   0x1A, 0x2B, 0x3C, 0x4D, 0, 1, 0, 0,  //
      0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0,    0,    0,    28,                //
      0,    0,    0,    1,    0,    0,    0,    20,   0x01, 0x01, 0,    0,    0, 0, 0, 0,
      0,    0,    0,    20,  //
      0,    0,    0,    6,    0,    0,    0,    36,   0,    0,    0,    0,    0, 0, 0, 1,
      0,    0,    0,    2,  //
      0,    0,    0,    1,    0,    0,    0,    1,    0xE5, 0,    0,    0,    0, 0, 0, 36,
  };
  const Capture c = read(f);
  ASSERT_TRUE(c.ok) << c.error;
  ASSERT_EQ(c.interfaces.size(), 1u);
  EXPECT_EQ(c.interfaces[0].linktype, kLinktypeProfibusDl);
  ASSERT_EQ(c.packets.size(), 1u);
  EXPECT_EQ(c.packets[0].time, (1ull << 32) + 2);
  EXPECT_EQ(c.packets[0].data, Bytes{0xE5});
  EXPECT_EQ(time_ns(c.interfaces[0], 3), std::optional<std::uint64_t>(3000)) << "default µs";
}

TEST(PcapngRead, TimeResolutions) {
  Interface i;
  i.tsresol = 9;
  EXPECT_EQ(time_ns(i, 42), std::optional<std::uint64_t>(42));
  i.tsresol = 3;
  EXPECT_EQ(time_ns(i, 42), std::optional<std::uint64_t>(42'000'000));
  i.tsresol = 12;
  EXPECT_EQ(time_ns(i, 42'000), std::optional<std::uint64_t>(42));
  i.tsresol = 0x80 | 10;  // 1/1024 s
  EXPECT_EQ(time_ns(i, 1024), std::optional<std::uint64_t>(1'000'000'000));
  i.tsresol = 0;
  EXPECT_FALSE(time_ns(i, UINT64_MAX));
}

}  // namespace
}  // namespace candp2::capture::pcapng
