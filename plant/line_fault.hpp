// A fault on cue on the line in time (docs/faults.md "Line faults") as one type from the parser
// on: replay's line_fault step and the Modbus line block build it, the plant's control surface
// takes it (plant/control.hpp), the timed line applies it. Its kind is a station's answer fault
// (fdl::StationFault, the same values) or noise on the whole line.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "common/time.hpp"
#include "profibus_sim/fdl/wire_faults.hpp"

namespace candp2::plant {

enum class LineFaultKind : std::uint8_t {
  None = 0,  // cancels the station's fault
  Corrupt = 1,
  Silent = 2,
  Late = 3,
  DoubleAddress = 4,
  Noise = 5,  // every telegram on the whole line garbled for the duration
};
static_assert(static_cast<std::size_t>(LineFaultKind::Noise) == fdl::kStationFaultNames.size(),
              "a station's kinds are fdl::StationFault's values, noise the next");

// The answer fault of a station's kind (None for noise).
constexpr fdl::StationFault station_fault(LineFaultKind k) {
  return k == LineFaultKind::Noise ? fdl::StationFault::None : static_cast<fdl::StationFault>(k);
}
constexpr LineFaultKind line_fault_kind(fdl::StationFault f) {
  return static_cast<LineFaultKind>(f);
}
// "none", "corrupt", "silent", "late", "double_address" (fdl::kStationFaultNames) and "noise".
constexpr std::string_view to_string(LineFaultKind k) {
  return k == LineFaultKind::Noise ? std::string_view("noise") : fdl::to_string(station_fault(k));
}
inline std::optional<LineFaultKind> line_fault_kind(std::string_view name) {
  if (name == "noise") return LineFaultKind::Noise;
  if (const auto f = fdl::station_fault(name)) return line_fault_kind(*f);
  return std::nullopt;
}

struct LineFault {
  LineFaultKind kind = LineFaultKind::None;
  std::uint8_t station = 0;          // a station's fault: its DP address (noise: the whole line)
  std::uint32_t count = 1;           // answers faulted, without a duration
  std::uint32_t every = 1;           // one answer in every `every` requests
  std::optional<Duration> duration;  // how long instead of a count; noise: required
};

}  // namespace candp2::plant
