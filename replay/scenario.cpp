#include "replay/scenario.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/hex.hpp"
#include "config/json_reader.hpp"

namespace candp2::replay {

using nlohmann::json;

// ---------------------------------------------------------------- patterns

bool BytePattern::matches(std::span<const std::uint8_t> actual) const {
  if (actual.size() < bytes.size()) return false;
  for (std::size_t i = 0; i < bytes.size(); ++i)
    if (care[i] && actual[i] != bytes[i]) return false;
  return true;
}

std::string BytePattern::text() const {
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (i) out += ' ';
    out += care[i] ? hex_bytes(std::span(&bytes[i], 1)) : "??";
  }
  return out;
}

bool FramePattern::matches(const can::Frame& f) const {
  if (any) return true;
  if (any_data) return !f.remote && f.id == frame.id && f.extended == frame.extended;
  return f == frame;
}

std::string FramePattern::text() const {
  if (any) return "*";
  if (!any_data) return can::format_candump(frame);
  std::string s = can::format_candump(frame);
  return s.substr(0, s.find('#') + 1) + "*";
}

std::string_view to_string(Db db) {
  switch (db) {
    case Db::WriteConfig:
      return "WRITE_CONFIG_DB";
    case Db::ReadConfig:
      return "READ_CONFIG_DB";
    case Db::Write:
      return "WRITE_DB";
    case Db::Read:
      return "READ_DB";
  }
  return "?";
}

namespace {

struct ActionName {
  Action action;
  const char* key;
};
// The step keys, one per action (docs/replay-format.md).
constexpr ActionName kActions[] = {
    {Action::Advance, "advance_ms"},
    {Action::Cycles, "cycles"},
    {Action::Write, "write"},
    {Action::Inject, "inject"},
    {Action::ExpectFrame, "expect_frame"},
    {Action::ExpectFrames, "expect_frames"},
    {Action::ExpectNoFrame, "expect_no_frame"},
    {Action::ExpectInput, "expect_input"},
    {Action::ExpectOutput, "expect_output"},
    {Action::ExpectDiag, "expect_diag"},
    {Action::ExpectDpState, "expect_dp_state"},
    {Action::Freigabe, "freigabe"},
    {Action::DbWrite, "db_write"},
    {Action::ExpectDb, "expect_db"},
    {Action::SetTx, "set_tx"},
    {Action::ExpectRx, "expect_rx"},
    {Action::ExpectRetValue, "expect_ret_value"},
    {Action::PowerCycle, "power_cycle"},
    {Action::Reparameterize, "reparameterize"},
    {Action::MasterStop, "master_stop"},
    {Action::MasterResume, "master_resume"},
    {Action::ForceCanState, "force_can_state"},
    {Action::DropRx, "drop_rx"},
    {Action::ExpectCounters, "expect_counters"},
    {Action::DriveMute, "drive_mute"},
    {Action::DriveErrorBits, "drive_error_bits"},
    {Action::DriveWarningBits, "drive_warning_bits"},
    {Action::DriveRestart, "drive_restart"},
};

// force_can_state values, as holding register 8193 (docs/faults.md).
constexpr const char* kCanStates[] = {"real", "warning", "error-passive", "bus-off"};

}  // namespace

std::string_view to_string(Action a) {
  if (a == Action::Note) return "note";
  for (const auto& n : kActions)
    if (n.action == a) return n.key;
  return "?";
}

bool Step::expectation() const {
  switch (action) {
    case Action::ExpectFrame:
    case Action::ExpectFrames:
    case Action::ExpectNoFrame:
    case Action::ExpectInput:
    case Action::ExpectOutput:
    case Action::ExpectDiag:
    case Action::ExpectDpState:
    case Action::ExpectDb:
    case Action::ExpectRx:
    case Action::ExpectRetValue:
    case Action::ExpectCounters:
      return true;
    default:
      return false;
  }
}

namespace {

std::string ms_text(Duration d) {
  const auto us = d.count();
  if (us % 1000 == 0) return std::to_string(us / 1000) + " ms";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f ms", static_cast<double>(us) / 1000.0);
  return buf;
}

std::string frames_text(const std::vector<FramePattern>& v) {
  std::string s;
  for (const auto& p : v) {
    if (!s.empty()) s += ' ';  // not `" " + p.text()`: GCC 12 -O3 false -Wrestrict
    s += p.text();
  }
  return s;
}

}  // namespace

