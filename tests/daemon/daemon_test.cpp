// candp2d's wiring in-process: the daemon on an event loop thread, driven from the test thread by
// the same kinds of clients the end-to-end test uses (libmodbus, socketcand on the wire).
#include "daemon/daemon.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "can/socketcand.hpp"
#include "daemon_test_support.hpp"
#include "modbus/map_report.hpp"
#include "modbus/modbus_map.hpp"

namespace candp2::daemon {
namespace {

using namespace candp2::test;
using json = nlohmann::json;
namespace fs = std::filesystem;

std::vector<std::uint16_t> regs(std::variant<std::vector<std::uint16_t>, int> r) {
  if (auto* e = std::get_if<int>(&r)) {
    ADD_FAILURE() << "Modbus error " << modbus_strerror(*e);
    return {};
  }
  return std::get<0>(r);
}

struct TempDir {
  TempDir() {
    char tmpl[] = "/tmp/candp2-daemon-test-XXXXXX";
    path = ::mkdtemp(tmpl);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string file(const std::string& name) const { return (fs::path(path) / name).string(); }
  std::string path;
};

// The manual §5.1.4 slot example on a virtual bus exported over socketcand, master cycle 1 ms.
json manual_514() {
  return json::parse(R"({
    "modbus": {"listen": "127.0.0.1:0"},
    "master": {"address": 2, "cycle_ms": 1, "retry_ms": 50},
    "buses": {"can0": {"type": "virtual", "socketcand": "127.0.0.1:0"}},
    "gateways": [{
      "name": "gw5", "address": 5, "bus": "can0",
      "parameters": {"watchdog_ms": 200},
      "slots": [
        {"io": "input",  "address": 172, "length": 6, "comment": "02,89,B8"},
        {"io": "output", "address": 172, "length": 6, "comment": "03,09,B8"}
      ]
    }]
  })");
}

config::DaemonConfig load(const json& j, const std::string& file = "test.json") {
  auto r = config::parse_daemon(j.dump(), file);
  if (auto* e = std::get_if<config::ConfigError>(&r)) throw std::runtime_error(e->to_string());
  return std::get<config::DaemonConfig>(r);
}

struct Running {
  explicit Running(const config::DaemonConfig& c) {
    std::string error;
    daemon = Daemon::start(c, loop, &log, &error);
    if (!daemon) throw std::runtime_error(error);
    thread.start();
  }
  ~Running() {
    thread.stop();
    daemon.reset();
  }
  std::uint16_t modbus() const { return daemon->modbus_port(); }
  std::uint16_t socketcand(const char* bus = "can0") const {
    return daemon->socketcand_port(bus).value_or(0);
  }
  // Waits (over Modbus) until the gateway is in Data_Exch and the master has exchanged data with
  // it (status block: DP state 2, master state 4, data exchanges > 0).
  bool in_data_exchange(int unit = 5) {
    ModbusClient c(modbus(), unit);
    return eventually([&] {
      auto r = c.read_input(modbus::kStatusBase, modbus::status::kCount);
      if (!std::holds_alternative<std::vector<std::uint16_t>>(r)) return false;
      const auto& s = std::get<0>(r);
      return s[modbus::status::kDpState] == 2 && s[modbus::status::kMasterState] == 4 &&
             s[modbus::status::kDataExchanges + 1] > 0;
    });
  }

