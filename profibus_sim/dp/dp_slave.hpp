// A DP-V0 slave state machine (docs/dp-slave.md): Wait_Prm → Wait_Cfg → Data_Exch, watchdog,
// Slave_Diag, Get_Cfg, Global_Control. Generic over the device: the device firmware plugs in as a
// SlaveApplication, like firmware behind a VPC3 ASIC. Driven only through DP services; time is
// passed in with every call. No I/O.
//
// Where DP-V0 leaves a device a choice, SlaveOptions::profile says which: DpProfile::CanDp2 is the
// CAN-DP/2 firmware (docs/decisions.md "DP slave": 11-byte diagnosis with the Prm/Cfg fault in
// bytes 8..10, one fixed Set_Prm length, Global_Control ignored, Sync/Freeze refused, a Set_Prm
// without Lock_Req taken in Wait_Prm); DpProfile::Standard is a slave as IEC 61158-6-3 describes
// it, with the optional services its GSD announces (docs/slaves.md "The DP-V0 slave"). The rules
// of the standard both keep are written once here: the lock (docs/dp-slave.md "Lock") and a
// Data_Exchange with the wrong output length (docs/dp-slave.md "Wrong output length").
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/log.hpp"
#include "common/time.hpp"
#include "profibus_sim/dp/dp_telegram.hpp"

namespace candp2::dp {

enum class SlaveState : std::uint8_t { WaitPrm = 0, WaitCfg = 1, DataExch = 2 };
std::string_view to_string(SlaveState s);

// Extended diagnosis bytes 8..10 (manual table 3.4.5): SAP of the failed service and its details.
inline constexpr std::uint8_t kExtDiagPrmSap = 0x3D;  // Set_Prm (SAP 61) faulty
inline constexpr std::uint8_t kExtDiagCfgSap = 0x3E;  // Chk_Cfg (SAP 62) faulty

// A Slave_Diag answer is 6..244 bytes (IEC 61158-6-3: 6 standard bytes, Ext_Diag_Data up to 238).
inline constexpr std::size_t kDiagStdLen = 6;
inline constexpr std::size_t kDiagMaxLen = 244;

struct PrmFault {
  std::uint8_t byte = 0;     // faulty telegram byte (diag byte 9)
  std::uint8_t correct = 0;  // a correct value (diag byte 10)
  friend bool operator==(const PrmFault&, const PrmFault&) = default;
};

struct CfgFault {
  std::uint8_t slot = 0;  // diag byte 9
  std::uint8_t code = 0;  // diag byte 10 (docs/slots.md "Chk_Cfg slots" codes 1..10)
  friend bool operator==(const CfgFault&, const CfgFault&) = default;
};

// Bytes 8..10 the device reports when no Prm/Cfg fault is pending, and whether they count as
// extended diagnosis (Station_Status_1 bit 3). DpProfile::CanDp2 only.
struct DeviceDiag {
  std::array<std::uint8_t, 3> bytes{};
  bool ext_diag = false;
};

// The Ext_Diag_Data after the 6 standard bytes (DpProfile::Standard): the blocks as they go on the
// wire (a device-related block starts with its header byte 00LLLLLL), and whether they report a
// fault (Station_Status_1 bit 3 Ext_Diag) or only carry status.
struct ExtDiag {
  std::vector<std::uint8_t> data;
  bool ext_diag = false;
};

class SlaveApplication {
 public:
  virtual ~SlaveApplication() = default;
  // Called with the whole Set_Prm telegram after the slave checked length, Station_Status and
  // Ident_Number. Return a fault to reject, nullopt to accept (the application applies it then).
  virtual std::optional<PrmFault> on_set_prm(std::span<const std::uint8_t> telegram, Time now) = 0;
  virtual std::optional<CfgFault> on_chk_cfg(std::span<const std::uint8_t> cfg, Time now) = 0;
  virtual void on_enter_data_exchange(Time now) = 0;
  virtual void on_leave_data_exchange(Time now) = 0;
  // Output bytes in, input bytes out (both sized from the accepted configuration). Standard
  // profile: `outputs` are what the device shall apply now, which is not always what the master
  // sent: empty = the safe state (Clear_Data, a fail-safe telegram without outputs), in Sync mode
  // the outputs of the last Sync command. It is also called outside a Data_Exchange when a
  // Global_Control changes them (Sync, Unsync, Clear_Data) or samples the inputs (Freeze); calls
  // with the same outputs must be harmless.
  virtual void on_data_exchange(std::span<const std::uint8_t> outputs,
                                std::span<std::uint8_t> inputs, Time now) = 0;
  virtual std::size_t output_length() const = 0;
  virtual std::size_t input_length() const = 0;
  // DpProfile::CanDp2: diagnosis bytes 8..10.
  virtual DeviceDiag device_diag() const { return {}; }
  // DpProfile::Standard: Ext_Diag_Data and the device's status bits.
  virtual ExtDiag ext_diag() const { return {}; }
  // The device's real configuration, answered by Get_Cfg in every state (a modular station's
  // plugged modules); nullopt: Get_Cfg answers the last accepted Chk_Cfg (the CAN-DP/2, whose
  // configuration is what Chk_Cfg defines).
  virtual std::optional<std::vector<std::uint8_t>> real_cfg() const { return std::nullopt; }
  // Standard profile, after on_set_prm accepted: DPV1_Status_1 bit 2 (WD_Base_1ms) asks for a
  // 1 ms watchdog time base instead of 10 ms.
  virtual bool watchdog_base_1ms() const { return false; }
};

enum class DpProfile : std::uint8_t { CanDp2, Standard };

// What a slave offers beyond the mandatory DP-V0 services (GSD keywords); Standard profile only.
struct SlaveOptions {
  DpProfile profile = DpProfile::CanDp2;
  bool sync = false;           // Sync_Mode_supp
  bool freeze = false;         // Freeze_Mode_supp
  bool fail_safe = false;      // Fail_Safe: Data_Exchange without output bytes is accepted
  bool set_slave_add = false;  // Set_Slave_Add_supp
  std::size_t max_diag_len = kDiagMaxLen;  // Max_Diag_Data_Len (6..244)
};

struct SlaveInfo {
  std::uint8_t address = 3;
  std::uint16_t ident_number = 0;
  // CanDp2: Max_User_Prm_Data_Len, the telegram must be 7 + this long. Standard: unused, the
  // application judges the user parameter length.
  std::size_t user_prm_len = 0;
  std::array<std::uint8_t, 2> ext_diag_header{};  // CanDp2: diag bytes 6, 7
  SlaveOptions options{};
  std::string log_name{};  // the log component; empty: "dpN" (N = address)
};

// Global_Control Control_Command bits (IEC 61158-6-3; pyprofibus dp.py uses the same values).
inline constexpr std::uint8_t kGcClearData = 0x02;
inline constexpr std::uint8_t kGcUnfreeze = 0x04;
inline constexpr std::uint8_t kGcFreeze = 0x08;
inline constexpr std::uint8_t kGcUnsync = 0x10;
inline constexpr std::uint8_t kGcSync = 0x20;

class DpSlave {
 public:
  static constexpr std::size_t kDiagLen = 11;  // docs/dp-slave.md "Diagnosis": the CAN-DP/2 sends
                                               // 11 bytes
  using Diag = std::array<std::uint8_t, kDiagLen>;

