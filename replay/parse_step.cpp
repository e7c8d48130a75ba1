// The steps of a replay scenario (docs/replay-format.md): one action key per step, its value, the
// step's window and the gateway, bus or drive it concerns.
#include <algorithm>

#include "common/hex.hpp"
#include "config/json_reader.hpp"
#include "profibus_sim/fdl/line_stats.hpp"
#include "profibus_sim/fdl/wire_faults.hpp"
#include "profibus_sim/master/dp_master.hpp"
#include "replay/parse_internal.hpp"
#include "station/status.hpp"

namespace candp2::replay::parse {

using nlohmann::json;
using namespace config::json_reader;

Duration as_ms(const json& j, const std::string& path, std::uint64_t max) {
  return milliseconds(as_uint(j, path, 0, max, "ms"));
}

namespace {

BytePattern as_pattern(const json& j, const std::string& path) {
  const std::string text = as_string(j, path, "hex bytes like \"00 33 ?? 00\" (?? = any byte)");
  std::string error;
  auto read = parse_hex_bytes(text, HexForm::Patterns, &error);
  if (!read) fail(path, error);
  return BytePattern{std::move(read->bytes), std::move(read->care)};
}

can::Frame as_frame(const json& j, const std::string& path) {
  const std::string text = as_string(j, path, "a frame in candump notation like \"201#1122\"");
  auto r = can::parse_candump(text);
  if (!r)
    fail(path,
         "\"" + text + "\" column " + std::to_string(r.error.column) + ": " + r.error.message);
  return *r.frame;
}

FramePattern as_frame_pattern(const json& j, const std::string& path) {
  const std::string text =
      as_string(j, path, "a frame like \"201#1122\", \"201#*\" (any data) or \"*\" (any frame)");
  FramePattern p;
  if (text == "*") {
    p.any = true;
    return p;
  }
  std::string t = text;
  if (t.size() >= 2 && t.compare(t.size() - 2, 2, "#*") == 0) {
    p.any_data = true;
    t.pop_back();
  }
  auto r = can::parse_candump(t);
  if (!r)
    fail(path,
         "\"" + text + "\" column " + std::to_string(r.error.column) + ": " + r.error.message);
  p.frame = *r.frame;
  return p;
}

Db as_db(const json& j, const std::string& path) {
  const std::string s = as_string(j, path, "a data block name");
  if (s == "WRITE_CONFIG_DB" || s == "DB94") return Db::WriteConfig;
  if (s == "READ_CONFIG_DB" || s == "DB95") return Db::ReadConfig;
  if (s == "WRITE_DB" || s == "DB96") return Db::Write;
  if (s == "READ_DB" || s == "DB97") return Db::Read;
  fail(path,
       "expected \"WRITE_CONFIG_DB\" (DB94), \"READ_CONFIG_DB\" (DB95), \"WRITE_DB\" (DB96) "
       "or \"READ_DB\" (DB97), got " +
           kind_of(j));
}

dp::SlaveState as_dp_state(const json& j, const std::string& path) {
  const std::string s = as_string(j, path, "a DP state");
  if (s == "wait_prm") return dp::SlaveState::WaitPrm;
  if (s == "wait_cfg") return dp::SlaveState::WaitCfg;
  if (s == "data_exch") return dp::SlaveState::DataExch;
  fail(path, "expected \"wait_prm\", \"wait_cfg\" or \"data_exch\", got " + kind_of(j));
}

}  // namespace

void parse_nothing(Step&, const StepInput&) {}

void parse_advance(Step& s, const StepInput& in) {
  s.advance = as_ms(in.value, in.path);
}

void parse_cycles(Step& s, const StepInput& in) {
  s.cycles = static_cast<std::uint32_t>(as_uint(in.value, in.path, 1, 1000000, "DP cycles"));
}

// write / expect_input / expect_output: {"address": PLC byte address, "bytes": ...}.
void parse_image(Step& s, const StepInput& in) {
  const Object w(in.value, in.path, {"address", "bytes"});
  s.address = static_cast<std::uint16_t>(
      as_uint(w.at("address"), w.path("address"), 0, dp::kImageSize - 1, "(PLC byte address)"));
  std::size_t n = 0;
  if (s.action == Action::Write) {
    s.bytes = as_hex(w.at("bytes"), w.path("bytes"), "00 33 01 00");
    n = s.bytes.size();
  } else {
    s.pattern = as_pattern(w.at("bytes"), w.path("bytes"));
    n = s.pattern.size();
  }
  if (s.address + n > dp::kImageSize)
    fail(w.path("bytes"), "the bytes run past the end of the 8192-byte process image");
}

void parse_inject(Step& s, const StepInput& in) {
  const json& v = in.value;
  if (!v.is_array()) {
    s.frames.push_back(as_frame(v, in.path));
    return;
  }
  if (v.empty()) fail(in.path, "expected at least one frame");
  for (std::size_t i = 0; i < v.size(); ++i)
    s.frames.push_back(as_frame(v[i], element(in.path, i)));
}

void parse_frame(Step& s, const StepInput& in) {
  s.frame_patterns.push_back(as_frame_pattern(in.value, in.path));
}

void parse_frame_list(Step& s, const StepInput& in) {
  const json& v = in.value;
  if (!v.is_array()) fail(in.path, "expected an array of frames, got " + kind_of(v));
  for (std::size_t i = 0; i < v.size(); ++i)
    s.frame_patterns.push_back(as_frame_pattern(v[i], element(in.path, i)));
}

void parse_diag(Step& s, const StepInput& in) {
  s.pattern = as_pattern(in.value, in.path);
  // A generic slave's diagnosis is 6 + n bytes (docs/slaves.md); the gateway's always 11.
  if (!in.slave && s.pattern.size() != dp::DpSlave::kDiagLen)
    fail(in.path, "expected the 11 diagnosis bytes (docs/dp-slave.md \"Diagnosis\"), got " +
                      std::to_string(s.pattern.size()));
}

void parse_dp_state(Step& s, const StepInput& in) {
  s.dp_state = as_dp_state(in.value, in.path);
}

void parse_flag(Step& s, const StepInput& in) {
  s.on = in.value.is_boolean() ? in.value.get<bool>() : as_uint(in.value, in.path, 0, 1) == 1;
}

// The Page-Mode driver's data blocks: {"db", "index", "offset", "bytes"}.
void parse_db(Step& s, const StepInput& in) {
  const Object w(in.value, in.path, {"db", "index", "offset", "bytes"});
  s.db = as_db(w.at("db"), w.path("db"));
  s.db_index = w.has("index") ? as_uint(w.at("index"), w.path("index"), 0, 1000) : 0;
  s.offset = as_uint(w.at("offset"), w.path("offset"), 0, 65535, "(byte in the DB)");
  if (s.action == Action::DbWrite)
    s.bytes = as_hex(w.at("bytes"), w.path("bytes"), "02 01 02 03");
  else
    s.pattern = as_pattern(w.at("bytes"), w.path("bytes"));
}

// set_tx {"id", "force", "data"} / expect_rx {"id", "count_in", "data"}.
void parse_entry(Step& s, const StepInput& in) {
  const std::string& vp = in.path;
  const bool tx = s.action == Action::SetTx;
  const Object w(in.value, vp,
                 tx ? std::vector<std::string>{"id", "force", "data"}
                    : std::vector<std::string>{"id", "count_in", "data"});
  s.entry = as_uint(w.at("id"), w.path("id"), 1, gw::page::kMaxIdentifiers,
                    tx ? "(Tx identifier number: 1 = TxId1)" : "(Rx identifier number)");
  if (tx && w.has("force"))
    s.force = static_cast<std::uint8_t>(as_uint(w.at("force"), w.path("force"), 0, 255));
  if (!tx && w.has("count_in"))
    s.count_in = static_cast<std::uint8_t>(as_uint(w.at("count_in"), w.path("count_in"), 0, 255));
  if (w.has("data")) {
    s.has_data = true;
    if (tx)
      s.bytes = as_hex(w.at("data"), w.path("data"), "00 11 22 33 44 55");
    else
      s.pattern = as_pattern(w.at("data"), w.path("data"));
  }
  if (!s.has_data && !s.force && !s.count_in)
    fail(vp, tx ? "give \"force\" and/or \"data\"" : "give \"count_in\" and/or \"data\"");
}

void parse_ret_value(Step& s, const StepInput& in) {
  s.ret_value =
      static_cast<std::uint16_t>(as_uint(in.value, in.path, 0, 4, "(manual table 6.5.7)"));
}

void parse_true(Step&, const StepInput& in) {
  if (!in.value.is_boolean() || !in.value.get<bool>())
    fail(in.path, "expected true, got " + kind_of(in.value));
}

void parse_can_state(Step& s, const StepInput& in) {
  const std::string t = in.value.is_string() ? in.value.get<std::string>() : "";
  for (std::uint16_t i = 0; i < 4; ++i)
    if (t == kCanStates[i]) {
      s.can_state = i;
      return;
    }
  fail(in.path, "expected \"real\", \"warning\", \"error-passive\" or \"bus-off\", got " +
                    kind_of(in.value));
}

void parse_drop_rx(Step& s, const StepInput& in) {
  s.count = static_cast<std::uint32_t>(as_uint(in.value, in.path, 0, 65535, "frames"));
}

namespace {
// The counters replay checks, as the station table names them (station/status.hpp), in the
// table's replay order.
std::vector<std::string> counter_names() {
  std::vector<const station::Field*> rows;
  for (const auto& f : station::fields())
    if (f.replay) rows.push_back(&f);
  std::sort(rows.begin(), rows.end(), [](auto* a, auto* b) { return a->replay < b->replay; });
  std::vector<std::string> names;
  for (const auto* f : rows) names.emplace_back(f->name);
  return names;
}
}  // namespace

void parse_counters(Step& s, const StepInput& in) {
  static const std::vector<std::string> kNames = counter_names();
  const Object w(in.value, in.path, kNames);
  for (const auto& n : kNames)
    if (w.has(n))
      s.counters.emplace_back(
          n, static_cast<std::uint32_t>(as_uint(w.at(n), w.path(n), 0, 0xFFFFFFFFull)));
  if (s.counters.empty()) fail(in.path, "give at least one counter (" + join(kNames) + ")");
}

void parse_bits(Step& s, const StepInput& in) {
  s.bits =
      static_cast<std::uint16_t>(as_uint(in.value, in.path, 0, 0xFFFF, "(ERR_BITMAP1 0x8F bits)"));
}

void parse_bool(Step& s, const StepInput& in) {
  if (!in.value.is_boolean()) fail(in.path, "expected true or false, got " + kind_of(in.value));
  s.on = in.value.get<bool>();
}

void parse_alarm(Step& s, const StepInput& in) {
  const std::string text = as_string(in.value, in.path, "hex bytes, \"\" to clear", Empty::Allowed);
  if (!text.empty()) s.bytes = as_hex(in.value, in.path, "00 01");
  if (s.bytes.size() > 62) fail(in.path, "at most 62 device-related bytes");
}

// field_write / expect_field: {"offset", "bytes"}.
void parse_field(Step& s, const StepInput& in) {
  const Object w(in.value, in.path, {"offset", "bytes"});
  s.offset = w.has("offset") ? as_uint(w.at("offset"), w.path("offset"), 0, 243, "(byte)") : 0;
  if (s.action == Action::FieldWrite)
    s.bytes = as_hex(w.at("bytes"), w.path("bytes"), "01 02");
  else
    s.pattern = as_pattern(w.at("bytes"), w.path("bytes"));
}

namespace {

// A station of the line: a configured gateway's or generic slave's DP address.
std::uint8_t line_station(const Object& w, const StepInput& in) {
  const auto a = static_cast<std::uint8_t>(
      as_uint(w.at("station"), w.path("station"), 0, 126, "(a DP address)"));
  const auto& inst = in.scenario.installation;
  for (const auto& g : inst.gateways)
    if (g.dp_address() == a) return a;
  for (const auto& sl : inst.slaves)
    if (sl.address == a) return a;
  fail(w.path("station"),
       "no gateway or slave of the configuration has DP address " + std::to_string(a));
}

void need_timed_line(const StepInput& in) {
  if (!in.scenario.installation.line)
    fail(in.path,
         "needs a line in time: give the configuration a baud rate ($.master.baud, "
         "docs/profibus.md \"The line in time\")");
}

}  // namespace

// line_fault: {"station", "kind", "count", "every", "for_ms"} or {"kind": "noise", "for_ms"}
// (docs/replay-format.md, docs/faults.md "Line faults").
void parse_line_fault(Step& s, const StepInput& in) {
  need_timed_line(in);
  const Object w(in.value, in.path, {"station", "kind", "count", "every", "for_ms"});
  const std::string kind = as_string(w.at("kind"), w.path("kind"), "a fault kind");
  const auto parsed = plant::line_fault_kind(kind);
  if (!parsed)
    fail(w.path("kind"),
         "expected corrupt, silent, late, double_address, none or noise, got \"" + kind + "\"");
  plant::LineFault& f = s.line_fault;
  f.kind = *parsed;
  if (w.has("for_ms")) f.duration = as_ms(w.at("for_ms"), w.path("for_ms"));
  if (f.kind == plant::LineFaultKind::Noise) {
    for (const char* k : {"station", "count", "every"})
      if (w.has(k)) fail(w.path(k), "noise is on the whole line: give only \"for_ms\"");
    if (!f.duration) fail(in.path, "noise needs \"for_ms\"");
    return;
  }
  f.station = line_station(w, in);
  if (w.has("count") && f.duration) fail(w.path("count"), "give \"count\" or \"for_ms\", not both");
  f.count = get_uint<std::uint32_t>(w, "count", 1, 1, 65535, "answers");
  f.every = get_uint<std::uint32_t>(w, "every", 1, 1, 65535, "requests");
}

// can_fault: {"bus", "gateway", "drive", "id", "kind", "count", "every", "for_ms"}
// (docs/replay-format.md, docs/faults.md "CAN faults on cue").
void parse_can_fault(Step& s, const StepInput& in) {
  const Object w(in.value, in.path,
                 {"bus", "gateway", "drive", "id", "kind", "count", "every", "for_ms"});
  const std::string kind = as_string(w.at("kind"), w.path("kind"), "a fault kind");
  const auto parsed = plant::can_fault_kind(kind);
  if (!parsed)
    fail(w.path("kind"),
         "expected none, error_frames, unplugged, wrong_bitrate or noise, got \"" + kind + "\"");
  plant::CanFault& f = s.can_fault;
  f.kind = *parsed;
  const auto& inst = in.scenario.installation;
  std::string node_bus;
  if (w.has("gateway") && w.has("drive"))
    fail(w.path("drive"), "give \"gateway\" or \"drive\", not both");
  if (w.has("gateway")) {
    const auto a = static_cast<std::uint8_t>(
        as_uint(w.at("gateway"), w.path("gateway"), 0, 126, "(a DP address)"));
    const auto g = std::find_if(inst.gateways.begin(), inst.gateways.end(),
                                [&](const auto& c) { return c.dp_address() == a; });
    if (g == inst.gateways.end())
      fail(w.path("gateway"),
           "no gateway of the configuration has DP address " + std::to_string(a));
    f.node.gateway = a;
    node_bus = g->bus;
  }
  if (w.has("drive")) {
    f.node.drive = as_string(w.at("drive"), w.path("drive"), "a drive's name");
    const auto d = std::find_if(inst.drives.begin(), inst.drives.end(),
                                [&](const auto& c) { return c.name == f.node.drive; });
    if (d == inst.drives.end())
      fail(w.path("drive"), "no drive of the configuration is named \"" + f.node.drive + "\"");
    node_bus = d->bus;
  }
  if (w.has("bus")) {
    f.bus = as_string(w.at("bus"), w.path("bus"), "a bus's name");
    if (!node_bus.empty() && node_bus != f.bus)
      fail(w.path("bus"), "the node is on bus \"" + node_bus + "\", not \"" + f.bus + "\"");
  } else if (node_bus.empty()) {
    fail(in.path, "needs \"bus\", \"gateway\" or \"drive\"");
  }
  const std::string bus_name = f.bus.empty() ? node_bus : f.bus;
  const auto b = std::find_if(inst.buses.begin(), inst.buses.end(),
                              [&](const auto& c) { return c.name == bus_name; });
  if (b == inst.buses.end()) fail(w.path("bus"), "no bus \"" + bus_name + "\"");
  if (!b->timed_bitrate)
    fail(in.path, "needs a bus in time: give bus \"" + bus_name + "\" a bit rate ($.buses." +
                      bus_name + ".bitrate, docs/can-bus.md)");
  if (w.has("id")) {
    const std::string text = as_string(w.at("id"), w.path("id"), "an identifier like \"201\"");
    const auto r = can::parse_candump(text + "#");
    if (!r)
      fail(w.path("id"),
           "expected an identifier as candump writes it (\"201\", \"18FF0001\"), got \"" + text +
               "\"");
    f.id = can::ident_of(*r.frame);
  }
  if (w.has("for_ms")) f.duration = as_ms(w.at("for_ms"), w.path("for_ms"));
  const bool node = f.node.any();
  const bool counted = f.kind == plant::CanFaultKind::ErrorFrames;
  if (!counted)
    for (const char* k : {"count", "every"})
      if (w.has(k)) fail(w.path(k), "only error_frames takes \"" + std::string(k) + "\"");
  switch (f.kind) {
    case plant::CanFaultKind::None:
    case plant::CanFaultKind::Unplugged:
    case plant::CanFaultKind::WrongBitrate:
      if (w.has("id")) fail(w.path("id"), kind + " is a node's (or the bus's): no \"id\"");
      // Unplugged and wrong_bitrate last until a none, or end by themselves after for_ms.
      if (f.kind == plant::CanFaultKind::None && w.has("for_ms"))
        fail(w.path("for_ms"), "none cancels at once: no \"for_ms\"");
      if (f.duration && *f.duration == Duration(0)) f.duration.reset();  // 0: until a none
      if (f.kind != plant::CanFaultKind::None && !node)
        fail(in.path, kind + " needs a node: \"gateway\" or \"drive\"");
      break;
    case plant::CanFaultKind::Noise:
      for (const char* k : {"gateway", "drive", "id"})
        if (w.has(k)) fail(w.path(k), "noise is on the whole bus: give \"bus\" and \"for_ms\"");
      if (!f.duration) fail(in.path, "noise needs \"for_ms\"");
      break;
    case plant::CanFaultKind::ErrorFrames:
      if (node && f.id) fail(w.path("id"), "give a node or \"id\", not both");
      if (!node && !f.id) fail(in.path, "error_frames needs \"gateway\", \"drive\" or \"id\"");
      if (w.has("count") && f.duration)
        fail(w.path("count"), "give \"count\" or \"for_ms\", not both");
      f.count = get_uint<std::uint32_t>(w, "count", 1, 1, 65535, "frames");
      f.every = get_uint<std::uint32_t>(w, "every", 1, 1, 65535, "frames");
      break;
  }
}

// expect_line: {"station", the counters of fdl::kStationCounters, "live", "bus_cycle_us":
// {"max_le"}} (docs/replay-format.md).
void parse_expect_line(Step& s, const StepInput& in) {
  need_timed_line(in);
  std::vector<std::string> counters;
  for (const auto& f : fdl::kStationCounters) counters.emplace_back(f.name);
  std::vector<std::string> keys = {"station", "live", "bus_cycle_us"};
  keys.insert(keys.end(), counters.begin(), counters.end());
  const Object w(in.value, in.path, keys);
  if (w.has("station")) s.station = line_station(w, in);
  for (const auto& f : fdl::kStationCounters) {
    const std::string n(f.name);
    if (!w.has(n)) continue;
    if (!s.station) fail(w.path(n), "a station's counter needs \"station\"");
    s.counters.emplace_back(
        n, static_cast<std::uint32_t>(as_uint(w.at(n), w.path(n), 0, 0xFFFFFFFFull)));
  }
  if (w.has("live")) {
    if (!s.station) fail(w.path("live"), "the live state needs \"station\"");
    s.live = as_string(w.at("live"), w.path("live"), "ok, missing, phantom or none");
    const fdl::Live states[] = {fdl::Live::Ok, fdl::Live::Missing, fdl::Live::Phantom,
                                fdl::Live::None};
    if (std::ranges::none_of(states, [&](fdl::Live l) { return fdl::to_string(l) == s.live; }))
      fail(w.path("live"), "expected ok, missing, phantom or none, got \"" + s.live + "\"");
  }
  if (w.has("bus_cycle_us")) {
    const Object c(w.at("bus_cycle_us"), w.path("bus_cycle_us"), {"max_le"});
    s.bus_cycle_max_le = as_uint(c.at("max_le"), c.path("max_le"), 0, 0xFFFFFFFFull, "µs");
  }
  if (s.counters.empty() && s.live.empty() && !s.bus_cycle_max_le)
    fail(in.path,
         "give a station's counters (" + join(counters) + "), \"live\" or \"bus_cycle_us\"");
}

namespace {

// A figure's range: a number (exactly it) or {"min", "max"} (replay/bus_figures.hpp).
Bound as_bound(const json& j, const std::string& path) {
  auto number = [](const json& v, const std::string& p) {
    if (!v.is_number()) fail(p, "expected a number, got " + kind_of(v));
    return v.get<double>();
  };
  Bound b;
  if (j.is_number()) {
    b.min = b.max = j.get<double>();
    return b;
  }
  if (!j.is_object())
    fail(path, "expected a number (exactly it) or {\"min\": …, \"max\": …}, got " + kind_of(j));
  const Object o(j, path, {"min", "max"});
  if (o.has("min")) b.min = number(o.at("min"), o.path("min"));
  if (o.has("max")) b.max = number(o.at("max"), o.path("max"));
  if (!b.min && !b.max) fail(path, "give \"min\", \"max\" or both");
  if (b.min && b.max && *b.min > *b.max) fail(o.path("min"), "\"min\" lies above \"max\"");
  return b;
}

// "a", "b": the names quoted, joined.
std::string quoted_names(const std::vector<std::string>& names) {
  std::vector<std::string> q;
  for (const auto& n : names) q.push_back("\"" + n + "\"");
  return join(q);
}

// A word figure's value (a node's state): one of its words, exactly it.
Bound as_word(const BusFigure& f, const json& j, const std::string& path) {
  std::vector<std::string> words;
  for (std::size_t c = 0; !f.word(c).empty(); ++c) words.emplace_back(f.word(c));
  const auto code = j.is_string() ? f.code_of(j.get<std::string>()) : std::nullopt;
  if (!code)
    fail(path, "expected one of " + quoted_names(words) + ", got " +
                   (j.is_string() ? quoted_names({j.get<std::string>()}) : kind_of(j)));
  return Bound{code, code};
}

// expect_bus's "bus": a bus of the configuration with a bit rate; without the key, the only bus.
void expect_bus_bus(Step& s, const Object& w, const StepInput& in) {
  const auto& buses = in.scenario.installation.buses;
  std::vector<std::string> names;
  for (const auto& b : buses) names.push_back("\"" + b.name + "\"");
  const std::string where = w.has("bus") ? w.path("bus") : in.path;
  if (w.has("bus")) {
    const std::string name = as_string(w.at("bus"), w.path("bus"), "a bus name");
    const auto it = std::find_if(buses.begin(), buses.end(),
                                 [&](const config::BusConfig& b) { return b.name == name; });
    if (it == buses.end()) fail(where, "no bus \"" + name + "\" (the buses: " + join(names) + ")");
    s.bus = static_cast<std::size_t>(it - buses.begin());
  } else if (buses.size() != 1) {
    fail(in.path, "give \"bus\", one of " + join(names));
  }
  s.bus_name = buses.at(s.bus).name;
  if (!buses[s.bus].timed_bitrate)
    fail(where, "bus \"" + s.bus_name +
                    "\" has no \"bitrate\": expect_bus needs a bus in time (docs/can-bus.md "
                    "\"The bus in time\")");
}

}  // namespace

// expect_bus: {"bus", "id", "extended", "rtr", the figures of replay/bus_figures.hpp}
// (docs/replay-format.md "The CAN bus in time").
void parse_expect_bus(Step& s, const StepInput& in) {
  std::vector<std::string> figures;
  for (const auto& f : bus_figures()) figures.emplace_back(f.key);
  std::vector<std::string> keys = {"bus", "id", "extended", "rtr", "node"};
  keys.insert(keys.end(), figures.begin(), figures.end());
  const Object w(in.value, in.path, keys);
  expect_bus_bus(s, w, in);
  if (w.has("id")) {
    const bool ext = w.has("extended") && as_bool(w.at("extended"), w.path("extended"));
    s.can_id = can::Ident{static_cast<std::uint32_t>(as_uint(
                              w.at("id"), w.path("id"), 0, ext ? can::kMaxExtId : can::kMaxStdId,
                              ext ? "(29-bit identifier)"
                                  : "(11-bit identifier; set \"extended\": true for 29-bit)")),
                          ext};
    s.can_remote = w.has("rtr") && as_bool(w.at("rtr"), w.path("rtr"));
  } else {
    for (const char* k : {"extended", "rtr"})
      if (w.has(k)) fail(w.path(k), "qualifies an identifier: give \"id\"");
  }
  if (w.has("node")) {
    s.bus_node = as_string(w.at("node"), w.path("node"), "a node's name (\"gw:NAME\")");
    if (s.bus_node.empty()) fail(w.path("node"), "give a node's name (\"gw:NAME\")");
  }
  for (const auto& f : bus_figures()) {
    const std::string k(f.key);
    if (!w.has(k)) continue;
    if (f.scope == BusScope::Identifier && !s.can_id)
      fail(w.path(k),
           "is an identifier's figure: give \"id\"" +
               std::string(k == "frames" ? " (the bus's frames: \"frames_on_bus\")" : ""));
    if (f.scope == BusScope::Node && s.bus_node.empty())
      fail(w.path(k), "is a node's figure: give \"node\" (\"gw:NAME\")");
    s.bus_checks.push_back(
        {&f, f.word ? as_word(f, w.at(k), w.path(k)) : as_bound(w.at(k), w.path(k))});
  }
  if (s.bus_checks.empty()) fail(in.path, "give at least one figure (" + join(figures) + ")");
}

namespace {

// "gateway": NAME → s.gateway. Without the key: the only gateway, else an error.
void resolve_gateway(Step& s, const Object& o, const std::string& path, const std::string& key,
                     const Scenario& sc) {
  const auto& gateways = sc.installation.gateways;
  std::vector<std::string> names;
  for (const auto& g : gateways) names.push_back(g.name);
  const json* g = o.find("gateway");
  if (!g && gateways.empty()) {
    // A line of generic slaves alone (docs/replay-format.md "Version 2"): the image steps need
    // no gateway (the image is the master's), the gateway's own steps have none to act on.
    const bool image = s.action == Action::Write || s.action == Action::ExpectInput ||
                       s.action == Action::ExpectOutput;
    if (!image)
      fail(path,
           "\"" + key + "\" concerns a gateway, and " +
               (sc.config_file.empty() ? "the scenario" : sc.config_file) + " configures none" +
               (spec(s.action).target == Target::Station ? " (give \"slave\" for a generic slave)"
                                                         : ""));
    return;
  }
  if (!g) {
    if (gateways.size() > 1)
      fail(path,
           "\"" + key + "\" concerns one gateway: give \"gateway\", one of " + quoted_names(names));
    return;
  }
  const std::string name = as_string(*g, o.path("gateway"), "a gateway name");
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end())
    fail(o.path("gateway"), "no gateway \"" + name + "\" in " +
                                (sc.config_file.empty() ? "the scenario" : sc.config_file) +
                                " (its gateways: " + quoted_names(names) + ")");
  s.gateway = static_cast<std::size_t>(it - names.begin());
  s.gateway_name = name;
}

// "slave": NAME → s.slave; optional for slave-only steps when there is one slave.
void resolve_slave(Step& s, const Object& o, const std::string& path, const std::string& key,
                   const Scenario& sc) {
  const auto& slaves = sc.installation.slaves;
  std::vector<std::string> names;
  for (const auto& x : slaves) names.push_back(x.name);
  const json* j = o.find("slave");
  if (!j) {
    if (slaves.size() != 1)
      fail(path, "\"" + key + "\" concerns one generic slave: give \"slave\"" +
                     (slaves.empty() ? std::string(" (the installation has none)")
                                     : ", one of " + quoted_names(names)));
    s.slave = 0;
    s.slave_name = slaves[0].name;
    return;
  }
  const std::string name = as_string(*j, o.path("slave"), "a slave name");
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end())
    fail(o.path("slave"), "no slave \"" + name + "\" in " +
                              (sc.config_file.empty() ? "the scenario" : sc.config_file) +
                              (names.empty() ? std::string(" (it has none)")
                                             : " (its slaves: " + quoted_names(names) + ")"));
  s.slave = static_cast<std::size_t>(it - names.begin());
  s.slave_name = name;
}

