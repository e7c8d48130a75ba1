// Runs a configuration's plant in virtual time, as replay runs it, and prints what its buses in
// time measured (docs/can-bus.md "The bus in time"), for bus_prediction_test.py to hold against
// `candp2 validate --json`'s prediction (docs/validate.md "CAN buses"):
//
//   timed_bus_run CONFIG SECONDS [--writer longest|counter] [--step-us N]
//
// --writer: from the first second on, a writer changes every output slot of every gateway between
// two Data_Exchanges, every master cycle: the traffic validate predicts (each Tx slot's frame once
// per master cycle, and again every `cycle` ms). `longest`: the slot's bytes alternate between the
// two longest data the slot's frame can carry (the most stuff bits with the real CRC-15, found
// here by a dynamic programme over the data bits), so that the bus carries the longest real
// frames; `counter`: every byte the cycle's number plus its place (cheap, for benchmarks:
// bench/can_load.py). --step-us: the plant's step (plant::Options::step; replay's 0 by default,
// candp2d runs 1000: the engines in time advanced at most once a millisecond, as the daemon's
// share of the work). The run's wall time goes to stderr.
//
// Prints one JSON line: {"buses": {NAME: {bitrate, load_last_pct, load_max_pct, frames, lost,
// identifiers: [{id, extended, remote, frames, latency_max_us, latency_mean_us}]}} (an ideal bus:
// {frames_sent}),
// "slots": [{gateway, id, data_a, data_b, bits_a, bits_b}]}. Exit status 0; 1 on a bad command
// line or configuration.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "can/frame_bits.hpp"
#include "common/hex.hpp"
#include "config/config.hpp"
#include "plant/plant.hpp"
#include "tests/virtual_time_plant.hpp"

