// A DP-V0 slave that behaves as its GSD says (docs/slaves.md): a dp::DpSlave in the Standard
// profile with the GSD's optional services, and this object as its dp::SlaveApplication — the
// user parameters checked against the GSD's ExtUserPrmData and limits, Chk_Cfg against the
// slave's own modules — plus its field side and its faults.
//
// Field side: the inputs the slave reports (written by a user or a test, kept across
// parameterizations) and the outputs as the device applies them (the master's last outputs;
// the safe state after Clear_Data, a fail-safe telegram or leaving Data_Exch; in Sync mode those
// of the last Sync). The Modbus face maps them on the slave's `field_unit` (docs/slaves.md).
//
// Pure and deterministic like gw::Gateway: DP services through dp(), time passed in, timers by
// advance(now) at next_deadline(). No sockets, threads, globals or clock.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/log.hpp"
#include "common/time.hpp"
#include "gsd/gsd.hpp"
#include "gsd_slave/configuration.hpp"
#include "gsd_slave/profile.hpp"
#include "gsd_slave/user_prm.hpp"
#include "profibus_sim/dp/dp_slave.hpp"

namespace candp2::gsd_slave {

// What the outputs do when the master stops driving them (Clear_Data, a fail-safe telegram
// without outputs, the slave leaves Data_Exch): go to 0, or keep their last value (the device
// parameter many devices offer as "substitute value / hold last value").
enum class SafeState : std::uint8_t { Zero, Hold };

struct SlaveSetup {
  std::uint8_t address = 0;
  std::shared_ptr<const gsd::Model> gsd;
  // The slave's modules (indices into gsd->modules, slot order), or its configuration as raw
  // Chk_Cfg bytes (then `modules` is empty and the modules' parameter blocks are unknown).
  std::vector<std::size_t> modules;
  std::optional<std::vector<std::uint8_t>> cfg;
  SafeState safe_state = SafeState::Zero;
  std::string name;
  LogSink* log = nullptr;
};

class GsdSlave final : private dp::SlaveApplication {
 public:
  // nullptr and *error when the GSD cannot describe a slave (no Ident_Number) or a module index
  // is out of range.
  static std::unique_ptr<GsdSlave> create(SlaveSetup setup, std::string* error);
  GsdSlave(const GsdSlave&) = delete;
  GsdSlave& operator=(const GsdSlave&) = delete;

  dp::DpSlave& dp() { return slave_; }
  const dp::DpSlave& dp() const { return slave_; }
  const Profile& profile() const { return profile_; }
  const Configuration& configuration() const { return cfg_; }
  const UserPrmLayout& user_prm_layout() const { return prm_layout_; }
  const gsd::Model& gsd() const { return *setup_.gsd; }
  const std::string& name() const { return setup_.name; }
  std::uint8_t address() const { return slave_.info().address; }

  // --- field side ---
  std::size_t input_length() const override { return cfg_.decoded.input_len; }
  std::size_t output_length() const override { return cfg_.decoded.output_len; }
  // The inputs the slave reports (holding registers on its field_unit).
  std::span<const std::uint8_t> field_inputs() const { return field_inputs_; }
  // Writes input bytes from `offset`; false (nothing written) when they do not fit.
  bool write_inputs(std::size_t offset, std::span<const std::uint8_t> bytes);
  // The outputs as the device applies them (input registers on its field_unit).
  std::span<const std::uint8_t> field_outputs() const { return field_outputs_; }
  // The outputs of the master's last Data_Exchange, as on the wire (Rd_Outp).
  std::span<const std::uint8_t> received_outputs() const { return slave_.outputs(); }
  SafeState safe_state() const { return setup_.safe_state; }

  // --- faults ---
  // Leave the bus (no answer at all) / come back. The slave's time runs on meanwhile.
  void set_online(bool online) { slave_.set_offline(!online); }
  bool online() const { return !slave_.offline(); }
  // A diagnosis alarm: a device-related Ext_Diag_Data block (header byte + these 1..62 bytes);
  // `fault` sets Ext_Diag (Station_Status_1 bit 3), without it the block is status only. False
  // (nothing changed) for an empty or longer string.
  bool set_device_diag(std::vector<std::uint8_t> bytes, bool fault = true);
  void clear_device_diag();
  const std::optional<std::vector<std::uint8_t>>& device_diagnosis() const { return device_diag_; }
  // Forced Prm / Cfg fault: at once Prm_Fault / Cfg_Fault and back to Wait_Prm; while forced,
  // every Set_Prm / Chk_Cfg is rejected. Releasing it lets the next parameterization succeed.
  void force_prm_fault(bool on, Time now);
  void force_cfg_fault(bool on, Time now);
  bool prm_fault_forced() const { return force_prm_; }
  bool cfg_fault_forced() const { return force_cfg_; }

  // Why the last Set_Prm / Chk_Cfg was rejected ("" when accepted).
  const std::string& prm_problem() const { return prm_problem_; }
  const std::string& cfg_problem() const { return cfg_problem_; }

  // --- time ---
  void advance(Time now) { slave_.advance(now); }
  std::optional<Time> next_deadline() const { return slave_.next_deadline(); }

 private:
  GsdSlave(SlaveSetup setup, Profile profile, Configuration cfg);

  // dp::SlaveApplication
  std::optional<dp::PrmFault> on_set_prm(std::span<const std::uint8_t> telegram, Time now) override;
  std::optional<dp::CfgFault> on_chk_cfg(std::span<const std::uint8_t> cfg, Time now) override;
  void on_enter_data_exchange(Time now) override;
  void on_leave_data_exchange(Time now) override;
  void on_data_exchange(std::span<const std::uint8_t> outputs, std::span<std::uint8_t> inputs,
                        Time now) override;
  dp::ExtDiag ext_diag() const override;
  std::optional<std::vector<std::uint8_t>> real_cfg() const override { return cfg_.bytes; }
  bool watchdog_base_1ms() const override { return watchdog_1ms_; }

  void to_safe_state();

  SlaveSetup setup_;
  Profile profile_;
  Configuration cfg_;
  UserPrmLayout prm_layout_;
  Logger log_;
  dp::DpSlave slave_;
  std::vector<std::uint8_t> field_inputs_, field_outputs_;
  std::optional<std::vector<std::uint8_t>> device_diag_;
  bool device_fault_ = false;
  bool force_prm_ = false, force_cfg_ = false;
  bool watchdog_1ms_ = false;
  std::string prm_problem_, cfg_problem_;
};

}  // namespace candp2::gsd_slave
