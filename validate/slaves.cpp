#include "validate/slaves.hpp"

#include <algorithm>

#include "common/hex.hpp"
#include "validate/text.hpp"
#include "validate/validate.hpp"

namespace candp2::validate {

namespace {

using json = nlohmann::ordered_json;

std::string trimmed(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return gsd::to_utf8(s);
}

// Hex bytes, 16 per line, each line indented.
std::string wrapped(std::span<const std::uint8_t> b, const std::string& indent) {
  if (b.empty()) return indent + "(none)\n";
  std::string out;
  for (std::size_t i = 0; i < b.size(); i += 16)
    out += indent + hex_bytes(b.subspan(i, std::min<std::size_t>(16, b.size() - i))) + "\n";
  return out;
}

void fill_modules(SlaveReport& r, const gsd_slave::GsdSlave& slave) {
  const SlaveInput& in = r.input;
  const gsd_slave::Configuration& c = slave.configuration();
  // PLC addresses per identifier entry (config::slave_parameters), summed up per module.
  const auto entries = dp::decode_chk_cfg(in.params.cfg).entries;
  std::size_t entry = 0;
  auto add = [&](std::string name, std::string path, std::vector<std::uint8_t> bytes) {
    SlaveModuleRow row;
    row.name = std::move(name);
    row.json_path = std::move(path);
    const auto decoded = dp::decode_chk_cfg(bytes);
    for (std::size_t k = 0; k < decoded.entries.size(); ++k, ++entry) {
      row.in_length += decoded.entries[k].in_bytes();
      row.out_length += decoded.entries[k].out_bytes();
      if (entry >= in.params.addresses.size() || entry >= entries.size()) continue;
      const auto& a = in.params.addresses[entry];
      if (!row.plc_input && entries[entry].in_bytes() && a.input) row.plc_input = a.input;
      if (!row.plc_output && entries[entry].out_bytes() && a.output) row.plc_output = a.output;
    }
    row.cfg_bytes = std::move(bytes);
    r.modules.push_back(std::move(row));
  };
  if (c.modules.empty()) {
    add("", in.cfg_source, c.bytes);
    return;
  }
  for (std::size_t i = 0; i < c.modules.size(); ++i)
    add(trimmed(c.modules[i]->name),
        i < in.module_paths.size() ? in.module_paths[i] : in.cfg_source, c.modules[i]->config);
}

void fill_parameters(SlaveReport& r, const gsd_slave::GsdSlave& slave) {
  const auto& prm = r.input.params.prm;
  if (prm.size() < dp::kPrmStdLen) return;
  const auto user = std::span(prm).subspan(dp::kPrmStdLen);
  const auto& layout = slave.user_prm_layout();
  r.user_prm_len = user.size();
  for (const auto& f : layout.fields) {
    if (f.offset + f.def->size() > user.size()) continue;
    const std::int64_t v = gsd_slave::read_value(user, f);
    if (f.offset + f.def->size() <= layout.defaults.size() &&
        gsd_slave::read_value(layout.defaults, f) == v)
      continue;
    SlaveParamRow row;
    row.name = trimmed(f.def->name);
    row.module = trimmed(f.module);
    row.byte = dp::kPrmStdLen + f.offset;
    if (f.def->type == gsd::PrmType::Bit)
      row.bits = std::to_string(f.def->first_bit);
    else if (f.def->type == gsd::PrmType::BitArea)
      row.bits = std::to_string(f.def->first_bit) + "-" + std::to_string(f.def->last_bit);
    row.value = v;
    if (f.def->prm_text_ref)
      if (const gsd::PrmText* t = slave.gsd().prm_text(*f.def->prm_text_ref))
        if (const std::string* text = t->text_for(v)) row.text = trimmed(*text);
    r.parameters.push_back(std::move(row));
  }
}

}  // namespace

SlaveReport check_slave(SlaveInput input) {
  SlaveReport r;
  r.input = std::move(input);
  const SlaveInput& in = r.input;
  std::string error;
  auto slave = gsd_slave::GsdSlave::create(in.setup, &error);
  if (!slave) {
    r.error = error;
    return r;
  }
  r.device = slave->profile().name();
  const Time t0{0};
  dp::DpSlave& dp = slave->dp();
  // The master's start-up sequence: Set_Prm, Chk_Cfg, Slave_Diag (as for gateways).
  r.prm_accepted = dp.set_prm(in.master_address, in.params.prm, t0);
  r.cfg_accepted = dp.chk_cfg(in.master_address, in.params.cfg, t0);
  r.diag = dp.diagnosis(t0);
  r.state = dp.state();
  r.not_supported = r.diag.size() > 0 && (r.diag[0] & dp::kDiag1NotSupported);
  r.prm_problem = slave->prm_problem();
  r.cfg_problem = r.prm_accepted ? slave->cfg_problem() : "";
  fill_modules(r, *slave);
  fill_parameters(r, *slave);
  return r;
}

std::string explain_slave(const SlaveReport& s) {
  if (s.error) return "not emulated: " + *s.error;
  const std::string state(dp::to_string(s.state));
  if (s.not_supported)
    return state +
           ": Set_Prm rejected, Not_Supported: Sync_Req or Freeze_Req, which the GSD "
           "does not support (docs/slaves.md)";
  if (!s.prm_accepted)
    return state + ": Set_Prm rejected (Prm_Fault): " +
           (s.prm_problem.empty() ? std::string("see the log") : s.prm_problem);
  if (!s.cfg_accepted)
    return state + ": Chk_Cfg rejected (Cfg_Fault): " +
           (s.cfg_problem.empty() ? std::string("see the log") : s.cfg_problem);
  return state + ": the slave accepts the parameters and the configuration";
}

void format_slave(std::ostream& os, const SlaveReport& s, const std::vector<Warning>& line) {
  const SlaveInput& in = s.input;
  os << "\nslave " << in.name << " (" << in.json_path << "): DP address " << int(in.setup.address);
  if (in.field_unit) os << ", field_unit " << int(*in.field_unit);
  os << "\n  GSD " << in.gsd_file;
  if (!s.device.empty()) os << ": " << s.device;
  os << "\n";
  if (s.error) {
    os << "  " << explain_slave(s) << "\n";
    return;
  }
  os << "  Set_Prm, " << plural(in.params.prm.size(), "byte") << " from " << in.prm_source << ":\n"
     << wrapped(in.params.prm, "    ");
  os << "  Chk_Cfg, " << plural(in.params.cfg.size(), "byte") << " from " << in.cfg_source << ":\n"
     << wrapped(in.params.cfg, "    ");
  os << "  parameters: " << plural(s.user_prm_len, "user byte");
  if (s.parameters.empty())
    os << ", all GSD defaults\n";
  else
    os << ", " << s.parameters.size() << " not the GSD default:\n";
  for (const auto& p : s.parameters) {
    os << "    \"" << p.name << "\"";
    if (!p.module.empty()) os << " of module \"" << p.module << "\"";
    os << " (byte " << p.byte << (p.bits.empty() ? "" : ", bits " + p.bits) << ") = " << p.value;
    if (!p.text.empty()) os << " \"" << p.text << "\"";
    os << "\n";
  }
  os << "  modules:\n";
  for (std::size_t i = 0; i < s.modules.size(); ++i) {
    const auto& m = s.modules[i];
    os << "    " << i << ": " << (m.name.empty() ? "(cfg_hex)" : "\"" + m.name + "\"") << " "
       << hex_bytes(m.cfg_bytes) << ", in " << m.in_length;
    if (m.in_length && m.plc_input) os << " at I " << range(*m.plc_input, m.in_length);
    os << ", out " << m.out_length;
    if (m.out_length && m.plc_output) os << " at Q " << range(*m.plc_output, m.out_length);
    os << "\n";
  }
  os << "  diagnosis: " << hex_bytes(s.diag) << "\n";
  os << "    " << dp::describe_diag(s.diag) << "\n";
  os << "    " << explain_slave(s) << "\n";
  if (!in.notes.empty()) os << "  notes:\n";
  for (const auto& n : in.notes) os << "    " << n.json_path << ": " << n.message << "\n";
  format_warnings(os, s.warnings, line);
}

json slave_json(const SlaveReport& s, const std::vector<Warning>& line) {
  const SlaveInput& in = s.input;
  json o;
  o["name"] = in.name;
  o["json_path"] = in.json_path;
  o["address"] = in.setup.address;
  o["field_unit"] = in.field_unit ? json(*in.field_unit) : json(nullptr);
  o["gsd"] = {{"file", in.gsd_file}, {"device", s.device}};
  o["valid"] = s.valid();
  o["error"] = s.error ? json(*s.error) : json(nullptr);
  o["set_prm"] = {{"bytes", hex_bytes(in.params.prm)},
                  {"source", in.prm_source},
                  {"accepted", s.prm_accepted},
                  {"problem", s.prm_problem.empty() ? json(nullptr) : json(s.prm_problem)}};
  json params = json::array();
  for (const auto& p : s.parameters)
    params.push_back({{"name", p.name},
                      {"module", p.module.empty() ? json(nullptr) : json(p.module)},
                      {"byte", p.byte},
                      {"bits", p.bits.empty() ? json(nullptr) : json(p.bits)},
                      {"value", p.value},
                      {"text", p.text.empty() ? json(nullptr) : json(p.text)}});
  o["parameters"] = params;
  o["chk_cfg"] = {{"bytes", hex_bytes(in.params.cfg)},
                  {"source", in.cfg_source},
                  {"accepted", s.cfg_accepted},
                  {"evaluated", s.prm_accepted},
                  {"problem", s.cfg_problem.empty() ? json(nullptr) : json(s.cfg_problem)}};
  json modules = json::array();
  for (const auto& m : s.modules)
    modules.push_back({{"name", m.name.empty() ? json(nullptr) : json(m.name)},
                       {"json_path", m.json_path},
                       {"chk_cfg", hex_bytes(m.cfg_bytes)},
                       {"in_length", m.in_length},
                       {"out_length", m.out_length},
                       {"plc_input", m.plc_input ? json(*m.plc_input) : json(nullptr)},
                       {"plc_output", m.plc_output ? json(*m.plc_output) : json(nullptr)}});
  o["modules"] = modules;
  o["diagnosis"] = {{"bytes", hex_bytes(s.diag)},
                    {"words", s.diag.empty() ? std::string() : dp::describe_diag(s.diag)},
                    {"state", dp::to_string(s.state)},
                    {"explanation", explain_slave(s)},
                    {"not_supported", s.not_supported}};
  json notes = json::array();
  for (const auto& n : in.notes)
    notes.push_back({{"json_path", n.json_path}, {"message", n.message}});
  o["notes"] = notes;
  o["warnings"] = warnings_json(s.warnings, line);
  return o;
}

}  // namespace candp2::validate
