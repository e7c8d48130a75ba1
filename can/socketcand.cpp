#include "can/socketcand.hpp"

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

namespace candp2::can {

// ---------------------------------------------------------------------------------------------
// Pure protocol functions
// ---------------------------------------------------------------------------------------------

namespace socketcand {

namespace {

constexpr std::size_t kItemTextLimit = 64;  // how much of a stray run or overflow we keep for logs
constexpr std::uint32_t kCanErrFlag = 0x20000000U;  // linux/can.h CAN_ERR_FLAG
constexpr std::uint32_t kCanErrMask = 0x1FFFFFFFU;  // linux/can.h CAN_ERR_MASK

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n';
}

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool parse_hex(std::string_view text, std::uint32_t* value) {
  if (text.empty() || text.size() > 8) return false;
  std::uint32_t v = 0;
  for (char c : text) {
    const int d = hex_value(c);
    if (d < 0) return false;
    v = (v << 4) | static_cast<std::uint32_t>(d);
  }
  *value = v;
  return true;
}

// socketcand: `%03X` for 11-bit, `%08X` for 29-bit; an 8-character identifier is 29-bit
// (state_raw.c: element_length(buf, 2) == 8 → CAN_EFF_FLAG). Values above 0x7FF with fewer digits
// are taken as 29-bit too (python-can writes `{:X}` without padding).
bool parse_id(std::string_view text, Frame* f, std::string* error) {
  std::uint32_t v = 0;
  if (!parse_hex(text, &v)) {
    *error = "bad identifier '" + std::string(text.substr(0, 16)) + "' (1 to 8 hex digits)";
    return false;
  }
  if (v > kMaxExtId) {
    *error = "identifier " + std::string(text) + " above 1FFFFFFF";
    return false;
  }
  f->extended = text.size() == 8 || v > kMaxStdId;
  f->id = v;
  return true;
}

FrameResult failed(std::string message) {
  FrameResult r;
  r.error = std::move(message);
  return r;
}

bool is_timestamp(std::string_view t) {
  const auto dot = t.find('.');
  if (dot == std::string_view::npos || dot == 0 || dot + 1 == t.size()) return false;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (i != dot && (t[i] < '0' || t[i] > '9')) return false;
  return true;
}

void append_hex_byte(std::string& out, std::uint8_t b, bool upper, bool pad) {
  static constexpr char kUpper[] = "0123456789ABCDEF";
  static constexpr char kLower[] = "0123456789abcdef";
  const char* digits = upper ? kUpper : kLower;
  if (pad || b >= 0x10) out += digits[b >> 4];
  out += digits[b & 0xF];
}

std::string format_id(const Frame& f) {
  char buf[16];
  std::snprintf(buf, sizeof buf, f.extended ? "%08X" : "%03X", static_cast<unsigned>(f.id));
  return buf;
}

}  // namespace

void ElementSplitter::flush_stray(std::vector<Item>& out) {
  if (stray_bytes_ == 0) return;
  out.push_back({Kind::Stray, std::move(stray_), stray_bytes_});
  stray_.clear();
  stray_bytes_ = 0;
}

void ElementSplitter::feed(std::string_view bytes, std::vector<Item>& out) {
  for (const char c : bytes) {
    if (in_element_) {
      if (c == '<') {
        // A new element starts before the previous one closed: the unclosed part is stray.
        stray_ = partial_.substr(0, kItemTextLimit);
        stray_bytes_ = partial_.size();
        flush_stray(out);
        partial_.assign(1, '<');
        continue;
      }
      partial_ += c;
      if (c == '>') {
        const std::size_t n = partial_.size();
        out.push_back({Kind::Element, std::move(partial_), n});
        partial_.clear();
        in_element_ = false;
      } else if (partial_.size() > max_) {
        const std::size_t n = partial_.size();
        out.push_back({Kind::Overflow, partial_.substr(0, kItemTextLimit), n});
        partial_.clear();
        in_element_ = false;
      }
      continue;
    }
    if (c == '<') {
      flush_stray(out);
      in_element_ = true;
      partial_.assign(1, '<');
    } else if (is_space(c)) {
      flush_stray(out);
    } else {
      if (stray_.size() < kItemTextLimit) stray_ += c;
      ++stray_bytes_;
    }
  }
  flush_stray(out);
}

std::vector<std::string_view> words(std::string_view element) {
  if (!element.empty() && element.front() == '<') element.remove_prefix(1);
  if (!element.empty() && element.back() == '>') element.remove_suffix(1);
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < element.size()) {
    while (i < element.size() && is_space(element[i])) ++i;
    std::size_t j = i;
    while (j < element.size() && !is_space(element[j])) ++j;
    if (j > i) out.push_back(element.substr(i, j - i));
    i = j;
  }
  return out;
}

