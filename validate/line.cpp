// The line in time for `candp2 validate` (docs/validate.md "The line").
#include "validate/line.hpp"

#include <algorithm>
#include <cstdio>

namespace candp2::validate {

std::size_t LineReport::warnings() const {
  return static_cast<std::size_t>(
      std::count_if(problems.begin(), problems.end(), [](const auto& p) { return !p.error; }));
}

bool LineReport::valid() const {
  return std::none_of(problems.begin(), problems.end(), [](const auto& p) { return p.error; });
}

namespace {
std::string ms_text(Duration d) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f ms", static_cast<double>(d.count()) / 1000.0);
  return b;
}
}  // namespace

LineReport check_line(const LineInput& in) {
  LineReport r;
  if (in.baud != 0) r.baud = in.baud;
  r.params = in.params;
  r.cycle_ms = in.cycle_ms;
  std::vector<fdl::CycleStation> st;
  std::vector<bool> taken(128, false);
  for (const auto& s : in.stations) {
    st.push_back({.outputs = s.outputs, .inputs = s.inputs, .tsdr_bits = in.params.min_tsdr_bits});
    taken[s.address & 0x7F] = true;
  }
  bool gap = false;  // a free address above the master's own up to HSA
  for (unsigned a = in.master_address + 1u; a <= std::min(in.params.hsa, 126u); ++a)
    gap = gap || !taken[a];
  r.cycle = fdl::predict_cycle(in.baud, in.params, st, gap);
  for (const auto& p : fdl::check_bus_parameters(in.params))
    r.problems.push_back({true, in.bus_parameters_path + "." + p.key, p.message, ""});
  const auto rate = gsd::rate_name(in.baud);
  for (const auto& s : in.stations) {
    if (!s.gsd && !s.max_tsdr_bits) continue;
    if (s.gsd && !gsd::supports_rate(*s.gsd, in.baud)) {
      r.problems.push_back({true, s.json_path,
                            "station " + s.name + ": " + s.gsd_name + " does not support " +
                                std::to_string(in.baud) + " bit/s (no " + std::string(*rate) +
                                "_supp = 1); set " + in.baud_path + " to a rate it supports",
                            s.json_path});
      continue;
    }
    const auto max = s.gsd ? gsd::max_tsdr(*s.gsd, in.baud) : s.max_tsdr_bits;
    if (max && *max > in.params.max_tsdr_bits)
      r.problems.push_back({false, in.bus_parameters_path + ".max_tsdr_bits",
                            "station " + s.name + " answers as late as " + std::to_string(*max) +
                                " bit times (MaxTsdr_" + std::string(*rate) + " of " + s.gsd_name +
                                "), later than max_tsdr_bits " +
                                std::to_string(in.params.max_tsdr_bits),
                            s.json_path});
  }
  const Duration grid = milliseconds(in.cycle_ms);
  if (r.cycle.worst > grid)
    r.problems.push_back({false, in.cycle_path,
                          "cycle_ms " + std::to_string(in.cycle_ms) +
                              " is shorter than the bus cycle the line needs: the cycles run back "
                              "to back every " +
                              ms_text(r.cycle.mean) + " (at most " + ms_text(r.cycle.worst) +
                              "), and grid points are missed",
                          ""});
  return r;
}

std::vector<Warning> station_warnings(const LineReport& r, const std::string& station_path) {
  std::vector<Warning> w;
  for (const auto& p : r.problems)
    if (p.station == station_path)
      w.push_back({WarningKind::Line, p.json_path, p.message, p.error});
  return w;
}

}  // namespace candp2::validate
