#include "drive_sim/file_parameter_store.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

namespace candp2::drive {

std::optional<StoredParameters> FileParameterStore::load(std::string* error) {
  if (error) error->clear();
  std::error_code ec;
  if (!std::filesystem::exists(path_, ec)) {
    if (ec && error) *error = "cannot access state file " + path_ + ": " + ec.message();
    return std::nullopt;
  }
  std::ifstream in(path_, std::ios::binary);
  if (!in) {
    if (error) *error = "cannot open state file " + path_ + ": " + std::strerror(errno);
    return std::nullopt;
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) {
    if (error) *error = "cannot read state file " + path_;
    return std::nullopt;
  }
  StateFileParse parsed = parse_state_file(text.str());
  if (!parsed.parameters) {
    if (error) *error = "state file " + path_ + " rejected, " + parsed.error;
    return std::nullopt;
  }
  return std::move(parsed.parameters);
}

bool FileParameterStore::save(const StoredParameters& parameters, std::string* error) {
  const std::string tmp = path_ + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      if (error) *error = "cannot create " + tmp + ": " + std::strerror(errno);
      return false;
    }
    out << format_state_file(parameters);
    out.flush();
    if (!out) {
      if (error) *error = "cannot write " + tmp;
      std::remove(tmp.c_str());
      return false;
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path_, ec);
  if (ec) {
    if (error) *error = "cannot replace " + path_ + ": " + ec.message();
    std::remove(tmp.c_str());
    return false;
  }
  return true;
}

}  // namespace candp2::drive
