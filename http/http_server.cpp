#include "http/http_server.hpp"

#include <arpa/inet.h>
#include <microhttpd.h>
#include <netinet/in.h>

#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <list>
#include <unordered_map>

#include "http/web/assets.hpp"
#include "net/tcp_listener.hpp"

namespace candp2::http {

namespace {

// One SSE stream. `current` is being written from `offset`; `next` is the newest snapshot not yet
// started (replaced, not queued, when a newer one arrives).
struct SseClient {
  MHD_Connection* connection = nullptr;
  std::shared_ptr<const std::string> current;
  std::size_t offset = 0;
  std::shared_ptr<const std::string> next;
  bool suspended = false;
};

// A GET /api/v1/status parked until the end of the next master cycle.
struct PendingStatus {
  MHD_Connection* connection = nullptr;
  std::shared_ptr<const std::string> body;  // set when answered
};

class HttpServerImpl;

struct SseContext {
  HttpServerImpl* server;
  SseClient* client;
};

class HttpServerImpl final : public HttpServer {
 public:
  HttpServerImpl(Options o, EventLoop& loop, StatusModel& model, LogSink* log)
      : options_(std::move(o)), loop_(loop), model_(model), log_(log, "http") {}

  ~HttpServerImpl() override {
    if (timeout_timer_) loop_.cancel_timer(timeout_timer_);
    if (epoll_fd_ >= 0) loop_.remove_fd(epoll_fd_);
    if (daemon_) {
      // MHD: suspended connections must be resumed before MHD_stop_daemon; the streams end.
      closing_ = true;
      for (auto& [c, client] : clients_)
        if (client->suspended) {
          client->suspended = false;
          MHD_resume_connection(client->connection);
        }
      for (auto& p : pending_)
        if (!p.body) MHD_resume_connection(p.connection);
      MHD_stop_daemon(daemon_);
    }
  }

  bool start(std::string* error) {
    // The listening socket comes from the helper both faces share (net/tcp_listener.hpp);
    // libmicrohttpd owns it from here on (it closes it in MHD_stop_daemon).
    auto listener = net::TcpListener::listen(options_.host, options_.port, options_.backlog, error);
    if (!listener) return false;
    daemon_ = MHD_start_daemon(
        MHD_USE_EPOLL | MHD_ALLOW_SUSPEND_RESUME | MHD_USE_ERROR_LOG, options_.port, nullptr,
        nullptr, &HttpServerImpl::on_request, this,
        // the logger first: MHD reports option errors through the logger set before them
        MHD_OPTION_EXTERNAL_LOGGER, &HttpServerImpl::on_mhd_log, this, MHD_OPTION_LISTEN_SOCKET,
        listener->fd(), MHD_OPTION_CONNECTION_LIMIT, options_.max_connections,
        MHD_OPTION_CONNECTION_TIMEOUT, options_.connection_timeout_s, MHD_OPTION_END);
    if (!daemon_) {
      *error = "cannot serve HTTP on " + options_.host + ":" + std::to_string(listener->port()) +
               " (libmicrohttpd refused)";
      return false;
    }
    listener->release();
    const auto* info = MHD_get_daemon_info(daemon_, MHD_DAEMON_INFO_EPOLL_FD);
    const auto* port = MHD_get_daemon_info(daemon_, MHD_DAEMON_INFO_BIND_PORT);
    if (!info || !port) {
      *error = "libmicrohttpd gave no epoll descriptor";
      return false;
    }
    epoll_fd_ = info->epoll_fd;
    port_ = port->port;
    if (!loop_.add_fd(
            epoll_fd_, EventLoop::kReadable, [this](std::uint32_t) { run(); }, error))
      return false;
    rearm_timeout();
    return true;
  }

  std::uint16_t port() const override { return port_; }
  std::size_t sse_clients() const override { return clients_.size(); }
  void after_cycle(Time now) override {
    bool waiting = false;
    for (const auto& p : pending_) waiting = waiting || !p.body;
    if (waiting) {
      auto body = std::make_shared<const std::string>(model_.status(loop_.now()).dump() + "\n");
      for (auto& p : pending_)
        if (!p.body) {
          p.body = body;
          MHD_resume_connection(p.connection);
        }
    }
    if (!clients_.empty() && now - last_push_ >= options_.push_interval) {
      last_push_ = now;
      push();
    } else if (waiting) {
      run();
    }
  }