std::string format_frame(const Frame& frame, Time wall_time) {
  const long long us = std::max<long long>(0, wall_time.count());
  char stamp[48];
  std::snprintf(stamp, sizeof stamp, "%lld.%06lld", us / 1000000, us % 1000000);
  std::string out = "< frame " + format_id(frame) + ' ' + stamp + ' ';
  for (std::uint8_t i = 0; i < frame.dlc && i < kMaxDlc; ++i)
    append_hex_byte(out, frame.data[i], /*upper=*/true, /*pad=*/true);
  out += " >";
  return out;
}

std::string format_send(const Frame& frame) {
  const std::uint8_t dlc = std::min(frame.dlc, kMaxDlc);
  std::string out = "< send " + format_id(frame) + ' ' + std::to_string(dlc) + ' ';
  for (std::uint8_t i = 0; i < dlc; ++i) {
    append_hex_byte(out, frame.data[i], /*upper=*/false, /*pad=*/false);
    out += ' ';
  }
  out += '>';
  return out;
}

FrameResult parse_send(std::string_view element) {
  const auto w = words(element);
  if (w.empty() || w[0] != "send") return failed("not a send command");
  if (w.size() < 3) return failed("send needs an identifier and a DLC");
  Frame f;
  std::string error;
  if (!parse_id(w[1], &f, &error)) return failed(std::move(error));
  // socketcand reads the DLC with %hhu (decimal); python-can writes {:X}: the same for 0..8.
  const auto dlc_text = w[2];
  if (dlc_text.empty() || dlc_text.size() > 2 ||
      !std::all_of(dlc_text.begin(), dlc_text.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return failed("bad DLC '" + std::string(dlc_text.substr(0, 8)) + "' (0 to 8)");
  const int dlc = std::stoi(std::string(dlc_text));
  if (dlc > kMaxDlc) return failed("DLC " + std::to_string(dlc) + " above 8");
  const std::size_t given = w.size() - 3;
  if (given != static_cast<std::size_t>(dlc))
    return failed("DLC " + std::to_string(dlc) + " but " + std::to_string(given) + " data bytes");
  f.dlc = static_cast<std::uint8_t>(dlc);
  for (int i = 0; i < dlc; ++i) {
    const auto b = w[3 + static_cast<std::size_t>(i)];
    std::uint32_t v = 0;
    if (b.size() > 2 || !parse_hex(b, &v))
      return failed("bad data byte '" + std::string(b.substr(0, 8)) + "' (1 or 2 hex digits)");
    f.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v);
  }
  FrameResult r;
  r.frame = f;
  return r;
}

FrameResult parse_frame(std::string_view element) {
  const auto w = words(element);
  if (w.empty() || w[0] != "frame") return failed("not a frame message");
  if (w.size() < 3) return failed("frame needs an identifier and a time stamp");
  Frame f;
  std::string error;
  if (!parse_id(w[1], &f, &error)) return failed(std::move(error));
  if (!is_timestamp(w[2]))
    return failed("bad time stamp '" + std::string(w[2].substr(0, 24)) + "'");
  // Raw mode writes the data as one word ("1122"), BCM mode as words of two digits ("11 22 ").
  std::string hex;
  for (std::size_t i = 3; i < w.size(); ++i) hex += w[i];
  if (hex.size() % 2 != 0 || hex.size() > 2 * kMaxDlc)
    return failed("frame data '" + hex.substr(0, 32) + "' is not 0 to 8 hex bytes");
  f.dlc = static_cast<std::uint8_t>(hex.size() / 2);
  for (std::size_t i = 0; i < f.dlc; ++i) {
    std::uint32_t v = 0;
    if (!parse_hex(std::string_view(hex).substr(2 * i, 2), &v))
      return failed("frame data '" + hex.substr(0, 32) + "' is not hex");
    f.data[i] = static_cast<std::uint8_t>(v);
  }
  FrameResult r;
  r.frame = f;
  return r;
}

std::optional<socketcan::RawFrame> parse_error_frame(std::string_view element) {
  const auto w = words(element);
  if (w.size() < 3 || w[0] != "error" || !is_timestamp(w[2])) return std::nullopt;
  std::uint32_t cls = 0;
  if (!parse_hex(w[1], &cls)) return std::nullopt;
  socketcan::RawFrame raw;
  raw.can_id = kCanErrFlag | (cls & kCanErrMask);
  raw.len = 8;  // CAN_ERR_DLC
  // BCM mode appends the data bytes ("%02X "); raw mode sends none.
  for (std::size_t i = 3; i < w.size() && i - 3 < raw.data.size(); ++i) {
    std::uint32_t v = 0;
    if (w[i].size() > 2 || !parse_hex(w[i], &v)) return std::nullopt;
    raw.data[i - 3] = static_cast<std::uint8_t>(v);
  }
  return raw;
}

}  // namespace socketcand

