#include "can/socketcand_protocol.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>

#include "common/hex.hpp"

namespace candp2::can {

// ---------------------------------------------------------------------------------------------
// Pure protocol functions
// ---------------------------------------------------------------------------------------------

namespace socketcand {

namespace {

constexpr std::size_t kItemTextLimit = 64;  // how much of a stray run or overflow we keep for logs
constexpr std::uint32_t kCanErrFlag = 0x20000000U;  // linux/can.h CAN_ERR_FLAG
constexpr std::uint32_t kCanErrMask = 0x1FFFFFFFU;  // linux/can.h CAN_ERR_MASK

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n';
}

bool parse_hex(std::string_view text, std::uint32_t* value) {
  const auto v = parse_hex_u32(text);
  if (v) *value = *v;
  return v.has_value();
}

// socketcand: `%03X` for 11-bit, `%08X` for 29-bit; an 8-character identifier is 29-bit
// (state_raw.c: element_length(buf, 2) == 8 → CAN_EFF_FLAG). Values above 0x7FF with fewer digits
// are taken as 29-bit too (python-can writes `{:X}` without padding).
bool parse_id(std::string_view text, Frame* f, std::string* error) {
  std::uint32_t v = 0;
  if (!parse_hex(text, &v)) {
    *error = "bad identifier '" + std::string(text.substr(0, 16)) + "' (1 to 8 hex digits)";
    return false;
  }
  if (v > kMaxExtId) {
    *error = "identifier " + std::string(text) + " above 1FFFFFFF";
    return false;
  }
  f->extended = text.size() == 8 || v > kMaxStdId;
  f->id = v;
  return true;
}

FrameResult failed(std::string message) {
  FrameResult r;
  r.error = std::move(message);
  return r;
}

bool is_timestamp(std::string_view t) {
  const auto dot = t.find('.');
  if (dot == std::string_view::npos || dot == 0 || dot + 1 == t.size()) return false;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (i != dot && (t[i] < '0' || t[i] > '9')) return false;
  return true;
}

void append_hex_byte(std::string& out, std::uint8_t b, bool upper, bool pad) {
  static constexpr char kUpper[] = "0123456789ABCDEF";
  static constexpr char kLower[] = "0123456789abcdef";
  const char* digits = upper ? kUpper : kLower;
  if (pad || b >= 0x10) out += digits[b >> 4];
  out += digits[b & 0xF];
}

std::string format_id(const Frame& f) {
  return ident_text(ident_of(f));  // socketcand writes `%03X` / `%08X`, as candump does
}

}  // namespace

void ElementSplitter::flush_stray(std::vector<Item>& out) {
  if (stray_bytes_ == 0) return;
  out.push_back({Kind::Stray, std::move(stray_), stray_bytes_});
  stray_.clear();
  stray_bytes_ = 0;
}

void ElementSplitter::feed(std::string_view bytes, std::vector<Item>& out) {
  for (const char c : bytes) {
    if (in_element_) {
      if (c == '<') {
        // A new element starts before the previous one closed: the unclosed part is stray.
        stray_ = partial_.substr(0, kItemTextLimit);
        stray_bytes_ = partial_.size();
        flush_stray(out);
        partial_.assign(1, '<');
        continue;
      }
      partial_ += c;
      if (c == '>') {
        const std::size_t n = partial_.size();
        out.push_back({Kind::Element, std::move(partial_), n});
        partial_.clear();
        in_element_ = false;
      } else if (partial_.size() > max_) {
        const std::size_t n = partial_.size();
        out.push_back({Kind::Overflow, partial_.substr(0, kItemTextLimit), n});
        partial_.clear();
        in_element_ = false;
      }
      continue;
    }
    if (c == '<') {
      flush_stray(out);
      in_element_ = true;
      partial_.assign(1, '<');
    } else if (is_space(c)) {
      flush_stray(out);
    } else {
      if (stray_.size() < kItemTextLimit) stray_ += c;
      ++stray_bytes_;
    }
  }
  flush_stray(out);
}

std::vector<std::string_view> words(std::string_view element) {
  if (!element.empty() && element.front() == '<') element.remove_prefix(1);
  if (!element.empty() && element.back() == '>') element.remove_suffix(1);
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < element.size()) {
    while (i < element.size() && is_space(element[i])) ++i;
    std::size_t j = i;
    while (j < element.size() && !is_space(element[j])) ++j;
    if (j > i) out.push_back(element.substr(i, j - i));
    i = j;
  }
  return out;
}

