#include "http/http_server.hpp"

#include <microhttpd.h>
#include <sys/resource.h>
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <list>
#include <unordered_map>
#include <vector>

#include "event_loop/deadline_timer.hpp"
#include "event_loop/throttled_log.hpp"
#include "http/client_table.hpp"
#include "http/documents.hpp"
#include "http/live_view.hpp"
#include "http/web/assets.hpp"
#include "net/tcp_listener.hpp"

namespace candp2::http {

namespace {

constexpr std::size_t kAcceptBatch = 64;              // connections accepted per loop turn
constexpr Duration kAcceptPause = milliseconds(100);  // after the process ran out of descriptors
constexpr std::size_t kStreamBlock = 16 * 1024;       // libmicrohttpd's buffer for a stream
constexpr rlim_t kSpareDescriptors = 256;             // beyond max_clients: buses, Modbus, files

std::string ms_text(Duration d) {
  return std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(d).count()) + " ms";
}

struct Stream;

// One connection: its id in the ClientTable and libmicrohttpd's handle. `closing`: evicted or
// timed out (no longer in the table); libmicrohttpd closes it at its next run.
struct Conn {
  ClientTable::Id id = 0;
  int fd = -1;
  std::string peer;
  MHD_Connection* mhd = nullptr;
  Stream* stream = nullptr;
  bool closing = false;
};

// One Server-Sent Events stream: the event being written from `offset`, the live view's cursor.
struct Stream {
  Conn* conn = nullptr;
  LiveView::Cursor cursor;
  std::uint64_t first_round = 0;  // the first round that can serve it
  std::string event;
  std::size_t offset = 0;
  bool suspended = false;
  bool once = false;  // ?once: the first event only, then the end of the answer
};

// GET /api/v1/status or GET /metrics: built in steps for the requests waiting for it.
struct Document {
  bool metrics = false;
  std::unique_ptr<DocumentBuild> job;
  std::uint64_t builds = 0;  // started
  std::size_t last_size = 0;
};

// A request parked until the build numbered `build` of its document is done.
struct Pending {
  MHD_Connection* mhd = nullptr;
  Document* doc = nullptr;
  std::uint64_t build = 0;
  std::shared_ptr<const std::string> body;  // set when answered
};

class HttpServerImpl;
struct StreamContext {
  HttpServerImpl* server;
  Stream* stream;
};

class HttpServerImpl final : public HttpServer {
 public:
  HttpServerImpl(Options o, EventLoop& loop, StatusModel& model, LogSink* log)
      : options_(std::move(o)),
        loop_(loop),
        model_(model),
        log_(log, "http"),
        table_(options_.max_clients, options_.idle_timeout),
        view_(model),
        budget_(std::clamp<Duration>(options_.cycle / 4, microseconds(100), milliseconds(2))),
        idle_timer_(loop, [this] { close_idle(); }),
        notes_(loop, log_) {}

  ~HttpServerImpl() override {
    notes_.stop();
    for (auto* t : {&mhd_timer_, &work_timer_, &pause_timer_})
      if (*t) loop_.cancel_timer(*t);
    idle_timer_.disarm();
    if (listener_ && listening_) loop_.remove_fd(listener_->fd());
    if (epoll_fd_ >= 0) loop_.remove_fd(epoll_fd_);
    if (daemon_) {
      // MHD: suspended connections must be resumed before MHD_stop_daemon; the streams end.
      closing_ = true;
      for (auto& [s, stream] : streams_)
        if (stream->suspended && stream->conn) {
          stream->suspended = false;
          MHD_resume_connection(stream->conn->mhd);
        }
      for (auto& p : pending_)
        if (!p.body) MHD_resume_connection(p.mhd);
      MHD_stop_daemon(daemon_);  // closes every connection (notify CLOSED frees each Conn)
    }
  }

