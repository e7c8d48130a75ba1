// candp2d's HTTP face (docs/daemon.md "HTTP face"): the live front panel page, GET /api/v1/status,
// GET /metrics and the page's Server-Sent Events (GET /api/v1/events), on libmicrohttpd inside
// the daemon's one event loop.
//
// Connections are ours: we accept them (net/tcp_listener.hpp) and hand each to libmicrohttpd
// (MHD_add_connection; it has no listening socket of its own), so the limit and which connection
// gives way are decided here (http/client_table.hpp): at max_clients a new connection evicts the
// one waiting longest for a request; a connection without a complete request for idle_timeout is
// closed, also when its header trickles in a byte at a time. libmicrohttpd runs in external epoll
// mode (MHD_USE_EPOLL without an internal thread): its epoll descriptor is watched by our
// EventLoop, MHD_run() is called when it is readable, after every change we make to its
// connections, and when MHD_get_timeout() says. No threads.
//
// Read-only: GET and HEAD only (anything else: 405 with "Allow: GET, HEAD"); unknown paths 404.
//
// Snapshot work never takes a loop turn for long (docs/daemon.md "Cost"): the live view
// (http/live_view.hpp) and GET /api/v1/status (http/status_build.hpp) are built in small steps,
// run right after a master cycle and, when the next cycle is far enough away, in later loop turns,
// within a budget of a quarter of the cycle per turn. Each Server-Sent Events stream gets the
// changes since its last event, composed only when its connection can take more; a stream with
// nothing to send is suspended (MHD_suspend_connection) until the next round is published.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
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
    Duration push_interval = milliseconds(200);  // live-view rounds at most this often
    std::size_t max_clients = 64;                // http.max_clients
    Duration idle_timeout = seconds(60);         // http.idle_timeout_s; 0 = never
    // A burst of a thousand connections queues in the kernel instead of SYNs being dropped and
    // retried a second later (candp2d accepts 64 a loop turn); Linux caps it at somaxconn.
    int backlog = 1024;
    // The master's cycle: snapshot work gets a quarter of it per loop turn (100 µs .. 2 ms).
    Duration cycle = milliseconds(10);
    // When the next master cycle is due; snapshot work outside after_cycle() runs only when it is
    // at least two budgets away. Empty: no cycle to protect.
    std::function<std::optional<Time>()> next_cycle;
    // The clock of the documents (the plant's time: candp2d's simulated clock, docs/daemon.md
    // "Host stalls"). Empty: the loop's.
    std::function<Time()> now = {};
  };

  // nullptr and *error ("cannot listen on 127.0.0.1:8080") on failure.
  static std::unique_ptr<HttpServer> listen(Options options, EventLoop& loop, StatusModel& model,
                                            LogSink* log, std::string* error);
  virtual ~HttpServer() = default;
  virtual std::uint16_t port() const = 0;
  virtual std::size_t sse_clients() const = 0;
  virtual std::size_t connections() const = 0;

  // Called by the daemon right after each master cycle: starts a live-view round when
  // push_interval has passed and a stream is open, and runs snapshot work within the budget. The
  // whole cycle period lies ahead, so this work cannot delay a cycle start.
  virtual void after_cycle(Time now) = 0;
};

}  // namespace candp2::http
