// candp2-drive: a simulated Unitek DS/BAMOCAR servo drive on a real or remote CAN bus.
//
//   candp2-drive --socketcan vcan0
//   candp2-drive --socketcand 127.0.0.1:29536/vcan0 --rx-id 0x210 --tx-id 0x190 --state
//   drive.eeprom
//
// The application layer: owns the clock (steady_clock, microseconds since start), the channel and
// the poll() loop; the simulator core (UnitekDrive) stays pure.
#include <poll.h>
#include <signal.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "can/channel.hpp"
#include "can/socketcan.hpp"
#include "can/socketcand.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "drive_sim/file_parameter_store.hpp"
#include "drive_sim/unitek_drive.hpp"
#include "logsink/spdlog_sink.hpp"
#include "version/version.hpp"

namespace {

using namespace candp2;

// "0x201", "513": an 11-bit identifier.
std::optional<std::uint32_t> parse_id(const std::string& s) {
  try {
    std::size_t used = 0;
    const unsigned long v = std::stoul(s, &used, 0);
    if (used != s.size() || v > can::kMaxStdId) return std::nullopt;
    return static_cast<std::uint32_t>(v);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

struct SocketcandTarget {
  std::string host;
  std::uint16_t port = 29536;
  std::string channel = "vcan0";
};

// HOST:PORT[/CHANNEL]
std::optional<SocketcandTarget> parse_socketcand(const std::string& spec) {
  SocketcandTarget t;
  std::string rest = spec;
  if (const auto slash = rest.find('/'); slash != std::string::npos) {
    t.channel = rest.substr(slash + 1);
    rest = rest.substr(0, slash);
    if (t.channel.empty()) return std::nullopt;
  }
  const auto colon = rest.rfind(':');
  if (colon == std::string::npos || colon == 0) return std::nullopt;
  t.host = rest.substr(0, colon);
  try {
    std::size_t used = 0;
    const std::string port = rest.substr(colon + 1);
    const unsigned long p = std::stoul(port, &used, 10);
    if (used != port.size() || p == 0 || p > 65535) return std::nullopt;
    t.port = static_cast<std::uint16_t>(p);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  return t;
}

// The command line.
struct Options {
  std::string socketcan_if;
  std::string socketcand_spec;
  std::string rx_text = "0x201";
  std::string tx_text = "0x181";
  std::string state_file;
  std::string log_level = "info";
  std::string name = "drive";
  bool status_16bit = false;
  unsigned reference_ms = 500;
};

void add_options(CLI::App& app, Options& o) {
  app.set_version_flag("--version", candp2::version_line("candp2-drive"));
  auto* transport = app.add_option_group("transport", "the CAN bus to join");
  transport->add_option("--socketcan", o.socketcan_if, "SocketCAN interface, e.g. vcan0");
  transport->add_option("--socketcand", o.socketcand_spec,
                        "socketcand server HOST:PORT[/CHANNEL] (channel default vcan0)");
  transport->require_option(1);
  app.add_option("--rx-id", o.rx_text, "receive identifier (manual range 0x201..0x27F)")
      ->capture_default_str();
  app.add_option("--tx-id", o.tx_text, "transmit identifier (manual range 0x181..0x1FF)")
      ->capture_default_str();
  app.add_option("--state", o.state_file,
                 "parameter memory file: loaded at start, written by REGID 0x84 (EEPROM write)");
  app.add_option("--name", o.name, "name used in log lines")->capture_default_str();
  app.add_flag("--status-16bit", o.status_16bit,
               "send STATUS 0x40 / ERR_BITMAP1 0x8F as 16-bit replies (manual V1 1011 examples)");
  app.add_option("--reference-ms", o.reference_ms, "duration of the simulated reference run")
      ->capture_default_str()
      ->check(CLI::Range(0u, 600000u));
  app.add_option("--log-level", o.log_level, "trace, debug, info, warn, error")
      ->capture_default_str()
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
}

// SIGINT/SIGTERM arrive on a signalfd polled with the channel: no races, no async handlers.
// -1 (logged) when they cannot be blocked or the descriptor cannot be made.
int signal_fd(Logger& log) {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  if (sigprocmask(SIG_BLOCK, &signals, nullptr) != 0) {
    log.error("cannot block SIGINT/SIGTERM");
    return -1;
  }
  const int sig_fd = signalfd(-1, &signals, SFD_CLOEXEC | SFD_NONBLOCK);
  if (sig_fd < 0) log.error("signalfd failed");
  return sig_fd;
}

// Runs the drive on the channel until a signal (0) or a channel without a valid descriptor (1).
int serve(drive::UnitekDrive& sim, can::Channel& channel, int sig_fd, Logger& log) {
  const auto t0 = std::chrono::steady_clock::now();
  auto now = [&] {
    return std::chrono::duration_cast<Time>(std::chrono::steady_clock::now() - t0);
  };
  sim.advance(now(), channel);

  can::BusState last_state = channel.bus_state();
  for (;;) {
    while (auto frame = channel.receive()) sim.on_frame(*frame, now(), channel);
    sim.advance(now(), channel);
    if (const auto state = channel.bus_state(); state != last_state) {
      log.warn("bus state " + std::string(to_string(last_state)) + " -> " +
               std::string(to_string(state)));
      last_state = state;
    }

    // Sleep until a frame arrives, a signal, or the drive's next deadline (at most 1 s).
    int timeout_ms = 1000;
    if (const auto deadline = sim.next_deadline()) {
      const auto wait = *deadline - now();
      timeout_ms =
          wait.count() <= 0
              ? 0
              : static_cast<int>(std::min<std::int64_t>(1000, (wait.count() + 999) / 1000));
    }
    pollfd fds[2] = {{sig_fd, POLLIN, 0}, {channel.poll_fd(), POLLIN, 0}};
    const nfds_t nfds = channel.poll_fd() >= 0 ? 2 : 1;
    if (nfds == 1) timeout_ms = std::min(timeout_ms, 10);  // in-process channel: drain often
    const int rc = poll(fds, nfds, timeout_ms);
    if (rc < 0 && errno != EINTR) {
      log.error("poll failed");
      break;
    }
    if (rc > 0 && (fds[0].revents & POLLIN)) {
      signalfd_siginfo info{};
      if (read(sig_fd, &info, sizeof info) == static_cast<ssize_t>(sizeof info))
        log.info(std::string("signal ") + (info.ssi_signo == SIGINT ? "SIGINT" : "SIGTERM") +
                 ", exiting");
      break;
    }
    if (rc > 0 && nfds == 2 && (fds[1].revents & POLLNVAL)) {
      log.error("the CAN channel " + std::string(channel.name()) + " has no valid descriptor");
      return 1;
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"candp2-drive: a simulated Unitek DS/BAMOCAR servo drive (REGID protocol)"};
  Options o;
  add_options(app, o);
  CLI11_PARSE(app, argc, argv);

  const auto rx = parse_id(o.rx_text);
  const auto tx = parse_id(o.tx_text);
  if (!rx || !tx) {
    std::fprintf(stderr,
                 "candp2-drive: --rx-id/--tx-id must be 11-bit identifiers (0x000..0x7FF)\n");
    return 2;
  }
  std::optional<SocketcandTarget> remote;
  if (!o.socketcand_spec.empty()) {
    remote = parse_socketcand(o.socketcand_spec);
    if (!remote) {
      std::fprintf(stderr, "candp2-drive: --socketcand expects HOST:PORT[/CHANNEL], got '%s'\n",
                   o.socketcand_spec.c_str());
      return 2;
    }
  }

  auto logger = spdlog::stderr_color_mt("candp2-drive");
  // The shared spdlog sink (logsink/spdlog_sink.hpp) on a coloured stderr logger; --log-level is
  // checked by CLI11 above, so parse_level() always answers.
  candp2::logsink::SpdlogSink sink(*candp2::logsink::parse_level(o.log_level), logger);
  Logger log(&sink, "main");

  const int sig_fd = signal_fd(log);
  if (sig_fd < 0) return 1;

  std::string error;
  std::unique_ptr<can::Channel> channel;
  if (remote) {
    channel = can::connect_socketcand(remote->host, remote->port, remote->channel, &error);
  } else {
    channel = can::open_socketcan(o.socketcan_if, &error);
  }
  if (!channel) {
    log.error(error);
    return 1;
  }
  log.info("joined " + std::string(channel->name()));

  std::unique_ptr<drive::FileParameterStore> store;
  if (!o.state_file.empty()) store = std::make_unique<drive::FileParameterStore>(o.state_file);

  drive::UnitekDrive::Options options;
  options.rx_id = *rx;
  options.tx_id = *tx;
  options.name = o.name;
  options.status_16bit = o.status_16bit;
  options.reference_run_time = milliseconds(o.reference_ms);
  drive::UnitekDrive sim(options, &sink, store.get());
  if (sim.rx_id() != *rx || sim.tx_id() != *tx)
    log.warn("identifiers from the state file take precedence over --rx-id/--tx-id");

  const int rc = serve(sim, *channel, sig_fd, log);
  close(sig_fd);
  return rc;
}