  bool start(std::string* error) {
    listener_ = net::TcpListener::listen(options_.host, options_.port, options_.backlog, error);
    if (!listener_) return false;
    raise_descriptor_limit();
    // No listening socket of its own: connections come through MHD_add_connection. Its limit
    // only backs ours up (evicted connections close at its next run).
    daemon_ = MHD_start_daemon(
        MHD_USE_EPOLL | MHD_ALLOW_SUSPEND_RESUME | MHD_USE_ERROR_LOG | MHD_USE_NO_LISTEN_SOCKET, 0,
        nullptr, nullptr, &HttpServerImpl::on_request, this,
        // the logger first: MHD reports option errors through the logger set before them
        MHD_OPTION_EXTERNAL_LOGGER, &HttpServerImpl::on_mhd_log, this, MHD_OPTION_CONNECTION_LIMIT,
        static_cast<unsigned>(2 * options_.max_clients + 64),
        // A response that makes no progress (a reader that stopped reading) for idle_timeout.
        MHD_OPTION_CONNECTION_TIMEOUT,
        static_cast<unsigned>(
            std::chrono::duration_cast<std::chrono::seconds>(options_.idle_timeout).count()),
        MHD_OPTION_NOTIFY_CONNECTION, &HttpServerImpl::on_connection, this,
        MHD_OPTION_NOTIFY_COMPLETED, &HttpServerImpl::on_completed, this, MHD_OPTION_END);
    if (!daemon_) {
      *error = "cannot serve HTTP on " + options_.host + ":" + std::to_string(listener_->port()) +
               " (libmicrohttpd refused)";
      return false;
    }
    const auto* info = MHD_get_daemon_info(daemon_, MHD_DAEMON_INFO_EPOLL_FD);
    if (!info) {
      *error = "libmicrohttpd gave no epoll descriptor";
      return false;
    }
    epoll_fd_ = info->epoll_fd;
    if (!loop_.add_fd(
            epoll_fd_, EventLoop::kReadable, [this](std::uint32_t) { run(); }, error))
      return false;
    if (!listen_again(error)) return false;
    rearm_mhd_timer();
    return true;
  }

  std::uint16_t port() const override { return listener_->port(); }
  std::size_t sse_clients() const override { return streams_.size(); }
  std::size_t connections() const override { return conns_.size(); }

  void after_cycle(Time now) override {
    maybe_start_round(now);
    if (has_work()) pump();
  }

 private:
  // ---------------------------------------------------------------------------- connections

  void raise_descriptor_limit() {
    rlimit r{};
    if (::getrlimit(RLIMIT_NOFILE, &r) != 0) return;
    const rlim_t want = static_cast<rlim_t>(options_.max_clients) + kSpareDescriptors;
    if (r.rlim_cur >= want) return;
    const rlim_t was = r.rlim_cur;
    r.rlim_cur = std::min(want, r.rlim_max);
    if (::setrlimit(RLIMIT_NOFILE, &r) == 0 && r.rlim_cur >= want) {
      log_.info("descriptor limit raised from " + std::to_string(was) + " to " +
                std::to_string(r.rlim_cur) + " for http.max_clients " +
                std::to_string(options_.max_clients));
      return;
    }
    log_.warn("descriptor limit " + std::to_string(was) + " (hard " + std::to_string(r.rlim_max) +
              ") is low for http.max_clients " + std::to_string(options_.max_clients) +
              ": connections beyond it are refused (raise LimitNOFILE)");
  }

  bool listen_again(std::string* error) {
    if (!loop_.add_fd(
            listener_->fd(), EventLoop::kReadable, [this](std::uint32_t) { accept_some(); }, error))
      return false;
    listening_ = true;
    return true;
  }

  void accept_some() {
    std::string error;
    const bool ok = listener_->accept_all(
        [this](int fd, const sockaddr_in& peer) { admit(fd, peer); }, &error, kAcceptBatch);
    const int e = errno;
    run();  // libmicrohttpd reads the new connections and closes the evicted ones
    if (ok) return;
    if (e == EMFILE || e == ENFILE || e == ENOBUFS || e == ENOMEM) {
      // Out of descriptors: stop accepting for a moment (the listening socket would stay
      // readable and spin the loop); the connections wait in the backlog.
      ++model_.http_counters().clients_refused;
      note("refused", "not accepting for " + ms_text(kAcceptPause) + ": " + error, LogLevel::Warn);
      loop_.remove_fd(listener_->fd());
      listening_ = false;
      pause_timer_ = loop_.add_timer(kAcceptPause, [this] {
        pause_timer_ = 0;
        std::string err;
        if (!listen_again(&err)) log_.error(err);
      });
      return;
    }
    log_.error(error);
  }

