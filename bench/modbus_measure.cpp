// Measures candp2d from outside (docs/modbus.md "Performance"):
//
//  1. Modbus requests/s through the daemon against a bare libmodbus server in the same run: the
//     textbook libmodbus server (blocking modbus_receive + modbus_reply on an 8192-register
//     mapping) in a child process, and candp2d with the manual §5.1.4 configuration. One client
//     connection each, sequential requests (FC 03, 10 registers, and FC 16, 3 registers),
//     alternating rounds; the median round of each is compared. Goal: daemon >= 0.9 x bare.
//  2. Modbus-write-to-CAN-frame latency at master cycle 1 ms on the virtual bus: the time from
//     sending a Write Multiple Registers request (Q 172..177) until the resulting frame 0x309
//     arrives at a socketcand client of the bus export. Writes are spaced by a random 0..2 ms so
//     that they fall on every phase of the master cycle. Goal: p99 <= 1.1 ms.
//
// Usage: modbus_measure [--candp2d PATH] [--seconds S] [--samples N]
// Binds 127.0.0.1 only; every child process is killed at exit.
#include <arpa/inet.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "can/frame.hpp"
#include "can/socketcand.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

std::uint16_t free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  return ntohs(a.sin_port);
}

bool wait_listening(std::uint16_t port, pid_t child) {
  const auto end = Clock::now() + 10s;
  while (Clock::now() < end) {
    int status = 0;
    if (::waitpid(child, &status, WNOHANG) == child) return false;
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    ::close(fd);
    if (ok) return true;
    std::this_thread::sleep_for(10ms);
  }
  return false;
}

struct Child {
  pid_t pid = -1;
  Child() = default;
  Child(Child&& o) noexcept : pid(o.pid) { o.pid = -1; }
  Child& operator=(Child&&) = delete;
  ~Child() { stop(); }
  void stop() {
    if (pid <= 0) return;
    ::kill(pid, SIGTERM);
    int status = 0;
    for (int i = 0; i < 200 && ::waitpid(pid, &status, WNOHANG) == 0; ++i)
      std::this_thread::sleep_for(10ms);
    if (::waitpid(pid, &status, WNOHANG) == 0) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
    }
    pid = -1;
  }
};

// The bare libmodbus server of the libmodbus documentation (tests/bandwidth-server-one.c style).
[[noreturn]] void bare_server(std::uint16_t port) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", port);
  modbus_mapping_t* map = modbus_mapping_new(65536, 65536, 8193, 8193);
  const int listener = modbus_tcp_listen(ctx, 4);
  if (listener < 0) _exit(1);
  for (;;) {
    int s = listener;
    const int conn = modbus_tcp_accept(ctx, &s);  // also becomes the context's socket
    if (conn < 0) _exit(1);
    std::uint8_t req[MODBUS_TCP_MAX_ADU_LENGTH];
    for (;;) {
      const int n = modbus_receive(ctx, req);
      if (n > 0) modbus_reply(ctx, req, n, map);
      if (n < 0) break;
    }
    ::close(conn);
  }
}

std::string write_config(const std::string& dir, std::uint16_t modbus, std::uint16_t socketcand,
                         int cycle_ms) {
  const std::string path = dir + "/candp2d-" + std::to_string(modbus) + ".json";
  std::ofstream f(path);
  f << R"({"modbus": {"listen": "127.0.0.1:)" << modbus << R"("},
  "master": {"address": 1, "cycle_ms": )"
    << cycle_ms << R"(},
  "buses": {"can0": {"type": "virtual", "socketcand": "127.0.0.1:)"
    << socketcand << R"("}},
  "gateways": [{"name": "gw5", "address": 5, "bus": "can0", "slots": [
    {"io": "input",  "address": 172, "length": 6, "comment": "02,89,B8"},
    {"io": "output", "address": 172, "length": 6, "comment": "03,09,B8"}]}],
  "log": {"level": "warn"}})";
  return path;
}