  MemoryLog log;
  EventLoop loop{nullptr};
  std::unique_ptr<Daemon> daemon;
  LoopThread thread{loop};
};

TEST(Daemon, Manual514RoundTripOverModbusAndSocketcand) {
  TempDir tmp;
  json j = manual_514();
  j["log"] = {{"can_log", tmp.file("can.log")}};
  Running d(load(j));
  ASSERT_TRUE(d.in_data_exchange());
  SocketcandClient observer(d.socketcand(), "can0");
  ModbusClient plc(d.modbus(), 5);
  // Q 172..177 = holding registers 86..88 (docs/modbus.md).
  ASSERT_EQ(plc.write(86, {0x0A0B, 0x0C0D, 0x0E0F}), 0);
  // form B8 on 6 bytes: a b c d e f → b a f e d c (docs/slots.md "Data exchange in normal mode",
  // manual §5.2.2).
  EXPECT_EQ(observer.frame(), "309#0B0A0F0E0D0C");
  // The same bytes coming back on the input slot's identifier, swapped back.
  observer.send(F("289#0B0A0F0E0D0C"));
  EXPECT_TRUE(eventually([&] {
    return regs(plc.read_input(86, 3)) == std::vector<std::uint16_t>{0x0A0B, 0x0C0D, 0x0E0F};
  }));
  // Status block: Data_Exch, diagnosis byte 3 = master 2, tx/rx counters, LEDs.
  const auto s = regs(plc.read_input(modbus::kStatusBase, modbus::status::kCount));
  ASSERT_EQ(s.size(), modbus::status::kCount);
  EXPECT_EQ(s[modbus::status::kDiag + 3], 2);
  EXPECT_EQ(s[modbus::status::kDiag + 4], 0x04);
  EXPECT_EQ(s[modbus::status::kDiag + 5], 0xA4);
  EXPECT_EQ(s[modbus::status::kMasterState], 4);
  EXPECT_EQ(s[modbus::status::kReleased], 1);
  EXPECT_GE(s[modbus::status::kTxFrames + 1], 2);  // release frame + the change
  EXPECT_EQ(s[modbus::status::kRxFrames + 1], 1);
  EXPECT_EQ(s[modbus::status::kLedD], 1);
  EXPECT_EQ(s[modbus::status::kDpAddress], 5);
  d.thread.stop();
  // The CAN log holds both frames in candump -l notation.
  std::ifstream in(tmp.file("can.log"));
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find(") can0 309#0B0A0F0E0D0C\n"), std::string::npos) << text.str();
  EXPECT_NE(text.str().find(") can0 289#0B0A0F0E0D0C\n"), std::string::npos) << text.str();
}

TEST(Daemon, ControlRegisterPowerCycleAndReparameterize) {
  Running d(load(manual_514()));
  ASSERT_TRUE(d.in_data_exchange());
  ModbusClient plc(d.modbus(), 5);
  auto parameterizations = [&] {
    const auto r =
        regs(plc.read_input(modbus::kStatusBase + modbus::status::kParameterizations, 2));
    return r.size() == 2 ? (r[0] << 16) | r[1] : -1;
  };
  EXPECT_EQ(parameterizations(), 1);
  ASSERT_EQ(plc.write_one(modbus::kControlRegister, 2), 0);  // re-parameterize
  EXPECT_TRUE(eventually([&] { return parameterizations() == 2; }));
  ASSERT_EQ(plc.write_one(modbus::kControlRegister, 1), 0);  // power cycle
  // The gateway is back in Wait_Prm at once; the master notices and parameterizes it again.
  EXPECT_EQ(regs(plc.read_input(modbus::kStatusBase, 1)), std::vector<std::uint16_t>{0});
  EXPECT_EQ(regs(plc.read_holding(modbus::kControlRegister, 1)), std::vector<std::uint16_t>{1});
  EXPECT_TRUE(eventually([&] { return parameterizations() == 3; }));
  EXPECT_TRUE(d.in_data_exchange());
  d.thread.stop();
  EXPECT_TRUE(d.log.contains("power cycle requested over Modbus"));
}

// docs/faults.md: holding registers 8193 (forced CAN state), 8194 (drop received frames) and
// control 3/4 (the master stops / resumes), seen through Modbus and the socketcand export.
TEST(Daemon, FaultControlsThroughModbusAndSocketcand) {
  json j = manual_514();
  j["gateways"][0]["parameters"]["can_diagnosis"] = true;  // diagnosis bytes 8..10 (manual §3.4.2)
  Running d(load(j));
  ASSERT_TRUE(d.in_data_exchange());
  SocketcandClient bus(d.socketcand(), "can0");
  ModbusClient plc(d.modbus(), 5);
  namespace st = modbus::status;
  auto status = [&] { return regs(plc.read_input(modbus::kStatusBase, st::kCount)); };
  auto u32 = [](const std::vector<std::uint16_t>& s, std::uint16_t at) {
    return (static_cast<std::uint32_t>(s[at]) << 16) | s[at + 1];
  };

  // Warning and error-passive: byte 8 = 0x40 / 0x80, Ext_Diag, LED C 'W' / 'E' (manual table
  // 3.3.1, table 3.4.5); the gateway still sends.
  for (auto [code, byte8, led] :
       {std::tuple{1, 0x40, modbus::led::kMorseW}, std::tuple{2, 0x80, modbus::led::kMorseE}}) {
    ASSERT_EQ(plc.write_one(modbus::kForcedStateRegister, static_cast<std::uint16_t>(code)), 0);
    const auto s = status();
    EXPECT_EQ(s[st::kBusState], code);
    EXPECT_EQ(s[st::kDiag + 8], byte8);
    EXPECT_TRUE(s[st::kDiag + 0] & 0x08) << "Ext_Diag";
    EXPECT_EQ(s[st::kLedC], led);
    EXPECT_EQ(s[st::kForcedState], code);
  }
  ASSERT_EQ(plc.write(86, {0x1111, 0x1111, 0x1111}), 0);
  EXPECT_EQ(bus.frame(), "309#111111111111");

  // Bus-off: byte 8 = 0xC0, LED C 'O'; nothing sent, nothing received.
  ASSERT_EQ(plc.write_one(modbus::kForcedStateRegister, 3), 0);
  auto s = status();
  EXPECT_EQ(s[st::kBusState], 3);
  EXPECT_EQ(s[st::kDiag + 8], 0xC0);
  EXPECT_EQ(s[st::kLedC], modbus::led::kMorseO);
  EXPECT_EQ(regs(plc.read_holding(modbus::kForcedStateRegister, 1)), std::vector<std::uint16_t>{3});
  const std::uint32_t tx_before = u32(s, st::kTxFrames);
  ASSERT_EQ(plc.write(86, {0x2222, 0x2222, 0x2222}), 0);
  ASSERT_TRUE(eventually([&] { return u32(status(), st::kTxSuppressed) >= 1; }));
  bus.send(F("289#AAAAAAAAAAAA"));
  ASSERT_TRUE(eventually([&] { return u32(status(), st::kRxSuppressed) >= 1; }));
  // The suppressed frame never reaches the bus, and the received one never reaches the image.
  EXPECT_EQ(bus.frame(200ms), std::nullopt);
  EXPECT_EQ(regs(plc.read_input(86, 3)), (std::vector<std::uint16_t>{0, 0, 0}));
  EXPECT_EQ(u32(status(), st::kIrqLost), 0u);  // off the bus: nothing lost by the controller

  // Back to the real state: the next change is sent again (the one made during bus-off is not).
  ASSERT_EQ(plc.write_one(modbus::kForcedStateRegister, 0), 0);
  s = status();
  EXPECT_EQ(s[st::kBusState], 0);
  EXPECT_EQ(s[st::kDiag + 8], 0);
  EXPECT_EQ(s[st::kLedC], modbus::led::kOn);
  EXPECT_FALSE(s[st::kDiag + 0] & 0x08);
  EXPECT_EQ(u32(s, st::kTxFrames), tx_before + 1);  // the engine counted the dropped send
  ASSERT_EQ(plc.write(86, {0x3333, 0x3333, 0x3333}), 0);
  EXPECT_EQ(bus.frame(), "309#333333333333");

  // 8194: the next 2 received frames are lost, counted in IRQ_LOST (diagnosis byte 9).
  ASSERT_EQ(plc.write_one(modbus::kDropRxRegister, 2), 0);
  EXPECT_EQ(regs(plc.read_holding(modbus::kDropRxRegister, 1)), std::vector<std::uint16_t>{2});
  bus.send(F("289#010101010101"));
  bus.send(F("289#020202020202"));
  bus.send(F("289#030303030303"));
  EXPECT_TRUE(eventually([&] {
    return regs(plc.read_input(86, 3)) == std::vector<std::uint16_t>{0x0303, 0x0303, 0x0303};
  }));
  s = status();
  EXPECT_EQ(u32(s, st::kIrqLost), 2u);
  EXPECT_EQ(s[st::kDiag + 9], 2);
  EXPECT_EQ(s[st::kRxDropRemaining], 0);
  EXPECT_EQ(regs(plc.read_holding(modbus::kDropRxRegister, 1)), std::vector<std::uint16_t>{0});

  // Control 3: the master stops; the watchdog (200 ms) expires, the gateway drops to Wait_Prm.
  ASSERT_EQ(plc.write_one(modbus::kControlRegister, 3), 0);
  EXPECT_TRUE(eventually([&] {
    const auto v = status();
    return v[st::kDpState] == 0 && v[st::kAddressed] == 0 && v[st::kLedE] == 3;
  }));
  // Control 4: the master parameterizes it again and exchanges data.
  ASSERT_EQ(plc.write_one(modbus::kControlRegister, 4), 0);
  EXPECT_TRUE(d.in_data_exchange());
  EXPECT_EQ(status()[st::kAddressed], 1);
  d.thread.stop();
  EXPECT_TRUE(d.log.contains("forced to bus-off over Modbus"));
  EXPECT_TRUE(d.log.contains("no longer addressed"));
}

// Raises the descriptor limit for tests that hold hundreds of connections.
void raise_nofile(rlim_t want) {
  rlimit r{};
  ::getrlimit(RLIMIT_NOFILE, &r);
  if (r.rlim_cur < want) {
    r.rlim_cur = std::min(want, r.rlim_max);
    ::setrlimit(RLIMIT_NOFILE, &r);
  }
}

// 300 idle Modbus connections must not lock a new client out. At modbus.max_clients the
// new connection evicts the one idle longest; the new client is answered at once.
TEST(Daemon, HundredsOfIdleModbusConnectionsDoNotLockOthersOut) {
  raise_nofile(4096);
  json j = manual_514();
  j["modbus"]["max_clients"] = 64;
  Running d(load(j));
  ASSERT_TRUE(d.in_data_exchange());
  std::vector<int> idle;
  for (int i = 0; i < 300; ++i) idle.push_back(connect_tcp(d.modbus()));
  const auto t0 = std::chrono::steady_clock::now();
  ModbusClient plc(d.modbus(), 5);
  const auto r = plc.read_input(modbus::kStatusBase, 1);
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_EQ(regs(r), std::vector<std::uint16_t>{2});
  EXPECT_LT(took, 2s) << "a new client must be served at once";
  // The earliest idle connections were closed to make room; the newest ones are still open.
  EXPECT_TRUE(closed_by_peer(idle.front(), 2000ms));
  for (int fd : idle) ::close(fd);
  d.thread.stop();
  EXPECT_TRUE(d.log.contains("evicted for"));
  EXPECT_FALSE(d.log.contains("refused"));
}

TEST(Daemon, IdleModbusConnectionsCloseAfterTheTimeout) {
  json j = manual_514();
  j["modbus"]["idle_timeout_s"] = 1;
  Running d(load(j));
  const int fd = connect_tcp(d.modbus());
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_TRUE(closed_by_peer(fd, 5000ms));
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 900ms);
  ::close(fd);
  d.thread.stop();
  EXPECT_TRUE(d.log.contains("idle for 1 s"));
}

