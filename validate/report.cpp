#include "validate/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "can/frame_bits.hpp"
#include "common/hex.hpp"
#include "gateway/slot_config.hpp"
#include "validate/text.hpp"

namespace candp2::validate {

namespace {

using json = nlohmann::ordered_json;

const char* direction(dp::CfgIo io) {
  switch (io) {
    case dp::CfgIo::Input:
      return "in";
    case dp::CfgIo::Output:
      return "out";
    case dp::CfgIo::InputOutput:
      return "in+out";
    case dp::CfgIo::Empty:
      break;
  }
  return "none";
}

const char* direction_word(dp::CfgIo io) {
  switch (io) {
    case dp::CfgIo::Input:
      return "input";
    case dp::CfgIo::Output:
      return "output";
    case dp::CfgIo::InputOutput:
      return "input+output";
    case dp::CfgIo::Empty:
      break;
  }
  return "empty";
}

const char* slot_type(gw::SlotKind k) {
  switch (k) {
    case gw::SlotKind::Rx:
      return "rx";
    case gw::SlotKind::Tx:
      return "tx";
    case gw::SlotKind::CwIn:
    case gw::SlotKind::CwOut:
      return "cw";
    case gw::SlotKind::SegmentIn:
    case gw::SlotKind::SegmentOut:
      return "segment";
  }
  return "?";
}

bool has_form(const gw::Slot& s) {
  return s.kind != gw::SlotKind::SegmentIn && s.kind != gw::SlotKind::SegmentOut;
}

std::string plc_text(const SlotRow& row) {
  std::string s;
  if (row.plc_output) s = "Q " + range(*row.plc_output, row.out_length);
  if (row.plc_input)
    s += (s.empty() ? "" : ", ") + std::string("I ") + range(*row.plc_input, row.in_length);
  return s.empty() ? "-" : s;
}

std::string length_text(const SlotRow& row) {
  if (row.slot && row.slot->counter)
    return std::to_string(row.slot->length) + " (" + std::to_string(row.slot->data_len) +
           "+counter)";
  if (row.slot) return std::to_string(row.slot->length);
  if (row.io == dp::CfgIo::InputOutput)
    return std::to_string(row.out_length) + "+" + std::to_string(row.in_length);
  return std::to_string(std::max(row.in_length, row.out_length));
}

std::string can_id_text(const gw::Slot& s) {
  if (s.kind != gw::SlotKind::Rx && s.kind != gw::SlotKind::Tx) return "-";
  return s.id ? "0x" + can::ident_text(*s.id) : "none";  // manual §5.1.4: 0x07F8 dummy output
}

// Tx: the cycle (manual §5.2.3); CW: the SYNC time of comment bytes 4-5 (manual §5.3.2).
std::string cycle_text(const gw::Slot& s) {
  if (s.cw_sync_ms) return "SYNC " + std::to_string(s.cw_sync_ms) + " ms";
  return s.cycle_ms ? std::to_string(s.cycle_ms) + " ms" : "-";
}

std::string parameters_text(const GatewayReport& g) {
  const gw::UserPrm& p = *g.prm;
  auto b = [](bool v) { return v ? "true" : "false"; };
  const auto std_part = dp::decode_prm_std(g.input.params.prm);
  const std::string watchdog =
      std_part && std_part->wd_on() ? std::to_string(std_part->watchdog_ms()) + " ms" : "off";
  std::vector<std::string> items = {
      "can_bitrate " + gw::bitrate_text(p.bitrate_index),
      std::string("canopen ") + std::string(gw::to_string(p.role())),
      "module_id " + std::to_string(p.module_id),
      std::string("communication_window ") + b(p.comm_window),
      std::string("page_mode ") + b(p.page_mode),
      std::string("rtr_frames ") + b(p.send_rtr),
      std::string("start_frame ") + b(p.start_frame),
      std::string("can_diagnosis ") + b(p.can_diagnosis),
      std::string("rx_counter ") + b(p.rx_counter),
      std::string("tx_counter ") + b(p.tx_counter),
      "wakeup_s " + std::to_string(p.wakeup_s) + (p.wakeup_s == gw::kWakeupKeep ? " (keep)" : ""),
      "sync_ms " + std::to_string(p.sync_ms) + (p.sync_ms == gw::kSyncKeep ? " (keep)" : ""),
      "watchdog " + watchdog,
  };
  // Wrapped at 100 columns under "  parameters: ".
  const std::string indent(14, ' ');
  std::string out = "  parameters: ";
  std::size_t col = out.size();
  for (std::size_t i = 0; i < items.size(); ++i) {
    std::string item = items[i] + (i + 1 < items.size() ? "," : "");
    if (col > indent.size() && col + 1 + item.size() > 100) {
      out += "\n" + indent;
      col = indent.size();
    } else if (col > indent.size()) {
      out += ' ';
      ++col;
    }
    out += item;
    col += item.size();
  }
  return out + "\n";
}

// A table with columns padded to their widest cell; the last column is not padded.
std::string table(const std::vector<std::vector<std::string>>& rows, const std::string& indent,
                  const std::vector<bool>& right) {
  std::vector<std::size_t> width;
  for (const auto& r : rows)
    for (std::size_t c = 0; c < r.size(); ++c) {
      if (width.size() <= c) width.push_back(0);
      width[c] = std::max(width[c], r[c].size());
    }
  std::string out;
  for (const auto& r : rows) {
    std::string line = indent;
    for (std::size_t c = 0; c < r.size(); ++c) {
      const bool last = c + 1 == r.size();
      const std::size_t pad = width[c] - r[c].size();
      if (c < right.size() && right[c]) line.append(pad, ' ');
      line += r[c];
      if (!last && !(c < right.size() && right[c])) line.append(pad, ' ');
      if (!last) line += "  ";
    }
    while (!line.empty() && line.back() == ' ') line.pop_back();
    out += line + "\n";
  }
  return out;
}

std::string slot_table(const GatewayReport& g) {
  std::vector<std::vector<std::string>> rows = {
      {"slot", "PLC", "dir", "type", "length", "CAN ID", "form", "cycle", "Chk_Cfg entry"}};
  for (const auto& row : g.slots) {
    std::vector<std::string> r = {std::to_string(row.index), plc_text(row), direction(row.io)};
    if (row.slot) {
      const gw::Slot& s = *row.slot;
      r.insert(r.end(), {slot_type(s.kind), length_text(row), can_id_text(s),
                         has_form(s) ? hex8(s.form) : "-", cycle_text(s)});
    } else {
      r.insert(r.end(), {"-", length_text(row), "-", "-", "-"});
    }
    std::string entry = hex_bytes(row.cfg_bytes);
    if (row.fault_code) entry += "  <- Cfg fault code " + std::to_string(*row.fault_code);
    r.push_back(entry);
    rows.push_back(std::move(r));
  }
  return table(rows, "    ", {true, false, false, false, true});
}

json slot_json(const SlotRow& row) {
  json j;
  j["slot"] = row.index;
  j["json_path"] = row.json_path;
  j["direction"] = direction_word(row.io);
  j["plc_input"] = row.plc_input ? json(*row.plc_input) : json(nullptr);
  j["plc_output"] = row.plc_output ? json(*row.plc_output) : json(nullptr);
  j["input_length"] = row.in_length;
  j["output_length"] = row.out_length;
  j["cfg"] = hex_bytes(row.cfg_bytes);
  j["fault_code"] = row.fault_code ? json(*row.fault_code) : json(nullptr);
  if (!row.slot) {
    j["gateway"] = nullptr;
    return j;
  }
  const gw::Slot& s = *row.slot;
  json d;
  d["type"] = gw::to_string(s.kind);
  d["length"] = s.length;
  d["data_length"] = s.data_len;
  d["counter"] = s.counter;
  d["consistent"] = s.consistent;
  d["can_id"] = s.id ? json("0x" + can::ident_text(*s.id)) : json(nullptr);
  d["extended"] = s.id ? json(s.id->extended) : json(nullptr);
  d["form"] = has_form(s) ? json(hex8(s.form)) : json(nullptr);
  d["cycle_ms"] = s.cycle_ms;
  if (s.kind == gw::SlotKind::CwIn || s.kind == gw::SlotKind::CwOut) d["sync_ms"] = s.cw_sync_ms;
  j["gateway"] = d;
  return j;
}

json parameters_json(const GatewayReport& g) {
  if (!g.prm) return nullptr;
  const gw::UserPrm& p = *g.prm;
  const auto std_part = dp::decode_prm_std(g.input.params.prm);
  json j;
  j["can_bitrate"] = gw::bitrate_bps(p.bitrate_index).value_or(0);
  j["canopen"] = gw::to_string(p.role());
  j["module_id"] = p.module_id;
  j["communication_window"] = p.comm_window;
  j["page_mode"] = p.page_mode;
  j["rtr_frames"] = p.send_rtr;
  j["start_frame"] = p.start_frame;
  j["can_diagnosis"] = p.can_diagnosis;
  j["rx_counter"] = p.rx_counter;
  j["tx_counter"] = p.tx_counter;
  j["wakeup_s"] = p.wakeup_s;
  j["sync_ms"] = p.sync_ms;
  j["watchdog_ms"] = std_part && std_part->wd_on() ? std_part->watchdog_ms() : 0;
  return j;
}

}  // namespace

std::string explain_diagnosis(const GatewayReport& g) {
  const std::string state(dp::to_string(g.state));
  if (g.not_supported)
    return state +
           ": Set_Prm rejected with Not_Supported: Sync_Req or Freeze_Req in "
           "Station_Status (docs/dp-slave.md: FREEZE/SYNC not supported)";
  if (g.prm_fault) {
    const auto& f = *g.prm_fault;
    const std::size_t len = g.input.params.prm.size();
    if (len != gw::kSetPrmLen)
      return state + ": Set_Prm rejected, the telegram has " + std::to_string(len) +
             " bytes, the gateway expects " + std::to_string(gw::kSetPrmLen) +
             " (byte 9 = " + std::to_string(f.byte) +
             ": first missing or excess byte; docs/dp-slave.md)";
    std::string at = prm_byte_name(f.byte);
    if (f.byte < len) at += " = " + hex8(g.input.params.prm[f.byte]);
    return state + ": Set_Prm rejected at " + at + ", a correct value is " + hex8(f.correct) +
           " (docs/dp-slave.md)";
  }
  if (!g.prm_accepted) return state + ": Set_Prm rejected";
  if (g.cfg_fault) {
    const auto& f = *g.cfg_fault;
    std::string where = "slot " + std::to_string(f.slot);
    if (f.slot < g.slots.size()) where += " (" + g.slots[f.slot].json_path + ")";
    return state + ": Chk_Cfg rejected, " + where + ": code " + std::to_string(f.code) + " = " +
           std::string(gw::cfg_code_text(f.code)) + " (docs/slots.md)";
  }
  if (!g.cfg_accepted) return state + ": Chk_Cfg rejected";
  return state + ": the gateway accepts the parameters and the configuration";
}

namespace {

// docs/validate.md "The line": the predicted bus cycle and the line's problems (timed lines only).
void format_line(std::ostringstream& os, const LineReport& l) {
  const auto& p = l.params;
  os << "\nline: " << *l.baud << " bit/s, predicted bus cycle " << l.cycle.mean.count() << " us ("
     << l.cycle.bits << " bit times; " << l.cycle.worst.count()
     << " us with a GAP request), cycle_ms " << l.cycle_ms << "\n";
  os << "  bus parameters: slot_time " << p.slot_time_bits << ", min_tsdr " << p.min_tsdr_bits
     << ", max_tsdr " << p.max_tsdr_bits << ", tset " << p.tset_bits << ", tqui " << p.tqui_bits
     << ", gap_factor " << p.gap_factor << ", hsa " << p.hsa << ", retry_limit " << p.retry_limit
     << ", ttr " << p.ttr_bits << "\n";
  os << "  problems:";
  if (l.problems.empty()) os << " none";
  os << "\n";
  for (const auto& x : l.problems)
    os << "    " << (x.error ? "error: " : "") << x.json_path << ": " << x.message << "\n";
}

json line_json(const LineReport& l) {
  json o;
  o["ideal"] = !l.baud;
  json problems = json::array();
  for (const auto& x : l.problems)
    problems.push_back({{"severity", x.error ? "error" : "warning"},
                        {"json_path", x.json_path},
                        {"message", x.message}});
  if (!l.baud) {
    o["baud"] = nullptr;
    o["bus_cycle_us"] = nullptr;
    if (!problems.empty()) o["problems"] = problems;  // the watchdogs' (docs/validate.md)
    return o;
  }
  const auto& p = l.params;
  o["baud"] = *l.baud;
  o["bus_cycle_us"] = l.cycle.mean.count();
  o["bus_cycle_bits"] = l.cycle.bits;
  o["bus_cycle_gap_us"] = l.cycle.worst.count();
  o["cycle_ms"] = l.cycle_ms;
  o["bus_parameters"] = {{"slot_time_bits", p.slot_time_bits},
                         {"min_tsdr_bits", p.min_tsdr_bits},
                         {"max_tsdr_bits", p.max_tsdr_bits},
                         {"tset_bits", p.tset_bits},
                         {"tqui_bits", p.tqui_bits},
                         {"gap_factor", p.gap_factor},
                         {"hsa", p.hsa},
                         {"retry_limit", p.retry_limit},
                         {"ttr_bits", p.ttr_bits}};
  o["problems"] = problems;
  return o;
}

// Microseconds with up to three decimals, trailing zeros dropped: "135", "168.75".
std::string us_text(std::chrono::nanoseconds d) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", static_cast<double>(d.count()) / 1000.0);
  std::string t = b;
  while (t.back() == '0') t.pop_back();
  if (t.back() == '.') t.pop_back();
  return t;
}

double us_value(std::chrono::nanoseconds d) {
  return static_cast<double>(d.count()) / 1000.0;
}

// The messages of a bus, highest priority first (bitwise arbitration), then in configuration
// order.
std::vector<std::size_t> priority_order(const BusReport& b) {
  std::vector<std::size_t> order(b.messages.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    const auto& a = b.messages[x].message;
    const auto& c = b.messages[y].message;
    return can::arbitration_key(a.id, a.remote) < can::arbitration_key(c.id, c.remote);
  });
  return order;
}

