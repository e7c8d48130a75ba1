// The Page-Mode page wire format (manual §6, docs/page-mode.md), shared by the gateway's Page-Mode
// engine (gateway/page_mode.hpp) and the PLC-side page driver (plc/page_driver.hpp):
// segment layout and payload regions ("Segments"), header bytes ("Header bytes"), the 6-byte
// identifier entries and end markers of configuration pages ("Pages", manual tables 6.4.4/6.4.5),
// the packing of data entries onto pages 251.. (manual tables 6.4.6/6.4.8). Pure functions and
// value types at the wire-format level (library candp2_pageformat, over candp2_can only): no
// engine, no I/O.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "can/frame.hpp"

namespace candp2::page {

// Page numbers (manual table 6.4.3).
inline constexpr std::uint16_t kInitRequest = 0;  // page 0: PLC → gateway, resets Page-Mode
inline constexpr std::uint16_t kInitAnswer = 1;   // page 1: gateway → PLC, page sizes
inline constexpr std::uint16_t kTxConfigFirst = 51;
inline constexpr std::uint16_t kTxConfigLast = 150;
inline constexpr std::uint16_t kRxConfigFirst = 151;
inline constexpr std::uint16_t kRxConfigLast = 250;
inline constexpr std::uint16_t kDataFirst = 251;
inline constexpr std::size_t kMaxDataPages = 65285;  // manual §6.4.7: 251..65535

// Segment structure (docs/page-mode.md "Segments", manual table 6.4.2).
inline constexpr std::size_t kPageNumberLen = 2;  // every segment starts with the page number
inline constexpr std::size_t kHeaderLen = 8;      // first segment: page number + bytes 2-7
inline constexpr std::size_t kSegmentLen = 32;    // manual table 6.4.1 rule 2

// Header bytes (docs/page-mode.md "Header bytes").
inline constexpr std::size_t kSeqByte = 2;     // output: sequence number; input: acknowledge
inline constexpr std::size_t kStatusByte = 3;  // input only
inline constexpr std::size_t kWord4 = 4;       // input bytes 4-5, big-endian
inline constexpr std::size_t kWord6 = 6;       // input bytes 6-7, big-endian
// Page 1 payload (docs/page-mode.md "Pages").
inline constexpr std::size_t kInitOutSegments = 8;
inline constexpr std::size_t kInitInSegments = 9;
inline constexpr std::size_t kInitCommWindow = 10;

// Configuration pages (manual tables 6.4.4/6.4.5, 6.5.2/6.5.3; docs/page-mode.md "Pages").
inline constexpr std::size_t kEntryLen = 6;   // identifier (4, big-endian), form, length
inline constexpr std::size_t kMarkerLen = 4;  // DD DD DD DD / EE EE EE EE
inline constexpr std::uint8_t kMarkerMore = 0xDD;
inline constexpr std::uint8_t kMarkerEnd = 0xEE;
inline constexpr std::uint32_t kIdFlag29 = 0x20000000;  // manual §5.2.1: bit 29 flags a 29-bit id
inline constexpr std::uint8_t kMinDataLen = 1;          // manual §6.4.5 "länge": 1..8
inline constexpr std::uint8_t kMaxDataLen = 8;

// This product's memory limit per direction (manual §6.1 leaves it to "the gateway's memory").
inline constexpr std::size_t kMaxIdentifiers = 2048;

// force values (manual table 6.4.7).
inline constexpr std::uint8_t kForceNever = 0;
inline constexpr std::uint8_t kForceAlways = 1;
inline constexpr std::uint8_t kForceOnChange = 2;
inline constexpr std::uint8_t kForceToggleA = 3;  // a change into 3 or into 4 sends once
inline constexpr std::uint8_t kForceToggleB = 4;
inline constexpr std::uint8_t kForceMax = 4;

// Input byte 3 (docs/page-mode.md "Header bytes").
enum class Status : std::uint8_t {
  Ok = 0,
  Unexpected = 1,     // page not expected here (wrong order, undefined number, beyond N)
  BadEntry = 2,       // malformed entry, missing end marker, force > 4
  TooMany = 3,        // more identifiers than the gateway holds
  NotConfigured = 4,  // data page before the configuration is complete
};
std::string_view to_string(Status s);

// The byte range of one segment's payload in the concatenated page.
struct Region {
  std::size_t offset = 0;
  std::size_t length = 0;
  friend bool operator==(const Region&, const Region&) = default;
};

// How a page is cut into segments (docs/page-mode.md "Segments"): every segment starts with the
// page number; the first segment's bytes 2-7 are the header, its payload starts at byte 8; every
// further segment's payload starts at its byte 2.
class Layout {
 public:
  Layout() = default;
  explicit Layout(std::vector<std::size_t> segment_lengths);
  // The layout a page of `page_len` bytes in `segments` segments must have: every segment but the
  // last is 32 bytes (manual table 6.4.1). nullopt when no such layout exists.
  static std::optional<Layout> from_sizes(std::size_t page_len, std::size_t segments);

