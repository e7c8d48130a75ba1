// The parts of the scenario parser that its files share (replay/parse_step.cpp,
// replay/parse_scenario.cpp, the action table replay/actions.cpp). Errors are thrown as
// config::json_reader::Failure (JSON path and what was expected) and turned into a
// config::ConfigError by parse_scenario().
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "replay/actions.hpp"
#include "replay/scenario.hpp"

namespace candp2::replay::parse {

Duration as_ms(const nlohmann::json& j, const std::string& path, std::uint64_t max = 86400000);
// One step of "steps"; `sc` holds the installation and the driver already parsed.
Step parse_step(const nlohmann::json& j, const std::string& path, const Scenario& sc);

// The parsers of the action table (replay/actions.cpp): each reads the action's value into the
// step (docs/replay-format.md).
void parse_nothing(Step& s, const StepInput& in);      // note
void parse_advance(Step& s, const StepInput& in);      // advance_ms
void parse_cycles(Step& s, const StepInput& in);       // cycles
void parse_image(Step& s, const StepInput& in);        // write, expect_input, expect_output
void parse_inject(Step& s, const StepInput& in);       // inject: a frame or an array of them
void parse_frame(Step& s, const StepInput& in);        // expect_frame, expect_no_frame
void parse_frame_list(Step& s, const StepInput& in);   // expect_frames
void parse_diag(Step& s, const StepInput& in);         // expect_diag
void parse_dp_state(Step& s, const StepInput& in);     // expect_dp_state
void parse_flag(Step& s, const StepInput& in);         // freigabe, drive_mute: bool, 0 or 1
void parse_db(Step& s, const StepInput& in);           // db_write, expect_db
void parse_entry(Step& s, const StepInput& in);        // set_tx, expect_rx
void parse_ret_value(Step& s, const StepInput& in);    // expect_ret_value
void parse_true(Step& s, const StepInput& in);         // power_cycle, ..., drive_restart: true
void parse_can_state(Step& s, const StepInput& in);    // force_can_state
void parse_drop_rx(Step& s, const StepInput& in);      // drop_rx
void parse_counters(Step& s, const StepInput& in);     // expect_counters
void parse_bits(Step& s, const StepInput& in);         // drive_error_bits, drive_warning_bits
void parse_bool(Step& s, const StepInput& in);         // slave_online, slave_*_fault
void parse_alarm(Step& s, const StepInput& in);        // slave_alarm
void parse_field(Step& s, const StepInput& in);        // field_write, expect_field
void parse_line_fault(Step& s, const StepInput& in);   // line_fault
void parse_expect_line(Step& s, const StepInput& in);  // expect_line
void parse_can_fault(Step& s, const StepInput& in);    // can_fault
void parse_expect_bus(Step& s, const StepInput& in);   // expect_bus

}  // namespace candp2::replay::parse
