// The CAN-DP/2's reading of GSD module entries for the GSD library (gsd::DeviceReader): every
// module entry of a GSD with the CAN-DP/2's Ident_Number (0x04A4, manual §4) is read by the
// gateway's slot rules, gw::read_cfg_entry (gateway/cfg_reading.hpp), so `candp2 gsd` and the
// emulated gateway can never disagree (docs/gsd.md).
#pragma once

#include "gsd/cfg.hpp"

namespace candp2::cli {

// Shows "CAN-DP/2: Rx 11-bit ID 0x181, ..." in gsd::summary and the finding "the CAN-DP/2 rejects
// this entry (Cfg fault code ...; manual §7, docs/slots.md)" in gsd::check.
const gsd::DeviceReader& candp2_reader();

}  // namespace candp2::cli
