// ParameterStore on a state file (the --state option of candp2-drive). The only file I/O of the
// drive library; the simulator core never touches files.
#pragma once

#include <string>

#include "drive_sim/parameter_store.hpp"

namespace candp2::drive {

class FileParameterStore final : public ParameterStore {
 public:
  explicit FileParameterStore(std::string path) : path_(std::move(path)) {}
  // A missing file is "nothing stored yet" (nullopt, empty error).
  std::optional<StoredParameters> load(std::string* error) override;
  // Writes PATH.tmp and renames it over PATH, so a crash never leaves a half-written file.
  bool save(const StoredParameters& parameters, std::string* error) override;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace candp2::drive
