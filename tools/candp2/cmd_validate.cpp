// candp2 validate CONFIG [--gsd FILE] [--json] [--strict]: what the emulated CAN-DP/2 makes of
// every gateway of a daemon configuration, and every generic slave of its own GSD
// (docs/validate.md). Exit status: 0 valid, 1 invalid (a gateway or slave rejects its Set_Prm or
// Chk_Cfg; with --strict also any warning), 2 unusable input (file missing, JSON syntax,
// configuration error, unusable GSD).
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <variant>

#include "common/hex.hpp"
#include "config/config.hpp"
#include "config/watchdog_check.hpp"
#include "gateway/line_limits.hpp"
#include "gsd/gsd.hpp"
#include "tools/candp2/commands.hpp"
#include "validate/params.hpp"
#include "validate/report.hpp"
#include "validate/validate.hpp"

namespace candp2::cli {

namespace {

struct ValidateArgs {
  std::string config;
  std::string gsd;
  bool json = false;
  bool strict = false;
};

// Unusable input: the message on stderr; with --json also a JSON document on stdout.
int unusable(const ValidateArgs& a, const std::string& file, const std::string& json_path,
             const std::string& message) {
  std::cerr << "candp2 validate: " << file << ": " << (json_path.empty() ? "" : json_path + ": ")
            << message << "\n";
  if (a.json) {
    nlohmann::ordered_json j;
    j["file"] = a.config;
    j["valid"] = false;
    j["exit_code"] = 2;
    j["error"] = {{"file", file},
                  {"json_path", json_path.empty() ? nlohmann::ordered_json(nullptr)
                                                  : nlohmann::ordered_json(json_path)},
                  {"message", message}};
    std::cout << j.dump(2) << "\n";
  }
  return 2;
}

std::string device_name(const gsd::Model& m) {
  char ident[16] = "?";
  if (const auto id = m.ident_number())
    std::snprintf(ident, sizeof ident, "0x%04llX", static_cast<unsigned long long>(*id));
  return gsd::to_utf8(m.vendor_name()) + " " + gsd::to_utf8(m.model_name()) + ", Ident_Number " +
         ident;
}

// docs/validate.md "The line": the stations as the line sees them (a gateway's GSD is --gsd, when
// given, else the CAN-DP/2's own values; a generic slave's its own).
validate::LineInput line_input(const config::DaemonConfig& cfg, const gsd::Model* gateway_gsd,
                               const std::string& gateway_gsd_name) {
  validate::LineInput in;
  in.baud = cfg.line->baud;
  in.baud_path = cfg.line->json_path;
  in.params = cfg.line->params;
  in.master_address = cfg.master_address;
  in.cycle_ms = cfg.cycle_ms;
  auto add = [&](const std::string& name, const std::string& path, std::uint8_t address,
                 const dp::SlaveParameters& params, const gsd::Model* model,
                 const std::string& gsd_name) {
    const dp::ImageMap map = dp::map_image(params);
    in.stations.push_back(
        {name, path, address, map.out_len, map.in_len, model, "the GSD " + gsd_name, std::nullopt});
  };
  for (const auto& g : cfg.gateways) {
    add(g.name, g.json_path, g.dp_address(), config::slave_parameters(g), gateway_gsd,
        gateway_gsd_name);
    if (!gateway_gsd) {  // its own GSD's values, built in (as the plant answers)
      in.stations.back().max_tsdr_bits = gw::max_tsdr_bits(in.baud);
      in.stations.back().gsd_name = "the CAN-DP/2's GSD";
    }
  }
  for (const auto& s : cfg.slaves)
    add(s.name, s.json_path, s.address, config::slave_parameters(s), s.model.get(), s.gsd);
  return in;
}

// Whether element `i` of the top-level array `list` of the configuration has `key`: a path the
// report prints must be one the file has (docs/validate.md: every path can be pasted into jq).
bool has_key(const nlohmann::json& doc, const char* list, std::size_t i, const char* key) {
  const auto it = doc.find(list);
  return it != doc.end() && it->is_array() && i < it->size() && (*it)[i].is_object() &&
         (*it)[i].contains(key);
}

// The longest head of `path` ("$.master.bus_parameters.max_tsdr_bits") that `doc` has: a line
// check names the key to change, which the file may leave at its default (the message names the
// key and its value).
std::string existing_path(const nlohmann::json& doc, const std::string& path) {
  const nlohmann::json* node = &doc;
  std::size_t end = 1;  // after "$"
  while (end < path.size()) {
    std::size_t next = end;
    const nlohmann::json* child = nullptr;
    if (path[end] == '.') {
      next = path.find_first_of(".[", end + 1);
      if (next == std::string::npos) next = path.size();
      const std::string key = path.substr(end + 1, next - end - 1);
      if (node->is_object() && node->contains(key)) child = &(*node)[key];
    } else if (path[end] == '[' && end + 1 < path.size() && path[end + 1] == '"') {
      next = path.find("\"]", end);
      if (next == std::string::npos) break;
      next += 2;
      const auto key = nlohmann::json::parse(path.substr(end + 1, next - end - 2), nullptr, false);
      if (key.is_string() && node->is_object() && node->contains(key.get<std::string>()))
        child = &(*node)[key.get<std::string>()];
    } else if (path[end] == '[') {
      next = path.find(']', end);
      if (next == std::string::npos) break;
      ++next;
      const std::size_t i = std::strtoul(path.c_str() + end + 1, nullptr, 10);
      if (node->is_array() && i < node->size()) child = &(*node)[i];
    }
    if (!child) break;
    node = child;
    end = next;
  }
  return path.substr(0, end);
}

int run_validate(const ValidateArgs& a) {
  auto loaded = config::load_daemon(a.config);
  if (const auto* e = std::get_if<config::ConfigError>(&loaded))
    return unusable(a, e->file, e->json_path, e->message);
  const config::DaemonConfig& cfg = std::get<config::DaemonConfig>(loaded);
  // The file as JSON again (it loaded, so it parses): which optional keys it spells out.
  const nlohmann::json doc = nlohmann::json::parse(std::ifstream(a.config), nullptr, false);

  std::optional<gsd::ParseResult> gsd_file;
  if (!a.gsd.empty()) {
    if (!std::ifstream(a.gsd, std::ios::binary))
      return unusable(a, a.gsd, "",
                      "cannot open the GSD file: " + std::string(std::strerror(errno)));
    gsd_file = gsd::parse_file(a.gsd);
    if (gsd_file->not_gsd)  // one line, as `candp2 gsd` says it (docs/gsd.md)
      return unusable(a, a.gsd, "", gsd::to_utf8(gsd_file->diagnostics.front().message));
    if (!gsd_file->ok()) {
      std::string first;
      for (const auto& d : gsd_file->diagnostics)
        if (d.severity == gsd::Severity::Error) {
          first = gsd::format(d, a.gsd);
          break;
        }
      return unusable(a, a.gsd, "",
                      "the GSD has errors (see `candp2 gsd " + a.gsd + "`): " + first);
    }
  }

  validate::Report report;
  report.file = a.config;
  if (gsd_file) {
    report.gsd_file = a.gsd;
    report.gsd_name = device_name(gsd_file->model);
  }
  for (std::size_t i = 0; i < cfg.gateways.size(); ++i) {
    const auto& g = cfg.gateways[i];
    // Without a "parameters" object every parameter is its default (docs/configuration.md).
    const bool named = has_key(doc, "gateways", i, "parameters");
    const std::string prm_path = named ? g.json_path + ".parameters" : g.json_path;
    const std::string defaults = named ? "" : " (no parameters: the defaults)";
    validate::GatewayInput in;
    in.name = g.name;
    in.json_path = g.json_path;
    in.bus = g.bus;
    in.address = g.address;
    in.master_address = cfg.master_address;
    in.stored_sync_ms = g.stored_sync_ms;
    in.params = config::slave_parameters(g);
    // config: one Chk_Cfg entry per slot (cfg_hex holds exactly one entry).
    for (const auto& s : g.slots) in.entry_paths.push_back(s.json_path);
    if (g.prm_hex) {
      in.prm_source = g.json_path + ".prm_hex";
      if (gsd_file) in.prm_source += " (raw telegram, the GSD is not used)";
    } else if (!gsd_file) {
      in.prm_source = prm_path + defaults;
    } else {
      const auto enc = validate::encode_set_prm(gsd_file->model, g.parameters, g.watchdog_ms);
      if (!enc.errors.empty())
        return unusable(a, a.config, prm_path,
                        "cannot be encoded through the GSD " + a.gsd + ": " + enc.errors.front());
      // (the first error is enough to act on; `candp2 gsd FILE` shows the GSD's problems)
      in.params.prm = enc.telegram;
      in.prm_source = prm_path + defaults + " through the GSD";
      const auto builtin = config::set_prm_bytes(g);
      if (builtin != enc.telegram)
        in.warnings.push_back({validate::WarningKind::GsdEncoding, prm_path,
                               "the GSD encodes Set_Prm as " + hex_bytes(enc.telegram) +
                                   ", the built-in encoding (docs/dp-slave.md) gives " +
                                   hex_bytes(builtin)});
    }
    report.gateways.push_back(validate::check_gateway(std::move(in)));
  }
  validate::check_overlaps(report.gateways);
  // Generic slaves: checked against their own GSD (the --gsd option is for the gateways).
  for (std::size_t i = 0; i < cfg.slaves.size(); ++i) {
    const auto& s = cfg.slaves[i];
    validate::SlaveInput in;
    in.name = s.name;
    in.json_path = s.json_path;
    in.gsd_file = s.gsd;
    in.master_address = cfg.master_address;
    in.setup = s.setup();
    in.params = config::slave_parameters(s);
    const bool listed = has_key(doc, "slaves", i, "modules");
    if (listed)  // else the GSD's own, at in.cfg_source
      for (const auto& m : s.modules) in.module_paths.push_back(m.json_path);
    // No "parameters": the GSD's defaults; no "modules": the GSD's own (a compact station's one
    // module, docs/slaves.md).
    in.prm_source =
        s.json_path + (s.prm_hex                                 ? ".prm_hex"
                       : has_key(doc, "slaves", i, "parameters") ? ".parameters"
                                                                 : " (no parameters: "
                                                                   "the GSD's defaults)");
    in.cfg_source = s.json_path + (s.cfg_hex ? ".cfg_hex" : listed ? ".modules" : ".gsd");
    in.field_unit = s.field_unit;
    for (const auto& n : s.notes) in.notes.push_back({n.json_path, n.message});
    report.slaves.push_back(validate::check_slave(std::move(in)));
  }
  validate::check_slave_overlaps(report.gateways, report.slaves);
  if (cfg.line)
    report.line =
        validate::check_line(line_input(cfg, gsd_file ? &gsd_file->model : nullptr, a.gsd));
  // docs/validate.md "The watchdog rule": the words candp2d warns with, on the ideal line too.
  for (auto& w : config::check_watchdogs(cfg))
    report.line.problems.push_back({w.verdict == fdl::WatchdogVerdict::NeverHolds, w.json_path,
                                    std::move(w.message), w.station});
  for (auto& p : report.line.problems) p.json_path = existing_path(doc, p.json_path);

  // docs/validate.md "CAN buses": every timed bus, with the gateways and drives on it.
  std::vector<validate::DriveInput> drives;
  for (const auto& d : cfg.drives) drives.push_back({d.name, d.json_path, d.bus, d.rx_id, d.tx_id});
  for (const auto& b : cfg.buses) {
    if (!b.timed_bitrate) continue;
    report.buses.push_back(validate::check_bus({.name = b.name,
                                                .json_path = b.json_path + ".bitrate",
                                                .bitrate = *b.timed_bitrate,
                                                .cycle_ms = cfg.cycle_ms},
                                               report.gateways, drives));
    for (auto& p : report.buses.back().problems) p.json_path = existing_path(doc, p.json_path);
  }

  const int rc = validate::exit_code(report, a.strict);
  if (a.json)
    std::cout << validate::to_json(report, rc).dump(2) << "\n";
  else
    std::cout << validate::format_text(report);
  return rc;
}

}  // namespace

void add_validate(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<ValidateArgs>();
  auto* cmd = app.add_subcommand(
      "validate",
      "Show, per gateway and generic slave of a daemon configuration, the Set_Prm and Chk_Cfg "
      "bytes the master sends, the slot or module table, the diagnosis the emulated device "
      "answers and warnings; exit 0 valid, 1 invalid, 2 unusable input");
  cmd->add_option("CONFIG", args->config, "daemon configuration (docs/configuration.md)")
      ->required();
  cmd->add_option("--gsd", args->gsd,
                  "encode the named parameters through this GSD's ExtUserPrmData "
                  "(docs/validate.md has the name mapping)");
  cmd->add_flag("--json", args->json, "print one JSON document instead of the text report");
  cmd->add_flag("--strict", args->strict, "exit 1 when there are warnings");
  cmd->callback([args, &exit_code] { exit_code = run_validate(*args); });
}

}  // namespace candp2::cli
