// Writes a pcapng capture of the README demo walk-through (config/demo.json) as candp2d does:
// the very plant candp2d runs (plant/plant.hpp, its in-process DP services as FDL telegrams),
// driven in virtual time as replay drives it, every frame, telegram and note through
// capture::PcapngTap.
//
//   demo_capture OUT.pcapng                 the walk-through: enable axis1 (Q 0..4 = 51 00 00 ..),
//                                           read its speed every 100 ms (3D A8 64), 30 % speed
//                                           (31 66 26), ~5 s
//   demo_capture OUT.pcapng --baud RATE     the walk-through on a line in time at RATE bit/s
//   demo_capture OUT.pcapng --frames N      then more of the same, with re-parameterizations,
//                                           power cycles, forced CAN controller states and two
//                                           faulty gateways (a Prm and a Cfg fault), until the
//                                           capture holds at least N packets
//   demo_capture OUT.pcapng --config F --seconds S
//                                           the configuration F alone for S s of virtual time
//                                           (no walk-through); prints one JSON line with each bus
//                                           in time's statistics (docs/can-bus.md "The bus in
//                                           time": bitrate, load_last_pct, load_max_pct, frames,
//                                           lost)
//
// Used by tests/wireshark/tshark_test.py (ctest) and for the screenshot of docs/capture.md.
// Exit status 0, 1 on a bad command line or configuration, 2 when the capture failed.
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "capture/pcapng_tap.hpp"
#include "config/config.hpp"
#include "gateway/user_prm.hpp"
#include "plant/plant.hpp"
#include "tests/virtual_time_plant.hpp"

