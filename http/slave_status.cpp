// The generic DP-V0 slaves in the HTTP face (docs/slaves.md "Front panel and HTTP API",
// docs/daemon.md "HTTP face"): a slave's overview tile and its whole state, read from its unit's
// view (plant::SlaveView) and from its status and whole diagnosis (plant/station_status.hpp), so the
// page, Modbus and /metrics can never disagree.

#include "common/hex.hpp"
#include "gsd/cfg.hpp"
#include "http/http_status.hpp"
#include "plant/plant.hpp"
#include "profibus_sim/dp/dp_telegram.hpp"

namespace candp2::http {

namespace {

using nlohmann::json;

// The one line a slave's tile shows when something is wrong (docs/slaves.md "Faults"): off the
// bus, a forced or real Prm/Cfg fault, Not_Supported, a diagnosis alarm, a master that stopped
// addressing it. Empty when all is well.
std::string slave_fault(const SlaveSource& s, std::span<const std::uint8_t> diag,
                        const std::optional<dp::DpMaster::SlaveView>& view) {
  const plant::SlaveView g = s.unit->view();
  const std::uint8_t s1 = diag.empty() ? 0 : diag[0];
  if (!g.online) return "off the bus";
  if (g.prm_fault_forced) return "Prm fault (forced)";
  if (g.cfg_fault_forced) return "Cfg fault (forced)";
  if (s1 & dp::kDiag1PrmFault) return "Prm fault";
  if (s1 & dp::kDiag1CfgFault) return "Cfg fault";
  if (s1 & dp::kDiag1NotSupported) return "Not_Supported";
  if (s1 & dp::kDiag1ExtDiag) return "diagnosis alarm";
  if (view && !view->addressed) return "not addressed by the master";
  return "";
}

std::string plc_address(char area, std::optional<std::uint16_t> base, std::size_t offset,
                        std::size_t length) {
  if (!base || length == 0) return {};
  std::string text(1, area);  // appended, not operator+ (GCC 12 -Wrestrict false positive)
  text += std::to_string(*base + offset);
  return text;
}

json nullable(const std::string& s) {
  return s.empty() ? json(nullptr) : json(s);
}

// One module row: its GSD name (or "entry k" of a cfg_hex configuration), its Chk_Cfg bytes, the
// input/output lengths and offsets in the slave's process data, the PLC addresses the built-in
// master gives them, and the current bytes of each direction.
json module_row(const SlaveSource& s, std::string name, std::span<const std::uint8_t> cfg,
                std::size_t in_len, std::size_t out_len, std::size_t in_at, std::size_t out_at) {
  const plant::SlaveView g = s.unit->view();
  const auto in = g.field_inputs;
  const auto out = g.field_outputs;
  auto slice = [](std::span<const std::uint8_t> all, std::size_t at, std::size_t n) {
    return at + n <= all.size() ? hex_bytes(all.subspan(at, n)) : std::string();
  };
  return {{"name", std::move(name)},
          {"cfg_hex", hex_bytes(cfg)},
          {"inputs", in_len},
          {"outputs", out_len},
          {"input_offset", in_at},
          {"output_offset", out_at},
          {"plc_inputs", nullable(plc_address('I', s.cfg->input_address, in_at, in_len))},
          {"plc_outputs", nullable(plc_address('Q', s.cfg->output_address, out_at, out_len))},
          {"input_bytes", slice(in, in_at, in_len)},
          {"output_bytes", slice(out, out_at, out_len)}};
}

json modules_json(const SlaveSource& s) {
  json rows = json::array();
  const auto& c = s.unit->view().configuration;
  std::size_t in_at = 0, out_at = 0;
  if (!c.modules.empty()) {
    for (const gsd::Module* m : c.modules) {
      const auto d = gsd::decode_config(m->config);
      rows.push_back(module_row(s, gsd::to_utf8(m->name), m->config, d.input_len, d.output_len,
                                in_at, out_at));
      in_at += d.input_len;
      out_at += d.output_len;
    }
    return rows;
  }
  for (std::size_t k = 0; k < c.decoded.entries.size(); ++k) {  // cfg_hex: one row an entry
    const auto& e = c.decoded.entries[k];
    rows.push_back(module_row(s, "entry " + std::to_string(k + 1), e.bytes, e.input_len(),
                              e.output_len(), in_at, out_at));
    in_at += e.input_len();
    out_at += e.output_len();
  }
  return rows;
}

}  // namespace

json StatusModel::slave_tile(std::size_t index, Time now) const {
  const SlaveSource& s = src_.slaves[index];
  const auto diag = s.diagnosis(now);
  const auto view = src_.master ? src_.master->slave(s.cfg->address) : std::nullopt;
  const plant::SlaveView g = s.unit->view();
  return {{"dp_address", s.cfg->address},
          {"name", s.cfg->name},
          {"model", gsd::to_utf8(g.profile.model)},
          {"kind", s.line ? "line" : "in-process"},
          {"dp_state", std::string(dp::to_string(g.dp_state))},
          {"fault", slave_fault(s, diag, view)}};
}

json StatusModel::slave_json(std::size_t index, Time now) const {
  const SlaveSource& s = src_.slaves[index];
  const station::Status status = s.status(now);
  const auto diag = s.diagnosis(now);
  const auto view = src_.master ? src_.master->slave(s.cfg->address) : std::nullopt;
  const plant::SlaveView g = s.unit->view();
  const auto& p = g.profile;
  json j;
  j["name"] = s.cfg->name;
  j["dp_address"] = s.cfg->address;
  j["kind"] = s.line ? "line" : "in-process";
  j["gsd"] = {{"file", s.cfg->gsd},
              {"model", gsd::to_utf8(p.model)},
              {"vendor", gsd::to_utf8(p.vendor)},
              {"ident_number", p.ident_number}};
  j["field_unit"] = s.cfg->field_unit ? json(*s.cfg->field_unit) : json(nullptr);
  j["watchdog_ms"] = s.cfg->watchdog_ms;
  j["dp_state"] = std::string(dp::to_string(g.dp_state));
  j["dp_state_code"] = station::field("dp_state")->get(status);
  if (view)
    j["master"] = {{"state", std::string(dp::to_string(view->state))},
                   {"data_exchanges", view->data_exchanges},
                   {"parameterizations", view->parameterizations},
                   {"addressed", view->addressed},
                   {"station_lost", view->station_lost}};
  else
    j["master"] = nullptr;         // no built-in master drives it (profibus role slaves)
  json counters = json::object();  // the station table's (station/status.hpp)
  for (const auto& f : station::fields())
    if (f.shown & station::kSlaveCounters) counters[std::string(f.name)] = f.get(status);
  j["counters"] = std::move(counters);

  // The whole diagnosis (docs/slaves.md "Diagnosis"): 6 standard bytes, then Ext_Diag_Data.
  json bits = json::array();
  for (const auto& b : dp::kDiagBitNames)
    if (b.byte < diag.size() && (diag[b.byte] & b.mask)) bits.push_back(b.name);
  const bool full = diag.size() >= dp::kDiagStdLen;
  j["diag"] = diag;
  j["diagnosis"] = {
      {"bits", std::move(bits)},
      {"master_address", full && diag[3] != 0xFF ? json(diag[3]) : json(nullptr)},
      {"ident_number", full ? json(diag[4] << 8 | diag[5]) : json(nullptr)},
      {"ext_diag_hex", full ? hex_bytes(std::span(diag).subspan(dp::kDiagStdLen)) : std::string()}};
  j["prm_problem"] = g.prm_problem;
  j["cfg_problem"] = g.cfg_problem;

  j["modules"] = modules_json(s);
  j["input_length"] = g.input_length;
  j["output_length"] = g.output_length;
  // The field side (docs/slaves.md "Field side"): what the slave reports, what it applies, and
  // the master's last outputs as on the wire.
  j["inputs_hex"] = hex_bytes(g.field_inputs);
  j["outputs_hex"] = hex_bytes(g.field_outputs);
  j["received_outputs_hex"] = hex_bytes(g.received_outputs);
  const auto& alarm = g.device_diagnosis;
  j["faults"] = {{"on_bus", g.online},
                 {"prm_fault", g.prm_fault_forced},
                 {"cfg_fault", g.cfg_fault_forced},
                 {"alarm_hex", alarm ? json(hex_bytes(*alarm)) : json(nullptr)}};
  j["fault"] = slave_fault(s, diag, view);
  return j;
}

}  // namespace candp2::http
