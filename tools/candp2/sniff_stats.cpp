// `candp2 sniff --stats` output (docs/sniff.md "Line statistics: --stats").
#include "tools/candp2/sniff_stats.hpp"

#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>

namespace candp2::cli {

namespace {

std::string pad(std::string_view text, std::size_t width) {
  std::string s(width > text.size() ? width - text.size() : 0, ' ');
  return s.append(text);
}

}  // namespace

std::string stats_table(const fdl::LineStatistics& s, bool times) {
  constexpr std::size_t kMinWidth = 7;
  std::string out = pad("station", kMinWidth) + pad("live", kMinWidth + 2);
  for (const auto& f : fdl::kStationStats)
    out += pad(f.name, std::max(kMinWidth, f.name.size()) + 2);
  out += "\n";
  for (const std::uint8_t a : s.stations()) {
    out += pad(std::to_string(a), kMinWidth) + pad(fdl::to_string(s.live(a)), kMinWidth + 2);
    for (const auto& f : fdl::kStationStats)
      out += pad(std::to_string(s.station(a).*f.member), std::max(kMinWidth, f.name.size()) + 2);
    out += "\n";
  }
  out += "line: " + std::to_string(s.telegrams()) + " telegrams, " +
         std::to_string(s.illegals_unattributed()) + " illegals unattributed, token rotation ";
  const fdl::RotationTimes& r = s.rotation();
  if (!times) {
    out += "unknown (no times in a raw capture)";
  } else if (r.count == 0) {
    out += "not seen";
  } else {
    char buf[160];
    std::snprintf(buf, sizeof buf, "last %lld min %lld mean %lld max %lld us (%llu rotations)",
                  static_cast<long long>(r.last.count()), static_cast<long long>(r.min.count()),
                  static_cast<long long>(r.mean().count()), static_cast<long long>(r.max.count()),
                  static_cast<unsigned long long>(r.count));
    out += buf;
  }
  return out + "\n";
}

std::string stats_json(const fdl::LineStatistics& s, bool times) {
  nlohmann::ordered_json stations = nlohmann::ordered_json::array();
  nlohmann::ordered_json live = {{"ok", nlohmann::ordered_json::array()},
                                 {"missing", nlohmann::ordered_json::array()},
                                 {"phantom", nlohmann::ordered_json::array()}};
  for (const std::uint8_t a : s.stations()) {
    const fdl::Live l = s.live(a);
    nlohmann::ordered_json st = {{"address", a}, {"live", fdl::to_string(l)}};
    for (const auto& f : fdl::kStationStats) st[std::string(f.name)] = s.station(a).*f.member;
    stations.push_back(std::move(st));
    if (l != fdl::Live::None) live[std::string(fdl::to_string(l))].push_back(a);
  }
  nlohmann::ordered_json doc;
  doc["stations"] = std::move(stations);
  doc["live_list"] = std::move(live);
  doc["illegals_unattributed"] = s.illegals_unattributed();
  doc["telegrams"] = s.telegrams();
  const fdl::RotationTimes& r = s.rotation();
  if (times)
    doc["rotation_us"] = {{"last", r.last.count()},
                          {"min", r.min.count()},
                          {"mean", r.mean().count()},
                          {"max", r.max.count()},
                          {"count", r.count}};
  else
    doc["rotation_us"] = nullptr;
  return doc.dump();
}

}  // namespace candp2::cli