std::string Step::describe() const {
  std::string s(to_string(action));
  auto window_text = [&](const char* word) {
    return window ? std::string(" ") + word + " " + ms_text(*window) : std::string();
  };
  switch (action) {
    case Action::Note:
      return "note";
    case Action::Advance:
      return s + " " + ms_text(advance);
    case Action::Cycles:
      return s + " " + std::to_string(cycles);
    case Action::Write:
      return s + " Q" + std::to_string(address) + ": " + hex_bytes(bytes);
    case Action::Inject: {
      std::string f;
      for (const auto& fr : frames) f += (f.empty() ? "" : " ") + can::format_candump(fr);
      return s + " " + f;
    }
    case Action::ExpectFrame:
    case Action::ExpectFrames:
      return s + " " + frames_text(frame_patterns) + window_text("within");
    case Action::ExpectNoFrame:
      return s + " " + frames_text(frame_patterns) + window_text("for");
    case Action::ExpectInput:
      return s + " I" + std::to_string(address) + ": " + pattern.text() + window_text("within");
    case Action::ExpectOutput:
      return s + " Q" + std::to_string(address) + ": " + pattern.text() + window_text("within");
    case Action::ExpectDiag:
      return s + " " + pattern.text() + window_text("within");
    case Action::ExpectDpState:
      return s + " " + std::string(dp::to_string(dp_state)) + window_text("within");
    case Action::Freigabe:
      return s + (on ? " 1" : " 0");
    case Action::DbWrite:
      return s + " " + std::string(to_string(db)) + "[" + std::to_string(db_index) + "]+" +
             std::to_string(offset) + ": " + hex_bytes(bytes);
    case Action::ExpectDb:
      return s + " " + std::string(to_string(db)) + "[" + std::to_string(db_index) + "]+" +
             std::to_string(offset) + ": " + pattern.text() + window_text("within");
    case Action::SetTx:
      return s + " " + std::to_string(entry) +
             (force ? " force " + std::to_string(*force) : std::string()) +
             (has_data ? " data " + hex_bytes(bytes) : std::string());
    case Action::ExpectRx:
      return s + " " + std::to_string(entry) +
             (count_in ? " count_in " + std::to_string(*count_in) : std::string()) +
             (has_data ? " data " + pattern.text() : std::string()) + window_text("within");
    case Action::ExpectRetValue:
      return s + " " + std::to_string(ret_value) + window_text("within");
    case Action::PowerCycle:
    case Action::Reparameterize:
    case Action::MasterStop:
    case Action::MasterResume:
      return s;
    case Action::ForceCanState:
      return s + " " + kCanStates[can_state];
    case Action::DropRx:
      return s + " " + std::to_string(count);
    case Action::ExpectCounters: {
      std::string c;
      for (const auto& [name, value] : counters)
        c += (c.empty() ? " " : ", ") + name + " " + std::to_string(value);
      return s + c + window_text("within");
    }
    case Action::DriveMute:
      return s + " " + drive_name + (on ? " on" : " off");
    case Action::DriveErrorBits:
    case Action::DriveWarningBits: {
      char b[8];
      std::snprintf(b, sizeof b, "%04X", static_cast<unsigned>(bits));
      return s + " " + drive_name + " 0x" + b;
    }
    case Action::DriveRestart:
      return s + " " + drive_name;
  }
  return s;
}

// ---------------------------------------------------------------- JSON helpers

namespace {

using namespace config::json_reader;

Duration as_ms(const json& j, const std::string& path, std::uint64_t max = 86400000) {
  return milliseconds(as_uint(j, path, 0, max, "ms"));
}

BytePattern as_pattern(const json& j, const std::string& path) {
  const std::string text = as_string(j, path, "hex bytes like \"00 33 ?? 00\" (?? = any byte)");
  BytePattern p;
  std::size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    if (c == ' ' || c == ',' || c == '\t') {
      ++i;
      continue;
    }
    if (i + 1 < text.size() && c == '?' && text[i + 1] == '?') {
      p.bytes.push_back(0);
      p.care.push_back(false);
      i += 2;
      continue;
    }
    if (i + 1 >= text.size() || hex_digit(c) < 0 || hex_digit(text[i + 1]) < 0)
      fail(path, "position " + std::to_string(i) +
                     ": expected two hex digits or ?? per byte, e.g. \"00 33 ?? 00\"");
    p.bytes.push_back(static_cast<std::uint8_t>((hex_digit(c) << 4) | hex_digit(text[i + 1])));
    p.care.push_back(true);
    i += 2;
  }
  if (p.bytes.empty()) fail(path, "no bytes given");
  return p;
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
                 {"write_address", "read_address", "output_page_len", "freigabe", "init_delay_ms",
                  "ack_timeout_ms", "retry_delay_ms", "tx", "rx", "ids_per_db", "write_config_db",
                  "read_config_db", "write_db", "read_db"});
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

