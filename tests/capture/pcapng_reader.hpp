// The capture tests read what was written with the library's reader (capture/pcapng_read.hpp).
#pragma once

#include <cstdint>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "capture/pcapng_read.hpp"

namespace candp2::capture::test {

using pcapng::Capture;
using pcapng::Interface;
using pcapng::Packet;

inline std::vector<std::uint8_t> slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline Capture read_capture(const std::vector<std::uint8_t>& file) {
  return pcapng::read(file);
}

}  // namespace candp2::capture::test
