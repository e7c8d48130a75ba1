// Vendor files as extras (docs/development.md "Vendor files"). The vendor GSD corpus and the
// vendor manuals are not part of the repository: the tests run on the project's own files
// (tests/gsd/data). A test that also checks a vendor file reads it from the folder the environment
// variable CANDP2_GSD_CORPUS or CANDP2_MANUALS names; without the variable it is skipped with a
// message, and its suite name begins with "Vendor" so that tools/setup.sh can say how many did not
// run. A variable that names no folder is a failure, not a skip.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

namespace candp2::test {

inline constexpr const char* kGsdCorpusVar = "CANDP2_GSD_CORPUS";
inline constexpr const char* kManualsVar = "CANDP2_MANUALS";

// The folder `var` names, or nothing when it is unset or empty.
inline std::optional<std::filesystem::path> vendor_dir(const char* var) {
  const char* v = std::getenv(var);
  if (!v || !*v) return std::nullopt;
  return std::filesystem::path(v);
}

// The folder of the project's own GSD files, written for the tests (tests/gsd/data/README.md),
// and one of them.
inline std::filesystem::path project_gsd_dir() {
  return (std::filesystem::path(CANDP2_SOURCE_DIR) / "tests" / "gsd" / "data").lexically_normal();
}
inline std::filesystem::path project_gsd(const std::string& file) {
  return project_gsd_dir() / file;
}

}  // namespace candp2::test

// In a test body: `dir` is the folder `var` names; without it the test is skipped.
#define CANDP2_VENDOR_DIR(dir, var)                                                   \
  const auto dir##_given = ::candp2::test::vendor_dir(var);                           \
  if (!dir##_given) GTEST_SKIP() << "vendor files not given (" << (var) << " unset)"; \
  ASSERT_TRUE(std::filesystem::is_directory(*dir##_given))                            \
      << (var) << "=" << dir##_given->string() << " is not a folder";                 \
  const std::filesystem::path dir = *dir##_given
