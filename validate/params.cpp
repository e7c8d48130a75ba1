#include "validate/params.hpp"

#include <algorithm>

#include "gsd/prm.hpp"

namespace candp2::validate {

namespace {

std::int64_t flag(bool b) {
  return b ? 1 : 0;
}

// GSD ExtUserPrmData 1..13 of gsd/CDPS04A4.GSD (manual §4 and §5.1.2,
// docs/dp-slave.md "User parameters").
constexpr ParamMapping kMappings[] = {
    {"can_bitrate", "CAN-Bitrate",
     [](const gw::UserPrm& p) -> std::int64_t { return p.bitrate_index; }},
    {"communication_window", "Communication Window",
     [](const gw::UserPrm& p) { return flag(p.comm_window); }},
    // PrmText 3: RTR-Frames 0 = "Yes" = send RTR frames (docs/dp-slave.md "User parameters").
    {"rtr_frames", "RTR-Frames", [](const gw::UserPrm& p) { return flag(!p.send_rtr); }},
    {"canopen", "CANopen-Slave", [](const gw::UserPrm& p) { return flag(p.canopen_slave); }},
    {"canopen", "CANopen-Master", [](const gw::UserPrm& p) { return flag(p.canopen_master); }},
    {"start_frame", "Start-Frame", [](const gw::UserPrm& p) { return flag(p.start_frame); }},
    {"page_mode", "Page-Mode", [](const gw::UserPrm& p) { return flag(p.page_mode); }},
    {"module_id", "ModuleID", [](const gw::UserPrm& p) -> std::int64_t { return p.module_id; }},
    {"wakeup_s", "WakeUp Time (0=Off, 255=Default)",
     [](const gw::UserPrm& p) -> std::int64_t { return p.wakeup_s; }},
    {"sync_ms", "Sync Time (0=Off, 65535=Default)",
     [](const gw::UserPrm& p) -> std::int64_t { return p.sync_ms; }},
    {"can_diagnosis", "CAN-Diagnosis", [](const gw::UserPrm& p) { return flag(p.can_diagnosis); }},
    {"rx_counter", "Rx-Counter", [](const gw::UserPrm& p) { return flag(p.rx_counter); }},
    {"tx_counter", "Tx-Counter", [](const gw::UserPrm& p) { return flag(p.tx_counter); }},
};

bool defines(const gsd::Model& m, std::string_view name) {
  return std::any_of(m.ext_user_prm_data.begin(), m.ext_user_prm_data.end(),
                     [&](const gsd::ExtUserPrmData& d) { return gsd::iequals(d.name, name); });
}

}  // namespace

std::span<const ParamMapping> param_mappings() {
  return kMappings;
}

GsdSetPrm encode_set_prm(const gsd::Model& gsd, const gw::UserPrm& p, std::uint16_t watchdog_ms) {
  GsdSetPrm out;
  const gw::UserPrm defaults;
  std::vector<gsd::PrmOverride> overrides;
  for (const auto& m : kMappings) {
    const std::int64_t v = m.gsd_value(p);
    if (defines(gsd, m.gsd_name)) {
      overrides.push_back({std::string(m.gsd_name), v});
    } else if (v != m.gsd_value(defaults)) {
      out.errors.push_back(std::string(m.config_key) + " (GSD value " + std::to_string(v) +
                           ") needs the ExtUserPrmData \"" + std::string(m.gsd_name) +
                           "\", which the GSD does not define");
    }
  }
  const gsd::EncodeResult user = gsd::encode_user_prm(gsd, overrides);
  for (const auto& e : user.errors) out.errors.push_back(e);

  // DP standard part (EN 50170 DDLM_Set_Prm): as the built-in encoding writes it, with the
  // Ident_Number a configuration tool takes from the GSD.
  const auto builtin = gw::make_set_prm(p, watchdog_ms);
  out.telegram.assign(builtin.begin(), builtin.begin() + dp::kPrmStdLen);
  if (const auto ident = gsd.ident_number()) {
    out.telegram[4] = static_cast<std::uint8_t>((*ident >> 8) & 0xFF);
    out.telegram[5] = static_cast<std::uint8_t>(*ident & 0xFF);
  } else {
    out.errors.push_back("the GSD has no Ident_Number");
  }
  out.telegram.insert(out.telegram.end(), user.bytes.begin(), user.bytes.end());
  return out;
}

}  // namespace candp2::validate