// The same for the socketcand export: idle connections that never open the bus are evicted first;
// a new client completes the handshake and sees bus traffic.
TEST(Daemon, HundredsOfIdleSocketcandConnectionsDoNotLockOthersOut) {
  raise_nofile(4096);
  json j = manual_514();
  j["buses"]["can0"]["socketcand_max_clients"] = 32;
  Running d(load(j));
  ASSERT_TRUE(d.in_data_exchange());
  SocketcandClient listener(d.socketcand(), "can0");  // a raw-mode client: kept over idle ones
  std::vector<int> idle;
  for (int i = 0; i < 300; ++i) idle.push_back(connect_tcp(d.socketcand()));
  const auto t0 = std::chrono::steady_clock::now();
  SocketcandClient fresh(d.socketcand(), "can0");
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 2s);
  ModbusClient plc(d.modbus(), 5);
  ASSERT_EQ(plc.write(86, {0x0102, 0x0304, 0x0506}), 0);
  EXPECT_EQ(fresh.frame(), "309#020106050403");
  EXPECT_EQ(listener.frame(), "309#020106050403");
  for (int fd : idle) ::close(fd);
  d.thread.stop();
  EXPECT_TRUE(d.log.contains("evicted for"));
}

TEST(Daemon, SocketcandClientsThatNeverOpenTheBusTimeOut) {
  json j = manual_514();
  j["buses"]["can0"]["socketcand_idle_timeout_s"] = 1;
  Running d(load(j));
  const int fd = connect_tcp(d.socketcand());
  EXPECT_EQ(read_bytes(fd, 6), (std::vector<std::uint8_t>{'<', ' ', 'h', 'i', ' ', '>'}));
  EXPECT_TRUE(closed_by_peer(fd, 5000ms));
  ::close(fd);
  d.thread.stop();
  EXPECT_TRUE(d.log.contains("no raw mode after 1 s idle"));
}

