// The hex byte reader (common/hex.hpp).
#include "common/hex.hpp"

namespace candp2 {

namespace {

bool is_separator(char c) {
  return c == ' ' || c == ',' || c == '\t';
}

std::string position(std::size_t i) {
  return "position " + std::to_string(i) + ": ";
}

std::uint8_t byte_at(std::string_view text, std::size_t i) {
  return static_cast<std::uint8_t>((hex_digit(text[i]) << 4) | hex_digit(text[i + 1]));
}

// One byte or the error at text[i] (not a separator); i moves past what was read.
std::optional<std::string> read(std::string_view text, HexForm form, std::size_t& i,
                                HexBytes& out) {
  switch (form) {
    case HexForm::Separated: {
      std::size_t j = i;
      while (j < text.size() && !is_separator(text[j])) ++j;
      for (std::size_t k = i; k < j; ++k)
        if (hex_digit(text[k]) < 0)
          return position(k) + "'" + std::string(1, text[k]) + "' is not a hex digit";
      if (j - i != 2)
        return position(i) + "'" + std::string(text.substr(i, j - i)) +
               "' is not one byte (write two hex digits per byte, e.g. 02,89,B8)";
      out.bytes.push_back(byte_at(text, i));
      out.care.push_back(true);
      i = j;
      return std::nullopt;
    }
    case HexForm::Runs: {
      if (hex_digit(text[i]) < 0)
        return position(i) + "'" + std::string(1, text[i]) + "' is not a hex digit";
      std::size_t j = i;
      while (j < text.size() && hex_digit(text[j]) >= 0) ++j;
      if ((j - i) % 2 != 0)
        return position(i) + "'" + std::string(text.substr(i, j - i)) +
               "' has an odd number of hex digits (write two digits per byte)";
      for (std::size_t k = i; k < j; k += 2) {
        out.bytes.push_back(byte_at(text, k));
        out.care.push_back(true);
      }
      i = j;
      return std::nullopt;
    }
    case HexForm::Patterns: {
      if (i + 1 < text.size() && text[i] == '?' && text[i + 1] == '?') {
        out.bytes.push_back(0);
        out.care.push_back(false);
      } else if (i + 1 >= text.size() || hex_digit(text[i]) < 0 || hex_digit(text[i + 1]) < 0) {
        return position(i) + "expected two hex digits or ?? per byte, e.g. \"00 33 ?? 00\"";
      } else {
        out.bytes.push_back(byte_at(text, i));
        out.care.push_back(true);
      }
      i += 2;
      return std::nullopt;
    }
  }
  return position(i) + "unknown hex form";
}

}  // namespace

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::optional<std::uint32_t> parse_hex_u32(std::string_view text, std::size_t* bad) {
  if (bad) *bad = 0;
  if (text.empty() || text.size() > 8) return std::nullopt;
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const int d = hex_digit(text[i]);
    if (d < 0) {
      if (bad) *bad = i;
      return std::nullopt;
    }
    v = (v << 4) | static_cast<std::uint32_t>(d);
  }
  return v;
}

std::optional<HexBytes> parse_hex_bytes(std::string_view text, HexForm form, std::string* error,
                                        bool allow_empty) {
  HexBytes out;
  std::size_t i = 0;
  while (i < text.size()) {
    if (is_separator(text[i])) {
      ++i;
      continue;
    }
    if (auto why = read(text, form, i, out)) {
      if (error) *error = std::move(*why);
      return std::nullopt;
    }
  }
  if (out.bytes.empty() && !allow_empty) {
    if (error) *error = "no bytes given";
    return std::nullopt;
  }
  return out;
}

}  // namespace candp2
