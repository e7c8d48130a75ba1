// candp2 replay SCENARIO: runs a scenario (docs/replay-format.md) in virtual time and reports.
// Exit status: 0 every expectation held, 1 an expectation failed, 2 the scenario cannot be used
// (unreadable, invalid JSON, wrong key) or an output file cannot be written.
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include "replay/report.hpp"
#include "replay/runner.hpp"
#include "replay/scenario.hpp"
#include "tools/candp2/commands.hpp"

namespace candp2::cli {

namespace {

struct ReplayArgs {
  std::string scenario;
  std::string junit;
  std::string can_log;
  bool verbose = false;
  bool traffic = false;
  bool quiet = false;
  std::string log_level = "info";
};

bool write_file(const std::string& path, const std::string& text, const char* what) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) {
    std::cerr << "candp2 replay: cannot write the " << what << " file " << path << "\n";
    return false;
  }
  return true;
}

LogLevel level_of(const std::string& s) {
  if (s == "trace") return LogLevel::Trace;
  if (s == "debug") return LogLevel::Debug;
  if (s == "warn") return LogLevel::Warn;
  if (s == "error") return LogLevel::Error;
  return LogLevel::Info;
}

int run_replay(const ReplayArgs& a) {
  auto loaded = replay::load_scenario(a.scenario);
  if (auto* e = std::get_if<config::ConfigError>(&loaded)) {
    std::cerr << "candp2 replay: " << e->to_string() << "\n";
    if (!a.junit.empty()) write_file(a.junit, replay::format_junit_error(a.scenario, *e), "JUnit");
    return 2;
  }
  const auto& sc = std::get<replay::Scenario>(loaded);
  const auto result = replay::run(sc, level_of(a.log_level));
  replay::ReportOptions o;
  o.verbose = a.verbose;
  o.traffic = a.traffic;
  if (!a.quiet || !result.passed()) std::cout << replay::format_report(sc, result, o);
  bool written = true;
  if (!a.junit.empty()) written &= write_file(a.junit, replay::format_junit(sc, result), "JUnit");
  if (!a.can_log.empty())
    written &= write_file(a.can_log, replay::format_can_log(sc, result), "CAN log");
  if (!written) return 2;
  return result.passed() ? 0 : 1;
}

}  // namespace

void add_replay(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<ReplayArgs>();
  auto* cmd = app.add_subcommand(
      "replay",
      "Run a scenario (gateway configuration, DP cycle, timed steps) in virtual time; exit 0 when "
      "every expectation holds, 1 when one fails, 2 when the scenario cannot be used");
  cmd->add_option("SCENARIO", args->scenario, "scenario file (docs/replay-format.md)")->required();
  cmd->add_option("--junit", args->junit, "write a JUnit XML report to this file");
  cmd->add_option("--can-log", args->can_log,
                  "write the CAN traffic as a candump log (virtual time stamps) to this file");
  cmd->add_flag("-v,--verbose", args->verbose, "print the log lines of each step under it");
  cmd->add_flag("--traffic", args->traffic, "print every CAN frame under the step that saw it");
  cmd->add_flag("-q,--quiet", args->quiet, "print the report only when an expectation fails");
  cmd->add_option("--log-level", args->log_level, "log level for --verbose")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
  cmd->callback([args, &exit_code] { exit_code = run_replay(*args); });
}

}  // namespace candp2::cli
