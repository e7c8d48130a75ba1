#include "gsd_slave/profile.hpp"

#include <algorithm>
#include <cstdio>

namespace candp2::gsd_slave {

namespace {

bool flag(const gsd::Model& m, std::string_view key) {
  return m.number(key).value_or(0) != 0;
}

}  // namespace

dp::SlaveOptions Profile::options() const {
  dp::SlaveOptions o;
  o.profile = dp::DpProfile::Standard;
  o.sync = sync;
  o.freeze = freeze;
  o.fail_safe = fail_safe;
  o.set_slave_add = set_slave_add;
  o.max_diag_len = max_diag_len;
  return o;
}

std::string Profile::name() const {
  auto trim = [](std::string_view s) {
    while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
    while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
    return gsd::to_utf8(s);
  };
  char ident[8];
  std::snprintf(ident, sizeof ident, "0x%04X", static_cast<unsigned>(ident_number));
  std::string s = trim(vendor);
  if (const std::string m = trim(model); !m.empty()) {
    if (!s.empty()) s += ' ';  // chars, not `" " + m`: GCC 12 -O3 false -Wrestrict
    s += m;
  }
  return s + ", Ident_Number " + ident;
}

std::variant<Profile, std::string> read_profile(const gsd::Model& m) {
  Profile p;
  const auto ident = m.ident_number();
  if (!ident) return std::string("the GSD has no Ident_Number");
  if (*ident < 0 || *ident > 0xFFFF)
    return "Ident_Number " + std::to_string(*ident) + " is outside 0..0xFFFF";
  p.ident_number = static_cast<std::uint16_t>(*ident);
  p.vendor = m.vendor_name();
  p.model = m.model_name();
  const gsd::Limits l = m.limits();
  p.modular = l.modular_station;
  auto opt = [](const std::optional<std::int64_t>& v) -> std::optional<std::size_t> {
    if (!v || *v < 0) return std::nullopt;
    return static_cast<std::size_t>(*v);
  };
  p.max_module = opt(l.max_module);
  p.max_input_len = opt(l.max_input_len);
  p.max_output_len = opt(l.max_output_len);
  p.max_data_len = opt(l.max_data_len);
  p.max_user_prm_len = opt(l.max_user_prm_data_len);
  // GSD: Max_Diag_Data_Len 6..244; a file without it is taken at the protocol's limit.
  if (const auto d = opt(l.max_diag_data_len))
    p.max_diag_len = std::clamp(*d, dp::kDiagStdLen, dp::kDiagMaxLen);
  p.sync = flag(m, "Sync_Mode_supp");
  p.freeze = flag(m, "Freeze_Mode_supp");
  p.set_slave_add = flag(m, "Set_Slave_Add_supp");
  p.fail_safe = flag(m, "Fail_Safe");
  p.dpv1 = flag(m, "DPV1_Slave");
  Dpv1Support& s = p.dpv1_support;
  s.wd_base_1ms = flag(m, "WD_Base_1ms_supp");
  s.publisher = flag(m, "Publisher_supp");
  s.fail_safe = p.fail_safe;
  s.update_alarm = flag(m, "Update_Alarm_supp");
  s.status_alarm = flag(m, "Status_Alarm_supp");
  s.manufacturer_alarm = flag(m, "Manufacturer_Specific_Alarm_supp");
  s.diagnostic_alarm = flag(m, "Diagnostic_Alarm_supp");
  s.process_alarm = flag(m, "Process_Alarm_supp");
  s.pull_plug_alarm = flag(m, "Pull_Plug_Alarm_supp");
  s.prm_block_structure = flag(m, "Prm_Block_Structure_supp");
  s.isochron = flag(m, "Isochron_Mode_supp");
  s.prm_cmd = flag(m, "PrmCmd_supp");
  return p;
}

}  // namespace candp2::gsd_slave
