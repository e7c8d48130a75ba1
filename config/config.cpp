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
  auto fail = [&](std::string m) -> std::optional<std::vector<std::uint8_t>> {
    if (error) *error = std::move(m);
    return std::nullopt;
  };
  std::vector<std::uint8_t> out;
  std::size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    if (c == ' ' || c == ',' || c == '\t') {
      ++i;
      continue;
    }
    if (json_reader::hex_digit(c) < 0)
      return fail("position " + std::to_string(i) + ": '" + std::string(1, c) +
                  "' is not a hex digit");
    // A run of digits must have an even length: "8880C4" is three bytes, "888" is an error.
    std::size_t j = i;
    while (j < text.size() && json_reader::hex_digit(text[j]) >= 0) ++j;
    if ((j - i) % 2 != 0)
      return fail("position " + std::to_string(i) + ": '" + std::string(text.substr(i, j - i)) +
                  "' has an odd number of hex digits (write two digits per byte)");
    for (std::size_t k = i; k < j; k += 2)
      out.push_back(static_cast<std::uint8_t>((json_reader::hex_digit(text[k]) << 4) |
                                              json_reader::hex_digit(text[k + 1])));
    i = j;
  }
  if (out.empty()) return fail("no bytes given");
  return out;
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

// ------------------------------------------------------------------------------------ helpers

using namespace json_reader;

template <typename E>
E get_enum(const Object& o, const std::string& key, E fallback,
           const std::vector<std::pair<std::string, E>>& names) {
  const json* j = o.find(key);
  if (!j) return fallback;
  std::vector<std::string> quoted;
  for (const auto& [n, v] : names) quoted.push_back("\"" + n + "\"");
  if (j->is_string())
    for (const auto& [n, v] : names)
      if (j->get_ref<const std::string&>() == n) return v;
  fail(o.path(key), "expected one of " + join(quoted) + ", got " + kind_of(*j));
}

Endpoint get_endpoint(const json& j, const std::string& path) {
  const std::string text = as_string(j, path, "\"HOST:PORT\"");
  std::string error;
  auto e = parse_endpoint(text, &error);
  if (!e) fail(path, error);
  return *e;
}

// A name usable as a socketcand bus name and in log lines (socketcand.h MAX_BUSNAME).
bool valid_name(std::string_view s, std::size_t max) {
  return !s.empty() && s.size() <= max && std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  });
}

std::string resolve(const std::string& file, const std::string& p) {
  namespace fs = std::filesystem;
  const fs::path path(p);
  if (path.is_absolute()) return p;
  const fs::path dir = fs::path(file).parent_path();
  return dir.empty() ? p : (dir / path).lexically_normal().string();
}

// ------------------------------------------------------------------------------ parameters

std::uint8_t parse_bitrate(const json& j, const std::string& path) {
  std::vector<std::string> names;
  for (std::uint8_t i = 0; i < gw::kBitrates.size(); ++i)
    names.push_back('"' + std::string(gw::bitrate_name(i)) +
                    '"');  // chars: GCC 12 -O3 false -Wrestrict
  const std::string expected = "expected a CAN bit rate of manual table 5.1.1 in bit/s (" +
                               std::to_string(gw::kBitrates[0]) + ", …, " +
                               std::to_string(gw::kBitrates.back()) + ") or one of " + join(names);
  if (j.is_string()) {
    std::string s = j.get<std::string>();
    // Accept "125k", "125 kbit/s", "125kbit/s" as the GSD's PrmText writes them.
    std::erase(s, ' ');
    if (s.size() > 6 && s.ends_with("kbit/s")) s = s.substr(0, s.size() - 5);
    for (std::uint8_t i = 0; i < gw::kBitrates.size(); ++i)
      if (s == gw::bitrate_name(i)) return i;
    if (!s.starts_with("0x")) fail(path, expected + ", got " + kind_of(j));
  }
  const auto v = as_uint(j, path, 0, 1000000, "bit/s");
  for (std::uint8_t i = 0; i < gw::kBitrates.size(); ++i)
    if (gw::kBitrates[i] == v) return i;
  fail(path, expected + ", got " + std::to_string(v));
}

