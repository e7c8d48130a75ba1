// Named user parameters of the configuration (docs/configuration.md, "parameters") and the
// ExtUserPrmData of the CAN-DP/2 GSD they correspond to (gsd/CDPS04A4.GSD; manual §5.1.2,
// docs/dp-slave.md "User parameters"). With `candp2 validate --gsd FILE` the named parameters are
// encoded through the GSD (gsd/prm.hpp) instead of gw::encode_user_prm; for the shipped GSD both
// encodings agree byte for byte (tests/validate/prm_roundtrip_test.cpp).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gateway/user_prm.hpp"
#include "gsd/gsd.hpp"

namespace candp2::validate {

// One row of the mapping table of docs/validate.md.
struct ParamMapping {
  std::string_view config_key;  // key in $.gateways[i].parameters
  std::string_view gsd_name;    // ExtUserPrmData name in the GSD
  // The parameter's GSD value for these parameters (e.g. RTR-Frames: 0 = "Yes" = send RTR).
  std::int64_t (*gsd_value)(const gw::UserPrm&);
};

// Every GSD-visible user parameter, in the order of the shipped GSD's ExtUserPrmData 1..13.
// "canopen" appears twice: "slave" sets CANopen-Slave, "master" sets CANopen-Master.
std::span<const ParamMapping> param_mappings();

struct GsdSetPrm {
  std::vector<std::uint8_t> telegram;  // the whole Set_Prm telegram (7 standard + user bytes)
  std::vector<std::string> errors;     // the GSD cannot express these parameters
};

// Set_Prm for parameters `p` through a GSD: the DP standard bytes as gw::make_set_prm writes
// them (Station_Status, watchdog factors), the GSD's Ident_Number in bytes 4-5, then
// gsd::encode_user_prm with one override per mapped parameter. A mapped parameter the GSD does
// not define is skipped when `p` holds the gateway's default for it (the GSD's own bytes then
// stand), otherwise it is an error.
GsdSetPrm encode_set_prm(const gsd::Model& gsd, const gw::UserPrm& p, std::uint16_t watchdog_ms);

}  // namespace candp2::validate
