// A small pcapng reader for the capture tests: walks the blocks of a file (little-endian, as
// candp2 writes them) and decodes the fields the tests check. Not a general reader.
#pragma once

#include <cstdint>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

namespace candp2::capture::test {

struct Block {
  std::uint32_t type = 0;
  std::vector<std::uint8_t> body;  // between the two length fields
};

struct Interface {
  std::uint16_t linktype = 0;
  std::string name;
  std::optional<std::uint8_t> tsresol;
  std::optional<std::uint64_t> speed;  // if_speed, bit/s
};

struct Packet {
  std::uint32_t interface = 0;
  std::uint64_t time = 0;
  std::vector<std::uint8_t> data;
  std::optional<std::uint32_t> flags;
  std::string comment;
};

struct Capture {
  bool ok = false;  // every block well formed, the first one a Section Header
  std::size_t sections = 0;
  std::vector<Interface> interfaces;
  std::vector<Packet> packets;
};

inline std::uint32_t rd32(const std::vector<std::uint8_t>& b, std::size_t at) {
  return b[at] | (b[at + 1] << 8) | (b[at + 2] << 16) | (std::uint32_t{b[at + 3]} << 24);
}
inline std::uint16_t rd16(const std::vector<std::uint8_t>& b, std::size_t at) {
  return static_cast<std::uint16_t>(b[at] | (b[at + 1] << 8));
}

inline std::vector<std::uint8_t> slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Options from `at` to the end of `body`: calls fn(code, value bytes).
template <typename Fn>
bool options(const std::vector<std::uint8_t>& body, std::size_t at, Fn fn) {
  while (at + 4 <= body.size()) {
    const std::uint16_t code = rd16(body, at), len = rd16(body, at + 2);
    if (code == 0) return true;
    if (at + 4 + len > body.size()) return false;
    fn(code, std::vector<std::uint8_t>(body.begin() + at + 4, body.begin() + at + 4 + len));
    at += 4 + (len + 3u) / 4 * 4;
  }
  return at == body.size();
}

inline Capture read_capture(const std::vector<std::uint8_t>& file) {
  Capture c;
  std::size_t at = 0;
  bool good = true;
  while (good && at + 12 <= file.size()) {
    const std::uint32_t type = rd32(file, at), len = rd32(file, at + 4);
    if (len < 12 || len % 4 || at + len > file.size() || rd32(file, at + len - 4) != len) {
      good = false;
      break;
    }
    std::vector<std::uint8_t> body(file.begin() + at + 8, file.begin() + at + len - 4);
    if (at == 0 && type != 0x0A0D0D0A) good = false;
    if (type == 0x0A0D0D0A) {
      ++c.sections;
      good = good && body.size() >= 16 && rd32(body, 0) == 0x1A2B3C4D;
    } else if (type == 1) {
      Interface i;
      i.linktype = rd16(body, 0);
      good = good && options(body, 8, [&](std::uint16_t code, const std::vector<std::uint8_t>& v) {
               if (code == 2) i.name.assign(v.begin(), v.end());
               if (code == 9 && v.size() == 1) i.tsresol = v[0];
               if (code == 8 && v.size() == 8) {
                 std::uint64_t s = 0;
                 for (std::size_t k = 0; k < 8; ++k) s |= std::uint64_t{v[k]} << (8 * k);
                 i.speed = s;
               }
             });
      c.interfaces.push_back(i);
    } else if (type == 6) {
      Packet p;
      p.interface = rd32(body, 0);
      p.time = (std::uint64_t{rd32(body, 4)} << 32) | rd32(body, 8);
      const std::uint32_t caplen = rd32(body, 12);
      p.data.assign(body.begin() + 20, body.begin() + 20 + caplen);
      good = good && options(body, 20 + (caplen + 3u) / 4 * 4,
                             [&](std::uint16_t code, const std::vector<std::uint8_t>& v) {
                               if (code == 1) p.comment.assign(v.begin(), v.end());
                               if (code == 2 && v.size() == 4) p.flags = rd32(v, 0);
                             });
      c.packets.push_back(std::move(p));
    }
    at += len;
  }
  c.ok = good && at == file.size() && c.sections > 0;
  return c;
}

}  // namespace candp2::capture::test
