#include "gsd/cfg.hpp"

#include <algorithm>
#include <cstdio>
#include <variant>

#include "common/hex.hpp"

namespace candp2::gsd {

namespace {

std::string hex8(unsigned v) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "0x%02X", v & 0xFFu);
  return buf;
}

std::string hex_id(std::uint32_t v, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%0*X", digits, v);
  return buf;
}

std::string bytes_text(std::size_t n) {
  return std::to_string(n) + (n == 1 ? " byte" : " bytes");
}

std::vector<std::uint8_t> encode_one(const dp::CfgEntry& e) {
  return dp::encode_chk_cfg(std::span(&e, 1));
}

void append(std::vector<std::uint8_t>& out, const dp::CfgEntry& e) {
  const auto b = encode_one(e);
  out.insert(out.end(), b.begin(), b.end());
}

}  // namespace

bool CfgEntry::input() const {
  return decoded.io == dp::CfgIo::Input || decoded.io == dp::CfgIo::InputOutput;
}

bool CfgEntry::output() const {
  return decoded.io == dp::CfgIo::Output || decoded.io == dp::CfgIo::InputOutput;
}

CfgDecode decode_config(std::span<const std::uint8_t> cfg) {
  CfgDecode out;
  const dp::CfgDecodeResult r = dp::decode_chk_cfg(cfg);
  std::size_t end = 0;  // where the next entry starts
  for (const auto& d : r.entries) {
    CfgEntry e;
    e.decoded = d;
    e.offset = d.offset;
    // The entry's extent: its encoding has the same length as its bytes (identifier, length
    // bytes, manufacturer bytes), so the decoder stays the single authority on the formats.
    e.size = encode_one(d).size();
    e.bytes.assign(cfg.begin() + static_cast<std::ptrdiff_t>(e.offset),
                   cfg.begin() + static_cast<std::ptrdiff_t>(e.offset + e.size));
    end = e.offset + e.size;
    out.input_len += e.input_len();
    out.output_len += e.output_len();
    out.entries.push_back(std::move(e));
  }
  if (r.error && end < cfg.size())
    out.error = "byte " + std::to_string(end) + " (" + hex8(cfg[end]) + "): " + r.error->message;
  return out;
}

std::string describe(const CfgEntry& e) {
  const dp::CfgEntry& d = e.decoded;
  auto part = [](const char* dir, std::size_t len, bool words, bool consistent) {
    std::string s = std::string(dir) + " " + bytes_text(len);
    if (words) s += " (" + std::to_string(len / 2) + (len == 2 ? " word)" : " words)");
    if (consistent) s += " consistent";
    return s;
  };
  std::string s;
  if (e.output()) s = part("output", e.output_len(), d.words, d.consistent);
  if (e.input()) {
    if (!s.empty()) s += ", ";
    const bool words = d.io == dp::CfgIo::InputOutput ? d.in_words : d.words;
    s += part("input", e.input_len(), words, d.consistent);
  }
  if (s.empty()) s = "no data (empty slot)";
  if (!d.manufacturer.empty()) s += ", manufacturer bytes " + hex_bytes(d.manufacturer);
  return s;
}

bool is_universal_module(std::span<const std::uint8_t> config) {
  return config.size() == 1 && config[0] == 0x00;
}

std::string describe_slot(const gw::Slot& s) {
  using gw::SlotKind;
  switch (s.kind) {
    case SlotKind::CwIn:
    case SlotKind::CwOut: {
      const bool in = s.kind == SlotKind::CwIn;
      std::string t = std::string("Communication Window ") +
                      (in ? "read (input)" : "write (output)") + ", form " + hex8(s.form);
      // manual §5.3.2 / docs/communication-window.md: comment bytes 4-5, 00 00 = not given.
      t += s.cw_sync_ms ? ", SYNC time " + std::to_string(s.cw_sync_ms) + " ms" : ", no SYNC time";
      return t;
    }
    case SlotKind::SegmentIn:
    case SlotKind::SegmentOut:
      return std::string("Page-Mode ") + (s.kind == SlotKind::SegmentIn ? "input" : "output") +
             " segment, " + bytes_text(s.length);
    case SlotKind::Rx:
    case SlotKind::Tx:
      break;
  }
  const bool in = s.kind == SlotKind::Rx;
  std::string len = bytes_text(s.length);
  if (s.counter)
    len += " (" + std::to_string(s.data_len) + " data + " + (in ? "Rx" : "Tx") + "-Counter)";
  if (!s.id)  // manual §5.1.4: output without CAN assignment
    return "Tx without CAN identifier (0x07F8 dummy), " + len;
  std::string t =
      std::string(in ? "Rx" : "Tx") +
      (s.id->extended ? " 29-bit ID " + hex_id(s.id->id, 8) : " 11-bit ID " + hex_id(s.id->id, 3)) +
      ", " + len + ", form " + hex8(s.form);
  if (s.cycle_ms) t += ", cycle " + std::to_string(s.cycle_ms) + " ms";
  return t;
}

