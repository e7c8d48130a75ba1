#include "can/socketcand_server.hpp"

#include <arpa/inet.h>
#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <deque>
#include <map>
#include <utility>

#include "can/socketcand_net.hpp"
#include "common/idle_clients.hpp"
#include "common/log_throttle.hpp"

namespace candp2::can {

namespace {

using socketcand::ElementSplitter;
using socketcand_net::address_text;
using socketcand_net::errno_text;
using socketcand_net::is_printable_element;
using socketcand_net::printable;
using socketcand_net::set_error;
using socketcand_net::UniqueFd;

bool is_bcm_command(std::string_view cmd) {
  // doc/protocol.md, mode BCM.
  return cmd == "add" || cmd == "update" || cmd == "delete" || cmd == "filter" ||
         cmd == "muxfilter" || cmd == "subscribe" || cmd == "unsubscribe";
}

// ---------------------------------------------------------------------------------------------
// Server
// ---------------------------------------------------------------------------------------------

class Server final : public SocketcandServer {
 public:
  Server(Options options, FrameSink& bus, LogSink* log, UniqueFd listener, UniqueFd epoll,
         std::uint16_t port)
      : options_(std::move(options)),
        bus_(bus),
        bus_channel_(dynamic_cast<Channel*>(&bus)),
        log_(log, "socketcand-server"),
        listener_(std::move(listener)),
        epoll_(std::move(epoll)),
        port_(port),
        pending_(options_.idle_timeout),
        notes_(log_) {}

  std::uint16_t port() const override { return port_; }
  std::vector<int> poll_fds() const override { return {epoll_.get()}; }
  std::size_t client_count() const override {
    return static_cast<std::size_t>(std::count_if(clients_.begin(), clients_.end(),
                                                  [](const auto& kv) { return !kv.second->dead; }));
  }
  Stats stats() const override { return stats_; }

  void on_readable(int fd, Time now) override {
    now_ = now;
    if (fd != epoll_.get()) return;
    epoll_event events[64];
    const int n = ::epoll_wait(epoll_.get(), events, 64, 0);
    if (n < 0 && errno != EINTR) log_.error("epoll_wait failed: " + errno_text(errno));
    for (int i = 0; i < n; ++i) {
      const std::uint64_t id = events[i].data.u64;
      if (id == kListenerId) {
        accept_clients(now);
        continue;
      }
      Client* c = find(id);
      if (!c || c->dead) continue;
      if (events[i].events & EPOLLOUT) flush(*c);
      if (!c->dead && (events[i].events & (EPOLLIN | EPOLLHUP | EPOLLERR))) read(*c, now);
    }
    reap();
  }

  void publish(const Frame& frame, Time wall_time) override {
    if (frame.remote) {
      // socketcand state_raw.c forwards no RTR frames ("TODO implement"); the protocol has none.
      ++stats_.remote_frames_skipped;
      log_.log(stats_.remote_frames_skipped == 1 ? LogLevel::Info : LogLevel::Debug,
               "remote frame " + format_candump(frame) +
                   " not forwarded: the socketcand protocol has no remote frames");
      return;
    }
    ++stats_.frames_to_clients;
    const std::string line = socketcand::format_frame(frame, wall_time);
    for (auto& [id, c] : clients_)
      if (forwards_to(*c)) queue(*c, line);
    reap();
  }

 private:
  static constexpr std::uint64_t kListenerId = 0;
  enum class Mode { NoBus, Bcm, Raw };
  struct Client {
    std::uint64_t id = 0;
    UniqueFd fd;
    std::string peer;
    Mode mode = Mode::NoBus;
    ElementSplitter splitter;
    std::string out;
    std::size_t stray = 0;
    bool want_write = false;
    bool close_after_flush = false;
    bool dead = false;
    explicit Client(std::size_t max_element) : splitter(max_element) {}
  };

  // Bus frames go to the live clients in raw mode (BCM mode without subscriptions gets none).
  static bool forwards_to(const Client& c) { return !c.dead && c.mode == Mode::Raw; }

  Client* find(std::uint64_t id) {
    const auto it = clients_.find(id);
    return it == clients_.end() ? nullptr : it->second.get();
  }

