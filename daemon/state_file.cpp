#include "daemon/state_file.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

namespace candp2::daemon {

StoredMap load_state(const std::string& path, const Logger& log) {
  StoredMap out;
  std::ifstream in(path);
  if (!in) return out;  // nothing stored yet
  try {
    const auto j = nlohmann::json::parse(in);
    for (const auto& [key, v] : j.at("gateways").items()) {
      const int address = std::stoi(key);
      if (address < 0 || address > 255) continue;
      plant::StoredValues s;
      s.wakeup_s = static_cast<std::uint8_t>(std::min(v.at("wakeup_s").get<unsigned>(), 254u));
      s.sync_ms = static_cast<std::uint16_t>(std::min(v.at("sync_ms").get<unsigned>(), 65534u));
      out[static_cast<std::uint8_t>(address)] = s;
    }
  } catch (const std::exception& e) {
    log.error("state file " + path + " unreadable, using the configured values: " + e.what());
    out.clear();
  }
  return out;
}

bool save_state(const std::string& path, const StoredMap& state, std::string* error) {
  nlohmann::json j;
  j["gateways"] = nlohmann::json::object();
  for (const auto& [address, s] : state)
    j["gateways"][std::to_string(address)] = {{"wakeup_s", s.wakeup_s}, {"sync_ms", s.sync_ms}};
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << j.dump(2) << "\n";
    if (!out) {
      *error = "cannot write " + tmp + ": " + std::strerror(errno);
      return false;
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    *error = "cannot rename " + tmp + " to " + path + ": " + ec.message();
    return false;
  }
  return true;
}

bool prepare_folder_of(const std::string& path, std::string* why) {
  const auto folder = std::filesystem::path(path).parent_path();
  if (folder.empty()) return true;  // the working folder
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec) {
    *why = "cannot create its folder " + folder.string() + ": " + ec.message();
    return false;
  }
  if (::access(folder.c_str(), W_OK) != 0) {
    *why = "its folder " + folder.string() + " is not writable: " + std::strerror(errno);
    return false;
  }
  return true;
}

}  // namespace candp2::daemon
