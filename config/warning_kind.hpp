// What a warning says of a configuration (docs/configuration.md "Warnings"): Rejected, a gateway
// or slave will refuse its Set_Prm or Chk_Cfg (`candp2 validate` says invalid, so `candp2d
// --check` exits 1); Overlap, PLC bytes of two stations overlap; Other, the rest. Beyond 20 of
// one kind the log sums them up in one line.
#pragma once

#include <cstdint>

namespace candp2::config {

enum class WarningKind : std::uint8_t { Other, Rejected, Overlap };

}  // namespace candp2::config