// inject: "bus": NAME or "gateway": NAME (that gateway's bus); the only bus otherwise.
void resolve_bus(Step& s, const Object& o, const std::string& path, const Scenario& sc) {
  const auto& buses = sc.installation.buses;
  std::vector<std::string> names;
  for (const auto& b : buses) names.push_back(b.name);
  std::string name;
  if (const json* b = o.find("bus")) {
    name = as_string(*b, o.path("bus"), "a bus name");
  } else if (o.has("gateway")) {
    Step tmp;
    resolve_gateway(tmp, o, path, "inject", sc);
    name = sc.installation.gateways[tmp.gateway].bus;
  } else if (buses.size() > 1) {
    fail(path, "\"inject\" with several buses: give \"bus\", one of " + quoted_names(names));
  } else {
    return;
  }
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end())
    fail(o.has("bus") ? o.path("bus") : path,
         "no bus \"" + name + "\" (the buses: " + quoted_names(names) + ")");
  s.bus = static_cast<std::size_t>(it - names.begin());
}

// "drive": NAME → s.drive; optional with one drive.
void resolve_drive(Step& s, const Object& o, const std::string& path, const std::string& key,
                   const std::string& vp, const Scenario& sc) {
  const auto& drives = sc.drives();
  if (drives.empty()) fail(vp, "\"" + key + "\" needs a \"drives\" entry in the scenario");
  if (const json* d = o.find("drive")) {
    const std::string name = as_string(*d, o.path("drive"), "a drive name");
    const auto it = std::find_if(drives.begin(), drives.end(),
                                 [&](const config::DriveConfig& c) { return c.name == name; });
    if (it == drives.end()) {
      std::vector<std::string> names;
      for (const auto& c : drives) names.push_back(c.name);
      fail(o.path("drive"),
           "no drive \"" + name + "\" in \"drives\" (" + quoted_names(names) + ")");
    }
    s.drive = static_cast<std::size_t>(it - drives.begin());
  } else if (drives.size() > 1) {
    fail(path, "\"" + key + "\" needs \"drive\": the name of one of the " +
                   std::to_string(drives.size()) + " drives");
  }
  s.drive_name = drives[s.drive].name;
}

