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
      log_(log, info.log_name.empty() ? "dp" + std::to_string(info.address) : info.log_name) {
  info_.options.max_diag_len = std::clamp(info_.options.max_diag_len, kDiagStdLen, kDiagMaxLen);
}

void DpSlave::enter(SlaveState next, Time now, std::string_view why) {
  if (next == state_) return;
  const SlaveState prev = state_;
  state_ = next;
  log_.info(std::string(to_string(prev)) + " -> " + std::string(to_string(next)) + ": " +
            std::string(why));
  if (prev == SlaveState::DataExch) app_.on_leave_data_exchange(now);
  if (next == SlaveState::DataExch) app_.on_enter_data_exchange(now);
}

void DpSlave::to_wait_prm(Time now, std::string_view why) {
  prm_.reset();
  enter(SlaveState::WaitPrm, now, why);
}

void DpSlave::reject_prm(PrmFault fault, std::string_view why) {
  prm_fault_ = fault;
  log_.warn("Set_Prm rejected: " + std::string(why) + " (diag 3D " +
            hex_bytes(std::array{fault.byte, fault.correct}) + ")");
}

// IEC 61158-6-3 Set_Prm Station_Status bits 7 Lock_Req, 6 Unlock_Req, for every profile
// (docs/dp-slave.md "Lock", docs/slaves.md "Set_Prm"): 1 0 locks the slave to this master and
// parameterizes it; 0 1 and 1 1 unlock it; 0 0 only changes min_TSDR (the FDL front end takes it)
// and, from the master holding the lock, the user parameters. A slave locked to one master ignores
// Set_Prm from any other. True when the telegram was fully handled here (`*accepted` says how).
bool DpSlave::lock_request(std::uint8_t master, const PrmStd& p, std::span<const std::uint8_t> t,
                           Time now, bool* accepted) {
  *accepted = false;
  const bool locked = state_ != SlaveState::WaitPrm && master_ != kNoMaster;
  if (locked && master != master_) {
    log_.warn("Set_Prm from master " + std::to_string(master) + " ignored: locked by master " +
              std::to_string(master_));
    return true;
  }
  const bool lock = p.station_status & kPrmLockReq;
  const bool unlock = p.station_status & kPrmUnlockReq;
  if (lock && !unlock) return false;  // the ordinary parameterization
  // docs/dp-slave.md "Lock": an unlocked CAN-DP/2 takes 0 0 as an ordinary parameterization.
  if (!unlock && !locked && !standard()) return false;
  touch(now);
  if (unlock) {
    log_.info("Set_Prm with Unlock_Req from master " + std::to_string(master) + ": unlocked");
    prm_fault_.reset();
    cfg_fault_.reset();
    not_supported_ = false;
    master_ = kNoMaster;
    to_wait_prm(now, "unlocked");
    return true;
  }
  if (!locked) {
    log_.warn("Set_Prm from master " + std::to_string(master) +
              " without Lock_Req: only min_TSDR is taken, the slave stays in " +
              std::string(to_string(state_)));
    *accepted = true;
    return true;
  }
  // 0 0 from the master holding the lock: state, watchdog and lock unchanged; a generic slave takes
  // the user parameters, the CAN-DP/2 keeps its own (docs/dp-slave.md "Lock").
  if (!check_prm(t) && (!standard() || !app_.on_set_prm(t, now))) {
    log_.info("Set_Prm without Lock_Req from master " + std::to_string(master) + ": " +
              (standard() ? "user parameters taken" : "only min_TSDR is taken") + ", still " +
              std::string(to_string(state_)));
    *accepted = true;
    return true;
  }
  return false;  // judged (and rejected) as an ordinary Set_Prm
}

