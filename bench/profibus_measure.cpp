// Measures candp2d's PROFIBUS line from outside (docs/profibus.md "Performance"), acting as the DP
// master itself with the FDL codec (profibus_sim/fdl/fdl.hpp) on the serial PHY (serial/):
//
//  1. Slave response time over a pty: from the request's last byte written to the response's first
//     byte read, over N Data_Exchange requests to one gateway. Goal: p99 <= 100 µs.
//  2. Data_Exchange round trips per second over one pty, with 1 and with 32 gateways (requests sent
//     round-robin, each waiting for its answer, as a master's cycle does).
//
// candp2d runs `profibus.role: "slaves"` on `pty:<tmp>/pb` at 12 Mbit/s (min_TSDR 11 bit times =
// 0.9 µs; a pty has no wire, so the bit rate only sets that delay), log level warn.
// Usage: profibus_measure [--candp2d PATH] [--samples N] [--gateways-max M]
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "profibus_sim/fdl/fdl.hpp"
#include "serial/serial_port.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;
namespace fdl = candp2::fdl;
namespace fs = std::filesystem;

constexpr std::uint8_t kMaster = 2;
constexpr std::uint32_t kBaud = 12000000;

struct Daemon {
  pid_t pid = -1;
  std::string link;
  ~Daemon() {
    if (pid <= 0) return;
    ::kill(pid, SIGTERM);
    int status = 0;
    for (int i = 0; i < 200 && ::waitpid(pid, &status, WNOHANG) == 0; ++i) ::usleep(10000);
    if (::waitpid(pid, &status, WNOHANG) == 0) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
    }
  }
};

std::string hex2(unsigned v) {
  char b[8];
  std::snprintf(b, sizeof b, "%02X", v & 0xFF);
  return b;
}

// N gateways at DP addresses 3..3+N-1 on one virtual bus, each with an input slot (CAN ID
// 0x280+i) and an output slot (0x300+i) of 6 bytes, form B8 (manual §5.1.4 shape).
std::string config_json(const std::string& link, int n) {
  std::string gws;
  for (int i = 0; i < n; ++i) {
    if (i) gws += ",";
    gws += "{\"name\":\"gw" + std::to_string(3 + i) + "\",\"address\":" + std::to_string(3 + i) +
           ",\"bus\":\"can0\",\"slots\":[{\"io\":\"input\",\"address\":" + std::to_string(8 * i) +
           ",\"length\":6,\"comment\":\"02," + hex2(0x80 + i) +
           ",B8\"},{\"io\":\"output\",\"address\":" + std::to_string(8 * i) +
           ",\"length\":6,\"comment\":\"03," + hex2(i) + ",B8\"}]}";
  }
  return "{\"modbus\":{\"listen\":\"127.0.0.1:0\"},\"profibus\":{\"port\":\"pty:" + link +
         "\",\"baud\":" + std::to_string(kBaud) +
         ",\"role\":\"slaves\"},\"buses\":{\"can0\":{\"type\":\"virtual\"}},\"gateways\":[" + gws +
         "],\"log\":{\"level\":\"warn\"}}";
}

bool start(Daemon& d, const std::string& candp2d, const std::string& dir, int n) {
  d.link = dir + "/pb";
  const std::string cfg = dir + "/slaves.json";
  std::ofstream(cfg) << config_json(d.link, n);
  d.pid = ::fork();
  if (d.pid == 0) {
    ::execl(candp2d.c_str(), candp2d.c_str(), "--config", cfg.c_str(), static_cast<char*>(nullptr));
    std::_Exit(127);
  }
  const auto end = Clock::now() + 10s;
  while (Clock::now() < end) {
    std::error_code ec;
    if (fs::is_symlink(d.link, ec)) return true;
    int status = 0;
    if (::waitpid(d.pid, &status, WNOHANG) == d.pid) {
      d.pid = -1;
      return false;
    }
    ::usleep(5000);
  }
  return false;
}

class Master {
 public:
  explicit Master(candp2::serial::SerialPort& port) : port_(port) {}

