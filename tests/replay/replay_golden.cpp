// Replay byte for byte (docs/development.md "Golden documents"): every example scenario of
// config/scenarios/ with its verbose report (log lines and traffic under each step) and its JUnit
// XML, and the parser's answer to a bad step of every action, against tests/replay/golden/. They
// guard refactorings of the action table (replay/actions.hpp). Regenerate with
// CANDP2_UPDATE_GOLDEN=1 and review the diff before committing.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <variant>
#include <vector>

#include "replay/report.hpp"
#include "replay/runner.hpp"
#include "replay/scenario.hpp"
#include "tests/golden_file.hpp"

namespace candp2::replay {
namespace {

namespace fs = std::filesystem;

const fs::path kGolden = fs::path(CANDP2_SOURCE_DIR) / "tests/replay/golden";

void expect_golden(const std::string& name, const std::string& actual) {
  test::expect_golden_file(kGolden / name, name, actual, actual);
}

// A scenario loaded from the repository's root, so that the paths in its report stay relative.
Scenario load(const std::string& relative) {
  const auto cwd = fs::current_path();
  fs::current_path(CANDP2_SOURCE_DIR);
  auto r = load_scenario(relative);
  fs::current_path(cwd);
  if (auto* e = std::get_if<config::ConfigError>(&r)) {
    ADD_FAILURE() << e->to_string();
    return {};
  }
  return std::get<Scenario>(r);
}

TEST(ReplayGolden, EveryExampleScenario) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(fs::path(CANDP2_SOURCE_DIR) / "config/scenarios"))
    if (e.path().extension() == ".json") names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  ASSERT_FALSE(names.empty());
  for (const auto& name : names) {
    SCOPED_TRACE(name);
    const auto cwd = fs::current_path();
    const Scenario sc = load("config/scenarios/" + name + ".json");
    fs::current_path(CANDP2_SOURCE_DIR);  // a version-2 scenario's configuration, its GSD files
    const RunResult r = run(sc, LogLevel::Debug);
    fs::current_path(cwd);
    expect_golden(name + ".report.txt", format_report(sc, r, {.verbose = true, .traffic = true}));
    expect_golden(name + ".junit.xml", format_junit(sc, r));
  }
}

// One gateway (slots in and out), one drive, a Page-Mode driver; the step under test follows.
std::string scenario_with(const std::string& step) {
  return R"({"format": "candp2-replay", "version": 1, "name": "bad", "cycle_ms": 10,
  "gateway": {"name": "gw5", "address": 5, "bus": "can0",
    "parameters": {"can_bitrate": "125k", "canopen": "none", "watchdog_ms": 200},
    "slots": [{"io": "input", "address": 0, "length": 2, "comment": "02,89,B8"},
              {"io": "output", "address": 0, "length": 2, "comment": "03,09,B8"}]},
  "drives": [{"type": "unitek", "name": "axis1", "bus": "can0", "rx_id": "0x201",
              "tx_id": "0x181"}],
  "steps": [)" +
         step + "]}";
}

TEST(ReplayGolden, TheParsersAnswers) {
  // Each line: a step, then what the parser makes of it (its description, or its error).
  const char* steps[] = {
      R"({})",
      R"({"write": {"address": 0, "bytes": "01"}, "inject": "201#00"})",
      R"({"bogus": 1})",
      R"({"note": "only a note", "at_ms": 5})",
      R"({"advance_ms": -1})",
      R"({"advance_ms": 12})",
      R"({"cycles": 0})",
      R"({"cycles": 3})",
      R"({"write": {"address": 8191, "bytes": "01 02"}})",
      R"({"write": {"address": 0, "bytes": "01 02"}, "within_ms": 5})",
      R"({"write": {"address": 0, "bytes": "01 02"}, "gateway": "gw5"})",
      R"({"inject": []})",
      R"({"inject": ["201#01", "12345678#R"], "bus": "can0"})",
      R"({"inject": "201#0", "bus": "can9"})",
      R"({"expect_frame": "309#*", "within_ms": 20})",
      R"({"expect_frame": "309#zz"})",
      R"({"expect_frames": "309#01"})",
      R"({"expect_frames": ["309#01", "*"], "within_ms": 3})",
      R"({"expect_no_frame": "*", "for_ms": 50})",
      R"({"expect_no_frame": "*", "within_ms": 50})",
      R"({"expect_input": {"address": 0, "bytes": "00 ??"}, "within_ms": 7})",
      R"({"expect_output": {"address": 0, "bytes": "00 01 02"}})",
      R"({"expect_diag": "00 0C"})",
      R"({"expect_diag": "00 0C 00 01 04 A4 05 04 00 ?? 00", "slave": "x"})",
      R"({"expect_dp_state": "data_exch", "within_ms": 100})",
      R"({"expect_dp_state": "running"})",
      R"({"freigabe": true})",
      R"({"db_write": {"db": "WRITE_DB", "offset": 0, "bytes": "01"}})",
      R"({"expect_ret_value": 0})",
      R"({"power_cycle": true})",
      R"({"power_cycle": false})",
      R"({"reparameterize": true, "gateway": "gw5"})",
      R"({"master_stop": true})",
      R"({"master_resume": 1})",
      R"({"force_can_state": "bus-off"})",
      R"({"force_can_state": "off"})",
      R"({"drop_rx": 3})",
      R"({"drop_rx": 70000})",
      R"({"expect_counters": {"rx_frames": 1, "irq_lost": 2, "tx_suppressed": 0}})",
      R"({"expect_counters": {}})",
      R"({"expect_counters": {"fifo_level": 1}})",
      R"({"drive_mute": true})",
      R"({"drive_mute": 2})",
      R"({"drive_error_bits": 4660, "drive": "axis1"})",
      R"({"drive_warning_bits": 1})",
      R"({"drive_restart": true, "drive": "axis9"})",
      R"({"slave_online": false})",
      R"({"slave_alarm": "00 01"})",
      R"({"slave_prm_fault": true})",
      R"({"slave_cfg_fault": true})",
      R"({"field_write": {"bytes": "01"}})",
      R"({"expect_field": {"offset": 1, "bytes": "01"}})",
      R"({"line_fault": {"station": 5, "kind": "corrupt"}})",
      R"({"expect_line": {"station": 5, "repeats": 0}})",
      R"({"can_fault": {"gateway": 5, "kind": "bogus"}})",
      R"({"can_fault": {"gateway": 5, "kind": "unplugged"}})",
      R"({"expect_bus": {"tx_lost": 0}})",
  };
  std::string out;
  for (const char* step : steps) {
    out += step;
    out += "\n  ";
    auto r = parse_scenario(scenario_with(step), "bad.json");
    if (auto* e = std::get_if<config::ConfigError>(&r)) {
      out += "error: " + e->to_string();
    } else {
      const auto& s = std::get<Scenario>(r).steps.at(0);
      out += std::string(to_string(s.action)) + (s.expectation() ? " (expects): " : ": ") +
             s.describe();
    }
    out += "\n";
  }
  expect_golden("parser-answers.txt", out);
}

}  // namespace
}  // namespace candp2::replay
