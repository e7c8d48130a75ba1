// Replay scenarios (docs/replay-format.md): strict parsing with JSON paths, the virtual-time
// runner's step semantics, determinism, the report / JUnit / candump outputs.
#include "replay/scenario.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "replay/report.hpp"
#include "replay/runner.hpp"

namespace candp2::replay {
namespace {

// A normal-mode gateway (manual §5.1.4 slots) around the given steps.
std::string slots_scenario(const std::string& steps, const std::string& extra = "") {
  return R"({"format": "candp2-replay", "version": 1, "name": "t", "cycle_ms": 10,)" + extra +
         R"("gateway": {"address": 5, "bus": "can1", "parameters": {"can_bitrate": "125k"},
             "slots": [{"io": "input", "address": 172, "length": 6, "comment": "02,89,B8"},
                       {"io": "output", "address": 172, "length": 6, "comment": "03,09,B8"}]},
            "steps": [)" +
         steps + "]}";
}

Scenario parse_ok(const std::string& text) {
  auto r = parse_scenario(text, "t.json");
  if (auto* e = std::get_if<config::ConfigError>(&r)) ADD_FAILURE() << e->to_string();
  return std::holds_alternative<Scenario>(r) ? std::get<Scenario>(r) : Scenario{};
}

config::ConfigError parse_error(const std::string& text) {
  auto r = parse_scenario(text, "t.json");
  EXPECT_TRUE(std::holds_alternative<config::ConfigError>(r)) << "parsed although invalid";
  return std::holds_alternative<config::ConfigError>(r) ? std::get<config::ConfigError>(r)
                                                        : config::ConfigError{};
}

// ------------------------------------------------------------------ parsing

struct BadCase {
  const char* what;
  std::string text;
  const char* path;
  const char* message;
};

class BadScenario : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadScenario, IsRejectedWithFileAndJsonPath) {
  const auto& c = GetParam();
  const auto e = parse_error(c.text);
  EXPECT_EQ(e.file, "t.json") << c.what;
  EXPECT_EQ(e.json_path, c.path) << c.what << ": " << e.to_string();
  EXPECT_NE(e.message.find(c.message), std::string::npos) << c.what << ": " << e.to_string();
}