// The checks before the user parameters, in this order (docs/decisions.md "DP slave"): length,
// Sync_Req / Freeze_Req, Ident_Number, and for the standard profile the watchdog factors.
std::optional<DpSlave::PrmRejection> DpSlave::check_prm(std::span<const std::uint8_t> t) const {
  const std::size_t expected = kPrmStdLen + info_.user_prm_len;
  // docs/dp-slave.md "User parameters": checks run in telegram byte order; the length comes first.
  // The standard profile leaves the user parameter length to the application.
  if (standard() ? t.size() < kPrmStdLen : t.size() != expected) {
    const auto first = static_cast<std::uint8_t>(std::min(t.size(), expected));
    return PrmRejection{PrmFault{first, 0},
                        "length " + std::to_string(t.size()) + ", expected " +
                            (standard() ? "at least 7" : std::to_string(expected))};
  }
  const auto p = *decode_prm_std(t);
  // docs/dp-slave.md: FREEZE/SYNC not supported -> Not_Supported (Station_Status_1 bit 4). The
  // standard profile supports what its GSD says.
  const bool sync_bad = p.sync_req() && !(standard() && info_.options.sync);
  const bool freeze_bad = p.freeze_req() && !(standard() && info_.options.freeze);
  if (sync_bad || freeze_bad)
    return PrmRejection{std::nullopt, sync_bad ? "Sync_Req" : "Freeze_Req"};
  if (p.ident_number != info_.ident_number) {
    const bool high_wrong = (p.ident_number >> 8) != (info_.ident_number >> 8);
    return PrmRejection{high_wrong
                            ? PrmFault{4, static_cast<std::uint8_t>(info_.ident_number >> 8)}
                            : PrmFault{5, static_cast<std::uint8_t>(info_.ident_number & 0xFF)},
                        "wrong Ident_Number"};
  }
  // IEC 61158-6-3: WD_Fact_1, WD_Fact_2 are 1..255 when the watchdog is on.
  if (standard() && p.wd_on() && (p.wd_fact_1 == 0 || p.wd_fact_2 == 0))
    return PrmRejection{PrmFault{static_cast<std::uint8_t>(p.wd_fact_1 == 0 ? 1 : 2), 1},
                        "watchdog factor 0"};
  return std::nullopt;
}