// ---------------------------------------------------------------------------------------------
// Sockets
// ---------------------------------------------------------------------------------------------

namespace {

using socketcand::ElementSplitter;

std::string errno_text(int err) {
  return std::string(std::strerror(err));
}

class UniqueFd {
 public:
  UniqueFd() = default;
  explicit UniqueFd(int fd) : fd_(fd) {}
  UniqueFd(UniqueFd&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}
  UniqueFd& operator=(UniqueFd&& o) noexcept {
    if (this != &o) {
      reset();
      fd_ = std::exchange(o.fd_, -1);
    }
    return *this;
  }
  ~UniqueFd() { reset(); }
  void reset() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  int get() const { return fd_; }
  explicit operator bool() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
};

bool is_printable_element(std::string_view e) {
  return std::all_of(e.begin(), e.end(), [](char ch) {
    const auto c = static_cast<unsigned char>(ch);
    return (c >= 0x20 && c < 0x7F) || c == '\t' || c == '\r' || c == '\n';
  });
}

std::string printable(std::string_view text) {
  std::string out;
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c >= 0x20 && c < 0x7F) {
      out += ch;
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02X", c);
      out += buf;
    }
  }
  return out;
}

std::string address_text(const sockaddr* sa) {
  char host[INET6_ADDRSTRLEN] = "?";
  unsigned port = 0;
  if (sa->sa_family == AF_INET) {
    const auto* in = reinterpret_cast<const sockaddr_in*>(sa);
    ::inet_ntop(AF_INET, &in->sin_addr, host, sizeof host);
    port = ntohs(in->sin_port);
    return std::string(host) + ':' + std::to_string(port);
  }
  if (sa->sa_family == AF_INET6) {
    const auto* in6 = reinterpret_cast<const sockaddr_in6*>(sa);
    ::inet_ntop(AF_INET6, &in6->sin6_addr, host, sizeof host);
    port = ntohs(in6->sin6_port);
    return '[' + std::string(host) + "]:" + std::to_string(port);
  }
  return "?";
}

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
        port_(port) {}

  std::uint16_t port() const override { return port_; }
  std::vector<int> poll_fds() const override { return {epoll_.get()}; }
  std::size_t client_count() const override {
    return static_cast<std::size_t>(std::count_if(clients_.begin(), clients_.end(),
                                                  [](const auto& kv) { return !kv.second->dead; }));
  }
  Stats stats() const override { return stats_; }

  void on_readable(int fd, Time now) override {
    if (fd != epoll_.get()) return;
    epoll_event events[64];
    const int n = ::epoll_wait(epoll_.get(), events, 64, 0);
    if (n < 0 && errno != EINTR) log_.error("epoll_wait failed: " + errno_text(errno));
    for (int i = 0; i < n; ++i) {
      const std::uint64_t id = events[i].data.u64;
      if (id == kListenerId) {
        accept_clients();
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

  void accept_clients() {
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
      if (client_count() >= options_.max_clients) {
        static constexpr char kBusy[] = "< error too many clients >";
        [[maybe_unused]] const auto n =
            ::send(fd.get(), kBusy, sizeof kBusy - 1, MSG_DONTWAIT | MSG_NOSIGNAL);
        log_.warn("refused client " + peer + ": " + std::to_string(options_.max_clients) +
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
      log_.info("client " + peer + " connected");
      Client& ref = *c;
      clients_.emplace(c->id, std::move(c));
      queue(ref, "< hi >");  // state_nobus.c greets every new connection
    }
  }

  void read(Client& c, Time now) {
    char buf[4096];
    const ssize_t n = ::recv(c.fd.get(), buf, sizeof buf, MSG_DONTWAIT);
    if (n == 0) {
      log_.info("client " + c.peer + " disconnected");
      c.dead = true;
      return;
    }
    if (n < 0) {
      const int err = errno;
      if (err == EAGAIN || err == EWOULDBLOCK || err == EINTR) return;
      log_.info("client " + c.peer + " connection error: " + errno_text(err));
      c.dead = true;
      return;
    }
    if (c.close_after_flush) return;  // answered with an error and closing: ignore the rest
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
            log_.warn("client " + c.peer + ": ignored " + std::to_string(item.bytes) +
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
      log_.warn("client " + c.peer + ": command with non-ASCII bytes: " + printable(element));
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
          log_.info("client " + c.peer + " opened " + options_.channel);
          queue(c, "< ok >");
        } else {
          log_.warn("client " + c.peer + " asked for bus '" +
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
        log_.warn("client " + c.peer + ": " + r.error + " in '" + printable(element) + "'");
        queue(c, "< error " + r.error + " >");
        return;
      }
      // When the bus is a Channel, its tx_dropped() tells whether the frame really went out
      // (bus-off, full queue); a frame that did not is not shown to the other clients either.
      const std::uint32_t dropped_before = bus_channel_ ? bus_channel_->tx_dropped() : 0;
      bus_.send(*r.frame);
      if (bus_channel_ && bus_channel_->tx_dropped() != dropped_before) {
        log_.warn("client " + c.peer + ": frame " + format_candump(*r.frame) +
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
    log_.warn("client " + c.peer + ": rejected '" + printable(element) + "'");
    queue(c, std::move(reply));
  }

  void drop(Client& c, const std::string& reason) {
    if (c.dead) return;
    log_.warn("client " + c.peer + " dropped: " + reason);
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
      log_.info("client " + c.peer + " write failed: " + errno_text(err));
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
      log_.info("client " + c.peer + " closed");
      c.dead = true;
    }
  }

  void reap() {
    bool any = false;
    for (auto it = clients_.begin(); it != clients_.end();) {
      if (it->second->dead) {
        ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, it->second->fd.get(), nullptr);
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
  std::map<std::uint64_t, std::unique_ptr<Client>> clients_;
  std::vector<ElementSplitter::Item> items_;
  Stats stats_;
};

// ---------------------------------------------------------------------------------------------
// Client
// ---------------------------------------------------------------------------------------------

using Clock = std::chrono::steady_clock;

int remaining_ms(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  return static_cast<int>(std::max<std::chrono::milliseconds::rep>(0, left.count()));
}

// Blocking helper for the handshake, bounded by one deadline.
class Handshake {
 public:
  Handshake(int fd, Clock::time_point deadline, std::string who)
      : fd_(fd), deadline_(deadline), who_(std::move(who)) {}

  bool next(std::string* element, std::string* error) {
    while (elements_.empty()) {
      pollfd p{fd_, POLLIN, 0};
      const int r = ::poll(&p, 1, remaining_ms(deadline_));
      if (r < 0 && errno == EINTR) continue;
      if (r <= 0) return fail(error, "timed out waiting for the server during the handshake");
      char buf[4096];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
      if (n == 0) return fail(error, "the server closed the connection during the handshake");
      if (n < 0) {
        if (errno == EAGAIN || errno == EINTR) continue;
        return fail(error, "receive failed during the handshake: " + errno_text(errno));
      }
      items_.clear();
      splitter_.feed(std::string_view(buf, static_cast<std::size_t>(n)), items_);
      for (auto& item : items_) {
        if (item.kind == ElementSplitter::Kind::Element) elements_.push_back(std::move(item.text));
        if (item.kind == ElementSplitter::Kind::Overflow)
          return fail(error, "the server sent an over-long line (not a socketcand server?)");
      }
    }
    *element = std::move(elements_.front());
    elements_.pop_front();
    return true;
  }

  bool send(std::string_view text, std::string* error) {
    while (!text.empty()) {
      const ssize_t n = ::send(fd_, text.data(), text.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n > 0) {
        text.remove_prefix(static_cast<std::size_t>(n));
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && errno == EAGAIN) {
        pollfd p{fd_, POLLOUT, 0};
        if (::poll(&p, 1, remaining_ms(deadline_)) <= 0)
          return fail(error, "timed out sending to the server during the handshake");
        continue;
      }
      return fail(error, "send failed during the handshake: " + errno_text(errno));
    }
    return true;
  }

  // Waits for `< ok >`; an `< error ... >` answer becomes the message.
  bool expect_ok(std::string_view after, std::string* error) {
    std::string e;
    if (!next(&e, error)) return false;
    const auto w = socketcand::words(e);
    if (w.size() == 1 && w[0] == "ok") return true;
    if (!w.empty() && w[0] == "error") {
      std::string reason;
      for (std::size_t i = 1; i < w.size(); ++i) reason += (i > 1 ? " " : "") + std::string(w[i]);
      return fail(error, "the server refused " + std::string(after) + ": " + reason);
    }
    return fail(error,
                "expected '< ok >' after " + std::string(after) + ", got '" + printable(e) + "'");
  }

  ElementSplitter& splitter() { return splitter_; }
  std::deque<std::string>& elements() { return elements_; }

 private:
  bool fail(std::string* error, std::string message) {
    if (error) *error = "socketcand " + who_ + ": " + std::move(message);
    return false;
  }
  int fd_;
  Clock::time_point deadline_;
  std::string who_;
  ElementSplitter splitter_;
  std::vector<ElementSplitter::Item> items_;
  std::deque<std::string> elements_;
};

class SocketcandChannel final : public Channel {
 public:
  static constexpr std::size_t kMaxOutput = 256 * 1024;  // queued `< send >` bytes

  SocketcandChannel(UniqueFd sock, UniqueFd epoll, std::string who, LogSink* log,
                    ElementSplitter splitter, std::deque<std::string> pending)
      : sock_(std::move(sock)),
        epoll_(std::move(epoll)),
        name_("socketcand:" + who),
        log_(log, "socketcand " + who),
        splitter_(std::move(splitter)) {
    for (const auto& e : pending) element(e);
  }

  void send(const Frame& frame) override {
    if (!sock_) {
      ++tx_dropped_;
      if (tx_dropped_ == 1 || tx_dropped_ % 1000 == 0)
        log_.warn("not connected: frame " + format_candump(frame) + " dropped (" +
                  std::to_string(tx_dropped_) + " so far)");
      return;
    }
    if (frame.remote) {
      ++tx_dropped_;
      ++remote_dropped_;
      log_.log(remote_dropped_ == 1 ? LogLevel::Warn : LogLevel::Debug,
               "remote frame " + format_candump(frame) +
                   " dropped: the socketcand protocol has no remote frames");
      return;
    }
    const std::string line = socketcand::format_send(frame);
    if (out_.size() + line.size() > kMaxOutput) {
      ++tx_dropped_;
      log_.warn("server not reading: frame " + format_candump(frame) + " dropped (" +
                std::to_string(out_.size()) + " bytes waiting)");
      return;
    }
    out_ += line;
    flush();
  }

  std::optional<Frame> receive() override {
    flush();
    for (;;) {
      if (!rx_.empty()) {
        Frame f = rx_.front();
        rx_.pop_front();
        return f;
      }
      if (!sock_) return std::nullopt;
      char buf[16384];
      const ssize_t n = ::recv(sock_.get(), buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) {
        items_.clear();
        splitter_.feed(std::string_view(buf, static_cast<std::size_t>(n)), items_);
        for (const auto& item : items_) {
          if (!sock_) break;
          switch (item.kind) {
            case ElementSplitter::Kind::Element:
              element(item.text);
              break;
            case ElementSplitter::Kind::Stray:
              log_.warn("ignored " + std::to_string(item.bytes) + " bytes outside < >: '" +
                        printable(item.text) + "'");
              break;
            case ElementSplitter::Kind::Overflow:
              disconnect("the server sent a line longer than " +
                         std::to_string(socketcand::kMaxElementBytes) + " bytes");
              break;
          }
        }
        continue;
      }
      if (n == 0) {
        disconnect("the server closed the connection");
        continue;
      }
      const int err = errno;
      if (err == EINTR) continue;
      if (err == EAGAIN || err == EWOULDBLOCK) return std::nullopt;
      disconnect("receive failed: " + errno_text(err));
    }
  }

  BusState bus_state() const override { return sock_ ? state_ : BusState::BusOff; }
  std::uint32_t rx_lost() const override { return rx_lost_; }
  std::uint32_t tx_dropped() const override { return tx_dropped_; }
  int poll_fd() const override { return epoll_.get(); }
  std::string_view name() const override { return name_; }

 private:
  void element(const std::string& e) {
    const auto w = socketcand::words(e);
    const std::string_view cmd = w.empty() ? std::string_view() : w[0];
    if (cmd == "frame") {
      auto r = socketcand::parse_frame(e);
      if (r.frame) {
        rx_.push_back(*r.frame);
      } else {
        ++rx_lost_;  // a frame the server reported that this reader cannot use
        log_.warn("unusable frame from the server (" + r.error + "): '" + printable(e) + "'");
      }
    } else if (cmd == "error") {
      if (const auto raw = socketcand::parse_error_frame(e)) {
        const auto effect = socketcan::decode_error(*raw);
        rx_lost_ += effect.rx_lost;
        if (effect.state && *effect.state != state_) {
          log_.warn("error frame: " + effect.description + "; bus state " +
                    std::string(to_string(state_)) + " -> " +
                    std::string(to_string(*effect.state)));
          state_ = *effect.state;
        } else {
          log_.log(effect.rx_lost ? LogLevel::Warn : LogLevel::Debug,
                   "error frame: " + effect.description);
        }
      } else {
        log_.warn("the server answered: '" + printable(e) + "'");
      }
    } else {
      log_.debug("ignored '" + printable(e) + "'");
    }
  }

  void flush() {
    if (!sock_) {
      out_.clear();
      return;
    }
    std::size_t done = 0;
    while (done < out_.size()) {
      const ssize_t n =
          ::send(sock_.get(), out_.data() + done, out_.size() - done, MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n > 0) {
        done += static_cast<std::size_t>(n);
        continue;
      }
      const int err = errno;
      if (n < 0 && err == EINTR) continue;
      if (n < 0 && (err == EAGAIN || err == EWOULDBLOCK)) break;
      disconnect("send failed: " + errno_text(err));
      return;
    }
    out_.erase(0, done);
    watch_write(!out_.empty());
  }

  void watch_write(bool on) {
    if (on == want_write_ || !sock_) return;
    epoll_event ev{};
    ev.events = EPOLLIN | (on ? EPOLLOUT : 0u);
    ::epoll_ctl(epoll_.get(), EPOLL_CTL_MOD, sock_.get(), &ev);
    want_write_ = on;
  }

  void disconnect(const std::string& why) {
    if (!sock_) return;
    log_.error(why + "; channel is down (bus state bus-off)");
    ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, sock_.get(), nullptr);
    sock_.reset();
    tx_dropped_ += static_cast<std::uint32_t>(std::count(out_.begin(), out_.end(), '<'));
    out_.clear();
  }

  UniqueFd sock_;
  UniqueFd epoll_;
  std::string name_;
  Logger log_;
  ElementSplitter splitter_;
  std::vector<ElementSplitter::Item> items_;
  std::deque<Frame> rx_;
  std::string out_;
  bool want_write_ = false;
  BusState state_ = BusState::Ok;
  std::uint32_t rx_lost_ = 0;
  std::uint32_t tx_dropped_ = 0;
  std::uint32_t remote_dropped_ = 0;
};

bool set_error(std::string* error, std::string message) {
  if (error) *error = std::move(message);
  return false;
}

}  // namespace

std::unique_ptr<SocketcandServer> SocketcandServer::listen(Options options, FrameSink& bus,
                                                           LogSink* log, std::string* error) {
  const std::string where = options.host + ":" + std::to_string(options.port);
  if (options.channel.empty() || options.channel.size() > socketcand::kMaxBusName ||
      std::any_of(options.channel.begin(), options.channel.end(),
                  [](char c) { return c <= ' ' || c == '<' || c == '>' || c > '~'; })) {
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
  if (::listen(fd.get(), 16) < 0) {
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

std::unique_ptr<Channel> connect_socketcand(const std::string& host, std::uint16_t port,
                                            const std::string& channel, std::string* error,
                                            int timeout_ms, LogSink* log) {
  const std::string who = host + ":" + std::to_string(port);
  if (channel.empty() || channel.size() > socketcand::kMaxBusName ||
      std::any_of(channel.begin(), channel.end(),
                  [](char c) { return c <= ' ' || c == '<' || c == '>' || c > '~'; })) {
    set_error(error, "socketcand " + who + ": bus name '" + channel + "' must be 1.." +
                         std::to_string(socketcand::kMaxBusName) +
                         " printable characters without spaces or < >");
    return nullptr;
  }
  const auto deadline = Clock::now() + std::chrono::milliseconds(std::max(0, timeout_ms));
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_NUMERICSERV;
  addrinfo* res = nullptr;
  const int gai = ::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &res);
  if (gai != 0 || !res) {
    set_error(error, "socketcand " + who + ": cannot resolve host: " + ::gai_strerror(gai));
    return nullptr;
  }
  std::unique_ptr<addrinfo, decltype(&::freeaddrinfo)> guard(res, &::freeaddrinfo);

  UniqueFd sock;
  std::string last_error = "no address";
  for (addrinfo* ai = res; ai && !sock; ai = ai->ai_next) {
    UniqueFd fd(::socket(ai->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
    if (!fd) {
      last_error = errno_text(errno);
      continue;
    }
    if (::connect(fd.get(), ai->ai_addr, ai->ai_addrlen) < 0) {
      if (errno != EINPROGRESS) {
        last_error = errno_text(errno);
        continue;
      }
      pollfd p{fd.get(), POLLOUT, 0};
      int r;
      do {
        r = ::poll(&p, 1, remaining_ms(deadline));
      } while (r < 0 && errno == EINTR);
      if (r <= 0) {
        last_error = "timed out after " + std::to_string(timeout_ms) + " ms";
        continue;
      }
      int soerr = 0;
      socklen_t len = sizeof soerr;
      ::getsockopt(fd.get(), SOL_SOCKET, SO_ERROR, &soerr, &len);
      if (soerr != 0) {
        last_error = errno_text(soerr);
        continue;
      }
    }
    sock = std::move(fd);
  }
  if (!sock) {
    set_error(error, "cannot connect to socketcand at " + who + ": " + last_error);
    return nullptr;
  }
  const int on = 1;
  ::setsockopt(sock.get(), IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);

  // doc/protocol.md: `< hi >`, then `< open BUS >` → `< ok >` (BCM mode), `< rawmode >` → `< ok >`.
  Handshake hs(sock.get(), deadline, who);
  std::string e;
  if (!hs.next(&e, error)) return nullptr;
  if (const auto w = socketcand::words(e); !(w.size() == 1 && w[0] == "hi")) {
    set_error(error, "socketcand " + who + ": expected the greeting '< hi >', got '" +
                         printable(e) + "' (not a socketcand server?)");
    return nullptr;
  }
  if (!hs.send("< open " + channel + " >", error) || !hs.expect_ok("bus " + channel, error) ||
      !hs.send("< rawmode >", error) || !hs.expect_ok("rawmode", error))
    return nullptr;

  UniqueFd ep(::epoll_create1(EPOLL_CLOEXEC));
  epoll_event ev{};
  ev.events = EPOLLIN;
  if (!ep || ::epoll_ctl(ep.get(), EPOLL_CTL_ADD, sock.get(), &ev) < 0) {
    set_error(error, "socketcand " + who + ": epoll setup failed: " + errno_text(errno));
    return nullptr;
  }
  Logger(log, "socketcand " + who).info("connected, bus " + channel + " in raw mode");
  return std::make_unique<SocketcandChannel>(std::move(sock), std::move(ep), who + "/" + channel,
                                             log, std::move(hs.splitter()),
                                             std::move(hs.elements()));
}

}  // namespace candp2::can