  void admit(int fd, const sockaddr_in& peer) {
    const Time now = loop_.now();
    auto& counters = model_.http_counters();
    const auto a = table_.admit(now);
    if (a.evict) {
      ++counters.clients_evicted;
      close_conn(*a.evict,
                 "evicted for a new connection (http.max_clients " +
                     std::to_string(options_.max_clients) + ", " +
                     (a.evict_was_waiting ? "waited longest for a request)"
                                          : "every connection busy, oldest request)"),
                 "evicted");
    }
    auto owned = std::make_unique<Conn>();
    Conn* c = owned.get();
    c->id = a.id;
    c->fd = fd;
    c->peer = net::peer_name(peer);
    const std::string name = c->peer;  // c is gone when libmicrohttpd refuses after STARTED
    conns_[a.id] = std::move(owned);
    adding_ = c;
    const auto ok = MHD_add_connection(daemon_, fd, reinterpret_cast<const sockaddr*>(&peer),
                                       sizeof peer);  // closes fd on failure
    const int add_errno = errno;
    adding_ = nullptr;
    if (ok != MHD_YES) {
      ++counters.clients_refused;
      note("refused",
           "connection from " + name + " refused by libmicrohttpd: " + std::strerror(add_errno),
           LogLevel::Warn);
      if (conns_.count(a.id)) forget(a.id);  // no CLOSED notification came
      return;
    }
    ++counters.clients_accepted;
    counters.connections = conns_.size();
    arm_idle_timer();
  }

  // Closes a connection we decided to close: out of the table at once; libmicrohttpd sees the
  // shut-down socket (or the stream's end) at its next run and closes it.
  void close_conn(ClientTable::Id id, const std::string& why, std::string_view kind) {
    const auto it = conns_.find(id);
    if (it == conns_.end()) return;
    Conn& c = *it->second;
    table_.remove(id);
    if (c.closing) return;
    c.closing = true;
    note(kind, "connection " + c.peer + " closed: " + why);
    ::shutdown(c.fd, SHUT_RDWR);
    if (c.stream && c.stream->suspended) {  // libmicrohttpd looks at it only when resumed
      c.stream->suspended = false;
      MHD_resume_connection(c.mhd);
    }
    kick();
  }

  void forget(ClientTable::Id id) {
    if (const auto it = conns_.find(id); it != conns_.end() && it->second->stream)
      it->second->stream->conn = nullptr;  // the stream's response may be freed after this
    table_.remove(id);
    conns_.erase(id);
    model_.http_counters().connections = conns_.size();
  }

  // Every line a client can cause by the thousand goes through the throttle (docs/daemon.md
  // "Logging"): one a second per kind, with the count.
  void note(std::string_view kind, std::string line, LogLevel level = LogLevel::Info) {
    if (!closing_) notes_.log(kind, level, std::move(line));
  }

  // One timer for the earliest idle expiry of a waiting connection (a request only moves a
  // connection's expiry later).
  void arm_idle_timer() { idle_timer_.arm_earlier(table_.next_expiry(), loop_.now()); }

  void close_idle() {
    for (const auto id : table_.expired(loop_.now())) {
      ++model_.http_counters().clients_timed_out;
      close_conn(id, "no complete request within " + ms_text(options_.idle_timeout), "idle");
    }
    arm_idle_timer();
  }

  // ---------------------------------------------------------------------- libmicrohttpd

  void run() {
    MHD_run(daemon_);
    rearm_mhd_timer();
  }

  // A run at the next loop turn, after a change libmicrohttpd must see (an eviction, a resume).
  void kick() {
    if (kick_pending_) return;
    kick_pending_ = true;
    if (mhd_timer_) loop_.cancel_timer(mhd_timer_);
    mhd_timer_ = loop_.add_timer(Duration(0), [this] {
      mhd_timer_ = 0;
      kick_pending_ = false;
      run();
    });
  }

  void rearm_mhd_timer() {
    if (kick_pending_) return;
    if (mhd_timer_) loop_.cancel_timer(mhd_timer_);
    mhd_timer_ = 0;
    MHD_UNSIGNED_LONG_LONG ms = 0;
    if (MHD_get_timeout(daemon_, &ms) != MHD_YES) return;  // nothing to time out
    mhd_timer_ = loop_.add_timer(milliseconds(static_cast<std::int64_t>(ms)), [this] {
      mhd_timer_ = 0;
      run();
    });
  }