void parse_parameters(const json& j, const std::string& path, GatewayConfig& g) {
  const Object o(j, path,
                 {"can_bitrate", "communication_window", "rtr_frames", "canopen", "start_frame",
                  "page_mode", "module_id", "wakeup_s", "sync_ms", "can_diagnosis", "rx_counter",
                  "tx_counter", "watchdog_ms"});
  gw::UserPrm& p = g.parameters;
  if (const json* b = o.find("can_bitrate"))
    p.bitrate_index = parse_bitrate(*b, o.path("can_bitrate"));
  p.comm_window = get_bool(o, "communication_window", false);
  // GSD PrmText 3: RTR-Frames "Yes" = bit 4 clear = send RTR frames (emulator-spec §1.1).
  p.send_rtr = get_bool(o, "rtr_frames", true);
  const auto role = get_enum<gw::CanopenRole>(o, "canopen", gw::CanopenRole::None,
                                              {{"none", gw::CanopenRole::None},
                                               {"master", gw::CanopenRole::Master},
                                               {"slave", gw::CanopenRole::Slave}});
  p.canopen_master = role == gw::CanopenRole::Master;
  p.canopen_slave = role == gw::CanopenRole::Slave;
  p.start_frame = get_bool(o, "start_frame", false);
  p.page_mode = get_bool(o, "page_mode", false);
  // GSD ExtUserPrmData 8: ModuleID 1..127, default 1.
  p.module_id = get_uint<std::uint8_t>(o, "module_id", 1, 1, 127);
  // GSD ExtUserPrmData 9/10: defaults 255 / 65535 = keep the stored value (manual tables
  // 5.1.3, 5.1.4).
  p.wakeup_s = get_uint<std::uint8_t>(o, "wakeup_s", gw::kWakeupKeep, 0, 255, "s");
  p.sync_ms = get_uint<std::uint16_t>(o, "sync_ms", gw::kSyncKeep, 0, 65535, "ms");
  p.can_diagnosis = get_bool(o, "can_diagnosis", false);
  p.rx_counter = get_bool(o, "rx_counter", false);
  p.tx_counter = get_bool(o, "tx_counter", false);
  // 10 ms × WD_Fact_1 × WD_Fact_2 with both factors 1..255 (emulator-spec §1).
  g.watchdog_ms = get_uint<std::uint16_t>(o, "watchdog_ms", 0, 0, 65000, "ms");
}

// ---------------------------------------------------------------------------------- slots

SlotEntry parse_slot(const json& j, const std::string& path) {
  const Object o(j, path, {"io", "address", "length", "consistent", "comment", "cfg_hex"});
  SlotEntry s;
  s.json_path = path;
  if (const json* raw = o.find("cfg_hex")) {
    for (const char* k : {"io", "length", "consistent", "comment"})
      if (o.has(k))
        fail(o.path(k),
             "cfg_hex gives the whole Chk_Cfg entry; leave out io, length, "
             "consistent and comment");
    auto bytes = as_hex(*raw, o.path("cfg_hex"), "43 85 02 89 B8");
    const auto decoded = dp::decode_chk_cfg(bytes);
    if (decoded.error || decoded.entries.size() != 1)
      fail(o.path("cfg_hex"),
           "expected exactly one Chk_Cfg entry (identifier byte, length byte(s), manufacturer "
           "bytes), got " +
               (decoded.error ? decoded.error->message
                              : std::to_string(decoded.entries.size()) + " entries"));
    const auto& e = decoded.entries.front();
    if (e.io == dp::CfgIo::Empty) {
      if (o.has("address"))
        fail(o.path("address"), "an empty Chk_Cfg entry has no data and no address");
      s.length = 0;
      s.cfg = std::move(bytes);
      return s;
    }
    s.io = e.io == dp::CfgIo::Input ? SlotIo::Input : SlotIo::Output;
    s.length = static_cast<std::uint8_t>(std::max(e.in_bytes(), e.out_bytes()));
    s.consistent = e.consistent;
    s.comment = e.manufacturer;
    s.cfg = std::move(bytes);
    s.address = static_cast<std::uint16_t>(
        as_uint(o.at("address"), o.path("address"), 0, dp::kImageSize - 1, "(PLC byte address)"));
  } else {
    if (!o.has("io")) fail(path, "missing key \"io\" (\"input\" or \"output\")");
    s.io = get_enum<SlotIo>(o, "io", SlotIo::Output,
                            {{"input", SlotIo::Input}, {"output", SlotIo::Output}});
    s.address = static_cast<std::uint16_t>(
        as_uint(o.at("address"), o.path("address"), 0, dp::kImageSize - 1, "(PLC byte address)"));
    // Special identifier format: length byte bits 5-0 = count-1 (emulator-spec §2).
    s.length = static_cast<std::uint8_t>(as_uint(o.at("length"), o.path("length"), 1, 64, "bytes"));
    s.consistent = get_bool(o, "consistent", true);
    if (const json* c = o.find("comment")) {
      if (!c->is_string())
        fail(o.path("comment"),
             "expected the comment as typed in SIMATIC, a string like \"02,89,B8\", got " +
                 kind_of(*c));
      std::string error;
      auto bytes = gw::parse_comment(c->get_ref<const std::string&>(), &error);
      if (!bytes) fail(o.path("comment"), "expected hex bytes like \"02,89,B8\": " + error);
      s.comment = std::move(*bytes);
    }
  }
  const std::size_t end = std::size_t{s.address} + s.length;
  if (end > dp::kImageSize)
    fail(o.path("address"), "the slot's bytes " + std::to_string(s.address) + ".." +
                                std::to_string(end - 1) + " lie outside the " +
                                std::to_string(dp::kImageSize) + "-byte PLC image");
  return s;
}

