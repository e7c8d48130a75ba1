// candp2d's HTTP face (docs/daemon.md "HTTP face"): the live front panel page, GET /api/v1/status,
// GET /metrics and the page's Server-Sent Events (GET /api/v1/events), on libmicrohttpd inside
// the daemon's one event loop.
//
// libmicrohttpd runs in external epoll mode (MHD_USE_EPOLL without an internal thread): its epoll
// descriptor is watched by our EventLoop, MHD_run() is called when it is readable, and
// MHD_get_timeout() arms a loop timer for connection timeouts. No threads.
//
// Read-only: GET and HEAD only (anything else: 405 with "Allow: GET, HEAD"); unknown paths 404.
//
// Server-Sent Events: every push interval (counted in master cycles, see after_cycle) one snapshot
// (StatusModel::status) is serialized once and shared by every SSE client (a shared_ptr, not a
// copy). Each client holds at most the snapshot being written and the newest one waiting: a slow
// client skips intermediate snapshots, so its memory never grows. A client with nothing to send is
// suspended (MHD_suspend_connection) and resumed at the next push, so idle streams cost nothing
// between pushes.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "common/log.hpp"
#include "event_loop/event_loop.hpp"
#include "http/http_status.hpp"

namespace candp2::http {

class HttpServer {
 public:
  struct Options {
    std::string host = "127.0.0.1";              // numeric IPv4
    std::uint16_t port = 8080;                   // 0 = any free port (see port())
    Duration push_interval = milliseconds(200);  // SSE snapshots at most this often
    unsigned max_connections = 64;
    int backlog = 128;  // connection bursts queue instead of retrying SYNs after 1 s
    unsigned connection_timeout_s = 60;  // idle keep-alive connections
    // GET /api/v1/status waits for the end of the next master cycle (after_cycle) and is answered
    // there, all waiting requests with one snapshot, so building it never delays a cycle start.
    // Only sensible when cycles are short (the daemon sets it for cycle_ms <= 100).
    bool status_after_cycle = false;
  };

  // nullptr and *error ("cannot listen on 127.0.0.1:8080") on failure.
  static std::unique_ptr<HttpServer> listen(Options options, EventLoop& loop, StatusModel& model,
                                            LogSink* log, std::string* error);
  virtual ~HttpServer() = default;
  virtual std::uint16_t port() const = 0;
  virtual std::size_t sse_clients() const = 0;

  // Called by the daemon right after each master cycle: pushes a snapshot when push_interval has
  // passed since the last one. Building the snapshot right after a cycle leaves it the whole
  // cycle period before the next one, so it never delays a cycle start (docs/daemon.md).
  virtual void after_cycle(Time now) = 0;
};

}  // namespace candp2::http