dp::SlaveState as_dp_state(const json& j, const std::string& path) {
  const std::string s = as_string(j, path, "a DP state");
  if (s == "wait_prm") return dp::SlaveState::WaitPrm;
  if (s == "wait_cfg") return dp::SlaveState::WaitCfg;
  if (s == "data_exch") return dp::SlaveState::DataExch;
  fail(path, "expected \"wait_prm\", \"wait_cfg\" or \"data_exch\", got " + kind_of(j));
}

Step parse_step(const json& j, const std::string& path, const Scenario& sc) {
  if (!j.is_object()) fail(path, "expected a step object, got " + kind_of(j));
  Step s;
  s.path = path;
  // Exactly one action key (or none: a note).
  const ActionName* found = nullptr;
  for (const auto& a : kActions) {
    if (!j.contains(a.key)) continue;
    if (found)
      fail(path, std::string("one action per step: both \"") + found->key + "\" and \"" + a.key +
                     "\" given");
    found = &a;
  }
  std::vector<std::string> allowed = {"at_ms", "note"};
  if (found) {
    s.action = found->action;
    allowed.push_back(found->key);
  }
  const bool windowed = s.expectation() && s.action != Action::ExpectNoFrame;
  if (windowed) allowed.push_back("within_ms");
  if (s.action == Action::ExpectNoFrame) allowed.push_back("for_ms");
  const bool drive_step = s.action == Action::DriveMute || s.action == Action::DriveErrorBits ||
                          s.action == Action::DriveWarningBits || s.action == Action::DriveRestart;
  if (drive_step) allowed.push_back("drive");
  if (!found && !j.contains("note")) {
    std::vector<std::string> keys;
    for (const auto& a : kActions) keys.push_back(a.key);
    fail(path, "a step needs one action (" + join(keys) + ") or a \"note\"");
  }
  const Object o(j, path, allowed);
  if (o.has("note")) s.note = as_string(o.at("note"), o.path("note"), "a text", Empty::Allowed);
  if (o.has("at_ms")) s.at = as_ms(o.at("at_ms"), o.path("at_ms"));
  if (o.has("within_ms")) s.window = as_ms(o.at("within_ms"), o.path("within_ms"));
  if (o.has("for_ms")) s.window = as_ms(o.at("for_ms"), o.path("for_ms"));
  if (!found) return s;
  const std::string key = found->key;
  const json& v = o.at(key);
  const std::string vp = o.path(key);
  auto need_driver = [&] {
    if (!sc.driver) fail(vp, "\"" + key + "\" needs a \"page_driver\" in the scenario");
  };
  switch (s.action) {
    case Action::Note:
      break;
    case Action::Advance:
      s.advance = as_ms(v, vp);
      break;
    case Action::Cycles:
      s.cycles = static_cast<std::uint32_t>(as_uint(v, vp, 1, 1000000, "DP cycles"));
      break;
    case Action::Write:
    case Action::ExpectInput:
    case Action::ExpectOutput: {
      const Object w(v, vp, {"address", "bytes"});
      s.address = static_cast<std::uint16_t>(
          as_uint(w.at("address"), w.path("address"), 0, dp::kImageSize - 1, "(PLC byte address)"));
      if (s.action == Action::Write) {
        s.bytes = as_hex(w.at("bytes"), w.path("bytes"), "00 33 01 00");
        if (s.address + s.bytes.size() > dp::kImageSize)
          fail(w.path("bytes"), "the bytes run past the end of the 8192-byte process image");
      } else {
        s.pattern = as_pattern(w.at("bytes"), w.path("bytes"));
        if (s.address + s.pattern.size() > dp::kImageSize)
          fail(w.path("bytes"), "the bytes run past the end of the 8192-byte process image");
      }
      break;
    }
    case Action::Inject:
      if (v.is_array()) {
        if (v.empty()) fail(vp, "expected at least one frame");
        for (std::size_t i = 0; i < v.size(); ++i)
          s.frames.push_back(as_frame(v[i], element(vp, i)));
      } else {
        s.frames.push_back(as_frame(v, vp));
      }
      break;
    case Action::ExpectFrame:
    case Action::ExpectNoFrame:
      s.frame_patterns.push_back(as_frame_pattern(v, vp));
      break;
    case Action::ExpectFrames:
      if (!v.is_array()) fail(vp, "expected an array of frames, got " + kind_of(v));
      for (std::size_t i = 0; i < v.size(); ++i)
        s.frame_patterns.push_back(as_frame_pattern(v[i], element(vp, i)));
      break;
    case Action::ExpectDiag:
      s.pattern = as_pattern(v, vp);
      if (s.pattern.size() != dp::DpSlave::kDiagLen)
        fail(vp, "expected the 11 diagnosis bytes (emulator-spec §3), got " +
                     std::to_string(s.pattern.size()));
      break;
    case Action::ExpectDpState:
      s.dp_state = as_dp_state(v, vp);
      break;
    case Action::Freigabe:
      need_driver();
      s.on = v.is_boolean() ? v.get<bool>() : as_uint(v, vp, 0, 1) == 1;
      break;
    case Action::DbWrite:
    case Action::ExpectDb: {
      need_driver();
      const Object w(v, vp, {"db", "index", "offset", "bytes"});
      s.db = as_db(w.at("db"), w.path("db"));
      s.db_index = w.has("index") ? as_uint(w.at("index"), w.path("index"), 0, 1000) : 0;
      s.offset = as_uint(w.at("offset"), w.path("offset"), 0, 65535, "(byte in the DB)");
      if (s.action == Action::DbWrite)
        s.bytes = as_hex(w.at("bytes"), w.path("bytes"), "02 01 02 03");
      else
        s.pattern = as_pattern(w.at("bytes"), w.path("bytes"));
      break;
    }
    case Action::SetTx:
    case Action::ExpectRx: {
      need_driver();
      const bool tx = s.action == Action::SetTx;
      const Object w(v, vp,
                     tx ? std::vector<std::string>{"id", "force", "data"}
                        : std::vector<std::string>{"id", "count_in", "data"});
      s.entry = as_uint(w.at("id"), w.path("id"), 1, gw::page::kMaxIdentifiers,
                        tx ? "(Tx identifier number: 1 = TxId1)" : "(Rx identifier number)");
      if (tx && w.has("force"))
        s.force = static_cast<std::uint8_t>(as_uint(w.at("force"), w.path("force"), 0, 255));
      if (!tx && w.has("count_in"))
        s.count_in =
            static_cast<std::uint8_t>(as_uint(w.at("count_in"), w.path("count_in"), 0, 255));
      if (w.has("data")) {
        s.has_data = true;
        if (tx)
          s.bytes = as_hex(w.at("data"), w.path("data"), "00 11 22 33 44 55");
        else
          s.pattern = as_pattern(w.at("data"), w.path("data"));
      }
      if (!s.has_data && !s.force && !s.count_in)
        fail(vp, tx ? "give \"force\" and/or \"data\"" : "give \"count_in\" and/or \"data\"");
      break;
    }
    case Action::ExpectRetValue:
      need_driver();
      s.ret_value = static_cast<std::uint16_t>(as_uint(v, vp, 0, 4, "(manual table 6.5.7)"));
      break;
    case Action::PowerCycle:
    case Action::Reparameterize:
    case Action::MasterStop:
    case Action::MasterResume:
      if (!v.is_boolean() || !v.get<bool>()) fail(vp, "expected true, got " + kind_of(v));
      break;
    case Action::ForceCanState: {
      const std::string t = v.is_string() ? v.get<std::string>() : "";
      bool ok = false;
      for (std::uint16_t i = 0; i < 4; ++i)
        if (t == kCanStates[i]) {
          s.can_state = i;
          ok = true;
        }
      if (!ok)
        fail(vp,
             "expected \"real\", \"warning\", \"error-passive\" or \"bus-off\", got " + kind_of(v));
      break;
    }
    case Action::DropRx:
      s.count = static_cast<std::uint32_t>(as_uint(v, vp, 0, 65535, "frames"));
      break;
    case Action::ExpectCounters: {
      static const std::vector<std::string> kNames = {
          "irq_lost", "msg_lost", "rx_frames", "tx_frames", "tx_suppressed", "rx_suppressed"};
      const Object w(v, vp, kNames);
      for (const auto& n : kNames)
        if (w.has(n))
          s.counters.emplace_back(
              n, static_cast<std::uint32_t>(as_uint(w.at(n), w.path(n), 0, 0xFFFFFFFFull)));
      if (s.counters.empty()) fail(vp, "give at least one counter (" + join(kNames) + ")");
      break;
    }
    case Action::DriveMute:
      s.on = v.is_boolean() ? v.get<bool>() : as_uint(v, vp, 0, 1) == 1;
      break;
    case Action::DriveErrorBits:
    case Action::DriveWarningBits:
      s.bits = static_cast<std::uint16_t>(as_uint(v, vp, 0, 0xFFFF, "(ERR_BITMAP1 0x8F bits)"));
      break;
    case Action::DriveRestart:
      if (!v.is_boolean() || !v.get<bool>()) fail(vp, "expected true, got " + kind_of(v));
      break;
  }
  if (drive_step) {
    if (sc.drives.empty()) fail(vp, "\"" + key + "\" needs a \"drives\" entry in the scenario");
    if (const json* d = o.find("drive")) {
      const std::string name = as_string(*d, o.path("drive"), "a drive name");
      const auto it = std::find_if(sc.drives.begin(), sc.drives.end(),
                                   [&](const config::DriveConfig& c) { return c.name == name; });
      if (it == sc.drives.end()) {
        std::vector<std::string> names;
        for (const auto& c : sc.drives) names.push_back("\"" + c.name + "\"");
        fail(o.path("drive"), "no drive \"" + name + "\" in \"drives\" (" + join(names) + ")");
      }
      s.drive = static_cast<std::size_t>(it - sc.drives.begin());
    } else if (sc.drives.size() > 1) {
      fail(path, "\"" + key + "\" needs \"drive\": the name of one of the " +
                     std::to_string(sc.drives.size()) + " drives");
    }
    s.drive_name = sc.drives[s.drive].name;
  }
  return s;
}

