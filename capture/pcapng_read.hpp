// Reading a pcapng capture (draft-ietf-opsawg-pcapng): the Section Header, Interface Description
// and Enhanced Packet blocks, as candp2 writes them (docs/capture.md) and as other writers do
// (either byte order, any if_tsresol); other block types are skipped. `candp2 sniff` reads
// candp2d's captures with it (docs/sniff.md), the capture tests check what was written. Pure:
// bytes in, blocks out; a damaged or cut file keeps what came before the damage.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace candp2::capture::pcapng {

struct Interface {
  std::uint16_t linktype = 0;
  std::string name;                     // if_name
  std::optional<std::uint8_t> tsresol;  // if_tsresol as written (absent: microseconds)
  std::optional<std::uint64_t> speed;   // if_speed, bit/s
};

struct Packet {
  std::uint32_t interface = 0;  // index into Capture::interfaces (over all sections)
  std::uint64_t time = 0;       // in the interface's if_tsresol units
  std::vector<std::uint8_t> data;
  std::optional<std::uint32_t> flags;  // epb_flags
  std::string comment;                 // opt_comment
};

struct Capture {
  bool ok = false;    // every block well formed, the first one a Section Header
  std::string error;  // what was wrong and at which byte offset, when not ok
  std::size_t sections = 0;
  std::vector<Interface> interfaces;
  std::vector<Packet> packets;
};

// The file starts with a Section Header Block.
bool is_pcapng(std::span<const std::uint8_t> file);
Capture read(std::span<const std::uint8_t> file);

// A packet's time in nanoseconds (its interface's if_tsresol: a power of 10, or of 2 with bit 7
// set); nullopt when it does not fit.
std::optional<std::uint64_t> time_ns(const Interface& i, std::uint64_t time);

// An exported PDU (LINKTYPE_WIRESHARK_UPPER_PDU): the dissector named by its tags and the PDU
// after them; nullopt when the tags are malformed.
struct ExportedPdu {
  std::string dissector;
  std::span<const std::uint8_t> pdu;
};
std::optional<ExportedPdu> parse_exported_pdu(std::span<const std::uint8_t> data);

}  // namespace candp2::capture::pcapng