  DpSlave(SlaveInfo info, SlaveApplication& app, LogSink* log = nullptr);

  // --- DP services (the slave's responder side) ---
  // Returns true when the telegram was accepted (the result shows in the diagnosis either way).
  bool set_prm(std::uint8_t master, std::span<const std::uint8_t> telegram, Time now);
  bool chk_cfg(std::uint8_t master, std::span<const std::uint8_t> cfg, Time now);
  // The Slave_Diag answer as it goes on the wire (CanDp2: always 11 bytes; Standard: 6 + the
  // Ext_Diag_Data, at most Max_Diag_Data_Len).
  std::vector<std::uint8_t> diagnosis(Time now);
  // The first 11 bytes of diagnosis(), zero-padded: the CAN-DP/2's whole diagnosis, for the views
  // made for it (status block, validate).
  Diag slave_diag(Time now);
  std::optional<std::vector<std::uint8_t>> get_cfg(Time now);
  // nullopt when not in Data_Exch for this master or the output length is wrong (the master sees
  // no data; a wrong length from the lock holder also takes the slave to Wait_Prm).
  std::optional<std::span<const std::uint8_t>> data_exchange(std::uint8_t master,
                                                             std::span<const std::uint8_t> outputs,
                                                             Time now);
  void global_control(std::uint8_t master, std::uint8_t control, Time now,
                      std::uint8_t group_select = 0);
  // Set_Slave_Add (SAP 55): New_Slave_Add, Ident_Number high/low, No_Add_Chg. True when the
  // address changed (info().address is the new one); false = refused (not supported, not in
  // Wait_Prm, wrong Ident_Number, address out of range, changes locked by No_Add_Chg).
  bool set_slave_add(std::uint8_t master, std::span<const std::uint8_t> data, Time now);

