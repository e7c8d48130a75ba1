// The Modbus CAN fault block (docs/modbus.md "CAN fault block"): holding registers 8410..8413 of a
// gateway on a bus in time build a plant::CanFault with the line faults' write-last semantics; a
// gateway on an ideal bus has no such block (exception 0x02); the map's text and JSON list it only
// where a bus is in time.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <variant>
#include <vector>

#include "config/config.hpp"
#include "modbus/map_json.hpp"
#include "modbus/map_report.hpp"
#include "modbus/plant_faces.hpp"
#include "plant/plant.hpp"

namespace candp2::modbus {
namespace {

// Gateway 3 on can0, a bus in time; gateway 5 on can1, an ideal bus.
const char* kConfig = R"({
  "master": {"address": 1, "cycle_ms": 10},
  "buses": {"can0": {"type": "virtual", "bitrate": "500k"}, "can1": {"type": "virtual"}},
  "gateways": [
    {"name": "timed", "address": 3, "bus": "can0", "parameters": {"can_bitrate": "500k"},
     "slots": [{"io": "output", "address": 0, "length": 2, "comment": "02,01,00"}]},
    {"name": "ideal", "address": 5, "bus": "can1", "parameters": {"can_bitrate": "500k"},
     "slots": [{"io": "output", "address": 2, "length": 2, "comment": "02,02,00"}]}]
})";

config::DaemonConfig config_of(const char* text) {
  auto r = config::parse_daemon(text, "can-faults.json");
  if (auto* e = std::get_if<config::ConfigError>(&r)) ADD_FAILURE() << e->to_string();
  return std::holds_alternative<config::DaemonConfig>(r) ? std::get<config::DaemonConfig>(r)
                                                         : config::DaemonConfig{};
}

// A control surface that records the CAN faults it is given and accepts or refuses them.
struct Recorder final : plant::ControlSurface {
  std::vector<plant::CanFault> faults;
  bool accept = true;
  bool can_fault(const plant::CanFault& f, Time, std::string_view origin) override {
    EXPECT_EQ(origin, "over Modbus");
    faults.push_back(f);
    return accept;
  }
  bool force_can_state(plant::GatewayUnit&, std::uint16_t, Time, std::string_view) override {
    return false;
  }
  void drop_rx(plant::GatewayUnit&, std::uint32_t, Time, std::string_view) override {}
  void power_cycle(plant::GatewayUnit&, Time, std::string_view) override {}
  bool reparameterize(std::uint8_t, Time, std::string_view) override { return false; }
  void set_addressed(std::uint8_t, bool, Time, std::string_view) override {}
  void set_drive_fault(plant::DriveUnit&, std::uint16_t, std::uint16_t, Time,
                       std::string_view) override {}
  void set_slave_online(plant::SlaveUnit&, bool, Time, std::string_view) override {}
  bool set_slave_alarm(plant::SlaveUnit&, std::vector<std::uint8_t>, Time,
                       std::string_view) override {
    return false;
  }
  void force_slave_fault(plant::SlaveUnit&, bool, bool, Time, std::string_view) override {}
  void power_cycle(plant::SlaveUnit&, Time, std::string_view) override {}
  void note(std::string_view, Time) override {}
  bool line_fault(const plant::LineFault&, Time, std::string_view) override { return false; }
};

std::optional<DecodeFailure> write(CanFaultAccess& a, std::uint16_t first,
                                   std::vector<std::uint16_t> values) {
  return a.write_faults(3, static_cast<std::uint16_t>(first - kCanFaultBase), values, Time{0});
}

TEST(CanFaultBlock, TheKindWrittenLastAppliesTheOthersAsLastWritten) {
  Recorder rec;
  PlantCanFaults block(rec, {{3, "can0"}});
  EXPECT_FALSE(write(block, 8411, {5, 2}));  // count 5, every 2: nothing applied yet
  EXPECT_TRUE(rec.faults.empty());
  EXPECT_FALSE(write(block, 8410, {1}));  // error_frames
  ASSERT_EQ(rec.faults.size(), 1u);
  const plant::CanFault& f = rec.faults[0];
  EXPECT_EQ(f.kind, plant::CanFaultKind::ErrorFrames);
  EXPECT_EQ(f.bus, "can0");
  EXPECT_EQ(f.node.gateway, std::optional<std::uint8_t>(3));
  EXPECT_FALSE(f.id);
  EXPECT_EQ(f.count, 5u);
  EXPECT_EQ(f.every, 2u);
  EXPECT_FALSE(f.duration);
  for (std::uint16_t i = 0; i < can_fault::kRegisters; ++i)
    EXPECT_EQ(block.fault_register(3, i), (std::array<std::uint16_t, 4>{1, 5, 2, 0}[i]));
  // All four in one write: unplugged for 300 ms.
  EXPECT_FALSE(write(block, 8410, {2, 0, 1, 300}));
  ASSERT_EQ(rec.faults.size(), 2u);
  EXPECT_EQ(rec.faults[1].kind, plant::CanFaultKind::Unplugged);
  EXPECT_EQ(rec.faults[1].duration, std::optional<Duration>(milliseconds(300)));
}

