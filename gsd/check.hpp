// Consistency check of a parsed GSD model: what a configuration tool would reject or
// misinterpret. Usable by `candp2 gsd FILE` next to the parse diagnostics.
#pragma once

#include <vector>

#include "gsd/cfg.hpp"
#include "gsd/gsd.hpp"

namespace candp2::gsd {

// Findings in line order. Errors: mandatory keywords missing, references to undefined
// ExtUserPrmData/PrmText/modules, defaults outside their range, parameter offsets beyond
// User_Prm_Data_Len / Max_User_Prm_Data_Len, malformed module configuration bytes, limits
// exceeded. Warnings: doubtful but workable entries (e.g. User_Prm_Data disagreeing with the
// Ext_User_Prm_Data defaults). When `reader` applies to the GSD's Ident_Number, module entries are
// also checked against that device's rules (the CAN-DP/2's slot rules:
// tools/candp2/gsd_reading.hpp, manual §7, docs/slots.md "Chk_Cfg slots").
std::vector<Diagnostic> check(const Model& model, const DeviceReader* reader = nullptr);

}  // namespace candp2::gsd