std::string pct_text(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f %%", v);
  return b;
}

// docs/validate.md "CAN buses": the bus's load and one row per message.
void format_bus(std::ostringstream& os, const BusReport& b) {
  os << "\nbus " << b.name << ": " << b.bitrate << " bit/s, predicted load " << pct_text(b.load_pct)
     << " (worst-case frame lengths, outputs sent every master cycle of " << b.cycle_ms
     << " ms), limit " << pct_text(kBusLoadLimitPct) << "\n";
  os << "  identifiers (highest priority first; times in us; deadline = period):";
  if (b.messages.empty()) os << " none";
  os << "\n";
  if (!b.messages.empty()) {
    std::vector<std::vector<std::string>> rows = {
        {"CAN ID", "frame", "period", "bits", "C", "B", "R", "R<=T", "sender", "source", "from"}};
    for (const auto i : priority_order(b)) {
      const BusMessage& m = b.messages[i];
      const can::RtaResult& a = b.analysis.messages[i];
      rows.push_back(
          {"0x" + can::ident_text(m.message.id),
           std::string(m.message.remote ? "rtr " : "data ") + std::to_string(m.message.dlc),
           m.once ? "once" : us_text(m.message.period), std::to_string(a.frame_bits),
           us_text(a.transmission), us_text(a.blocking), a.response ? us_text(*a.response) : "-",
           m.once ? "-" : (a.schedulable ? "yes" : "no"), m.sender,
           std::string(to_string(m.source)), m.json_path});
    }
    os << table(rows, "    ", {false, false, true, true, true, true, true});
  }
  os << "  problems:";
  if (b.problems.empty()) os << " none";
  os << "\n";
  for (const auto& p : b.problems) os << "    " << p.json_path << ": " << p.message << "\n";
}