 private:
  void run() {
    MHD_run(daemon_);
    rearm_timeout();
  }

  void rearm_timeout() {
    if (timeout_timer_) loop_.cancel_timer(timeout_timer_);
    timeout_timer_ = 0;
    MHD_UNSIGNED_LONG_LONG ms = 0;
    if (MHD_get_timeout(daemon_, &ms) != MHD_YES) return;  // nothing to time out
    timeout_timer_ = loop_.add_timer(milliseconds(static_cast<std::int64_t>(ms)), [this] {
      timeout_timer_ = 0;
      run();
    });
  }

  // Once per push interval, only when a stream is open: one snapshot for everyone.
  void push() {
    if (clients_.empty()) return;
    const Time t0 = EventLoop::monotonic_now();
    auto snap = std::make_shared<const std::string>(
        "event: status\ndata: " + model_.status(loop_.now()).dump() + "\n\n");
    auto& counters = model_.http_counters();
    counters.last_build_us = static_cast<std::uint64_t>((EventLoop::monotonic_now() - t0).count());
    ++counters.snapshots;
    for (auto& [c, client] : clients_) {
      if (client->next) ++counters.snapshots_dropped;  // the slow client skips it
      client->next = snap;
      if (client->suspended) {
        client->suspended = false;
        MHD_resume_connection(client->connection);
      }
    }
    run();
  }

  // MHD_ContentReaderCallback of an SSE stream.
  static ssize_t read_sse(void* cls, std::uint64_t, char* buf, std::size_t max) {
    auto* ctx = static_cast<SseContext*>(cls);
    auto& self = *ctx->server;
    SseClient& c = *ctx->client;
    if (self.closing_) return MHD_CONTENT_READER_END_OF_STREAM;
    if (!c.current || c.offset >= c.current->size()) {
      c.current = std::move(c.next);
      c.next.reset();
      c.offset = 0;
    }
    if (!c.current) {
      // Nothing new: park the connection until the next push resumes it.
      c.suspended = true;
      MHD_suspend_connection(c.connection);
      return 0;
    }
    const std::size_t n = std::min(max, c.current->size() - c.offset);
    std::memcpy(buf, c.current->data() + c.offset, n);
    c.offset += n;
    return static_cast<ssize_t>(n);
  }

  static void free_sse(void* cls) {
    auto* ctx = static_cast<SseContext*>(cls);
    ctx->server->clients_.erase(ctx->client);
    ctx->server->model_.http_counters().sse_clients = ctx->server->clients_.size();
    delete ctx;
  }

  static void on_mhd_log(void* cls, const char* fmt, va_list ap) {
    char line[512];
    std::vsnprintf(line, sizeof line, fmt, ap);
    std::string text(line);
    while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
    static_cast<HttpServerImpl*>(cls)->log_.warn("libmicrohttpd: " + text);
  }

  static MHD_Result queue(MHD_Connection* connection, unsigned status, std::string_view type,
                          std::string body, const char* allow = nullptr) {
    auto* r = MHD_create_response_from_buffer(body.size(), body.data(), MHD_RESPMEM_MUST_COPY);
    MHD_add_response_header(r, "Content-Type", std::string(type).c_str());
    MHD_add_response_header(r, "Cache-Control", "no-store");
    if (allow) MHD_add_response_header(r, "Allow", allow);
    const auto ret = MHD_queue_response(connection, status, r);
    MHD_destroy_response(r);
    return ret;
  }