INSTANTIATE_TEST_SUITE_P(
    Strict, BadScenario,
    ::testing::Values(
        BadCase{"not JSON", "{", "", "not valid JSON"},
        BadCase{"format", R"({"format": "x", "version": 1})", "$.format", "candp2-replay"},
        BadCase{"version", R"({"format": "candp2-replay", "version": 3})", "$.version",
                "reads versions 1 and 2"},
        BadCase{"unknown top key", slots_scenario("", R"("cycle": 10,)"), "$.cycle", "unknown key"},
        BadCase{"gateway error",
                slots_scenario("").replace(slots_scenario("").find("02,89,B8"), 8, "2,89,B8"),
                "$.gateway.slots[0].comment", "two hex digits"},
        BadCase{"two actions", slots_scenario(R"({"advance_ms": 1, "cycles": 1})"), "$.steps[0]",
                "one action per step"},
        BadCase{"no action", slots_scenario(R"({"at_ms": 1})"), "$.steps[0]", "needs one action"},
        BadCase{"typo", slots_scenario(R"({"expect_frame": "309#", "whitin_ms": 5})"),
                "$.steps[0].whitin_ms", "unknown key"},
        BadCase{"bad frame", slots_scenario(R"({"inject": "309#1"})"), "$.steps[0].inject",
                "column"},
        BadCase{"bad pattern",
                slots_scenario(R"({"expect_input": {"address": 172, "bytes": "0?"}})"),
                "$.steps[0].expect_input.bytes", "?? per byte"},
        BadCase{"diag length", slots_scenario(R"({"expect_diag": "00 04"})"),
                "$.steps[0].expect_diag", "11 diagnosis bytes"},
        BadCase{"outside the image",
                slots_scenario(R"({"write": {"address": 8191, "bytes": "00 00"}})"),
                "$.steps[0].write.bytes", "8192-byte"},
        BadCase{"driver step without driver", slots_scenario(R"({"freigabe": true})"),
                "$.steps[0].freigabe", "page_driver"},
        BadCase{"dp state", slots_scenario(R"({"expect_dp_state": "run"})"),
                "$.steps[0].expect_dp_state", "data_exch"},
        // Simulated drives (docs/replay-format.md "Simulated drives"): entries as in the daemon's
        // "drives".
        BadCase{"drives not an array", slots_scenario("", R"("drives": {},)"), "$.drives",
                "array of drives"},
        BadCase{"drive key typo",
                slots_scenario("", R"("drives": [{"bus": "can1", "nmae": "a"}],)"),
                "$.drives[0].nmae", "unknown key"},
        BadCase{"drive without bus", slots_scenario("", R"("drives": [{"name": "a"}],)"),
                "$.drives[0]", "bus"},
        BadCase{"drive rx_id",
                slots_scenario("", R"("drives": [{"bus": "can1", "rx_id": "0x300"}],)"),
                "$.drives[0].rx_id", "from 513 to 639"},
        BadCase{"drive on another bus", slots_scenario("", R"("drives": [{"bus": "can0"}],)"),
                "$.drives[0].bus", "one bus, the gateway's \"can1\""},
        BadCase{"drive state file",
                slots_scenario("", R"("drives": [{"bus": "can1", "state_file": "a.json"}],)"),
                "$.drives[0].state_file", "no state file"},
        BadCase{"drive names twice", slots_scenario("", R"("drives": [{"bus": "can1", "name": "a"},
                                                  {"bus": "can1", "name": "a", "rx_id": "0x202"}],)"),
                "$.drives[1].name", "already used by $.drives[0]"},
        BadCase{"drive step without drives", slots_scenario(R"({"drive_mute": true})"),
                "$.steps[0].drive_mute", "needs a \"drives\" entry"},
        BadCase{"unknown drive",
                slots_scenario(R"({"drive_restart": true, "drive": "b"})",
                               R"("drives": [{"bus": "can1", "name": "a"}],)"),
                "$.steps[0].drive", "no drive \"b\""},
        BadCase{"which drive",
                slots_scenario(R"({"drive_mute": true})",
                               R"("drives": [{"bus": "can1", "name": "a"},
                                             {"bus": "can1", "name": "b", "rx_id": "0x202"}],)"),
                "$.steps[0]", "needs \"drive\""},
        BadCase{
            "error bits beyond 16",
            slots_scenario(R"({"drive_error_bits": "0x10000"})", R"("drives": [{"bus": "can1"}],)"),
            "$.steps[0].drive_error_bits", "0x8F"},
        BadCase{"warning bits not a number",
                slots_scenario(R"({"drive_warning_bits": "4"})", R"("drives": [{"bus": "can1"}],)"),
                "$.steps[0].drive_warning_bits", "0x"},
        BadCase{"restart false",
                slots_scenario(R"({"drive_restart": false})", R"("drives": [{"bus": "can1"}],)"),
                "$.steps[0].drive_restart", "expected true"},
        BadCase{"drive key on another step",
                slots_scenario(R"({"advance_ms": 1, "drive": "drive"})",
                               R"("drives": [{"bus": "can1"}],)"),
                "$.steps[0].drive", "unknown key"}));

TEST(ScenarioParse, NumbersAsHexStringsAndComments) {
  const auto sc = parse_ok(slots_scenario(
      R"({"_c": "a comment", "advance_ms": "0x10", "note": "n"}, {"note": "only a note"})"));
  ASSERT_EQ(sc.steps.size(), 2u);
  EXPECT_EQ(sc.steps[0].advance, milliseconds(16));
  EXPECT_EQ(sc.steps[1].action, Action::Note);
  EXPECT_EQ(sc.gateway().address, 5);
}