// The one action key of a step, or none (a note).
const ActionSpec* action_of(const json& j, const std::string& path) {
  const ActionSpec* found = nullptr;
  for (const auto& a : actions()) {
    if (a.action == Action::Note || !j.contains(a.key)) continue;
    if (found)
      fail(path, "one action per step: both \"" + std::string(found->key) + "\" and \"" +
                     std::string(a.key) + "\" given");
    found = &a;
  }
  if (!found && !j.contains("note")) {
    std::vector<std::string> keys;
    for (const auto& a : actions())
      if (a.action != Action::Note) keys.emplace_back(a.key);
    fail(path, "a step needs one action (" + join(keys) + ") or a \"note\"");
  }
  return found;
}

}  // namespace

Step parse_step(const json& j, const std::string& path, const Scenario& sc) {
  if (!j.is_object()) fail(path, "expected a step object, got " + kind_of(j));
  Step s;
  s.path = path;
  const ActionSpec* found = action_of(j, path);
  const ActionSpec& a = found ? *found : spec(Action::Note);
  std::vector<std::string> allowed = {"at_ms", "note"};
  if (found) {
    s.action = found->action;
    allowed.emplace_back(found->key);
  }
  // The keys besides the action's (docs/replay-format.md): its window, what it concerns.
  if (!a.window.empty()) allowed.emplace_back(a.window);
  if (a.target == Target::Drive) allowed.push_back("drive");
  if (a.target == Target::Gateway || a.target == Target::Station) allowed.push_back("gateway");
  if (a.target == Target::Station || a.target == Target::Slave) allowed.push_back("slave");
  if (a.target == Target::Bus) allowed.insert(allowed.end(), {"bus", "gateway"});
  const Object o(j, path, allowed);
  if (o.has("note")) s.note = as_string(o.at("note"), o.path("note"), "a text", Empty::Allowed);
  if (o.has("at_ms")) s.at = as_ms(o.at("at_ms"), o.path("at_ms"));
  if (o.has("within_ms")) s.window = as_ms(o.at("within_ms"), o.path("within_ms"));
  if (o.has("for_ms")) s.window = as_ms(o.at("for_ms"), o.path("for_ms"));
  if (!found) return s;
  const std::string key(a.key);
  const std::string vp = o.path(key);
  if (a.target == Target::Driver && !sc.driver)
    fail(vp, "\"" + key + "\" needs a \"page_driver\" in the scenario");
  a.parse(s, StepInput{o.at(key), vp, key, sc, o.has("slave")});
  switch (a.target) {
    case Target::Slave:
    case Target::Station:
      if (a.target == Target::Slave || o.has("slave")) {
        if (o.has("gateway")) fail(path, "give \"gateway\" or \"slave\", not both");
        resolve_slave(s, o, path, key, sc);
      } else {
        resolve_gateway(s, o, path, key, sc);
      }
      break;
    case Target::Gateway:
      resolve_gateway(s, o, path, key, sc);
      break;
    case Target::Bus:
      resolve_bus(s, o, path, sc);
      break;
    case Target::Drive:
      resolve_drive(s, o, path, key, vp, sc);
      break;
    case Target::None:
    case Target::Driver:
      break;
  }
  return s;
}

}  // namespace candp2::replay::parse
