#include "profibus_sim/dp/dp_telegram.hpp"

namespace candp2::dp {

std::optional<PrmStd> decode_prm_std(std::span<const std::uint8_t> t) {
  if (t.size() < kPrmStdLen) return std::nullopt;
  PrmStd p;
  p.station_status = t[0];
  p.wd_fact_1 = t[1];
  p.wd_fact_2 = t[2];
  p.min_tsdr = t[3];
  p.ident_number = static_cast<std::uint16_t>((t[4] << 8) | t[5]);
  p.group_ident = t[6];
  return p;
}

void encode_prm_std(const PrmStd& p, std::span<std::uint8_t> out) {
  out[0] = p.station_status;
  out[1] = p.wd_fact_1;
  out[2] = p.wd_fact_2;
  out[3] = p.min_tsdr;
  out[4] = static_cast<std::uint8_t>(p.ident_number >> 8);
  out[5] = static_cast<std::uint8_t>(p.ident_number & 0xFF);
  out[6] = p.group_ident;
}

std::vector<std::uint8_t> with_lock_req(std::span<const std::uint8_t> t) {
  std::vector<std::uint8_t> out(t.begin(), t.end());
  if (!out.empty()) out[0] = static_cast<std::uint8_t>((out[0] & ~kPrmUnlockReq) | kPrmLockReq);
  return out;
}

std::size_t CfgEntry::out_bytes() const {
  if (io == CfgIo::Output || io == CfgIo::InputOutput) return std::size_t{count} * (words ? 2 : 1);
  return 0;
}

std::size_t CfgEntry::in_bytes() const {
  if (io == CfgIo::Input) return std::size_t{count} * (words ? 2 : 1);
  if (io == CfgIo::InputOutput) return std::size_t{in_count} * (in_words ? 2 : 1);
  return 0;
}

CfgDecodeResult decode_chk_cfg(std::span<const std::uint8_t> cfg) {
  CfgDecodeResult r;
  std::size_t pos = 0;
  while (pos < cfg.size()) {
    CfgEntry e;
    e.offset = pos;
    const std::uint8_t id = cfg[pos++];
    auto truncated = [&](const char* what) {
      r.error = CfgDecodeError{r.entries.size(), pos, std::string("Chk_Cfg truncated: ") + what};
      return r;
    };
    if ((id & 0x30) == 0) {
      // Special identifier format.
      e.special = true;
      const std::uint8_t kind = id >> 6;
      const std::size_t m = id & 0x0F;
      e.io = static_cast<CfgIo>(kind);
      const std::size_t length_bytes = kind == 0 ? 0 : (kind == 3 ? 2 : 1);
      if (pos + length_bytes > cfg.size()) return truncated("length byte missing");
      if (length_bytes >= 1) {
        const std::uint8_t len = cfg[pos++];
        e.consistent = len & 0x80;
        e.words = len & 0x40;
        e.count = static_cast<std::uint8_t>((len & 0x3F) + 1);
      }
      if (length_bytes == 2) {
        const std::uint8_t len = cfg[pos++];
        e.in_words = len & 0x40;
        e.in_count = static_cast<std::uint8_t>((len & 0x3F) + 1);
        e.consistent = e.consistent && (len & 0x80);
      }
      if (pos + m > cfg.size()) return truncated("manufacturer bytes missing");
      e.manufacturer.assign(cfg.begin() + static_cast<std::ptrdiff_t>(pos),
                            cfg.begin() + static_cast<std::ptrdiff_t>(pos + m));
      pos += m;
    } else {
      e.special = false;
      e.consistent = id & 0x80;
      e.words = id & 0x40;
      e.io = static_cast<CfgIo>((id >> 4) & 0x03);
      e.count = static_cast<std::uint8_t>((id & 0x0F) + 1);
      if (e.io == CfgIo::InputOutput) {
        e.in_count = e.count;
        e.in_words = e.words;
      }
    }
    r.entries.push_back(std::move(e));
  }
  return r;
}

std::vector<std::uint8_t> encode_chk_cfg(std::span<const CfgEntry> entries) {
  std::vector<std::uint8_t> out;
  for (const auto& e : entries) {
    if (e.special || !e.manufacturer.empty() || e.io == CfgIo::Empty) {
      const std::uint8_t m = static_cast<std::uint8_t>(e.manufacturer.size() & 0x0F);
      out.push_back(static_cast<std::uint8_t>((static_cast<std::uint8_t>(e.io) << 6) | m));
      auto len = [](bool cons, bool words, std::uint8_t count) {
        return static_cast<std::uint8_t>((cons ? 0x80 : 0) | (words ? 0x40 : 0) |
                                         ((count - 1) & 0x3F));
      };
      if (e.io != CfgIo::Empty) out.push_back(len(e.consistent, e.words, e.count));
      if (e.io == CfgIo::InputOutput) out.push_back(len(e.consistent, e.in_words, e.in_count));
      out.insert(out.end(), e.manufacturer.begin(), e.manufacturer.begin() + m);
    } else {
      out.push_back(static_cast<std::uint8_t>((e.consistent ? 0x80 : 0) | (e.words ? 0x40 : 0) |
                                              (static_cast<std::uint8_t>(e.io) << 4) |
                                              ((e.count - 1) & 0x0F)));
    }
  }
  return out;
}

namespace {
CfgEntry special(CfgIo io, std::uint8_t bytes, bool consistent, std::vector<std::uint8_t> comment) {
  CfgEntry e;
  e.special = true;
  e.io = io;
  e.count = bytes;
  e.consistent = consistent;
  e.manufacturer = std::move(comment);
  return e;
}
}  // namespace

CfgEntry special_input(std::uint8_t bytes, bool consistent, std::vector<std::uint8_t> comment) {
  return special(CfgIo::Input, bytes, consistent, std::move(comment));
}

CfgEntry special_output(std::uint8_t bytes, bool consistent, std::vector<std::uint8_t> comment) {
  return special(CfgIo::Output, bytes, consistent, std::move(comment));
}

}  // namespace candp2::dp
