// A slave's user parameters (Set_Prm bytes 7..) as its GSD defines them, for both ends:
// the master encodes them (defaults plus named overrides), the slave checks what it receives
// (length, DPV1_Status bytes, every ExtUserPrmData value). docs/slaves.md "User parameters".
//
// Layout (GSD specification): the device's block — User_Prm_Data, Ext_User_Prm_Data_Const,
// Ext_User_Prm_Data_Ref as gsd::encode_user_prm writes them — followed by one block per configured
// module that defines parameters (Ext_Module_Prm_Data_Len and its own Const/Ref lines), in the
// order of the modules. Pure.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "gsd/gsd.hpp"
#include "gsd/prm.hpp"
#include "gsd_slave/profile.hpp"

namespace candp2::gsd_slave {

// One ExtUserPrmData value in the user parameter bytes.
struct PrmField {
  std::size_t offset = 0;  // from the first user parameter byte (telegram byte 7)
  const gsd::ExtUserPrmData* def = nullptr;
  std::string module;  // the module whose block holds it; "" for the device's block
};

struct UserPrmLayout {
  std::vector<std::uint8_t> defaults;  // the default user parameter bytes (all blocks)
  std::size_t device_len = 0;          // bytes of the device's block
  // false: the configuration was given as raw bytes (cfg_hex), the module blocks are unknown and
  // only the device's block is checked.
  bool modules_known = true;
  std::vector<PrmField> fields;
};

// The layout for a slave with these modules (pointers into `model`, which must outlive it).
UserPrmLayout user_prm_layout(const gsd::Model& model, std::span<const gsd::Module* const> modules,
                              bool modules_known = true);

// The value of a field as `user` holds it (bits of a Bit/BitArea; 16/32 bits big-endian; signed
// types two's complement). `user` must hold the field.
std::int64_t read_value(std::span<const std::uint8_t> user, const PrmField& field);

// Why a slave rejects its user parameters (the first problem, in byte order after the length).
struct PrmProblem {
  std::size_t byte = 0;      // Set_Prm telegram byte (7 = the first user parameter byte)
  std::uint8_t correct = 0;  // a correct value of that byte (the GSD default)
  std::string text;          // "\"Class\" (byte 22) = 40: outside the range 5-30"
};

// The user parameter bytes of a Set_Prm (telegram bytes 7..) against the layout and the profile:
//  1. not more than Max_User_Prm_Data_Len bytes;
//  2. exactly as many as the layout defines (with unknown module blocks: at least the device's);
//  3. DP-V1 slave: DPV1_Status_1..3 reserved bits clear, every feature bit one the GSD supports;
//  4. every ExtUserPrmData value within its range or list (and its data type).
std::optional<PrmProblem> check_user_prm(const UserPrmLayout& layout, const Profile& profile,
                                         std::span<const std::uint8_t> user);

// Master side: the user parameter bytes with named overrides (ExtUserPrmData names, compared
// trimmed and case-insensitively; a value may be a number or a PrmText text). An override goes to
// every block that references the name; a name no block references is an error.
gsd::EncodeResult encode_user_prm(const gsd::Model& model,
                                  std::span<const gsd::Module* const> modules,
                                  std::span<const gsd::PrmOverride> overrides = {});

// The DP standard bytes the master sends (IEC 61158-6-3 Set_Prm bytes 0..6).
struct StdPrmRequest {
  std::uint16_t watchdog_ms = 0;  // 0 = WD off; else 10 ms × WD_Fact_1 × WD_Fact_2 ≥ this
  bool sync = false;              // Sync_Req
  bool freeze = false;            // Freeze_Req
  std::uint8_t group = 0;         // Group_Ident
};
// Station_Status = Lock_Req (+ WD_On, Sync_Req, Freeze_Req), the watchdog factors, min_TSDR 0
// (keep), the Ident_Number, Group_Ident; then `user`.
std::vector<std::uint8_t> encode_set_prm(std::uint16_t ident, const StdPrmRequest& request,
                                         std::span<const std::uint8_t> user);

}  // namespace candp2::gsd_slave