  std::size_t size() const { return size_; }
  bool empty() const { return segments_.empty(); }
  // The first segment holds the whole header (8 bytes).
  bool has_header() const { return !segments_.empty() && segments_.front() >= kHeaderLen; }
  const std::vector<std::size_t>& segments() const { return segments_; }
  const std::vector<std::size_t>& segment_offsets() const { return offsets_; }
  const std::vector<Region>& regions() const { return regions_; }
  // The largest entry that fits in one region (an entry never straddles two segments).
  std::size_t max_entry() const { return max_entry_; }

 private:
  std::vector<std::size_t> segments_, offsets_;
  std::vector<Region> regions_;
  std::size_t size_ = 0;
  std::size_t max_entry_ = 0;
};

// Places items one after the other into the payload regions of a page; an item that does not fit
// into the rest of the current region starts the next region (never straddles).
class Packer {
 public:
  explicit Packer(const Layout& layout) : layout_(&layout) {}
  // The offset of an item of `len` bytes, or nullopt when the page has no room for it.
  std::optional<std::size_t> place(std::size_t len);
  // Whether an item of `len` bytes would still fit after the items placed so far.
  bool fits(std::size_t len) const;

 private:
  const Layout* layout_;
  std::size_t region_ = 0;
  std::size_t used_ = 0;  // bytes used in the current region
};

// Page number in every segment; nullopt when the segments disagree (a torn page).
std::optional<std::uint16_t> page_number(const Layout& layout, std::span<const std::uint8_t> page);
void put_page_number(const Layout& layout, std::span<std::uint8_t> page, std::uint16_t number);

inline std::uint16_t get_be16(std::span<const std::uint8_t> b, std::size_t at) {
  return static_cast<std::uint16_t>((b[at] << 8) | b[at + 1]);
}
inline void put_be16(std::span<std::uint8_t> b, std::size_t at, std::uint16_t v) {
  b[at] = static_cast<std::uint8_t>(v >> 8);
  b[at + 1] = static_cast<std::uint8_t>(v & 0xFF);
}

// One identifier of a configuration page (manual table 6.4.4: TxId_wert, form, länge).
struct IdEntry {
  can::Ident id;
  std::uint8_t form = 0;
  std::uint8_t length = 0;  // data bytes 1..8
  friend bool operator==(const IdEntry&, const IdEntry&) = default;
};

std::array<std::uint8_t, kEntryLen> encode_entry(const IdEntry& e);
// nullopt and *why set for a malformed entry (11-bit value > 0x7FF, bits 30/31 set, length not
// 1..8).
std::optional<IdEntry> decode_entry(std::span<const std::uint8_t> bytes, std::string* why);

enum class Marker : std::uint8_t { None, More, End };
Marker marker_at(std::span<const std::uint8_t> bytes);  // needs 4 bytes

// A configuration page (51..150 or 151..250) decoded from the payload regions.
struct ConfigPage {
  std::vector<IdEntry> entries;
  bool complete = false;  // EE EE EE EE: the configuration of this direction is complete
};
struct ConfigPageFault {
  std::size_t offset = 0;  // byte in the page
  std::string why;
};
// Entries in region order until the end marker; an entry never straddles two segments, so a rest
// of a region too short for an entry that is no marker is skipped.
std::optional<ConfigPage> decode_config_page(const Layout& layout,
                                             std::span<const std::uint8_t> page,
                                             ConfigPageFault* fault);
// Writes as many of `entries` as fit together with the end marker into the payload of `page`
// (the header is the caller's). Returns how many entries were written; the marker is EE when they
// were all of them, DD otherwise. 0 with entries left means the page cannot hold one entry.
std::size_t encode_config_page(const Layout& layout, std::span<const IdEntry> entries,
                               std::span<std::uint8_t> page);
// The same with entries as raw bytes (a PLC copies DB94/DB95 entries verbatim).
using RawEntry = std::array<std::uint8_t, kEntryLen>;
std::size_t encode_config_page(const Layout& layout, std::span<const RawEntry> entries,
                               std::span<std::uint8_t> page);

// Where one entry of a data page lives: page index (0 = page 251) and byte offset in the page.
struct DataPlace {
  std::uint16_t page = 0;
  std::uint16_t offset = 0;
  friend bool operator==(const DataPlace&, const DataPlace&) = default;
};
// Output entries (force + data) and input entries (count_in + data) in configuration order: each
// page holds as many whole entries as fit, the next page continues (docs/page-mode.md "Pages").
// Entries longer than max_entry() are not placed (the result is shorter).
std::vector<DataPlace> pack_data(const Layout& layout, std::span<const IdEntry> entries);
// Number of pages `pack_data` uses (0 for no entries).
std::size_t pages_used(std::span<const DataPlace> places);

}  // namespace candp2::page