TEST(ScenarioParse, PageDriverDefaultsFromTheSegments) {
  const std::string text = R"({"format": "candp2-replay", "version": 1,
    "gateway": {"address": 3, "parameters": {"page_mode": true},
      "slots": [{"io": "output", "address": 300, "length": 32},
                {"io": "output", "address": 332, "length": 10},
                {"io": "input", "address": 400, "length": 32}]},
    "page_driver": {"tx": [{"id": "0x12345", "extended": true, "length": 8, "force": 1,
                            "data": "01 02 03 04 05 06 07 08"}],
                    "rx": [{"id": 1, "form": "0xFE", "length": 2}]},
    "steps": [{"set_tx": {"id": 1, "force": 3}}]})";
  const auto sc = parse_ok(text);
  ASSERT_TRUE(sc.driver);
  EXPECT_EQ(sc.driver->options.write_address, 300);
  EXPECT_EQ(sc.driver->options.read_address, 400);
  EXPECT_EQ(sc.driver->options.output_page_len, 42u);
  ASSERT_EQ(sc.driver->tx.size(), 1u);
  EXPECT_EQ(sc.driver->tx[0].id, (can::Ident{0x12345, true}));
  EXPECT_EQ(sc.driver->tx_force[0], 1);
  EXPECT_EQ(sc.driver->rx[0].form, 0xFE);
  // An 11-bit identifier above 7FF needs "extended".
  auto bad = text;
  bad.replace(bad.find(R"("extended": true, )"), 18, "");
  EXPECT_EQ(parse_error(bad).json_path, "$.page_driver.tx[0].id");
}

// ------------------------------------------------------------------ running

RunResult run_text(const std::string& text) {
  return run(parse_ok(text));
}