  // --- time ---
  void advance(Time now);  // watchdog
  std::optional<Time> next_deadline() const;

  // --- inspection ---
  SlaveState state() const { return state_; }
  const SlaveInfo& info() const { return info_; }
  std::optional<PrmFault> prm_fault() const { return prm_fault_; }
  std::optional<CfgFault> cfg_fault() const { return cfg_fault_; }
  std::optional<std::uint32_t> watchdog_ms() const;
  // The process image as last exchanged: inputs sent, outputs received (Rd_Inp / Rd_Outp).
  std::span<const std::uint8_t> inputs() const { return inputs_; }
  std::span<const std::uint8_t> outputs() const { return outputs_; }
  bool sync_mode() const { return sync_mode_; }
  bool freeze_mode() const { return freeze_mode_; }
  bool clear_data() const { return clear_; }
  std::optional<std::uint8_t> master() const {
    return master_ == kNoMaster ? std::nullopt : std::optional(master_);
  }

  // --- faults (fault injection; the device itself changes) ---
  // Power cycle: back to Wait_Prm with nothing accepted.
  void reset(Time now);
  // Off the bus (cable pulled, switched off): the links give the master no answer at all. The
  // slave's own time runs on (its watchdog expires).
  void set_offline(bool offline) { offline_ = offline; }
  bool offline() const { return offline_; }
  // The device reports a parameter / configuration fault now: Prm_Fault / Cfg_Fault in the
  // diagnosis and back to Wait_Prm, as after a rejected Set_Prm / Chk_Cfg.
  void raise_prm_fault(PrmFault fault, Time now);
  void raise_cfg_fault(CfgFault fault, Time now);

 private:
  bool standard() const { return info_.options.profile == DpProfile::Standard; }
  void enter(SlaveState next, Time now, std::string_view why);
  // Back to Wait_Prm with the parameters dropped (rejection, unlock, watchdog, reset, fault).
  void to_wait_prm(Time now, std::string_view why);
  void reject_prm(PrmFault fault, std::string_view why);
  void touch(Time now) { last_master_telegram_ = now; }
  // Lock_Req/Unlock_Req; true when the telegram was fully handled here.
  bool lock_request(std::uint8_t master, const PrmStd& p, std::span<const std::uint8_t> t, Time now,
                    bool* accepted);
  // Why a Set_Prm is refused before its user parameters: a Prm fault, or (no fault) Sync_Req /
  // Freeze_Req not supported.
  struct PrmRejection {
    std::optional<PrmFault> fault;
    std::string why;
  };
  std::optional<PrmRejection> check_prm(std::span<const std::uint8_t> t) const;
  std::vector<std::uint8_t> standard_diag() const;
  void standard_exchange(Time now);  // one Data_Exchange: outputs to the field, inputs back
  void apply_outputs(Time now);      // hands the outputs the field should show to the application

  SlaveInfo info_;
  SlaveApplication& app_;
  Logger log_;
  SlaveState state_ = SlaveState::WaitPrm;
  std::uint8_t master_ = kNoMaster;
  std::optional<PrmStd> prm_;
  std::vector<std::uint8_t> cfg_;  // the accepted Chk_Cfg (valid in Data_Exch)
  bool not_supported_ = false;
  std::optional<PrmFault> prm_fault_;
  std::optional<CfgFault> cfg_fault_;
  Time last_master_telegram_{0};
  std::vector<std::uint8_t> inputs_;
  std::vector<std::uint8_t> outputs_;
  bool offline_ = false;
  // Standard profile: Global_Control modes and what the field sees.
  bool watchdog_1ms_ = false;
  bool sync_mode_ = false, freeze_mode_ = false, clear_ = false;
  bool fail_safe_telegram_ = false;   // the last Data_Exchange carried no outputs
  std::vector<std::uint8_t> synced_;  // Sync mode: the outputs of the last Sync command
  bool address_locked_ = false;       // Set_Slave_Add with No_Add_Chg
};

}  // namespace candp2::dp
