// Human-readable summary of a GSD model for `candp2 gsd FILE`.
#pragma once

#include <string>

#include "gsd/cfg.hpp"
#include "gsd/gsd.hpp"

namespace candp2::gsd {

// Vendor, model, ident, baud rates, limits, user parameters with their byte/bit positions and
// defaults (with PrmText), the default user parameter bytes, and every module with its config
// bytes decoded (and, when `reader` applies to the GSD's Ident_Number, that device's reading of
// each entry: for the CAN-DP/2 the slot meaning of the comment bytes). UTF-8 output.
std::string summary(const Model& model, const DeviceReader* reader = nullptr);

}  // namespace candp2::gsd
