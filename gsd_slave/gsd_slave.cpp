#include "gsd_slave/gsd_slave.hpp"

#include <algorithm>
#include <variant>

#include "common/hex.hpp"

namespace candp2::gsd_slave {

namespace {

// IEC 61158-6-3 Ext_Diag_Data: a device-related block starts with a header byte 00LLLLLL, its
// length including the header (2..63).
constexpr std::size_t kMaxDeviceDiag = 62;

// The log component: the configured name ("io1", "io1.dp"), else "slaveN" / "dpN".
std::string log_name(const SlaveSetup& s) {
  return s.name.empty() ? "slave" + std::to_string(s.address) : s.name;
}

dp::SlaveInfo slave_info(const SlaveSetup& s, const Profile& p) {
  dp::SlaveInfo info;
  info.address = s.address;
  info.ident_number = p.ident_number;
  info.options = p.options();
  if (!s.name.empty()) info.log_name = s.name + ".dp";
  return info;
}

}  // namespace

std::unique_ptr<GsdSlave> GsdSlave::create(SlaveSetup setup, std::string* error) {
  if (!setup.gsd) {
    *error = "no GSD model";
    return nullptr;
  }
  auto profile = read_profile(*setup.gsd);
  if (auto* e = std::get_if<std::string>(&profile)) {
    *error = *e;
    return nullptr;
  }
  Configuration cfg;
  if (setup.cfg) {
    cfg = configuration_of(*setup.cfg);
  } else {
    std::vector<const gsd::Module*> modules;
    for (std::size_t i : setup.modules) {
      if (i >= setup.gsd->modules.size()) {
        *error = "module index " + std::to_string(i) + ": the GSD has " +
                 std::to_string(setup.gsd->modules.size()) + " modules";
        return nullptr;
      }
      modules.push_back(&setup.gsd->modules[i]);
    }
    cfg = configuration_of(std::move(modules));
  }
  return std::unique_ptr<GsdSlave>(
      new GsdSlave(std::move(setup), std::get<Profile>(std::move(profile)), std::move(cfg)));
}

GsdSlave::GsdSlave(SlaveSetup setup, Profile profile, Configuration cfg)
    : setup_(std::move(setup)),
      profile_(std::move(profile)),
      cfg_(std::move(cfg)),
      prm_layout_(gsd_slave::user_prm_layout(*setup_.gsd, cfg_.modules, !setup_.cfg.has_value())),
      log_(setup_.log, log_name(setup_)),
      slave_(slave_info(setup_, profile_), *this, setup_.log),
      field_inputs_(cfg_.decoded.input_len, 0),
      field_outputs_(cfg_.decoded.output_len, 0) {
  log_.info(profile_.name() + ", configuration " + hex_bytes(cfg_.bytes) + " (" +
            std::to_string(input_length()) + " input, " + std::to_string(output_length()) +
            " output bytes)");
}

bool GsdSlave::write_inputs(std::size_t offset, std::span<const std::uint8_t> bytes) {
  if (offset > field_inputs_.size() || bytes.size() > field_inputs_.size() - offset) return false;
  std::copy(bytes.begin(), bytes.end(),
            field_inputs_.begin() + static_cast<std::ptrdiff_t>(offset));
  return true;
}

bool GsdSlave::set_device_diag(std::vector<std::uint8_t> bytes, bool fault) {
  if (bytes.empty() || bytes.size() > kMaxDeviceDiag) return false;
  log_.info("device diagnosis " + hex_bytes(bytes) + (fault ? " (Ext_Diag)" : " (status)"));
  device_diag_ = std::move(bytes);
  device_fault_ = fault;
  return true;
}

void GsdSlave::clear_device_diag() {
  if (device_diag_) log_.info("device diagnosis cleared");
  device_diag_.reset();
  device_fault_ = false;
}

dp::ExtDiag GsdSlave::ext_diag() const {
  dp::ExtDiag d;
  if (!device_diag_) return d;
  // Sized first: GCC 12 at -O2 reports a false -Warray-bounds for push_back() then insert().
  d.data.resize(device_diag_->size() + 1);
  d.data[0] = static_cast<std::uint8_t>(device_diag_->size() + 1);  // header 00LLLLLL
  std::copy(device_diag_->begin(), device_diag_->end(), d.data.begin() + 1);
  d.ext_diag = device_fault_;
  return d;
}

void GsdSlave::force_prm_fault(bool on, Time now) {
  force_prm_ = on;
  log_.warn(on ? "Prm fault forced" : "forced Prm fault released");
  if (on) {
    prm_problem_ = "forced Prm fault";
    slave_.raise_prm_fault({static_cast<std::uint8_t>(dp::kPrmStdLen), 0}, now);
  }
}

void GsdSlave::force_cfg_fault(bool on, Time now) {
  force_cfg_ = on;
  log_.warn(on ? "Cfg fault forced" : "forced Cfg fault released");
  if (on) {
    cfg_problem_ = "forced Cfg fault";
    slave_.raise_cfg_fault({0, static_cast<std::uint8_t>(CfgCode::Differs)}, now);
  }
}

std::optional<dp::PrmFault> GsdSlave::on_set_prm(std::span<const std::uint8_t> telegram, Time) {
  if (force_prm_) {
    prm_problem_ = "forced Prm fault";
    return dp::PrmFault{static_cast<std::uint8_t>(dp::kPrmStdLen), 0};
  }
  const auto user = telegram.subspan(dp::kPrmStdLen);
  if (auto p = check_user_prm(prm_layout_, profile_, user)) {
    prm_problem_ = p->text;
    log_.warn("user parameters rejected: " + p->text);
    return dp::PrmFault{static_cast<std::uint8_t>(std::min<std::size_t>(p->byte, 255)), p->correct};
  }
  prm_problem_.clear();
  // DPV1_Status_1 bit 2: WD_Base_1ms (checked against WD_Base_1ms_supp above).
  watchdog_1ms_ = profile_.dpv1 && !user.empty() && (user[0] & 0x04);
  return std::nullopt;
}

std::optional<dp::CfgFault> GsdSlave::on_chk_cfg(std::span<const std::uint8_t> cfg, Time) {
  if (force_cfg_) {
    cfg_problem_ = "forced Cfg fault";
    return dp::CfgFault{0, static_cast<std::uint8_t>(CfgCode::Differs)};
  }
  if (auto p = check_chk_cfg(profile_, cfg_, cfg)) {
    cfg_problem_ = p->text;
    log_.warn("Chk_Cfg rejected: " + p->text);
    return dp::CfgFault{static_cast<std::uint8_t>(std::min<std::size_t>(p->entry, 255)),
                        static_cast<std::uint8_t>(p->code)};
  }
  cfg_problem_.clear();
  return std::nullopt;
}

void GsdSlave::on_enter_data_exchange(Time) {}

void GsdSlave::on_leave_data_exchange(Time) {
  to_safe_state();
}

void GsdSlave::to_safe_state() {
  if (setup_.safe_state == SafeState::Zero)
    std::fill(field_outputs_.begin(), field_outputs_.end(), 0);
}

void GsdSlave::on_data_exchange(std::span<const std::uint8_t> outputs,
                                std::span<std::uint8_t> inputs, Time) {
  if (outputs.size() == field_outputs_.size())
    std::copy(outputs.begin(), outputs.end(), field_outputs_.begin());
  else
    to_safe_state();  // no outputs: Clear_Data or a fail-safe telegram (dp_slave.hpp)
  std::copy_n(field_inputs_.begin(), std::min(inputs.size(), field_inputs_.size()), inputs.begin());
}

}  // namespace candp2::gsd_slave
