// Helpers for the daemon tests: an event loop served on a background thread (the test thread is
// the outside world with blocking clients), a libmodbus client, and a blocking socketcand client
// that speaks the wire protocol byte for byte. Every wait is bounded.
#pragma once

#include <arpa/inet.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "can/frame.hpp"
#include "can/socketcand.hpp"
#include "event_loop/event_loop.hpp"

namespace candp2::test {

using namespace std::chrono_literals;

// Upper bound for anything that should happen within a few master cycles on loopback sockets.
inline constexpr auto kWait = std::chrono::seconds(10);

// Runs `loop` on a background thread until stop(). Objects the loop serves must be created before
// start() and inspected only after stop() (thread start and join order the accesses).
class LoopThread {
 public:
  explicit LoopThread(EventLoop& loop) : loop_(loop) {
    wake_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    loop_.add_fd(wake_, EventLoop::kReadable, [this](std::uint32_t) {
      std::uint64_t v;
      [[maybe_unused]] auto n = ::read(wake_, &v, sizeof v);
      loop_.stop();
    });
  }
  ~LoopThread() {
    stop();
    loop_.remove_fd(wake_);
    ::close(wake_);
  }
  void start() {
    thread_ = std::thread([this] { loop_.run(); });
  }
  void stop() {
    if (!thread_.joinable()) return;
    const std::uint64_t one = 1;
    [[maybe_unused]] auto n = ::write(wake_, &one, sizeof one);
    thread_.join();
  }

 private:
  EventLoop& loop_;
  int wake_ = -1;
  std::thread thread_;
};

// Polls `done` every millisecond until it holds or `timeout` passes (for conditions only visible
// through the network, such as a status register changing).
inline bool eventually(const std::function<bool()>& done,
                       std::chrono::milliseconds timeout = std::chrono::milliseconds(kWait)) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

class ModbusClient {
 public:
  ModbusClient(std::uint16_t port, int unit) {
    ctx_ = modbus_new_tcp("127.0.0.1", port);
    if (!ctx_) throw std::runtime_error("modbus_new_tcp");
    modbus_set_response_timeout(ctx_, 2, 0);
    modbus_set_slave(ctx_, unit);
    if (modbus_connect(ctx_) != 0)
      throw std::runtime_error(std::string("modbus_connect: ") + modbus_strerror(errno));
  }
  ~ModbusClient() {
    modbus_close(ctx_);
    modbus_free(ctx_);
  }
  void unit(int u) { modbus_set_slave(ctx_, u); }
  // The registers, or the errno of the failure (EMBXILADD, EMBXGTAR, ...).
  std::variant<std::vector<std::uint16_t>, int> read_input(int address, int n) {
    std::vector<std::uint16_t> v(n);
    if (modbus_read_input_registers(ctx_, address, n, v.data()) != n) return errno;
    return v;
  }
  std::variant<std::vector<std::uint16_t>, int> read_holding(int address, int n) {
    std::vector<std::uint16_t> v(n);
    if (modbus_read_registers(ctx_, address, n, v.data()) != n) return errno;
    return v;
  }
  int write(int address, std::vector<std::uint16_t> values) {
    const int n = static_cast<int>(values.size());
    return modbus_write_registers(ctx_, address, n, values.data()) == n ? 0 : errno;
  }
  int write_one(int address, std::uint16_t value) {
    return modbus_write_register(ctx_, address, value) == 1 ? 0 : errno;
  }
  modbus_t* ctx() { return ctx_; }

 private:
  modbus_t* ctx_ = nullptr;
};

inline int connect_tcp(std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    throw std::runtime_error(std::string("connect: ") + std::strerror(errno));
  }
  return fd;
}

// Reads from `fd` until `n` bytes arrived, the peer closed, or the timeout passed.
inline std::vector<std::uint8_t> read_bytes(int fd, std::size_t n,
                                            std::chrono::milliseconds timeout = 5000ms) {
  std::vector<std::uint8_t> out;
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (out.size() < n) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        end - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) break;
    std::uint8_t buf[512];
    const ssize_t r = ::recv(fd, buf, std::min(sizeof buf, n - out.size()), 0);
    if (r <= 0) break;
    out.insert(out.end(), buf, buf + r);
  }
  return out;
}

// True when the peer closes the connection within the timeout (recv returns 0 or an error).
inline bool closed_by_peer(int fd, std::chrono::milliseconds timeout = 5000ms) {
  pollfd p{fd, POLLIN, 0};
  if (::poll(&p, 1, static_cast<int>(timeout.count())) <= 0) return false;
  std::uint8_t b[64];
  return ::recv(fd, b, sizeof b, 0) <= 0;
}

// A blocking raw-mode socketcand client as python-can's interface behaves on the wire.
class SocketcandClient {
 public:
  SocketcandClient(std::uint16_t port, const std::string& bus) : fd_(connect_tcp(port)) {
    expect("< hi >");
    send_text("< open " + bus + " >");
    expect("< ok >");
    send_text("< rawmode >");
    expect("< ok >");
  }
  ~SocketcandClient() { ::close(fd_); }
  void send_text(const std::string& s) {
    if (::send(fd_, s.data(), s.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(s.size()))
      throw std::runtime_error("send");
  }
  void send(const can::Frame& f) { send_text(can::socketcand::format_send(f)); }
  // The next element, or nullopt after the timeout.
  std::optional<std::string> element(std::chrono::milliseconds timeout = 5000ms) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (items_.empty()) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          end - std::chrono::steady_clock::now());
      if (left.count() <= 0) return std::nullopt;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) return std::nullopt;
      char buf[1024];
      const ssize_t r = ::recv(fd_, buf, sizeof buf, 0);
      if (r <= 0) return std::nullopt;
      std::vector<can::socketcand::ElementSplitter::Item> items;
      splitter_.feed(std::string_view(buf, static_cast<std::size_t>(r)), items);
      for (auto& i : items)
        if (i.kind == can::socketcand::ElementSplitter::Kind::Element)
          items_.push_back(std::move(i.text));
    }
    std::string e = items_.front();
    items_.erase(items_.begin());
    return e;
  }
  // The next `< frame >` in candump notation ("309#0B0A0F0E0D0C"), skipping other elements.
  std::optional<std::string> frame(std::chrono::milliseconds timeout = 5000ms) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (true) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          end - std::chrono::steady_clock::now());
      auto e = element(std::max(left, 0ms));
      if (!e) return std::nullopt;
      auto r = can::socketcand::parse_frame(*e);
      if (r.frame) return can::format_candump(*r.frame);
    }
  }

 private:
  void expect(const std::string& what) {
    auto e = element();
    if (!e || *e != what)
      throw std::runtime_error("socketcand: expected " + what + ", got " + e.value_or("nothing"));
  }
  int fd_;
  can::socketcand::ElementSplitter splitter_;
  std::vector<std::string> items_;
};

inline can::Frame F(const char* candump) {
  auto r = can::parse_candump(candump);
  if (!r) throw std::runtime_error(std::string("bad test frame ") + candump);
  return *r.frame;
}

}  // namespace candp2::test
