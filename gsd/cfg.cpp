#include "gsd/cfg.hpp"

#include <cstdio>

#include "common/hex.hpp"

namespace candp2::gsd {

namespace {

std::string hex8(unsigned v) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "0x%02X", v & 0xFFu);
  return buf;
}
std::string bytes_text(std::size_t n) {
  return std::to_string(n) + (n == 1 ? " byte" : " bytes");
}

std::string hex_id(std::uint32_t v, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%0*X", digits, v);
  return buf;
}

void apply_length(std::uint8_t len, bool in, CfgEntry& e) {
  const bool words = (len & 0x40) != 0;
  const std::size_t count = static_cast<std::size_t>(len & 0x3F) + 1;
  const std::size_t bytes = words ? 2 * count : count;
  if (in) {
    e.input = true;
    e.input_len = bytes;
    e.input_words = words;
    e.input_consistent = (len & 0x80) != 0;
  } else {
    e.output = true;
    e.output_len = bytes;
    e.output_words = words;
    e.output_consistent = (len & 0x80) != 0;
  }
}

// CAN-DP/2 constants (manual §5.1.4, §5.2.1, §5.3.2, table 6.4.1; emulator-spec §2).
constexpr std::uint32_t kDummyTxId = 0x07F8;  // manual §5.1.4: output without CAN assignment
constexpr std::size_t kCwLen = 16;            // manual §5.3.1: Communication Window length
constexpr std::size_t kSegmentMax = 32;       // manual table 6.4.1: Page-Mode segment <= 32 bytes
constexpr std::size_t kMaxData = 8;           // CAN data bytes; +1 with Rx-/Tx-Counter

}  // namespace

CfgDecode decode_config(std::span<const std::uint8_t> cfg) {
  CfgDecode out;
  std::size_t i = 0;
  while (i < cfg.size()) {
    CfgEntry e;
    e.offset = i;
    e.identifier = cfg[i];
    const std::uint8_t id = cfg[i];
    if ((id & 0x30) != 0) {  // general identifier format
      const bool words = (id & 0x40) != 0;
      const bool consistent = (id & 0x80) != 0;
      const std::size_t count = static_cast<std::size_t>(id & 0x0F) + 1;
      const std::size_t bytes = words ? 2 * count : count;
      if (id & 0x10) {
        e.input = true;
        e.input_len = bytes;
        e.input_words = words;
        e.input_consistent = consistent;
      }
      if (id & 0x20) {
        e.output = true;
        e.output_len = bytes;
        e.output_words = words;
        e.output_consistent = consistent;
      }
      e.size = 1;
    } else {  // special identifier format
      e.special = true;
      const std::size_t m = id & 0x0F;
      if (m == 15) {
        out.error = "byte " + std::to_string(i) + " (" + hex8(id) +
                    "): special format with the reserved manufacturer length 15";
        return out;
      }
      const std::size_t lens = (id >> 6) == 3 ? 2 : (id >> 6) == 0 ? 0 : 1;
      if (i + 1 + lens + m > cfg.size()) {
        out.error = "byte " + std::to_string(i) + " (" + hex8(id) + "): special format needs " +
                    std::to_string(lens) + " length byte(s) and " + std::to_string(m) +
                    " manufacturer byte(s), only " + std::to_string(cfg.size() - i - 1) + " follow";
        return out;
      }
      std::size_t p = i + 1;
      if ((id >> 6) == 1) apply_length(cfg[p++], true, e);
      if ((id >> 6) == 2) apply_length(cfg[p++], false, e);
      if ((id >> 6) == 3) {  // output length first, then input length
        apply_length(cfg[p++], false, e);
        apply_length(cfg[p++], true, e);
      }
      e.manufacturer.assign(cfg.begin() + static_cast<std::ptrdiff_t>(p),
                            cfg.begin() + static_cast<std::ptrdiff_t>(p + m));
      e.size = 1 + lens + m;
    }
    out.input_len += e.input_len;
    out.output_len += e.output_len;
    i += e.size;
    out.entries.push_back(std::move(e));
  }
  return out;
}

std::string describe(const CfgEntry& e) {
  auto part = [](const char* dir, std::size_t len, bool words, bool consistent) {
    std::string s = std::string(dir) + " " + bytes_text(len);
    if (words) s += " (" + std::to_string(len / 2) + (len == 2 ? " word)" : " words)");
    if (consistent) s += " consistent";
    return s;
  };
  std::string s;
  if (e.output) s = part("output", e.output_len, e.output_words, e.output_consistent);
  if (e.input) {
    if (!s.empty()) s += ", ";
    s += part("input", e.input_len, e.input_words, e.input_consistent);
  }
  if (s.empty()) s = "no data (empty slot)";
  if (!e.manufacturer.empty()) s += ", manufacturer bytes " + hex_bytes(e.manufacturer);
  return s;
}

