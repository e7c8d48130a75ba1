// The front panel's files (web/*.html, *.css, *.js), embedded into candp2d at build time
// (web/embed.cmake): the page works with no network and no files next to the binary.
#pragma once

#include <span>
#include <string_view>

namespace candp2::web {

struct Asset {
  std::string_view path;  // URL path, "/index.html"
  const char* content_type;
  std::span<const unsigned char> body;
};

std::span<const Asset> assets();

}  // namespace candp2::web
