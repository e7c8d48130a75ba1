// The version of candp2's executables: the project version (CMakeLists.txt `project(VERSION)`) and
// the source revision the binary was built from (`git describe --always --dirty`, re-read on every
// build by version/gen_version.cmake; "unknown" when not built from a git checkout).
#pragma once

#include <string>
#include <string_view>

namespace candp2 {

// "0.1.0"
const char* version();
// "ed70f9e", "v0.1.0-3-ged70f9e-dirty", or "unknown".
const char* source_revision();
// `--version` output: "candp2d 0.1.0 (revision ed70f9e)".
std::string version_line(std::string_view program);

}  // namespace candp2
