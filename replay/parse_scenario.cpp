// A replay scenario's top level (docs/replay-format.md): format and version, the installation
// (version 1: "gateway", "drives", "cycle_ms", "master_address"; version 2 may name "config"),
// the Page-Mode driver, the steps.
#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/hex.hpp"
#include "config/json_reader.hpp"
#include "gateway/comm_window.hpp"
#include "replay/parse_internal.hpp"

namespace candp2::replay {

using nlohmann::json;
using namespace config::json_reader;
using parse::as_ms;

namespace {

gw::page::IdEntry as_ident(const json& j, const std::string& path) {
  const Object o(j, path, {"id", "extended", "form", "length", "force", "data"});
  gw::page::IdEntry e;
  const bool ext = o.has("extended") && as_bool(o.at("extended"), o.path("extended"));
  e.id.extended = ext;
  e.id.id = static_cast<std::uint32_t>(as_uint(
      o.at("id"), o.path("id"), 0, ext ? can::kMaxExtId : can::kMaxStdId,
      ext ? "(29-bit identifier)" : "(11-bit identifier; set \"extended\": true for 29-bit)"));
  e.form =
      o.has("form") ? static_cast<std::uint8_t>(as_uint(o.at("form"), o.path("form"), 0, 255)) : 0;
  e.length = static_cast<std::uint8_t>(as_uint(o.at("length"), o.path("length"), 1, 8, "bytes"));
  return e;
}

plc::DbChain as_chain(const json& j, const std::string& path) {
  if (!j.is_array() || j.empty())
    fail(path, "expected an array of data blocks in hex (one string per DB), got " + kind_of(j));
  plc::DbChain chain;
  for (std::size_t i = 0; i < j.size(); ++i)
    chain.push_back(as_hex(j[i], element(path, i), "00 00 02 01 B8 06 EE EE EE EE"));
  return chain;
}

// The PLC addresses of the Page-Mode segments of the gateway entry (first output / input slot
// without a Communication Window comment).
struct Segments {
  std::optional<std::uint16_t> out_address, in_address;
  std::size_t out_len = 0;
};
Segments segments_of(const config::GatewayConfig& g) {
  Segments s;
  for (const auto& slot : g.slots) {
    const bool cw = slot.comment.size() >= 2 && slot.comment[0] == gw::kCommWindowIdHigh &&
                    slot.comment[1] == gw::kCommWindowIdLow;
    if (cw || !slot.comment.empty()) continue;
    if (slot.io == config::SlotIo::Output) {
      if (!s.out_address) s.out_address = slot.address;
      s.out_len += slot.length;
    } else if (!s.in_address) {
      s.in_address = slot.address;
    }
  }
  return s;
}

DriverSpec parse_driver(const json& j, const std::string& path, const config::GatewayConfig& g) {
  const Object o(j, path,
                 {"gateway", "write_address", "read_address", "output_page_len", "freigabe",
                  "init_delay_ms", "ack_timeout_ms", "retry_delay_ms", "tx", "rx", "ids_per_db",
                  "write_config_db", "read_config_db", "write_db", "read_db"});
  DriverSpec d;
  const Segments seg = segments_of(g);
  auto address = [&](const char* key, std::optional<std::uint16_t> def) -> std::uint16_t {
    if (o.has(key))
      return static_cast<std::uint16_t>(
          as_uint(o.at(key), o.path(key), 0, dp::kImageSize - 1, "(PLC byte address)"));
    if (!def)
      fail(path, std::string("missing key \"") + key +
                     "\" (the gateway entry has no Page-Mode segment to take it from)");
    return *def;
  };
  d.options.write_address = address("write_address", seg.out_address);
  d.options.read_address = address("read_address", seg.in_address);
  d.options.output_page_len =
      o.has("output_page_len")
          ? as_uint(o.at("output_page_len"), o.path("output_page_len"), 8, 244, "bytes")
          : seg.out_len;
  if (d.options.output_page_len < gw::page::kHeaderLen)
    fail(path, "the output page needs at least 8 bytes (set \"output_page_len\")");
  if (o.has("freigabe")) d.freigabe = as_bool(o.at("freigabe"), o.path("freigabe"));
  if (o.has("init_delay_ms"))
    d.options.init_delay = as_ms(o.at("init_delay_ms"), o.path("init_delay_ms"));
  if (o.has("ack_timeout_ms"))
    d.options.ack_timeout = as_ms(o.at("ack_timeout_ms"), o.path("ack_timeout_ms"));
  if (o.has("retry_delay_ms"))
    d.options.retry_delay = as_ms(o.at("retry_delay_ms"), o.path("retry_delay_ms"));
  if (o.has("ids_per_db"))
    d.ids_per_db = as_uint(o.at("ids_per_db"), o.path("ids_per_db"), 1, 10000, "identifiers");
  for (const char* key : {"tx", "rx"}) {
    const json* list = o.find(key);
    if (!list) continue;
    if (!list->is_array())
      fail(o.path(key), "expected an array of identifiers, got " + kind_of(*list));
    const bool tx = std::string(key) == "tx";
    for (std::size_t i = 0; i < list->size(); ++i) {
      const std::string p = element(o.path(key), i);
      const auto e = as_ident((*list)[i], p);
      (tx ? d.tx : d.rx).push_back(e);
      const json& item = (*list)[i];
      if (!tx) {
        for (const char* k : {"force", "data"})
          if (item.contains(k)) fail(member(p, k), "only Tx identifiers carry force and data");
        continue;
      }
      d.tx_force.push_back(
          item.contains("force")
              ? static_cast<std::uint8_t>(as_uint(item.at("force"), member(p, "force"), 0, 255))
              : 0);
      std::vector<std::uint8_t> data(e.length, 0);
      if (item.contains("data")) {
        data = as_hex(item.at("data"), member(p, "data"), "00 11 22 33 44 55");
        if (data.size() != e.length)
          fail(member(p, "data"), "expected " + std::to_string(e.length) +
                                      " bytes (\"length\"), got " + std::to_string(data.size()));
      }
      d.tx_data.push_back(std::move(data));
    }
  }
  if (const json* c = o.find("write_config_db"))
    d.write_config_db = as_chain(*c, o.path("write_config_db"));
  if (const json* c = o.find("read_config_db"))
    d.read_config_db = as_chain(*c, o.path("read_config_db"));
  if (const json* c = o.find("write_db")) d.write_db = as_chain(*c, o.path("write_db"));
  if (const json* c = o.find("read_db")) d.read_db = as_chain(*c, o.path("read_db"));
  return d;
}

// "page_driver": the Page-Mode driver of one gateway ("gateway": NAME with several).
void driver(const json& j, const std::string& path, Scenario& sc) {
  const auto& gateways = sc.installation.gateways;
  if (gateways.empty())  // a line of generic slaves alone
    fail(path, "the Page-Mode driver drives a gateway, and " + sc.config_file + " configures none");
  if (j.is_object() && j.contains("gateway")) {
    const std::string p = member(path, "gateway");
    const std::string name = as_string(j.at("gateway"), p, "a gateway name");
    const auto it = std::find_if(gateways.begin(), gateways.end(),
                                 [&](const config::GatewayConfig& g) { return g.name == name; });
    if (it == gateways.end()) fail(p, "no gateway \"" + name + "\" in the installation");
    sc.driver_gateway = static_cast<std::size_t>(it - gateways.begin());
  } else if (gateways.size() > 1) {
    fail(path, "with several gateways, give the driver's \"gateway\"");
  }
  sc.driver = parse_driver(j, path, gateways[sc.driver_gateway]);
}

// "drives": entries as in the daemon's "drives" array, on the scenario's one bus (the gateway's).
void parse_drives(const json& j, const std::string& path, const std::string& gateway_bus,
                  Scenario& sc) {
  if (!j.is_array()) fail(path, "expected an array of drives, got " + kind_of(j));
  auto& drives = sc.installation.drives;
  for (std::size_t i = 0; i < j.size(); ++i) {
    const std::string p = element(path, i);
    auto r = config::parse_drive_entry(j[i], sc.file, p);
    if (auto* e = std::get_if<config::ConfigError>(&r)) throw Failure{e->json_path, e->message};
    auto d = std::move(std::get<config::DriveConfig>(r));
    if (d.bus != gateway_bus)
      fail(member(p, "bus"),
           "a scenario has one bus, the gateway's \"" + gateway_bus + "\"; got \"" + d.bus + "\"");
    if (d.state_file)
      fail(member(p, "state_file"),
           "a replay keeps no state file (every run starts from the drive's defaults)");
    for (const auto& other : drives)
      if (other.name == d.name)
        fail(member(p, "name"),
             "the name \"" + d.name + "\" is already used by " + other.json_path);
    drives.push_back(std::move(d));
  }
}

// Version 1 (and version 2 without "config"): one gateway on one virtual bus, named after the
// gateway's bus ("can0" when it names none), with the scenario's drives.
void inline_installation(const Object& o, Scenario& sc) {
  auto& c = sc.installation;
  c.file = sc.file;
  c.master_address = sc.master_address;
  c.cycle_ms = static_cast<std::uint32_t>(sc.cycle.count() / 1000);
  auto g = config::parse_gateway(o.at("gateway"), sc.file, o.path("gateway"));
  if (auto* e = std::get_if<config::ConfigError>(&g)) throw Failure{e->json_path, e->message};
  auto gateway = std::move(std::get<config::GatewayConfig>(g));
  sc.warnings = gateway.warnings;
  const std::string named_bus = gateway.bus;
  config::BusConfig bus;
  bus.name = named_bus.empty() ? "can0" : named_bus;
  bus.channel = bus.name;
  bus.json_path = o.path("gateway") + ".bus";
  gateway.bus = bus.name;
  c.buses.push_back(bus);
  c.gateways.push_back(std::move(gateway));
  if (const json* d = o.find("drives")) parse_drives(*d, o.path("drives"), named_bus, sc);
  for (auto& d : c.drives) d.bus = bus.name;
}

// Version 2 "config": a candp2d configuration (relative paths: to the scenario file). Replay opens
// none of its sockets or serial lines: every bus becomes an in-process virtual bus under its own
// name and interface, the built-in master drives the gateways in-process (the `profibus` section
// is not used), no state file is read or written.
void config_installation(const Object& o, Scenario& sc) {
  const std::string given = as_string(o.at("config"), o.path("config"), "a configuration file");
  std::filesystem::path p(given);
  if (p.is_relative()) p = std::filesystem::path(sc.file).parent_path() / p;
  sc.config_file = p.lexically_normal().string();
  auto r = config::load_daemon(sc.config_file);
  if (auto* e = std::get_if<config::ConfigError>(&r))
    fail(o.path("config"), "the configuration does not load: " + e->to_string());
  sc.installation = std::move(std::get<config::DaemonConfig>(r));
  auto& c = sc.installation;
  for (auto& b : c.buses) {
    if (b.type == config::BusType::SocketCan) b.channel = b.interface;
    b.type = config::BusType::Virtual;
    b.socketcand_listen.reset();
  }
  c.state_file.reset();
  c.can_log.reset();
  for (auto& d : c.drives) d.state_file.reset();
  sc.cycle = milliseconds(c.cycle_ms);
  sc.master_address = c.master_address;
  sc.warnings = c.warnings;
}

Scenario parse_or_throw(const std::string& text, const std::string& file) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    fail("", std::string("not valid JSON: ") + e.what());
  }
  if (!j.is_object()) fail("$", "expected a scenario object, got " + kind_of(j));
  const bool with_config = j.contains("config");
  std::vector<std::string> keys = {"format",      "version",     "name",
                                   "description", "page_driver", "steps"};
  if (with_config)
    keys.push_back("config");
  else
    keys.insert(keys.end(), {"cycle_ms", "master_address", "gateway", "drives"});
  for (const char* k : {"cycle_ms", "master_address", "gateway", "drives"})
    if (with_config && j.contains(k))
      fail(member("$", k),
           std::string("\"") + k + "\" comes from the configuration when \"config\" is given");
  const Object o(j, "$", keys);
  Scenario sc;
  sc.file = file;
  const std::string format = as_string(o.at("format"), o.path("format"), "\"candp2-replay\"");
  if (format != kFormat)
    fail(o.path("format"), "expected \"candp2-replay\", got \"" + format + "\"");
  const auto version = as_uint(o.at("version"), o.path("version"), 1, 1000);
  if (version > static_cast<std::uint64_t>(kVersion))
    fail(o.path("version"), "this candp2 reads versions 1 and 2, got " + std::to_string(version));
  if (with_config && version < 2) fail(o.path("config"), "\"config\" needs \"version\": 2");
  sc.version = static_cast<int>(version);
  sc.name =
      o.has("name") ? as_string(o.at("name"), o.path("name"), "a name", Empty::Allowed) : file;
  if (o.has("description"))
    sc.description =
        as_string(o.at("description"), o.path("description"), "a text", Empty::Allowed);
  if (o.has("cycle_ms"))
    sc.cycle = milliseconds(as_uint(o.at("cycle_ms"), o.path("cycle_ms"), 1, 60000, "ms"));
  if (o.has("master_address"))
    sc.master_address = static_cast<std::uint8_t>(
        as_uint(o.at("master_address"), o.path("master_address"), 0, 126, "(DP address)"));
  if (with_config)
    config_installation(o, sc);
  else
    inline_installation(o, sc);
  if (const json* d = o.find("page_driver")) driver(*d, o.path("page_driver"), sc);
  const json& steps = o.at("steps");
  if (!steps.is_array()) fail(o.path("steps"), "expected an array of steps, got " + kind_of(steps));
  for (std::size_t i = 0; i < steps.size(); ++i)
    sc.steps.push_back(parse::parse_step(steps[i], element(o.path("steps"), i), sc));
  return sc;
}

}  // namespace

config::Result<Scenario> parse_scenario(const std::string& text, const std::string& file) {
  try {
    return parse_or_throw(text, file);
  } catch (const Failure& f) {
    return config::ConfigError{file, f.path, f.message};
  }
}

config::Result<Scenario> load_scenario(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return config::ConfigError{path, "",
                               "cannot open the file: " + std::string(std::strerror(errno))};
  std::ostringstream text;
  text << in.rdbuf();
  return parse_scenario(text.str(), path);
}

}  // namespace candp2::replay
