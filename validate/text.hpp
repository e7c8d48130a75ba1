// Small text pieces the report and the warnings of `candp2 validate` share (docs/validate.md).
#pragma once

#include <cstddef>
#include <string>

namespace candp2::validate {

// "1 byte", "3 bytes".
inline std::string plural(std::size_t n, const char* word) {
  return std::to_string(n) + " " + word + (n == 1 ? "" : "s");
}

// PLC byte addresses: "12" for one byte, "12..15" for four.
inline std::string range(std::size_t begin, std::size_t len) {
  if (len <= 1) return std::to_string(begin);
  return std::to_string(begin) + ".." + std::to_string(begin + len - 1);
}

}  // namespace candp2::validate