json bus_json(const BusReport& b) {
  json o;
  o["bitrate"] = b.bitrate;
  o["load_pct"] = std::round(b.load_pct * 100.0) / 100.0;
  o["load_limit_pct"] = kBusLoadLimitPct;
  o["cycle_ms"] = b.cycle_ms;
  json ids = json::array();
  for (const auto i : priority_order(b)) {
    const BusMessage& m = b.messages[i];
    const can::RtaResult& a = b.analysis.messages[i];
    json x;
    x["can_id"] = "0x" + can::ident_text(m.message.id);
    x["extended"] = m.message.id.extended;
    x["remote"] = m.message.remote;
    x["dlc"] = m.message.dlc;
    x["sender"] = m.sender;
    x["source"] = to_string(m.source);
    x["json_path"] = m.json_path;
    x["period_us"] = m.once ? json(nullptr) : json(us_value(m.message.period));
    x["jitter_us"] = us_value(m.message.jitter);
    x["frame_bits"] = a.frame_bits;
    x["transmission_us"] = us_value(a.transmission);
    x["blocking_us"] = us_value(a.blocking);
    x["busy_period_us"] = a.busy_period ? json(us_value(*a.busy_period)) : json(nullptr);
    x["instances"] = a.instances;
    x["response_us"] = a.response ? json(us_value(*a.response)) : json(nullptr);
    x["meets_period"] = m.once ? json(nullptr) : json(a.schedulable);
    ids.push_back(x);
  }
  o["identifiers"] = ids;
  json problems = json::array();
  for (const auto& p : b.problems)
    problems.push_back(
        {{"severity", "warning"}, {"json_path", p.json_path}, {"message", p.message}});
  o["problems"] = problems;
  return o;
}

}  // namespace