TEST(Daemon, BadRequestsAreAnsweredAndTheDaemonServesOn) {
  Running d(load(manual_514()));
  ModbusClient plc(d.modbus(), 5);
  EXPECT_EQ(std::get<int>(plc.read_holding(5000, 1)), EMBXILADD);
  plc.unit(6);
  EXPECT_EQ(std::get<int>(plc.read_input(8192, 1)), EMBXGTAR);
  const int garbage = connect_tcp(d.modbus());
  const char junk[] = "\x01\x02\x03\x04\x05\x06\x07\x08";
  ::send(garbage, junk, 8, MSG_NOSIGNAL);
  EXPECT_TRUE(closed_by_peer(garbage));
  ::close(garbage);
  plc.unit(0);  // the first gateway
  EXPECT_EQ(regs(plc.read_input(modbus::kStatusBase + modbus::status::kDpAddress, 1)),
            std::vector<std::uint16_t>{5});
}

TEST(Daemon, MissingSocketcanInterfaceIsAClearError) {
  json j = manual_514();
  j["buses"] = {{"hw", {{"type", "socketcan"}, {"interface", "candp2none0"}}}};
  j["gateways"][0]["bus"] = "hw";
  EventLoop loop;
  MemoryLog log;
  std::string error;
  auto d = Daemon::start(load(j), loop, &log, &error);
  EXPECT_FALSE(d);
  EXPECT_NE(error.find("gateway \"gw5\" on bus \"hw\" ($.buses.hw)"), std::string::npos) << error;
  EXPECT_NE(error.find("candp2none0"), std::string::npos) << error;
}