Child start_daemon(const std::string& candp2d, const std::string& config) {
  Child c;
  c.pid = ::fork();
  if (c.pid == 0) {
    ::execl(candp2d.c_str(), candp2d.c_str(), "--config", config.c_str(),
            static_cast<char*>(nullptr));
    _exit(127);
  }
  return c;
}

modbus_t* connect_modbus(std::uint16_t port, int unit) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", port);
  modbus_set_slave(ctx, unit);
  modbus_set_response_timeout(ctx, 2, 0);
  if (modbus_connect(ctx) != 0) throw std::runtime_error("modbus_connect failed");
  return ctx;
}

// Requests per second over `seconds` on one connection; `write` = FC 16 else FC 03.
double rate(std::uint16_t port, double seconds, bool write) {
  modbus_t* ctx = connect_modbus(port, 5);
  std::uint16_t regs[10] = {1, 2, 3};
  std::uint64_t n = 0;
  const auto start = Clock::now();
  const auto end = start + std::chrono::duration<double>(seconds);
  while (Clock::now() < end) {
    for (int i = 0; i < 100; ++i) {
      regs[0] = static_cast<std::uint16_t>(n);
      const int rc = write ? modbus_write_registers(ctx, 86, 3, regs)
                           : modbus_read_registers(ctx, 86, 10, regs);
      if (rc < 0)
        throw std::runtime_error(std::string("request failed: ") + modbus_strerror(errno));
      ++n;
    }
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  modbus_close(ctx);
  modbus_free(ctx);
  return static_cast<double>(n) / elapsed;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(p / 100.0 * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(i, v.size() - 1)];
}

// A raw-mode socketcand client (blocking, TCP_NODELAY).
class Observer {
 public:
  Observer(std::uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0)
      throw std::runtime_error("socketcand connect failed");
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    expect("< hi >");
    send("< open can0 >");
    expect("< ok >");
    send("< rawmode >");
    expect("< ok >");
  }
  ~Observer() { ::close(fd_); }
  // The next frame in candump notation, or "" after the timeout.
  std::string frame(std::chrono::milliseconds timeout) {
    const auto end = Clock::now() + timeout;
    for (;;) {
      while (!items_.empty()) {
        auto text = items_.front().text;
        items_.erase(items_.begin());
        auto r = candp2::can::socketcand::parse_frame(text);
        if (r.frame) return candp2::can::format_candump(*r.frame);
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now());
      if (left.count() <= 0 || !fill(static_cast<int>(left.count()))) return "";
    }
  }

 private:
  bool fill(int timeout_ms) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) <= 0) return false;
    char buf[4096];
    const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
    if (n <= 0) return false;
    splitter_.feed(std::string_view(buf, static_cast<std::size_t>(n)), items_);
    return true;
  }
  void send(const std::string& s) { ::send(fd_, s.data(), s.size(), MSG_NOSIGNAL); }
  void expect(const std::string& what) {
    const auto end = Clock::now() + 5s;
    while (items_.empty() && Clock::now() < end) fill(100);
    if (items_.empty() || items_.front().text != what)
      throw std::runtime_error("socketcand handshake: expected " + what);
    items_.erase(items_.begin());
  }
  int fd_;
  candp2::can::socketcand::ElementSplitter splitter_;
  std::vector<candp2::can::socketcand::ElementSplitter::Item> items_;
};

}  // namespace