std::string format_text(const Report& r) {
  std::ostringstream os;
  os << "candp2 validate " << r.file << "\n";
  if (r.gsd_file.empty())
    os << "named parameters: built-in encoding (docs/dp-slave.md)\n";
  else
    os << "named parameters: encoded through the GSD " << r.gsd_file << " (" << r.gsd_name << ")\n";
  std::size_t invalid = 0;
  for (const auto& g : r.gateways) {
    const GatewayInput& in = g.input;
    if (!g.valid()) ++invalid;
    os << "\ngateway " << in.name << " (" << in.json_path << "): DP address " << int(g.dp_address);
    if (!in.bus.empty()) os << ", bus " << in.bus;
    os << "\n";
    os << "  Set_Prm, " << plural(in.params.prm.size(), "byte") << " from " << in.prm_source
       << ":\n    " << hex_bytes(in.params.prm) << "\n";
    os << "  Chk_Cfg, " << plural(in.params.cfg.size(), "byte") << " from " << in.json_path
       << ".slots:\n    " << (in.params.cfg.empty() ? "(none)" : hex_bytes(in.params.cfg)) << "\n";
    if (g.cfg_decode_error) os << "    malformed: " << *g.cfg_decode_error << "\n";
    if (g.prm) os << parameters_text(g);
    os << "  slots:";
    if (g.slots.empty())
      os << " none\n";
    else
      os << "\n" << slot_table(g);
    if (!g.prm_accepted)
      os << "    (Chk_Cfg not evaluated: the gateway ignores it after a rejected Set_Prm)\n";
    os << "  diagnosis: " << hex_bytes(g.diag) << "\n";
    os << "    " << dp::describe_diag(g.diag) << "\n";
    os << "    " << explain_diagnosis(g) << "\n";
    format_warnings(os, g.warnings, station_warnings(r.line, in.json_path));
  }
  for (const auto& s : r.slaves) {
    if (!s.valid()) ++invalid;
    format_slave(os, s, station_warnings(r.line, s.input.json_path));
  }
  if (r.line.baud) format_line(os, r.line);
  for (const auto& b : r.buses) format_bus(os, b);
  os << "\n";
  // "1 gateway" or, with generic slaves, "1 gateway, 2 slaves".
  std::string stations = plural(r.gateways.size(), "gateway");
  if (!r.slaves.empty()) stations += ", " + plural(r.slaves.size(), "slave");
  // The line's errors (a rate a GSD does not support, a watchdog that can never hold) apart.
  const std::size_t line_errors = r.line.problems.size() - r.line.warnings();
  const std::string errors = line_errors ? plural(line_errors, "line error") + ", " : "";
  if (invalid == 0 && line_errors == 0)
    os << "result: valid (" << stations << ", " << plural(r.warning_count(), "warning") << ")\n";
  else if (invalid == 0)
    os << "result: invalid (" << stations << ", " << errors << plural(r.warning_count(), "warning")
       << ")\n";
  else
    os << "result: invalid (rejected by " << invalid << " of " << stations << ", " << errors
       << plural(r.warning_count(), "warning") << ")\n";
  return os.str();
}

