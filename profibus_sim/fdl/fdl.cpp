// FDL telegram codec and stream parser (docs/profibus.md).
#include "profibus_sim/fdl/fdl.hpp"

#include <algorithm>

namespace candp2::fdl {

std::string_view to_string(Kind k) {
  switch (k) {
    case Kind::SD1:
      return "SD1";
    case Kind::SD2:
      return "SD2";
    case Kind::SD3:
      return "SD3";
    case Kind::SD4:
      return "SD4";
    case Kind::SC:
      return "SC";
  }
  return "?";
}

std::string_view to_string(Error e) {
  switch (e) {
    case Error::None:
      return "ok";
    case Error::Empty:
      return "empty";
    case Error::BadStart:
      return "no start delimiter";
    case Error::Truncated:
      return "truncated telegram";
    case Error::LeOutOfRange:
      return "LE out of range 3..249";
    case Error::LeMismatch:
      return "LE != LEr";
    case Error::BadSd2Repeat:
      return "second SD2 missing";
    case Error::BadFcs:
      return "FCS wrong";
    case Error::MissingEd:
      return "ED missing";
    case Error::SapMissing:
      return "SAP byte missing";
    case Error::BadSap:
      return "unsupported address extension";
    case Error::ParityError:
      return "parity error";
    case Error::TrailingBytes:
      return "bytes after ED";
  }
  return "?";
}

Telegram Telegram::with_data(std::uint8_t da, std::uint8_t sa, std::uint8_t fc,
                             std::optional<std::uint8_t> dsap, std::optional<std::uint8_t> ssap,
                             std::vector<std::uint8_t> du) {
  Telegram t{Kind::SD2, da, sa, fc, dsap, ssap, std::move(du)};
  const std::size_t n = t.du.size() + (dsap ? 1 : 0) + (ssap ? 1 : 0);
  if (n == kSd3DataLen) t.kind = Kind::SD3;
  return t;
}

void Telegram::assign(Kind k, std::uint8_t d, std::uint8_t s, std::uint8_t f) {
  kind = k;
  da = d;
  sa = s;
  fc = f;
  dsap.reset();
  ssap.reset();
  du.clear();
}

void Telegram::assign_with_data(std::uint8_t d, std::uint8_t s, std::uint8_t f,
                                std::optional<std::uint8_t> dsap_,
                                std::optional<std::uint8_t> ssap_,
                                std::span<const std::uint8_t> data) {
  assign(Kind::SD2, d, s, f);
  dsap = dsap_;
  ssap = ssap_;
  du.assign(data.begin(), data.end());
  if (du.size() + (dsap ? 1 : 0) + (ssap ? 1 : 0) == kSd3DataLen) kind = Kind::SD3;
}

std::uint8_t fcs(std::span<const std::uint8_t> bytes) {
  unsigned sum = 0;
  for (auto b : bytes) sum += b;
  return static_cast<std::uint8_t>(sum & 0xFF);
}

namespace {

bool valid_for_encode(const Telegram& t) {
  if (t.da > kAddrMask || t.sa > kAddrMask) return false;
  if ((t.dsap && *t.dsap > kSapMask) || (t.ssap && *t.ssap > kSapMask)) return false;
  const std::size_t n = t.du.size() + (t.dsap ? 1 : 0) + (t.ssap ? 1 : 0);
  switch (t.kind) {
    case Kind::SD1:
      return n == 0;
    case Kind::SD2:
      return n >= kLeMin - 3 && n <= kMaxDataUnit;
    case Kind::SD3:
      return n == kSd3DataLen;
    case Kind::SD4:
    case Kind::SC:
      return true;
  }
  return false;
}

}  // namespace

void encode_to(const Telegram& t, std::vector<std::uint8_t>& out) {
  if (!valid_for_encode(t)) return;
  if (t.kind == Kind::SC) {
    out.push_back(kSC);
    return;
  }
  const auto da = static_cast<std::uint8_t>(t.da | (t.dsap ? kAddrExt : 0));
  const auto sa = static_cast<std::uint8_t>(t.sa | (t.ssap ? kAddrExt : 0));
  const std::size_t at = out.size();
  if (t.kind == Kind::SD4) {
    out.resize(at + 3);
    std::uint8_t* p = out.data() + at;
    p[0] = kSD4;
    p[1] = da;
    p[2] = sa;
    return;
  }
  // One resize, then the bytes in place (a line encodes every telegram it carries).
  const std::size_t n = t.du.size() + (t.dsap ? 1 : 0) + (t.ssap ? 1 : 0);
  const std::size_t header = t.kind == Kind::SD2 ? 4 : 1;
  out.resize(at + header + 3 + n + 2);
  std::uint8_t* p = out.data() + at;
  switch (t.kind) {
    case Kind::SD1:
      *p++ = kSD1;
      break;
    case Kind::SD2: {
      const auto le = static_cast<std::uint8_t>(n + 3);
      *p++ = kSD2;
      *p++ = le;
      *p++ = le;
      *p++ = kSD2;
      break;
    }
    default:
      *p++ = kSD3;
      break;
  }
  const std::uint8_t* body = p;
  *p++ = da;
  *p++ = sa;
  *p++ = t.fc;
  if (t.dsap) *p++ = *t.dsap;
  if (t.ssap) *p++ = *t.ssap;
  if (!t.du.empty()) p = std::copy(t.du.begin(), t.du.end(), p);
  const std::uint8_t sum = fcs(std::span(body, p));
  *p++ = sum;
  *p = kED;
}

std::vector<std::uint8_t> encode(const Telegram& t) {
  std::vector<std::uint8_t> out;
  out.reserve(t.du.size() + 11);
  encode_to(t, out);
  return out;
}

namespace {

// Length of the candidate starting at b[0] when enough bytes are there to know it; 0 when more
// bytes are needed; sets `err` when the header is already inconsistent.
std::size_t candidate_length(std::span<const std::uint8_t> b, Error& err) {
  err = Error::None;
  switch (b[0]) {
    case kSC:
      return 1;
    case kSD4:
      return 3;
    case kSD1:
      return 6;
    case kSD3:
      return 6 + kSd3DataLen;
    case kSD2: {
      if (b.size() < 2) return 0;
      const std::size_t le = b[1];
      if (le < kLeMinRx || le > kLeMax) {
        err = Error::LeOutOfRange;
        return 0;
      }
      if (b.size() < 3) return 0;
      if (b[2] != b[1]) {
        err = Error::LeMismatch;
        return 0;
      }
      if (b.size() < 4) return 0;
      if (b[3] != kSD2) {
        err = Error::BadSd2Repeat;
        return 0;
      }
      return le + 6;
    }
    default:
      err = Error::BadStart;
      return 0;
  }
}

// Decodes a candidate whose length is exactly `b.size()` (as given by candidate_length).
DecodeResult decode_complete(std::span<const std::uint8_t> b) {
  DecodeResult r;
  Telegram t;
  switch (b[0]) {
    case kSC:
      t.kind = Kind::SC;
      r.telegram = t;
      r.length = 1;
      return r;
    case kSD4:
      t.kind = Kind::SD4;
      t.da = b[1] & kAddrMask;
      t.sa = b[2] & kAddrMask;
      r.telegram = t;
      r.length = 3;
      return r;
    default:
      break;
  }
  std::size_t body = 1;
  if (b[0] == kSD1) t.kind = Kind::SD1;
  if (b[0] == kSD3) t.kind = Kind::SD3;
  if (b[0] == kSD2) {
    t.kind = Kind::SD2;
    body = 4;
  }
  const std::size_t fcs_pos = b.size() - 2;
  if (b.back() != kED) {
    r.error = Error::MissingEd;
    return r;
  }
  if (fcs(b.subspan(body, fcs_pos - body)) != b[fcs_pos]) {
    r.error = Error::BadFcs;
    return r;
  }
  const std::uint8_t da = b[body], sa = b[body + 1];
  t.da = da & kAddrMask;
  t.sa = sa & kAddrMask;
  t.fc = b[body + 2];
  std::size_t pos = body + 3;
  if (t.kind != Kind::SD1) {
    for (int i = 0; i < 2; ++i) {
      const bool present = (i == 0 ? da : sa) & kAddrExt;
      if (!present) continue;
      if (pos >= fcs_pos) {
        r.error = Error::SapMissing;
        return r;
      }
      if (b[pos] & kSapExtMask) {
        r.error = Error::BadSap;
        return r;
      }
      (i == 0 ? t.dsap : t.ssap) = b[pos] & kSapMask;
      ++pos;
    }
    t.du.assign(b.begin() + static_cast<std::ptrdiff_t>(pos),
                b.begin() + static_cast<std::ptrdiff_t>(fcs_pos));
  }
  // SD1 with an address extension bit: there is no room for SAPs; the bits are ignored.
  r.telegram = std::move(t);
  r.length = b.size();
  return r;
}

}  // namespace

DecodeResult decode(std::span<const std::uint8_t> bytes) {
  DecodeResult r;
  if (bytes.empty()) {
    r.error = Error::Empty;
    return r;
  }
  Error err;
  const std::size_t len = candidate_length(bytes, err);
  if (err != Error::None) {
    r.error = err;
    return r;
  }
  if (len == 0 || bytes.size() < len) {
    r.error = Error::Truncated;
    return r;
  }
  r = decode_complete(bytes.first(len));
  if (r.error == Error::None && bytes.size() > len) {
    r.telegram.reset();
    r.error = Error::TrailingBytes;
  }
  return r;
}

// ---- StreamParser -------------------------------------------------------------------------------

void StreamParser::feed(std::span<const std::uint8_t> bytes) {
  stats_.bytes += bytes.size();
  buf_.insert(buf_.end(), bytes.begin(), bytes.end());
  bad_.insert(bad_.end(), bytes.size(), false);
  scan(false);
}

void StreamParser::feed_bad_char(std::uint8_t byte) {
  stats_.bytes += 1;
  buf_.push_back(byte);
  bad_.push_back(true);
  scan(false);
}

void StreamParser::gap() {
  scan(true);
}

std::optional<ParserEvent> StreamParser::next() {
  if (events_.empty()) return std::nullopt;
  ParserEvent e = std::move(events_.front());
  events_.pop_front();
  return e;
}

void StreamParser::emit_error(Error e, std::span<const std::uint8_t> raw) {
  ParserEvent ev;
  ev.error = e;
  ev.offset = buf_offset_;
  ev.raw.assign(raw.begin(), raw.end());
  switch (e) {
    case Error::BadFcs:
      ++stats_.fcs_errors;
      break;
    case Error::ParityError:
      ++stats_.parity_errors;
      break;
    default:
      ++stats_.framing_errors;
      break;
  }
  events_.push_back(std::move(ev));
}

void StreamParser::scan(bool at_gap) {
  std::size_t pos = 0;  // consumed prefix of buf_
  auto drop = [&](std::size_t n) {
    pos += n;
    buf_offset_ += n;
  };
  while (pos < buf_.size()) {
    const std::span<const std::uint8_t> rest(buf_.data() + pos, buf_.size() - pos);
    // Hunting: a byte that is no start delimiter, or one with a parity error, is garbage.
    if (bad_[pos]) {
      ++stats_.garbage_bytes;
      drop(1);
      continue;
    }
    Error err;
    const std::size_t len = candidate_length(rest, err);
    if (err == Error::BadStart) {
      ++stats_.garbage_bytes;
      drop(1);
      continue;
    }
    // A bad candidate is abandoned; scanning resumes at the byte after its start delimiter.
    auto abandon = [&](Error e, std::size_t n) {
      emit_error(e, rest.first(n));
      drop(1);
    };
    if (err != Error::None) {
      abandon(err, std::min<std::size_t>(rest.size(), 4));
      continue;
    }
    if (len == 0 || rest.size() < len) {
      // Incomplete. A parity error inside the known part already dooms it.
      bool doomed = false;
      for (std::size_t i = pos + 1; i < buf_.size(); ++i) doomed = doomed || bad_[i];
      if (doomed) {
        abandon(Error::ParityError, rest.size());
        continue;
      }
      if (at_gap) {
        abandon(Error::Truncated, rest.size());
        continue;
      }
      break;  // wait for more bytes
    }
    bool parity = false;
    for (std::size_t i = pos + 1; i < pos + len; ++i) parity = parity || bad_[i];
    if (parity) {
      abandon(Error::ParityError, len);
      continue;
    }
    DecodeResult r = decode_complete(rest.first(len));
    if (r.error != Error::None) {
      abandon(r.error, len);
      continue;
    }
    ParserEvent ev;
    ev.telegram = std::move(*r.telegram);
    ev.offset = buf_offset_;
    ev.raw.assign(rest.begin(), rest.begin() + static_cast<std::ptrdiff_t>(len));
    events_.push_back(std::move(ev));
    ++stats_.telegrams;
    drop(len);
  }
  buf_.erase(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(pos));
  bad_.erase(bad_.begin(), bad_.begin() + static_cast<std::ptrdiff_t>(pos));
}

}  // namespace candp2::fdl