std::string format_frame(const Frame& frame, Time wall_time) {
  const long long us = std::max<long long>(0, wall_time.count());
  char stamp[48];
  std::snprintf(stamp, sizeof stamp, "%lld.%06lld", us / 1000000, us % 1000000);
  std::string out = "< frame " + format_id(frame) + ' ' + stamp + ' ';
  for (std::uint8_t i = 0; i < frame.dlc && i < kMaxDlc; ++i)
    append_hex_byte(out, frame.data[i], /*upper=*/true, /*pad=*/true);
  out += " >";
  return out;
}

std::string format_send(const Frame& frame) {
  const std::uint8_t dlc = std::min(frame.dlc, kMaxDlc);
  std::string out = "< send " + format_id(frame) + ' ' + std::to_string(dlc) + ' ';
  for (std::uint8_t i = 0; i < dlc; ++i) {
    append_hex_byte(out, frame.data[i], /*upper=*/false, /*pad=*/false);
    out += ' ';
  }
  out += '>';
  return out;
}

FrameResult parse_send(std::string_view element) {
  const auto w = words(element);
  if (w.empty() || w[0] != "send") return failed("not a send command");
  if (w.size() < 3) return failed("send needs an identifier and a DLC");
  Frame f;
  std::string error;
  if (!parse_id(w[1], &f, &error)) return failed(std::move(error));
  // socketcand reads the DLC with %hhu (decimal); python-can writes {:X}: the same for 0..8.
  const auto dlc_text = w[2];
  if (dlc_text.empty() || dlc_text.size() > 2 ||
      !std::all_of(dlc_text.begin(), dlc_text.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return failed("bad DLC '" + std::string(dlc_text.substr(0, 8)) + "' (0 to 8)");
  const int dlc = std::stoi(std::string(dlc_text));
  if (dlc > kMaxDlc) return failed("DLC " + std::to_string(dlc) + " above 8");
  const std::size_t given = w.size() - 3;
  if (given != static_cast<std::size_t>(dlc))
    return failed("DLC " + std::to_string(dlc) + " but " + std::to_string(given) + " data bytes");
  f.dlc = static_cast<std::uint8_t>(dlc);
  for (int i = 0; i < dlc; ++i) {
    const auto b = w[3 + static_cast<std::size_t>(i)];
    std::uint32_t v = 0;
    if (b.size() > 2 || !parse_hex(b, &v))
      return failed("bad data byte '" + std::string(b.substr(0, 8)) + "' (1 or 2 hex digits)");
    f.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v);
  }
  FrameResult r;
  r.frame = f;
  return r;
}

FrameResult parse_frame(std::string_view element) {
  const auto w = words(element);
  if (w.empty() || w[0] != "frame") return failed("not a frame message");
  if (w.size() < 3) return failed("frame needs an identifier and a time stamp");
  Frame f;
  std::string error;
  if (!parse_id(w[1], &f, &error)) return failed(std::move(error));
  if (!is_timestamp(w[2]))
    return failed("bad time stamp '" + std::string(w[2].substr(0, 24)) + "'");
  // Raw mode writes the data as one word ("1122"), BCM mode as words of two digits ("11 22 ").
  std::string hex;
  for (std::size_t i = 3; i < w.size(); ++i) hex += w[i];
  if (hex.size() % 2 != 0 || hex.size() > 2 * kMaxDlc)
    return failed("frame data '" + hex.substr(0, 32) + "' is not 0 to 8 hex bytes");
  f.dlc = static_cast<std::uint8_t>(hex.size() / 2);
  for (std::size_t i = 0; i < f.dlc; ++i) {
    std::uint32_t v = 0;
    if (!parse_hex(std::string_view(hex).substr(2 * i, 2), &v))
      return failed("frame data '" + hex.substr(0, 32) + "' is not hex");
    f.data[i] = static_cast<std::uint8_t>(v);
  }
  FrameResult r;
  r.frame = f;
  return r;
}

std::optional<socketcan::RawFrame> parse_error_frame(std::string_view element) {
  const auto w = words(element);
  if (w.size() < 3 || w[0] != "error" || !is_timestamp(w[2])) return std::nullopt;
  std::uint32_t cls = 0;
  if (!parse_hex(w[1], &cls)) return std::nullopt;
  socketcan::RawFrame raw;
  raw.can_id = kCanErrFlag | (cls & kCanErrMask);
  raw.len = 8;  // CAN_ERR_DLC
  // BCM mode appends the data bytes ("%02X "); raw mode sends none.
  for (std::size_t i = 3; i < w.size() && i - 3 < raw.data.size(); ++i) {
    std::uint32_t v = 0;
    if (w[i].size() > 2 || !parse_hex(w[i], &v)) return std::nullopt;
    raw.data[i - 3] = static_cast<std::uint8_t>(v);
  }
  return raw;
}

}  // namespace socketcand

}  // namespace candp2::can