namespace candp2 {
namespace {

using test::run_until;
using ErrLog = test::StderrErrors;

// ---- The longest data of a frame --------------------------------------------------------------
// A state after some bits: the CRC-15 register, the last bit and its run (1..4), packed
// crc << 3 | last << 2 | (run - 1).
constexpr std::size_t kStates = std::size_t{1} << 18;

std::uint16_t crc_step(std::uint16_t crc, unsigned bit) {
  const bool feedback = (((crc >> 14) & 1u) ^ bit) != 0;
  crc = static_cast<std::uint16_t>((crc << 1) & 0x7FFF);
  return feedback ? static_cast<std::uint16_t>(crc ^ can::kCrc15Polynomial) : crc;
}

// One bit through the stuffing state: the new last bit and run, and whether a stuff bit followed.
bool stuff_step(unsigned& last, unsigned& run, unsigned bit) {
  run = bit == last ? run + 1 : 1;
  last = bit;
  if (run < can::kStuffRun) return false;
  last = bit ^ 1u;
  run = 1;
  return true;
}

struct Longest {
  std::vector<std::uint8_t> data;
  std::uint32_t bits = 0;
};

// The data of `dlc` bytes that gives a data frame of `id` the most stuff bits, the CRC computed
// from it; with `first_bit` 0 or 1 the first data bit is that (another data, nearly as long).
Longest longest_data(const can::Ident& id, std::size_t dlc, int first_bit) {
  const auto zeros = can::Frame::data_frame(id.id, id.extended, std::vector<std::uint8_t>(dlc));
  const can::BitStream region = can::crc_region(zeros);
  const std::size_t header = region.size - 8 * dlc, steps = 8 * dlc;
  std::uint16_t crc = 0;
  unsigned last = 2, run = 0, header_stuff = 0;
  for (std::size_t i = 0; i < header; ++i) {
    crc = crc_step(crc, region.bits[i]);
    header_stuff += stuff_step(last, run, region.bits[i]) ? 1 : 0;
  }
  std::vector<std::int16_t> score(kStates, -1), next(kStates);
  // Per step and state: the previous state's last bit and run, and the bit taken.
  std::vector<std::uint8_t> choice(steps * kStates);
  score[std::size_t{crc} << 3 | last << 2 | (run - 1)] = 0;
  for (std::size_t k = 0; k < steps; ++k) {
    std::fill(next.begin(), next.end(), std::int16_t{-1});
    for (std::size_t s = 0; s < kStates; ++s) {
      if (score[s] < 0) continue;
      for (unsigned b = 0; b < 2; ++b) {
        if (k == 0 && first_bit >= 0 && static_cast<int>(b) != first_bit) continue;
        unsigned l = (s >> 2) & 1u, r = (s & 3u) + 1;
        const bool stuffed = stuff_step(l, r, b);
        const auto c = crc_step(static_cast<std::uint16_t>(s >> 3), b);
        const std::size_t t = std::size_t{c} << 3 | l << 2 | (r - 1);
        const auto v = static_cast<std::int16_t>(score[s] + (stuffed ? 1 : 0));
        if (v > next[t]) {
          next[t] = v;
          choice[k * kStates + t] = static_cast<std::uint8_t>((s & 7u) << 1 | b);
        }
      }
    }
    score.swap(next);
  }
  std::size_t best = 0;
  int most = -1;
  for (std::size_t s = 0; s < kStates; ++s) {
    if (score[s] < 0) continue;
    unsigned l = (s >> 2) & 1u, r = (s & 3u) + 1;
    int v = score[s];
    for (unsigned i = 15; i-- > 0;) v += stuff_step(l, r, (s >> (3 + i)) & 1u) ? 1 : 0;
    if (v > most) {
      most = v;
      best = s;
    }
  }
  // Back through the choices: the CRC register runs backwards given the bit that entered it.
  Longest out;
  out.data.assign(dlc, 0);
  std::size_t s = best;
  for (std::size_t k = steps; k-- > 0;) {
    const std::uint8_t ch = choice[k * kStates + s];
    const unsigned b = ch & 1u;
    const auto c2 = static_cast<std::uint16_t>(s >> 3);
    const unsigned feedback = c2 & 1u;  // the polynomial's lowest bit: set when fed back
    const auto c = static_cast<std::uint16_t>(((feedback ? c2 ^ can::kCrc15Polynomial : c2) >> 1) |
                                              ((feedback ^ b) << 14));
    if (b) out.data[k / 8] = static_cast<std::uint8_t>(out.data[k / 8] | 0x80u >> (k % 8));
    s = std::size_t{c} << 3 | ch >> 1;
  }
  out.bits = can::frame_bits_exact(can::Frame::data_frame(id.id, id.extended, out.data));
  // The data found must be as long as the programme says (else the way back is wrong).
  const auto promised =
      region.size + 15 + header_stuff + static_cast<std::size_t>(most) + can::kTrailerBits;
  if (out.bits != promised) {
    std::fprintf(stderr, "longest data of %s: %u bits, the programme said %zu\n",
                 can::ident_text(id).c_str(), out.bits, promised);
    std::abort();
  }
  return out;
}

// ---- The writer ------------------------------------------------------------------------------
struct Written {
  std::string gateway;
  can::Ident id;
  std::size_t address = 0;  // Q byte address
  Longest a, b;
};

// The Tx slots the writer changes; with `longest` their two longest data (else the slots'
// lengths only).
std::vector<Written> writer_slots(plant::Plant& p, bool longest) {
  std::vector<Written> out;
  for (auto& g : p.gateways()) {
    const auto& cfg = g->gateway().slot_config();
    if (!cfg) continue;
    for (const auto& s : cfg->slots) {
      if (s.kind != gw::SlotKind::Tx || !s.id || s.counter || s.form != 0) continue;
      Written w{g->name(), *s.id, g->config().slots.at(s.index).address, {}, {}};
      if (!longest) {
        w.a.data.assign(s.data_len, 0);
        w.b = w.a;
        out.push_back(std::move(w));
        continue;
      }
      w.a = longest_data(w.id, s.data_len, -1);
      const int first = w.a.data.empty() ? -1 : (w.a.data[0] >> 7) ^ 1;
      w.b = w.a.data.empty() ? w.a : longest_data(w.id, s.data_len, first);
      out.push_back(std::move(w));
    }
  }
  return out;
}

nlohmann::json bus_json(plant::Plant& p) {
  nlohmann::json buses = nlohmann::json::object();
  for (auto& b : p.buses()) {
    const can::TimedBus* t = b->virtual_bus() ? b->virtual_bus()->timed() : nullptr;
    if (!t) {  // an ideal bus: the frames sent on it
      if (b->virtual_bus()) buses[b->name()] = {{"frames_sent", b->virtual_bus()->frames_sent()}};
      continue;
    }
    const auto load = t->load(p.now());
    nlohmann::json ids = nlohmann::json::array();
    for (const auto& [key, s] : t->identifiers())
      ids.push_back({{"id", s.id.id},
                     {"extended", s.id.extended},
                     {"remote", s.remote},
                     {"frames", s.frames},
                     {"latency_max_us", s.latency_max.count()},
                     {"latency_mean_us", s.latency_mean().count()}});
    buses[b->name()] = {{"bitrate", t->bitrate()},
                        {"load_last_pct", load.last_pct},
                        {"load_max_pct", load.max_pct},
                        {"frames", t->frames()},
                        {"lost", t->lost()},
                        {"identifiers", ids}};
  }
  return buses;
}

int run(int argc, char** argv) {
  std::string mode;
  long long step_us = 0;
  bool ok = argc >= 3;
  for (int i = 3; ok && i < argc; i += 2) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) {
      ok = false;
    } else if (flag == "--writer") {
      mode = argv[i + 1];
      ok = mode == "longest" || mode == "counter";
    } else if (flag == "--step-us") {
      step_us = std::atoll(argv[i + 1]);
      ok = step_us >= 0;
    } else {
      ok = false;
    }
  }
  const bool writer = !mode.empty();
  if (!ok) {
    std::fprintf(stderr,
                 "usage: timed_bus_run CONFIG SECONDS [--writer longest|counter] [--step-us N]\n");
    return 1;
  }
  const auto wall_start = std::chrono::steady_clock::now();
  const auto loaded = config::load_daemon(argv[1]);
  if (const auto* e = std::get_if<config::ConfigError>(&loaded)) {
    std::fprintf(stderr, "%s\n", e->to_string().c_str());
    return 1;
  }
  const auto& cfg = std::get<config::DaemonConfig>(loaded);
  ErrLog log;
  plant::Options po;
  po.log = &log;
  po.first_cycle_at_start = true;  // cycles at 0, T, 2T, ... as replay runs them
  po.step = Duration(step_us);     // candp2d's 1 ms, for its share of the work
  std::string error;
  auto plant = plant::Plant::build(cfg, std::move(po), Time{0}, &error);
  if (!plant) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return 1;
  }
  const Time end = seconds(std::strtoll(argv[2], nullptr, 10));
  const Duration cycle = milliseconds(cfg.cycle_ms);
  nlohmann::json slots = nlohmann::json::array();
  if (writer) {
    run_until(*plant, seconds(1) - cycle / 2);  // parameterized, exchanging data
    const auto written = writer_slots(*plant, mode == "longest");
    auto& q = plant->master().image().outputs;
    for (std::uint64_t k = 0; plant->now() + cycle <= end; ++k) {
      for (const auto& w : written) {
        const auto& data = k % 2 ? w.b.data : w.a.data;
        const auto at = q.begin() + static_cast<std::ptrdiff_t>(w.address);
        if (mode == "longest")
          std::copy(data.begin(), data.end(), at);
        else
          for (std::size_t i = 0; i < data.size(); ++i)
            at[static_cast<std::ptrdiff_t>(i)] = static_cast<std::uint8_t>(k + i);
      }
      run_until(*plant, plant->now() + cycle);
    }
    for (const auto& w : written)
      slots.push_back({{"gateway", w.gateway},
                       {"id", w.id.id},
                       {"extended", w.id.extended},
                       {"data_a", hex_bytes(w.a.data)},
                       {"data_b", hex_bytes(w.b.data)},
                       {"bits_a", w.a.bits},
                       {"bits_b", w.b.bits}});
  }
  run_until(*plant, end);
  std::fprintf(
      stderr, "%.3f s wall time\n",
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count());
  std::printf("%s\n", nlohmann::json{{"buses", bus_json(*plant)}, {"slots", slots}}.dump().c_str());
  return 0;
}

}  // namespace
}  // namespace candp2

int main(int argc, char** argv) {
  return candp2::run(argc, argv);
}