  void set_listener_watched(bool on) {
    if (on == listener_watched_) return;
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.u64 = kListenerId;
    ::epoll_ctl(epoll_.get(), on ? EPOLL_CTL_ADD : EPOLL_CTL_DEL, listener_.get(), &ev);
    listener_watched_ = on;
  }

  std::optional<Time> next_deadline() const override {
    const auto idle = pending_.next_expiry();
    const auto flush = notes_.next_flush();
    if (!idle || !flush) return idle ? idle : flush;
    return std::min(*idle, *flush);
  }

  void advance(Time now) override {
    now_ = now;
    notes_.flush(now);
    for (const auto id : pending_.expired(now)) {
      Client* c = find(id);
      if (!c || c->dead) continue;
      ++stats_.clients_timed_out;
      note(
          "timed out", LogLevel::Info,
          "client " + c->peer + " closed: no raw mode after " +
              std::to_string(
                  std::chrono::duration_cast<std::chrono::seconds>(options_.idle_timeout).count()) +
              " s idle");
      c->dead = true;
    }
    reap();
  }

  void note(std::string_view kind, LogLevel level, std::string line) {
    notes_.log(now_, kind, level, std::move(line));
  }

  // At max_clients: close the client idle longest (those not in raw mode first) for `peer`.
  bool evict_for(const std::string& peer, Time now) {
    auto victim = pending_.longest_idle();
    if (!victim) victim = raw_.longest_idle();
    Client* c = victim ? find(*victim) : nullptr;
    if (!c) return false;
    const auto idle =
        now - pending_.last_activity(*victim).value_or(raw_.last_activity(*victim).value_or(now));
    note("evicted", LogLevel::Warn,
         "client " + c->peer + " evicted for " + peer + " (limit " +
             std::to_string(options_.max_clients) + " clients; idle longest, " +
             std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(idle).count()) +
             " ms)");
    ++stats_.clients_evicted;
    c->dead = true;
    reap();
    return true;
  }

  void accept_clients(Time now) {
    for (int i = 0; i < 16; ++i) {  // bounded: other clients get their turn
      sockaddr_storage addr{};
      socklen_t len = sizeof addr;
      UniqueFd fd(::accept4(listener_.get(), reinterpret_cast<sockaddr*>(&addr), &len,
                            SOCK_NONBLOCK | SOCK_CLOEXEC));
      if (!fd) {
        const int err = errno;
        if (err == EAGAIN || err == EWOULDBLOCK || err == EINTR || err == ECONNABORTED) return;
        if (err == EMFILE || err == ENFILE || err == ENOBUFS || err == ENOMEM) {
          // Out of descriptors: stop watching the listener (level-triggered, it would spin)
          // until a client goes away.
          log_.error("cannot accept connections: " + errno_text(err) +
                     "; paused until a client disconnects");
          set_listener_watched(false);
          return;
        }
        log_.error("accept failed: " + errno_text(err));
        return;
      }
      const std::string peer = address_text(reinterpret_cast<const sockaddr*>(&addr));
      if (client_count() >= options_.max_clients && !evict_for(peer, now)) {
        static constexpr char kBusy[] = "< error too many clients >";
        [[maybe_unused]] const auto n =
            ::send(fd.get(), kBusy, sizeof kBusy - 1, MSG_DONTWAIT | MSG_NOSIGNAL);
        note("refused", LogLevel::Warn,
             "refused client " + peer + ": " + std::to_string(options_.max_clients) +
                 " clients connected already");
        continue;
      }
      const int on = 1;
      ::setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
      auto c = std::make_unique<Client>(options_.max_command_bytes);
      c->id = next_id_++;
      c->peer = peer;
      epoll_event ev{};
      ev.events = EPOLLIN;
      ev.data.u64 = c->id;
      if (::epoll_ctl(epoll_.get(), EPOLL_CTL_ADD, fd.get(), &ev) < 0) {
        log_.error("cannot watch client " + peer + ": " + errno_text(errno));
        continue;
      }
      c->fd = std::move(fd);
      ++stats_.clients_accepted;
      note("connected", LogLevel::Info, "client " + peer + " connected");
      Client& ref = *c;
      pending_.touch(c->id, now);
      clients_.emplace(c->id, std::move(c));
      queue(ref, "< hi >");  // state_nobus.c greets every new connection
    }
  }