bool is_universal_module(std::span<const std::uint8_t> config) {
  return config.size() == 1 && config[0] == 0x00;
}

CanDp2Slot describe_candp2(const CfgEntry& e) {
  CanDp2Slot r;
  auto fault = [&](int code, std::string why) {
    r.problem = "Cfg fault code " + std::to_string(code) + ": " + std::move(why);
  };
  // emulator-spec §2 code 1: only input or output slots in the special format.
  if (!e.special || e.input == e.output) {
    r.text = "not a CAN-DP/2 slot";
    fault(1, !e.special ? "general identifier format (no comment bytes)"
                        : (e.input ? "input+output slot" : "empty slot"));
    return r;
  }
  const bool in = e.input;
  const std::size_t len = in ? e.input_len : e.output_len;
  const bool consistent = in ? e.input_consistent : e.output_consistent;
  if (in ? e.input_words : e.output_words) {
    r.text = in ? "input" : "output";
    fault(2, "word structure (the gateway counts bytes)");
    return r;
  }
  const auto& m = e.manufacturer;
  const char* dir = in ? "Rx" : "Tx";
  // Page-Mode segment (manual table 6.4.1, emulator-spec §6.1): no comment bytes.
  if (m.empty()) {
    if (consistent && len <= kSegmentMax) {
      r.text = std::string("Page-Mode ") + (in ? "input" : "output") + " segment, " +
               std::to_string(len) + " bytes (valid only with Page-Mode on)";
      return r;
    }
    r.text = dir;
    fault(4, "no CAN identifier in the comment bytes");
    return r;
  }
  // Communication Window (manual §5.3.2): comment FF EF form [SYNC time high, low].
  if ((m.size() == 3 || m.size() == 5) && m[0] == 0xFF && m[1] == 0xEF) {
    r.text = std::string("Communication Window ") + (in ? "read" : "write") + " (" +
             (in ? "input" : "output") + "), form " + hex8(m[2]);
    if (m.size() == 5) {
      const unsigned sync = (m[3] << 8) | m[4];
      r.text += sync ? ", SYNC time " + std::to_string(sync) + " ms" : ", no SYNC time";
    }
    if (len != kCwLen)
      fault(3, "a Communication Window is 16 bytes");
    else if (!consistent)
      fault(8, "a Communication Window must be consistent over its length");
    return r;
  }
  if (m.size() == 1) {
    r.text = dir;
    fault(4, "only one identifier byte");
    return r;
  }
  if (m.size() == 2) {
    r.text = dir;
    fault(5, "the form byte is missing");
    return r;
  }
  std::uint32_t id = 0;
  bool extended = false;
  std::size_t p = 0;
  if (m.size() == 3 || (m.size() == 5 && !(m[0] & 0x20))) {  // 11-bit identifier
    id = static_cast<std::uint32_t>((m[0] << 8) | m[1]);
    p = 2;
  } else if ((m.size() == 5 || m.size() == 7) && (m[0] & 0x20)) {  // 29-bit (manual §5.2.1)
    id = ((static_cast<std::uint32_t>(m[0]) << 24) | (static_cast<std::uint32_t>(m[1]) << 16) |
          (static_cast<std::uint32_t>(m[2]) << 8) | m[3]) &
         0x1FFFFFFFu;
    extended = true;
    p = 4;
  } else if (m.size() == 4 && (m[0] & 0x20)) {
    r.text = dir;
    fault(5, "29-bit identifier without the form byte");
    return r;
  } else {
    r.text = dir;
    fault(6, std::to_string(m.size()) + " comment bytes (expected 3, 5 or 7)");
    return r;
  }
  const std::uint8_t form = m[p++];
  if (!in && !extended && id == kDummyTxId) {
    r.text = "Tx without CAN identifier (0x07F8 dummy), " + bytes_text(len);
  } else {
    r.text = std::string(dir) +
             (extended ? " 29-bit ID " + hex_id(id, 8) : " 11-bit ID " + hex_id(id, 3)) + ", " +
             bytes_text(len) + ", form " + hex8(form);
  }
  if (p + 2 <= m.size()) {
    const unsigned cycle = (m[p] << 8) | m[p + 1];
    if (in)
      r.text += " (cycle bytes ignored on an input)";
    else if (cycle)
      r.text += ", cycle " + std::to_string(cycle) + " ms";
  }
  if (!extended && id > 0x7FF)
    fault(6, "11-bit identifier " + hex_id(id, 3) + " > 0x7FF");
  else if (len < 1 || len > kMaxData + 1)
    fault(3, std::to_string(len) + " data bytes (1..8, +1 with Rx-/Tx-Counter)");
  return r;
}

}  // namespace candp2::gsd