// What the emulated gateway would answer to this configuration: a dry run on a real Gateway.
void check_with_gateway(const std::string& file, GatewayConfig& g) {
  struct Discard : can::FrameSink {
    void send(const can::Frame&) override {}
  } discard;
  gw::Gateway gateway({.address = g.address}, discard, Time{0});
  auto warn = [&](std::string path, std::string message) {
    g.warnings.push_back({file, std::move(path), std::move(message)});
  };
  if (g.dp_address() != g.address)
    warn(g.json_path + ".address", "DP address " + std::to_string(g.address) + " is clamped to " +
                                       std::to_string(g.dp_address()) + " (manual §2.1: 3..124)");
  const auto prm = set_prm_bytes(g);
  const std::string prm_path = g.prm_hex ? g.json_path + ".prm_hex" : g.json_path + ".parameters";
  constexpr std::uint8_t kProbeMaster = 1;
  if (!gateway.dp().set_prm(kProbeMaster, prm, Time{0})) {
    if (const auto f = gateway.dp().prm_fault())
      warn(prm_path, "the gateway will reject this Set_Prm (diagnosis 3D " +
                         hex_bytes(std::array{f->byte, f->correct}) + ": telegram byte " +
                         std::to_string(f->byte) + ", a correct value is 0x" +
                         hex_bytes(std::array{f->correct}) + ")");
    else
      warn(prm_path, "the gateway will reject this Set_Prm (Not_Supported: Sync_Req/Freeze_Req)");
    return;
  }
  const auto cfg = chk_cfg_bytes(g);
  if (!gateway.dp().chk_cfg(kProbeMaster, cfg, Time{0})) {
    const auto f = gateway.dp().cfg_fault().value_or(dp::CfgFault{});
    const std::string path =
        f.slot < g.slots.size() ? g.slots[f.slot].json_path : g.json_path + ".slots";
    warn(path, "the gateway will reject this configuration (diagnosis 3E " +
                   hex_bytes(std::array{f.slot, f.code}) + ": slot " + std::to_string(f.slot) +
                   ", code " + std::to_string(f.code) + " = " +
                   std::string(gw::cfg_code_text(f.code)) + ")");
    return;
  }
  // Behaviour the manual states, which the validator reports (emulator-spec §2).
  const auto& slots = gateway.slot_config()->slots;
  for (std::size_t i = 0; i < slots.size() && i < g.slots.size(); ++i) {
    const auto& s = slots[i];
    if (s.kind != gw::SlotKind::Rx) continue;
    const auto& m = s.comment;
    const bool bit29 = !m.empty() && (m[0] & 0x20);
    if ((m.size() == 5 && !bit29) || m.size() == 7)
      warn(g.slots[i].json_path + ".comment",
           "cycle bytes on an input slot are ignored (emulator-spec §2)");
    for (std::size_t k = i + 1; k < slots.size(); ++k)
      if (slots[k].kind == gw::SlotKind::Rx && slots[k].id == s.id)
        warn(g.slots[i].json_path,
             "Rx identifier also used by slot " + std::to_string(k) +
                 ": the later slot wins, this one never updates (manual §5.2.1)");
  }
}

