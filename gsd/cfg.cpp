#include "gsd/cfg.hpp"

#include "common/hex.hpp"

namespace candp2::gsd {

namespace {

std::string bytes_text(std::size_t n) {
  return std::to_string(n) + (n == 1 ? " byte" : " bytes");
}

std::vector<std::uint8_t> encode_one(const dp::CfgEntry& e) {
  return dp::encode_chk_cfg(std::span(&e, 1));
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

}  // namespace candp2::gsd
