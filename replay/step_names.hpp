// The step keys of a replay scenario, one per action, and the force_can_state values
// (docs/replay-format.md). Shared by the parser and the step descriptions.
#pragma once

#include "replay/scenario.hpp"

namespace candp2::replay {

struct ActionName {
  Action action;
  const char* key;
};
// The step keys, one per action (docs/replay-format.md).
inline constexpr ActionName kActions[] = {
    {Action::Advance, "advance_ms"},
    {Action::Cycles, "cycles"},
    {Action::Write, "write"},
    {Action::Inject, "inject"},
    {Action::ExpectFrame, "expect_frame"},
    {Action::ExpectFrames, "expect_frames"},
    {Action::ExpectNoFrame, "expect_no_frame"},
    {Action::ExpectInput, "expect_input"},
    {Action::ExpectOutput, "expect_output"},
    {Action::ExpectDiag, "expect_diag"},
    {Action::ExpectDpState, "expect_dp_state"},
    {Action::Freigabe, "freigabe"},
    {Action::DbWrite, "db_write"},
    {Action::ExpectDb, "expect_db"},
    {Action::SetTx, "set_tx"},
    {Action::ExpectRx, "expect_rx"},
    {Action::ExpectRetValue, "expect_ret_value"},
    {Action::PowerCycle, "power_cycle"},
    {Action::Reparameterize, "reparameterize"},
    {Action::MasterStop, "master_stop"},
    {Action::MasterResume, "master_resume"},
    {Action::ForceCanState, "force_can_state"},
    {Action::DropRx, "drop_rx"},
    {Action::ExpectCounters, "expect_counters"},
    {Action::DriveMute, "drive_mute"},
    {Action::DriveErrorBits, "drive_error_bits"},
    {Action::DriveWarningBits, "drive_warning_bits"},
    {Action::DriveRestart, "drive_restart"},
    {Action::SlaveOnline, "slave_online"},
    {Action::SlaveAlarm, "slave_alarm"},
    {Action::SlavePrmFault, "slave_prm_fault"},
    {Action::SlaveCfgFault, "slave_cfg_fault"},
    {Action::FieldWrite, "field_write"},
    {Action::ExpectField, "expect_field"},
};

// force_can_state values, as holding register 8193 (docs/faults.md).
inline constexpr const char* kCanStates[] = {"real", "warning", "error-passive", "bus-off"};

}  // namespace candp2::replay
