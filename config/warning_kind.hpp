// What a warning says of a configuration (docs/configuration.md "Warnings"): Rejected, a gateway
// or slave will refuse its Set_Prm or Chk_Cfg, and Unholdable, a watchdog shorter than the cycle
// itself (`candp2 validate` says invalid, so `candp2d --check` exits 1); Watchdog, a watchdog
// that will expire (docs/validate.md "The watchdog rule"); Overlap, PLC bytes of two stations
// overlap; Other, the rest. Beyond 20 of one kind the log sums them up in one line.
#pragma once

#include <cstdint>

namespace candp2::config {

enum class WarningKind : std::uint8_t { Other, Rejected, Overlap, Watchdog, Unholdable };

// Whether a warning of this kind makes the configuration invalid for `candp2 validate` (and so
// for `candp2d --check`); running, candp2d warns and starts (a test may want it on purpose).
constexpr bool makes_invalid(WarningKind k) {
  return k == WarningKind::Rejected || k == WarningKind::Unholdable;
}

}  // namespace candp2::config