TEST(ReplayRun, SlotRoundTripAndTiming) {
  const auto sc = parse_ok(slots_scenario(R"(
    {"expect_dp_state": "data_exch", "within_ms": 100},
    {"write": {"address": 172, "bytes": "0A 0B 0C 0D 0E 0F"}},
    {"expect_frame": "309#0B0A0F0E0D0C", "within_ms": 20},
    {"inject": "289#0B0A0F0E0D0C"},
    {"expect_input": {"address": 172, "bytes": "0A 0B ?? 0D 0E 0F"}, "within_ms": 20},
    {"at_ms": 500, "expect_no_frame": "*", "for_ms": 100})"));
  const auto r = run(sc);
  ASSERT_EQ(r.steps.size(), 6u);
  EXPECT_TRUE(r.passed()) << format_report(sc, r);
  EXPECT_EQ(r.steps[0].end, milliseconds(20));  // Chk_Cfg in the master's third cycle
  EXPECT_EQ(r.steps[2].end, milliseconds(30));  // the next Data_Exchange carries the write
  EXPECT_EQ(r.steps[5].start, milliseconds(500));
  EXPECT_EQ(r.end, milliseconds(600));
  EXPECT_EQ(r.expectations(), 4u);
  // Traffic: the gateway's first frames and the injected one, stamped with virtual time.
  ASSERT_GE(r.traffic.size(), 2u);
  EXPECT_EQ(format_can_log(r, log_interface(sc)).substr(0, 33),
            "(0.030000) can1 309#0B0A0F0E0D0C\n");
}

TEST(ReplayRun, FailuresSayWhatWasSeen) {
  const auto sc = parse_ok(slots_scenario(R"(
    {"write": {"address": 172, "bytes": "01 02 03 04 05 06"}},
    {"expect_frame": "309#FFFFFFFFFFFF", "within_ms": 50},
    {"expect_input": {"address": 172, "bytes": "01"}},
    {"expect_frames": ["309#*", "309#*"], "within_ms": 30},
    {"expect_no_frame": "*", "for_ms": 10},
    {"at_ms": 10, "note": "in the past"})"));
  const auto r = run(sc);
  EXPECT_FALSE(r.passed());
  EXPECT_EQ(r.failures(), 4u);
  EXPECT_EQ(r.expectations(), 5u);  // 4 expectations + the failed action
  EXPECT_NE(r.steps[1].detail.find("309#020106050403"), std::string::npos) << r.steps[1].detail;
  EXPECT_EQ(r.steps[1].end, milliseconds(50));  // waited the whole window
  EXPECT_EQ(r.steps[2].detail, "got 00");
  EXPECT_NE(r.steps[3].detail.find("the gateway sent: 309#020106050403 @30.000 ms"),
            std::string::npos)
      << r.steps[3].detail;
  EXPECT_TRUE(r.steps[4].passed);
  EXPECT_NE(r.steps[5].detail.find("before the current time"), std::string::npos);
  const auto report = format_report(sc, r);
  EXPECT_NE(report.find("FAIL  #2 expect_frame 309#FFFFFFFFFFFF within 50 ms"), std::string::npos)
      << report;
  EXPECT_NE(report.find("FAIL: 5 expectations, 1 passed, 4 failed"), std::string::npos) << report;
  const auto junit = format_junit(sc, r);
  EXPECT_NE(junit.find(R"(tests="5" failures="4")"), std::string::npos) << junit;
  EXPECT_NE(junit.find("<failure message=\"no matching frame"), std::string::npos) << junit;
}

// A simulated Unitek drive (docs/replay-format.md "Simulated drives") on the scenario's bus answers
// the gateway's frames at once; the drive fault steps act as its Modbus registers 0..3
// (docs/faults.md): muted it neither answers nor sends its cyclic replies (and answering again does
// not send the missed ones), restarted it has lost its cyclic request.
TEST(ReplayRun, SimulatedDriveAnswersAndItsFaults) {
  const auto sc = parse_ok(R"({"format": "candp2-replay", "version": 1, "cycle_ms": 10,
    "gateway": {"address": 3, "bus": "can0", "parameters": {"can_bitrate": "500k"},
      "slots": [{"io": "output", "address": 0, "length": 5, "comment": "02,01,00"},
                {"io": "input", "address": 0, "length": 6, "comment": "01,81,00"}]},
    "drives": [{"type": "unitek", "name": "axis1", "bus": "can0", "rx_id": "0x201",
                "tx_id": "0x181"}],
    "steps": [
      {"expect_dp_state": "data_exch", "within_ms": 100},
      {"write": {"address": 0, "bytes": "3D 8F 64 00 00"}},
      {"expect_input": {"address": 0, "bytes": "8F 00 00 00 00 00"}, "within_ms": 20},
      {"drive_error_bits": "0x0104"},
      {"drive_warning_bits": 1},
      {"expect_input": {"address": 0, "bytes": "8F 04 01 01 00 00"}, "within_ms": 100},
      {"drive_mute": true},
      {"advance_ms": 1000},
      {"drive_mute": false},
      {"advance_ms": 150},
      {"drive_restart": true},
      {"advance_ms": 500}]})");
  const auto r = run(sc);
  ASSERT_EQ(r.steps.size(), 12u);
  EXPECT_TRUE(r.passed()) << format_report(sc, r);
  EXPECT_EQ(sc.steps[6].describe(), "drive_mute axis1 on");
  EXPECT_EQ(sc.steps[3].describe(), "drive_error_bits axis1 0x0104");
  auto drive_frames = [&](Time from, Time to) {
    std::vector<Time> at;
    for (const auto& t : r.traffic)
      if (!t.from_gateway && t.time > from && t.time <= to) {
        EXPECT_EQ(t.drive, "axis1");
        EXPECT_EQ(t.frame.id, 0x181u);  // the drive's Tx ID
        at.push_back(t.time);
      }
    return at;
  };
  // The request went out at 30 ms (the first Data_Exchange); the drive answered at once.
  EXPECT_EQ(drive_frames(Time{0}, milliseconds(30)), std::vector<Time>{milliseconds(30)});
  // Muted: nothing for 1000 ms (10 periods); answering again: one reply per 100 ms, none missed.
  EXPECT_TRUE(drive_frames(r.steps[6].start, r.steps[8].start).empty());
  EXPECT_EQ(drive_frames(r.steps[8].start, r.steps[9].end).size(), 1u)
      << "the missed cyclic replies are not sent in a burst";
  // Restarted: the cyclic request is lost; the PLC's unchanged outputs do not repeat it.
  EXPECT_TRUE(drive_frames(r.steps[10].start, r.end).empty());
  const auto report = format_report(sc, r, {.traffic = true});
  EXPECT_NE(report.find("axis1 -> 181#8F0401010000"), std::string::npos) << report;
}

TEST(ReplayRun, FrameExpectationsTakeFramesInOrder) {
  const auto r = run_text(slots_scenario(R"(
    {"expect_frame": "309#000000000000", "within_ms": 100},
    {"write": {"address": 172, "bytes": "01 00 00 00 00 00"}},
    {"cycles": 1},
    {"write": {"address": 172, "bytes": "02 00 00 00 00 00"}},
    {"cycles": 1},
    {"expect_frame": "309#000100000000"},
    {"expect_frame": "309#000200000000"},
    {"expect_frame": "309#000100000000"},
    {"expect_no_frame": "*", "for_ms": 0})"));
  EXPECT_TRUE(r.steps[0].passed);
  EXPECT_EQ(r.steps[2].end, milliseconds(40));  // "cycles 1" runs through the next DP cycle
  EXPECT_TRUE(r.steps[5].passed) << r.steps[5].detail;
  EXPECT_TRUE(r.steps[6].passed) << r.steps[6].detail;
  EXPECT_FALSE(r.steps[7].passed);  // already passed over
  EXPECT_TRUE(r.steps[8].passed);
}

TEST(ReplayRun, SameScenarioSameResultEveryRun) {
  for (const char* name : {"page-driver-manual-8.2.json", "page-mode-raw.json"}) {
    const std::string file = std::string(CANDP2_SOURCE_DIR) + "/config/scenarios/" + name;
    auto loaded = load_scenario(file);
    ASSERT_TRUE(std::holds_alternative<Scenario>(loaded))
        << std::get<config::ConfigError>(loaded).to_string();
    const auto& sc = std::get<Scenario>(loaded);
    const auto a = run(sc, LogLevel::Debug);
    const auto b = run(sc, LogLevel::Debug);
    EXPECT_TRUE(a.passed()) << format_report(sc, a);
    const ReportOptions verbose{true, true};
    EXPECT_EQ(format_report(sc, a, verbose), format_report(sc, b, verbose));
    EXPECT_EQ(format_junit(sc, a), format_junit(sc, b));
    EXPECT_EQ(format_can_log(a, "can0"), format_can_log(b, "can0"));
    EXPECT_GT(a.log.size(), 10u);
  }
}

TEST(ReplayRun, EveryExampleScenarioPasses) {
  std::size_t n = 0;
  for (const auto& f :
       std::filesystem::directory_iterator(std::string(CANDP2_SOURCE_DIR) + "/config/scenarios")) {
    if (f.path().extension() != ".json") continue;
    ++n;
    auto loaded = load_scenario(f.path().string());
    ASSERT_TRUE(std::holds_alternative<Scenario>(loaded))
        << std::get<config::ConfigError>(loaded).to_string();
    const auto& sc = std::get<Scenario>(loaded);
    const auto r = run(sc);
    EXPECT_TRUE(r.passed()) << format_report(sc, r);
    EXPECT_GT(r.expectations(), 0u) << f.path();
  }
  EXPECT_GE(n, 2u);
}

// docs/profibus.md "The line in time": the watchdog expiry at 9.6 kbit/s happens on the line in
// time only; the same scenario on the ideal line (master.baud removed) fails.
TEST(ReplayRun, WatchdogScenarioNeedsTheLineInTime) {
  auto loaded =
      load_scenario(std::string(CANDP2_SOURCE_DIR) + "/config/scenarios/line-watchdog-9600.json");
  ASSERT_TRUE(std::holds_alternative<Scenario>(loaded))
      << std::get<config::ConfigError>(loaded).to_string();
  const auto& timed = std::get<Scenario>(loaded);
  ASSERT_TRUE(timed.installation.line);
  const auto r = run(timed);
  EXPECT_TRUE(r.passed()) << format_report(timed, r);
  Scenario ideal = timed;
  ideal.installation.line.reset();
  const auto i = run(ideal);
  EXPECT_FALSE(i.passed()) << format_report(ideal, i);
}

TEST(ReplayRun, JunitEscapesAndUnreadableScenario) {
  const auto e = format_junit_error("a<b>.json", {"a<b>.json", "$.x", "bad \"thing\" & more"});
  EXPECT_NE(e.find(R"(errors="1")"), std::string::npos);
  EXPECT_NE(e.find("a&lt;b&gt;.json: $.x: bad &quot;thing&quot; &amp; more"), std::string::npos)
      << e;
  auto missing = load_scenario("/nonexistent/x.json");
  ASSERT_TRUE(std::holds_alternative<config::ConfigError>(missing));
  EXPECT_NE(std::get<config::ConfigError>(missing).message.find("cannot open"), std::string::npos);
}

// docs/faults.md "Line faults": every line fault scenario holds its exact counters, and a second
// run gives the same report to the microsecond (faults on cue, the same in every run).
TEST(ReplayRun, LineFaultScenariosAreExactAndRepeatable) {
  for (const char* name : {"corrupt", "silent", "late", "double-address", "noise"}) {
    auto loaded = load_scenario(std::string(CANDP2_SOURCE_DIR) + "/config/scenarios/line-fault-" +
                                name + ".json");
    ASSERT_TRUE(std::holds_alternative<Scenario>(loaded))
        << std::get<config::ConfigError>(loaded).to_string();
    const auto& sc = std::get<Scenario>(loaded);
    const auto first = run(sc), second = run(sc);
    EXPECT_TRUE(first.passed()) << format_report(sc, first);
    EXPECT_EQ(format_report(sc, first), format_report(sc, second)) << name;
    // On the ideal line the scenario cannot run: the line has no time to be faulty in.
    Scenario ideal = sc;
    ideal.installation.line.reset();
    EXPECT_FALSE(run(ideal).passed()) << name;
  }
}

// docs/replay-format.md "The line in time": the parser gives the plant's LineFault, its kind an enum
// (noise included), which the control surface takes as it is.
TEST(ScenarioParse, ALineFaultIsTheEnumFromTheParserOn) {
  const auto kind_of = [](const char* name) {
    auto loaded = load_scenario(std::string(CANDP2_SOURCE_DIR) + "/config/scenarios/line-fault-" +
                                name + ".json");
    EXPECT_TRUE(std::holds_alternative<Scenario>(loaded)) << name;
    for (const auto& st : std::get<Scenario>(loaded).steps)
      if (st.action == Action::LineFault && st.line_fault.kind != plant::LineFaultKind::None)
        return st.line_fault.kind;
    return plant::LineFaultKind::None;
  };
  EXPECT_EQ(kind_of("noise"), plant::LineFaultKind::Noise);
  EXPECT_EQ(kind_of("corrupt"), plant::LineFaultKind::Corrupt);
  EXPECT_EQ(kind_of("double-address"), plant::LineFaultKind::DoubleAddress);
  for (const auto k :
       {plant::LineFaultKind::None, plant::LineFaultKind::Late, plant::LineFaultKind::Noise})
    EXPECT_EQ(plant::line_fault_kind(plant::to_string(k)), k);
  EXPECT_FALSE(plant::line_fault_kind("noisy"));
}

}  // namespace
}  // namespace candp2::replay
