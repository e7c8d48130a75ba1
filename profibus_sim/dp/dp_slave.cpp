#include "profibus_sim/dp/dp_slave.hpp"

#include <algorithm>
#include <string>

#include "common/hex.hpp"

namespace candp2::dp {

std::string_view to_string(SlaveState s) {
  switch (s) {
    case SlaveState::WaitPrm:
      return "Wait_Prm";
    case SlaveState::WaitCfg:
      return "Wait_Cfg";
    case SlaveState::DataExch:
      return "Data_Exch";
  }
  return "?";
}

DpSlave::DpSlave(SlaveInfo info, SlaveApplication& app, LogSink* log)
    : info_(info),
      app_(app),
      log_(log, info.log_name.empty() ? "dp" + std::to_string(info.address) : info.log_name) {}

void DpSlave::enter(SlaveState next, Time now, std::string_view why) {
  if (next == state_) return;
  const SlaveState prev = state_;
  state_ = next;
  log_.info(std::string(to_string(prev)) + " -> " + std::string(to_string(next)) + ": " +
            std::string(why));
  if (prev == SlaveState::DataExch) app_.on_leave_data_exchange(now);
  if (next == SlaveState::DataExch) app_.on_enter_data_exchange(now);
}

void DpSlave::reject_prm(PrmFault fault, std::string_view why) {
  prm_fault_ = fault;
  log_.warn("Set_Prm rejected: " + std::string(why) + " (diag 3D " +
            hex_bytes(std::array{fault.byte, fault.correct}) + ")");
}

bool DpSlave::set_prm(std::uint8_t master, std::span<const std::uint8_t> t, Time now) {
  touch(now);
  // A new Set_Prm starts parameterization afresh: earlier faults are forgotten.
  prm_fault_.reset();
  cfg_fault_.reset();
  not_supported_ = false;
  const std::size_t expected = kPrmStdLen + info_.user_prm_len;
  auto fail = [&](std::optional<PrmFault> fault, std::string_view why) {
    if (fault) reject_prm(*fault, why);
    prm_.reset();
    cfg_accepted_ = false;
    enter(SlaveState::WaitPrm, now, "Set_Prm rejected");
    return false;
  };
  // emulator-spec §1.1: checks run in telegram byte order; the length comes first.
  if (t.size() != expected) {
    const auto first = static_cast<std::uint8_t>(std::min(t.size(), expected));
    return fail(PrmFault{first, 0},
                "length " + std::to_string(t.size()) + ", expected " + std::to_string(expected));
  }
  const auto std_part = *decode_prm_std(t);
  // emulator-spec §1: FREEZE/SYNC not supported -> Not_Supported (Station_Status_1 bit 4).
  if (std_part.sync_req() || std_part.freeze_req()) {
    not_supported_ = true;
    log_.warn("Set_Prm rejected: Sync_Req/Freeze_Req not supported");
    return fail(std::nullopt, "not supported");
  }
  if (std_part.ident_number != info_.ident_number) {
    const bool high_wrong = (std_part.ident_number >> 8) != (info_.ident_number >> 8);
    return fail(high_wrong ? PrmFault{4, static_cast<std::uint8_t>(info_.ident_number >> 8)}
                           : PrmFault{5, static_cast<std::uint8_t>(info_.ident_number & 0xFF)},
                "wrong Ident_Number");
  }
  if (auto fault = app_.on_set_prm(t, now)) return fail(*fault, "user parameter");
  prm_ = std_part;
  master_ = master;
  cfg_accepted_ = false;
  log_.info("Set_Prm accepted from master " + std::to_string(master) +
            (std_part.wd_on() ? ", watchdog " + std::to_string(std_part.watchdog_ms()) + " ms"
                              : ", watchdog off"));
  enter(SlaveState::WaitCfg, now, "Set_Prm accepted");
  return true;
}

bool DpSlave::chk_cfg(std::uint8_t master, std::span<const std::uint8_t> cfg, Time now) {
  touch(now);
  if (state_ == SlaveState::WaitPrm || master != master_) {
    log_.warn("Chk_Cfg ignored: slave not parameterized by master " + std::to_string(master));
    return false;
  }
  if (auto fault = app_.on_chk_cfg(cfg, now)) {
    cfg_fault_ = fault;
    cfg_accepted_ = false;
    log_.warn("Chk_Cfg rejected: slot " + std::to_string(fault->slot) + " code " +
              std::to_string(fault->code));
    // emulator-spec §1: a faulty Chk_Cfg leaves the slave in Wait_Prm.
    prm_.reset();
    enter(SlaveState::WaitPrm, now, "Chk_Cfg rejected");
    return false;
  }
  cfg_fault_.reset();
  cfg_.assign(cfg.begin(), cfg.end());
  cfg_accepted_ = true;
  inputs_.assign(app_.input_length(), 0);
  outputs_.assign(app_.output_length(), 0);
  enter(SlaveState::DataExch, now, "Chk_Cfg accepted");
  return true;
}

DpSlave::Diag DpSlave::slave_diag(Time now) {
  advance(now);
  Diag d{};
  const DeviceDiag dev = app_.device_diag();
  const bool fault_ext = prm_fault_ || cfg_fault_;
  std::uint8_t s1 = 0;
  if (state_ != SlaveState::DataExch) s1 |= kDiag1StationNotReady;
  if (cfg_fault_) s1 |= kDiag1CfgFault;
  if (fault_ext || dev.ext_diag) s1 |= kDiag1ExtDiag;
  if (not_supported_) s1 |= kDiag1NotSupported;
  if (prm_fault_) s1 |= kDiag1PrmFault;
  std::uint8_t s2 = kDiag2AlwaysOne;
  if (state_ != SlaveState::DataExch) s2 |= kDiag2PrmReq;
  if (prm_ && prm_->wd_on()) s2 |= kDiag2WdOn;
  d[0] = s1;
  d[1] = s2;
  d[2] = 0;
  d[3] = master_;
  d[4] = static_cast<std::uint8_t>(info_.ident_number >> 8);
  d[5] = static_cast<std::uint8_t>(info_.ident_number & 0xFF);
  d[6] = info_.ext_diag_header[0];
  d[7] = info_.ext_diag_header[1];
  if (prm_fault_) {
    d[8] = kExtDiagPrmSap;
    d[9] = prm_fault_->byte;
    d[10] = prm_fault_->correct;
  } else if (cfg_fault_) {
    d[8] = kExtDiagCfgSap;
    d[9] = cfg_fault_->slot;
    d[10] = cfg_fault_->code;
  } else {
    d[8] = dev.bytes[0];
    d[9] = dev.bytes[1];
    d[10] = dev.bytes[2];
  }
  return d;
}

std::optional<std::vector<std::uint8_t>> DpSlave::get_cfg(Time now) {
  advance(now);
  if (!cfg_accepted_) return std::nullopt;
  return cfg_;
}

std::optional<std::span<const std::uint8_t>> DpSlave::data_exchange(
    std::uint8_t master, std::span<const std::uint8_t> outputs, Time now) {
  advance(now);
  if (state_ != SlaveState::DataExch || master != master_) return std::nullopt;
  touch(now);
  if (outputs.size() != app_.output_length()) {
    log_.warn("Data_Exchange with " + std::to_string(outputs.size()) +
              " output bytes, configured " + std::to_string(app_.output_length()) + ": ignored");
    return std::nullopt;
  }
  outputs_.assign(outputs.begin(), outputs.end());
  app_.on_data_exchange(outputs, inputs_, now);
  return std::span<const std::uint8_t>(inputs_);
}

void DpSlave::global_control(std::uint8_t, std::uint8_t control, Time now) {
  touch(now);
  // manual §2.6: Global_Control services are not implemented; the telegram is ignored.
  log_.debug("Global_Control " + hex_bytes(std::array{control}) + " ignored (manual §2.6)");
}

std::optional<std::uint32_t> DpSlave::watchdog_ms() const {
  if (prm_ && prm_->wd_on()) return prm_->watchdog_ms();
  return std::nullopt;
}

void DpSlave::advance(Time now) {
  const auto wd = watchdog_ms();
  if (!wd || state_ == SlaveState::WaitPrm) return;
  if (now - last_master_telegram_ > milliseconds(*wd)) {
    log_.warn("watchdog expired after " + std::to_string(*wd) + " ms without a master telegram");
    prm_.reset();
    cfg_accepted_ = false;
    enter(SlaveState::WaitPrm, now, "watchdog");
  }
}

std::optional<Time> DpSlave::next_deadline() const {
  const auto wd = watchdog_ms();
  if (!wd || state_ == SlaveState::WaitPrm) return std::nullopt;
  return last_master_telegram_ + milliseconds(*wd) + microseconds(1);
}

void DpSlave::reset(Time now) {
  prm_.reset();
  cfg_.clear();
  cfg_accepted_ = false;
  prm_fault_.reset();
  cfg_fault_.reset();
  not_supported_ = false;
  master_ = kNoMaster;
  enter(SlaveState::WaitPrm, now, "reset");
}

}  // namespace candp2::dp