  static Conn* conn_of(MHD_Connection* connection) {
    const auto* info = MHD_get_connection_info(connection, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
    return info ? static_cast<Conn*>(info->socket_context) : nullptr;
  }

  static void on_connection(void* cls, MHD_Connection* connection, void** socket_context,
                            MHD_ConnectionNotificationCode toe) {
    auto& self = *static_cast<HttpServerImpl*>(cls);
    if (toe == MHD_CONNECTION_NOTIFY_STARTED) {
      if (self.adding_) {
        self.adding_->mhd = connection;
        *socket_context = self.adding_;
      }
      return;
    }
    auto* c = static_cast<Conn*>(*socket_context);
    *socket_context = nullptr;
    if (c) self.forget(c->id);
  }

  static void on_completed(void* cls, MHD_Connection* connection, void** req_cls,
                           MHD_RequestTerminationCode) {
    auto& self = *static_cast<HttpServerImpl*>(cls);
    if (auto* p = static_cast<Pending*>(*req_cls)) {  // a parked request that ended early
      *req_cls = nullptr;
      self.pending_.remove_if([p](const Pending& x) { return &x == p; });
    }
    if (self.closing_) return;  // MHD_stop_daemon: no timers any more
    if (Conn* c = conn_of(connection); c && !c->closing) {
      self.table_.request_done(c->id, self.loop_.now());
      self.arm_idle_timer();
    }
  }

  static void on_mhd_log(void* cls, const char* fmt, va_list ap) {
    char line[512];
    std::vsnprintf(line, sizeof line, fmt, ap);
    std::string text(line);
    while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
    auto& self = *static_cast<HttpServerImpl*>(cls);
    self.note("libmicrohttpd", "libmicrohttpd: " + text, LogLevel::Warn);
  }

  static MHD_Result queue(MHD_Connection* connection, unsigned status, std::string_view type,
                          std::string_view body, const char* allow = nullptr) {
    auto* r = MHD_create_response_from_buffer(body.size(), const_cast<char*>(body.data()),
                                              MHD_RESPMEM_MUST_COPY);
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
    if (!*req_cls) {
      ++self.model_.http_counters().requests;
      if (Conn* c = conn_of(connection); c && !c->closing) self.table_.request_started(c->id);
    }
    const std::string_view m(method), path(url);
    if (m != MHD_HTTP_METHOD_GET && m != MHD_HTTP_METHOD_HEAD) {
      self.log_.debug(std::string(m) + " " + std::string(path) + ": 405 (read-only)");
      return queue(connection, MHD_HTTP_METHOD_NOT_ALLOWED, "text/plain; charset=utf-8",
                   "405 method not allowed: this interface is read-only (GET)\n", "GET, HEAD");
    }
    if (path == "/api/v1/status") return self.document_request(connection, req_cls, self.status_);
    if (path == "/metrics") return self.document_request(connection, req_cls, self.metrics_);
    if (path == "/api/v1/events") return self.open_stream(connection);
    const std::string_view asset_path = path == "/" ? "/index.html" : path;
    for (const auto& a : web::assets())
      if (a.path == asset_path)
        return queue(connection, MHD_HTTP_OK, a.content_type,
                     {reinterpret_cast<const char*>(a.body.data()), a.body.size()});
    return queue(connection, MHD_HTTP_NOT_FOUND, "text/plain; charset=utf-8",
                 "404 not found: " + std::string(path) +
                     " (try /, /api/v1/status, /api/v1/events, /metrics)\n");
  }

  // ------------------------------------------------------ GET /api/v1/status, GET /metrics

  MHD_Result document_request(MHD_Connection* connection, void** req_cls, Document& doc) {
    if (auto* p = static_cast<Pending*>(*req_cls)) {  // resumed: the document is ready
      *req_cls = nullptr;
      const auto body = p->body;
      pending_.remove_if([p](const Pending& x) { return &x == p; });
      return doc.metrics
                 ? queue(connection, MHD_HTTP_OK, "text/plain; version=0.0.4; charset=utf-8", *body)
                 : queue(connection, MHD_HTTP_OK, "application/json", *body);
    }
    // Served by a build that starts after the request came, so it sees everything before it:
    // the running build's successor when one is running.
    if (!doc.job) start_build(doc);
    pending_.push_back({connection, &doc, doc.builds + (doc.job->started() ? 1 : 0), nullptr});
    *req_cls = &pending_.back();
    MHD_suspend_connection(connection);
    kick_work();
    return MHD_YES;
  }

  void start_build(Document& doc) {
    if (doc.metrics)
      doc.job = std::make_unique<MetricsBuild>(model_, doc.last_size);
    else
      doc.job = std::make_unique<StatusBuild>(model_, doc.last_size);
    ++doc.builds;
  }

  void built(Document& doc) {
    auto body = std::make_shared<const std::string>(doc.job->take());
    doc.last_size = body->size();
    doc.job.reset();
    bool more = false;
    for (auto& p : pending_) {
      if (p.body || p.doc != &doc) continue;
      if (p.build > doc.builds) {
        more = true;
        continue;
      }
      p.body = body;
      MHD_resume_connection(p.mhd);
    }
    if (more) start_build(doc);
    kick();
  }

  // -------------------------------------------------------------- Server-Sent Events

  MHD_Result open_stream(MHD_Connection* connection) {
    Conn* c = conn_of(connection);
    if (!c) return MHD_NO;
    auto stream = std::make_unique<Stream>();
    stream->conn = c;
    // ?gw=17: the panel of the gateway at DP address 17 besides the overview.
    if (const char* gw = MHD_lookup_connection_value(connection, MHD_GET_ARGUMENT_KIND, "gw")) {
      const auto& gateways = model_.sources().gateways;
      for (std::size_t i = 0; i < gateways.size(); ++i)
        if (std::to_string(gateways[i].cfg->dp_address()) == gw) stream->cursor.gateway = i;
    }
    // ?slave=8: the panel of the generic slave at DP address 8 (docs/slaves.md).
    if (const char* sl = MHD_lookup_connection_value(connection, MHD_GET_ARGUMENT_KIND, "slave")) {
      const auto& slaves = model_.sources().slaves;
      for (std::size_t i = 0; i < slaves.size(); ++i)
        if (std::to_string(slaves[i].cfg->address) == sl) stream->cursor.slave = i;
    }
    // ?once: one full event and the end of the answer, for a page that renders from it before its
    // load event (docs/daemon.md "Server-Sent Events").
    const char* once = nullptr;  // (a key without a value has none: only its presence counts)
    stream->once = MHD_lookup_connection_value_n(connection, MHD_GET_ARGUMENT_KIND, "once", 4,
                                                 &once, nullptr) == MHD_YES;
    stream->first_round = view_.first_round_for(stream->cursor.gateway, stream->cursor.slave);
    auto* ctx = new StreamContext{this, stream.get()};
    auto* r = MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, kStreamBlock,
                                                &HttpServerImpl::read_stream, ctx,
                                                &HttpServerImpl::free_stream);
    if (!r) {
      delete ctx;
      return MHD_NO;
    }
    c->stream = stream.get();
    streams_.emplace(stream.get(), std::move(stream));
    model_.http_counters().sse_clients = streams_.size();
    MHD_add_response_header(r, "Content-Type", "text/event-stream");
    MHD_add_response_header(r, "Cache-Control", "no-store");
    const auto ret = MHD_queue_response(connection, MHD_HTTP_OK, r);
    MHD_destroy_response(r);  // freed (free_stream) when the connection is done with it
    want_round_ = true;
    kick_work();
    return ret;
  }

