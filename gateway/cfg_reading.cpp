// What the CAN-DP/2 makes of one Chk_Cfg entry (gateway/cfg_reading.hpp).
#include "gateway/cfg_reading.hpp"

#include <algorithm>
#include <variant>
#include <vector>

#include "common/hex.hpp"

namespace candp2::gw {

namespace {

std::string bytes_text(std::size_t n) {
  return std::to_string(n) + (n == 1 ? " byte" : " bytes");
}

void append(std::vector<std::uint8_t>& out, const dp::CfgEntry& e) {
  const auto b = dp::encode_chk_cfg(std::span(&e, 1));
  out.insert(out.end(), b.begin(), b.end());
}

}  // namespace

std::string describe_slot(const Slot& s) {
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
  std::string t = std::string(in ? "Rx" : "Tx") +
                  (s.id->extended ? " 29-bit ID 0x" : " 11-bit ID 0x") + can::ident_text(*s.id) +
                  ", " + len + ", form " + hex8(s.form);
  if (s.cycle_ms) t += ", cycle " + std::to_string(s.cycle_ms) + " ms";
  return t;
}

std::optional<std::uint16_t> ignored_input_cycle(const Slot& s, const UserPrm& prm) {
  if (s.kind != SlotKind::Rx || s.length < 1 || s.length > 64) return std::nullopt;
  // The gateway drops the cycle of an input (docs/slots.md "Chk_Cfg slots"); read the same comment
  // bytes the way it reads an output's, with the same counter setting.
  UserPrm as_output = prm;
  as_output.page_mode = false;
  as_output.tx_counter = s.counter;
  std::vector<std::uint8_t> cfg;
  append(cfg, dp::special_output(static_cast<std::uint8_t>(s.length), s.consistent, s.comment));
  const auto r = decode_slots(cfg, as_output);
  const auto* c = std::get_if<SlotConfig>(&r);
  if (!c || c->slots.empty() || c->slots[0].cycle_ms == 0) return std::nullopt;
  return c->slots[0].cycle_ms;
}

EntryReading read_cfg_entry(std::span<const std::uint8_t> entry) {
  // Companion entries (see the header for the order of the contexts).
  const auto dummy = [](std::uint8_t len) {
    return dp::special_output(
        len, false,
        {static_cast<std::uint8_t>(kDummyTxId >> 8), static_cast<std::uint8_t>(kDummyTxId & 0xFF),
         0x00});  // manual §5.1.4
  };
  const dp::CfgEntry dummy_tx = dummy(1);
  // With the Tx-Counter on the dummy needs a data byte besides the counter byte (docs/slots.md
  // "Cfg fault codes" code 3).
  const dp::CfgEntry dummy_tx_counter = dummy(2);
  const std::vector<std::uint8_t> cw_comment = {kCommWindowIdHigh, kCommWindowIdLow, 0x00};
  const auto cw_len = static_cast<std::uint8_t>(kCommWindowLen);
  const auto seg_len = static_cast<std::uint8_t>(kSegmentLen);

  struct Context {
    const char* condition;
    UserPrm prm;
    std::vector<dp::CfgEntry> before, after;
    std::vector<std::uint8_t> cures;  // context 1 fault codes this context can cure
  };
  UserPrm counters, cw, page;
  counters.rx_counter = counters.tx_counter = true;
  cw.comm_window = true;
  page.page_mode = true;
  // A context is tried only when the fault of context 1 is one it can cure: the counters allow a
  // 9th byte (code 3), the CW flag and partner fix code 8, a segment has no identifier and up to
  // 32 bytes (codes 3, 4).
  const Context contexts[] = {
      {"", {}, {}, {dummy_tx}, {}},
      {"", counters, {}, {dummy_tx_counter}, {kCfgWrongLength}},
      {"Communication Window on",
       cw,
       {},
       {dp::special_input(cw_len, true, cw_comment)},
       {kCfgCommWindow}},
      {"Communication Window on",
       cw,
       {},
       {dp::special_output(cw_len, true, cw_comment)},
       {kCfgCommWindow}},
      {"Page-Mode on",
       page,
       {dp::special_input(seg_len, true, {}), dp::special_output(seg_len, true, {})},
       {},
       {kCfgWrongLength, kCfgIdentifierMissing}},
  };

  EntryReading r;
  for (std::size_t c = 0; c < std::size(contexts); ++c) {
    const Context& ctx = contexts[c];
    if (c > 0 && std::find(ctx.cures.begin(), ctx.cures.end(), r.fault_code) == ctx.cures.end())
      continue;
    std::vector<std::uint8_t> cfg;
    for (const auto& b : ctx.before) append(cfg, b);
    cfg.insert(cfg.end(), entry.begin(), entry.end());
    for (const auto& a : ctx.after) append(cfg, a);
    const auto decoded = decode_slots(cfg, ctx.prm);
    if (const auto* f = std::get_if<dp::CfgFault>(&decoded)) {
      if (c == 0) r.fault_code = f->code;
      continue;
    }
    const Slot& s = std::get<SlotConfig>(decoded).slots.at(ctx.before.size());
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
  r.problem = "Cfg fault code " + std::to_string(code) + ": " + std::string(cfg_code_text(code));
  return r;
}

}  // namespace candp2::gw
