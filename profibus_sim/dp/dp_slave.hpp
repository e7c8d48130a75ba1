// A DP-V0 slave state machine (emulator-spec §1): Wait_Prm → Wait_Cfg → Data_Exch, watchdog,
// Slave_Diag, Get_Cfg. Generic over the device: the device firmware (the CAN-DP/2 gateway) plugs in
// as a SlaveApplication, like firmware behind a VPC3 ASIC. Driven only through DP services; time is
// passed in with every call. No I/O.
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

struct PrmFault {
  std::uint8_t byte = 0;     // faulty telegram byte (diag byte 9)
  std::uint8_t correct = 0;  // a correct value (diag byte 10)
  friend bool operator==(const PrmFault&, const PrmFault&) = default;
};

struct CfgFault {
  std::uint8_t slot = 0;  // diag byte 9
  std::uint8_t code = 0;  // diag byte 10 (emulator-spec §2 codes 1..10)
  friend bool operator==(const CfgFault&, const CfgFault&) = default;
};

// Bytes 8..10 the device reports when no Prm/Cfg fault is pending, and whether they count as
// extended diagnosis (Station_Status_1 bit 3).
struct DeviceDiag {
  std::array<std::uint8_t, 3> bytes{};
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
  // Output bytes in, input bytes out (both sized from the accepted configuration).
  virtual void on_data_exchange(std::span<const std::uint8_t> outputs,
                                std::span<std::uint8_t> inputs, Time now) = 0;
  virtual std::size_t output_length() const = 0;
  virtual std::size_t input_length() const = 0;
  virtual DeviceDiag device_diag() const = 0;
};

struct SlaveInfo {
  std::uint8_t address = 3;
  std::uint16_t ident_number = 0;
  std::size_t user_prm_len = 0;  // Max_User_Prm_Data_Len: the telegram must be 7 + this long
  std::array<std::uint8_t, 2> ext_diag_header{};  // diag bytes 6, 7
  std::string log_name{};                         // the log component; empty: "dpN" (N = address)
};

class DpSlave {
 public:
  static constexpr std::size_t kDiagLen = 11;  // emulator-spec §3: always 11 bytes
  using Diag = std::array<std::uint8_t, kDiagLen>;

  DpSlave(SlaveInfo info, SlaveApplication& app, LogSink* log = nullptr);

  // --- DP services (the slave's responder side) ---
  // Returns true when the telegram was accepted (the result shows in the diagnosis either way).
  bool set_prm(std::uint8_t master, std::span<const std::uint8_t> telegram, Time now);
  bool chk_cfg(std::uint8_t master, std::span<const std::uint8_t> cfg, Time now);
  Diag slave_diag(Time now);
  std::optional<std::vector<std::uint8_t>> get_cfg(Time now);
  // nullopt when not in Data_Exch or the output length is wrong (the master sees no data).
  std::optional<std::span<const std::uint8_t>> data_exchange(std::uint8_t master,
                                                             std::span<const std::uint8_t> outputs,
                                                             Time now);
  void global_control(std::uint8_t master, std::uint8_t control, Time now);

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
  // Power cycle: back to Wait_Prm with nothing accepted.
  void reset(Time now);

 private:
  void enter(SlaveState next, Time now, std::string_view why);
  void reject_prm(PrmFault fault, std::string_view why);
  void touch(Time now) { last_master_telegram_ = now; }

  SlaveInfo info_;
  SlaveApplication& app_;
  Logger log_;
  SlaveState state_ = SlaveState::WaitPrm;
  std::uint8_t master_ = kNoMaster;
  std::optional<PrmStd> prm_;
  std::vector<std::uint8_t> cfg_;
  bool cfg_accepted_ = false;
  bool not_supported_ = false;
  std::optional<PrmFault> prm_fault_;
  std::optional<CfgFault> cfg_fault_;
  Time last_master_telegram_{0};
  std::vector<std::uint8_t> inputs_;
  std::vector<std::uint8_t> outputs_;
};

}  // namespace candp2::dp
