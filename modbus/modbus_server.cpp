#include "modbus/modbus_server.hpp"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <unordered_map>
#include <vector>

#include "common/hex.hpp"
#include "common/idle_clients.hpp"
#include "event_loop/deadline_timer.hpp"
#include "event_loop/throttled_log.hpp"
#include "net/tcp_listener.hpp"

namespace candp2::modbus {

namespace {

// Modbus function codes that write (MB spec §6): 5, 6, 15, 16, 22, 23.
bool is_write(std::uint8_t function) {
  return function == 5 || function == 6 || function == 15 || function == 16 || function == 22 ||
         function == 23;
}

// Bytes read from a client per readiness callback: enough for many pipelined requests, small
// enough that one busy client cannot starve the others (the loop is level-triggered).
constexpr std::size_t kReadChunk = 4096;

class Server final : public ModbusServer {
 public:
  Server(Options options, EventLoop& loop, Handler& handler, LogSink* log)
      : options_(std::move(options)),
        loop_(loop),
        handler_(handler),
        log_(log, "modbus"),
        scratch_(65536, 0),
        idle_(options_.idle_timeout),
        idle_timer_(loop, [this] { close_idle(); }),
        clients_log_(loop, log_) {}

  ~Server() override {
    idle_timer_.disarm();
    for (auto& [fd, c] : clients_) {
      loop_.remove_fd(fd);
      ::close(fd);
    }
    clients_.clear();
    if (listener_) loop_.remove_fd(listener_->fd());
    if (ctx_) {
      modbus_set_socket(ctx_, -1);
      modbus_free(ctx_);
    }
  }

  bool start(std::string* error) {
    const std::string where = options_.host + ":" + std::to_string(options_.port);
    ctx_ = modbus_new_tcp(options_.host.c_str(), options_.port);
    if (!ctx_) {
      *error = "cannot create the Modbus context for " + where + ": " + modbus_strerror(errno);
      return false;
    }
    listener_ = net::TcpListener::listen(options_.host, options_.port, options_.backlog, error);
    if (!listener_) return false;
    port_ = listener_->port();
    if (!loop_.add_fd(
            listener_->fd(), EventLoop::kReadable, [this](std::uint32_t) { accept_all(); }, error))
      return false;
    log_.info("listening on " + options_.host + ":" + std::to_string(port_));
    return true;
  }

  std::uint16_t port() const override { return port_; }
  std::size_t client_count() const override { return clients_.size(); }
  const Stats& stats() const override { return stats_; }

 private:
  struct Client {
    int fd = -1;
    std::string name;
    MbapFramer framer;
    bool warned_device_failure = false;  // 0x04 (role slaves output image) logged once
  };

  void accept_all() {
    std::string error;
    if (!listener_->accept_all([this](int fd, const sockaddr_in& peer) { accepted(fd, peer); },
                               &error))
      log_.error(error);
  }

  void accepted(int fd, const sockaddr_in& peer) {
    const std::string name = net::peer_name(peer);
    if (clients_.size() >= options_.max_clients) {
      // Many Modbus/TCP devices do this: the client idle longest makes room for the new one.
      const auto victim = idle_.longest_idle();
      if (!victim || options_.max_clients == 0) {
        ++stats_.clients_refused;
        clients_log_.warn("refused", "client " + name + " refused: limit of " +
                                         std::to_string(options_.max_clients) + " clients");
        ::close(fd);
        return;
      }
      const int vfd = static_cast<int>(*victim);
      const auto idle_s = (loop_.now() - idle_.last_activity(*victim).value_or(loop_.now()));
      ++stats_.clients_evicted;
      close_client(vfd,
                   "evicted for " + name + " (limit " + std::to_string(options_.max_clients) +
                       " clients; idle longest, " +
                       std::to_string(
                           std::chrono::duration_cast<std::chrono::milliseconds>(idle_s).count()) +
                       " ms)",
                   false, "evicted", LogLevel::Warn);
    }
    // Answers are small; without TCP_NODELAY Nagle's algorithm would hold back an answer while
    // an earlier one is unacknowledged.
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    std::string error;
    if (!loop_.add_fd(
            fd, EventLoop::kReadable, [this, fd](std::uint32_t) { on_readable(fd); }, &error)) {
      log_.error("client " + name + ": " + error);
      ::close(fd);
      return;
    }
    auto& c = clients_[fd];
    c.fd = fd;
    c.name = name;
    idle_.touch(static_cast<IdleClients::Id>(fd), loop_.now());
    arm_idle_timer();
    ++stats_.clients_accepted;
    clients_log_.info(
        "connected", "client " + name + " connected (" + std::to_string(clients_.size()) + " now)");
  }