TEST(CanFaultBlock, NoiseIsTheBusAndNeedsATime) {
  Recorder rec;
  PlantCanFaults block(rec, {{3, "can0"}});
  const auto refused = write(block, 8410, {4});  // noise without for_ms
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->exception, Exception::IllegalDataValue);
  EXPECT_TRUE(rec.faults.empty());
  EXPECT_FALSE(write(block, 8410, {4, 0, 1, 50}));
  ASSERT_EQ(rec.faults.size(), 1u);
  EXPECT_EQ(rec.faults[0].kind, plant::CanFaultKind::Noise);
  EXPECT_FALSE(rec.faults[0].node.any());  // the whole bus
  EXPECT_EQ(rec.faults[0].bus, "can0");
  EXPECT_EQ(rec.faults[0].duration, std::optional<Duration>(milliseconds(50)));
}

TEST(CanFaultBlock, BadValuesChangeNothing) {
  Recorder rec;
  PlantCanFaults block(rec, {{3, "can0"}});
  for (const auto& values : {std::vector<std::uint16_t>{5}, {1, 1, 0}, {1, 0, 1, 0}}) {
    const auto f = write(block, 8410, values);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->exception, Exception::IllegalDataValue) << f->why;
  }
  EXPECT_TRUE(rec.faults.empty());
  EXPECT_EQ(block.fault_register(3, can_fault::kCount), 1);  // the defaults, untouched
  EXPECT_EQ(block.fault_register(3, can_fault::kEvery), 1);
  rec.accept = false;  // the plant refuses: exception 0x04, the kind not taken
  const auto f = write(block, 8410, {3});
  ASSERT_TRUE(f);
  EXPECT_EQ(f->exception, Exception::ServerDeviceFailure);
  EXPECT_EQ(block.fault_register(3, can_fault::kKind), 0);
  EXPECT_EQ(rec.faults.size(), 1u);
}

// Through the map of a plant: only the gateway on the bus in time has the block.
TEST(CanFaultBlock, OnlyAGatewayOnABusInTimeHasIt) {
  const config::DaemonConfig cfg = config_of(kConfig);
  std::string error;
  auto plant = plant::Plant::build(cfg, plant::Options{}, Time{0}, &error);
  ASSERT_TRUE(plant) << error;
  auto faces = make_faces(*plant);
  ASSERT_TRUE(faces.can_faults);
  ProcessImageMap map(plant->master().image(), faces.gateway_list(), faces.drive_list(),
                      faces.field_list());
  auto read = [&](std::uint8_t unit) {
    Request r;
    r.unit = unit;
    r.function = Function::ReadHoldingRegisters;
    r.table = Table::HoldingRegisters;
    r.address = kCanFaultBase;
    r.count = can_fault::kRegisters;
    ReadResult res;
    const auto f = map.handle(r, res, Time{0});
    return f ? std::vector<std::uint16_t>{}
             : std::vector<std::uint16_t>(res.registers.begin(),
                                          res.registers.begin() + can_fault::kRegisters);
  };
  EXPECT_EQ(read(3), (std::vector<std::uint16_t>{0, 1, 1, 0}));
  EXPECT_TRUE(read(5).empty());  // exception 0x02: gateway 5's bus is ideal
  Request w;
  w.unit = 5;
  w.function = Function::WriteSingleRegister;
  w.write_address = kCanFaultBase + can_fault::kCount;
  w.write_count = 1;
  const std::vector<std::uint8_t> value{0, 7};
  w.values = value;
  ReadResult res;
  const auto f = map.handle(w, res, Time{0});
  ASSERT_TRUE(f);
  EXPECT_EQ(f->exception, Exception::IllegalDataAddress);
  w.unit = 3;
  EXPECT_FALSE(map.handle(w, res, Time{0}));
  EXPECT_EQ(read(3), (std::vector<std::uint16_t>{0, 7, 1, 0}));
}

TEST(CanFaultBlock, TheMapListsItOnlyWithABusInTime) {
  const config::DaemonConfig timed = config_of(kConfig);
  const std::string text = map_text(timed);
  EXPECT_NE(text.find("CAN fault block"), std::string::npos) << text;
  EXPECT_NE(text.find("  8410        kind: "), std::string::npos) << text;
  EXPECT_NE(text.find("  8413        for_ms: "), std::string::npos) << text;
  const auto j = map_json(timed);
  ASSERT_TRUE(j.contains("can_faults"));
  EXPECT_EQ(j["can_faults"]["units"].dump(), "[3]");
  EXPECT_EQ(j["can_faults"]["first"], 8410);
  EXPECT_EQ(j["can_faults"]["registers"][3]["name"], "for_ms");
  EXPECT_EQ(j["can_faults"]["kinds"][4]["name"], "noise");
  std::string ideal_text = kConfig;
  const std::string bitrate = R"(, "bitrate": "500k")";
  ideal_text.erase(ideal_text.find(bitrate), bitrate.size());
  const config::DaemonConfig ideal = config_of(ideal_text.c_str());
  EXPECT_EQ(map_text(ideal).find("CAN fault block"), std::string::npos);
  EXPECT_FALSE(map_json(ideal).contains("can_faults"));
}

}  // namespace
}  // namespace candp2::modbus
