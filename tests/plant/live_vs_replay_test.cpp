// One plant, proven (docs/architecture.md "The plant"): the same configuration and the same
// sequence of PLC output writes, once live in candp2d (Modbus writes from a client, the frames as
// the daemon's CAN log recorded them on the virtual bus) and once in `candp2 replay` (a version-2
// scenario over the same configuration file) give the same CAN frames in the same order.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "config/config.hpp"
#include "daemon/daemon.hpp"
#include "daemon_test_support.hpp"
#include "modbus/modbus_map.hpp"
#include "replay/runner.hpp"
#include "replay/scenario.hpp"

namespace candp2 {
namespace {

using namespace test;
using nlohmann::json;
namespace fs = std::filesystem;

struct Discard : LogSink {
  bool enabled(LogLevel) const override { return false; }
  void write(LogLevel, std::string_view, std::string_view) override {}
};

// One PLC write: Q address, the 5 bytes of a Unitek command (REGID, value little-endian), the
// gateway's frame it causes and whether the drive answers it.
struct Write {
  std::uint16_t q;
  std::vector<std::uint8_t> bytes;
  std::string frame;
  bool answered;
};

// Commands whose answers do not depend on time (no motor running, no cyclic reads): the drive's
// ready flag, its error bitmap, parameter writes.
const std::vector<Write> kWrites = {
    {0, {0x3D, 0xE2, 0x00, 0x00, 0x00}, "201#3DE2000000", true},
    {8, {0x3D, 0x8F, 0x00, 0x00, 0x00}, "202#3D8F000000", true},
    {0, {0x35, 0xF4, 0x01, 0x00, 0x00}, "201#35F4010000", false},
    {0, {0x3D, 0x35, 0x00, 0x00, 0x00}, "201#3D35000000", true},
    {8, {0x3D, 0xE2, 0x00, 0x00, 0x00}, "202#3DE2000000", true},
    {0, {0x3D, 0x8F, 0x00, 0x00, 0x00}, "201#3D8F000000", true},
};

// The frames the two output slots send with the first Data_Exchange (outputs 0), before any write.
const std::vector<std::string> kReleaseFrames = {"201#0000000000", "202#0000000000"};

std::string hex(const std::vector<std::uint8_t>& b) {
  std::string s;
  char buf[4];
  for (auto v : b) {
    std::snprintf(buf, sizeof buf, "%s%02X", s.empty() ? "" : " ", v);
    s += buf;
  }
  return s;
}

// candump -l lines "(sec.usec) can0 201#..." → "201#...".
std::vector<std::string> frames_of_log(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);)
    if (const auto sp = line.rfind(' '); sp != std::string::npos)
      out.push_back(line.substr(sp + 1));
  return out;
}

// `baud`: the demo on a line in time (docs/profibus.md "The line in time"); none: the ideal line.
void live_and_replay(std::optional<std::uint32_t> baud) {
  const fs::path dir =
      fs::temp_directory_path() /
      ("candp2-one-plant-" + std::to_string(::getpid()) + "-" + std::to_string(baud.value_or(0)));
  fs::create_directories(dir);
  // The demo configuration with free ports and a CAN log.
  std::ifstream demo(std::string(CANDP2_SOURCE_DIR) + "/config/demo.json");
  json j = json::parse(demo);
  j["modbus"]["listen"] = "127.0.0.1:0";
  j.erase("http");
  j["buses"]["can0"]["socketcand"] = "127.0.0.1:0";
  j["log"]["can_log"] = (dir / "can.log").string();
  if (baud) j["master"]["baud"] = *baud;
  std::ofstream(dir / "line.json") << j.dump(2);

  // Live: candp2d on its event loop, a Modbus client as the PLC.
  {
    auto loaded = config::load_daemon((dir / "line.json").string());
    ASSERT_TRUE(std::holds_alternative<config::DaemonConfig>(loaded));
    EventLoop loop{nullptr};
    Discard quiet;
    std::string error;
    auto d = daemon::Daemon::start(std::get<config::DaemonConfig>(loaded), loop, &quiet, &error);
    ASSERT_TRUE(d) << error;
    LoopThread thread(loop);
    thread.start();
    SocketcandClient observer(*d->socketcand_port("can0"), "can0");
    ModbusClient plc(d->modbus_port(), 3);
    ASSERT_TRUE(eventually([&] {
      auto r = plc.read_input(modbus::kStatusBase, 1);
      return std::holds_alternative<std::vector<std::uint16_t>>(r) && std::get<0>(r)[0] == 2;
    }));
    // The slots' first frames (the first Data_Exchange's outputs, all 0) before the first write,
    // as in the replay below: a write racing them would put the order in the client's hands.
    for (const std::string& release : kReleaseFrames) {
      std::optional<std::string> f;
      do {
        f = observer.frame();
      } while (f && *f != release);
      ASSERT_EQ(f, release);
    }
    for (const auto& w : kWrites) {
      std::vector<std::uint16_t> regs;
      auto b = w.bytes;
      if (w.q % 2 || b.size() % 2) b.push_back(0);  // whole registers: pad with the next byte
      for (std::size_t i = 0; i < b.size(); i += 2)
        regs.push_back(static_cast<std::uint16_t>(b[i] << 8 | b[i + 1]));
      ASSERT_EQ(plc.write(w.q / 2, regs), 0);
      // The gateway's frame, then (if any) the drive's answer, before the next write.
      std::optional<std::string> f;
      do {
        f = observer.frame();
      } while (f && *f != w.frame);
      ASSERT_EQ(f, w.frame);
      if (w.answered) {
        ASSERT_TRUE(observer.frame()) << "no answer to " << w.frame;
      }
    }
    thread.stop();
    d->shutdown();
  }
  const auto live = frames_of_log(dir / "can.log");

  // Replay: the same configuration file, the same writes.
  json steps = json::array({{{"expect_dp_state", "data_exch"}, {"within_ms", 1000}}});
  for (const std::string& release : kReleaseFrames)
    steps.push_back({{"expect_frame", release}, {"within_ms", 1000}});
  for (const auto& w : kWrites) {
    steps.push_back({{"write", {{"address", w.q}, {"bytes", hex(w.bytes)}}}});
    steps.push_back({{"expect_frame", w.frame}, {"within_ms", 100}});
    steps.push_back({{"advance_ms", 30}});
  }
  const json scenario = {
      {"format", "candp2-replay"}, {"version", 2}, {"config", "line.json"}, {"steps", steps}};
  auto parsed = replay::parse_scenario(scenario.dump(), (dir / "s.json").string());
  ASSERT_TRUE(std::holds_alternative<replay::Scenario>(parsed))
      << std::get<config::ConfigError>(parsed).to_string();
  const auto& sc = std::get<replay::Scenario>(parsed);
  const auto result = replay::run(sc);
  ASSERT_TRUE(result.passed());
  std::vector<std::string> replayed;
  for (const auto& t : result.traffic) replayed.push_back(can::format_candump(t.frame));

  EXPECT_GE(live.size(), kWrites.size() + 2);  // the release frames, the writes, the answers
  EXPECT_EQ(live, replayed);
  fs::remove_all(dir);
}

TEST(OnePlant, LiveAndReplayGiveTheSameFramesInTheSameOrder) {
  live_and_replay(std::nullopt);
}

TEST(OnePlant, LiveAndReplayAgreeOnALineInTime) {
  live_and_replay(187500);
}

}  // namespace
}  // namespace candp2