  // `kind`: the throttle's kind of the line (docs/daemon.md "Logging"), so that one kind of
  // closing (evicted, idle) is never hidden behind another.
  void close_client(int fd, std::string_view why, bool dropped,
                    std::string_view kind = "disconnected", LogLevel level = LogLevel::Info) {
    const auto it = clients_.find(fd);
    if (it == clients_.end()) return;
    if (dropped) {
      ++stats_.clients_dropped;
      clients_log_.warn("dropped", "client " + it->second.name + " dropped: " + std::string(why));
    } else {
      clients_log_.log(kind, level,
                       "client " + it->second.name + " disconnected (" + std::string(why) + ")");
    }
    loop_.remove_fd(fd);
    ::close(fd);
    clients_.erase(it);
    idle_.remove(static_cast<IdleClients::Id>(fd));
  }

  // One timer for the earliest idle expiry (a request only moves a client's expiry later).
  void arm_idle_timer() { idle_timer_.arm_earlier(idle_.next_expiry(), loop_.now()); }

  // Closes every client idle for idle_timeout.
  void close_idle() {
    for (const auto id : idle_.expired(loop_.now())) {
      ++stats_.clients_timed_out;
      close_client(
          static_cast<int>(id),
          "idle for " +
              std::to_string(
                  std::chrono::duration_cast<std::chrono::seconds>(options_.idle_timeout).count()) +
              " s",
          false, "idle");
    }
    arm_idle_timer();
  }

  void on_readable(int fd) {
    const auto it = clients_.find(fd);
    if (it == clients_.end()) return;
    std::array<std::uint8_t, kReadChunk> buf;
    const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
    if (n == 0) return close_client(fd, "end of stream", false);
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return;
      return close_client(fd, std::strerror(errno), false);
    }
    Client& c = it->second;
    idle_.touch(static_cast<IdleClients::Id>(fd), loop_.now());
    c.framer.append(std::span(buf.data(), static_cast<std::size_t>(n)));
    for (;;) {
      const auto next = c.framer.next();
      if (next.status == MbapFramer::Status::NeedMore) return;
      if (next.status == MbapFramer::Status::Garbage)
        return close_client(fd, "not Modbus/TCP: " + next.why, true);
      if (!answer(c, next.adu)) return;  // the client is gone
    }
  }

  // Returns false when the client was closed.
  bool answer(Client& c, std::span<const std::uint8_t> adu) {
    const Time now = options_.now ? options_.now() : loop_.now();
    if (log_.enabled(LogLevel::Trace)) log_.log(LogLevel::Trace, c.name + " > " + hex_bytes(adu));
    auto decoded = decode_request(adu);
    std::optional<DecodeFailure> failure;
    if (auto* f = std::get_if<DecodeFailure>(&decoded)) {
      failure = std::move(*f);
    } else {
      failure = handler_.handle(std::get<Request>(decoded), result_, now);
    }
    modbus_set_socket(ctx_, c.fd);
    int rc;
    if (failure) {
      ++stats_.exceptions;
      const std::string code = hex_bytes(std::array{static_cast<std::uint8_t>(failure->exception)});
      if (failure->exception == Exception::ServerDeviceFailure && !c.warned_device_failure) {
        c.warned_device_failure = true;  // once per client; later ones at debug
        clients_log_.warn("exception 0x04",
                          c.name + ": write refused with exception 0x04: " + failure->why);
      } else if (failure->exception != Exception::ServerDeviceFailure && is_write(adu[7])) {
        // A write the daemon refuses says why (docs/daemon.md "Logging"): a test or a PLC
        // program that writes a wrong value learns it from the log, throttled per exception.
        clients_log_.warn("write refused 0x" + code,
                          c.name + ": unit " + std::to_string(adu[6]) + ": write (function " +
                              std::to_string(adu[7]) + ") refused with exception 0x" + code + " (" +
                              std::string(to_string(failure->exception)) + "): " + failure->why);
      } else if (log_.enabled(LogLevel::Debug))
        log_.debug(c.name + ": unit " + std::to_string(adu[6]) + " function " +
                   std::to_string(adu[7]) + ": exception 0x" + code + " (" +
                   std::string(to_string(failure->exception)) + "): " + failure->why);
      rc = modbus_reply_exception(ctx_, adu.data(), static_cast<unsigned>(failure->exception));
    } else {
      ++stats_.requests;
      modbus_mapping_t m = mapping_for(std::get<Request>(decoded));
      rc = modbus_reply(ctx_, adu.data(), static_cast<int>(adu.size()), &m);
    }
    modbus_set_socket(ctx_, -1);
    if (rc < 0) {
      // A non-blocking send that could not take the whole answer: the client does not read.
      const bool slow = errno == EAGAIN || errno == EWOULDBLOCK || errno == EMBBADDATA;
      close_client(c.fd, slow ? "does not read its answers" : modbus_strerror(errno), slow);
      return false;
    }
    return true;
  }