  void read(Client& c, Time now) {
    char buf[4096];
    const ssize_t n = ::recv(c.fd.get(), buf, sizeof buf, MSG_DONTWAIT);
    if (n == 0) {
      note("disconnected", LogLevel::Info, "client " + c.peer + " disconnected");
      c.dead = true;
      return;
    }
    if (n < 0) {
      const int err = errno;
      if (err == EAGAIN || err == EWOULDBLOCK || err == EINTR) return;
      note("connection error", LogLevel::Info,
           "client " + c.peer + " connection error: " + errno_text(err));
      c.dead = true;
      return;
    }
    if (c.close_after_flush) return;  // answered with an error and closing: ignore the rest
    (c.mode == Mode::Raw ? raw_ : pending_).touch(c.id, now);
    items_.clear();
    c.splitter.feed(std::string_view(buf, static_cast<std::size_t>(n)), items_);
    for (auto& item : items_) {
      if (c.dead || c.close_after_flush) break;
      switch (item.kind) {
        case ElementSplitter::Kind::Element:
          command(c, item.text, now);
          break;
        case ElementSplitter::Kind::Stray:
          c.stray += item.bytes;
          if (c.stray > options_.max_stray_bytes) {
            drop(c, "sent " + std::to_string(c.stray) + " bytes outside < > (limit " +
                        std::to_string(options_.max_stray_bytes) + "; not a socketcand client?)");
          } else {
            note("ignored", LogLevel::Warn,
                 "client " + c.peer + ": ignored " + std::to_string(item.bytes) +
                     " bytes outside < >: '" + printable(item.text) + "'");
          }
          break;
        case ElementSplitter::Kind::Overflow:
          drop(c, "command longer than " + std::to_string(options_.max_command_bytes) +
                      " bytes: '" + printable(item.text) + "...'");
          break;
      }
    }
  }

  void command(Client& c, const std::string& element, Time now) {
    if (log_.enabled(LogLevel::Debug)) log_.debug("client " + c.peer + ": " + printable(element));
    if (!is_printable_element(element)) {
      note("non-ASCII", LogLevel::Warn,
           "client " + c.peer + ": command with non-ASCII bytes: " + printable(element));
      queue(c, "< error malformed command >");
      return;
    }
    const auto w = socketcand::words(element);
    const std::string_view cmd = w.empty() ? std::string_view() : w[0];

    if (c.mode == Mode::NoBus) {
      // state_nobus.c: only `open` (and interface configuration) before a bus is open.
      if (cmd == "open") {
        if (w.size() == 2 && w[1] == options_.channel) {
          c.mode = Mode::Bcm;  // socketcand starts every opened bus in BCM mode
          note("opened", LogLevel::Info, "client " + c.peer + " opened " + options_.channel);
          queue(c, "< ok >");
        } else {
          note("wrong bus", LogLevel::Warn,
               "client " + c.peer + " asked for bus '" +
                   printable(w.size() > 1 ? w[1] : std::string_view()) +
                   "', this server exports '" + options_.channel + "'; closing");
          queue(c, "< error could not open bus >");
          c.close_after_flush = true;  // socketcand shuts the connection down
          finish_if_flushed(c);
        }
      } else if (w.size() >= 2 && (w[1] == "B" || w[1] == "C")) {
        unknown(c, element, "< error interface configuration not supported by this server >");
      } else {
        unknown(c, element, "< error unknown command >");
      }
      return;
    }

    if (cmd == "send") {
      auto r = socketcand::parse_send(element);
      if (!r.frame) {
        note("bad command", LogLevel::Warn,
             "client " + c.peer + ": " + r.error + " in '" + printable(element) + "'");
        queue(c, "< error " + r.error + " >");
        return;
      }
      // When the bus is a Channel, its tx_dropped() tells whether the frame really went out
      // (bus-off, full queue); a frame that did not is not shown to the other clients either.
      const std::uint32_t dropped_before = bus_channel_ ? bus_channel_->tx_dropped() : 0;
      bus_.send(*r.frame);
      if (bus_channel_ && bus_channel_->tx_dropped() != dropped_before) {
        note("bad frame", LogLevel::Warn,
             "client " + c.peer + ": frame " + format_candump(*r.frame) +
                 " not sent, the bus dropped it (bus state " +
                 std::string(to_string(bus_channel_->bus_state())) + ")");
        return;
      }
      ++stats_.frames_from_clients;
      // Every other raw-mode client sees the frame, as its own raw socket would.
      const std::string line = socketcand::format_frame(*r.frame, now);
      for (auto& [id, other] : clients_)
        if (other.get() != &c && forwards_to(*other)) queue(*other, line);
    } else if (cmd == "rawmode" && w.size() == 1) {
      if (c.mode != Mode::Raw) {
        pending_.remove(c.id);
        raw_.touch(c.id, now);
      }
      c.mode = Mode::Raw;
      queue(c, "< ok >");
    } else if (cmd == "bcmmode" && w.size() == 1) {
      c.mode = Mode::Bcm;
      queue(c, "< ok >");
    } else if (cmd == "echo" && w.size() == 1) {
      queue(c, "< echo >");
    } else if (c.mode == Mode::Bcm && is_bcm_command(cmd)) {
      unknown(c, element, "< error bcm commands are not supported by this server, use rawmode >");
    } else if (cmd == "controlmode" || cmd == "isotpmode") {
      unknown(c, element, "< error mode not supported by this server >");
    } else {
      unknown(c, element, "< error unknown command >");
    }
  }

