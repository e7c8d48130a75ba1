// The faces' documents, byte for byte (docs/development.md "Golden documents"): the Modbus map
// (`candp2d --print-modbus-map [--json]`), GET /api/v1/status and GET /metrics, rendered in
// virtual time from config/demo.json, config/plc-line.json (generic slaves),
// config/timed-bus-125k.json (a CAN bus in time) and a line of 122 gateways × 48 slots
// (tests/e2e/http_common.py line_config). They guard refactorings of the
// vocabulary the faces share (status/station_status.hpp): a change of any document shows here.
//
// The small documents are kept whole in tests/daemon/golden/; the 122 × 48 ones (megabytes) by
// their length and FNV-1a digest, with the whole text written to the build tree for a diff.
// Regenerate with CANDP2_UPDATE_GOLDEN=1 and review the diff before committing.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <variant>

#include "config/config.hpp"
#include "http/documents.hpp"
#include "http_plant_support.hpp"
#include "modbus/map_json.hpp"
#include "modbus/map_report.hpp"
#include "modbus/plant_faces.hpp"
#include "plant/plant.hpp"
#include "tests/golden_file.hpp"

namespace candp2 {
namespace {

namespace fs = std::filesystem;

const fs::path kGolden = fs::path(CANDP2_SOURCE_DIR) / "tests/daemon/golden";

// The text as it is kept for a large document: its length and 64-bit FNV-1a digest.
std::string digest(const std::string& text) {
  std::uint64_t h = 14695981039346656037ull;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char buf[64];
  std::snprintf(buf, sizeof buf, "%zu bytes, fnv1a64 %016llx\n", text.size(),
                static_cast<unsigned long long>(h));
  return buf;
}

// Compares `actual` with golden file `name` (whole, or its digest when `whole` is false).
void expect_golden(const std::string& name, const std::string& actual, bool whole) {
  test::expect_golden_file(kGolden / (whole ? name : name + ".digest"), name, actual,
                           whole ? actual : digest(actual));
}

// tests/e2e/http_common.py line_config(10): 122 gateways (DP 3..124) × 24 output and 24 input
// slots of 6 bytes, each gateway on its own virtual bus.
std::string line_config() {
  nlohmann::ordered_json gws = nlohmann::ordered_json::array(),
                         buses = nlohmann::ordered_json::object();
  for (int i = 0; i < 122; ++i) {
    const int a = 3 + i;
    const std::string bus = "can" + std::to_string(a);
    buses[bus] = {{"type", "virtual"}};
    nlohmann::ordered_json slots = nlohmann::ordered_json::array();
    for (const auto& [io, base] : {std::pair{"output", 0x100}, {"input", 0x300}})
      for (int k = 0; k < 24; ++k) {
        const int ident = base + k;
        char comment[16];
        std::snprintf(comment, sizeof comment, "%02X,%02X,00", ident >> 8, ident & 0xFF);
        slots.push_back({{"io", io},
                         {"address", (k * 6 + (a - 3) * 8) % 8000},
                         {"length", 6},
                         {"comment", comment}});
      }
    gws.push_back({{"name", "gw" + std::to_string(a)},
                   {"address", a},
                   {"bus", bus},
                   {"parameters", {{"can_bitrate", "1000k"}}},
                   {"slots", std::move(slots)}});
  }
  return nlohmann::ordered_json{{"modbus", {{"listen", "127.0.0.1:0"}}},
                                {"http", {{"listen", "127.0.0.1:0"}}},
                                {"master", {{"address", 1}, {"cycle_ms", 10}}},
                                {"buses", std::move(buses)},
                                {"gateways", std::move(gws)},
                                {"log", {{"level", "info"}}}}
      .dump(2);
}

// Renders the four documents of a configuration; the status and metrics after `run` of virtual
// time, with PLC outputs written at 100 ms so that frames flow.
// `act`, when given, runs at 200 ms of virtual time through the Modbus map (a test's requests).
using Act = std::function<std::string(modbus::ProcessImageMap& map, Time now)>;
void check_documents(const std::string& name, const config::DaemonConfig& cfg, Time run, bool whole,
                     const Act& act = {}) {
  expect_golden(name + ".map.txt", modbus::map_text(cfg), whole);
  expect_golden(name + ".map.json", modbus::map_json_text(cfg), whole);

  std::string error;
  auto plant = plant::Plant::build(cfg, plant::Options{}, Time{0}, &error);
  ASSERT_TRUE(plant) << error;
  http::BusMonitors monitors(plant->buses().size());
  plant->add_tap(&monitors);
  auto faces = modbus::make_faces(*plant);
  http::StatusModel model(http::make_sources(*plant, &monitors));
  Time now{0};
  test::run_plant_until(*plant, now, Time{100'000});
  // Read the drives' status words (REGID 0x40) and touch every gateway's first output slot.
  for (std::size_t i = 0; i < 16; ++i) plant->master().image().outputs[i] = i % 8 == 0 ? 0x3D : 0;
  plant->master().image().outputs[1] = 0x40;
  plant->master().image().outputs[9] = 0x40;
  std::string modbus_text;
  modbus::ProcessImageMap map(plant->master().image(), faces.gateway_list(), faces.drive_list(),
                              faces.field_list());
  if (act) {
    test::run_plant_until(*plant, now, Time{200'000});
    modbus_text += act(map, now);
  }
  test::run_plant_until(*plant, now, run);
  now = run;
  plant->advance(now);
  if (act) {
    modbus_text += act(map, now);
    expect_golden(name + ".modbus.txt", modbus_text, whole);
  }

  http::StatusBuild status(model, 0);
  while (!status.step(now)) {
  }
  expect_golden(name + ".status.json", status.take(), whole);
  http::MetricsBuild metrics(model, 0);
  while (!metrics.step(now)) {
  }
  expect_golden(name + ".metrics.txt", metrics.take(), whole);
  plant->remove_tap(&monitors);
}

// A configuration of the repository, loaded from its root so that the paths in the documents
// (a generic slave's GSD file) stay relative.
config::DaemonConfig load(const std::string& relative) {
  const auto cwd = fs::current_path();
  fs::current_path(CANDP2_SOURCE_DIR);
  auto r = config::load_daemon(relative);
  fs::current_path(cwd);
  if (auto* e = std::get_if<config::ConfigError>(&r)) {
    ADD_FAILURE() << e->to_string();
    return {};
  }
  return std::get<config::DaemonConfig>(r);
}

TEST(FacesGolden, Demo) {
  check_documents("demo", load("config/demo.json"), Time{2'000'000}, true);
}

TEST(FacesGolden, PlcLineWithGenericSlaves) {
  check_documents("plc-line", load("config/plc-line.json"), Time{2'000'000}, true);
}

// A bus in time (docs/can-bus.md "Seen from outside"): its load, identifiers and nodes in the
// status, its families in /metrics, at 3 s of the overload the configuration shows.
TEST(FacesGolden, TimedBus) {
  check_documents("timed-bus-125k", load("config/timed-bus-125k.json"), Time{3'000'000}, true);
}

// Modbus requests of a test: FC 16 to a unit (values from `first`), FC 04 / 03 reads, each
// answered as text (registers in decimal, or the exception).
struct Requests {
  modbus::ProcessImageMap& map;
  Time now;
  std::string out;
  void write(std::uint8_t unit, std::uint16_t first, std::vector<std::uint16_t> values) {
    std::vector<std::uint8_t> bytes;
    for (auto v : values) {
      bytes.push_back(static_cast<std::uint8_t>(v >> 8));
      bytes.push_back(static_cast<std::uint8_t>(v & 0xFF));
    }
    modbus::Request r;
    r.unit = unit;
    r.function = modbus::Function::WriteMultipleRegisters;
    r.write_address = first;
    r.write_count = static_cast<std::uint16_t>(values.size());
    r.values = bytes;
    modbus::ReadResult res;
    const auto f = map.handle(r, res, now);
    out += "write unit " + std::to_string(unit) + " " + std::to_string(first) + ": " +
           (f ? "exception " + std::to_string(static_cast<int>(f->exception)) + " " + f->why
              : std::string("ok")) +
           "\n";
  }
  void read(std::uint8_t unit, modbus::Table t, std::uint16_t first, std::uint16_t count) {
    modbus::Request r;
    r.unit = unit;
    r.function = t == modbus::Table::InputRegisters ? modbus::Function::ReadInputRegisters
                                                    : modbus::Function::ReadHoldingRegisters;
    r.table = t;
    r.address = first;
    r.count = count;
    modbus::ReadResult res;
    const auto f = map.handle(r, res, now);
    out += std::string(t == modbus::Table::InputRegisters ? "input" : "holding") + " unit " +
           std::to_string(unit) + " " + std::to_string(first) + ":";
    if (f)
      out += " exception " + std::to_string(static_cast<int>(f->exception));
    else
      for (std::uint16_t i = 0; i < count; ++i) out += " " + std::to_string(res.registers[i]);
    out += "\n";
  }
};

// docs/faults.md "Line faults", docs/modbus.md "Line block": on the 1.5 Mbit/s line, station 3
// gets 10 corrupt answers every 2nd request and station 4 is silent for 2 requests, both over
// Modbus at 200 ms; the documents at 2 s show the analyser's counters (illegals 10 / repeats 10
// at 3; lost 1, repeats 1, syncs 2 at 4), the Modbus line block the same.
TEST(FacesGolden, LineFaults) {
  check_documents("line-1500k", load("config/line-1500k.json"), Time{2'000'000}, true,
                  [first = true](modbus::ProcessImageMap& map, Time now) mutable {
                    Requests q{map, now, {}};
                    if (first) {
                      first = false;
                      q.write(3, 8400, {1, 10, 2, 0});  // corrupt, 10 answers, every 2nd
                      q.write(4, 8401, {2});            // count 2 ...
                      q.write(4, 8400, {2});            // ... silent
                      q.read(3, modbus::Table::HoldingRegisters, 8400, 5);
                      q.write(3, 8400, {7});  // no such kind: 0x03
                      q.write(3, 8402, {0});  // every 0: 0x03
                      q.write(3, 8405, {1});  // outside the block: 0x02
                      return q.out;
                    }
                    for (std::uint8_t unit : {3, 4}) {
                      q.read(unit, modbus::Table::InputRegisters, 8400, 23);
                      q.read(unit, modbus::Table::HoldingRegisters, 8400, 5);
                    }
                    return q.out;
                  });
}

TEST(FacesGolden, Line122x48) {
  auto parsed = config::parse_daemon(line_config(), "line-122x48.json");
  ASSERT_TRUE(std::holds_alternative<config::DaemonConfig>(parsed));
  check_documents("line-122x48", std::get<config::DaemonConfig>(parsed), Time{500'000}, false);
}

}  // namespace
}  // namespace candp2
