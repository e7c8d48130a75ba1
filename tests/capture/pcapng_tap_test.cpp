// The plant's pcapng tap (capture/pcapng_tap.hpp): interfaces per CAN bus, per PROFIBUS side and
// for notes, link types, direction flags, comments and wall-clock time stamps; and a full disk
// that stops the capture with one log line while the DP cycle goes on.
#include "capture/pcapng_tap.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>

#include "fixture.hpp"
#include "gateway/gateway.hpp"
#include "pcapng_reader.hpp"
#include "profibus_sim/fdl/dp_wire.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::capture::test {
namespace {

namespace fs = std::filesystem;

std::string temp_file(const char* name) {
  return (fs::temp_directory_path() /
          ("candp2-tap-" + std::to_string(::getpid()) + "-" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name() + "-" + name))
      .string();
}

// 2023-11-14 22:13:20 UTC as the plant's time origin.
constexpr Duration kOffset{1'700'000'000'000'000};

const std::vector<std::uint8_t> kSetPrmTelegram = {0x68, 0x05, 0x05, 0x68, 0x83, 0x82,
                                                   0x6D, 0x3C, 0x3E, 0xEC, 0x16};

Capture write_records(ProfibusLinktype linktype) {
  const std::string path = temp_file("c.pcapng");
  {
    MemoryLog log;
    PcapngTap tap({.writer = {.path = path}, .profibus = linktype, .wall_offset = kOffset}, &log);
    const auto f = can::Frame::std_data(0x201, std::vector<std::uint8_t>{0x51, 0, 0, 0, 0});
    tap.on_dp({.time = Time(10),
               .line = 0,
               .line_name = "in-process",
               .telegram = kSetPrmTelegram,
               .from_emulation = true,
               .baud = 1'500'000});  // a line in time (docs/profibus.md "The line in time")
    tap.on_can({.time = Time(20),
                .bus = 0,
                .bus_name = "can0",
                .interface = "demo",
                .frame = f,
                .sender = "gw:gw3",
                .from_emulation = true});
    tap.on_note({.time = Time(30), .text = "gateway gw3: power cycle"});
    tap.on_can({.time = Time(40),
                .bus = 0,
                .bus_name = "can0",
                .interface = "demo",
                .frame = f,
                .sender = "replay",
                .from_emulation = false});
    const std::vector<std::uint8_t> sc = {0xE5};
    tap.on_dp({.time = Time(50),
               .line = 1,
               .line_name = "pty:/tmp/pb",
               .telegram = sc,
               .from_emulation = false});
    EXPECT_EQ(tap.stats().packets, 5u);
    EXPECT_TRUE(log.contains("pcapng capture to " + path));
  }
  auto c = read_capture(slurp(path));
  fs::remove(path);
  return c;
}

TEST(PcapngTap, InterfacesPacketsDirectionsAndTimes) {
  const auto c = write_records(ProfibusLinktype::WiresharkUpperPdu);
  ASSERT_TRUE(c.ok);
  ASSERT_EQ(c.interfaces.size(), 4u);  // in order of first appearance
  EXPECT_EQ(c.interfaces[0].linktype, 252);
  EXPECT_EQ(c.interfaces[0].name, "in-process");
  // A line in time states its baud rate (if_speed); the CAN bus and a line of unknown rate don't.
  EXPECT_EQ(c.interfaces[0].speed, std::optional<std::uint64_t>{1'500'000});
  EXPECT_FALSE(c.interfaces[1].speed.has_value());
  EXPECT_FALSE(c.interfaces[3].speed.has_value());
  EXPECT_EQ(c.interfaces[1].linktype, 227);
  EXPECT_EQ(c.interfaces[1].name, "demo");
  EXPECT_EQ(c.interfaces[2].linktype, 252);
  EXPECT_EQ(c.interfaces[2].name, "candp2 notes");
  EXPECT_EQ(c.interfaces[3].name, "pty:/tmp/pb");
  for (const auto& i : c.interfaces) EXPECT_EQ(i.tsresol, 9);
  ASSERT_EQ(c.packets.size(), 5u);
  const std::uint32_t kOut = 2, kIn = 1;
  EXPECT_EQ(c.packets[0].interface, 0u);
  EXPECT_EQ(c.packets[0].flags, kOut);
  EXPECT_EQ(c.packets[0].time, (1'700'000'000'000'000ull + 10) * 1000);
  // Exported PDU: dissector "fdl", end tag, the telegram as on the wire.
  std::vector<std::uint8_t> expected = {0, 12, 0, 4, 'f', 'd', 'l', 0, 0, 0, 0, 0};
  expected.insert(expected.end(), kSetPrmTelegram.begin(), kSetPrmTelegram.end());
  EXPECT_EQ(c.packets[0].data, expected);
  EXPECT_EQ(c.packets[1].interface, 1u);
  EXPECT_EQ(c.packets[1].flags, kOut);
  EXPECT_EQ(c.packets[1].data,
            (std::vector<std::uint8_t>{0, 0, 2, 1, 5, 0, 0, 0, 0x51, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(c.packets[2].interface, 2u);
  EXPECT_EQ(c.packets[2].comment, "gateway gw3: power cycle");
  EXPECT_FALSE(c.packets[2].flags);
  EXPECT_EQ(c.packets[3].flags, kIn) << "received by the emulation";
  EXPECT_EQ(c.packets[4].interface, 3u);
  EXPECT_EQ(c.packets[4].flags, kIn);
  EXPECT_EQ(c.packets[4].time, (1'700'000'000'000'000ull + 50) * 1000);
}

TEST(PcapngTap, ProfibusDlCarriesTheTelegramAlone) {
  const auto c = write_records(ProfibusLinktype::ProfibusDl);
  ASSERT_TRUE(c.ok);
  EXPECT_EQ(c.interfaces[0].linktype, 257);
  EXPECT_EQ(c.interfaces[3].linktype, 257);
  EXPECT_EQ(c.interfaces[2].linktype, 252) << "notes stay exported PDUs";
  EXPECT_EQ(c.packets[0].data, kSetPrmTelegram);
  EXPECT_EQ(c.packets[4].data, std::vector<std::uint8_t>{0xE5});
}

// docs/capture.md: a CAN bus in time states its bit rate as its interface's if_speed; an ideal bus
// (0, or no entry for its index) states none.
TEST(PcapngTap, TimedCanBusStatesItsBitRate) {
  const std::string path = temp_file("c.pcapng");
  {
    MemoryLog log;
    PcapngTap tap({.writer = {.path = path}, .wall_offset = kOffset, .can_bitrates = {0, 125'000}},
                  &log);
    const auto f = can::Frame::std_data(0x101, std::vector<std::uint8_t>{1, 2});
    for (std::uint16_t bus : {1, 0, 2})
      tap.on_can({.time = Time(20 + bus),
                  .bus = bus,
                  .bus_name = "b",
                  .interface = "b" + std::to_string(bus),
                  .frame = f,
                  .sender = "gw"});
  }
  const auto c = read_capture(slurp(path));
  fs::remove(path);
  ASSERT_TRUE(c.ok);
  ASSERT_EQ(c.interfaces.size(), 3u);
  EXPECT_EQ(c.interfaces[0].speed, std::optional<std::uint64_t>{125'000});
  EXPECT_FALSE(c.interfaces[1].speed.has_value()) << "bus 0: ideal";
  EXPECT_FALSE(c.interfaces[2].speed.has_value()) << "bus 2: no bit rate given";
}

// A disk that takes `room` bytes, then answers ENOSPC.
class FullDisk final : public FileSystem {
 public:
  int create(const std::string&) override { return 7; }
  ssize_t write(int, const std::uint8_t*, std::size_t n) override {
    if (room_ == 0) {
      errno = ENOSPC;
      return -1;
    }
    const std::size_t w = std::min(n, room_);
    room_ -= w;
    return static_cast<ssize_t>(w);
  }
  void close(int) override {}
  void remove(const std::string&) override {}

 private:
  std::size_t room_ = 4096;
};

TEST(PcapngTap, FullDiskDoesNotStopTheDpCycle) {
  Time now{0};
  gw::test::Recorder rec;
  rec.now = &now;
  gw::Gateway gateway(gw::GatewayOptions{.address = 3}, rec, now);
  MemoryLog log;
  PcapngTap tap({.writer = {.path = "/full/c.pcapng"}}, &log, std::make_unique<FullDisk>());
  dp::InProcessLink inner(gateway.dp());
  fdl::WireImageLink link(inner, [&](std::span<const std::uint8_t> b, bool from_master, Time t) {
    tap.on_dp({.time = t,
               .line = 0,
               .line_name = "in-process",
               .telegram = b,
               .from_emulation = from_master});
  });
  dp::DpMaster master({.address = 1});
  const auto prm = gw::make_set_prm(gw::UserPrm{}, 0);
  master.add_slave(link, {{prm.begin(), prm.end()},
                          gw::test::cfg_of({gw::test::out_slot(5, {0x02, 0x01, 0x00})}),
                          {{{}, 0}},
                          "gw3"});
  // Cycle until the writer has failed (it fails after 4 KiB), then 1000 cycles more.
  int cycles = 0;
  for (; cycles < 100000 && !tap.stats().stopped; ++cycles) {
    now += milliseconds(10);
    master.cycle(now);
    if (cycles % 50 == 0) tap.sync();  // let the writer catch up (and fail)
  }
  ASSERT_TRUE(tap.stats().stopped);
  const auto before = master.slave(3)->data_exchanges;
  for (int i = 0; i < 1000; ++i) {
    now += milliseconds(10);
    master.cycle(now);
  }
  EXPECT_EQ(master.slave(3)->state, dp::MasterSlaveState::DataExch);
  EXPECT_EQ(master.slave(3)->data_exchanges, before + 1000);
  int errors = 0;
  for (const auto& l : log.lines)
    if (l.level == LogLevel::Error) {
      ++errors;
      EXPECT_EQ(l.message,
                "pcapng capture stopped: cannot write /full/c.pcapng: No space left on device; "
                "nothing more is captured, everything else goes on");
    }
  EXPECT_EQ(errors, 1);
}

}  // namespace
}  // namespace candp2::capture::test