  // Sends one request; returns the response telegram (nullopt on timeout). *first_byte_us is the
  // time from the write's return to the first response byte read.
  std::optional<fdl::Telegram> transact(const fdl::Telegram& t, double* first_byte_us = nullptr) {
    const auto bytes = fdl::encode(t);
    std::string error;
    if (!port_.write(bytes.data(), bytes.size(), candp2::Time(0), &error)) {
      std::fprintf(stderr, "write: %s\n", error.c_str());
      return std::nullopt;
    }
    const auto t0 = Clock::now();
    bool first = true;
    const auto end = t0 + 1s;
    while (Clock::now() < end) {
      pollfd p{port_.fd(), POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      rx_.clear();
      if (port_.read(rx_, candp2::Time(0), &error) <= 0) continue;
      if (first) {
        if (first_byte_us)
          *first_byte_us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
        first = false;
      }
      for (const auto& b : rx_) parser_.feed(b.value);
      while (auto ev = parser_.next())
        if (ev->error == fdl::Error::None) return ev->telegram;
      // SC and complete telegrams resolve without a gap; a partial one waits for more bytes.
    }
    parser_.gap();
    return std::nullopt;
  }

  std::optional<fdl::Telegram> srd(std::uint8_t station, std::optional<std::uint8_t> dsap,
                                   std::vector<std::uint8_t> du, double* us = nullptr) {
    auto& fcb = fcb_[station];
    std::uint8_t fc;
    if (fcb < 0) {  // first after FDL_Status: FCB=1, FCV=0 (docs/profibus.md)
      fcb = 1;
      fc = fdl::request_fc(fdl::kFcSrdHigh, true, false);
    } else {
      fcb = !fcb;
      fc = fdl::request_fc(fdl::kFcSrdHigh, fcb, true);
    }
    std::optional<std::uint8_t> ssap;
    if (dsap) ssap = fdl::kSapChkCfg;  // master SSAP 62
    return transact(fdl::Telegram::with_data(station, kMaster, fc, dsap, ssap, std::move(du)), us);
  }

  bool parameterize(std::uint8_t station, int index) {
    fcb_[station] = -1;
    if (!transact(fdl::Telegram::no_data(station, kMaster, fdl::request_fc(fdl::kFcFdlStatus))))
      return false;
    if (!srd(station, fdl::kSapSlaveDiag, {})) return false;
    // docs/profibus.md capture's Set_Prm with the watchdog off (Lock_Req only).
    const std::vector<std::uint8_t> prm = {0x80, 0x01, 0x01, 0x00, 0x04, 0xA4, 0x00, 0x00,
                                           0x02, 0x00, 0x01, 0x00, 0x00, 0xFF, 0xFF, 0xFF};
    auto r = srd(station, fdl::kSapSetPrm, prm);
    if (!r || r->kind != fdl::Kind::SC) return false;
    const std::vector<std::uint8_t> cfg = {
        0x43, 0x85, 0x02, static_cast<std::uint8_t>(0x80 + index), 0xB8,
        0x83, 0x85, 0x03, static_cast<std::uint8_t>(index),        0xB8};
    r = srd(station, fdl::kSapChkCfg, cfg);
    if (!r || r->kind != fdl::Kind::SC) return false;
    r = srd(station, fdl::kSapSlaveDiag, {});
    return r && !r->du.empty() && !(r->du[0] & 0x06);  // no Station_Not_Ready, no Cfg_Fault
  }

 private:
  candp2::serial::SerialPort& port_;
  fdl::StreamParser parser_;
  std::vector<candp2::serial::RxByte> rx_;
  int fcb_[128] = {};
};

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * (v.size() - 1) + 0.5))];
}

bool run(const std::string& candp2d, int gateways, int samples, bool latency) {
  char tmpl[] = "/tmp/candp2-pbmeasure-XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  bool ok = false;
  {
    Daemon d;
    if (!start(d, candp2d, dir, gateways)) {
      std::fprintf(stderr, "candp2d did not start\n");
    } else {
      candp2::serial::SerialOptions o;
      o.port = d.link;
      o.baud = kBaud;
      std::string error;
      auto port = candp2::serial::SerialPort::open(o, &error);
      if (!port) {
        std::fprintf(stderr, "%s\n", error.c_str());
      } else {
        Master m(*port);
        ok = true;
        for (int i = 0; i < gateways && ok; ++i)
          if (!m.parameterize(static_cast<std::uint8_t>(3 + i), i)) {
            std::fprintf(stderr, "station %d: parameterization failed\n", 3 + i);
            ok = false;
          }
        std::vector<double> us;
        us.reserve(static_cast<std::size_t>(samples));
        const std::vector<std::uint8_t> out = {1, 2, 3, 4, 5, 6};
        for (int i = 0; i < 200 && ok; ++i)  // warm-up
          ok = m.srd(static_cast<std::uint8_t>(3 + i % gateways), std::nullopt, out).has_value();
        const auto t0 = Clock::now();
        int lost = 0;
        for (int i = 0; i < samples && ok; ++i) {
          double u = 0;
          if (m.srd(static_cast<std::uint8_t>(3 + i % gateways), std::nullopt, out, &u))
            us.push_back(u);
          else
            ++lost;
        }
        const double secs = std::chrono::duration<double>(Clock::now() - t0).count();
        if (ok && !us.empty()) {
          if (latency)
            std::printf(
                "response time, 1 gateway, %zu requests: p50 %.1f us  p90 %.1f us  p99 "
                "%.1f us  max %.1f us  (lost %d)\n",
                us.size(), percentile(us, 0.5), percentile(us, 0.9), percentile(us, 0.99),
                percentile(us, 1.0), lost);
          std::printf(
              "Data_Exchange round trips, %d gateway(s): %.0f /s  (%d requests in %.2f s, "
              "lost %d)\n",
              gateways, samples / secs, samples, secs, lost);
        }
      }
    }
  }
  fs::remove_all(dir);
  return ok;
}

}  // namespace

int main(int argc, char** argv) {
  std::string candp2d = "build/bin/candp2d";
  int samples = 10000;
  int gateways_max = 32;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--candp2d") candp2d = argv[i + 1];
    if (a == "--samples") samples = std::atoi(argv[i + 1]);
    if (a == "--gateways-max") gateways_max = std::atoi(argv[i + 1]);
  }
  ::signal(SIGPIPE, SIG_IGN);
  bool ok = run(candp2d, 1, samples, true);
  if (gateways_max > 1) ok = run(candp2d, gateways_max, samples, false) && ok;
  return ok ? 0 : 1;
}
