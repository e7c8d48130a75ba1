// candp2d: the CAN-DP/2 emulator daemon (docs/daemon.md).
//
//   candp2d --config FILE              run
//   candp2d --config FILE --check      validate the configuration and exit
//   candp2d --config FILE --print-modbus-map [--json]
//   candp2d                            run the built-in default (config/demo.json)
//   candp2d --version                  version and source revision
//
// Under systemd (Type=notify, packaging/systemd/candp2d.service) it reports READY=1, STATUS=,
// STOPPING=1 and WATCHDOG=1 (daemon/systemd_notify.hpp) and logs in journald's format.
//
// Exit status: 0 success, 1 the daemon could not start (port in use, CAN interface missing),
// 2 bad command line or configuration.
#include <signal.h>
#include <systemd/sd-daemon.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>
#include <map>

#include "config/config.hpp"
#include "daemon/daemon.hpp"
#include "daemon/default_config.hpp"
#include "daemon/systemd_notify.hpp"
#include "event_loop/event_loop.hpp"
#include "logsink/spdlog_sink.hpp"
#include "modbus/map_json.hpp"
#include "modbus/map_report.hpp"
#include "version/version.hpp"

namespace {

constexpr int kExitStart = 1;
// Warnings of one kind beyond this many are summed up in one line (docs/configuration.md
// "Warnings"); `candp2 validate` lists them all.
constexpr std::size_t kWarningsPerKind = 20;
constexpr int kExitUsage = 2;

// Messages written to stderr before the log sink exists: with a syslog priority prefix when
// stderr is the journal (sd-daemon.h), so warnings and errors keep their level there.
std::string prefix(const char* priority) {
  static const bool journal = candp2::logsink::stderr_is_journal();
  return journal ? priority : "";
}

// Writes the configuration's warnings to stderr, at most kWarningsPerKind of a kind and then one
// line with the count of the rest; with `invalid_are_errors` a warning that makes the
// configuration invalid (a station's rejection, a watchdog that can never hold) is an error line.
// Returns how many of each kind there are.
std::map<candp2::config::WarningKind, std::size_t> print_warnings(
    const candp2::config::DaemonConfig& config, bool invalid_are_errors) {
  using candp2::config::WarningKind;
  std::map<WarningKind, std::size_t> count;
  for (const auto& w : config.warnings) {
    const bool error = invalid_are_errors && candp2::config::makes_invalid(w.kind);
    if (++count[w.kind] > kWarningsPerKind && w.kind != WarningKind::Other && !error) continue;
    std::cerr << prefix(error ? SD_ERR : SD_WARNING)
              << "candp2d: " << (error ? "error: " : "warning: ") << w.to_string() << "\n";
  }
  static constexpr auto what = [](WarningKind k) {
    switch (k) {
      case WarningKind::Overlap:
        return "overlapping PLC addresses";
      case WarningKind::Rejected:
        return "rejected stations";
      default:
        return "watchdogs too short";
    }
  };
  for (const auto& [kind, n] : count)
    if (n > kWarningsPerKind && kind != WarningKind::Other)
      std::cerr << prefix(SD_WARNING) << "candp2d: warning: " << config.file << ": "
                << n - kWarningsPerKind << " more warnings like these (" << what(kind)
                << "); candp2 validate " << config.file << " lists them all\n";
  return count;
}

int run(const candp2::config::DaemonConfig& config, candp2::LogLevel level) {
  using namespace candp2;
  logsink::SpdlogSink sink(level);
  Logger log(&sink, "candp2d");
  // Sockets are written with MSG_NOSIGNAL; a stray SIGPIPE must still never end the daemon.
  ::signal(SIGPIPE, SIG_IGN);
  EventLoop loop(&sink);
  daemon::SystemdNotifier systemd(loop, &sink);
  std::string error;
  for (int signo : {SIGTERM, SIGINT})
    if (!loop.add_signal(
            signo,
            [&](int) {
              systemd.stopping();
              loop.stop();
            },
            &error)) {
      log.error(error);
      return kExitStart;
    }
  std::unique_ptr<daemon::Daemon> d;
  if (!loop.add_signal(
          SIGHUP,
          [&](int) {
            if (d) d->reopen_can_log();
          },
          &error)) {
    log.error(error);
    return kExitStart;
  }
  log.info(version_line("candp2d") + " starting with " + config.file);
  d = daemon::Daemon::start(config, loop, &sink, &error);
  if (!d) {
    log.error("cannot start: " + error);
    systemd.failed(error);
    return kExitStart;
  }
  log.info("ready: " + d->listening());
  // Every listener is open now: READY=1 (Type=notify).
  systemd.ready(*d, config);
  loop.run();
  systemd.stopping();
  d->shutdown();
  d.reset();
  log.info("stopped");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "candp2d - emulator of the esd CAN-DP/2 PROFIBUS-DP/CAN gateway: a simulated DP master "
      "cycles the emulated gateways, serves the PLC process image over Modbus/TCP and connects "
      "each gateway to a CAN bus (virtual, SocketCAN or socketcand)."};
  app.set_version_flag("--version", candp2::version_line("candp2d"));
  std::string file;
  bool check = false;
  bool print_map = false;
  bool json = false;
  std::string level_override;
  app.add_option("-c,--config", file,
                 "JSON configuration file (docs/configuration.md); without it the built-in "
                 "default runs: a gateway and two simulated drives on a virtual bus "
                 "(config/demo.json), Modbus on 127.0.0.1:1502, socketcand on "
                 "127.0.0.1:29536");
  app.add_flag("--check", check, "validate the configuration, print warnings, and exit");
  auto* map_flag = app.add_flag("--print-modbus-map", print_map,
                                "print the Modbus register map of the configuration and exit");
  app.add_flag("--json", json,
               "with --print-modbus-map: the map as JSON, every register number a client needs "
               "(docs/modbus.md)")
      ->needs(map_flag);
  app.add_option("--log-level", level_override,
                 "override log.level: trace, debug, info, warn, error");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : kExitUsage;
  }

  const auto loaded = file.empty()
                          ? candp2::config::parse_daemon(candp2::daemon::kDefaultConfig,
                                                         candp2::daemon::kDefaultConfigName)
                          : candp2::config::load_daemon(file);
  if (const auto* err = std::get_if<candp2::config::ConfigError>(&loaded)) {
    std::cerr << prefix(SD_ERR) << "candp2d: error: " << err->to_string() << "\n";
    return kExitUsage;
  }
  const auto& config = std::get<candp2::config::DaemonConfig>(loaded);
  // With --check a configuration a gateway or slave rejects, or with a watchdog that can never
  // hold, is an error, the verdict of `candp2 validate` (docs/validate.md "One verdict"); running,
  // it is a warning: a test may configure a rejected station or a watchdog expiry on purpose.
  auto counts = print_warnings(config, check);
  const std::size_t rejected = counts[candp2::config::WarningKind::Rejected];
  const std::size_t unholdable = counts[candp2::config::WarningKind::Unholdable];

  const std::string level_name = level_override.empty() ? config.log_level : level_override;
  const auto level = candp2::logsink::parse_level(level_name);
  if (!level) {
    std::cerr << prefix(SD_ERR)
              << "candp2d: error: --log-level: expected trace, debug, info, warn or error, got \""
              << level_name << "\"\n";
    return kExitUsage;
  }
  if (check && (rejected || unholdable)) {
    std::cout << config.file << ": configuration invalid (";
    if (rejected)
      std::cout << rejected << " station(s) would reject their parameters or configuration"
                << (unholdable ? ", " : "");
    if (unholdable) std::cout << unholdable << " watchdog(s) can never hold";
    std::cout << ", as candp2 validate says)\n";
    return kExitStart;
  }
  if (check) {
    std::cout << config.file << ": configuration OK (" << config.gateways.size() << " gateway(s), "
              << (config.slaves.empty()
                      ? std::string()
                      : std::to_string(config.slaves.size()) + " generic slave(s), ")
              << config.buses.size() << " bus(es), " << config.warnings.size() << " warning(s))\n";
    return 0;
  }
  if (print_map) {
    std::cout << (json ? candp2::modbus::map_json_text(config) : candp2::modbus::map_text(config));
    return 0;
  }
  return run(config, *level);
}
