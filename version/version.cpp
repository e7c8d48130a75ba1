#include "version/version.hpp"

namespace candp2 {

std::string version_line(std::string_view program) {
  std::string line(program);
  line += ' ';
  line += version();
  line += " (revision ";
  line += source_revision();
  line += ')';
  return line;
}

}  // namespace candp2
