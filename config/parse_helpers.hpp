// Parsing helpers shared by the configuration's files (config.cpp, gateway_config.cpp,
// slaves_config.cpp); not a public interface.
#pragma once

#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "config/config.hpp"
#include "config/json_reader.hpp"

namespace candp2::config::detail {

using nlohmann::json;
using namespace json_reader;

template <typename E>
E get_enum(const Object& o, const std::string& key, E fallback,
           const std::vector<std::pair<std::string, E>>& names) {
  const json* j = o.find(key);
  if (!j) return fallback;
  std::vector<std::string> quoted;
  for (const auto& [n, v] : names) quoted.push_back("\"" + n + "\"");
  if (j->is_string())
    for (const auto& [n, v] : names)
      if (j->get_ref<const std::string&>() == n) return v;
  fail(o.path(key), "expected one of " + join(quoted) + ", got " + kind_of(*j));
}

// $.master.baud and $.master.bus_parameters (config/line_config.cpp; docs/profibus.md "The line in
// time"); after $.profibus was read, whose keys of role master must not say the same again.
void parse_line(const Object& master, const json* profibus, DaemonConfig& c);
// The serial line's bus parameters: the DP default profile of `baud` (a DP rate) with
// $.profibus's slot_time_bits, retries and min_tsdr_bits over it (docs/profibus.md "Bus
// parameters"); the rules are not checked yet.
fdl::BusParameters read_profibus_bus_parameters(const Object& profibus, std::uint32_t baud);
// After $.profibus and $.master: the serial line's bus parameters against the one rule set
// (fdl::check_bus_parameters); an error names the key that set the parameter.
void check_profibus_bus_parameters(const Object& top, const DaemonConfig& c);

inline Endpoint get_endpoint(const json& j, const std::string& path) {
  const std::string text = as_string(j, path, "\"HOST:PORT\"");
  std::string error;
  auto e = parse_endpoint(text, &error);
  if (!e) fail(path, error);
  return *e;
}

// A name usable as a socketcand bus name and in log lines (socketcand.h MAX_BUSNAME).
inline bool valid_name(std::string_view s, std::size_t max) {
  return !s.empty() && s.size() <= max && std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  });
}

// Relative paths are relative to the configuration file's folder (json_reader::relative_to).
inline std::string resolve(const std::string& file, const std::string& p) {
  return relative_to(file, p);
}

// A CAN bit rate of manual table 5.1.1 as `can_bitrate` takes it ("500k", "125 kbit/s", 500000):
// its index in gw::kBitrates (config/gateway_config.cpp); throws Failure.
std::uint8_t parse_bitrate(const json& j, const std::string& path);

// A gateway entry (config/gateway_config.cpp); throws Failure.
GatewayConfig parse_gateway_or_throw(const json& j, const std::string& file,
                                     const std::string& path);
// Slots whose PLC bytes overlap: allowed, reported as warnings (docs/modbus.md).
void check_overlaps(const std::string& file, const std::vector<GatewayConfig*>& gateways,
                    std::vector<ConfigError>& warnings);

}  // namespace candp2::config::detail