  // A libmodbus mapping that covers exactly what this request touches, so modbus_reply finds
  // every address valid (the map already checked them) and reads the values from result_/scratch_.
  modbus_mapping_t mapping_for(const Request& r) {
    modbus_mapping_t m{};
    switch (r.function) {
      case Function::ReadCoils:
      case Function::WriteSingleCoil:
      case Function::WriteMultipleCoils:
        m.start_bits = r.address;
        m.nb_bits = r.count;
        m.tab_bits = result_.bits.data();
        break;
      case Function::ReadDiscreteInputs:
        m.start_input_bits = r.address;
        m.nb_input_bits = r.count;
        m.tab_input_bits = result_.bits.data();
        break;
      case Function::ReadInputRegisters:
        m.start_input_registers = r.address;
        m.nb_input_registers = r.count;
        m.tab_input_registers = result_.registers.data();
        break;
      case Function::ReadHoldingRegisters:
      case Function::WriteSingleRegister:
      case Function::WriteMultipleRegisters:
      case Function::MaskWriteRegister:
        m.start_registers = r.address;
        m.nb_registers = r.count;
        m.tab_registers = r.function == Function::ReadHoldingRegisters ? result_.registers.data()
                                                                       : scratch_.data();
        break;
      case Function::ReadWriteMultipleRegisters: {
        // libmodbus writes the values into the table first and then answers the read range from
        // it; the read values (as the map produced them) go in after its write, so put them at
        // their place and let libmodbus overwrite only the written range — which holds the same
        // values the map stored, as both ranges lie in one register table.
        const int start = std::min(r.address, r.write_address);
        const int end = std::max(r.address + r.count, r.write_address + r.write_count);
        m.start_registers = start;
        m.nb_registers = end - start;
        std::copy_n(result_.registers.begin(), r.count, scratch_.begin() + (r.address - start));
        m.tab_registers = scratch_.data();
        break;
      }
    }
    return m;
  }

  Options options_;
  EventLoop& loop_;
  Handler& handler_;
  Logger log_;
  modbus_t* ctx_ = nullptr;
  std::unique_ptr<net::TcpListener> listener_;
  std::uint16_t port_ = 0;
  std::unordered_map<int, Client> clients_;
  Stats stats_;
  ReadResult result_;
  std::vector<std::uint16_t> scratch_;
  IdleClients idle_;  // keyed by descriptor
  DeadlineTimer idle_timer_;
  // Every per-client line (connected, disconnected, dropped, refused, exception 0x04): one a
  // second per kind with the count, as many clients can repeat them (docs/daemon.md "Logging").
  ThrottledLog clients_log_;
};

}  // namespace

std::unique_ptr<ModbusServer> ModbusServer::listen(Options options, EventLoop& loop,
                                                   Handler& handler, LogSink* log,
                                                   std::string* error) {
  auto server = std::make_unique<Server>(std::move(options), loop, handler, log);
  std::string e;
  if (!server->start(&e)) {
    if (error) *error = e;
    return nullptr;
  }
  return server;
}

}  // namespace candp2::modbus
