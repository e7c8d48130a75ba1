#include "config/config.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "can/channel.hpp"
#include "common/hex.hpp"
#include "config/json_reader.hpp"
#include "config/parse_helpers.hpp"
#include "config/watchdog_check.hpp"
#include "gateway/gateway.hpp"
#include "gateway/slot_config.hpp"
#include "serial/serial_port.hpp"

namespace candp2::config {

using json = nlohmann::json;

std::string_view to_string(BusType t) {
  switch (t) {
    case BusType::Virtual:
      return "virtual";
    case BusType::SocketCan:
      return "socketcan";
    case BusType::Socketcand:
      return "socketcand";
  }
  return "?";
}

std::string_view to_string(ProfibusRole r) {
  return r == ProfibusRole::Master ? "master" : "slaves";
}

std::uint8_t GatewayConfig::dp_address() const {
  // manual §2.1: below 3 counts as 3, above 124 as 124.
  return std::clamp<std::uint8_t>(address, 3, 124);
}

const BusConfig* DaemonConfig::bus(const std::string& name) const {
  for (const auto& b : buses)
    if (b.name == name) return &b;
  return nullptr;
}

const GatewayConfig* DaemonConfig::gateway_by_dp_address(std::uint8_t dp_address) const {
  for (const auto& g : gateways)
    if (g.dp_address() == dp_address) return &g;
  return nullptr;
}

std::optional<std::vector<std::uint8_t>> parse_hex(std::string_view text, std::string* error) {
  auto read = parse_hex_bytes(text, HexForm::Runs, error);
  if (!read) return std::nullopt;
  return std::move(read->bytes);
}

std::optional<Endpoint> parse_endpoint(std::string_view text, std::string* error) {
  auto fail = [&](std::string m) -> std::optional<Endpoint> {
    if (error) *error = std::move(m);
    return std::nullopt;
  };
  const auto colon = text.rfind(':');
  if (colon == std::string_view::npos || colon == 0)
    return fail("expected \"HOST:PORT\" such as \"127.0.0.1:1502\", got \"" + std::string(text) +
                "\"");
  Endpoint e;
  e.host = std::string(text.substr(0, colon));
  in_addr addr{};
  if (::inet_pton(AF_INET, e.host.c_str(), &addr) != 1)
    return fail("\"" + e.host + "\" is not a numeric IPv4 address (such as 127.0.0.1 or 0.0.0.0)");
  const auto port_text = text.substr(colon + 1);
  unsigned port = 0;
  const auto [p, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (port_text.empty() || ec != std::errc{} || p != port_text.data() + port_text.size() ||
      port > 65535)
    return fail("port \"" + std::string(port_text) + "\" is not a number from 0 to 65535");
  e.port = static_cast<std::uint16_t>(port);
  return e;
}

namespace {

using namespace detail;

BusConfig parse_bus(const json& j, const std::string& path, const std::string& name) {
  BusConfig b;
  b.name = name;
  b.json_path = path;
  if (!j.is_object()) fail(path, "expected an object with \"type\", got " + kind_of(j));
  const json* type = j.contains("type") ? &j.at("type") : nullptr;
  if (!type) fail(path, "missing key \"type\" (\"virtual\", \"socketcan\" or \"socketcand\")");
  const std::string t = type->is_string() ? type->get<std::string>() : "";
  if (t == "virtual") {
    const Object o(j, path,
                   {"type", "socketcand", "channel", "socketcand_max_clients",
                    "socketcand_idle_timeout_s", "bitrate"});
    b.type = BusType::Virtual;
    if (const json* r = o.find("bitrate"))
      b.timed_bitrate = gw::kBitrates[parse_bitrate(*r, o.path("bitrate"))];
    if (const json* l = o.find("socketcand"))
      b.socketcand_listen = get_endpoint(*l, o.path("socketcand"));
    b.socketcand_max_clients = get_uint<std::uint32_t>(o, "socketcand_max_clients", 32, 1, 10000);
    b.socketcand_idle_timeout_s =
        get_uint<std::uint32_t>(o, "socketcand_idle_timeout_s", 60, 0, 86400, "s");
    b.channel = find_string(o, "channel", "a socketcand bus name").value_or(name);
    if (!valid_name(b.channel, 16))  // socketcand.h MAX_BUSNAME
      fail(o.has("channel") ? o.path("channel") : path,
           "the socketcand bus name \"" + b.channel +
               "\" must be 1..16 letters, digits, '_', '-', '.' (set \"channel\")");
  } else if (t == "socketcan") {
    const Object o(j, path, {"type", "interface", "bitrate", "restart_ms"});
    b.type = BusType::SocketCan;
    b.interface = get_string(o, "interface", "a CAN network interface such as \"can0\"");
    if (b.interface.size() > 15)  // IFNAMSIZ - 1
      fail(o.path("interface"), "expected an interface name of at most 15 characters");
    b.bitrate =
        get_enum<BitrateMode>(o, "bitrate", BitrateMode::Check,
                              {{"check", BitrateMode::Check}, {"apply", BitrateMode::Apply}});
    if (o.has("restart_ms")) {
      if (b.bitrate != BitrateMode::Apply)
        fail(o.path("restart_ms"),
             "restart_ms is applied together with the bit rate: set \"bitrate\": \"apply\"");
      // Kernel: IFLA_CAN_RESTART_MS, 0 = no automatic restart after bus-off.
      b.restart_ms = get_uint<std::uint32_t>(o, "restart_ms", 0, 0, 60000, "ms");
    }
  } else if (t == "socketcand") {
    const Object o(j, path, {"type", "host", "port", "channel"});
    b.type = BusType::Socketcand;
    b.remote.host = get_string(o, "host", "the socketcand server's host");
    b.remote.port = get_uint<std::uint16_t>(o, "port", 29536, 1, 65535);
    b.channel = get_string(o, "channel", "the bus to open on the server (such as \"can0\")");
  } else {
    fail(member(path, "type"),
         "expected \"virtual\", \"socketcan\" or \"socketcand\", got " + kind_of(*type));
  }
  return b;
}

DriveConfig parse_drive(const json& j, const std::string& path, const std::string& file) {
  const Object o(j, path, {"type", "name", "bus", "rx_id", "tx_id", "state_file", "modbus_unit"});
  DriveConfig d;
  d.json_path = path;
  d.type = get_enum<std::string>(o, "type", "unitek", {{"unitek", "unitek"}});
  d.bus = get_string(o, "bus", "the name of a bus in \"buses\"");
  d.name = find_string(o, "name", "a drive name").value_or("drive");
  if (!valid_name(d.name, 32))
    fail(o.path("name"), "expected a name of letters, digits, '_', '-', '.' (at most 32)");
  // Unitek CAN manual "Setting CAN-BUS": RPDO1 0x201..0x27F, TPDO1 0x181..0x1FF.
  d.rx_id = get_uint<std::uint32_t>(o, "rx_id", 0x201, 0x201, 0x27F);
  d.tx_id = get_uint<std::uint32_t>(o, "tx_id", 0x181, 0x181, 0x1FF);
  if (auto s = find_string(o, "state_file", "a file name")) d.state_file = resolve(file, *s);
  if (o.has("modbus_unit")) d.modbus_unit = get_uint<std::uint8_t>(o, "modbus_unit", 1, 1, 254);
  return d;
}

// docs/profibus.md: "profibus": {"port": ..., "baud": ..., "role": "slaves" | "master", ...}.
ProfibusConfig parse_profibus(const json& j, const std::string& path, const std::string& file) {
  const Object o(j, path,
                 {"port", "baud", "role", "master_address", "slot_time_bits", "retries",
                  "min_tsdr_bits", "rs485", "echo"});
  ProfibusConfig p;
  p.json_path = path;
  p.port = get_string(o, "port", "a serial device such as \"/dev/ttyUSB0\" or \"pty:PATH\"");
  std::string link;
  namespace fs = std::filesystem;
  std::error_code ec;
  if (serial::parse_pty_port(p.port, &link)) {
    if (link.empty())
      fail(o.path("port"),
           "expected \"pty:PATH\" with a path for the link, such as "
           "\"pty:/tmp/profibus\"");
    link = resolve(file, link);
    const fs::path dir = fs::path(link).parent_path();
    if (!dir.empty() && !fs::is_directory(dir, ec))
      fail(o.path("port"), "the directory " + dir.string() + " of the pty link does not exist");
    p.port = "pty:" + link;
  } else if (!fs::exists(p.port, ec)) {
    fail(o.path("port"), "unknown device \"" + p.port +
                             "\": it does not exist (a serial device such as /dev/ttyUSB0, "
                             "or \"pty:PATH\" for a pseudo-terminal)");
  }
  const std::uint64_t baud = as_uint(o.at("baud"), o.path("baud"), 0, 100000000, "baud");
  if (!phy::is_line_rate(static_cast<std::uint32_t>(baud)))
    fail(o.path("baud"), "baud " + std::to_string(baud) +
                             " is not supported; expected one of the PROFIBUS rates " +
                             phy::line_rates_text());
  p.baud = static_cast<std::uint32_t>(baud);
  if (!o.has("role")) fail(path, "missing key \"role\" (\"slaves\" or \"master\")");
  p.role =
      get_enum<ProfibusRole>(o, "role", ProfibusRole::Slaves,
                             {{"slaves", ProfibusRole::Slaves}, {"master", ProfibusRole::Master}});
  if (o.has("master_address")) {
    if (p.role == ProfibusRole::Master)
      fail(o.path("master_address"),
           "only for role \"slaves\" (the master whose requests are answered); the built-in "
           "master's own address is $.master.address");
    // DP master addresses 0..125 (127 is broadcast, 126 the default address of new slaves).
    p.master_address = get_uint<std::uint8_t>(o, "master_address", 1, 0, 125, "(DP address)");
  }
  // The rules are checked once $.master is read too (check_profibus_bus_parameters).
  p.bus = read_profibus_bus_parameters(o, p.baud);  // config/line_config.cpp
  p.rs485 = get_bool(o, "rs485", false);
  p.echo = get_bool(o, "echo", false);
  return p;
}

// Gateways whose Set_Prm sets the bit rate of one SocketCAN interface ("bitrate": "apply") must
// agree on it: the interface has one bit rate (manual §5.1.2, Set_Prm byte 8).
void check_shared_bitrates(const DaemonConfig& c) {
  std::map<std::string, const GatewayConfig*> first;  // interface → first gateway on it
  for (const auto& g : c.gateways) {
    const BusConfig* b = c.bus(g.bus);
    if (!b || b->type != BusType::SocketCan) continue;
    const auto [it, inserted] = first.try_emplace(b->interface, &g);
    if (inserted) continue;
    const BusConfig* ob = c.bus(it->second->bus);
    if (b->bitrate != BitrateMode::Apply && ob->bitrate != BitrateMode::Apply) continue;
    const auto rate = configured_bitrate(g), other = configured_bitrate(*it->second);
    if (rate && other && *rate != *other)
      fail(g.json_path + (g.prm_hex ? ".prm_hex" : ".parameters.can_bitrate"),
           "bit rate " + std::to_string(*rate) + " bit/s differs from " + std::to_string(*other) +
               " bit/s of " + it->second->json_path + " on the same interface " + b->interface +
               " with \"bitrate\": \"apply\" (one interface has one bit rate)");
  }
}

// "modbus", "http", "master", "log", "state_file", "capture": the daemon's own settings.
void parse_settings(const Object& top, const std::string& file, DaemonConfig& c) {
  if (const json* m = top.find("modbus")) {
    const Object o(*m, top.path("modbus"), {"listen", "max_clients", "idle_timeout_s"});
    if (const json* l = o.find("listen")) c.modbus_listen = get_endpoint(*l, o.path("listen"));
    c.modbus_max_clients = get_uint<std::uint32_t>(o, "max_clients", 64, 1, 10000);
    c.modbus_idle_timeout_s = get_uint<std::uint32_t>(o, "idle_timeout_s", 60, 0, 86400, "s");
  }
  if (const json* h = top.find("http")) {
    const Object o(*h, top.path("http"), {"listen", "max_clients", "idle_timeout_s"});
    if (const json* l = o.find("listen")) c.http_listen = get_endpoint(*l, o.path("listen"));
    c.http_max_clients = get_uint<std::uint32_t>(o, "max_clients", 64, 1, 10000);
    c.http_idle_timeout_s = get_uint<std::uint32_t>(o, "idle_timeout_s", 60, 0, 86400, "s");
  }
  if (const json* m = top.find("master")) {
    const Object o(*m, top.path("master"),
                   {"address", "cycle_ms", "retry_ms", "baud", "bus_parameters", "host_stall_ms"});
    c.master_address = get_uint<std::uint8_t>(o, "address", 1, 0, 125, "(DP master address)");
    c.cycle_ms = get_uint<std::uint32_t>(o, "cycle_ms", 10, 1, 60000, "ms");
    c.retry_ms = get_uint<std::uint32_t>(o, "retry_ms", 1000, 1, 600000, "ms");
    c.host_stall_ms = get_uint<std::uint32_t>(o, "host_stall_ms", 50, 0, 60000, "ms");
    parse_line(o, top.find("profibus"), c);  // config/line_config.cpp
  }
  if (const json* l = top.find("log")) {
    const Object o(*l, top.path("log"), {"level", "can_log"});
    c.log_level = get_enum<std::string>(o, "level", "info",
                                        {{"trace", "trace"},
                                         {"debug", "debug"},
                                         {"info", "info"},
                                         {"warn", "warn"},
                                         {"error", "error"}});
    if (auto p = find_string(o, "can_log", "a file name")) c.can_log = resolve(file, *p);
  }
  if (auto p = find_string(top, "state_file", "a file name")) c.state_file = resolve(file, *p);
  if (const json* cap = top.find("capture"))
    c.capture = parse_capture(*cap, top.path("capture"), file);
}

// "buses", and no two listeners of the configuration on one port.
void parse_buses(const Object& top, DaemonConfig& c, bool with_gateways) {
  // Role master: the gateways are remote stations; buses only serve simulated drives. Without
  // gateways (a line of generic slaves) no bus is needed either.
  const bool remote = c.remote_gateways() || !with_gateways;
  static const json kNoBuses = json::object();
  const json& buses = remote && !top.has("buses") ? kNoBuses : top.at("buses");
  if (!buses.is_object() || (buses.empty() && !remote))
    fail(top.path("buses"),
         "expected an object of buses by name, e.g. {\"can0\": {\"type\": \"virtual\"}}, got " +
             kind_of(buses));
  for (const auto& [name, value] : buses.items()) {
    if (!name.empty() && name[0] == '_') continue;
    const std::string path = member(top.path("buses"), name);
    if (!valid_name(name, 32))
      fail(path, "a bus name must be 1..32 letters, digits, '_', '-', '.'");
    c.buses.push_back(parse_bus(value, path, name));
  }
  std::set<std::pair<std::string, std::uint16_t>> listens;
  if (c.modbus_listen.port) listens.insert({c.modbus_listen.host, c.modbus_listen.port});
  if (c.http_listen && c.http_listen->port &&
      !listens.insert({c.http_listen->host, c.http_listen->port}).second)
    fail(top.path("http") + ".listen", "port " + std::to_string(c.http_listen->port) +
                                           " is already used by another listener of this "
                                           "configuration");
  for (const auto& b : c.buses)
    if (b.socketcand_listen && b.socketcand_listen->port &&
        !listens.insert({b.socketcand_listen->host, b.socketcand_listen->port}).second)
      fail(member(b.json_path, "socketcand"),
           "port " + std::to_string(b.socketcand_listen->port) +
               " is already used by another listener of this configuration");
}

// One "gateways" entry against the rest: its bus, a DP address and a name of its own.
void check_gateway(const GatewayConfig& g, const std::string& path, const DaemonConfig& c) {
  const bool remote = c.remote_gateways();
  if (remote && !g.bus.empty())
    fail(path + ".bus",
         "with $.profibus.role \"master\" the gateways are remote stations on the PROFIBUS "
         "line, emulated nowhere here: remove \"bus\"");
  if (remote) {
    // Fall through to the address checks below.
  } else if (g.bus.empty()) {
    fail(path, "missing key \"bus\"");
  } else if (!c.bus(g.bus)) {
    std::vector<std::string> names;
    for (const auto& b : c.buses) names.push_back(b.name);
    fail(path + ".bus", "unknown bus \"" + g.bus + "\" (defined in $.buses: " + join(names) + ")");
  }
  if (const auto* other = c.gateway_by_dp_address(g.dp_address()))
    fail(path + ".address", "DP address " + std::to_string(g.dp_address()) +
                                " is already used by " + other->json_path);
  if (c.profibus && c.profibus->master_address && g.dp_address() == *c.profibus->master_address)
    fail(path + ".address", "DP address " + std::to_string(g.dp_address()) +
                                " is the external master's address ($.profibus.master_address)");
  if (g.dp_address() == c.master_address)
    fail(path + ".address", "DP address " + std::to_string(g.dp_address()) +
                                " is the master's address ($.master.address)");
  for (const auto& other : c.gateways)
    if (other.name == g.name)
      fail(path + ".name", "the name \"" + g.name + "\" is already used by " + other.json_path);
}

// One "drives" entry against the rest: a virtual bus, a name and a Modbus unit of its own.
void check_drive(const DriveConfig& drive, const std::string& path, const DaemonConfig& c) {
  const BusConfig* bus = c.bus(drive.bus);
  if (!bus) fail(path + ".bus", "unknown bus \"" + drive.bus + "\"");
  if (bus->type != BusType::Virtual)
    fail(path + ".bus",
         "simulated drives run on virtual buses only (use candp2-drive on a "
         "SocketCAN or socketcand bus)");
  for (const auto& other : c.drives) {
    if (other.name == drive.name)
      fail(path + ".name", "the name \"" + drive.name + "\" is already used by " + other.json_path);
    if (drive.modbus_unit && other.modbus_unit == drive.modbus_unit)
      fail(path + ".modbus_unit", "unit ID " + std::to_string(*drive.modbus_unit) +
                                      " is already used by " + other.json_path);
  }
  if (drive.modbus_unit)
    if (const auto* g = c.gateway_by_dp_address(*drive.modbus_unit))
      fail(path + ".modbus_unit", "unit ID " + std::to_string(*drive.modbus_unit) +
                                      " is the DP address of " + g->json_path +
                                      " (the gateway's Modbus unit ID)");
}

// Warnings about the whole: watchdogs against the watchdog rule, bit rates, overlapping slots.
void collect_warnings(const std::string& file, DaemonConfig& c) {
  for (auto& g : c.gateways)
    c.warnings.insert(c.warnings.end(), g.warnings.begin(), g.warnings.end());
  // docs/validate.md "The watchdog rule": the words `candp2 validate` uses too.
  for (auto& w : check_watchdogs(c))
    c.warnings.push_back({file, w.json_path, std::move(w.message),
                          w.verdict == fdl::WatchdogVerdict::NeverHolds ? WarningKind::Unholdable
                                                                        : WarningKind::Watchdog});
  check_shared_bitrates(c);
  std::vector<GatewayConfig*> all;
  for (auto& g : c.gateways) all.push_back(&g);
  check_overlaps(file, all, c.warnings);
}

DaemonConfig parse_daemon_or_throw(const json& root, const std::string& file) {
  DaemonConfig c;
  c.file = file;
  const Object top(root, "$",
                   {"modbus", "http", "master", "buses", "gateways", "slaves", "drives", "log",
                    "state_file", "profibus", "capture"});
  if (const json* p = top.find("profibus"))
    c.profibus = parse_profibus(*p, top.path("profibus"), file);
  parse_settings(top, file, c);
  if (c.profibus) check_profibus_bus_parameters(top, c);  // config/line_config.cpp
  // docs/configuration.md: a line of generic slaves alone needs no gateway (and then no bus);
  // a configuration without either has nothing to emulate.
  static const json kNone = json::array();
  const json* g = top.find("gateways");
  const json& gateways = g ? *g : kNone;
  if (!gateways.is_array())
    fail(top.path("gateways"), "expected an array of gateways, got " + kind_of(gateways));
  const json* slaves = top.find("slaves");
  if (gateways.empty() && (!slaves || (slaves->is_array() && slaves->empty())))
    fail(top.path("gateways"),
         "expected a non-empty array of gateways, or generic DP-V0 slaves in $.slaves "
         "(docs/slaves.md); the file configures neither");
  parse_buses(top, c, !gateways.empty());
  for (std::size_t i = 0; i < gateways.size(); ++i) {
    const std::string path = element(top.path("gateways"), i);
    GatewayConfig g = parse_gateway_or_throw(gateways[i], file, path);
    check_gateway(g, path, c);
    c.gateways.push_back(std::move(g));
  }
  if (const json* d = top.find("drives")) {
    if (!d->is_array()) fail(top.path("drives"), "expected an array of drives, got " + kind_of(*d));
    for (std::size_t i = 0; i < d->size(); ++i) {
      const std::string path = element(top.path("drives"), i);
      DriveConfig drive = parse_drive((*d)[i], path, file);
      check_drive(drive, path, c);
      c.drives.push_back(std::move(drive));
    }
  }
  parse_slaves(top.find("slaves"), file, c);  // config/slaves_config.hpp
  collect_warnings(file, c);
  return c;
}

// nlohmann keeps the last of duplicate keys silently; a configuration with "address" twice is a
// mistake worth naming. Tracks the JSON path while parsing.
class DuplicateKeyFinder {
 public:
  bool operator()(int, json::parse_event_t event, json& parsed) {
    using E = json::parse_event_t;
    switch (event) {
      case E::object_start:
      case E::array_start:
        stack_.push_back({event == E::array_start, 0, {}, {}});
        break;
      case E::key: {
        auto& top = stack_.back();
        top.key = parsed.get<std::string>();
        if (!top.keys.insert(top.key).second && !duplicate_)
          duplicate_ = Failure{path(), "duplicate key (each key may appear once)"};
        break;
      }
      case E::object_end:
      case E::array_end:
        stack_.pop_back();
        next_element();
        break;
      case E::value:
        next_element();
        break;
    }
    return true;
  }
  const std::optional<Failure>& duplicate() const { return duplicate_; }

 private:
  struct Level {
    bool array;
    std::size_t index;
    std::set<std::string> keys;
    std::string key;
  };
  void next_element() {
    if (!stack_.empty() && stack_.back().array) ++stack_.back().index;
  }
  std::string path() const {
    std::string p = "$";
    for (const auto& l : stack_) p = l.array ? element(p, l.index) : member(p, l.key);
    return p;
  }
  std::vector<Level> stack_;
  std::optional<Failure> duplicate_;
};

Result<json> parse_json(const std::string& text, const std::string& file) {
  DuplicateKeyFinder finder;
  try {
    json j = json::parse(text, std::ref(finder));
    if (finder.duplicate())
      return ConfigError{file, finder.duplicate()->path, finder.duplicate()->message};
    return j;
  } catch (const json::exception& e) {
    // parse_error for syntax, out_of_range for numbers beyond 64 bits / double ("1E400").
    std::string what = e.what();
    // "[json.exception.parse_error.101] parse error at line 3, column 5: ..." → without the tag.
    if (const auto close = what.find("] "); close != std::string::npos && what[0] == '[')
      what = what.substr(close + 2);
    return ConfigError{file, "", "invalid JSON: " + what};
  }
}

}  // namespace

Result<DaemonConfig> parse_daemon(const std::string& text, const std::string& file) {
  auto j = parse_json(text, file);
  if (auto* e = std::get_if<ConfigError>(&j)) return *e;
  try {
    return parse_daemon_or_throw(std::get<json>(j), file);
  } catch (const Failure& f) {
    return ConfigError{file, f.path, f.message};
  }
}

Result<DaemonConfig> load_daemon(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return ConfigError{path, "", "cannot open the file: " + std::string(std::strerror(errno))};
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return ConfigError{path, "", "cannot read the file"};
  return parse_daemon(text.str(), path);
}

Result<DriveConfig> parse_drive_entry(const json& j, const std::string& file,
                                      const std::string& path) {
  try {
    return parse_drive(j, path, file);
  } catch (const Failure& f) {
    return ConfigError{file, f.path, f.message};
  }
}

}  // namespace candp2::config
