// User parameter bytes (the part of Set_Prm after the 7 DP standard bytes) from a GSD:
// User_Prm_Data, then every Ext_User_Prm_Data_Const, then every Ext_User_Prm_Data_Ref with its
// ExtUserPrmData default or a named override. Bit(n) and BitArea(a-b) replace only their bits;
// 16- and 32-bit values are written big-endian (GSD spec; docs/dp-slave.md "User parameters" bytes
// 14..15).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "gsd/gsd.hpp"

namespace candp2::gsd {

// IEC 61158-6-3 Set_Prm: at most 244 octets, 7 of them DP standard bytes -> 237 user bytes.
inline constexpr std::size_t kMaxUserPrmLen = 237;

// "CAN-Bitrate" = 2, or "CAN-Bitrate" = "125 kbit/s" (a Text of the parameter's PrmText).
struct PrmOverride {
  std::string name;  // ExtUserPrmData name, compared trimmed and case-insensitively
  std::variant<std::int64_t, std::string> value;
};

// Parses "Name=value" (value: a number, or a PrmText text; quotes around either are removed).
// Names may contain '=' themselves ("Sync Time (0=Off, 65535=Default)=1000"): with a model, the
// longest ExtUserPrmData name followed by '=' is taken; otherwise the text splits at the last
// '=' outside quotes. Returns nullopt for text without a name and '='.
std::optional<PrmOverride> parse_override(std::string_view text, const Model* model = nullptr);

struct EncodeResult {
  std::vector<std::uint8_t> bytes;
  std::vector<std::string> errors;  // unknown names, values out of range, undefined references
  bool ok() const { return errors.empty(); }
};

// The device's user parameter bytes (top-level User_Prm_Data / Ext_User_Prm_Data_*).
EncodeResult encode_user_prm(const Model& model, std::span<const PrmOverride> overrides = {});
// A module's parameter bytes (its Ext_Module_Prm_Data_Len and Ext_User_Prm_Data_* lines).
EncodeResult encode_module_prm(const Model& model, const Module& module,
                               std::span<const PrmOverride> overrides = {});

// Why v is not a valid value of d ("" when it is): the definition's range or list, and what
// the data type can hold.
std::string value_error(const ExtUserPrmData& d, std::int64_t v);

// The limits of a data type: Bit 0..1, BitArea(a-b) 0..2^(b-a+1)-1, Unsigned8 0..255, ...
std::pair<std::int64_t, std::int64_t> type_limits(const ExtUserPrmData& d);

}  // namespace candp2::gsd
