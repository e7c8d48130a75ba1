// A gateway entry of the configuration (docs/configuration.md "gateways[]"): named parameters or
// prm_hex, slots from the SIMATIC dialog's comment bytes or cfg_hex, and what the emulated gateway
// would answer to them (warnings); what the master sends for it.
#include <set>

#include "can/channel.hpp"
#include "common/hex.hpp"
#include "config/config.hpp"
#include "config/parse_helpers.hpp"
#include "gateway/gateway.hpp"
#include "gateway/slot_config.hpp"

namespace candp2::config {

namespace detail {

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

namespace {

void parse_parameters(const json& j, const std::string& path, GatewayConfig& g) {
  const Object o(j, path,
                 {"can_bitrate", "communication_window", "rtr_frames", "canopen", "start_frame",
                  "page_mode", "module_id", "wakeup_s", "sync_ms", "can_diagnosis", "rx_counter",
                  "tx_counter", "watchdog_ms"});
  gw::UserPrm& p = g.parameters;
  if (const json* b = o.find("can_bitrate"))
    p.bitrate_index = parse_bitrate(*b, o.path("can_bitrate"));
  p.comm_window = get_bool(o, "communication_window", false);
  // GSD PrmText 3: RTR-Frames "Yes" = bit 4 clear = send RTR frames
  // (docs/dp-slave.md "User parameters").
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
  // 10 ms × WD_Fact_1 × WD_Fact_2 with both factors 1..255 (docs/dp-slave.md).
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
    // Special identifier format: length byte bits 5-0 = count-1 (docs/slots.md "Chk_Cfg slots").
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
  auto warn = [&](std::string path, std::string message, WarningKind kind = WarningKind::Other) {
    g.warnings.push_back({file, std::move(path), std::move(message), kind});
  };
  if (g.dp_address() != g.address)
    warn(g.json_path + ".address", "DP address " + std::to_string(g.address) + " is clamped to " +
                                       std::to_string(g.dp_address()) + " (manual §2.1: 3..124)");
  const auto prm = set_prm_bytes(g);
  const std::string prm_path = g.prm_hex ? g.json_path + ".prm_hex" : g.json_path + ".parameters";
  constexpr std::uint8_t kProbeMaster = 1;
  if (!gateway.dp().set_prm(kProbeMaster, prm, Time{0})) {
    if (const auto f = gateway.dp().prm_fault())
      warn(prm_path,
           "the gateway will reject this Set_Prm (diagnosis 3D " +
               hex_bytes(std::array{f->byte, f->correct}) + ": telegram byte " +
               std::to_string(f->byte) + ", a correct value is 0x" +
               hex_bytes(std::array{f->correct}) + ")",
           WarningKind::Rejected);
    else
      warn(prm_path, "the gateway will reject this Set_Prm (Not_Supported: Sync_Req/Freeze_Req)",
           WarningKind::Rejected);
    return;
  }
  const auto cfg = chk_cfg_bytes(g);
  if (!gateway.dp().chk_cfg(kProbeMaster, cfg, Time{0})) {
    const auto f = gateway.dp().cfg_fault().value_or(dp::CfgFault{});
    const std::string path =
        f.slot < g.slots.size() ? g.slots[f.slot].json_path : g.json_path + ".slots";
    warn(path,
         "the gateway will reject this configuration (diagnosis 3E " +
             hex_bytes(std::array{f.slot, f.code}) + ": slot " + std::to_string(f.slot) +
             ", code " + std::to_string(f.code) + " = " + std::string(gw::cfg_code_text(f.code)) +
             ")",
         WarningKind::Rejected);
    return;
  }
  // Behaviour the manual states, which the validator reports (docs/slots.md "Chk_Cfg slots").
  const auto& slots = gateway.slot_config()->slots;
  for (std::size_t i = 0; i < slots.size() && i < g.slots.size(); ++i) {
    const auto& s = slots[i];
    if (s.kind != gw::SlotKind::Rx) continue;
    const auto& m = s.comment;
    const bool bit29 = !m.empty() && (m[0] & 0x20);
    if ((m.size() == 5 && !bit29) || m.size() == 7)
      warn(g.slots[i].json_path + ".comment",
           "cycle bytes on an input slot are ignored (docs/slots.md)");
    for (std::size_t k = i + 1; k < slots.size(); ++k)
      if (slots[k].kind == gw::SlotKind::Rx && slots[k].id == s.id)
        warn(g.slots[i].json_path,
             "Rx identifier also used by slot " + std::to_string(k) +
                 ": the later slot wins, this one never updates (manual §5.2.1)");
  }
}

// Slots whose PLC bytes overlap: allowed (docs/modbus.md), reported as warnings.
}  // namespace

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
                     (input ? " (the later slot's bytes win in the PLC image, docs/modbus.md)"
                            : " (both send the same PLC bytes, docs/modbus.md)"),
                 WarningKind::Overlap});
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

}  // namespace detail

using namespace detail;

Result<GatewayConfig> parse_gateway(const json& j, const std::string& file,
                                    const std::string& path) {
  try {
    return parse_gateway_or_throw(j, file, path);
  } catch (const Failure& f) {
    return ConfigError{file, f.path, f.message};
  }
}

std::optional<std::uint32_t> configured_bitrate(const GatewayConfig& g) {
  const auto prm = set_prm_bytes(g);
  if (prm.size() <= gw::kPrmBitrate) return std::nullopt;
  return gw::bitrate_bps(prm[gw::kPrmBitrate]);  // docs/dp-slave.md "User parameters" byte 8
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
    // Special identifier format with the comment as manufacturer bytes
    // (docs/slots.md "Chk_Cfg slots", manual §7): "Universalmodul" entries as SIMATIC writes them.
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