  // MHD_ContentReaderCallback of a stream.
  static ssize_t read_stream(void* cls, std::uint64_t, char* buf, std::size_t max) {
    auto* ctx = static_cast<StreamContext*>(cls);
    auto& self = *ctx->server;
    Stream& s = *ctx->stream;
    if (self.closing_) return MHD_CONTENT_READER_END_OF_STREAM;
    if (!s.conn || s.conn->closing) return MHD_CONTENT_READER_END_WITH_ERROR;
    if (s.offset >= s.event.size() && s.once && s.cursor.round)
      return MHD_CONTENT_READER_END_OF_STREAM;
    if (s.offset >= s.event.size() && !self.compose(s)) {
      // Nothing new: park the connection until the next round is published.
      s.suspended = true;
      MHD_suspend_connection(s.conn->mhd);
      return 0;
    }
    const std::size_t n = std::min(max, s.event.size() - s.offset);
    std::memcpy(buf, s.event.data() + s.offset, n);
    s.offset += n;
    return static_cast<ssize_t>(n);
  }

  // The next event of a stream, if a round it has not seen was published.
  bool compose(Stream& s) {
    const std::uint64_t last = view_.published();
    if (last < s.first_round || last <= s.cursor.round) return false;
    auto& counters = model_.http_counters();
    if (s.cursor.round) counters.snapshots_dropped += last - s.cursor.round - 1;
    s.event = s.cursor.round ? "event: status\ndata: " : "retry: 1000\nevent: status\ndata: ";
    s.event += view_.compose(s.cursor);
    s.event += "\n\n";
    s.offset = 0;
    ++counters.events;
    counters.event_bytes += s.event.size();
    return true;
  }