int main(int argc, char** argv) {
  std::string candp2d;
  double seconds = 2.0;
  int samples = 2000;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--candp2d" && i + 1 < argc)
      candp2d = argv[++i];
    else if (a == "--seconds" && i + 1 < argc)
      seconds = std::atof(argv[++i]);
    else if (a == "--samples" && i + 1 < argc)
      samples = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: %s [--candp2d PATH] [--seconds S] [--samples N]\n", argv[0]);
      return 2;
    }
  }
  if (candp2d.empty()) {
    std::string self = argv[0];
    candp2d = self.substr(0, self.rfind('/') + 1) + "candp2d";
  }
  ::signal(SIGPIPE, SIG_IGN);
  char tmpl[] = "/tmp/candp2-bench-XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  int rc = 0;
  try {
    // ---- 1. throughput
    const std::uint16_t bare_port = free_port();
    Child bare;
    bare.pid = ::fork();
    if (bare.pid == 0) bare_server(bare_port);
    const std::uint16_t d_port = free_port(), d_can = free_port();
    Child daemon = start_daemon(candp2d, write_config(dir, d_port, d_can, 10));
    if (!wait_listening(bare_port, bare.pid) || !wait_listening(d_port, daemon.pid))
      throw std::runtime_error("servers did not start (candp2d: " + candp2d + ")");
    std::printf("Modbus/TCP requests/s, one client, sequential (median of 5 rounds of %.1f s)\n",
                seconds / 5);
    std::printf("%-26s %12s %12s %8s\n", "request", "bare libmodbus", "candp2d", "ratio");
    for (const bool write : {false, true}) {
      std::vector<double> b, d;
      for (int round = 0; round < 5; ++round) {
        b.push_back(rate(bare_port, seconds / 5, write));
        d.push_back(rate(d_port, seconds / 5, write));
      }
      const double mb = median(b), md = median(d);
      std::printf("%-26s %12.0f %12.0f %8.2f%s\n",
                  write ? "FC16 write 3 registers" : "FC03 read 10 registers", mb, md, md / mb,
                  md / mb >= 0.9 ? "" : "  (goal >= 0.90)");
    }
    daemon.stop();
    bare.stop();

    // ---- 2. latency at cycle 1 ms
    const std::uint16_t l_port = free_port(), l_can = free_port();
    Child fast = start_daemon(candp2d, write_config(dir, l_port, l_can, 1));
    if (!wait_listening(l_port, fast.pid) || !wait_listening(l_can, fast.pid))
      throw std::runtime_error("candp2d did not start");
    std::this_thread::sleep_for(200ms);  // parameterization: a few master cycles
    Observer observer(l_can);
    modbus_t* plc = connect_modbus(l_port, 5);
    std::mt19937 random(12345);
    std::uniform_int_distribution<int> pause_us(0, 2000);
    std::vector<double> latency_ms, write_ms;
    int lost = 0;
    for (int i = 0; i < samples; ++i) {
      const std::uint16_t v = static_cast<std::uint16_t>(i + 1);
      const std::uint16_t regs[3] = {v, static_cast<std::uint16_t>(~v), 0x5A5A};
      // form B8: a b c d e f → b a f e d c
      char expected[32];
      std::snprintf(expected, sizeof expected, "309#%02X%02X5A5A%02X%02X", v & 0xFF, v >> 8,
                    (~v) & 0xFF, ((~v) >> 8) & 0xFF);
      std::this_thread::sleep_for(std::chrono::microseconds(pause_us(random)));
      const auto t0 = Clock::now();
      if (modbus_write_registers(plc, 86, 3, regs) != 3) throw std::runtime_error("write failed");
      const auto t1 = Clock::now();
      std::string got;
      do {
        got = observer.frame(1000ms);
      } while (!got.empty() && got != expected);
      const auto t2 = Clock::now();
      if (got.empty()) {
        ++lost;
        continue;
      }
      latency_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t0).count());
      write_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    }
    modbus_close(plc);
    modbus_free(plc);
    fast.stop();
    if (latency_ms.empty()) throw std::runtime_error("no frame observed");
    std::printf(
        "\nModbus write -> CAN frame at the socketcand client, master cycle 1 ms, %zu "
        "samples (%d lost)\n",
        latency_ms.size(), lost);
    std::printf("  write-to-frame  p50 %.3f ms  p90 %.3f ms  p99 %.3f ms  max %.3f ms%s\n",
                percentile(latency_ms, 50), percentile(latency_ms, 90), percentile(latency_ms, 99),
                percentile(latency_ms, 100),
                percentile(latency_ms, 99) <= 1.1 ? "" : "  (goal p99 <= 1.1 ms)");
    std::printf("  Modbus write round trip alone  p50 %.3f ms  p99 %.3f ms\n",
                percentile(write_ms, 50), percentile(write_ms, 99));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "modbus_measure: %s\n", e.what());
    rc = 1;
  }
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  return rc;
}
