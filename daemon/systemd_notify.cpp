#include "daemon/systemd_notify.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string_view>

namespace candp2::daemon {

namespace {

// How often the status summary is compared with the last one sent (cheap: a few counters).
constexpr Duration kStatusPeriod = milliseconds(1000);

// sd_notify(3), whose protocol systemd documents as stable for programs that speak it without
// libsystemd: one datagram with the state lines to the AF_UNIX socket $NOTIFY_SOCKET (a path, or
// "@name" in the abstract namespace). Done here so that candp2d does not load libsystemd and the
// seven libraries it pulls in (docs/daemon.md "systemd"). 0 = no NOTIFY_SOCKET, 1 sent, < 0 -errno.
int notify(std::string_view state) {
  const char* socket_path = std::getenv("NOTIFY_SOCKET");
  if (!socket_path || !*socket_path) return 0;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::size_t len = std::strlen(socket_path);
  if ((socket_path[0] != '/' && socket_path[0] != '@') || len >= sizeof addr.sun_path)
    return -EINVAL;
  std::memcpy(addr.sun_path, socket_path, len);
  if (addr.sun_path[0] == '@') addr.sun_path[0] = '\0';
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -errno;
  const auto size = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + len);
  const ssize_t sent = ::sendto(fd, state.data(), state.size(), MSG_NOSIGNAL,
                                reinterpret_cast<const sockaddr*>(&addr), size);
  const int rc = sent < 0 ? -errno : 1;
  ::close(fd);
  return rc;
}

// sd_watchdog_enabled(3): the interval of $WATCHDOG_USEC when it is set and $WATCHDOG_PID, if
// set, is this process; else 0.
std::uint64_t watchdog_usec() {
  const char* usec = std::getenv("WATCHDOG_USEC");
  if (!usec || !*usec) return 0;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(usec, &end, 10);
  if (*end != '\0') return 0;
  if (const char* pid = std::getenv("WATCHDOG_PID"); pid && *pid) {
    const unsigned long long p = std::strtoull(pid, &end, 10);
    if (*end != '\0' || p != static_cast<unsigned long long>(::getpid())) return 0;
  }
  return v;
}

std::string count(std::size_t n, const char* singular, const char* plural) {
  std::string out = std::to_string(n);
  out += ' ';
  out += n == 1 ? singular : plural;
  return out;
}

}  // namespace

std::string status_summary(std::size_t gateways, std::size_t slaves, std::size_t in_data_exch,
                           std::size_t modbus_clients) {
  std::string out = count(gateways, "gateway", "gateways");
  if (slaves) out += ", " + count(slaves, "generic slave", "generic slaves");
  out += ", ";
  out += std::to_string(in_data_exch);
  out += " in Data_Exch, ";
  out += count(modbus_clients, "Modbus client", "Modbus clients");
  return out;
}

std::string status_summary(Daemon& daemon) {
  const auto slaves = daemon.master().slaves();
  std::size_t exchanging = 0;
  for (const auto& s : slaves)
    if (s.state == dp::MasterSlaveState::DataExch) ++exchanging;
  const auto& config = daemon.plant().config();
  return status_summary(config.gateways.size(), config.slaves.size(), exchanging,
                        daemon.modbus_clients());
}

std::string listen_assignments(Daemon& daemon, const config::DaemonConfig& config) {
  std::string out =
      "X_CANDP2_MODBUS=" + config.modbus_listen.host + ":" + std::to_string(daemon.modbus_port());
  if (const auto http = daemon.http_port(); http && config.http_listen)
    out += "\nX_CANDP2_HTTP=" + config.http_listen->host + ":" + std::to_string(*http);
  std::string buses;
  for (const auto& b : config.buses) {
    const auto port = daemon.socketcand_port(b.name);
    if (!port || !b.socketcand_listen) continue;
    buses += (buses.empty() ? "" : ",") + b.name + "=" + b.socketcand_listen->host + ":" +
             std::to_string(*port);
  }
  if (!buses.empty()) out += "\nX_CANDP2_SOCKETCAND=" + buses;
  return out;
}

SystemdNotifier::SystemdNotifier(EventLoop& loop, LogSink* log)
    : loop_(loop), log_(log, "systemd") {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket && *socket;
}

SystemdNotifier::~SystemdNotifier() {
  if (status_timer_) loop_.cancel_timer(status_timer_);
  if (watchdog_timer_) loop_.cancel_timer(watchdog_timer_);
}

void SystemdNotifier::send(const std::string& state) {
  const int rc = notify(state);
  if (rc < 0) log_.warn("sd_notify(" + state + "): " + std::strerror(-rc));
}

void SystemdNotifier::ready(Daemon& daemon, const config::DaemonConfig& config) {
  if (!enabled_) return;
  daemon_ = &daemon;
  status_ = status_summary(daemon);
  send("READY=1\nSTATUS=" + status_ + "\n" + listen_assignments(daemon, config));
  status_timer_ = loop_.add_periodic(kStatusPeriod, [this] { update_status(); });
  // sd_watchdog_enabled(3): > 0 when WATCHDOG_USEC is set (and WATCHDOG_PID, if set, is ours);
  // systemd recommends sending WATCHDOG=1 at half the interval.
  if (const std::uint64_t usec = watchdog_usec(); usec > 0) {
    const Duration half = microseconds(static_cast<std::int64_t>(usec / 2));
    send("WATCHDOG=1");
    watchdog_timer_ = loop_.add_periodic(half > Duration{0} ? half : microseconds(1),
                                         [this] { send("WATCHDOG=1"); });
    log_.info("watchdog every " + std::to_string(usec / 2000) + " ms");
  }
}

void SystemdNotifier::failed(const std::string& why) {
  if (enabled_) send("STATUS=cannot start: " + why);
}

void SystemdNotifier::update_status() {
  if (!daemon_) return;
  auto now = status_summary(*daemon_);
  if (now == status_) return;
  status_ = std::move(now);
  send("STATUS=" + status_);
}

void SystemdNotifier::stopping() {
  if (stopped_) return;
  stopped_ = true;
  if (status_timer_) loop_.cancel_timer(status_timer_);
  if (watchdog_timer_) loop_.cancel_timer(watchdog_timer_);
  status_timer_ = watchdog_timer_ = 0;
  daemon_ = nullptr;
  if (enabled_) send("STOPPING=1\nSTATUS=stopping");
}

}  // namespace candp2::daemon
