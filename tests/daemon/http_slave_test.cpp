// The generic DP-V0 slaves in the HTTP face (docs/slaves.md "Front panel and HTTP API"): their
// part of /api/v1/status (in one piece and in steps), of /metrics and of the live view's rounds,
// on the plant of config/plc-line.json (a CAN-DP/2 and two slaves from gsd/examples/CDP20C2D.GSD).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <nlohmann/json.hpp>
#include <variant>

#include "config/config.hpp"
#include "http/documents.hpp"
#include "http/live_view.hpp"
#include "http_plant_support.hpp"
#include "plant/plant.hpp"

namespace candp2 {
namespace {

using nlohmann::json;

struct SlaveFace : ::testing::Test {
  void SetUp() override {
    auto parsed = config::load_daemon(CANDP2_SOURCE_DIR "/config/plc-line.json");
    ASSERT_TRUE(std::holds_alternative<config::DaemonConfig>(parsed));
    cfg = std::get<config::DaemonConfig>(parsed);
    ASSERT_EQ(cfg.slaves.size(), 2u);
    std::string error;
    plant = plant::Plant::build(cfg, plant::Options{}, Time{0}, &error);
    ASSERT_TRUE(plant) << error;
    model = std::make_unique<http::StatusModel>(http::make_sources(*plant));
    run_until(Time{500'000});  // every station in Data_Exch
  }
  void run_until(Time end) { test::run_plant_until(*plant, now, end); }
  plant::SlaveUnit& io(std::size_t k) { return *plant->slaves().at(k); }
  config::DaemonConfig cfg;
  std::unique_ptr<plant::Plant> plant;
  std::unique_ptr<http::StatusModel> model;
  Time now{0};
};

bool has(const json& list, const std::string& name) {
  return std::find(list.begin(), list.end(), json(name)) != list.end();
}

TEST_F(SlaveFace, TheStatusShowsEachSlaveWithItsModulesAndBytes) {
  // The PLC writes Q 100 (io1's 8 DO); io1's sensors report 8 DI and 2 AI on its field side.
  const std::uint16_t q = *cfg.slaves[0].output_address;
  plant->master().image().outputs[q] = 0xA5;
  const std::array<std::uint8_t, 5> field{0x3C, 0x12, 0x34, 0x56, 0x78};
  ASSERT_TRUE(io(0).slave().write_inputs(0, field));
  run_until(now + milliseconds(30));

  const json st = model->status(now);
  ASSERT_EQ(st["slaves"].size(), 2u);
  const json& s = st["slaves"][0];
  EXPECT_EQ(s["name"], "io1");
  EXPECT_EQ(s["dp_address"], 8);
  EXPECT_EQ(s["kind"], "in-process");
  EXPECT_EQ(s["field_unit"], 108);
  EXPECT_EQ(s["gsd"]["model"], gsd::to_utf8(io(0).slave().profile().model));
  EXPECT_EQ(s["gsd"]["ident_number"], io(0).slave().profile().ident_number);
  EXPECT_NE(s["gsd"]["file"].get<std::string>().find("CDP20C2D.GSD"), std::string::npos);
  EXPECT_EQ(s["dp_state"], "Data_Exch");
  EXPECT_EQ(s["master"]["state"], "Data_Exch");
  EXPECT_GT(s["master"]["data_exchanges"].get<int>(), 0);
  EXPECT_EQ(s["counters"]["data_exchanges"], s["master"]["data_exchanges"]);
  EXPECT_EQ(s["fault"], "");

  // Diagnosis: 6 standard bytes decoded, this master holds the lock, the GSD's ident.
  ASSERT_GE(s["diag"].size(), 6u);
  EXPECT_FALSE(has(s["diagnosis"]["bits"], "Station_Not_Ready")) << s["diagnosis"].dump();
  EXPECT_TRUE(has(s["diagnosis"]["bits"], "WD_On"));
  EXPECT_EQ(s["diagnosis"]["master_address"], cfg.master_address);
  EXPECT_EQ(s["diagnosis"]["ident_number"], io(0).slave().profile().ident_number);
  EXPECT_EQ(s["diagnosis"]["ext_diag_hex"], "");

  // Modules in slot order with their Chk_Cfg bytes, offsets, PLC addresses and current bytes.
  const json& m = s["modules"];
  ASSERT_EQ(m.size(), cfg.slaves[0].modules.size());
  for (std::size_t k = 0; k < m.size(); ++k) EXPECT_EQ(m[k]["name"], cfg.slaves[0].modules[k].name);
  EXPECT_EQ(m[0]["outputs"], 0);
  EXPECT_EQ(m[0]["inputs"], 1);
  EXPECT_EQ(m[0]["input_bytes"], "3C");
  EXPECT_EQ(m[0]["plc_inputs"], "I100");
  EXPECT_EQ(m[1]["outputs"], 1);
  EXPECT_EQ(m[1]["output_bytes"], "A5");
  EXPECT_EQ(m[1]["plc_outputs"], "Q" + std::to_string(q));
  EXPECT_EQ(m[2]["input_offset"], 1);
  EXPECT_EQ(m[2]["input_bytes"], "12 34 56 78");
  EXPECT_EQ(m[2]["plc_inputs"], "I101");
  EXPECT_EQ(s["outputs_hex"], "A5");
  EXPECT_EQ(s["received_outputs_hex"], "A5");
  EXPECT_EQ(s["inputs_hex"], "3C 12 34 56 78");
  EXPECT_EQ(s["faults"]["on_bus"], true);
  EXPECT_EQ(s["faults"]["alarm_hex"], nullptr);

  // The same document in steps: head, bus, drives, gw3's head and its rows, one step a slave.
  http::StatusBuild build(*model, 0);
  int steps = 1;
  while (!build.step(now)) ++steps;
  EXPECT_EQ(json::parse(build.take()), model->status(now));
  EXPECT_EQ(steps, 1 + 1 + 1 + 2 + 2);
}

TEST_F(SlaveFace, FaultsShowOnTheStatusAndTheTile) {
  plant->force_slave_fault(io(1), true, true, now, "by the test");
  json s = model->slave_json(1, now);
  EXPECT_EQ(s["faults"]["prm_fault"], true);
  EXPECT_EQ(s["dp_state"], "Wait_Prm");
  EXPECT_TRUE(has(s["diagnosis"]["bits"], "Prm_Fault")) << s["diagnosis"].dump();
  EXPECT_EQ(model->slave_tile(1, now)["fault"], "Prm fault (forced)");
  plant->force_slave_fault(io(1), true, false, now, "by the test");

  const std::vector<std::uint8_t> alarm{0x01, 0x02};
  ASSERT_TRUE(plant->set_slave_alarm(io(0), alarm, now, "by the test"));
  s = model->slave_json(0, now);
  EXPECT_EQ(s["faults"]["alarm_hex"], "01 02");
  EXPECT_EQ(s["diagnosis"]["ext_diag_hex"], "03 01 02");  // header 00LLLLLL: 3 bytes
  EXPECT_TRUE(has(s["diagnosis"]["bits"], "Ext_Diag"));
  EXPECT_EQ(model->slave_tile(0, now)["fault"], "diagnosis alarm");

  plant->set_slave_online(io(0), false, now, "by the test");
  EXPECT_EQ(model->slave_tile(0, now)["fault"], "off the bus");
  EXPECT_EQ(model->slave_json(0, now)["faults"]["on_bus"], false);
}

// What the face shows of a slave beyond its status comes from its unit's view, plain data
// (docs/slaves.md "Front panel and HTTP API"): its DP state, its faults, its field side.
TEST_F(SlaveFace, ASlavesViewIsWhatItsUnitHolds) {
  const std::array<std::uint8_t, 2> field{0xC3, 0x5A};
  ASSERT_TRUE(io(0).slave().write_inputs(0, field));
  const plant::SlaveView v = io(0).view();
  EXPECT_EQ(v.address, 8);
  EXPECT_EQ(v.dp_state, dp::SlaveState::DataExch);
  EXPECT_TRUE(v.online);
  EXPECT_FALSE(v.device_diagnosis.has_value());
  ASSERT_GE(v.field_inputs.size(), 2u);
  EXPECT_EQ(v.field_inputs[0], 0xC3);
  EXPECT_EQ(v.field_inputs[1], 0x5A);
  EXPECT_EQ(v.input_length, v.field_inputs.size());
  EXPECT_EQ(v.configuration.modules.size(), model->slave_json(0, now)["modules"].size());

  plant->force_slave_fault(io(0), false, true, now, "by the test");
  const plant::SlaveView faulty = io(0).view();
  EXPECT_TRUE(faulty.cfg_fault_forced);
  EXPECT_EQ(faulty.dp_state, dp::SlaveState::WaitPrm);
}

TEST_F(SlaveFace, TheMetricsHaveEachSlave) {
  http::MetricsBuild build(*model, 0);
  int steps = 1;
  while (!build.step(now)) ++steps;
  const std::string text = build.take();
  // the status blocks (gateway, slaves), ten per-gateway and three per-slave families, the rest
  EXPECT_EQ(steps, 1 + 1 + 10 + 3 + 1);
  EXPECT_NE(text.find("candp2_slave_dp_state{address=\"8\",name=\"io1\"} 2\n"), std::string::npos)
      << text;
  EXPECT_NE(text.find("candp2_slave_dp_state{address=\"9\",name=\"io2\"} 2\n"), std::string::npos);
  EXPECT_NE(text.find("# TYPE candp2_slave_data_exchanges_total counter\n"), std::string::npos);
  const auto at = text.find("candp2_slave_data_exchanges_total{address=\"8\",name=\"io1\"} ");
  ASSERT_NE(at, std::string::npos);
  EXPECT_NE(text[text.find("} ", at) + 2], '0');
}

using test::run_round;

TEST_F(SlaveFace, AStreamGetsTheSlaveTilesAndTheOpenSlavesPanel) {
  http::LiveView view(*model);
  http::LiveView::Cursor overview, panel;
  panel.slave = 1;  // io2
  // header, 1 gateway tile, 2 slave tiles, io2's panel, the drives, publication
  EXPECT_EQ(run_round(view, now, {}, {1}), 1 + 1 + 2 + 1 + 1 + 1);
  json e = json::parse(view.compose(overview));
  EXPECT_EQ(e["slave_count"], 2);
  ASSERT_EQ(e["slaves"].size(), 2u);
  EXPECT_EQ(e["slaves"][0]["dp_address"], 8);
  EXPECT_EQ(e["slaves"][1]["dp_state"], "Data_Exch");
  EXPECT_FALSE(e["slaves"][0].contains("leds"));  // no CAN-DP/2 front plate
  EXPECT_FALSE(e.contains("open_slave"));
  e = json::parse(view.compose(panel));
  EXPECT_EQ(e["open_slave"], 9);
  EXPECT_EQ(e["slave"]["name"], "io2");
  EXPECT_FALSE(e.contains("open"));  // no gateway panel

  // io1's outputs change: its tile shows no bytes, so the overview gets no tile.
  plant->master().image().outputs[*cfg.slaves[0].output_address] = 0x11;
  run_until(now + milliseconds(30));
  run_round(view, now, {}, {1});
  e = json::parse(view.compose(overview));
  EXPECT_TRUE(e["slaves"].empty()) << e.dump();
  EXPECT_FALSE(e.contains("slave"));
  e = json::parse(view.compose(panel));
  EXPECT_EQ(e["open_slave"], 9);

  // io2 gets a forced Cfg fault: its tile and its panel change, io1's tile does not.
  plant->force_slave_fault(io(1), false, true, now, "by the test");
  run_round(view, now, {}, {1});
  e = json::parse(view.compose(overview));
  ASSERT_EQ(e["slaves"].size(), 1u) << e.dump();
  EXPECT_EQ(e["slaves"][0]["fault"], "Cfg fault (forced)");
  e = json::parse(view.compose(panel));
  EXPECT_EQ(e["slave"]["faults"]["cfg_fault"], true);

  // A stream opening io1's panel waits for a round that refreshed it.
  EXPECT_EQ(view.first_round_for(std::nullopt, 0), 4u);
  view.start_round(now, {}, {});
  EXPECT_EQ(view.first_round_for(std::nullopt, 0), 5u);
  EXPECT_EQ(view.first_round_for(std::nullopt, std::nullopt), 4u);
}

}  // namespace
}  // namespace candp2
