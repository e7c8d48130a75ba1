#include "config/slaves_config.hpp"

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "common/hex.hpp"
#include "config/config.hpp"
#include "config/json_reader.hpp"
#include "config/parse_helpers.hpp"
#include "gsd_slave/configuration.hpp"
#include "gsd_slave/user_prm.hpp"

namespace candp2::config {

using json = nlohmann::json;
using namespace json_reader;
using detail::valid_name;

namespace {

std::shared_ptr<const gsd::Model> load_gsd(const std::string& path, const std::string& json_path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    fail(json_path, "expected a GSD file, but " + path + " does not exist or is not a file");
  gsd::ParseResult r = gsd::parse_file(path);
  if (r.not_gsd || !r.ok()) {
    std::string first;
    for (const auto& d : r.diagnostics)
      if (d.severity == gsd::Severity::Error) {
        first = gsd::format(d, path);
        break;
      }
    fail(json_path, "the GSD file has errors (see `candp2 gsd " + path + "`): " + first);
  }
  return std::make_shared<const gsd::Model>(std::move(r.model));
}

std::string trimmed(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return gsd::to_utf8(s);
}

std::string module_list(const gsd::Model& m) {
  std::vector<std::string> names;
  for (const auto& mod : m.modules) {
    if (names.size() == 8) {
      names.push_back("… (" + std::to_string(m.modules.size()) +
                      " modules, `candp2 gsd` lists them)");
      break;
    }
    names.push_back(json(trimmed(mod.name)).dump());
  }
  return names.empty() ? "none" : join(names);
}

// The GSD's preset modules where a configuration tool puts them (docs/slaves.md "Preset
// modules", gsd_slave::with_presets).
void add_presets(const Object& o, SlaveConfig& s) {
  const gsd::Model& m = *s.model;
  std::vector<std::size_t> user;
  for (const auto& mod : s.modules) user.push_back(mod.index);
  const gsd_slave::WithPresets w = gsd_slave::with_presets(m, user);
  if (w.problem)
    fail(w.problem->position < user.size() ? s.modules[w.problem->position].json_path
                                           : o.path("modules"),
         s.gsd + ": " + w.problem->text);
  std::vector<SlaveModuleConfig> mods;
  for (std::size_t i = 0; i < w.added; ++i) {
    const gsd::Module& mod = m.modules[w.modules[i]];
    mods.push_back({trimmed(mod.name), w.modules[i], o.path("modules"), true});
    s.notes.push_back(
        {o.path("modules"),
         "preset module \"" + trimmed(mod.name) + "\" of " + s.gsd + " added at slot " +
             std::to_string(i) + ", as configuration tools do (Preset = 1" +
             (m.fix_preset_modules() ? ", FixPresetModules = 1: it cannot be left out"
                                     : "; name the preset modules in \"modules\" to place them") +
             ", docs/slaves.md \"Preset modules\")"});
  }
  mods.insert(mods.end(), s.modules.begin(), s.modules.end());
  s.modules = std::move(mods);
}

void parse_modules(const Object& o, SlaveConfig& s) {
  const gsd::Model& m = *s.model;
  if (const json* raw = o.find("cfg_hex")) {
    if (o.has("modules"))
      fail(o.path("cfg_hex"), "give either \"modules\" (by GSD name) or \"cfg_hex\", not both");
    auto bytes = as_hex(*raw, o.path("cfg_hex"), "10 10 91 20 20 20 20");
    const auto decoded = gsd::decode_config(bytes);
    if (decoded.error)
      fail(o.path("cfg_hex"), "expected whole Chk_Cfg identifier entries: " + *decoded.error);
    s.cfg_hex = std::move(bytes);
    return;
  }
  const json* mods = o.find("modules");
  if (!mods) {
    // A compact station with one module: that module is its configuration.
    if (!s.profile.modular && m.modules.size() == 1) {
      s.modules.push_back({trimmed(m.modules[0].name), 0, o.path("modules")});
      return;  // its only module: a preset one stands where it is
    }
    fail(o.path(), "missing key \"modules\" (the slave's modules by their GSD names; its GSD has " +
                       module_list(m) + ") or \"cfg_hex\"");
  }
  if (!mods->is_array())
    fail(o.path("modules"),
         "expected an array of module names as in the GSD, got " + kind_of(*mods));
  for (std::size_t i = 0; i < mods->size(); ++i) {
    const std::string path = element(o.path("modules"), i);
    const std::string name = as_string((*mods)[i], path, "a module name as in the GSD");
    const gsd::Module* mod = m.module(name);
    if (!mod)
      fail(path,
           "no module \"" + name + "\" in " + s.gsd + " (its modules: " + module_list(m) + ")");
    s.modules.push_back(
        {trimmed(mod->name), static_cast<std::size_t>(mod - m.modules.data()), path});
  }
  add_presets(o, s);
}

void parse_parameters(const Object& o, SlaveConfig& s) {
  const json* p = o.find("parameters");
  if (!p) return;
  const std::string path = o.path("parameters");
  if (!p->is_object())
    fail(path, "expected an object of ExtUserPrmData names and values, e.g. {\"Class\": 20}, got " +
                   kind_of(*p));
  std::vector<const gsd::Module*> mods;
  for (const auto& m : s.modules) mods.push_back(&s.model->modules[m.index]);
  for (const auto& [name, value] : p->items()) {
    if (!name.empty() && name[0] == '_') continue;
    const std::string at = member(path, name);
    gsd::PrmOverride ov;
    ov.name = name;
    if (value.is_string())
      ov.value = value.get<std::string>();
    else if (value.is_number_integer())
      ov.value = value.get<std::int64_t>();
    else
      fail(at, "expected a number or a text of the parameter's PrmText, got " + kind_of(value));
    const auto one = gsd_slave::encode_user_prm(*s.model, mods, std::span(&ov, 1));
    if (!one.errors.empty()) fail(at, one.errors.front());
    s.parameters.push_back(std::move(ov));
  }
}

// The dry run: what the slave answers to what the master sends (a warning, not an error: a faulty
// slave may be configured on purpose).
void dry_run(SlaveConfig& s) {
  std::string error;
  auto slave = gsd_slave::GsdSlave::create(s.setup(), &error);
  if (!slave) {
    s.warnings.push_back(
        {s.json_path, "cannot emulate this slave: " + error, WarningKind::Rejected});
    return;
  }
  constexpr std::uint8_t kProbeMaster = 1;
  const Time t0{0};
  const std::string prm_path = s.prm_hex ? s.json_path + ".prm_hex" : s.json_path + ".parameters";
  if (!slave->dp().set_prm(kProbeMaster, set_prm_bytes(s), t0)) {
    const auto d = slave->dp().diagnosis(t0);
    s.warnings.push_back(
        {prm_path,
         "the slave will reject this Set_Prm: " +
             (d[0] & dp::kDiag1NotSupported  ? std::string("Not_Supported (Sync_Req or "
                                                            "Freeze_Req)")
              : slave->prm_problem().empty() ? std::string("Prm_Fault")
                                             : slave->prm_problem()),
         WarningKind::Rejected});
    return;
  }
  if (!slave->dp().chk_cfg(kProbeMaster, chk_cfg_bytes(s), t0))
    s.warnings.push_back({s.cfg_hex ? s.json_path + ".cfg_hex" : s.json_path + ".modules",
                          "the slave will reject this configuration: " + slave->cfg_problem(),
                          WarningKind::Rejected});
}

}  // namespace

gsd_slave::SlaveSetup SlaveConfig::setup(LogSink* log) const {
  gsd_slave::SlaveSetup s;
  s.address = address;
  s.gsd = model;
  for (const auto& m : modules) s.modules.push_back(m.index);
  s.cfg = cfg_hex;
  s.safe_state = safe_state;
  s.name = name;
  s.log = log;
  return s;
}

SlaveConfig parse_slave(const json& j, const std::string& file, const std::string& path) {
  const Object o(j, path,
                 {"name", "address", "gsd", "modules", "cfg_hex", "field_unit", "parameters",
                  "prm_hex", "watchdog_ms", "input_address", "output_address", "safe_state"});
  SlaveConfig s;
  s.json_path = path;
  // IEC 61158: DP slave addresses 0..125 (126 is the default address of a new slave).
  s.address = static_cast<std::uint8_t>(
      as_uint(o.at("address"), o.path("address"), 0, 125, "(DP address)"));
  s.name = find_string(o, "name", "a slave name").value_or("slave" + std::to_string(s.address));
  if (!valid_name(s.name, 32))  // as for gateways and drives
    fail(o.path("name"),
         "expected a name of letters, digits, '_', '-', '.' (at most 32), got \"" + s.name + "\"");
  s.gsd = relative_to(file, get_string(o, "gsd", "the GSD file of the slave"));
  s.model = load_gsd(s.gsd, o.path("gsd"));
  auto profile = gsd_slave::read_profile(*s.model);
  if (auto* e = std::get_if<std::string>(&profile)) fail(o.path("gsd"), s.gsd + ": " + *e);
  s.profile = std::get<gsd_slave::Profile>(std::move(profile));
  parse_modules(o, s);
  if (o.has("field_unit"))
    s.field_unit = get_uint<std::uint8_t>(o, "field_unit", 1, 1, 247, "(Modbus unit ID)");
  if (const json* h = o.find("prm_hex")) {
    for (const char* k : {"parameters", "watchdog_ms"})
      if (o.has(k))
        fail(o.path(k),
             "prm_hex gives the whole Set_Prm telegram; leave out parameters and "
             "watchdog_ms");
    s.prm_hex = as_hex(*h, o.path("prm_hex"), "88 0A 01 00 80 31 00 ...");
  }
  parse_parameters(o, s);
  // 10 ms × WD_Fact_1 × WD_Fact_2 with both factors 1..255.
  s.watchdog_ms = get_uint<std::uint16_t>(o, "watchdog_ms", 0, 0, 65000, "ms");
  const gsd_slave::Configuration c = s.cfg_hex ? gsd_slave::configuration_of(*s.cfg_hex) : [&] {
    std::vector<const gsd::Module*> mods;
    for (const auto& m : s.modules) mods.push_back(&s.model->modules[m.index]);
    return gsd_slave::configuration_of(std::move(mods));
  }();
  auto address = [&](const char* key, std::size_t length) -> std::optional<std::uint16_t> {
    if (!o.has(key)) return std::nullopt;
    const auto a = get_uint<std::uint16_t>(o, key, 0, 0, dp::kImageSize - 1, "(PLC byte address)");
    if (a + length > dp::kImageSize)
      fail(o.path(key), "the slave's " + std::to_string(length) + " bytes from " +
                            std::to_string(a) + " lie outside the " +
                            std::to_string(dp::kImageSize) + "-byte PLC image");
    return a;
  };
  s.input_address = address("input_address", c.decoded.input_len);
  s.output_address = address("output_address", c.decoded.output_len);
  if (const json* st = o.find("safe_state")) {
    const std::string v = st->is_string() ? st->get<std::string>() : "";
    if (v != "zero" && v != "hold")
      fail(o.path("safe_state"), "expected \"zero\" or \"hold\", got " + kind_of(*st));
    s.safe_state = v == "hold" ? gsd_slave::SafeState::Hold : gsd_slave::SafeState::Zero;
  }
  dry_run(s);
  return s;
}

void parse_slaves(const json* slaves, const std::string& file, DaemonConfig& c) {
  if (!slaves) return;
  const std::string top = "$.slaves";
  if (!slaves->is_array()) fail(top, "expected an array of slaves, got " + kind_of(*slaves));
  for (std::size_t i = 0; i < slaves->size(); ++i) {
    const std::string path = element(top, i);
    SlaveConfig s = parse_slave((*slaves)[i], file, path);
    auto taken = [&](std::uint8_t a) -> std::string {
      if (const GatewayConfig* g = c.gateway_by_dp_address(a)) return g->json_path;
      for (const auto& o : c.slaves)
        if (o.address == a) return o.json_path;
      if (a == c.master_address) return "$.master.address";
      if (c.profibus && c.profibus->master_address == a) return "$.profibus.master_address";
      return "";
    };
    if (const auto by = taken(s.address); !by.empty())
      fail(path + ".address",
           "DP address " + std::to_string(s.address) + " is already used by " + by);
    for (const auto& g : c.gateways)
      if (g.name == s.name)
        fail(path + ".name", "the name \"" + s.name + "\" is already used by " + g.json_path);
    for (const auto& o : c.slaves)
      if (o.name == s.name)
        fail(path + ".name", "the name \"" + s.name + "\" is already used by " + o.json_path);
    if (s.field_unit) {
      // Modbus unit IDs: a gateway's or slave's DP address is its PLC image unit (docs/modbus.md).
      std::string by = taken(*s.field_unit);
      if (by == "$.master.address" || by == "$.profibus.master_address") by.clear();
      if (*s.field_unit == s.address) by = path + ".address";
      for (const auto& o : c.slaves)
        if (o.field_unit == s.field_unit) by = o.json_path + ".field_unit";
      for (const auto& d : c.drives)
        if (d.modbus_unit == s.field_unit) by = d.json_path + ".modbus_unit";
      if (!by.empty())
        fail(path + ".field_unit",
             "Modbus unit ID " + std::to_string(*s.field_unit) + " is already used by " + by);
    }
    for (const auto& d : c.drives)
      if (d.modbus_unit == s.address)
        fail(path + ".address", "DP address " + std::to_string(s.address) +
                                    " is the Modbus unit ID of " + d.json_path +
                                    " (a slave's DP address is its Modbus unit)");
    for (const auto& w : s.warnings) c.warnings.push_back({file, w.json_path, w.message, w.kind});
    c.slaves.push_back(std::move(s));
  }
}

std::vector<std::uint8_t> set_prm_bytes(const SlaveConfig& s) {
  if (s.prm_hex) return *s.prm_hex;
  std::vector<const gsd::Module*> mods;
  for (const auto& m : s.modules) mods.push_back(&s.model->modules[m.index]);
  // Parsing checked every override, so the encoding has no errors here.
  const auto user = gsd_slave::encode_user_prm(*s.model, mods, s.parameters);
  return gsd_slave::encode_set_prm(s.profile.ident_number, {.watchdog_ms = s.watchdog_ms},
                                   user.bytes);
}

std::vector<std::uint8_t> chk_cfg_bytes(const SlaveConfig& s) {
  if (s.cfg_hex) return *s.cfg_hex;
  std::vector<std::uint8_t> out;
  for (const auto& m : s.modules) {
    const auto& bytes = s.model->modules[m.index].config;
    out.insert(out.end(), bytes.begin(), bytes.end());
  }
  return out;
}

dp::SlaveParameters slave_parameters(const SlaveConfig& s) {
  dp::SlaveParameters p;
  p.prm = set_prm_bytes(s);
  p.cfg = chk_cfg_bytes(s);
  p.name = s.name;
  std::optional<std::uint16_t> in = s.input_address, out = s.output_address;
  for (const auto& e : dp::decode_chk_cfg(p.cfg).entries) {
    dp::EntryAddress a;
    if (e.in_bytes() && in) {
      a.input = in;
      in = static_cast<std::uint16_t>(*in + e.in_bytes());
    }
    if (e.out_bytes() && out) {
      a.output = out;
      out = static_cast<std::uint16_t>(*out + e.out_bytes());
    }
    p.addresses.push_back(a);
  }
  return p;
}

}  // namespace candp2::config