  static void free_stream(void* cls) {
    auto* ctx = static_cast<StreamContext*>(cls);
    auto& self = *ctx->server;
    if (ctx->stream->conn) ctx->stream->conn->stream = nullptr;
    self.streams_.erase(ctx->stream);
    self.model_.http_counters().sse_clients = self.streams_.size();
    delete ctx;
  }

  void wake_streams() {
    for (auto& [p, s] : streams_)
      if (s->suspended && s->conn && view_.published() >= s->first_round) {
        s->suspended = false;
        MHD_resume_connection(s->conn->mhd);
      }
    kick();
  }

  // ------------------------------------------------------------------- snapshot work

  bool has_work() const { return view_.round_active() || status_.job || metrics_.job; }

  void maybe_start_round(Time now) {
    if (streams_.empty() || view_.round_active()) return;
    if (!want_round_ && now - last_round_ < options_.push_interval) return;
    std::vector<std::size_t> open, open_slaves;
    for (const auto& [p, s] : streams_) {
      if (s->cursor.gateway) open.push_back(*s->cursor.gateway);
      if (s->cursor.slave) open_slaves.push_back(*s->cursor.slave);
    }
    view_.start_round(now, std::move(open), std::move(open_slaves));
    last_round_ = now;
    want_round_ = false;
  }

  // Steps of the live view's round and of the documents in turn, for one budget.
  // The documents' time (Options::now).
  Time model_now() const { return options_.now ? options_.now() : loop_.now(); }

  void pump() {
    const Time t0 = EventLoop::monotonic_now();
    const Time m = model_now();
    Time t = t0;
    do {
      turn_ = (turn_ + 1) % 3;
      if (turn_ == 0 && view_.round_active()) {
        if (view_.step(m)) wake_streams();
      } else if (turn_ == 1 && status_.job) {
        if (status_.job->step(m)) built(status_);
      } else if (turn_ == 2 && metrics_.job) {
        if (metrics_.job->step(m)) built(metrics_);
      } else {
        continue;  // nothing of this kind: the next one
      }
      t = EventLoop::monotonic_now();
    } while (has_work() && t - t0 < budget_);
    auto& counters = model_.http_counters();
    counters.work_us_max =
        std::max<std::uint64_t>(counters.work_us_max, static_cast<std::uint64_t>((t - t0).count()));
    if (has_work() || (!streams_.empty() && want_round_)) kick_work();
  }

  // Snapshot work in a later loop turn when the next master cycle is far enough away; otherwise
  // the next after_cycle() goes on with it.
  void kick_work() {
    if (work_timer_) return;
    work_timer_ = loop_.add_timer(Duration(0), [this] {
      work_timer_ = 0;
      const Time now = model_now();
      if (options_.next_cycle)
        if (const auto next = options_.next_cycle(); next && *next - now < 2 * budget_) return;
      maybe_start_round(now);
      if (has_work()) pump();
    });
  }

  Options options_;
  EventLoop& loop_;
  StatusModel& model_;
  Logger log_;
  ClientTable table_;
  LiveView view_;
  const Duration budget_;
  std::unique_ptr<net::TcpListener> listener_;
  bool listening_ = false;
  MHD_Daemon* daemon_ = nullptr;
  int epoll_fd_ = -1;
  std::unordered_map<ClientTable::Id, std::unique_ptr<Conn>> conns_;
  Conn* adding_ = nullptr;  // the connection MHD_add_connection is adding (notify STARTED)
  std::unordered_map<Stream*, std::unique_ptr<Stream>> streams_;
  std::list<Pending> pending_;  // stable addresses: MHD keeps pointers in req_cls
  Document status_{false, nullptr, 0, 0}, metrics_{true, nullptr, 0, 0};
  int turn_ = 0;  // pump(): whose step is next
  Time last_round_{0};
  bool want_round_ = false;  // a new stream waits for its first event
  EventLoop::TimerId mhd_timer_ = 0, work_timer_ = 0, pause_timer_ = 0;
  bool kick_pending_ = false;
  DeadlineTimer idle_timer_;
  ThrottledLog notes_;  // kinds: "evicted", "idle", "refused", "libmicrohttpd"
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
