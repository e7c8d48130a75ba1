#include "gsd_slave/user_prm.hpp"

#include <algorithm>

#include "common/hex.hpp"

namespace candp2::gsd_slave {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

std::string quoted(std::string_view s) {
  std::string out(1, '"');
  out += gsd::to_utf8(trim(s));
  out += '"';
  return out;
}

bool bits_valid(const gsd::ExtUserPrmData& d) {
  return d.first_bit >= 0 && d.last_bit <= 7 && d.first_bit <= d.last_bit;
}

// The inverse of gsd::encode_user_prm's writing: bits of one byte, or big-endian 8/16/32 bits,
// signed types two's complement.
std::int64_t value_at(std::span<const std::uint8_t> user, std::size_t offset,
                      const gsd::ExtUserPrmData& d) {
  using gsd::PrmType;
  if (d.type == PrmType::Bit || d.type == PrmType::BitArea) {
    const unsigned width = static_cast<unsigned>(d.last_bit - d.first_bit + 1);
    return (user[offset] >> d.first_bit) & ((1u << width) - 1u);
  }
  const std::size_t n = d.size();
  std::uint64_t u = 0;
  for (std::size_t i = 0; i < n; ++i) u = (u << 8) | user[offset + i];
  const bool is_signed =
      d.type == PrmType::Signed8 || d.type == PrmType::Signed16 || d.type == PrmType::Signed32;
  if (is_signed && (u >> (8 * n - 1)) & 1u) return static_cast<std::int64_t>(u) - (1LL << (8 * n));
  return static_cast<std::int64_t>(u);
}

void add_fields(const gsd::Model& model, const gsd::PrmLayout& layout, std::size_t base,
                std::size_t block_len, const std::string& module, UserPrmLayout& out) {
  for (const auto& ref : layout.refs) {
    const gsd::ExtUserPrmData* d = model.ext_user_prm(ref.ref);
    if (!d || ref.offset < 0) continue;  // gsd::check reports it; the encoder skips it too
    const auto off = static_cast<std::size_t>(ref.offset);
    if (off + d->size() > block_len) continue;
    if ((d->type == gsd::PrmType::Bit || d->type == gsd::PrmType::BitArea) && !bits_valid(*d))
      continue;
    out.fields.push_back({base + off, d, module});
  }
}

// Whether a parameter layout references the ExtUserPrmData called `name`.
bool references(const gsd::Model& model, const gsd::PrmLayout& layout, std::string_view name) {
  return std::any_of(layout.refs.begin(), layout.refs.end(), [&](const gsd::PrmRef& r) {
    const gsd::ExtUserPrmData* d = model.ext_user_prm(r.ref);
    return d && gsd::iequals(trim(d->name), trim(name));
  });
}

struct Bit {
  std::uint8_t mask;
  bool supported;
  const char* name;
};

// IEC 61158-6-3 DPV1_Status_1..3; the bits and GSD keywords of pyprofibus dp.py and the GSD
// specification. Reserved bits have supported = false.
std::optional<PrmProblem> check_dpv1(std::span<const std::uint8_t> user, const Dpv1Support& s,
                                     const UserPrmLayout& layout) {
  const Bit status[3][8] = {
      {{0x01, false, "reserved bit 0"},
       {0x02, false, "reserved bit 1"},
       {0x04, s.wd_base_1ms, "WD_Base_1ms (WD_Base_1ms_supp)"},
       {0x08, false, "reserved bit 3"},
       {0x10, false, "reserved bit 4"},
       {0x20, s.publisher, "Publisher_Enable (Publisher_supp)"},
       {0x40, s.fail_safe, "Fail_Safe (Fail_Safe)"},
       {0x80, true, "DPV1_Enable"}},
      {{0x01, true, "Check_Cfg_Mode"},
       {0x02, false, "reserved bit 1"},
       {0x04, s.update_alarm, "Enable_Update_Alarm (Update_Alarm_supp)"},
       {0x08, s.status_alarm, "Enable_Status_Alarm (Status_Alarm_supp)"},
       {0x10, s.manufacturer_alarm,
        "Enable_Manufacturer_Specific_Alarm (Manufacturer_Specific_Alarm_supp)"},
       {0x20, s.diagnostic_alarm, "Enable_Diagnostic_Alarm (Diagnostic_Alarm_supp)"},
       {0x40, s.process_alarm, "Enable_Process_Alarm (Process_Alarm_supp)"},
       {0x80, s.pull_plug_alarm, "Enable_Pull_Plug_Alarm (Pull_Plug_Alarm_supp)"}},
      {{0x01, true, "Alarm_Mode"},
       {0x02, true, "Alarm_Mode"},
       {0x04, true, "Alarm_Mode"},
       {0x08, s.prm_block_structure, "Prm_Structure (Prm_Block_Structure_supp)"},
       {0x10, s.isochron, "IsoM_Req (Isochron_Mode_supp)"},
       {0x20, false, "reserved bit 5"},
       {0x40, false, "reserved bit 6"},
       {0x80, s.prm_cmd, "Prm_Cmd (PrmCmd_supp)"}},
  };
  for (std::size_t i = 0; i < 3; ++i) {
    for (const Bit& b : status[i]) {
      if (!(user[i] & b.mask) || b.supported) continue;
      const auto def = i < layout.defaults.size() ? layout.defaults[i] : std::uint8_t{0};
      return PrmProblem{dp::kPrmStdLen + i, static_cast<std::uint8_t>(def & ~b.mask),
                        "DPV1_Status_" + std::to_string(i + 1) + " (byte " +
                            std::to_string(dp::kPrmStdLen + i) + ") = 0x" +
                            hex_bytes(user.subspan(i, 1)) + ": " + b.name +
                            (std::string(b.name).starts_with("reserved")
                                 ? " must be 0"
                                 : " is set, the GSD does not support it")};
    }
  }
  return std::nullopt;
}

}  // namespace

