#include "gateway/slot_config.hpp"

#include <algorithm>
#include <map>
#include <string>

#include "common/hex.hpp"

namespace candp2::gw {

std::string_view cfg_code_text(std::uint8_t code) {
  switch (code) {
    case kCfgWrongIoType:
      return "wrong I/O type (must be input or output)";
    case kCfgWrongUnit:
      return "wrong unit (must be byte)";
    case kCfgWrongLength:
      return "wrong length (1..8 data bytes, +1 with counter; 16 for the CW)";
    case kCfgIdentifierMissing:
      return "identifier missing or only one byte given";
    case kCfgFormatMissing:
      return "format byte missing";
    case kCfgWrongIdentifier:
      return "wrong identifier";
    case kCfgLimitsExceeded:
      return "limits exceeded (48 slots, 244 in, 244 out, 300 total)";
    case kCfgCommWindow:
      return "Communication Window misconfigured";
    case kCfgPageLayout:
      return "Page-Mode segment layout broken";
    case kCfgNoOutput:
      return "no output slot (at least one is required)";
  }
  return "unknown code";
}

std::string_view to_string(SlotKind k) {
  switch (k) {
    case SlotKind::Rx:
      return "rx";
    case SlotKind::Tx:
      return "tx";
    case SlotKind::CwIn:
      return "cw-in";
    case SlotKind::CwOut:
      return "cw-out";
    case SlotKind::SegmentIn:
      return "segment-in";
    case SlotKind::SegmentOut:
      return "segment-out";
  }
  return "?";
}

namespace {

using dp::CfgEntry;
using dp::CfgFault;
using dp::CfgIo;

CfgFault fault(std::size_t slot, std::uint8_t code) {
  return CfgFault{static_cast<std::uint8_t>(std::min<std::size_t>(slot, 255)), code};
}

bool is_cw_comment(const std::vector<std::uint8_t>& m) {
  return m.size() >= 2 && m[0] == kCommWindowIdHigh && m[1] == kCommWindowIdLow;
}

struct Totals {
  std::size_t in = 0, out = 0;
};

// docs/slots.md "Chk_Cfg slots" code 7: > 48 slots, > 244 input or output bytes, > 300 in total.
bool over_limits(std::size_t slot_count, const Totals& t) {
  return slot_count > kMaxSlots || t.in > kMaxInputLen || t.out > kMaxOutputLen ||
         t.in + t.out > kMaxDataLen;
}

std::uint32_t be32(const std::vector<std::uint8_t>& m, std::size_t at) {
  return (std::uint32_t{m[at]} << 24) | (std::uint32_t{m[at + 1]} << 16) |
         (std::uint32_t{m[at + 2]} << 8) | m[at + 3];
}

// Normal-mode slot, checks in the order of docs/slots.md "Chk_Cfg slots" (codes 1..6; 7 by the
// caller).
std::variant<Slot, std::uint8_t> normal_slot(const CfgEntry& e, const UserPrm& prm) {
  Slot s;
  if (!e.special || (e.io != CfgIo::Input && e.io != CfgIo::Output)) return kCfgWrongIoType;
  if (e.words) return kCfgWrongUnit;
  const bool input = e.io == CfgIo::Input;
  const auto& m = e.manufacturer;
  const bool cw = is_cw_comment(m);
  const bool counter = !cw && (input ? prm.rx_counter : prm.tx_counter);
  const std::size_t len = e.count;
  if (cw) {
    if (len != kCommWindowLen) return kCfgWrongLength;
  } else if (const std::size_t extra = counter ? 1u : 0u; len < 1 + extra || len > 8 + extra) {
    // docs/slots.md "Cfg fault codes" code 3: 1..8 data bytes, plus the counter byte when the
    // Rx-/Tx-Counter is on (a counter byte alone carries no data).
    return kCfgWrongLength;
  }
  if (m.size() <= 1) return kCfgIdentifierMissing;
  if (m.size() == 2) return kCfgFormatMissing;
  s.length = len;
  s.consistent = e.consistent;
  s.comment = m;
  if (cw) {
    // manual §5.3.2: FF EF, form, optional SYNC time (comment bytes 4-5).
    if (m.size() != 3 && m.size() != 5) return kCfgWrongIdentifier;
    s.kind = input ? SlotKind::CwIn : SlotKind::CwOut;
    s.data_len = len;
    s.form = m[2];
    if (m.size() == 5) s.cw_sync_ms = static_cast<std::uint16_t>((m[3] << 8) | m[4]);
    return s;
  }
  const bool bit29 = m[0] & 0x20;  // manual §5.2.1: bit 29 of a 4-byte identifier
  std::uint32_t id = 0;
  bool extended = false;
  std::size_t pos = 0;
  if (m.size() == 3 || (m.size() == 5 && !bit29)) {
    id = (std::uint32_t{m[0]} << 8) | m[1];
    pos = 2;
    if (id > can::kMaxStdId) return kCfgWrongIdentifier;
  } else if (m.size() == 4 && bit29) {
    return kCfgFormatMissing;  // 29-bit identifier without the format byte
  } else if ((m.size() == 5 || m.size() == 7) && bit29) {
    id = be32(m, 0) & can::kMaxExtId;
    extended = true;
    pos = 4;
  } else {
    return kCfgWrongIdentifier;  // m = 4 (11-bit, half a cycle), 6, 7 without bit 29, >= 8
  }
  s.form = m[pos++];
  if (pos < m.size()) s.cycle_ms = static_cast<std::uint16_t>((m[pos] << 8) | m[pos + 1]);
  s.kind = input ? SlotKind::Rx : SlotKind::Tx;
  s.counter = counter;
  s.data_len = len - (counter ? 1 : 0);
  if (!input && !extended && id == kDummyTxId) {
    s.id.reset();  // manual §5.1.4: dummy output, nothing is sent
  } else {
    s.id = can::Ident{id, extended};
  }
  // Cycle bytes on an input slot are ignored (docs/slots.md "Comment bytes").
  if (input) s.cycle_ms = 0;
  return s;
}

}  // namespace

std::variant<SlotConfig, dp::CfgFault> decode_slots(std::span<const std::uint8_t> cfg,
                                                    const UserPrm& prm) {
  const auto decoded = dp::decode_chk_cfg(cfg);
  SlotConfig out;
  out.page_mode = prm.page_mode;
  Totals totals;
  std::map<can::Ident, SlotKind> used;  // identifier -> Rx or Tx, for the clash rule
  std::size_t cw_in_count = 0, cw_out_count = 0;
  // Page-Mode bookkeeping (docs/page-mode.md "Segments").
  std::optional<std::size_t> short_in, short_out;  // a segment below 32 bytes: must be the last
  bool cw_seen = false;

  for (std::size_t i = 0; i < decoded.entries.size(); ++i) {
    const CfgEntry& e = decoded.entries[i];
    Slot s;
    const bool cw = e.special && is_cw_comment(e.manufacturer);
    if (prm.page_mode && !cw) {
      // A segment: input or output, no comment bytes, consistent, 1..32 bytes, 32 unless last.
      if (cw_seen) return fault(i, kCfgCommWindow);  // CW slots come after all segments
      if ((e.io != CfgIo::Input && e.io != CfgIo::Output) || e.words || !e.manufacturer.empty() ||
          !e.consistent || e.count < 1 || e.count > kSegmentLen)
        return fault(i, kCfgPageLayout);
      const bool input = e.io == CfgIo::Input;
      auto& short_seg = input ? short_in : short_out;
      if (short_seg) return fault(*short_seg, kCfgPageLayout);  // a short segment was not last
      if (e.count < kSegmentLen) short_seg = i;
      s.kind = input ? SlotKind::SegmentIn : SlotKind::SegmentOut;
      s.length = s.data_len = e.count;
      s.consistent = true;
    } else {
      auto r = normal_slot(e, prm);
      if (auto* code = std::get_if<std::uint8_t>(&r)) return fault(i, *code);
      s = std::move(std::get<Slot>(r));
      if (s.id && (s.kind == SlotKind::Rx || s.kind == SlotKind::Tx)) {
        auto [it, inserted] = used.emplace(*s.id, s.kind);
        // manual §2.2: one identifier cannot be used for both Tx and Rx.
        if (!inserted && it->second != s.kind) return fault(i, kCfgWrongIdentifier);
      }
    }
    s.index = i;
    const bool input = s.is_input();
    s.offset = input ? totals.in : totals.out;
    (input ? totals.in : totals.out) += s.length;
    if (over_limits(i + 1, totals)) return fault(i, kCfgLimitsExceeded);
    if (s.kind == SlotKind::CwIn || s.kind == SlotKind::CwOut) {
      cw_seen = true;
      // docs/slots.md "Chk_Cfg slots" code 8: the Prm CW flag, one CW per direction, whole-length
      // consistency.
      if (!prm.comm_window) return fault(i, kCfgCommWindow);
      auto& count = s.kind == SlotKind::CwIn ? cw_in_count : cw_out_count;
      if (++count > 1 || !s.consistent) return fault(i, kCfgCommWindow);
      (s.kind == SlotKind::CwIn ? out.cw_in : out.cw_out) = i;
    }
    out.slots.push_back(std::move(s));
  }
  if (decoded.error) {
    // A truncated entry is a malformed entry: code 6 at the slot being decoded.
    return fault(decoded.error->slot, kCfgWrongIdentifier);
  }
  if (cw_in_count != cw_out_count) {
    return fault(out.cw_in ? *out.cw_in : *out.cw_out, kCfgCommWindow);  // only one direction
  }
  if (prm.page_mode) {
    std::optional<std::size_t> last_in;
    bool any_out = false;
    for (const auto& s : out.slots) {
      if (s.kind == SlotKind::SegmentIn) last_in = s.index;
      if (s.kind == SlotKind::SegmentOut) any_out = true;
    }
    std::size_t in_total = 0;
    for (const auto& s : out.slots)
      if (s.kind == SlotKind::SegmentIn) in_total += s.length;
    // manual table 6.4.1 rule 1: at least 32 input bytes.
    if (in_total < kSegmentLen) return fault(last_in.value_or(0), kCfgPageLayout);
    if (!any_out) return fault(0, kCfgNoOutput);
    // docs/page-mode.md "Segments": the first output segment carries the page number and header
    // bytes 2-7 (sequence number), so it needs at least 8 bytes.
    constexpr std::size_t kPageHeaderLen = 8;
    const auto first_out = std::find_if(out.slots.begin(), out.slots.end(), [](const Slot& s) {
      return s.kind == SlotKind::SegmentOut;
    });
    if (first_out->length < kPageHeaderLen) return fault(first_out->index, kCfgPageLayout);
  } else {
    const bool any_output = std::any_of(out.slots.begin(), out.slots.end(),
                                        [](const Slot& s) { return !s.is_input(); });
    // manual §5.1.4: at least one output is required (0x07F8 is the dummy).
    if (!any_output) return fault(0, kCfgNoOutput);
  }
  out.input_len = totals.in;
  out.output_len = totals.out;
  return out;
}

std::optional<std::vector<std::uint8_t>> parse_comment(std::string_view text, std::string* error) {
  auto read = parse_hex_bytes(text, HexForm::Separated, error, /*allow_empty=*/true);
  if (!read) return std::nullopt;
  std::vector<std::uint8_t> out = std::move(read->bytes);
  // manual §5.1.4: the comment field holds at most 15 bytes (14 in Page-Mode dialogs).
  if (out.size() > 15) {
    if (error) *error = "more than 15 comment bytes";
    return std::nullopt;
  }
  return out;
}

}  // namespace candp2::gw
