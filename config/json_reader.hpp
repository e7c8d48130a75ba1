// Strict JSON reading shared by the daemon configuration (config/config.cpp) and the replay
// scenarios (replay/scenario.cpp): errors carry the JSON path ("$.gateways[0].slots[2].comment")
// and say what was expected and what was found, objects reject unknown keys ('_' keys are
// comments), numbers are JSON numbers or "0x…" strings (docs/configuration.md,
// docs/replay-format.md).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace candp2::config::json_reader {

using json = nlohmann::json;

// Thrown inside a parser, caught at its API boundary and turned into a ConfigError.
struct Failure {
  std::string path;
  std::string message;
};

[[noreturn]] void fail(const std::string& path, std::string message);

// "$.a" + "b" → "$.a.b"; keys that are not plain identifiers are quoted: "$.a[\"x y\"]".
std::string member(const std::string& path, std::string_view key);
// "$.a" + 2 → "$.a[2]".
std::string element(const std::string& path, std::size_t i);
// What a value is, for "got …": "null", "an object", "the string \"x\"", "the number 5", ….
std::string kind_of(const json& j);
// "a, b, c".
std::string join(const std::vector<std::string>& words);
// A path from the configuration `file`: relative paths are relative to the file's directory.
std::string relative_to(const std::string& file, const std::string& path);

// An object whose keys are checked: unknown keys are errors, '_' keys are comments.
class Object {
 public:
  Object(const json& j, std::string path, std::vector<std::string> allowed);
  bool has(const std::string& key) const { return j_.contains(key); }
  // The value of a required key; fails with "missing key" when absent.
  const json& at(const std::string& key) const;
  const json* find(const std::string& key) const {
    const auto it = j_.find(key);
    return it == j_.end() ? nullptr : &*it;
  }
  std::string path(const std::string& key) const { return member(path_, key); }
  const std::string& path() const { return path_; }

 private:
  const json& j_;
  std::string path_;
  std::vector<std::string> allowed_;
};

// A whole number from min to max as a JSON number or a "0x…" string; unit is named in the error.
std::uint64_t as_uint(const json& j, const std::string& path, std::uint64_t min, std::uint64_t max,
                      std::string_view unit = {});

enum class Empty { Rejected, Allowed };
// A string; what says what it should be ("hex bytes", "a name").
std::string as_string(const json& j, const std::string& path, std::string_view what,
                      Empty empty = Empty::Rejected);
bool as_bool(const json& j, const std::string& path);
// Hex bytes as parse_hex() reads them; like is an example for the error message.
std::vector<std::uint8_t> as_hex(const json& j, const std::string& path, std::string_view like);

// Optional keys with a fallback, required keys.
template <typename T>
T get_uint(const Object& o, const std::string& key, T fallback, std::uint64_t min,
           std::uint64_t max, std::string_view unit = {}) {
  const json* j = o.find(key);
  if (!j) return fallback;
  return static_cast<T>(as_uint(*j, o.path(key), min, max, unit));
}
bool get_bool(const Object& o, const std::string& key, bool fallback);
std::string get_string(const Object& o, const std::string& key, std::string_view what);
std::optional<std::string> find_string(const Object& o, const std::string& key,
                                       std::string_view what);

}  // namespace candp2::config::json_reader