// Slots whose PLC bytes overlap: allowed (emulator-spec §8), reported as warnings.
void check_overlaps(const std::string& file, const std::vector<GatewayConfig*>& gateways,
                    std::vector<ConfigError>& warnings) {
  struct Span {
    std::size_t begin, end;
    const SlotEntry* slot;
  };
  std::vector<Span> in, out;
  for (const GatewayConfig* g : gateways) {
    const auto params = slave_parameters(*g);
    const auto decoded = dp::decode_chk_cfg(params.cfg);
    for (std::size_t i = 0; i < decoded.entries.size() && i < g->slots.size(); ++i) {
      const auto& e = decoded.entries[i];
      const auto& a = params.addresses[i];
      for (int dir = 0; dir < 2; ++dir) {
        const bool input = dir == 0;
        const std::size_t n = input ? e.in_bytes() : e.out_bytes();
        const auto addr = input ? a.input : a.output;
        if (n == 0 || !addr) continue;
        auto& list = input ? in : out;
        const Span s{*addr, *addr + n, &g->slots[i]};
        for (const auto& other : list)
          if (s.begin < other.end && other.begin < s.end)
            warnings.push_back(
                {file, s.slot->json_path,
                 std::string(input ? "input bytes I " : "output bytes Q ") +
                     std::to_string(s.begin) + ".." + std::to_string(s.end - 1) + " overlap " +
                     other.slot->json_path +
                     (input ? " (the later slot's bytes win in the PLC image, emulator-spec §8)"
                            : " (both send the same PLC bytes, emulator-spec §8)")});
        list.push_back(s);
      }
    }
  }
}

GatewayConfig parse_gateway_or_throw(const json& j, const std::string& file,
                                     const std::string& path) {
  const Object o(j, path,
                 {"name", "address", "bus", "parameters", "prm_hex", "slots", "cia301_bootup",
                  "stored_wakeup_s", "stored_sync_ms"});
  GatewayConfig g;
  g.json_path = path;
  // DP station addresses 0..126; the gateway clamps to 3..124 (manual §2.1).
  g.address = static_cast<std::uint8_t>(
      as_uint(o.at("address"), o.path("address"), 0, 126, "(DP station address)"));
  g.name = find_string(o, "name", "a gateway name").value_or("gw" + std::to_string(g.dp_address()));
  if (!valid_name(g.name, 32))
    fail(o.path("name"),
         "expected a name of letters, digits, '_', '-', '.' (at most 32), got \"" + g.name + "\"");
  if (o.has("bus")) g.bus = get_string(o, "bus", "the name of a bus in \"buses\"");
  if (const json* p = o.find("parameters")) parse_parameters(*p, o.path("parameters"), g);
  if (const json* h = o.find("prm_hex"))
    g.prm_hex = as_hex(*h, o.path("prm_hex"), "00 0A 01 00 04 A4 00 00 06 00 01 00 00 FF FF FF");
  g.cia301_bootup = get_bool(o, "cia301_bootup", false);
  g.stored_wakeup_s = get_uint<std::uint8_t>(o, "stored_wakeup_s", 0, 0, 254, "s");
  g.stored_sync_ms = get_uint<std::uint16_t>(o, "stored_sync_ms", 0, 0, 65534, "ms");
  const json& slots = o.at("slots");
  if (!slots.is_array()) fail(o.path("slots"), "expected an array of slots, got " + kind_of(slots));
  for (std::size_t i = 0; i < slots.size(); ++i)
    g.slots.push_back(parse_slot(slots[i], element(o.path("slots"), i)));
  check_with_gateway(file, g);
  return g;
}

