#include "gateway/page/page_format.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>

#include "common/hex.hpp"

namespace candp2::page {

std::string_view to_string(Status s) {
  switch (s) {
    case Status::Ok:
      return "OK";
    case Status::Unexpected:
      return "page unexpected here";
    case Status::BadEntry:
      return "bad entry";
    case Status::TooMany:
      return "too many identifiers";
    case Status::NotConfigured:
      return "data page before the configuration is complete";
  }
  return "unknown status";
}

// ----------------------------------------------------------- layout (docs/page-mode.md "Segments")

Layout::Layout(std::vector<std::size_t> segment_lengths) : segments_(std::move(segment_lengths)) {
  for (std::size_t i = 0; i < segments_.size(); ++i) {
    const std::size_t len = segments_[i];
    offsets_.push_back(size_);
    // First segment: payload from byte 8; every further segment: from byte 2.
    const std::size_t skip = i == 0 ? kHeaderLen : kPageNumberLen;
    const std::size_t payload = len > skip ? len - skip : 0;
    regions_.push_back({size_ + std::min(skip, len), payload});
    max_entry_ = std::max(max_entry_, payload);
    size_ += len;
  }
}

std::optional<Layout> Layout::from_sizes(std::size_t page_len, std::size_t segments) {
  if (segments == 0) return page_len == 0 ? std::optional<Layout>(Layout{}) : std::nullopt;
  const std::size_t full = kSegmentLen * (segments - 1);
  if (page_len <= full || page_len - full > kSegmentLen) return std::nullopt;
  std::vector<std::size_t> lengths(segments - 1, kSegmentLen);
  lengths.push_back(page_len - full);
  return Layout(std::move(lengths));
}

std::optional<std::size_t> Packer::place(std::size_t len) {
  const auto& regions = layout_->regions();
  while (region_ < regions.size()) {
    const Region& r = regions[region_];
    if (r.length - used_ >= len) {
      const std::size_t at = r.offset + used_;
      used_ += len;
      return at;
    }
    ++region_;  // an entry never straddles two segments: the rest of this one stays unused
    used_ = 0;
  }
  return std::nullopt;
}

bool Packer::fits(std::size_t len) const {
  Packer trial = *this;
  return trial.place(len).has_value();
}

std::optional<std::uint16_t> page_number(const Layout& layout, std::span<const std::uint8_t> page) {
  if (layout.empty() || page.size() < layout.size()) return std::nullopt;
  const auto& segs = layout.segments();
  const auto& offs = layout.segment_offsets();
  // A segment shorter than 2 bytes carries what fits of the number (docs/page-mode.md "Segments"
  // allows 1..32 bytes).
  std::uint16_t number =
      segs[0] >= 2 ? get_be16(page, 0) : static_cast<std::uint16_t>(page[0] << 8);
  for (std::size_t i = 1; i < segs.size(); ++i) {
    if (segs[i] >= 2) {
      if (get_be16(page, offs[i]) != number) return std::nullopt;
    } else if (page[offs[i]] != (number >> 8)) {
      return std::nullopt;
    }
  }
  return number;
}

void put_page_number(const Layout& layout, std::span<std::uint8_t> page, std::uint16_t number) {
  const auto& segs = layout.segments();
  const auto& offs = layout.segment_offsets();
  for (std::size_t i = 0; i < segs.size(); ++i) {
    if (segs[i] >= 2)
      put_be16(page, offs[i], number);
    else
      page[offs[i]] = static_cast<std::uint8_t>(number >> 8);
  }
}

// ---------------------------------------------------------------- entries (manual table 6.4.4)

std::array<std::uint8_t, kEntryLen> encode_entry(const IdEntry& e) {
  const std::uint32_t v = e.id.extended ? (e.id.id & can::kMaxExtId) | kIdFlag29 : e.id.id;
  return {static_cast<std::uint8_t>(v >> 24),
          static_cast<std::uint8_t>(v >> 16),
          static_cast<std::uint8_t>(v >> 8),
          static_cast<std::uint8_t>(v),
          e.form,
          e.length};
}

std::optional<IdEntry> decode_entry(std::span<const std::uint8_t> b, std::string* why) {
  auto bad = [&](std::string text) -> std::optional<IdEntry> {
    if (why) *why = std::move(text);
    return std::nullopt;
  };
  const std::uint32_t v =
      (std::uint32_t{b[0]} << 24) | (std::uint32_t{b[1]} << 16) | (std::uint32_t{b[2]} << 8) | b[3];
  IdEntry e;
  if (v & 0xC0000000u) return bad("identifier " + hex_bytes(b.first(4)) + ": bits 30/31 set");
  if (v & kIdFlag29) {
    e.id = {v & can::kMaxExtId, true};  // docs/page-mode.md "Pages": bit 29 flags a 29-bit
                                        // identifier
  } else {
    if (v > can::kMaxStdId)
      return bad("identifier " + hex_bytes(b.first(4)) +
                 ": above 7FF without bit 29 (29-bit identifiers need bit 29 set)");
    e.id = {v, false};
  }
  e.form = b[4];
  e.length = b[5];
  if (e.length < kMinDataLen || e.length > kMaxDataLen)
    return bad("length " + std::to_string(e.length) + " (1..8 allowed, manual §6.4.5)");
  return e;
}

Marker marker_at(std::span<const std::uint8_t> b) {
  if (b.size() < kMarkerLen) return Marker::None;
  auto all = [&](std::uint8_t v) {
    return std::all_of(b.begin(), b.begin() + kMarkerLen, [v](std::uint8_t x) { return x == v; });
  };
  if (all(kMarkerMore)) return Marker::More;
  if (all(kMarkerEnd)) return Marker::End;
  return Marker::None;
}

std::optional<ConfigPage> decode_config_page(const Layout& layout,
                                             std::span<const std::uint8_t> page,
                                             ConfigPageFault* fault) {
  ConfigPage out;
  for (const Region& r : layout.regions()) {
    std::size_t pos = r.offset;
    const std::size_t end = r.offset + r.length;
    while (end - pos >= kMarkerLen) {
      const Marker m = marker_at(page.subspan(pos, kMarkerLen));
      if (m != Marker::None) {
        out.complete = m == Marker::End;
        return out;
      }
      if (end - pos < kEntryLen) break;  // padding: the next entry starts the next segment
      std::string why;
      auto e = decode_entry(page.subspan(pos, kEntryLen), &why);
      if (!e) {
        if (fault) *fault = {pos, "entry " + std::to_string(out.entries.size() + 1) + ": " + why};
        return std::nullopt;
      }
      out.entries.push_back(*e);
      pos += kEntryLen;
    }
  }
  if (fault) *fault = {layout.size(), "no end marker (DD DD DD DD or EE EE EE EE)"};
  return std::nullopt;
}

std::size_t encode_config_page(const Layout& layout, std::span<const RawEntry> entries,
                               std::span<std::uint8_t> page) {
  for (const Region& r : layout.regions())
    std::fill_n(page.begin() + static_cast<std::ptrdiff_t>(r.offset), r.length, 0);
  Packer packer(layout);
  std::size_t n = 0;
  while (n < entries.size()) {
    // Place the next entry only when the end marker still fits after it.
    Packer trial = packer;
    if (!trial.place(kEntryLen) || !trial.fits(kMarkerLen)) break;
    const std::size_t at = *packer.place(kEntryLen);
    std::copy(entries[n].begin(), entries[n].end(), page.begin() + static_cast<std::ptrdiff_t>(at));
    ++n;
  }
  if (auto at = packer.place(kMarkerLen)) {
    const std::uint8_t m = n == entries.size() ? kMarkerEnd : kMarkerMore;
    std::fill_n(page.begin() + static_cast<std::ptrdiff_t>(*at), kMarkerLen, m);
  }
  return n;
}

std::size_t encode_config_page(const Layout& layout, std::span<const IdEntry> entries,
                               std::span<std::uint8_t> page) {
  std::vector<RawEntry> raw;
  raw.reserve(entries.size());
  for (const auto& e : entries) raw.push_back(encode_entry(e));
  return encode_config_page(layout, std::span<const RawEntry>(raw), page);
}

std::vector<DataPlace> pack_data(const Layout& layout, std::span<const IdEntry> entries) {
  std::vector<DataPlace> out;
  out.reserve(entries.size());
  Packer packer(layout);
  std::uint16_t page_index = 0;
  for (const IdEntry& e : entries) {
    const std::size_t len = 1u + e.length;  // force / count_in + data
    if (len > layout.max_entry()) break;
    auto at = packer.place(len);
    if (!at) {
      packer = Packer(layout);
      ++page_index;
      at = packer.place(len);
    }
    out.push_back({page_index, static_cast<std::uint16_t>(*at)});
  }
  return out;
}

std::size_t pages_used(std::span<const DataPlace> places) {
  return places.empty() ? 0 : places.back().page + 1u;
}

}  // namespace candp2::page
