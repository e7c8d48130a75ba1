// The table of expect_bus's figures (replay/bus_figures.hpp), in the order the docs list them.
#include "replay/bus_figures.hpp"

#include <cstdio>
#include <iterator>

namespace candp2::replay {

namespace {

using Stats = can::TimedBus::IdStatistics;
using Conf = can::TimedBus::Confinement;

double ms(Duration d) {
  return static_cast<double>(d.count()) / 1000.0;
}

// clang-format off
constexpr BusFigure kFigures[] = {
    {"load_pct", BusScope::Bus, 0,
     "the exact load of the last complete second of bus time, %",
     [](const can::TimedBus& b, const Stats*, const Conf*, Time now) { return b.load(now).last_pct; }},
    {"load_max_pct", BusScope::Bus, 0,
     "the load of the most loaded complete second so far, %",
     [](const can::TimedBus& b, const Stats*, const Conf*, Time now) { return b.load(now).max_pct; }},
    {"frames_on_bus", BusScope::Bus, 0, "frames that started on the bus",
     [](const can::TimedBus& b, const Stats*, const Conf*, Time) { return static_cast<double>(b.frames()); }},
    {"tx_lost", BusScope::Bus, 0, "frames lost past a full transmit queue",
     [](const can::TimedBus& b, const Stats*, const Conf*, Time) { return static_cast<double>(b.lost()); }},
    {"error_frames", BusScope::Bus, 0,
     "frames that ended in an error frame (docs/can-bus.md \"Error confinement\")",
     [](const can::TimedBus& b, const Stats*, const Conf*, Time) {
       return static_cast<double>(b.error_frames());
     }},
    {"frames", BusScope::Identifier, 0, "the identifier's frames on the bus",
     [](const can::TimedBus&, const Stats* s, const Conf*, Time) { return static_cast<double>(s->frames); }},
    {"period_ms", BusScope::Identifier, 2,
     "the mean time between two of its starts of frame, ms",
     [](const can::TimedBus&, const Stats* s, const Conf*, Time) { return ms(s->period_mean()); }},
    {"jitter_ms", BusScope::Identifier, 2,
     "its longest period less its shortest, ms",
     [](const can::TimedBus&, const Stats* s, const Conf*, Time) { return ms(s->jitter()); }},
    {"latency_last_ms", BusScope::Identifier, 1,
     "its last frame's queueing latency (send request to start of frame), ms",
     [](const can::TimedBus&, const Stats* s, const Conf*, Time) { return ms(s->latency_last); }},
    {"latency_mean_ms", BusScope::Identifier, 1,
     "the mean queueing latency of its frames, ms",
     [](const can::TimedBus&, const Stats* s, const Conf*, Time) { return ms(s->latency_mean()); }},
    {"latency_max_ms", BusScope::Identifier, 1,
     "the longest queueing latency of its frames, ms",
     [](const can::TimedBus&, const Stats* s, const Conf*, Time) { return ms(s->latency_max); }},
    {"tec", BusScope::Node, 0, "the node's transmit error counter",
     [](const can::TimedBus&, const Stats*, const Conf* n, Time) {
       return static_cast<double>(n->tec);
     }},
    {"rec", BusScope::Node, 0, "the node's receive error counter",
     [](const can::TimedBus&, const Stats*, const Conf* n, Time) {
       return static_cast<double>(n->rec);
     }},
    {"state", BusScope::Node, 0,
     "the node's error confinement state: ok, warning, error-passive or bus-off",
     [](const can::TimedBus&, const Stats*, const Conf* n, Time) {
       return static_cast<double>(n->state);
     },
     // The words of GET /api/v1/status nodes[].state (can::to_string).
     [](std::size_t code) -> std::string_view {
       return code <= static_cast<std::size_t>(can::BusState::BusOff)
                  ? can::to_string(static_cast<can::BusState>(code))
                  : std::string_view();
     }},
};
// clang-format on

}  // namespace

std::span<const BusFigure> bus_figures() {
  return kFigures;
}

const BusFigure* bus_figure(std::string_view key) {
  for (const auto& f : kFigures)
    if (f.key == key) return &f;
  return nullptr;
}

std::optional<double> BusFigure::code_of(std::string_view w) const {
  for (std::size_t c = 0; word && !word(c).empty(); ++c)
    if (word(c) == w) return static_cast<double>(c);
  return std::nullopt;
}

std::string BusFigure::text(double v) const {
  return word && v >= 0 ? std::string(word(static_cast<std::size_t>(v))) : figure_text(v);
}

std::string BusCheck::text() const {
  return figure->word && bound.min ? "= " + figure->text(*bound.min) : bound.text();
}

bool Bound::holds(double v) const {
  return (!min || v >= *min) && (!max || v <= *max);
}

std::string figure_text(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.3f", v);
  std::string s = b;
  s.erase(s.find_last_not_of('0') + 1);  // "2.500" → "2.5", "100.000" → "100."
  if (s.back() == '.') s.pop_back();
  return s == "-0" ? "0" : s;
}

std::string Bound::text() const {
  if (min && max)
    return *min == *max ? "= " + figure_text(*min) : figure_text(*min) + " .. " + figure_text(*max);
  if (min) return "≥ " + figure_text(*min);
  if (max) return "≤ " + figure_text(*max);
  return "any";
}

}  // namespace candp2::replay