std::optional<std::uint16_t> ignored_input_cycle(const gw::Slot& s, const gw::UserPrm& prm) {
  if (s.kind != gw::SlotKind::Rx || s.length < 1 || s.length > 64) return std::nullopt;
  // The gateway drops the cycle of an input (docs/slots.md "Chk_Cfg slots"); read the same comment
  // bytes the way it reads an output's, with the same counter setting.
  gw::UserPrm as_output = prm;
  as_output.page_mode = false;
  as_output.tx_counter = s.counter;
  std::vector<std::uint8_t> cfg;
  append(cfg, dp::special_output(static_cast<std::uint8_t>(s.length), s.consistent, s.comment));
  const auto r = gw::decode_slots(cfg, as_output);
  const auto* c = std::get_if<gw::SlotConfig>(&r);
  if (!c || c->slots.empty() || c->slots[0].cycle_ms == 0) return std::nullopt;
  return c->slots[0].cycle_ms;
}

CanDp2Slot describe_candp2(const CfgEntry& e) {
  // Companion entries (see the header for the order of the contexts).
  const auto dummy = [](std::uint8_t len) {
    return dp::special_output(
        len, false,
        {static_cast<std::uint8_t>(gw::kDummyTxId >> 8),
         static_cast<std::uint8_t>(gw::kDummyTxId & 0xFF), 0x00});  // manual §5.1.4
  };
  const dp::CfgEntry dummy_tx = dummy(1);
  // With the Tx-Counter on the dummy needs a data byte besides the counter byte (docs/slots.md
  // "Cfg fault codes" code 3).
  const dp::CfgEntry dummy_tx_counter = dummy(2);
  const std::vector<std::uint8_t> cw_comment = {gw::kCommWindowIdHigh, gw::kCommWindowIdLow, 0x00};
  const auto cw_len = static_cast<std::uint8_t>(gw::kCommWindowLen);
  const auto seg_len = static_cast<std::uint8_t>(gw::kSegmentLen);

  struct Context {
    const char* condition;
    gw::UserPrm prm;
    std::vector<dp::CfgEntry> before, after;
    std::vector<std::uint8_t> cures;  // context 1 fault codes this context can cure
  };
  gw::UserPrm counters, cw, page;
  counters.rx_counter = counters.tx_counter = true;
  cw.comm_window = true;
  page.page_mode = true;
  // A context is tried only when the fault of context 1 is one it can cure: the counters allow a
  // 9th byte (code 3), the CW flag and partner fix code 8, a segment has no identifier and up to
  // 32 bytes (codes 3, 4).
  const Context contexts[] = {
      {"", {}, {}, {dummy_tx}, {}},
      {"", counters, {}, {dummy_tx_counter}, {gw::kCfgWrongLength}},
      {"Communication Window on",
       cw,
       {},
       {dp::special_input(cw_len, true, cw_comment)},
       {gw::kCfgCommWindow}},
      {"Communication Window on",
       cw,
       {},
       {dp::special_output(cw_len, true, cw_comment)},
       {gw::kCfgCommWindow}},
      {"Page-Mode on",
       page,
       {dp::special_input(seg_len, true, {}), dp::special_output(seg_len, true, {})},
       {},
       {gw::kCfgWrongLength, gw::kCfgIdentifierMissing}},
  };

  CanDp2Slot r;
  for (std::size_t c = 0; c < std::size(contexts); ++c) {
    const Context& ctx = contexts[c];
    if (c > 0 && std::find(ctx.cures.begin(), ctx.cures.end(), r.fault_code) == ctx.cures.end())
      continue;
    std::vector<std::uint8_t> cfg;
    for (const auto& b : ctx.before) append(cfg, b);
    cfg.insert(cfg.end(), e.bytes.begin(), e.bytes.end());
    for (const auto& a : ctx.after) append(cfg, a);
    const auto decoded = gw::decode_slots(cfg, ctx.prm);
    if (const auto* f = std::get_if<dp::CfgFault>(&decoded)) {
      if (c == 0) r.fault_code = f->code;
      continue;
    }
    const gw::Slot& s = std::get<gw::SlotConfig>(decoded).slots.at(ctx.before.size());
    r.slot = s;
    r.fault_code.reset();
    r.condition = ctx.condition;
    if (c == 1) r.condition = s.is_input() ? "Rx-Counter on" : "Tx-Counter on";
    r.ignored_cycle = ignored_input_cycle(s, ctx.prm);
    r.text = describe_slot(s);
    if (r.ignored_cycle)
      r.text += ", cycle " + std::to_string(*r.ignored_cycle) + " ms ignored on an input";
    if (!r.condition.empty()) r.text += " (valid only with " + r.condition + ")";
    return r;
  }
  const std::uint8_t code = r.fault_code.value_or(0);
  r.problem =
      "Cfg fault code " + std::to_string(code) + ": " + std::string(gw::cfg_code_text(code));
  return r;
}

}  // namespace candp2::gsd