TEST(Daemon, ModbusPortInUseIsAClearError) {
  Running first(load(manual_514()));
  json j = manual_514();
  j["modbus"]["listen"] = "127.0.0.1:" + std::to_string(first.modbus());
  EventLoop loop;
  std::string error;
  EXPECT_FALSE(Daemon::start(load(j), loop, nullptr, &error));
  EXPECT_NE(error.find("$.modbus.listen"), std::string::npos) << error;
  EXPECT_NE(error.find("cannot listen"), std::string::npos) << error;
}

TEST(Daemon, StoredSyncTimeSurvivesARestartThroughTheStateFile) {
  TempDir tmp;
  json j = manual_514();
  j["state_file"] = tmp.file("state.json");
  // CANopen master: Set_Prm SYNC time 250 ms is stored (docs/dp-slave.md "User parameters", manual
  // table 5.1.4).
  j["gateways"][0]["parameters"] = {{"canopen", "master"}, {"wakeup_s", 0}, {"sync_ms", 250}};
  {
    Running d(load(j));
    ASSERT_TRUE(d.in_data_exchange());
    d.thread.stop();
    d.daemon->shutdown();
  }
  std::ifstream in(tmp.file("state.json"));
  const auto state = json::parse(in);
  EXPECT_EQ(state["gateways"]["5"]["sync_ms"], 250) << state.dump();
  // 65535 = keep the stored value: after the restart the gateway uses 250 from the state file.
  j["gateways"][0]["parameters"]["sync_ms"] = 65535;
  Running again(load(j));
  ASSERT_TRUE(again.in_data_exchange());
  ModbusClient plc(again.modbus(), 5);
  EXPECT_EQ(regs(plc.read_input(modbus::kStatusBase + modbus::status::kSyncMs, 1)),
            std::vector<std::uint16_t>{250});
}