bool DpSlave::set_prm(std::uint8_t master, std::span<const std::uint8_t> t, Time now) {
  if (t.size() >= kPrmStdLen) {
    bool accepted = false;
    if (lock_request(master, *decode_prm_std(t), t, now, &accepted)) return accepted;
  }
  touch(now);
  // A new Set_Prm starts parameterization afresh: earlier faults are forgotten.
  prm_fault_.reset();
  cfg_fault_.reset();
  not_supported_ = false;
  auto fail = [&](std::optional<PrmFault> fault, std::string_view why) {
    if (fault) reject_prm(*fault, why);
    to_wait_prm(now, "Set_Prm rejected");
    return false;
  };
  if (auto r = check_prm(t)) {
    if (!r->fault) {
      not_supported_ = true;
      log_.warn("Set_Prm rejected: " + r->why + " not supported");
      return fail(std::nullopt, "not supported");
    }
    return fail(r->fault, r->why);
  }
  if (auto fault = app_.on_set_prm(t, now)) return fail(*fault, "user parameter");
  const auto std_part = *decode_prm_std(t);
  prm_ = std_part;
  master_ = master;
  watchdog_1ms_ = standard() && app_.watchdog_base_1ms();
  log_.info("Set_Prm accepted from master " + std::to_string(master) +
            (std_part.wd_on() ? ", watchdog " + std::to_string(*watchdog_ms()) + " ms"
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
    log_.warn("Chk_Cfg rejected: slot " + std::to_string(fault->slot) + " code " +
              std::to_string(fault->code));
    // docs/dp-slave.md: a faulty Chk_Cfg leaves the slave in Wait_Prm.
    to_wait_prm(now, "Chk_Cfg rejected");
    return false;
  }
  cfg_fault_.reset();
  cfg_.assign(cfg.begin(), cfg.end());
  inputs_.assign(app_.input_length(), 0);
  outputs_.assign(app_.output_length(), 0);
  sync_mode_ = freeze_mode_ = clear_ = fail_safe_telegram_ = false;
  synced_.clear();
  enter(SlaveState::DataExch, now, "Chk_Cfg accepted");
  return true;
}

DpSlave::Diag DpSlave::slave_diag(Time now) {
  advance(now);
  Diag d{};
  if (standard()) {
    const auto bytes = standard_diag();
    std::copy_n(bytes.begin(), std::min(bytes.size(), d.size()), d.begin());
    return d;
  }
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

std::vector<std::uint8_t> DpSlave::diagnosis(Time now) {
  if (!standard()) {
    const Diag d = slave_diag(now);
    return {d.begin(), d.end()};
  }
  advance(now);
  return standard_diag();
}

// IEC 61158-6-3 Slave_Diag: Station_Status_1..3, Diag.Master_Add, Ident_Number, Ext_Diag_Data
// (docs/slaves.md "Diagnosis").
std::vector<std::uint8_t> DpSlave::standard_diag() const {
  const ExtDiag ext = app_.ext_diag();
  std::uint8_t s1 = 0;
  if (state_ != SlaveState::DataExch) s1 |= kDiag1StationNotReady;
  if (cfg_fault_) s1 |= kDiag1CfgFault;
  if (ext.ext_diag) s1 |= kDiag1ExtDiag;
  if (not_supported_) s1 |= kDiag1NotSupported;
  if (prm_fault_) s1 |= kDiag1PrmFault;
  std::uint8_t s2 = kDiag2AlwaysOne;
  if (state_ == SlaveState::WaitPrm) s2 |= kDiag2PrmReq;
  if (prm_ && prm_->wd_on()) s2 |= kDiag2WdOn;
  if (freeze_mode_) s2 |= kDiag2FreezeMode;
  if (sync_mode_) s2 |= kDiag2SyncMode;
  const std::size_t room = info_.options.max_diag_len - kDiagStdLen;
  const bool overflow = ext.data.size() > room;
  const std::size_t n = std::min(room, ext.data.size());
  // Filled byte by byte: GCC 12 at -O2 reports a false -Warray-bounds for an initializer list
  // followed by insert().
  std::vector<std::uint8_t> d(kDiagStdLen + n, 0);
  d[0] = s1;
  d[1] = s2;
  d[2] = overflow ? kDiag3ExtDiagOverflow : 0;
  d[3] = master_;
  d[4] = static_cast<std::uint8_t>(info_.ident_number >> 8);
  d[5] = static_cast<std::uint8_t>(info_.ident_number & 0xFF);
  for (std::size_t i = 0; i < n; ++i) d[kDiagStdLen + i] = ext.data[i];
  return d;
}

std::optional<std::vector<std::uint8_t>> DpSlave::get_cfg(Time now) {
  advance(now);
  if (auto real = app_.real_cfg()) return real;
  if (state_ != SlaveState::DataExch) return std::nullopt;  // no Chk_Cfg accepted
  return cfg_;
}

std::optional<std::span<const std::uint8_t>> DpSlave::data_exchange(
    std::uint8_t master, std::span<const std::uint8_t> outputs, Time now) {
  advance(now);
  if (state_ != SlaveState::DataExch || master != master_) return std::nullopt;
  touch(now);
  // IEC 61158-6-3 Fail_Safe: a master in the Clear state may send no output bytes at all.
  const bool fail_safe =
      standard() && info_.options.fail_safe && outputs.empty() && app_.output_length() > 0;
  if (outputs.size() != app_.output_length() && !fail_safe) {
    // docs/dp-slave.md "Wrong output length" (IEC 61158-6-3): the configuration no longer holds,
    // the slave asks to be parameterized again.
    log_.warn("Data_Exchange with " + std::to_string(outputs.size()) +
              " output bytes, configured " + std::to_string(app_.output_length()) +
              ": refused, the slave leaves Data_Exch");
    to_wait_prm(now, "Data_Exchange with the wrong output length");
    return std::nullopt;
  }
  if (standard()) {
    if (fail_safe != fail_safe_telegram_)
      log_.info(fail_safe ? "Data_Exchange without outputs (Fail_Safe): outputs in the safe state"
                          : "Data_Exchange with outputs again");
    fail_safe_telegram_ = fail_safe;
    if (!fail_safe) outputs_.assign(outputs.begin(), outputs.end());
    standard_exchange(now);
    return std::span<const std::uint8_t>(inputs_);
  }
  outputs_.assign(outputs.begin(), outputs.end());
  app_.on_data_exchange(outputs, inputs_, now);
  return std::span<const std::uint8_t>(inputs_);
}

namespace {
// What the field sees of the outputs (docs/slaves.md "Global_Control").
std::span<const std::uint8_t> field_outputs(bool cleared, bool sync,
                                            const std::vector<std::uint8_t>& synced,
                                            const std::vector<std::uint8_t>& received) {
  if (cleared) return {};
  return sync ? std::span<const std::uint8_t>(synced) : std::span<const std::uint8_t>(received);
}
}  // namespace

void DpSlave::standard_exchange(Time now) {
  // Freeze mode: the inputs stay those sampled by the last Freeze command.
  if (freeze_mode_) return apply_outputs(now);
  // Sampled in place: no buffer allocated per telegram.
  inputs_.assign(app_.input_length(), 0);
  app_.on_data_exchange(field_outputs(clear_ || fail_safe_telegram_, sync_mode_, synced_, outputs_),
                        inputs_, now);
}

void DpSlave::apply_outputs(Time now) {
  std::vector<std::uint8_t> scratch(app_.input_length(), 0);
  app_.on_data_exchange(field_outputs(clear_ || fail_safe_telegram_, sync_mode_, synced_, outputs_),
                        scratch, now);
}

// IEC 61158-6-3 Global_Control (docs/slaves.md "Global_Control"): Clear_Data, Sync/Unsync,
// Freeze/Unfreeze from the master holding the lock, in Data_Exch, for the slave's groups.
void DpSlave::global_control(std::uint8_t master, std::uint8_t control, Time now,
                             std::uint8_t group_select) {
  if (!standard()) {
    touch(now);
    // manual §2.6: Global_Control services are not implemented; the telegram is ignored.
    log_.debug("Global_Control " + hex_bytes(std::array{control}) + " ignored (manual §2.6)");
    return;
  }
  const std::string what = "Global_Control " + hex_bytes(std::array{control, group_select});
  if (state_ != SlaveState::DataExch || master != master_) {
    log_.debug(what + " from master " + std::to_string(master) + " ignored in " +
               std::string(to_string(state_)));
    return;
  }
  touch(now);
  if (group_select != 0 && !(group_select & prm_->group_ident)) {
    log_.debug(what + " ignored: not for Group_Ident " + hex_bytes(std::array{prm_->group_ident}));
    return;
  }
  bool changed = false;
  const bool clear = control & kGcClearData;
  if (clear != clear_) {
    clear_ = clear;
    changed = true;
    log_.info(clear ? "Clear_Data: outputs in the safe state" : "Clear_Data ended");
  }
  // Unsync/Unfreeze win over Sync/Freeze in one command.
  if (control & (kGcSync | kGcUnsync)) {
    if (!info_.options.sync || !prm_->sync_req()) {
      log_.warn(what + ": Sync/Unsync ignored (" +
                (info_.options.sync ? "Sync_Req was not set in Set_Prm" : "Sync_Mode_supp = 0") +
                ")");
    } else {
      const bool sync = !(control & kGcUnsync);
      if (sync) synced_ = outputs_;
      if (sync != sync_mode_) log_.info(sync ? "Sync mode" : "Unsync: Sync mode ended");
      sync_mode_ = sync;
      changed = true;
    }
  }
  if (control & (kGcFreeze | kGcUnfreeze)) {
    if (!info_.options.freeze || !prm_->freeze_req()) {
      log_.warn(
          what + ": Freeze/Unfreeze ignored (" +
          (info_.options.freeze ? "Freeze_Req was not set in Set_Prm" : "Freeze_Mode_supp = 0") +
          ")");
    } else {
      const bool freeze = !(control & kGcUnfreeze);
      if (freeze != freeze_mode_) log_.info(freeze ? "Freeze mode" : "Unfreeze: Freeze mode ended");
      freeze_mode_ = freeze;
      if (freeze) {
        inputs_.assign(app_.input_length(), 0);
        app_.on_data_exchange(
            field_outputs(clear_ || fail_safe_telegram_, sync_mode_, synced_, outputs_), inputs_,
            now);
        changed = false;  // the outputs were just applied with the sample
      }
    }
  }
  if (changed) apply_outputs(now);
}

bool DpSlave::set_slave_add(std::uint8_t master, std::span<const std::uint8_t> data, Time now) {
  auto refuse = [&](const std::string& why) {
    log_.warn("Set_Slave_Add from master " + std::to_string(master) + " refused: " + why);
    return false;
  };
  if (!standard() || !info_.options.set_slave_add) return refuse("not supported");
  if (state_ != SlaveState::WaitPrm) return refuse("only in Wait_Prm");
  if (data.size() < 4) return refuse(std::to_string(data.size()) + " data bytes, expected 4");
  const std::uint16_t ident = static_cast<std::uint16_t>((data[1] << 8) | data[2]);
  if (ident != info_.ident_number) return refuse("wrong Ident_Number");
  if (data[0] > 125) return refuse("address " + std::to_string(data[0]) + " outside 0..125");
  if (address_locked_) return refuse("locked by an earlier No_Add_Chg");
  touch(now);
  log_.info("Set_Slave_Add from master " + std::to_string(master) + ": address " +
            std::to_string(info_.address) + " -> " + std::to_string(data[0]));
  info_.address = data[0];
  address_locked_ = data[3] != 0;
  return true;
}

std::optional<std::uint32_t> DpSlave::watchdog_ms() const {
  if (!prm_ || !prm_->wd_on()) return std::nullopt;
  // DPV1_Status_1 WD_Base_1ms: 1 ms × WD_Fact_1 × WD_Fact_2 instead of 10 ms × ...
  return watchdog_1ms_ ? std::uint32_t{prm_->wd_fact_1} * prm_->wd_fact_2 : prm_->watchdog_ms();
}

void DpSlave::advance(Time now) {
  const auto wd = watchdog_ms();
  if (!wd || state_ == SlaveState::WaitPrm) return;
  if (now - last_master_telegram_ > milliseconds(*wd)) {
    log_.warn("watchdog expired after " + std::to_string(*wd) + " ms without a master telegram");
    // Standard profile: the expiry also releases the lock (docs/slaves.md "Watchdog").
    if (standard()) master_ = kNoMaster;
    to_wait_prm(now, "watchdog");
  }
}

std::optional<Time> DpSlave::next_deadline() const {
  const auto wd = watchdog_ms();
  if (!wd || state_ == SlaveState::WaitPrm) return std::nullopt;
  return last_master_telegram_ + milliseconds(*wd) + microseconds(1);
}

void DpSlave::reset(Time now) {
  cfg_.clear();
  prm_fault_.reset();
  cfg_fault_.reset();
  not_supported_ = false;
  master_ = kNoMaster;
  sync_mode_ = freeze_mode_ = clear_ = fail_safe_telegram_ = false;
  to_wait_prm(now, "reset");
}

void DpSlave::raise_prm_fault(PrmFault fault, Time now) {
  prm_fault_ = fault;
  cfg_fault_.reset();
  log_.warn("Prm fault raised by the device");
  to_wait_prm(now, "Prm fault");
}

void DpSlave::raise_cfg_fault(CfgFault fault, Time now) {
  cfg_fault_ = fault;
  prm_fault_.reset();
  log_.warn("Cfg fault raised by the device");
  to_wait_prm(now, "Cfg fault");
}

}  // namespace candp2::dp