  void unknown(Client& c, std::string_view element, std::string reply) {
    note("rejected", LogLevel::Warn,
         "client " + c.peer + ": rejected '" + printable(element) + "'");
    queue(c, std::move(reply));
  }

  void drop(Client& c, const std::string& reason) {
    if (c.dead) return;
    note("dropped", LogLevel::Warn, "client " + c.peer + " dropped: " + reason);
    ++stats_.clients_dropped;
    c.dead = true;
  }

  void watch_write(Client& c, bool on) {
    if (c.want_write == on) return;
    epoll_event ev{};
    ev.events = EPOLLIN | (on ? EPOLLOUT : 0u);
    ev.data.u64 = c.id;
    ::epoll_ctl(epoll_.get(), EPOLL_CTL_MOD, c.fd.get(), &ev);
    c.want_write = on;
  }

  // Writes what the socket takes now; returns false when the connection failed.
  bool write_some(Client& c, std::string_view data, std::size_t* written) {
    *written = 0;
    while (*written < data.size()) {
      const ssize_t n = ::send(c.fd.get(), data.data() + *written, data.size() - *written,
                               MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n > 0) {
        *written += static_cast<std::size_t>(n);
        continue;
      }
      const int err = errno;
      if (n < 0 && err == EINTR) continue;
      if (n < 0 && (err == EAGAIN || err == EWOULDBLOCK)) return true;
      note("write failed", LogLevel::Info,
           "client " + c.peer + " write failed: " + errno_text(err));
      c.dead = true;
      return false;
    }
    return true;
  }

  void queue(Client& c, std::string_view text) {
    if (c.dead) return;
    if (c.out.empty()) {
      std::size_t written = 0;
      if (!write_some(c, text, &written)) return;
      text.remove_prefix(written);
      if (text.empty()) return;
    }
    c.out.append(text);
    if (c.out.size() > options_.max_output_bytes) {
      drop(c, "not reading: " + std::to_string(c.out.size()) + " bytes waiting (limit " +
                  std::to_string(options_.max_output_bytes) + ")");
      return;
    }
    watch_write(c, true);
  }

  void flush(Client& c) {
    std::size_t written = 0;
    if (!write_some(c, c.out, &written)) return;
    c.out.erase(0, written);
    if (c.out.empty()) {
      watch_write(c, false);
      finish_if_flushed(c);
    }
  }