TEST(Daemon, SimulatedUnitekDriveAnswersThroughTheGateway) {
  json j = manual_514();
  j["gateways"][0]["slots"] = json::parse(R"([
    {"io": "output", "address": 0, "length": 3, "comment": "02,01,00"},
    {"io": "input",  "address": 0, "length": 4, "comment": "01,81,00"}
  ])");
  j["drives"] = json::parse(R"([{"type": "unitek", "name": "axis1", "bus": "can0"}])");
  Running d(load(j));
  ASSERT_TRUE(d.in_data_exchange());
  ModbusClient plc(d.modbus(), 5);
  // Q0..2 = 3D 51 00: read register 0x51 (MODE) once (Unitek CAN manual, REGID 0x3D time 0).
  ASSERT_EQ(plc.write(0, {0x3D51, 0x0000}), 0);
  // The drive answers on 0x181 with 0x51 + 16-bit value + stuff byte: I0 = 0x51.
  EXPECT_TRUE(eventually([&] {
    const auto r = regs(plc.read_input(0, 1));
    return !r.empty() && (r[0] >> 8) == 0x51;
  }));
}

// docs/faults.md: a simulated drive's fault registers on its own unit ID (drives[].modbus_unit).
TEST(Daemon, DriveFaultsThroughItsModbusUnit) {
  json j = manual_514();
  j["drives"] =
      json::parse(R"([{"type": "unitek", "name": "axis1", "bus": "can0", "modbus_unit": 20}])");
  Running d(load(j));
  ASSERT_TRUE(d.in_data_exchange());
  SocketcandClient bus(d.socketcand(), "can0");
  ModbusClient drive(d.modbus(), 20);
  auto next_181 = [&](std::chrono::milliseconds timeout) -> std::optional<std::string> {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (true) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          end - std::chrono::steady_clock::now());
      if (left.count() <= 0) return std::nullopt;
      auto f = bus.frame(left);
      if (!f) return std::nullopt;
      if (f->rfind("181#", 0) == 0) return f;
    }
  };
  // Error bits 0x0004 and warning bits 0x0001: ERR_BITMAP1 0x8F = 0x00010004 (little-endian).
  ASSERT_EQ(drive.write(1, {0x0004, 0x0001}), 0);
  EXPECT_EQ(regs(drive.read_holding(0, 4)), (std::vector<std::uint16_t>{0, 4, 1, 0}));
  bus.send(F("201#3D8F00"));  // Unitek REGID 0x3D: read 0x8F once
  auto f = next_181(2000ms);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->rfind("181#8F04000100", 0), 0u) << *f;
  // Mute: requests get no answer.
  ASSERT_EQ(drive.write_one(0, 1), 0);
  bus.send(F("201#3D8F00"));
  EXPECT_EQ(next_181(300ms), std::nullopt);
  ASSERT_EQ(drive.write_one(0, 0), 0);
  // A cyclic request (every 100 ms), then a restart: the cyclic replies stop, the errors are gone.
  bus.send(F("201#3D8F64"));
  ASSERT_TRUE(next_181(2000ms));
  ASSERT_EQ(drive.write_one(3, 1), 0);
  EXPECT_TRUE(eventually([&] { return !next_181(300ms).has_value(); }, 3000ms));
  EXPECT_EQ(regs(drive.read_holding(0, 4)), (std::vector<std::uint16_t>{0, 0, 0, 0}));
  bus.send(F("201#3D8F00"));
  f = next_181(2000ms);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->rfind("181#8F00000000", 0), 0u) << *f;
  // Other registers and functions get the protocol's exceptions.
  EXPECT_EQ(std::get<int>(drive.read_holding(4, 1)), EMBXILADD);
  EXPECT_EQ(std::get<int>(drive.read_input(0, 1)), EMBXILFUN);
}

TEST(Daemon, DriveUnitMustNotBeAGatewayAddress) {
  json j = manual_514();
  j["drives"] =
      json::parse(R"([{"type": "unitek", "name": "axis1", "bus": "can0", "modbus_unit": 5}])");
  try {
    load(j);
    ADD_FAILURE() << "accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("$.drives[0].modbus_unit"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("DP address"), std::string::npos) << e.what();
  }
}