BusConfig parse_bus(const json& j, const std::string& path, const std::string& name) {
  BusConfig b;
  b.name = name;
  b.json_path = path;
  if (!j.is_object()) fail(path, "expected an object with \"type\", got " + kind_of(j));
  const json* type = j.contains("type") ? &j.at("type") : nullptr;
  if (!type) fail(path, "missing key \"type\" (\"virtual\", \"socketcan\" or \"socketcand\")");
  const std::string t = type->is_string() ? type->get<std::string>() : "";
  if (t == "virtual") {
    const Object o(
        j, path,
        {"type", "socketcand", "channel", "socketcand_max_clients", "socketcand_idle_timeout_s"});
    b.type = BusType::Virtual;
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

// emulator-spec §10: "profibus": {"port": ..., "baud": ..., "role": "slaves" | "master", ...}.
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
  if (!serial::is_supported_baud(static_cast<std::uint32_t>(baud)))
    fail(o.path("baud"), "baud " + std::to_string(baud) +
                             " is not supported; expected one of the PROFIBUS rates " +
                             serial::supported_bauds_text());
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
  // IEC 61158-4-3: TSL 37..16383 bit times; max_retry_limit 0..7; min_TSDR 11..255.
  p.slot_time_bits = get_uint<std::uint32_t>(o, "slot_time_bits", 100, 37, 16383, "bit times");
  p.retries = get_uint<std::uint8_t>(o, "retries", 1, 0, 7);
  p.min_tsdr_bits = get_uint<std::uint8_t>(o, "min_tsdr_bits", 11, 11, 255, "bit times");
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

DaemonConfig parse_daemon_or_throw(const json& root, const std::string& file) {
  DaemonConfig c;
  c.file = file;
  const Object top(root, "$",
                   {"modbus", "http", "master", "buses", "gateways", "slaves", "drives", "log",
                    "state_file", "profibus", "capture"});
  if (const json* p = top.find("profibus"))
    c.profibus = parse_profibus(*p, top.path("profibus"), file);
  const bool remote = c.remote_gateways();
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
    const Object o(*m, top.path("master"), {"address", "cycle_ms", "retry_ms"});
    c.master_address = get_uint<std::uint8_t>(o, "address", 1, 0, 125, "(DP master address)");
    c.cycle_ms = get_uint<std::uint32_t>(o, "cycle_ms", 10, 1, 60000, "ms");
    c.retry_ms = get_uint<std::uint32_t>(o, "retry_ms", 1000, 1, 600000, "ms");
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

  // Role master: the gateways are remote stations; buses only serve simulated drives.
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

  const json& gateways = top.at("gateways");
  if (!gateways.is_array() || gateways.empty())
    fail(top.path("gateways"), "expected a non-empty array of gateways, got " + kind_of(gateways));
  for (std::size_t i = 0; i < gateways.size(); ++i) {
    const std::string path = element(top.path("gateways"), i);
    GatewayConfig g = parse_gateway_or_throw(gateways[i], file, path);
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
      fail(path + ".bus",
           "unknown bus \"" + g.bus + "\" (defined in $.buses: " + join(names) + ")");
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
    c.gateways.push_back(std::move(g));
  }
  if (const json* d = top.find("drives")) {
    if (!d->is_array()) fail(top.path("drives"), "expected an array of drives, got " + kind_of(*d));
    for (std::size_t i = 0; i < d->size(); ++i) {
      const std::string path = element(top.path("drives"), i);
      DriveConfig drive = parse_drive((*d)[i], path, file);
      const BusConfig* bus = c.bus(drive.bus);
      if (!bus) fail(path + ".bus", "unknown bus \"" + drive.bus + "\"");
      if (bus->type != BusType::Virtual)
        fail(path + ".bus",
             "simulated drives run on virtual buses only (use candp2-drive on a "
             "SocketCAN or socketcand bus)");
      for (const auto& other : c.drives) {
        if (other.name == drive.name)
          fail(path + ".name",
               "the name \"" + drive.name + "\" is already used by " + other.json_path);
        if (drive.modbus_unit && other.modbus_unit == drive.modbus_unit)
          fail(path + ".modbus_unit", "unit ID " + std::to_string(*drive.modbus_unit) +
                                          " is already used by " + other.json_path);
      }
      if (drive.modbus_unit)
        if (const auto* g = c.gateway_by_dp_address(*drive.modbus_unit))
          fail(path + ".modbus_unit", "unit ID " + std::to_string(*drive.modbus_unit) +
                                          " is the DP address of " + g->json_path +
                                          " (the gateway's Modbus unit ID)");
      c.drives.push_back(std::move(drive));
    }
  }

  parse_slaves(top.find("slaves"), file, c);  // config/slaves_config.hpp

  for (auto& g : c.gateways) {
    // emulator-spec §1: a Data_Exchange gap longer than the watchdog time drops the slave to
    // Wait_Prm; with a watchdog below two master cycles one late cycle is enough.
    // (Role slaves: an external master's cycle, unknown here.)
    const bool external_master = c.profibus && c.profibus->role == ProfibusRole::Slaves;
    if (!external_master && g.watchdog_ms != 0 && g.watchdog_ms < 2 * c.cycle_ms)
      g.warnings.push_back({file, g.json_path + ".parameters.watchdog_ms",
                            "watchdog " + std::to_string(g.watchdog_ms) +
                                " ms is shorter than two master cycles ($.master.cycle_ms = " +
                                std::to_string(c.cycle_ms) +
                                "): the gateway will drop out of Data_Exch"});
    c.warnings.insert(c.warnings.end(), g.warnings.begin(), g.warnings.end());
  }
  check_shared_bitrates(c);
  std::vector<GatewayConfig*> all;
  for (auto& g : c.gateways) all.push_back(&g);
  check_overlaps(file, all, c.warnings);
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

Result<GatewayConfig> parse_gateway(const json& j, const std::string& file,
                                    const std::string& path) {
  try {
    return parse_gateway_or_throw(j, file, path);
  } catch (const Failure& f) {
    return ConfigError{file, f.path, f.message};
  }
}

Result<DriveConfig> parse_drive_entry(const json& j, const std::string& file,
                                      const std::string& path) {
  try {
    return parse_drive(j, path, file);
  } catch (const Failure& f) {
    return ConfigError{file, f.path, f.message};
  }
}

std::optional<std::uint32_t> configured_bitrate(const GatewayConfig& g) {
  const auto prm = set_prm_bytes(g);
  if (prm.size() <= gw::kPrmBitrate || prm[gw::kPrmBitrate] > gw::kBitrateMax) return std::nullopt;
  return gw::kBitrates[prm[gw::kPrmBitrate]];  // emulator-spec §1.1 byte 8
}

std::vector<std::uint8_t> set_prm_bytes(const GatewayConfig& g) {
  if (g.prm_hex) return *g.prm_hex;
  const auto t = gw::make_set_prm(g.parameters, g.watchdog_ms);
  return {t.begin(), t.end()};
}

std::vector<std::uint8_t> chk_cfg_bytes(const GatewayConfig& g) {
  std::vector<std::uint8_t> out;
  for (const auto& s : g.slots) {
    if (s.cfg) {
      out.insert(out.end(), s.cfg->begin(), s.cfg->end());
      continue;
    }
    // Special identifier format with the comment as manufacturer bytes (emulator-spec §2, manual
    // §7): "Universalmodul" entries as SIMATIC writes them.
    const dp::CfgEntry e = s.io == SlotIo::Input
                               ? dp::special_input(s.length, s.consistent, s.comment)
                               : dp::special_output(s.length, s.consistent, s.comment);
    const auto bytes = dp::encode_chk_cfg(std::span(&e, 1));
    out.insert(out.end(), bytes.begin(), bytes.end());
  }
  return out;
}

dp::SlaveParameters slave_parameters(const GatewayConfig& g) {
  dp::SlaveParameters p;
  p.prm = set_prm_bytes(g);
  p.cfg = chk_cfg_bytes(g);
  p.name = g.name;
  for (const auto& s : g.slots) {
    dp::EntryAddress a;
    dp::CfgIo io = s.io == SlotIo::Input ? dp::CfgIo::Input : dp::CfgIo::Output;
    if (s.cfg) {
      const auto d = dp::decode_chk_cfg(*s.cfg);
      io = d.entries.empty() ? dp::CfgIo::Empty : d.entries.front().io;
    }
    if (io == dp::CfgIo::Input || io == dp::CfgIo::InputOutput) a.input = s.address;
    if (io == dp::CfgIo::Output || io == dp::CfgIo::InputOutput) a.output = s.address;
    p.addresses.push_back(a);
  }
  return p;
}

}  // namespace candp2::config
