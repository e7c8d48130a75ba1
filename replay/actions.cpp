// The table of replay actions (replay/actions.hpp) and the report's description of each.
#include "replay/actions.hpp"

#include <cstdio>
#include <iterator>

#include "common/hex.hpp"
#include "replay/parse_internal.hpp"
#include "replay/sim.hpp"

namespace candp2::replay {

namespace {

// ------------------------------------------------------------------ descriptions (the report)

std::string ms_text(Duration d) {
  const auto us = d.count();
  if (us % 1000 == 0) return std::to_string(us / 1000) + " ms";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f ms", static_cast<double>(us) / 1000.0);
  return buf;
}

std::string frames_text(const std::vector<FramePattern>& v) {
  std::string s;
  for (const auto& p : v) {
    if (!s.empty()) s += ' ';  // not `" " + p.text()`: GCC 12 -O3 false -Wrestrict
    s += p.text();
  }
  return s;
}

std::string within(const Step& st) {
  return st.window ? " within " + ms_text(*st.window) : std::string();
}

std::string key_only(const Step&, std::string s) {
  return s;
}
std::string advance_text(const Step& st, std::string s) {
  return s + " " + ms_text(st.advance);
}
std::string cycles_text(const Step& st, std::string s) {
  return s + " " + std::to_string(st.cycles);
}
std::string write_text(const Step& st, std::string s) {
  return s + " Q" + std::to_string(st.address) + ": " + hex_bytes(st.bytes);
}
std::string inject_text(const Step& st, std::string s) {
  std::string f;
  for (const auto& fr : st.frames) {
    if (!f.empty()) f += ' ';  // not `" " + ...`: GCC 12 -O3 false -Wrestrict
    f += can::format_candump(fr);
  }
  return s + " " + f;
}
std::string frames_within_text(const Step& st, std::string s) {
  return s + " " + frames_text(st.frame_patterns) + within(st);
}
std::string no_frame_text(const Step& st, std::string s) {
  return s + " " + frames_text(st.frame_patterns) +
         (st.window ? " for " + ms_text(*st.window) : std::string());
}
std::string input_text(const Step& st, std::string s) {
  return s + " I" + std::to_string(st.address) + ": " + st.pattern.text() + within(st);
}
std::string output_text(const Step& st, std::string s) {
  return s + " Q" + std::to_string(st.address) + ": " + st.pattern.text() + within(st);
}
std::string pattern_text(const Step& st, std::string s) {
  return s + " " + st.pattern.text() + within(st);
}
std::string dp_state_text(const Step& st, std::string s) {
  return s + " " + std::string(dp::to_string(st.dp_state)) + within(st);
}
std::string freigabe_text(const Step& st, std::string s) {
  return s + (st.on ? " 1" : " 0");
}
std::string db_write_text(const Step& st, std::string s) {
  return s + " " + std::string(to_string(st.db)) + "[" + std::to_string(st.db_index) + "]+" +
         std::to_string(st.offset) + ": " + hex_bytes(st.bytes);
}
std::string expect_db_text(const Step& st, std::string s) {
  return s + " " + std::string(to_string(st.db)) + "[" + std::to_string(st.db_index) + "]+" +
         std::to_string(st.offset) + ": " + st.pattern.text() + within(st);
}
std::string set_tx_text(const Step& st, std::string s) {
  return s + " " + std::to_string(st.entry) +
         (st.force ? " force " + std::to_string(*st.force) : std::string()) +
         (st.has_data ? " data " + hex_bytes(st.bytes) : std::string());
}
std::string expect_rx_text(const Step& st, std::string s) {
  return s + " " + std::to_string(st.entry) +
         (st.count_in ? " count_in " + std::to_string(*st.count_in) : std::string()) +
         (st.has_data ? " data " + st.pattern.text() : std::string()) + within(st);
}
std::string ret_value_text(const Step& st, std::string s) {
  return s + " " + std::to_string(st.ret_value) + within(st);
}
std::string can_state_text(const Step& st, std::string s) {
  return s + " " + kCanStates[st.can_state];
}
std::string drop_rx_text(const Step& st, std::string s) {
  return s + " " + std::to_string(st.count);
}
std::string counters_text(const Step& st, std::string s) {
  std::string c;
  for (const auto& [name, value] : st.counters)
    c += (c.empty() ? " " : ", ") + name + " " + std::to_string(value);
  return s + c + within(st);
}
std::string drive_mute_text(const Step& st, std::string s) {
  return s + " " + st.drive_name + (st.on ? " on" : " off");
}
std::string drive_bits_text(const Step& st, std::string s) {
  char b[8];
  std::snprintf(b, sizeof b, "%04X", static_cast<unsigned>(st.bits));
  return s + " " + st.drive_name + " 0x" + b;
}
std::string drive_text(const Step& st, std::string s) {
  return s + " " + st.drive_name;
}
std::string bool_text(const Step& st, std::string s) {
  return s + (st.on ? " true" : " false");
}
std::string alarm_text(const Step& st, std::string s) {
  if (st.bytes.empty()) return s + " cleared";
  s += ' ';  // not `" " + ...`: GCC 12 -O3 false -Wrestrict
  return s + hex_bytes(st.bytes);
}
std::string field_write_text(const Step& st, std::string s) {
  return s + " +" + std::to_string(st.offset) + ": " + hex_bytes(st.bytes);
}
std::string expect_field_text(const Step& st, std::string s) {
  return s + " +" + std::to_string(st.offset) + ": " + st.pattern.text() + within(st);
}

// The line faults' and CAN faults' shared vocabulary: for a time or a count, one in every.
std::string amount_text(const std::optional<Duration>& duration, std::uint32_t count,
                        std::uint32_t every) {
  std::string s = duration ? " for " + ms_text(*duration) : " count " + std::to_string(count);
  if (every > 1) s += " every " + std::to_string(every);
  return s;
}
std::string line_fault_text(const Step& st, std::string s) {
  const plant::LineFault& f = st.line_fault;
  s += ' ';  // not `" " + ...`: GCC 12 -O3 false -Wrestrict
  s += plant::to_string(f.kind);
  if (f.kind != plant::LineFaultKind::Noise) s += " station " + std::to_string(f.station);
  return s + amount_text(f.duration, f.count, f.every);
}
std::string can_fault_text(const Step& st, std::string s) {
  const plant::CanFault& f = st.can_fault;
  s += ' ';
  s += plant::to_string(f.kind);
  if (f.node.gateway) s += " gateway " + std::to_string(*f.node.gateway);
  if (!f.node.drive.empty()) s += " drive " + f.node.drive;
  if (!f.bus.empty()) s += " bus " + f.bus;
  if (f.id) s += " id " + can::ident_text(*f.id);
  if (f.kind == plant::CanFaultKind::ErrorFrames || f.kind == plant::CanFaultKind::Noise)
    s += amount_text(f.duration, f.count, f.every);
  else if (f.duration)
    s += amount_text(f.duration, 0, 1);
  return s;
}
std::string expect_line_text(const Step& st, std::string s) {
  if (st.station) s += " station " + std::to_string(*st.station);
  std::string c;
  for (const auto& [name, value] : st.counters)
    c += (c.empty() ? " " : ", ") + name + " " + std::to_string(value);
  s += c;
  if (!st.live.empty()) s += " live " + st.live;
  if (st.bus_cycle_max_le) s += " bus cycle ≤ " + std::to_string(*st.bus_cycle_max_le) + " µs";
  return s + within(st);
}

std::string expect_bus_text(const Step& st, std::string s) {
  s += ' ';  // not `" " + ...`: GCC 12 -O3 false -Wrestrict
  s += st.bus_name;
  // The bus's figures, then the identifier's after it (the table's order): "can0 tx_lost = 0;
  // 181 latency_max_ms ≤ 2.5".
  std::string c;
  bool id_named = false, node_named = false;
  for (const auto& check : st.bus_checks) {
    const bool of_id = check.figure->scope == BusScope::Identifier;
    const bool of_node = check.figure->scope == BusScope::Node;
    c += c.empty() ? " " : (of_id && !id_named) || (of_node && !node_named) ? "; " : ", ";
    if (of_id && !id_named) {
      c += can::ident_text(*st.can_id) + (st.can_remote ? " remote " : " ");
      id_named = true;
    }
    if (of_node && !node_named) {
      c += st.bus_node + " ";
      node_named = true;
    }
    c += std::string(check.figure->key) + " " + check.text();
  }
  return s + c + within(st);
}

// ------------------------------------------------------------------------------- the table

using namespace parse;
using K = Kind;
using T = Target;
constexpr std::string_view kWithin = "within_ms";
constexpr std::string_view kFor = "for_ms";

// In the order of enum Action (replay/scenario.hpp).
constexpr ActionSpec kTable[] = {
    {Action::Note, "note", K::Act, T::None, {}, parse_nothing, &Sim::nothing, key_only},
    {Action::Advance,
     "advance_ms",
     K::Act,
     T::None,
     {},
     parse_advance,
     &Sim::advance,
     advance_text},
    {Action::Cycles, "cycles", K::Act, T::None, {}, parse_cycles, &Sim::cycles, cycles_text},
    {Action::Write, "write", K::Act, T::Gateway, {}, parse_image, &Sim::write, write_text},
    {Action::Inject, "inject", K::Act, T::Bus, {}, parse_inject, &Sim::inject, inject_text},
    {Action::ExpectFrame, "expect_frame", K::Expect, T::Gateway, kWithin, parse_frame,
     &Sim::expect_frame, frames_within_text},
    {Action::ExpectFrames, "expect_frames", K::Expect, T::Gateway, kWithin, parse_frame_list,
     &Sim::expect_frames, frames_within_text},
    {Action::ExpectNoFrame, "expect_no_frame", K::Expect, T::Gateway, kFor, parse_frame,
     &Sim::expect_no_frame, no_frame_text},
    {Action::ExpectInput, "expect_input", K::ExpectPolled, T::Gateway, kWithin, parse_image,
     &Sim::expect_image, input_text},
    {Action::ExpectOutput, "expect_output", K::ExpectPolled, T::Gateway, kWithin, parse_image,
     &Sim::expect_image, output_text},
    {Action::ExpectDiag, "expect_diag", K::ExpectPolled, T::Station, kWithin, parse_diag,
     &Sim::expect_diag, pattern_text},
    {Action::ExpectDpState, "expect_dp_state", K::ExpectPolled, T::Station, kWithin, parse_dp_state,
     &Sim::expect_dp_state, dp_state_text},
    {Action::Freigabe,
     "freigabe",
     K::Act,
     T::Driver,
     {},
     parse_flag,
     &Sim::freigabe,
     freigabe_text},
    {Action::DbWrite, "db_write", K::Act, T::Driver, {}, parse_db, &Sim::db_write, db_write_text},
    {Action::ExpectDb, "expect_db", K::ExpectPolled, T::Driver, kWithin, parse_db, &Sim::expect_db,
     expect_db_text},
    {Action::SetTx, "set_tx", K::Act, T::Driver, {}, parse_entry, &Sim::entry, set_tx_text},
    {Action::ExpectRx, "expect_rx", K::ExpectPolled, T::Driver, kWithin, parse_entry, &Sim::entry,
     expect_rx_text},
    {Action::ExpectRetValue, "expect_ret_value", K::ExpectPolled, T::Driver, kWithin,
     parse_ret_value, &Sim::expect_ret_value, ret_value_text},
    {Action::PowerCycle,
     "power_cycle",
     K::Act,
     T::Station,
     {},
     parse_true,
     &Sim::power_cycle,
     key_only},
    {Action::Reparameterize,
     "reparameterize",
     K::Act,
     T::Station,
     {},
     parse_true,
     &Sim::reparameterize,
     key_only},
    {Action::MasterStop,
     "master_stop",
     K::Act,
     T::Station,
     {},
     parse_true,
     &Sim::set_addressed,
     key_only},
    {Action::MasterResume,
     "master_resume",
     K::Act,
     T::Station,
     {},
     parse_true,
     &Sim::set_addressed,
     key_only},
    {Action::ForceCanState,
     "force_can_state",
     K::Act,
     T::Gateway,
     {},
     parse_can_state,
     &Sim::force_can_state,
     can_state_text},
    {Action::DropRx, "drop_rx", K::Act, T::Gateway, {}, parse_drop_rx, &Sim::drop_rx, drop_rx_text},
    {Action::ExpectCounters, "expect_counters", K::Expect, T::Gateway, kWithin, parse_counters,
     &Sim::expect_counters, counters_text},
    {Action::DriveMute,
     "drive_mute",
     K::Act,
     T::Drive,
     {},
     parse_flag,
     &Sim::drive_fault,
     drive_mute_text},
    {Action::DriveErrorBits,
     "drive_error_bits",
     K::Act,
     T::Drive,
     {},
     parse_bits,
     &Sim::drive_fault,
     drive_bits_text},
    {Action::DriveWarningBits,
     "drive_warning_bits",
     K::Act,
     T::Drive,
     {},
     parse_bits,
     &Sim::drive_fault,
     drive_bits_text},
    {Action::DriveRestart,
     "drive_restart",
     K::Act,
     T::Drive,
     {},
     parse_true,
     &Sim::drive_fault,
     drive_text},
    {Action::SlaveOnline,
     "slave_online",
     K::Act,
     T::Slave,
     {},
     parse_bool,
     &Sim::slave_online,
     bool_text},
    {Action::SlaveAlarm,
     "slave_alarm",
     K::Act,
     T::Slave,
     {},
     parse_alarm,
     &Sim::slave_alarm,
     alarm_text},
    {Action::SlavePrmFault,
     "slave_prm_fault",
     K::Act,
     T::Slave,
     {},
     parse_bool,
     &Sim::slave_fault,
     bool_text},
    {Action::SlaveCfgFault,
     "slave_cfg_fault",
     K::Act,
     T::Slave,
     {},
     parse_bool,
     &Sim::slave_fault,
     bool_text},
    {Action::FieldWrite,
     "field_write",
     K::Act,
     T::Slave,
     {},
     parse_field,
     &Sim::field_write,
     field_write_text},
    {Action::ExpectField, "expect_field", K::ExpectPolled, T::Slave, kWithin, parse_field,
     &Sim::expect_field, expect_field_text},
    {Action::LineFault,
     "line_fault",
     K::Act,
     T::None,
     {},
     parse_line_fault,
     &Sim::line_fault,
     line_fault_text},
    {Action::ExpectLine, "expect_line", K::ExpectPolled, T::None, kWithin, parse_expect_line,
     &Sim::expect_line, expect_line_text},
    {Action::CanFault,
     "can_fault",
     K::Act,
     T::None,
     {},
     parse_can_fault,
     &Sim::can_fault,
     can_fault_text},
    {Action::ExpectBus, "expect_bus", K::ExpectPolled, T::None, kWithin, parse_expect_bus,
     &Sim::expect_bus, expect_bus_text},
};

// One row per action, in the enum's order, each with its key; an expectation names its window key.
// A new action without its row does not compile. (That every row has its parser, handler and
// description is a test, ReplayActions.EveryRowIsComplete: GCC cannot compare function addresses
// in a constant expression when it instruments the code for the sanitizers.)
constexpr bool complete() {
  if (std::size(kTable) != static_cast<std::size_t>(Action::Count)) return false;
  for (std::size_t i = 0; i < std::size(kTable); ++i) {
    const auto& a = kTable[i];
    if (a.action != static_cast<Action>(i) || a.key.empty() ||
        (a.kind != K::Act) == a.window.empty())
      return false;
  }
  return true;
}
static_assert(complete(), "every replay action needs its row in kTable (replay/actions.cpp)");

}  // namespace

std::span<const ActionSpec> actions() {
  return kTable;
}

const ActionSpec& spec(Action a) {
  return kTable[static_cast<std::size_t>(a)];
}

}  // namespace candp2::replay
