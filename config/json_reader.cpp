#include "config/json_reader.hpp"

#include <algorithm>
#include <charconv>
#include <filesystem>

#include "config/config.hpp"

namespace candp2::config::json_reader {

void fail(const std::string& path, std::string message) {
  throw Failure{path, std::move(message)};
}

namespace {

bool plain_key(std::string_view key) {
  if (key.empty()) return false;
  return std::all_of(key.begin(), key.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
  });
}

}  // namespace

std::string member(const std::string& path, std::string_view key) {
  if (plain_key(key)) return path + "." + std::string(key);
  return path + "[" + json(std::string(key)).dump() + "]";
}

std::string element(const std::string& path, std::size_t i) {
  return path + "[" + std::to_string(i) + "]";
}

std::string kind_of(const json& j) {
  switch (j.type()) {
    case json::value_t::null:
      return "null";
    case json::value_t::object:
      return "an object";
    case json::value_t::array:
      return "an array";
    case json::value_t::string:
      return "the string " + j.dump();
    case json::value_t::boolean:
      return j.get<bool>() ? "true" : "false";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float:
      return "the number " + j.dump();
    default:
      return "an unsupported value";
  }
}

std::string join(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : ", ") + w;
  return out;
}

std::string relative_to(const std::string& file, const std::string& path) {
  namespace fs = std::filesystem;
  if (fs::path(path).is_absolute()) return path;
  const fs::path dir = fs::path(file).parent_path();
  return dir.empty() ? path : (dir / path).lexically_normal().string();
}

Object::Object(const json& j, std::string path, std::vector<std::string> allowed)
    : j_(j), path_(std::move(path)), allowed_(std::move(allowed)) {
  if (!j_.is_object()) fail(path_, "expected an object, got " + kind_of(j_));
  for (const auto& [key, value] : j_.items()) {
    if (!key.empty() && key[0] == '_') continue;
    if (std::find(allowed_.begin(), allowed_.end(), key) == allowed_.end())
      fail(member(path_, key), "unknown key (expected one of: " + join(allowed_) + ")");
  }
}

const json& Object::at(const std::string& key) const {
  if (!j_.contains(key)) fail(path_, "missing key \"" + key + "\"");
  return j_.at(key);
}

std::uint64_t as_uint(const json& j, const std::string& path, std::uint64_t min, std::uint64_t max,
                      std::string_view unit) {
  const std::string expected = "expected a number from " + std::to_string(min) + " to " +
                               std::to_string(max) + (unit.empty() ? "" : ' ' + std::string(unit)) +
                               " (a JSON number or a \"0x…\" string)";
  std::uint64_t v = 0;
  if (j.is_number_unsigned()) {
    v = j.get<std::uint64_t>();
  } else if (j.is_number_integer()) {
    fail(path, expected + ", got " + kind_of(j));  // negative
  } else if (j.is_number_float()) {
    fail(path, expected + ", got " + kind_of(j) + " (not a whole number)");
  } else if (j.is_string()) {
    const auto& s = j.get_ref<const std::string&>();
    if (s.size() < 3 || s[0] != '0' || (s[1] != 'x' && s[1] != 'X'))
      fail(path, expected + ", got " + kind_of(j));
    const auto [p, ec] = std::from_chars(s.data() + 2, s.data() + s.size(), v, 16);
    if (ec != std::errc{} || p != s.data() + s.size())
      fail(path, expected + ", got " + kind_of(j) + " (not a hex number)");
  } else {
    fail(path, expected + ", got " + kind_of(j));
  }
  if (v < min || v > max) fail(path, expected + ", got " + std::to_string(v));
  return v;
}

std::string as_string(const json& j, const std::string& path, std::string_view what, Empty empty) {
  if (!j.is_string())
    fail(path, "expected " + std::string(what) + " (a string), got " + kind_of(j));
  const auto& s = j.get_ref<const std::string&>();
  if (s.empty() && empty == Empty::Rejected)
    fail(path, "expected " + std::string(what) + ", got an empty string");
  return s;
}

bool as_bool(const json& j, const std::string& path) {
  if (!j.is_boolean()) fail(path, "expected true or false, got " + kind_of(j));
  return j.get<bool>();
}

std::vector<std::uint8_t> as_hex(const json& j, const std::string& path, std::string_view like) {
  const std::string text = as_string(j, path, "hex bytes");
  std::string error;
  auto bytes = parse_hex(text, &error);
  if (!bytes) fail(path, "expected hex bytes like \"" + std::string(like) + "\": " + error);
  return *bytes;
}

bool get_bool(const Object& o, const std::string& key, bool fallback) {
  const json* j = o.find(key);
  if (!j) return fallback;
  return as_bool(*j, o.path(key));
}

std::string get_string(const Object& o, const std::string& key, std::string_view what) {
  return as_string(o.at(key), o.path(key), what);
}

std::optional<std::string> find_string(const Object& o, const std::string& key,
                                       std::string_view what) {
  const json* j = o.find(key);
  if (!j) return std::nullopt;
  return as_string(*j, o.path(key), what);
}

}  // namespace candp2::config::json_reader