std::int64_t read_value(std::span<const std::uint8_t> user, const PrmField& field) {
  return value_at(user, field.offset, *field.def);
}

UserPrmLayout user_prm_layout(const gsd::Model& model, std::span<const gsd::Module* const> modules,
                              bool modules_known) {
  UserPrmLayout out;
  out.modules_known = modules_known;
  out.defaults = gsd::encode_user_prm(model).bytes;
  out.device_len = out.defaults.size();
  add_fields(model, model.user_prm, 0, out.device_len, "", out);
  if (!modules_known) return out;
  for (const gsd::Module* m : modules) {
    const auto block = gsd::encode_module_prm(model, *m).bytes;
    if (block.empty()) continue;
    add_fields(model, m->prm, out.defaults.size(), block.size(), m->name, out);
    out.defaults.insert(out.defaults.end(), block.begin(), block.end());
  }
  return out;
}

std::optional<PrmProblem> check_user_prm(const UserPrmLayout& layout, const Profile& profile,
                                         std::span<const std::uint8_t> user) {
  const std::size_t n = user.size();
  auto byte_at = [&](std::size_t offset) {
    return offset < layout.defaults.size() ? layout.defaults[offset] : std::uint8_t{0};
  };
  if (profile.max_user_prm_len && n > *profile.max_user_prm_len)
    return PrmProblem{dp::kPrmStdLen + *profile.max_user_prm_len, 0,
                      std::to_string(n) + " user parameter bytes, Max_User_Prm_Data_Len is " +
                          std::to_string(*profile.max_user_prm_len)};
  const std::size_t expected = layout.modules_known ? layout.defaults.size() : layout.device_len;
  if (layout.modules_known ? n != expected : n < expected) {
    const std::size_t at = std::min(n, expected);
    return PrmProblem{dp::kPrmStdLen + at, byte_at(at),
                      std::to_string(n) + " user parameter bytes, the GSD defines " +
                          (layout.modules_known ? "" : "at least ") + std::to_string(expected) +
                          (layout.modules_known && layout.defaults.size() != layout.device_len
                               ? " with the configured modules"
                               : "")};
  }
  if (profile.dpv1) {
    if (n < 3)
      return PrmProblem{dp::kPrmStdLen + n, 0,
                        "a DP-V1 slave's user parameters begin with the 3 DPV1_Status bytes, got " +
                            std::to_string(n) + " bytes"};
    if (auto p = check_dpv1(user, profile.dpv1_support, layout)) return p;
  }
  for (const PrmField& f : layout.fields) {
    if (f.offset + f.def->size() > n) continue;
    const std::int64_t v = value_at(user, f.offset, *f.def);
    const std::string why = gsd::value_error(*f.def, v);
    if (why.empty()) continue;
    const std::size_t byte = dp::kPrmStdLen + f.offset;
    return PrmProblem{byte, byte_at(f.offset),
                      quoted(f.def->name) +
                          (f.module.empty() ? "" : " of module " + quoted(f.module)) + " (byte " +
                          std::to_string(byte) + ") = " + std::to_string(v) + ": " + why};
  }
  return std::nullopt;
}