TEST(Daemon, BuiltInDefaultGatewayWithTwoDrives) {
  // config/demo.json (compiled into candp2d as its default) on free ports.
  std::ifstream in(CANDP2_SOURCE_DIR "/config/demo.json");
  json j = json::parse(in);
  j["modbus"]["listen"] = "127.0.0.1:0";
  j["buses"]["can0"]["socketcand"] = "127.0.0.1:0";
  j["http"]["listen"] = "127.0.0.1:0";
  Running d(load(j, CANDP2_SOURCE_DIR "/config/demo.json"));
  ASSERT_TRUE(d.in_data_exchange(3));
  ModbusClient plc(d.modbus(), 3);
  // Q0..4 → axis1 (0x201), Q8..12 → axis2 (0x202): 3D 51 00 = read MODE (0x51) once.
  ASSERT_EQ(plc.write(0, {0x3D51, 0x0000, 0x0000, 0x0000, 0x3D51, 0x0000}), 0);
  // I0..5 ← axis1 (0x181), I8..13 ← axis2 (0x182): the answers start with the REGID.
  EXPECT_TRUE(eventually([&] {
    const auto r = regs(plc.read_input(0, 5));
    return r.size() == 5 && (r[0] >> 8) == 0x51 && (r[4] >> 8) == 0x51;
  }));
}