// "drives": entries as in the daemon's "drives" array, on the scenario's one bus (the gateway's).
void parse_drives(const json& j, const std::string& path, Scenario& sc) {
  if (!j.is_array()) fail(path, "expected an array of drives, got " + kind_of(j));
  for (std::size_t i = 0; i < j.size(); ++i) {
    const std::string p = element(path, i);
    auto r = config::parse_drive_entry(j[i], sc.file, p);
    if (auto* e = std::get_if<config::ConfigError>(&r)) throw Failure{e->json_path, e->message};
    auto d = std::move(std::get<config::DriveConfig>(r));
    if (d.bus != sc.gateway.bus)
      fail(member(p, "bus"), "a scenario has one bus, the gateway's \"" + sc.gateway.bus +
                                 "\"; got \"" + d.bus + "\"");
    if (d.state_file)
      fail(member(p, "state_file"),
           "a replay keeps no state file (every run starts from the drive's defaults)");
    for (const auto& other : sc.drives)
      if (other.name == d.name)
        fail(member(p, "name"),
             "the name \"" + d.name + "\" is already used by " + other.json_path);
    sc.drives.push_back(std::move(d));
  }
}

Scenario parse_or_throw(const std::string& text, const std::string& file) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    fail("", std::string("not valid JSON: ") + e.what());
  }
  const Object o(j, "$",
                 {"format", "version", "name", "description", "cycle_ms", "master_address",
                  "gateway", "page_driver", "drives", "steps"});
  Scenario sc;
  sc.file = file;
  const std::string format = as_string(o.at("format"), o.path("format"), "\"candp2-replay\"");
  if (format != kFormat)
    fail(o.path("format"), "expected \"candp2-replay\", got \"" + format + "\"");
  const auto version = as_uint(o.at("version"), o.path("version"), 1, 1000);
  if (version != kVersion)
    fail(o.path("version"), "this candp2 reads version " + std::to_string(kVersion) + ", got " +
                                std::to_string(version));
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
  auto g = config::parse_gateway(o.at("gateway"), file, o.path("gateway"));
  if (auto* e = std::get_if<config::ConfigError>(&g)) throw Failure{e->json_path, e->message};
  sc.gateway = std::move(std::get<config::GatewayConfig>(g));
  sc.warnings = sc.gateway.warnings;
  if (const json* d = o.find("page_driver"))
    sc.driver = parse_driver(*d, o.path("page_driver"), sc.gateway);
  if (const json* d = o.find("drives")) parse_drives(*d, o.path("drives"), sc);
  const json& steps = o.at("steps");
  if (!steps.is_array()) fail(o.path("steps"), "expected an array of steps, got " + kind_of(steps));
  for (std::size_t i = 0; i < steps.size(); ++i)
    sc.steps.push_back(parse_step(steps[i], element(o.path("steps"), i), sc));
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
