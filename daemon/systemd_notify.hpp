// candp2d under systemd (docs/daemon.md#systemd): the sd_notify(3) protocol of a Type=notify
// service, driven by the daemon's one event loop (no threads).
//
//   READY=1      once Daemon::start() has opened every listener (Modbus, socketcand exports),
//                with the addresses actually bound (a listener may ask for port 0) in variables
//                of our own, X_ as sd_notify(3) recommends:
//                  X_CANDP2_MODBUS=127.0.0.1:40313
//                  X_CANDP2_HTTP=127.0.0.1:40315           (only with http.listen)
//                  X_CANDP2_SOCKETCAND=can0=127.0.0.1:40314,can1=...   (exported virtual buses)
//                The candp2 Python package waits for this datagram (docs/python.md).
//   STATUS=...   "1 gateway, 1 in Data_Exch, 2 Modbus clients", re-sent when it changes (checked
//                every second)
//   STOPPING=1   on SIGTERM/SIGINT, before the shutdown
//   WATCHDOG=1   every WatchdogSec/2 when the unit asks for it (sd_watchdog_enabled(3))
//
// Outside systemd (no NOTIFY_SOCKET) nothing is sent and no timer is armed.
#pragma once

#include <cstddef>
#include <string>

#include "common/log.hpp"
#include "daemon/daemon.hpp"
#include "event_loop/event_loop.hpp"

namespace candp2::daemon {

// "3 gateways, 3 in Data_Exch, 2 Modbus clients" (singular for 1); with generic slaves
// "1 gateway, 2 generic slaves, 3 in Data_Exch, ..." (in Data_Exch: of all the master's stations).
std::string status_summary(std::size_t gateways, std::size_t slaves, std::size_t in_data_exch,
                           std::size_t modbus_clients);
std::string status_summary(Daemon& daemon);

// The X_CANDP2_* lines of the READY=1 datagram (above), without a final newline.
std::string listen_assignments(Daemon& daemon, const config::DaemonConfig& config);

class SystemdNotifier {
 public:
  SystemdNotifier(EventLoop& loop, LogSink* log);
  ~SystemdNotifier();
  SystemdNotifier(const SystemdNotifier&) = delete;
  SystemdNotifier& operator=(const SystemdNotifier&) = delete;

  // READY=1 with the first STATUS= and the bound addresses; arms the status and watchdog timers.
  // `daemon` must outlive the notifier or stopping() must be called first.
  void ready(Daemon& daemon, const config::DaemonConfig& config);
  // STATUS= for a failed start (the daemon exits right after).
  void failed(const std::string& why);
  // STOPPING=1 (once); cancels the timers.
  void stopping();

 private:
  void update_status();
  void send(const std::string& state);

  EventLoop& loop_;
  Logger log_;
  bool enabled_ = false;  // NOTIFY_SOCKET is set
  bool stopped_ = false;
  Daemon* daemon_ = nullptr;
  std::string status_;
  EventLoop::TimerId status_timer_ = 0;
  EventLoop::TimerId watchdog_timer_ = 0;
};

}  // namespace candp2::daemon
