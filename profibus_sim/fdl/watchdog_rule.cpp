// The watchdog rule (docs/validate.md "The watchdog rule").
#include "profibus_sim/fdl/watchdog_rule.hpp"

#include <algorithm>
#include <cstdio>

namespace candp2::fdl {

namespace {

// The DP services' SAPs (DSAP, SSAP) ahead of their data in an SD2 (dp_wire.hpp).
constexpr std::size_t kSapBytes = 2;

// A parameterization telegram and its answer, the station answering after the line's min_TSDR.
std::uint64_t answered_bits(const BusParameters& p, std::uint64_t request, std::uint64_t answer) {
  return fdl::message_bits(p, request, p.min_tsdr_bits, answer);
}

// One station's parameterization, the first Data_Exchange included (docs/profibus.md "The line
// in time": the master parameterizes a station in one go).
std::uint64_t parameterization_bits(const BusParameters& p, const WatchdogStation& s) {
  const std::uint64_t diag_request = telegram_bits(Kind::SD2, kSapBytes);
  const std::uint64_t diag =
      answered_bits(p, diag_request, telegram_bits(Kind::SD2, kSapBytes + s.diag_bytes));
  return answered_bits(p, telegram_bits(Kind::SD1), telegram_bits(Kind::SD1)) +  // FDL_Status
         diag +
         answered_bits(p, telegram_bits(Kind::SD2, kSapBytes + s.prm_bytes),
                       telegram_bits(Kind::SC)) +
         answered_bits(p, telegram_bits(Kind::SD2, kSapBytes + s.cfg_bytes),
                       telegram_bits(Kind::SC)) +
         diag + message_cycle_bits(p, {s.outputs, s.inputs, p.min_tsdr_bits});
}

std::string ms_text(Duration d) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f ms", static_cast<double>(d.count()) / 1000.0);
  return b;
}

// What to write: the DP watchdog counts in 10 ms (10 ms x WD_Fact_1 x WD_Fact_2).
std::string at_least(Duration d) {
  const auto ms = (d.count() + 9999) / 10000 * 10;
  return "; set watchdog_ms to at least " + std::to_string(ms);
}

}  // namespace

Duration WatchdogBounds::needed() const {
  return std::max(cycle + retries, startup) + late;
}

std::uint64_t startup_rotation_bits(const BusParameters& p,
                                    const std::vector<WatchdogStation>& stations, bool gap) {
  std::uint64_t bits = token_bits(p) + (gap ? gap_poll_bits(p) : 0);
  for (const auto& s : stations) bits += parameterization_bits(p, s);
  return bits;
}

WatchdogBounds watchdog_bounds(const WatchdogLine& line) {
  WatchdogBounds b;
  const Duration grid = milliseconds(line.cycle_ms);
  b.cycle = b.startup = grid;
  b.late = milliseconds(line.late_ms);
  if (line.baud == 0) return b;  // the ideal line: one step a cycle, no wire time
  std::vector<CycleStation> st;
  std::size_t longest = 0;  // the longest request a retry repeats
  for (const auto& s : line.stations) {
    st.push_back({s.outputs, s.inputs, line.params.min_tsdr_bits});
    longest = std::max(longest, s.outputs);
  }
  const auto cycle = predict_cycle(line.baud, line.params, st, line.gap);
  b.bus_cycle = cycle.worst;
  b.cycle = std::max(grid, cycle.worst);
  if (!line.stations.empty()) b.retries = bits_to_time(line.baud, retry_bits(line.params, longest));
  b.startup = std::max(
      grid, bits_to_time(line.baud, startup_rotation_bits(line.params, line.stations, line.gap)));
  return b;
}

WatchdogFinding judge_watchdog(const WatchdogBounds& b, std::uint32_t watchdog_ms) {
  const Duration wd = milliseconds(watchdog_ms);
  const std::string head = "watchdog " + std::to_string(watchdog_ms) + " ms is shorter than ";
  // The cycle's longer part: the line's own rotation, or the master cycle's grid.
  const std::string cycle = b.bus_cycle >= b.cycle ? "the bus cycle" : "the master cycle";
  if (watchdog_ms == 0 || wd >= b.needed()) return {};
  if (wd < b.cycle)
    return {WatchdogVerdict::NeverHolds,
            head + cycle + " itself (" + ms_text(b.cycle) +
                "): it expires between two Data_Exchanges every rotation and can never hold" +
                at_least(b.needed())};
  std::string why = b.cycle + b.retries >= b.startup
                        ? (b.retries == Duration{0} ? cycle + " " + ms_text(b.cycle)
                                                    : cycle + " " + ms_text(b.cycle) +
                                                          " with its retries " + ms_text(b.retries))
                        : "the rotation that parameterizes every station " + ms_text(b.startup);
  if (b.late > Duration{0}) why += ", up to " + ms_text(b.late) + " late";
  return {WatchdogVerdict::WillExpire, head + "the time the master may take to come back (" +
                                           ms_text(b.needed()) + ": " + why + "): it will expire" +
                                           at_least(b.needed())};
}

}  // namespace candp2::fdl
