// Writes a pcapng capture of the README demo walk-through (config/demo.json) the way candp2d
// would, without candp2d: gw::Gateway, the in-process dp::DpMaster (its services as FDL telegrams
// through fdl::WireImageLink) and the simulated Unitek drives on a virtual CAN bus, driven in
// virtual time like replay/runner.cpp, every frame and telegram through capture::PcapngTap.
//
//   demo_capture OUT.pcapng                 the walk-through: enable axis1 (Q 0..4 = 51 00 00 ..),
//                                           read its speed every 100 ms (3D A8 64), 30 % speed
//                                           (31 66 26), ~5 s
//   demo_capture OUT.pcapng --frames N      then more of the same, with re-parameterizations,
//                                           power cycles, forced CAN controller states and two
//                                           faulty gateways (a Prm and a Cfg fault), until the
//                                           capture holds at least N packets
//
// Used by tests/wireshark/tshark_test.py (ctest) and for the screenshot of docs/capture.md.
// Exit status 0, 1 on a bad command line or configuration, 2 when the capture failed.
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "can/virtual_bus.hpp"
#include "capture/pcapng_tap.hpp"
#include "config/config.hpp"
#include "drive_sim/unitek_drive.hpp"
#include "gateway/gateway.hpp"
#include "profibus_sim/fdl/dp_wire.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2 {
namespace {

// 2024-01-01 00:00:00 UTC as the capture's time origin: deterministic time stamps.
constexpr Duration kEpoch = seconds(1'704'067'200);
constexpr std::string_view kInProcess = "in-process";

class ErrLog final : public LogSink {
 public:
  bool enabled(LogLevel level) const override { return level >= LogLevel::Error; }
  void write(LogLevel level, std::string_view component, std::string_view message) override {
    std::fprintf(stderr, "%s %.*s: %.*s\n", std::string(to_string(level)).c_str(),
                 static_cast<int>(component.size()), component.data(),
                 static_cast<int>(message.size()), message.data());
  }
};

struct Station {
  std::unique_ptr<can::VirtualEndpoint> ep;
  std::unique_ptr<gw::Gateway> gateway;
  std::unique_ptr<dp::InProcessLink> inner;
  std::unique_ptr<fdl::WireImageLink> link;
  std::string name;
};

struct Drive {
  std::unique_ptr<can::VirtualEndpoint> ep;
  std::unique_ptr<drive::UnitekDrive> drive;
};

class Plant {
 public:
  Plant(const config::DaemonConfig& cfg, capture::PcapngTap& tap, LogSink* log)
      : cfg_(cfg),
        tap_(tap),
        log_(log),
        master_({cfg.master_address, milliseconds(cfg.retry_ms)}, log) {
    const std::string bus_name = cfg.buses.front().name;
    bus_.add_tap([this, bus_name](const can::Frame& f, Time t, std::string_view sender) {
      const bool emulated = sender.starts_with("gw:") || sender.starts_with("drive:");
      tap_.on_can({.time = t,
                   .bus = 0,
                   .bus_name = bus_name,
                   .interface = bus_name,
                   .frame = f,
                   .sender = sender,
                   .from_emulation = emulated});
    });
    for (const auto& g : cfg.gateways)
      add_gateway(g.name, g.dp_address(), config::slave_parameters(g));
    for (const auto& d : cfg.drives) {
      drive::UnitekDrive::Options o;
      o.rx_id = d.rx_id;
      o.tx_id = d.tx_id;
      o.name = d.name;
      drives_.push_back(
          {bus_.endpoint("drive:" + d.name), std::make_unique<drive::UnitekDrive>(o, log)});
    }
  }

  void add_gateway(const std::string& name, std::uint8_t address, dp::SlaveParameters params) {
    Station s;
    s.name = name;
    s.ep = bus_.endpoint("gw:" + name);
    gw::GatewayOptions o;
    o.address = address;
    o.log = log_;
    s.gateway = std::make_unique<gw::Gateway>(o, *s.ep, now_);
    s.inner = std::make_unique<dp::InProcessLink>(s.gateway->dp());
    s.link = std::make_unique<fdl::WireImageLink>(*s.inner, [this](std::span<const std::uint8_t> b,
                                                                   bool, Time t) {
      // In-process both ends are emulated: the master's requests and the slave's answers.
      tap_.on_dp(
          {.time = t, .line = 0, .line_name = kInProcess, .telegram = b, .from_emulation = true});
    });
    master_.add_slave(*s.link, std::move(params));
    stations_.push_back(std::move(s));
  }

  void run_until(Time until) {
    while (true) {
      Time next = next_cycle_;
      for (auto& s : stations_)
        if (auto d = s.gateway->next_deadline(); d && *d < next) next = std::max(*d, now_);
      for (auto& d : drives_)
        if (auto t = d.drive->next_deadline(); t && *t < next) next = std::max(*t, now_);
      if (next > until) break;
      now_ = next;
      step();
    }
    now_ = until;
    step();
  }

  void note(const std::string& text) { tap_.on_note({.time = now_, .text = text}); }
  dp::ProcessImage& image() { return master_.image(); }
  dp::DpMaster& master() { return master_; }
  Station& station(std::size_t i) { return stations_[i]; }
  Time now() const { return now_; }

 private:
  void step() {
    bus_.set_now(now_);
    for (auto& s : stations_) s.gateway->advance(now_);
    for (auto& d : drives_) d.drive->advance(now_, *d.ep);
    drain();
    if (now_ >= next_cycle_) {
      master_.cycle(now_);
      drain();
      next_cycle_ += milliseconds(cfg_.cycle_ms);
    }
  }
  // Delivers queued frames until nobody has any left (a drive answers a gateway frame at once).
  void drain() {
    for (bool work = true; work;) {
      work = false;
      for (auto& s : stations_) {
        s.gateway->set_controller_status(s.ep->bus_state(), s.ep->rx_lost());
        while (auto f = s.ep->receive()) {
          work = true;
          s.gateway->on_can_frame(*f, now_);
        }
      }
      for (auto& d : drives_)
        while (auto f = d.ep->receive()) {
          work = true;
          d.drive->on_frame(*f, now_, *d.ep);
        }
    }
  }

  const config::DaemonConfig& cfg_;
  capture::PcapngTap& tap_;
  LogSink* log_;
  Time now_{0};
  Time next_cycle_{0};
  can::VirtualBus bus_;
  dp::DpMaster master_;
  std::vector<Station> stations_;
  std::vector<Drive> drives_;
};

// Q bytes as the README's mbpoll writes holding registers 0..2 (register r = Q 2r high, 2r+1 low).
void write_q(Plant& p, std::vector<std::uint8_t> q, const std::string& what) {
  std::copy(q.begin(), q.end(), p.image().outputs.begin());
  char regs[64];
  std::snprintf(regs, sizeof regs, "0x%02X%02X 0x%02X%02X 0x%02X%02X", q[0], q[1], q[2], q[3], q[4],
                q[5]);
  p.note("Modbus: holding registers 0..2 = " + std::string(regs) + " (" + what + ")");
}

void walk_through(Plant& p) {
  p.run_until(seconds(1));  // parameterization, then Data_Exchange
  write_q(p, {0x51, 0x00, 0x00, 0x00, 0x00, 0x00}, "enable axis1: MODE 0x51 = 0");
  p.run_until(p.now() + milliseconds(500));
  write_q(p, {0x3D, 0xA8, 0x64, 0x00, 0x00, 0x00}, "read speed 0xA8 every 100 ms");
  p.run_until(p.now() + milliseconds(500));
  write_q(p, {0x31, 0x66, 0x26, 0x00, 0x00, 0x00}, "30 % speed");
  p.run_until(p.now() + seconds(3));
}

// Faulty gateways for the long capture: a Set_Prm with CAN bit-rate index 20 (Prm fault, byte 8)
// and a Chk_Cfg output slot with one comment byte (Cfg fault code 4, identifier missing).
void add_faulty_gateways(Plant& p) {
  auto prm = gw::make_set_prm(gw::UserPrm{}, 0);
  std::vector<std::uint8_t> bad_prm(prm.begin(), prm.end());
  bad_prm[gw::kPrmBitrate] = 20;
  const std::vector<std::uint8_t> cfg = {0x81, 0x84, 0x02};  // output, 5 bytes, 1 comment byte
  p.add_gateway("gw4", 4, {bad_prm, cfg, {{{}, 100}}, "gw4"});
  std::vector<std::uint8_t> good_prm(prm.begin(), prm.end());
  p.add_gateway("gw5", 5, {good_prm, cfg, {{{}, 110}}, "gw5"});
}

bool more(Plant& p, capture::PcapngTap& tap, std::uint64_t frames) {
  add_faulty_gateways(p);
  for (std::uint64_t round = 0; tap.stats().packets < frames; ++round) {
    const auto v = static_cast<std::uint8_t>(round * 37);
    write_q(p, {0x31, v, static_cast<std::uint8_t>(round % 0x40), 0x00, 0x00, 0x00},
            "speed set point");
    p.run_until(p.now() + milliseconds(500));
    auto& gw3 = p.station(0);
    switch (round % 8) {
      case 2:
        // The in-process master reads the diagnosis while it parameterizes: the WARN shows there.
        gw3.ep->set_bus_state_override(can::BusState::Warning);
        p.note("gateway gw3: CAN controller state forced to WARN");
        p.run_until(p.now() + milliseconds(20));
        p.master().reparameterize(3, p.now());
        p.note("gateway gw3: re-parameterization");
        break;
      case 3:
        gw3.ep->set_bus_state_override(std::nullopt);
        p.note("gateway gw3: CAN controller state back to the bus's");
        break;
      case 5:
        p.master().reparameterize(3, p.now());
        p.note("gateway gw3: re-parameterization");
        break;
      case 7:
        gw3.gateway->power_cycle(p.now());
        gw3.link->reset();
        p.note("gateway gw3: power cycle");
        break;
      default:
        break;
    }
    if (tap.stats().stopped) return false;
  }
  return true;
}

int run(int argc, char** argv) {
  if (argc != 2 && !(argc == 4 && std::string(argv[2]) == "--frames")) {
    std::fprintf(stderr, "usage: demo_capture OUT.pcapng [--frames N]\n");
    return 1;
  }
  const auto loaded = config::load_daemon(CANDP2_SOURCE_DIR "/config/demo.json");
  if (const auto* e = std::get_if<config::ConfigError>(&loaded)) {
    std::fprintf(stderr, "%s\n", e->to_string().c_str());
    return 1;
  }
  const auto& cfg = std::get<config::DaemonConfig>(loaded);
  ErrLog log;
  capture::PcapngTapOptions o;
  o.writer.path = argv[1];
  o.writer.application = "candp2 demo_capture";
  o.writer.buffer_bytes = std::size_t{64} << 20;
  o.wall_offset = kEpoch;
  capture::PcapngTap tap(o, &log);
  Plant plant(cfg, tap, &log);
  walk_through(plant);
  if (argc == 4 && !more(plant, tap, std::strtoull(argv[3], nullptr, 10))) return 2;
  tap.sync();
  std::printf("%llu packets, %llu dropped\n", static_cast<unsigned long long>(tap.stats().packets),
              static_cast<unsigned long long>(tap.stats().dropped));
  return tap.stats().stopped || tap.stats().dropped ? 2 : 0;
}

}  // namespace
}  // namespace candp2

int main(int argc, char** argv) {
  return candp2::run(argc, argv);
}
