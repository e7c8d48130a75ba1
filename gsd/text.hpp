// Lexical helpers shared by the GSD parser, the encoder and the summary (internal).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "gsd/gsd.hpp"

namespace candp2::gsd::detail {

std::string_view trim(std::string_view s);
std::string lower(std::string_view s);

// Reads tokens from one statement's value text. Never reads past the end.
class Scanner {
 public:
  explicit Scanner(std::string_view s) : s_(s) {}

  void ws();
  bool eof() const { return pos_ >= s_.size(); }
  bool eat(char c);
  std::size_t pos() const { return pos_; }
  std::string_view rest() const { return s_.substr(pos_); }

  // Decimal or 0x hex, optionally signed. A token that merely starts with digits ("1.1",
  // "12abc") is not a number: nothing is consumed. On overflow *error is set.
  std::optional<std::int64_t> number(bool allow_sign, std::string* error = nullptr);
  // "..." after optional blanks; the contents without the quotes.
  std::optional<std::string> quoted();
  // Letters, digits and '_' (a type name such as Unsigned8 or BitArea).
  std::string_view word();

 private:
  std::string_view s_;
  std::size_t pos_ = 0;
};

// Classifies a raw value: empty, number, number list, quoted string or other text.
Value classify(std::string_view raw);

}  // namespace candp2::gsd::detail
