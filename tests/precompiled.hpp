// The test programs' precompiled header (docs/development.md "Precompiled test header"): what
// nearly every test source parses, GoogleTest and nlohmann::json with the standard headers they
// pull in, compiled once per build tree and given to every test source first. Only headers from
// outside the repository: a change to ours must not recompile every test.
#pragma once

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <sstream>
#include <string>
#include <string_view>
#include <unordered_map>
#include <variant>
#include <vector>
