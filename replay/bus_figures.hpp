// What replay's expect_bus checks of a CAN bus in time (docs/replay-format.md "The CAN bus in
// time"): one row per figure, of the bus or of one identifier, read from the bus in time as
// GET /api/v1/status shows it (docs/can-bus.md "Seen from outside"). The parser, the check and
// the report read only this table: a new figure of the bus (its error frames, a node's error
// counters) is one row (docs/development.md "Add a bus figure").
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "can/timed_bus.hpp"
#include "common/time.hpp"

namespace candp2::replay {

enum class BusScope : std::uint8_t {
  Bus,         // the whole bus
  Identifier,  // the identifier the step names ("id")
  Node,        // the node the step names ("node": its endpoint's name, "gw:NAME" for a gateway)
};

struct BusFigure {
  std::string_view key;  // expect_bus's key
  BusScope scope;
  // How many of the identifier's frames the figure needs to have a value: 0 for a count (0
  // before anything happened), 1 for a latency, 2 for a period or the jitter.
  std::uint8_t frames_needed;
  std::string_view meaning;  // for docs and errors
  // The figure at `now`; `id` is the identifier's statistics (Identifier rows only, never null),
  // `node` the node's error confinement (Node rows only, never null).
  double (*get)(const can::TimedBus& bus, const can::TimedBus::IdStatistics* id,
                const can::TimedBus::Confinement* node, Time now);
  // A figure whose value is one of a few words (a node's state): the word of code `code`, empty
  // past the last; the step gives the word, the report shows it. Null: a number.
  std::string_view (*word)(std::size_t code) = nullptr;
  // The code of `w`, if it is one of the figure's words.
  std::optional<double> code_of(std::string_view w) const;
  // The value as the report writes it: its word, else figure_text(v).
  std::string text(double v) const;
};

std::span<const BusFigure> bus_figures();
const BusFigure* bus_figure(std::string_view key);

// A figure's expected range: a number (exactly it) or {"min", "max"} (either or both, inclusive).
struct Bound {
  std::optional<double> min, max;
  bool holds(double v) const;
  std::string text() const;  // "= 0", "≥ 10", "≤ 2.5", "40 .. 60"
};

// One figure of an expect_bus step and its range.
struct BusCheck {
  const BusFigure* figure = nullptr;
  Bound bound;
  std::string text() const;  // the range, a word figure's as "= error-passive"
};

// A figure's value as the report writes it: to the µs of a millisecond (3 decimals), without
// trailing zeros ("100", "2.5", "0.667").
std::string figure_text(double v);

}  // namespace candp2::replay