TEST(Daemon, GatewaysOnARemoteSocketcandBus) {
  // A socketcand server on its own loop thread stands in for a remote socketcand daemon.
  EventLoop remote_loop;
  can::VirtualBus remote_bus;
  auto remote_ep = remote_bus.endpoint("server");
  std::string error;
  auto server = can::SocketcandServer::listen({.host = "127.0.0.1", .port = 0, .channel = "can1"},
                                              *remote_ep, nullptr, &error);
  ASSERT_TRUE(server) << error;
  for (int fd : server->poll_fds())
    remote_loop.add_fd(fd, EventLoop::kReadable,
                       [&, fd](std::uint32_t) { server->on_readable(fd, EventLoop::wall_now()); });
  LoopThread remote_thread(remote_loop);
  remote_thread.start();

  TempDir tmp;
  json j = manual_514();
  j["buses"] = {{"far",
                 {{"type", "socketcand"},
                  {"host", "127.0.0.1"},
                  {"port", server->port()},
                  {"channel", "can1"}}}};
  j["gateways"][0]["bus"] = "far";
  // A second gateway on the same remote bus listens to the first one's output identifier.
  j["gateways"].push_back(json::parse(R"({"name": "gw6", "address": 6, "bus": "far", "slots": [
      {"io": "input",  "address": 300, "length": 6, "comment": "03,09,B8"},
      {"io": "output", "address": 400, "length": 1, "comment": "07,F8,00"}]})"));
  j["log"] = {{"can_log", tmp.file("can.log")}};
  Running d(load(j));
  ASSERT_TRUE(d.in_data_exchange(5));
  ASSERT_TRUE(d.in_data_exchange(6));
  // Another client of the remote server sees what the gateway sends and talks to it.
  SocketcandClient peer(server->port(), "can1");
  ModbusClient plc(d.modbus(), 5);
  ASSERT_EQ(plc.write(86, {0x0102, 0x0304, 0x0506}), 0);
  EXPECT_EQ(peer.frame(), "309#020106050403");  // form B8
  peer.send(F("289#020106050403"));
  EXPECT_TRUE(eventually([&] {
    return regs(plc.read_input(86, 3)) == std::vector<std::uint16_t>{0x0102, 0x0304, 0x0506};
  }));
  // gw6 received gw5's frame over its own connection: I 300..305 = input registers 150..152.
  EXPECT_TRUE(eventually([&] {
    return regs(plc.read_input(150, 3)) == std::vector<std::uint16_t>{0x0102, 0x0304, 0x0506};
  }));
  d.thread.stop();
  remote_thread.stop();
  // Each frame once in the CAN log, although both gateways' connections carried it.
  std::ifstream in(tmp.file("can.log"));
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  auto count = [&](const std::string& needle) {
    std::size_t n = 0;
    for (auto p = text.find(needle); p != std::string::npos; p = text.find(needle, p + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count(" far 309#020106050403\n"), 1u) << text;
  EXPECT_EQ(count(" far 289#020106050403\n"), 1u) << text;
}

// The socketcand server behind a `socketcand` bus restarts; the client reconnects with
// backoff, shows bus-off while disconnected (status block, LED C 'O'), and traffic resumes.
TEST(Daemon, SocketcandBusReconnectsAfterTheServerRestarts) {
  EventLoop remote_loop;
  can::VirtualBus remote_bus;
  auto remote_ep = remote_bus.endpoint("server");
  std::string error;
  auto serve = [&](std::uint16_t port) {
    auto server = can::SocketcandServer::listen(
        {.host = "127.0.0.1", .port = port, .channel = "can1"}, *remote_ep, nullptr, &error);
    if (server)
      for (int fd : server->poll_fds())
        remote_loop.add_fd(fd, EventLoop::kReadable, [s = server.get(), fd](std::uint32_t) {
          s->on_readable(fd, EventLoop::wall_now());
        });
    return server;
  };
  auto server = serve(0);
  ASSERT_TRUE(server) << error;
  const std::uint16_t port = server->port();
  LoopThread remote_thread(remote_loop);
  remote_thread.start();

  json j = manual_514();
  j["buses"] = {
      {"far",
       {{"type", "socketcand"}, {"host", "127.0.0.1"}, {"port", port}, {"channel", "can1"}}}};
  j["gateways"][0]["bus"] = "far";
  j["gateways"][0]["parameters"]["can_diagnosis"] = true;
  Running d(load(j));
  ASSERT_TRUE(d.in_data_exchange(5));
  ModbusClient plc(d.modbus(), 5);
  namespace st = modbus::status;
  auto status = [&] { return regs(plc.read_input(modbus::kStatusBase, st::kCount)); };
  {
    SocketcandClient peer(port, "can1");
    ASSERT_EQ(plc.write(86, {0x0102, 0x0304, 0x0506}), 0);
    EXPECT_EQ(peer.frame(), "309#020106050403");
  }

  // The server goes away: the gateway sees bus-off (diagnosis byte 8 = 0xC0, LED C 'O').
  remote_thread.stop();
  for (int fd : server->poll_fds()) remote_loop.remove_fd(fd);
  server.reset();
  EXPECT_TRUE(eventually([&] {
    const auto s = status();
    return s[st::kBusState] == 3 && s[st::kDiag + 8] == 0xC0 &&
           s[st::kLedC] == modbus::led::kMorseO;
  }));
  // Then it is back on the same port (attempts before that were refused; the backoff grows).
  server = serve(port);
  ASSERT_TRUE(server) << error;
  remote_thread.start();
  EXPECT_TRUE(eventually([&] {
    const auto s = status();
    return s[st::kBusState] == 0 && s[st::kReconnects + 1] == 1 && s[st::kLedC] == modbus::led::kOn;
  }));
  SocketcandClient peer(port, "can1");
  ASSERT_EQ(plc.write(86, {0x0A0B, 0x0C0D, 0x0E0F}), 0);
  EXPECT_EQ(peer.frame(), "309#0B0A0F0E0D0C");  // traffic resumes
  peer.send(F("289#0B0A0F0E0D0C"));
  EXPECT_TRUE(eventually([&] {
    return regs(plc.read_input(86, 3)) == std::vector<std::uint16_t>{0x0A0B, 0x0C0D, 0x0E0F};
  }));
  d.thread.stop();
  remote_thread.stop();
  for (int fd : server->poll_fds()) remote_loop.remove_fd(fd);
  EXPECT_TRUE(d.log.contains("channel is down"));
  EXPECT_TRUE(d.log.contains("reconnected after"));
}

TEST(ModbusMapText, NamesSlotsRegistersAndUnits) {
  const auto text = modbus::map_text(load(manual_514()));
  EXPECT_NE(text.find("5, 0, 255  gw5"), std::string::npos) << text;
  EXPECT_NE(text.find("I  172..177   input registers     86..88"), std::string::npos) << text;
  EXPECT_NE(text.find("Q  172..177   holding registers   86..88"), std::string::npos) << text;
  EXPECT_NE(text.find("coils            1376..1423"), std::string::npos) << text;
  EXPECT_NE(text.find("8226        dp_address"), std::string::npos) << text;
}

}  // namespace
}  // namespace candp2::daemon
