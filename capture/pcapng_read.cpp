// Reading pcapng (draft-ietf-opsawg-pcapng: §4.1 Section Header Block, §4.2 Interface
// Description Block, §4.3 Enhanced Packet Block, §3.5 options).
#include "capture/pcapng_read.hpp"

#include <cmath>
#include <cstdint>

#include "capture/pcapng.hpp"

namespace candp2::capture::pcapng {

namespace {

// The bytes of one section, in its byte order.
struct Reader {
  std::span<const std::uint8_t> b;
  bool big = false;
  std::uint16_t u16(std::size_t at) const {
    return big ? static_cast<std::uint16_t>(b[at] << 8 | b[at + 1])
               : static_cast<std::uint16_t>(b[at] | b[at + 1] << 8);
  }
  std::uint32_t u32(std::size_t at) const {
    return big ? std::uint32_t{u16(at)} << 16 | u16(at + 2)
               : std::uint32_t{u16(at + 2)} << 16 | u16(at);
  }
  std::uint64_t u64(std::size_t at) const {
    return big ? std::uint64_t{u32(at)} << 32 | u32(at + 4)
               : std::uint64_t{u32(at + 4)} << 32 | u32(at);
  }
};

// The options of a block body from `at` on: fn(code, value). False when they overrun the body.
template <typename Fn>
bool options(const Reader& r, std::size_t at, Fn fn) {
  while (at + 4 <= r.b.size()) {
    const std::uint16_t code = r.u16(at), len = r.u16(at + 2);
    if (code == kOptEndOfOpt) return true;
    if (at + 4 + len > r.b.size()) return false;
    fn(code, Reader{r.b.subspan(at + 4, len), r.big});
    at += 4 + (len + 3u) / 4 * 4;
  }
  return at >= r.b.size();
}

std::string text(const Reader& v) {
  std::string s(v.b.begin(), v.b.end());
  while (!s.empty() && s.back() == '\0') s.pop_back();
  return s;
}

}  // namespace

bool is_pcapng(std::span<const std::uint8_t> file) {
  return file.size() >= 4 && file[0] == 0x0A && file[1] == 0x0D && file[2] == 0x0D &&
         file[3] == 0x0A;
}

Capture read(std::span<const std::uint8_t> file) {
  Capture c;
  Reader r{file};
  std::size_t at = 0, section_base = 0;
  auto fail = [&](const std::string& why) {
    c.error = why + " at byte " + std::to_string(at);
    return c;
  };
  if (!is_pcapng(file)) return fail("no Section Header Block");
  while (at < file.size()) {
    if (at + 12 > file.size()) return fail("a cut block");
    if (r.u32(at) == kSectionHeaderBlock) {
      // The byte-order magic decides how this section's numbers read.
      const std::uint32_t magic = Reader{file, false}.u32(at + 8);
      if (magic != kByteOrderMagic && magic != 0x4D3C2B1A) return fail("a bad byte-order magic");
      r.big = magic != kByteOrderMagic;
    }
    const std::uint32_t type = r.u32(at), len = r.u32(at + 4);
    if (len < 12 || len % 4 || len > file.size() - at) return fail("a cut block");
    if (r.u32(at + len - 4) != len) return fail("a block whose two lengths differ");
    const Reader body{file.subspan(at + 8, len - 12), r.big};
    bool good = true;
    if (type == kSectionHeaderBlock) {
      ++c.sections;
      section_base = c.interfaces.size();
      good = body.b.size() >= 16;
    } else if (type == kInterfaceDescriptionBlock) {
      Interface i;
      good = body.b.size() >= 8;
      if (good) {
        i.linktype = body.u16(0);
        good = options(body, 8, [&](std::uint16_t code, const Reader& v) {
          if (code == kIfName) i.name = text(v);
          if (code == kIfTsresol && v.b.size() == 1) i.tsresol = v.b[0];
          if (code == kIfSpeed && v.b.size() == 8) i.speed = v.u64(0);
        });
      }
      c.interfaces.push_back(std::move(i));
    } else if (type == kEnhancedPacketBlock) {
      good = body.b.size() >= 20;
      Packet p;
      if (good) {
        const std::uint32_t id = body.u32(0), caplen = body.u32(12);
        p.interface = static_cast<std::uint32_t>(section_base + id);
        p.time = std::uint64_t{body.u32(4)} << 32 | body.u32(8);
        good = p.interface < c.interfaces.size() && caplen <= body.b.size() - 20;
        if (good) {
          p.data.assign(body.b.begin() + 20, body.b.begin() + 20 + caplen);
          const std::size_t opts = 20 + (std::size_t{caplen} + 3) / 4 * 4;
          good = options(body, opts, [&](std::uint16_t code, const Reader& v) {
            if (code == kOptComment) p.comment = text(v);
            if (code == kEpbFlags && v.b.size() == 4) p.flags = v.u32(0);
          });
        }
      }
      if (good) c.packets.push_back(std::move(p));
    }
    if (!good) return fail("a malformed block");
    at += len;
  }
  c.ok = true;
  return c;
}

std::optional<std::uint64_t> time_ns(const Interface& i, std::uint64_t time) {
  const std::uint8_t res = i.tsresol.value_or(6);  // absent: 10^-6 s
  const unsigned exp = res & 0x7F;
  if (res & 0x80) {  // 2^-exp s
    if (exp > 63) return std::nullopt;
    const long double ns = static_cast<long double>(time) * 1e9L / std::ldexp(1.0L, int(exp));
    if (ns >= 18446744073709551615.0L) return std::nullopt;
    return static_cast<std::uint64_t>(ns);
  }
  std::uint64_t scale = 1;
  for (unsigned k = 9; k < exp && k < 29; ++k) scale *= 10;  // finer than ns: divide
  if (exp > 9) return exp >= 29 ? 0 : time / scale;
  for (unsigned k = exp; k < 9; ++k) scale *= 10;  // coarser: multiply
  if (time > UINT64_MAX / scale) return std::nullopt;
  return time * scale;
}

std::optional<ExportedPdu> parse_exported_pdu(std::span<const std::uint8_t> data) {
  // Tags: type and length big-endian, then the value (Wireshark's wsutil/exported_pdu_tlvs.h).
  const Reader r{data, true};
  ExportedPdu out;
  std::size_t at = 0;
  while (at + 4 <= data.size()) {
    const std::uint16_t type = r.u16(at), len = r.u16(at + 2);
    at += 4;
    if (type == kExpPduEndOfOpt) {
      out.pdu = data.subspan(at);
      return out;
    }
    if (len > data.size() - at) return std::nullopt;
    if (type == kExpPduDissectorName) out.dissector = text(Reader{data.subspan(at, len), true});
    at += len;
  }
  return std::nullopt;
}

}  // namespace candp2::capture::pcapng