  void finish_if_flushed(Client& c) {
    if (c.close_after_flush && c.out.empty()) {
      note("closed", LogLevel::Info, "client " + c.peer + " closed");
      c.dead = true;
    }
  }

  void reap() {
    bool any = false;
    for (auto it = clients_.begin(); it != clients_.end();) {
      if (it->second->dead) {
        ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, it->second->fd.get(), nullptr);
        pending_.remove(it->first);
        raw_.remove(it->first);
        it = clients_.erase(it);
        any = true;
      } else {
        ++it;
      }
    }
    if (any) set_listener_watched(true);
  }

  Options options_;
  FrameSink& bus_;
  Channel* bus_channel_;  // &bus_ when it is a Channel, else null
  Logger log_;
  UniqueFd listener_;
  UniqueFd epoll_;
  std::uint16_t port_;
  bool listener_watched_ = true;
  std::uint64_t next_id_ = 1;
  IdleClients pending_;  // clients not in raw mode yet (idle timeout applies)
  IdleClients raw_;      // raw-mode clients (never timed out; evicted only after pending ones)
  std::map<std::uint64_t, std::unique_ptr<Client>> clients_;
  std::vector<ElementSplitter::Item> items_;
  Stats stats_;
  // Every per-client line goes through the throttle (common/log_throttle.hpp, docs/daemon.md
  // "Logging"): one a second per kind with the count; its clock is the latest `now` seen.
  LogThrottle notes_;
  Time now_{0};
};

}  // namespace

std::unique_ptr<SocketcandServer> SocketcandServer::listen(Options options, FrameSink& bus,
                                                           LogSink* log, std::string* error) {
  const std::string where = options.host + ":" + std::to_string(options.port);
  if (!socketcand_net::valid_bus_name(options.channel)) {
    set_error(error, "socketcand bus name '" + options.channel + "' must be 1.." +
                         std::to_string(socketcand::kMaxBusName) +
                         " printable characters without spaces or < >");
    return nullptr;
  }
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICHOST | AI_NUMERICSERV;
  addrinfo* res = nullptr;
  const int gai =
      ::getaddrinfo(options.host.c_str(), std::to_string(options.port).c_str(), &hints, &res);
  if (gai != 0 || !res) {
    set_error(error, "socketcand server: bad listen address " + where + ": " + ::gai_strerror(gai) +
                         " (use a numeric address such as 127.0.0.1)");
    return nullptr;
  }
  std::unique_ptr<addrinfo, decltype(&::freeaddrinfo)> guard(res, &::freeaddrinfo);
  UniqueFd fd(::socket(res->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
  if (!fd) {
    set_error(error, "socketcand server: socket() failed: " + errno_text(errno));
    return nullptr;
  }
  const int on = 1;
  ::setsockopt(fd.get(), SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
  if (::bind(fd.get(), res->ai_addr, res->ai_addrlen) < 0) {
    set_error(error, "socketcand server: cannot listen on " + where + ": " + errno_text(errno));
    return nullptr;
  }
  if (::listen(fd.get(), 128) < 0) {  // connection bursts queue instead of retrying SYNs
    set_error(error, "socketcand server: listen() on " + where + " failed: " + errno_text(errno));
    return nullptr;
  }
  sockaddr_storage bound{};
  socklen_t len = sizeof bound;
  ::getsockname(fd.get(), reinterpret_cast<sockaddr*>(&bound), &len);
  const std::uint16_t port = bound.ss_family == AF_INET6
                                 ? ntohs(reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port)
                                 : ntohs(reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
  UniqueFd ep(::epoll_create1(EPOLL_CLOEXEC));
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.u64 = 0;  // the listener
  if (!ep || ::epoll_ctl(ep.get(), EPOLL_CTL_ADD, fd.get(), &ev) < 0) {
    set_error(error, "socketcand server: epoll setup failed: " + errno_text(errno));
    return nullptr;
  }
  Logger(log, "socketcand-server")
      .info("listening on " + address_text(reinterpret_cast<sockaddr*>(&bound)) + ", bus " +
            options.channel);
  return std::make_unique<Server>(std::move(options), bus, log, std::move(fd), std::move(ep), port);
}

}  // namespace candp2::can