  static MHD_Result on_request(void* cls, MHD_Connection* connection, const char* url,
                               const char* method, const char*, const char*, std::size_t*,
                               void** req_cls) {
    auto& self = *static_cast<HttpServerImpl*>(cls);
    if (!*req_cls) ++self.model_.http_counters().requests;
    const std::string_view m(method), path(url);
    if (m != MHD_HTTP_METHOD_GET && m != MHD_HTTP_METHOD_HEAD) {
      self.log_.debug(std::string(m) + " " + std::string(path) + ": 405 (read-only)");
      return queue(connection, MHD_HTTP_METHOD_NOT_ALLOWED, "text/plain; charset=utf-8",
                   "405 method not allowed: this interface is read-only (GET)\n", "GET, HEAD");
    }
    if (path == "/api/v1/status") {
      if (auto* p = static_cast<PendingStatus*>(*req_cls)) {  // resumed after a cycle
        *req_cls = nullptr;
        std::string body = *p->body;
        self.pending_.remove_if([p](const PendingStatus& x) { return &x == p; });
        return queue(connection, MHD_HTTP_OK, "application/json", std::move(body));
      }
      if (self.options_.status_after_cycle) {
        self.pending_.push_back({connection, nullptr});
        *req_cls = &self.pending_.back();
        MHD_suspend_connection(connection);
        return MHD_YES;
      }
      return queue(connection, MHD_HTTP_OK, "application/json",
                   self.model_.status(self.loop_.now()).dump() + "\n");
    }
    if (path == "/metrics")
      return queue(connection, MHD_HTTP_OK, "text/plain; version=0.0.4; charset=utf-8",
                   self.model_.metrics(self.loop_.now()));
    if (path == "/api/v1/events") return self.open_stream(connection);
    const std::string_view asset_path = path == "/" ? "/index.html" : path;
    for (const auto& a : web::assets())
      if (a.path == asset_path)
        return queue(connection, MHD_HTTP_OK, a.content_type,
                     std::string(reinterpret_cast<const char*>(a.body.data()), a.body.size()));
    return queue(connection, MHD_HTTP_NOT_FOUND, "text/plain; charset=utf-8",
                 "404 not found: " + std::string(path) +
                     " (try /, /api/v1/status, /api/v1/events, /metrics)\n");
  }

  MHD_Result open_stream(MHD_Connection* connection) {
    auto client = std::make_unique<SseClient>();
    client->connection = connection;
    // The first snapshot at once, so a new page is not empty for a push interval.
    client->next = std::make_shared<const std::string>(
        "retry: 1000\nevent: status\ndata: " + model_.status(loop_.now()).dump() + "\n\n");
    auto* ctx = new SseContext{this, client.get()};
    auto* r = MHD_create_response_from_callback(
        MHD_SIZE_UNKNOWN, 16 * 1024, &HttpServerImpl::read_sse, ctx, &HttpServerImpl::free_sse);
    if (!r) {
      delete ctx;
      return MHD_NO;
    }
    clients_.emplace(client.get(), std::move(client));
    model_.http_counters().sse_clients = clients_.size();
    MHD_add_response_header(r, "Content-Type", "text/event-stream");
    MHD_add_response_header(r, "Cache-Control", "no-store");
    const auto ret = MHD_queue_response(connection, MHD_HTTP_OK, r);
    MHD_destroy_response(r);  // freed (free_sse) when the connection is done with it
    return ret;
  }

  Options options_;
  EventLoop& loop_;
  StatusModel& model_;
  Logger log_;
  MHD_Daemon* daemon_ = nullptr;
  int epoll_fd_ = -1;
  std::uint16_t port_ = 0;
  Time last_push_{0};
  EventLoop::TimerId timeout_timer_ = 0;
  std::unordered_map<SseClient*, std::unique_ptr<SseClient>> clients_;
  std::list<PendingStatus> pending_;  // stable addresses: MHD keeps pointers in req_cls
  bool closing_ = false;
};

}  // namespace

std::unique_ptr<HttpServer> HttpServer::listen(Options options, EventLoop& loop, StatusModel& model,
                                               LogSink* log, std::string* error) {
  auto s = std::make_unique<HttpServerImpl>(std::move(options), loop, model, log);
  std::string e;
  if (!s->start(&e)) {
    if (error) *error = e;
    return nullptr;
  }
  return s;
}

}  // namespace candp2::http