gsd::EncodeResult encode_user_prm(const gsd::Model& model,
                                  std::span<const gsd::Module* const> modules,
                                  std::span<const gsd::PrmOverride> overrides) {
  gsd::EncodeResult out;
  auto for_layout = [&](const gsd::PrmLayout& layout) {
    std::vector<gsd::PrmOverride> mine;
    for (const auto& o : overrides)
      if (references(model, layout, o.name)) mine.push_back(o);
    return mine;
  };
  for (const auto& o : overrides) {
    bool used = references(model, model.user_prm, o.name);
    for (const gsd::Module* m : modules) used = used || references(model, m->prm, o.name);
    if (used) continue;
    const bool defined = std::any_of(
        model.ext_user_prm_data.begin(), model.ext_user_prm_data.end(),
        [&](const gsd::ExtUserPrmData& d) { return gsd::iequals(trim(d.name), trim(o.name)); });
    out.errors.push_back(quoted(o.name) + (defined ? ": not referenced by the device's or the "
                                                     "configured modules' parameter bytes"
                                                   : ": no such parameter (ExtUserPrmData name)"));
  }
  const auto device = gsd::encode_user_prm(model, for_layout(model.user_prm));
  out.bytes = device.bytes;
  out.errors.insert(out.errors.end(), device.errors.begin(), device.errors.end());
  for (const gsd::Module* m : modules) {
    const auto block = gsd::encode_module_prm(model, *m, for_layout(m->prm));
    out.bytes.insert(out.bytes.end(), block.bytes.begin(), block.bytes.end());
    out.errors.insert(out.errors.end(), block.errors.begin(), block.errors.end());
  }
  return out;
}

std::vector<std::uint8_t> encode_set_prm(std::uint16_t ident, const StdPrmRequest& request,
                                         std::span<const std::uint8_t> user) {
  dp::PrmStd s;
  s.station_status = dp::kPrmLockReq;
  if (request.sync) s.station_status |= dp::kPrmSyncReq;
  if (request.freeze) s.station_status |= dp::kPrmFreezeReq;
  if (request.watchdog_ms > 0) {
    // 10 ms × f1 × f2 >= watchdog_ms and as close as whole factors allow: f2 as small as
    // possible, f1 then rounded up.
    const unsigned units = (request.watchdog_ms + 9u) / 10u;
    const unsigned f2 = (units + 254u) / 255u;
    s.station_status |= dp::kPrmWdOn;
    s.wd_fact_2 = static_cast<std::uint8_t>(f2);
    s.wd_fact_1 = static_cast<std::uint8_t>((units + f2 - 1u) / f2);
  }
  s.ident_number = ident;
  s.group_ident = request.group;
  std::vector<std::uint8_t> t(dp::kPrmStdLen);
  dp::encode_prm_std(s, t);
  t.insert(t.end(), user.begin(), user.end());
  return t;
}

}  // namespace candp2::gsd_slave