namespace candp2 {
namespace {

// 2024-01-01 00:00:00 UTC as the capture's time origin: deterministic time stamps.
constexpr Duration kEpoch = seconds(1'704'067'200);

using test::run_until;
using ErrLog = test::StderrErrors;

// Q bytes as the README's mbpoll writes holding registers 0..2 (register r = Q 2r high, 2r+1 low).
void write_q(plant::Plant& p, std::vector<std::uint8_t> q, const std::string& what) {
  std::copy(q.begin(), q.end(), p.master().image().outputs.begin());
  char regs[64];
  std::snprintf(regs, sizeof regs, "0x%02X%02X 0x%02X%02X 0x%02X%02X", q[0], q[1], q[2], q[3], q[4],
                q[5]);
  p.note("Modbus: holding registers 0..2 = " + std::string(regs) + " (" + what + ")", p.now());
}

void walk_through(plant::Plant& p) {
  run_until(p, seconds(1));  // parameterization, then Data_Exchange
  write_q(p, {0x51, 0x00, 0x00, 0x00, 0x00, 0x00}, "enable axis1: MODE 0x51 = 0");
  run_until(p, p.now() + milliseconds(500));
  write_q(p, {0x3D, 0xA8, 0x64, 0x00, 0x00, 0x00}, "read speed 0xA8 every 100 ms");
  run_until(p, p.now() + milliseconds(500));
  write_q(p, {0x31, 0x66, 0x26, 0x00, 0x00, 0x00}, "30 % speed");
  run_until(p, p.now() + seconds(3));
}

// Faulty gateways for the long capture: a Set_Prm with CAN bit-rate index 20 (Prm fault, byte 8)
// and a Chk_Cfg output slot with one comment byte (Cfg fault code 4, identifier missing).
void add_faulty_gateways(nlohmann::json& config) {
  auto prm = gw::make_set_prm(gw::UserPrm{}, 0);
  std::vector<std::uint8_t> bad_prm(prm.begin(), prm.end());
  bad_prm[gw::kPrmBitrate] = 20;
  std::string hex;
  for (auto b : bad_prm) {
    char t[4];
    std::snprintf(t, sizeof t, "%02X", b);
    hex += t;
  }
  const nlohmann::json slot = {{"address", 100},
                               {"cfg_hex", "81 84 02"}};  // output, 5 bytes, 1 comment byte
  config["gateways"].push_back(
      {{"name", "gw4"}, {"address", 4}, {"bus", "can0"}, {"prm_hex", hex}, {"slots", {slot}}});
  config["gateways"].push_back(
      {{"name", "gw5"}, {"address", 5}, {"bus", "can0"}, {"slots", {slot}}});
}

bool more(plant::Plant& p, capture::PcapngTap& tap, std::uint64_t frames) {
  constexpr std::string_view kOrigin = "by demo_capture";
  auto& gw3 = *p.gateway("gw3");
  for (std::uint64_t round = 0; tap.stats().packets < frames; ++round) {
    const auto v = static_cast<std::uint8_t>(round * 37);
    write_q(p, {0x31, v, static_cast<std::uint8_t>(round % 0x40), 0x00, 0x00, 0x00},
            "speed set point");
    run_until(p, p.now() + milliseconds(500));
    switch (round % 8) {
      case 2:
        // The in-process master reads the diagnosis while it parameterizes: the WARN shows there.
        p.force_can_state(gw3, 1, p.now(), kOrigin);
        run_until(p, p.now() + milliseconds(20));
        p.reparameterize(3, p.now(), kOrigin);
        break;
      case 3:
        p.force_can_state(gw3, 0, p.now(), kOrigin);
        break;
      case 5:
        p.reparameterize(3, p.now(), kOrigin);
        break;
      case 7:
        p.power_cycle(gw3, p.now(), kOrigin);
        break;
      default:
        break;
    }
    if (tap.stats().stopped) return false;
  }
  return true;
}

// The statistics of every bus in time, as one JSON line (the tshark test compares them with what
// it computes from the capture).
void print_timed_buses(plant::Plant& p) {
  nlohmann::json buses = nlohmann::json::object();
  for (auto& b : p.buses()) {
    const can::TimedBus* t = b->virtual_bus() ? b->virtual_bus()->timed() : nullptr;
    if (!t) continue;
    const auto load = t->load(p.now());
    buses[b->name()] = {{"bitrate", t->bitrate()},           {"load_last_pct", load.last_pct},
                        {"load_max_pct", load.max_pct},      {"frames", t->frames()},
                        {"error_frames", t->error_frames()}, {"lost", t->lost()}};
  }
  std::printf("%s\n", nlohmann::json{{"buses", buses}}.dump().c_str());
}

int run(int argc, char** argv) {
  const std::string option = argc >= 4 ? argv[2] : "";
  const bool timed_run = argc == 6 && option == "--config" && std::string(argv[4]) == "--seconds";
  if (argc != 2 && !(argc == 4 && (option == "--frames" || option == "--baud")) && !timed_run) {
    std::fprintf(stderr,
                 "usage: demo_capture OUT.pcapng [--frames N | --baud RATE | --config F "
                 "--seconds S]\n");
    return 1;
  }
  const bool long_run = option == "--frames";
  std::ifstream demo(timed_run ? argv[3] : CANDP2_SOURCE_DIR "/config/demo.json");
  if (!demo) {
    std::fprintf(stderr, "cannot read %s\n", timed_run ? argv[3] : "config/demo.json");
    return 1;
  }
  auto json = nlohmann::json::parse(demo);
  if (long_run) add_faulty_gateways(json);
  // docs/profibus.md "The line in time": the walk-through on a line with a baud rate.
  if (option == "--baud") json["master"]["baud"] = std::strtoul(argv[3], nullptr, 10);
  const auto loaded = config::parse_daemon(json.dump(), timed_run ? argv[3] : "demo.json");
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
  for (const auto& b : cfg.buses) o.can_bitrates.push_back(b.timed_bitrate.value_or(0));
  capture::PcapngTap tap(o, &log);
  std::string error;
  plant::Options po;
  po.log = &log;
  po.first_cycle_at_start = true;  // cycles at 0, T, 2T, ... as replay runs them
  po.wire_image = true;            // the in-process DP side as FDL telegrams
  auto plant = plant::Plant::build(cfg, std::move(po), Time{0}, &error);
  if (!plant) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 1;
  }
  plant->add_tap(&tap);
  tap.watch_bus_errors(*plant);
  if (timed_run) {
    run_until(*plant, seconds(std::strtoll(argv[5], nullptr, 10)));
    tap.sync();
    print_timed_buses(*plant);
    return tap.stats().stopped || tap.stats().dropped ? 2 : 0;
  }
  walk_through(*plant);
  if (long_run && !more(*plant, tap, std::strtoull(argv[3], nullptr, 10))) return 2;
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
