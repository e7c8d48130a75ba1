// The HTTP face's pure parts (docs/daemon.md "HTTP face"): which connection gives way
// (ClientTable), the documents built in steps (StatusBuild, MetricsBuild) against the ones built in
// one piece, and the live view's rounds and per-stream changes (LiveView) on a real plant.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <random>
#include <variant>

#include "can/frame_bits.hpp"
#include "config/config.hpp"
#include "http/client_table.hpp"
#include "http/documents.hpp"
#include "http/live_view.hpp"
#include "http_plant_support.hpp"
#include "plant/plant.hpp"

namespace candp2 {
namespace {

using nlohmann::json;

// ---------------------------------------------------------------------------------- ClientTable

TEST(ClientTable, AtTheLimitTheConnectionWaitingLongestGoes) {
  http::ClientTable t(3, seconds(60));
  const auto a = t.admit(Time{0}).id;
  const auto b = t.admit(Time{1000}).id;
  const auto c = t.admit(Time{2000}).id;
  t.request_started(a);  // a is busy (a stream, say): not a candidate while others wait
  const auto d = t.admit(Time{3000});
  ASSERT_TRUE(d.evict);
  EXPECT_EQ(*d.evict, b);  // waiting since 1000
  EXPECT_TRUE(d.evict_was_waiting);
  EXPECT_FALSE(t.contains(b));
  EXPECT_EQ(t.size(), 3u);
  // c finishes a request later than d was accepted: d now waits longest.
  t.request_started(c);
  t.request_done(c, Time{5000});
  const auto e = t.admit(Time{6000});
  ASSERT_TRUE(e.evict);
  EXPECT_EQ(*e.evict, d.id);
}

TEST(ClientTable, WhenEveryConnectionIsBusyTheOldestRequestGoes) {
  http::ClientTable t(2, seconds(60));
  const auto a = t.admit(Time{0}).id;
  const auto b = t.admit(Time{0}).id;
  t.request_started(b);  // b's request started first
  t.request_started(a);
  const auto c = t.admit(Time{10});
  ASSERT_TRUE(c.evict);
  EXPECT_EQ(*c.evict, b);
  EXPECT_FALSE(c.evict_was_waiting);
  EXPECT_EQ(t.busy(), 1u);
}

TEST(ClientTable, WaitingForARequestTimesOutEvenWhileBytesTrickle) {
  http::ClientTable t(10, seconds(5));
  const auto silent = t.admit(Time{0}).id;
  const auto served = t.admit(Time{0}).id;
  const auto trickler = t.admit(Time{1'000'000}).id;  // sends header bytes: no request yet
  t.request_started(served);
  EXPECT_EQ(t.next_expiry(), Time{5'000'000});
  EXPECT_EQ(t.expired(Time{4'999'999}), std::vector<http::ClientTable::Id>{});
  EXPECT_EQ(t.expired(Time{5'000'000}), std::vector<http::ClientTable::Id>{silent});
  EXPECT_EQ(t.expired(Time{6'000'000}), (std::vector<http::ClientTable::Id>{silent, trickler}));
  // A busy connection never times out here (a response without progress is libmicrohttpd's).
  t.request_done(served, Time{7'000'000});
  EXPECT_EQ(t.waiting_since(served), Time{7'000'000});
}

TEST(ClientTable, NoTimeoutWhenZero) {
  http::ClientTable t(1, Duration{0});
  t.admit(Time{0});
  EXPECT_FALSE(t.next_expiry());
  EXPECT_TRUE(t.expired(Time{1'000'000'000}).empty());
}

// ------------------------------------------------------------------- a plant and its status model

constexpr const char* kConfig = R"({
  "master": { "address": 1, "cycle_ms": 10 },
  "buses": { "can0": { "type": "virtual" }, "can1": { "type": "virtual" } },
  "gateways": [
    { "name": "gw3", "address": 3, "bus": "can0", "parameters": { "can_bitrate": "500k" },
      "slots": [ { "io": "output", "address": 0, "length": 2, "comment": "02,01,00" },
                 { "io": "output", "address": 2, "length": 2, "comment": "02,02,00" },
                 { "io": "input", "address": 0, "length": 2, "comment": "01,81,00" } ] },
    { "name": "gw4", "address": 4, "bus": "can1", "parameters": { "can_bitrate": "500k" },
      "slots": [ { "io": "output", "address": 16, "length": 1, "comment": "02,03,00" } ] } ]
})";

struct Face : ::testing::Test {
  virtual std::string text() const { return kConfig; }
  void SetUp() override {
    auto parsed = config::parse_daemon(text(), "face.json");
    ASSERT_TRUE(std::holds_alternative<config::DaemonConfig>(parsed));
    cfg = std::get<config::DaemonConfig>(parsed);
    std::string error;
    plant = plant::Plant::build(cfg, plant::Options{}, Time{0}, &error);
    ASSERT_TRUE(plant) << error;
    monitors = std::make_unique<http::BusMonitors>(plant->buses().size());
    plant->add_tap(monitors.get());
    model = std::make_unique<http::StatusModel>(http::make_sources(*plant, monitors.get()));
    run_until(Time{500'000});  // every gateway in Data_Exch
  }
  void run_until(Time end) { test::run_plant_until(*plant, now, end); }
  config::DaemonConfig cfg;
  std::unique_ptr<plant::Plant> plant;
  std::unique_ptr<http::BusMonitors> monitors;
  std::unique_ptr<http::StatusModel> model;
  Time now{0};
};

TEST_F(Face, TheStatusBuiltInStepsIsTheStatusBuiltAtOnce) {
  const json whole = model->status(now);
  http::StatusBuild build(*model, 0);
  int steps = 1;
  while (!build.step(now)) ++steps;
  const json parts = json::parse(build.take());
  EXPECT_EQ(parts, whole);
  EXPECT_EQ(parts["gateways"][0]["slots"].size(), 3u);
  // head, 2 buses, drives, per gateway its head and one step of up to 8 rows
  EXPECT_EQ(steps, 1 + 2 + 1 + 2 * 2);
}

// http::make_sources reads the plant: every gateway with its status, every bus with its
// monitor (fed by the tap) at the bit rate its gateway is configured to (manual table 5.1.1).
TEST_F(Face, TheSourcesComeFromThePlant) {
  const auto& src = model->sources();
  ASSERT_EQ(src.gateways.size(), 2u);
  EXPECT_EQ(src.gateways[1].cfg->name, "gw4");
  EXPECT_EQ(src.gateways[1].status(now).dp_address, 4);
  ASSERT_EQ(src.buses.size(), 2u);
  EXPECT_EQ(src.buses[1].bitrate, 500000u);
  EXPECT_EQ(src.buses[0].monitor, &monitors->at(0));
  EXPECT_GE(src.buses[0].monitor->frames(), 1u);  // the gateways' frames since start
  EXPECT_TRUE(src.slaves.empty());
  EXPECT_TRUE(src.drives.empty());
}

// What the face shows of a gateway beyond its status comes from its unit's view, plain data
// (docs/architecture.md "One vocabulary"): in Data_Exch the accepted user parameters (manual
// §5.1.2), the slots of Chk_Cfg with the frames each one sent.
TEST_F(Face, AGatewaysViewIsWhatItsUnitHolds) {
  const plant::GatewayView v = plant->gateways().at(0)->view();
  EXPECT_EQ(v.address, 3);
  EXPECT_TRUE(v.accepted);
  EXPECT_EQ(v.parameters.bitrate_index, cfg.gateways[0].parameters.bitrate_index);
  ASSERT_TRUE(v.slot_config.has_value());
  EXPECT_EQ(v.slot_config->slots.size(), 3u);
  ASSERT_EQ(v.slot_stats.size(), 3u);
  EXPECT_GE(v.slot_stats[0].frames, 1u);  // an output slot sends every master cycle
  EXPECT_EQ(v.pages_processed, 0u);
  const json head = model->status(now)["gateways"][0];
  EXPECT_EQ(head["parameters"]["accepted"], true);
  EXPECT_EQ(head["slots"][0]["frames"], v.slot_stats[0].frames);
}

TEST_F(Face, TheMetricsHaveEveryFamilyOnce) {
  http::MetricsBuild build(*model, 0);
  int steps = 1;
  while (!build.step(now)) ++steps;
  const std::string text = build.take();
  EXPECT_EQ(steps, 1 + 10 + 1);  // the status blocks, ten per-gateway families, the rest
  EXPECT_NE(text.find("candp2_gateway_dp_state{gateway=\"4\",bus=\"can1\",name=\"gw4\"} 2\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("candp2_master_cycles_missed_total 0\n"), std::string::npos);
  std::size_t types = 0;
  for (std::size_t at = 0;
       (at = text.find("# TYPE candp2_gateway_can_frames_lost_total", at)) != std::string::npos;
       ++at)
    ++types;
  EXPECT_EQ(types, 1u);
  EXPECT_EQ(text.find("candp2_bus_timed"), std::string::npos);  // no bus in time: as before
}

// docs/can-bus.md "Seen from outside": a bus with `bitrate` shows its exact load and its
// identifiers' latency; an ideal bus shows neither.
struct TimedFace : Face {
  std::string text() const override {
    std::string t = kConfig;
    const std::string bus = R"("can0": { "type": "virtual" })";
    t.replace(t.find(bus), bus.size(), R"("can0": { "type": "virtual", "bitrate": "125k" })");
    // docs/can-bus.md "Error confinement": gw3 at the bus's bit rate, and a drive beside it that
    // acknowledges its frames (alone, each would be an ACK error); it listens on 0x27F only.
    const std::string rate = R"("can_bitrate": "500k" },)";
    t.replace(t.find(rate), rate.size(), R"("can_bitrate": "125k" },)");
    t.replace(t.rfind("] }"), 3, R"(] }],
  "drives": [ { "type": "unitek", "name": "ack", "bus": "can0", "rx_id": "0x27F", "tx_id": "0x1FF" })");
    return t;
  }
};

TEST_F(TimedFace, TheStatusAndTheMetricsShowTheBusInTime) {
  const json st = model->status(now);
  const json& can0 = st["buses"][0];
  const json& can1 = st["buses"][1];
  EXPECT_FALSE(can1.contains("load"));
  EXPECT_FALSE(can1.contains("identifiers"));
  ASSERT_TRUE(can0.contains("identifiers")) << can0.dump();
  EXPECT_EQ(can0["timed_bitrate"], 125000);
  EXPECT_EQ(can0["tx_lost"], 0);
  EXPECT_EQ(can0["frames_on_bus"], 2);  // gw3's release: 201#0000 then 202#0000
  const json& ids = can0["identifiers"];
  ASSERT_EQ(ids.size(), 2u);
  EXPECT_EQ(ids[0]["id"], 0x201);
  EXPECT_EQ(ids[0]["latency_ms"]["last"], 0.0);
  // 202# waited in gw3's queue behind 201#: its length at 8 µs a bit.
  const auto bits = can::frame_bits_exact(*can::parse_candump("201#0000").frame);
  EXPECT_EQ(ids[1]["id"], 0x202);
  EXPECT_DOUBLE_EQ(ids[1]["latency_ms"]["max"].get<double>(), bits * 0.008);
  EXPECT_EQ(can0["load"]["max_pct"], 0.0);  // 2 frames in the first second, counted at its end
  run_until(Time{1'000'000});
  const json later = model->status(now);
  EXPECT_DOUBLE_EQ(later["buses"][0]["load"]["last_pct"].get<double>(),
                   100.0 * 2 * bits / 125000.0);
  // docs/daemon.md "Bus load": load_pct of a bus in time is its exact load, not the estimate
  // (which counts the worst case of stuff bits, more than these two frames have).
  EXPECT_DOUBLE_EQ(later["buses"][0]["load_pct"].get<double>(), 100.0 * 2 * bits / 125000.0);

  http::MetricsBuild build(*model, 0);
  while (!build.step(now)) {
  }
  const std::string text = build.take();
  EXPECT_NE(text.find("candp2_bus_timed_load_ratio{bus=\"can0\"} "), std::string::npos) << text;
  EXPECT_EQ(text.find("candp2_bus_timed_load_ratio{bus=\"can1\"}"), std::string::npos);
  EXPECT_NE(text.find("candp2_can_id_latency_max_seconds{bus=\"can0\",id=\"514\"} "),
            std::string::npos);
  EXPECT_NE(text.find("candp2_can_id_frames_total{bus=\"can0\",id=\"513\"} 1\n"),
            std::string::npos);
  EXPECT_NE(text.find("candp2_bus_error_frames_total{bus=\"can0\"} 0\n"), std::string::npos);
  EXPECT_NE(text.find("candp2_can_node_tec{bus=\"can0\",node=\"gw:gw3\"} 0\n"), std::string::npos);
  // The nodes' error confinement (docs/can-bus.md "Error confinement").
  const json& nodes = later["buses"][0]["nodes"];
  ASSERT_EQ(nodes.size(), 2u) << nodes.dump();
  EXPECT_EQ(nodes[0]["name"], "gw:gw3");
  EXPECT_EQ(nodes[0]["state"], "ok");
  EXPECT_EQ(nodes[1]["name"], "drive:ack");
  EXPECT_EQ(later["buses"][0]["error_frames"], 0);
}

// docs/can-bus.md "Performance": the status documents write a bus in time's identifiers as text;
// that text is the bus's json dumped, byte for byte (the documents' bytes do not change).
TEST_F(TimedFace, TheBusTextIsItsJsonDumped) {
  run_until(Time{3'000'000});
  for (const bool trace : {true, false}) {
    const std::string text = model->bus_text(0, now, trace);
    EXPECT_EQ(text, model->bus_json(0, now, trace).dump());
    EXPECT_NE(text.find("\"identifiers\":[{"), std::string::npos) << text;
    EXPECT_EQ(model->bus_text(1, now, trace), model->bus_json(1, now, trace).dump());  // ideal
  }
}

// For identifiers of every kind (11- and 29-bit, data and remote, DLC 0..8) and latencies and
// periods of every size, queued on a bus with three nodes: the text holds each identifier's
// statistics in arbitration order, and it is what nlohmann::json dumps for its parse (its key
// order, its digits).
TEST_F(TimedFace, EveryIdentifiersTextIsItsJsonDumped) {
  can::TimedBus bus(125'000, Time{0});
  for (int n = 0; n < 3; ++n) bus.add_node(255);
  std::mt19937 random(7);
  Time t{0};
  for (int k = 0; k < 3000; ++k) {
    can::Frame f;
    f.extended = random() % 3 == 0;
    // 64 identifiers of each kind, the 29-bit ones at the top of their range.
    f.id = static_cast<std::uint32_t>(random() % 64) + (f.extended ? 0x1FFFFFC0u : 0x7C0u);
    f.remote = random() % 5 == 0;
    f.dlc = static_cast<std::uint8_t>(random() % 9);
    for (auto& b : f.data) b = static_cast<std::uint8_t>(random());
    bus.request(random() % 3, f, t);
    t += Duration(static_cast<std::int64_t>(random() % (k % 100 == 0 ? 4'000'000 : 3'000)));
    bus.advance(t);
  }
  bus.advance(t + seconds(60));
  std::string text;
  http::StatusModel::put_identifiers(text, bus);
  const json ids = json::parse(text);
  EXPECT_EQ(text, ids.dump());
  EXPECT_EQ(http::StatusModel::timed_json(bus, t)["identifiers"], ids);
  const auto stats = bus.identifiers();
  ASSERT_EQ(ids.size(), stats.size());
  EXPECT_GT(ids.size(), 100u);
  auto ms = [](Duration d) { return static_cast<double>(d.count()) / 1000.0; };
  std::size_t k = 0;
  for (const auto& [key, s] : stats) {
    const json& e = ids[k++];
    EXPECT_EQ(e["id"], s.id.id);
    EXPECT_EQ(e["ext"], s.id.extended);
    EXPECT_EQ(e["rtr"], s.remote);
    EXPECT_EQ(e["frames"], s.frames);
    EXPECT_EQ(e["period_ms"], ms(s.period_mean()));
    EXPECT_EQ(e["jitter_ms"], ms(s.jitter()));
    EXPECT_EQ(e["latency_ms"]["last"], ms(s.latency_last));
    EXPECT_EQ(e["latency_ms"]["mean"], ms(s.latency_mean()));
    EXPECT_EQ(e["latency_ms"]["max"], ms(s.latency_max));
  }
}

// docs/can-bus.md "Seen from outside": the CAN faults on cue in force on a bus in time, what is
// left of each count and time, as the line shows a station's fault; an ideal bus has no "faults".
TEST_F(TimedFace, TheFaultsInForceAreShown) {
  EXPECT_EQ(model->status(now)["buses"][0]["faults"], json::array());
  EXPECT_FALSE(model->status(now)["buses"][1].contains("faults"));
  plant::CanFault unplugged;
  unplugged.kind = plant::CanFaultKind::Unplugged;
  unplugged.node.drive = "ack";
  unplugged.duration = milliseconds(50);
  ASSERT_TRUE(plant->can_fault(unplugged, now, "(test)"));
  plant::CanFault frames;
  frames.kind = plant::CanFaultKind::ErrorFrames;
  frames.bus = "can0";
  frames.id = can::Ident{0x201, false};
  frames.count = 3;
  frames.every = 2;
  ASSERT_TRUE(plant->can_fault(frames, now, "(test)"));
  plant::CanFault noise;
  noise.kind = plant::CanFaultKind::Noise;
  noise.bus = "can0";
  noise.duration = milliseconds(20);
  ASSERT_TRUE(plant->can_fault(noise, now, "(test)"));
  EXPECT_EQ(model->status(now)["buses"][0]["faults"], json::parse(R"([
    {"kind": "unplugged", "node": "drive:ack", "id": null, "ext": false, "remaining": 0,
     "every": 1, "remaining_ms": 50},
    {"kind": "error_frames", "node": null, "id": 513, "ext": false, "remaining": 3, "every": 2,
     "remaining_ms": 0},
    {"kind": "noise", "node": null, "id": null, "ext": false, "remaining": 0, "every": 1,
     "remaining_ms": 20}])"));
  run_until(now + milliseconds(30));  // the noise is over, the drive out 20 ms more
  const json later = model->status(now)["buses"][0]["faults"];
  ASSERT_EQ(later.size(), 2u) << later.dump();
  EXPECT_EQ(later[0]["remaining_ms"], 20);
  EXPECT_EQ(later[1]["kind"], "error_frames");
  run_until(now + milliseconds(30));  // the drive plugged in again by itself
  ASSERT_EQ(model->status(now)["buses"][0]["faults"].size(), 1u);
  plant::CanFault none;
  none.bus = "can0";
  ASSERT_TRUE(plant->can_fault(none, now, "(test)"));
  EXPECT_EQ(model->status(now)["buses"][0]["faults"], json::array());
}

using test::run_round;

TEST_F(Face, AStreamGetsEverythingFirstThenOnlyWhatChanged) {
  http::LiveView view(*model);
  http::LiveView::Cursor overview, panel;
  panel.gateway = 0;  // gw3
  EXPECT_EQ(view.first_round_for(std::nullopt), 1u);
  // header, 2 tiles, gw3's panel and its rows (one step), its bus, the drives, publication
  EXPECT_EQ(run_round(view, now, {0}), 1 + 2 + 2 + 1 + 1 + 1);
  EXPECT_GE(monitors->at(0).frames(), 1u);
  json e = json::parse(view.compose(overview));
  EXPECT_TRUE(e["full"]);
  ASSERT_EQ(e["gateways"].size(), 2u);
  EXPECT_EQ(e["gateways"][1]["dp_address"], 4);
  EXPECT_EQ(e["gateways"][0]["dp_state"], "Data_Exch");
  EXPECT_FALSE(e.contains("panel"));  // no panel open
  e = json::parse(view.compose(panel));
  EXPECT_EQ(e["open"], 3);
  EXPECT_EQ(e["panel"]["slot_count"], 3);
  ASSERT_EQ(e["slots"].size(), 3u);
  EXPECT_EQ(e["slots"][0]["bytes"], "00 00");
  EXPECT_EQ(e["buses"][0]["name"], "can0");

  // Q0..1 of gw3 change; everything else stays. The overview sees nothing new but the header.
  plant->master().image().outputs[1] = 0x42;
  run_until(now + milliseconds(20));
  run_round(view, now, {0});
  e = json::parse(view.compose(overview));
  EXPECT_FALSE(e["full"]);
  EXPECT_TRUE(e["gateways"].empty()) << e.dump();
  EXPECT_TRUE(e.contains("cycle"));
  e = json::parse(view.compose(panel));
  ASSERT_EQ(e["slots"].size(), 1u) << e.dump();
  EXPECT_EQ(e["slots"][0]["bytes"], "00 42");
  EXPECT_FALSE(e["slots"][0].contains("age_ms"));  // last_ms: changes only with a frame
  EXPECT_TRUE(e["trace"].size() >= 1u);            // the frame 0x201 42
  EXPECT_EQ(e["trace"].back()["id"], 0x201);

  // A stream that lags two rounds gets both rounds' changes in one event.
  plant->master().image().outputs[3] = 0x07;
  run_until(now + milliseconds(20));
  run_round(view, now, {0});
  plant->master().image().outputs[1] = 0x43;
  run_until(now + milliseconds(20));
  run_round(view, now, {0});
  e = json::parse(view.compose(panel));
  ASSERT_EQ(e["slots"].size(), 2u) << e.dump();
  EXPECT_EQ(e["slots"][0]["bytes"], "00 43");
  EXPECT_EQ(e["slots"][1]["bytes"], "00 07");
  EXPECT_EQ(json::parse(view.compose(panel))["slots"].size(), 0u);  // nothing new now
}

TEST_F(Face, ATraceFrameKeptFromTheRoundBeforeIsTheOneTheStatusShows) {
  http::LiveView view(*model);
  run_round(view, now, {0});
  plant->master().image().outputs[1] = 0x42;
  run_until(now + milliseconds(20));
  run_round(view, now, {0});  // the frames of the first round again, and the new ones
  http::LiveView::Cursor c;
  c.gateway = 0;
  const json e = json::parse(view.compose(c));
  const json want = model->bus_json(0, now, true)["trace"];
  ASSERT_GE(want.size(), 2u);
  EXPECT_EQ(e["trace"], want);
}

TEST_F(Face, APanelOpenedLaterWaitsForARoundThatRefreshedIt) {
  http::LiveView view(*model);
  run_round(view, now, {});  // nobody has gw4 open
  EXPECT_EQ(view.first_round_for(std::nullopt), 2u);
  view.start_round(now, {});
  EXPECT_EQ(view.first_round_for(std::nullopt), 2u);  // the running round refreshes tiles
  EXPECT_EQ(view.first_round_for(1), 3u);             // but not gw4's panel
  while (!view.step(now)) {
  }
  run_round(view, now, {1});
  http::LiveView::Cursor c;
  c.gateway = 1;
  const json e = json::parse(view.compose(c));
  EXPECT_EQ(e["open"], 4);
  EXPECT_EQ(e["panel"]["name"], "gw4");
  EXPECT_EQ(e["slots"].size(), 1u);
}

// The same plant on a 1.5 Mbit/s line in time (docs/profibus.md "The line in time").
struct LineFace : Face {
  std::string text() const override {
    std::string t = kConfig;
    const std::string cycle = R"("cycle_ms": 10 })";
    t.replace(t.find(cycle), cycle.size(), R"("cycle_ms": 10, "baud": 1500000 })");
    return t;
  }
};

// docs/daemon.md "Server-Sent Events": the header's line is the status document's and names the
// station counters in the table's order (docs/profibus.md "Line statistics"), which the page
// lists them in; the status document's objects have their keys sorted and no such list.
TEST_F(LineFace, TheStreamsLineNamesTheStationCountersInTheTablesOrder) {
  http::LiveView view(*model);
  http::LiveView::Cursor overview;
  test::run_round(view, now, {});
  json e = json::parse(view.compose(overview));
  ASSERT_TRUE(e.contains("line")) << e.dump();
  const json want = {"lost", "syncs", "repeats", "repeats_max", "illegals", "diagnostics"};
  EXPECT_EQ(e["line"]["counters"], want);
  ASSERT_EQ(e["line"]["stations"].size(), 2u);
  json status = model->status(now)["line"];
  EXPECT_FALSE(status.contains("counters"));
  e["line"].erase("counters");
  EXPECT_EQ(e["line"], status);
}

}  // namespace
}  // namespace candp2