json to_json(const Report& r, int exit_code) {
  json j;
  j["file"] = r.file;
  if (r.gsd_file.empty())
    j["gsd"] = nullptr;
  else
    j["gsd"] = {{"file", r.gsd_file}, {"device", r.gsd_name}};
  j["valid"] = r.valid();
  j["exit_code"] = exit_code;
  j["warning_count"] = r.warning_count();
  json gateways = json::array();
  for (const auto& g : r.gateways) {
    const GatewayInput& in = g.input;
    json o;
    o["name"] = in.name;
    o["json_path"] = in.json_path;
    o["address"] = in.address;
    o["dp_address"] = g.dp_address;
    o["bus"] = in.bus;
    o["valid"] = g.valid();
    o["set_prm"] = {{"bytes", hex_bytes(in.params.prm)},
                    {"source", in.prm_source},
                    {"accepted", g.prm_accepted}};
    o["parameters"] = parameters_json(g);
    o["chk_cfg"] = {{"bytes", hex_bytes(in.params.cfg)},
                    {"accepted", g.cfg_accepted},
                    {"evaluated", g.prm_accepted},
                    {"malformed", g.cfg_decode_error ? json(*g.cfg_decode_error) : json(nullptr)}};
    json slots = json::array();
    for (const auto& row : g.slots) slots.push_back(slot_json(row));
    o["slots"] = slots;
    json d;
    d["bytes"] = hex_bytes(g.diag);
    d["words"] = dp::describe_diag(g.diag);
    d["state"] = dp::to_string(g.state);
    d["explanation"] = explain_diagnosis(g);
    d["not_supported"] = g.not_supported;
    if (g.prm_fault)
      d["prm_fault"] = {{"byte", g.prm_fault->byte},
                        {"name", prm_byte_name(g.prm_fault->byte)},
                        {"correct", hex8(g.prm_fault->correct)}};
    else
      d["prm_fault"] = nullptr;
    if (g.cfg_fault)
      d["cfg_fault"] = {{"slot", g.cfg_fault->slot},
                        {"json_path", g.cfg_fault->slot < g.slots.size()
                                          ? json(g.slots[g.cfg_fault->slot].json_path)
                                          : json(nullptr)},
                        {"code", g.cfg_fault->code},
                        {"text", gw::cfg_code_text(g.cfg_fault->code)}};
    else
      d["cfg_fault"] = nullptr;
    o["diagnosis"] = d;
    o["warnings"] = warnings_json(g.warnings, station_warnings(r.line, in.json_path));
    gateways.push_back(o);
  }
  j["gateways"] = gateways;
  // Only with generic slaves in the configuration (docs/validate.md "--json").
  if (!r.slaves.empty()) {
    json slaves = json::array();
    for (const auto& s : r.slaves)
      slaves.push_back(slave_json(s, station_warnings(r.line, s.input.json_path)));
    j["slaves"] = slaves;
  }
  j["line"] = line_json(r.line);
  // Only with timed CAN buses in the configuration (docs/validate.md "--json").
  if (!r.buses.empty()) {
    json buses = json::object();
    for (const auto& b : r.buses) buses[b.name] = bus_json(b);
    j["buses"] = buses;
  }
  return j;
}

}  // namespace candp2::validate
