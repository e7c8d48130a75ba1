// Golden files for the tests that keep documents byte for byte (docs/development.md "Golden
// documents"): the actual text is written to the build tree's golden-actual/ for a diff, and with
// CANDP2_UPDATE_GOLDEN=1 over the golden file (review the diff before committing).
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace candp2::test {

inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void write_text(const std::filesystem::path& p, const std::string& text) {
  std::filesystem::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

// Compares `kept` with the golden file `golden`; `actual` (the whole text) goes to
// golden-actual/`name` in the current directory.
inline void expect_golden_file(const std::filesystem::path& golden, const std::string& name,
                               const std::string& actual, const std::string& kept) {
  const auto actual_path = std::filesystem::current_path() / "golden-actual" / name;
  write_text(actual_path, actual);
  const char* u = std::getenv("CANDP2_UPDATE_GOLDEN");
  if (u && std::string(u) == "1") write_text(golden, kept);
  ASSERT_TRUE(std::filesystem::exists(golden)) << golden << " missing (CANDP2_UPDATE_GOLDEN=1)";
  EXPECT_TRUE(read_text(golden) == kept)
      << name << " differs from " << golden << ": the actual text is " << actual_path;
}

}  // namespace candp2::test
