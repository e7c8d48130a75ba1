// A slave's configuration — the Chk_Cfg identifier bytes of its modules — and how Chk_Cfg is
// judged against it (docs/slaves.md "Chk_Cfg"): the bytes must equal the slave's own
// configuration, which must keep within the GSD's Max_Module, Max_Input_Len, Max_Output_Len and
// Max_Data_Len. The identifier formats are decoded by gsd::decode_config (dp::decode_chk_cfg).
// Pure.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "gsd/cfg.hpp"
#include "gsd/gsd.hpp"
#include "gsd_slave/profile.hpp"

namespace candp2::gsd_slave {

struct Configuration {
  std::vector<std::uint8_t> bytes;          // the Chk_Cfg data of the whole slave
  std::vector<const gsd::Module*> modules;  // in slot order; empty when given as raw bytes
  gsd::CfgDecode decoded;                   // entries, input/output totals, a truncation
  std::size_t module_count() const {
    return modules.empty() ? decoded.entries.size() : modules.size();
  }
};

// The configuration of these modules (pointers into a model that outlives it).
Configuration configuration_of(std::vector<const gsd::Module*> modules);
// The configuration given as raw Chk_Cfg bytes (cfg_hex).
Configuration configuration_of(std::vector<std::uint8_t> bytes);

// The modules a configuration tool configures from the user's module list (docs/slaves.md
// "Preset modules"): the GSD's preset modules (Preset = 1) stand first, in GSD order, then the
// user's modules. A list that names none of them gets them added in front; a list that names
// any is taken as written, except that with FixPresetModules = 1 the preset modules must then
// stand exactly first, all of them, in GSD order, and nowhere else (a fixed module can be neither
// moved nor removed).
struct PresetProblem {
  std::size_t position = 0;  // the entry of the user's list it is about (= its size: the end)
  std::string text;          // names the module
};
struct WithPresets {
  std::vector<std::size_t> modules;      // the whole configuration: indices into model.modules
  std::size_t added = 0;                 // preset modules put in front: modules[0 .. added)
  std::optional<PresetProblem> problem;  // a fixed preset module moved or removed
};
// `user`: indices into model.modules, in the user's order.
WithPresets with_presets(const gsd::Model& model, std::span<const std::size_t> user);

// Our own numbers for a Cfg fault, for logs and `candp2 validate` (the wire has only the
// Cfg_Fault bit, IEC 61158-6-3).
enum class CfgCode : std::uint8_t {
  Differs = 1,         // Chk_Cfg is not the slave's configuration
  Malformed = 2,       // an identifier entry is truncated
  TooManyModules = 3,  // more than Max_Module
  InputTooLong = 4,    // more than Max_Input_Len
  OutputTooLong = 5,   // more than Max_Output_Len
  DataTooLong = 6,     // more than Max_Data_Len
};

struct CfgProblem {
  std::size_t entry = 0;  // the identifier entry (0-based) the fault is about
  CfgCode code = CfgCode::Differs;
  std::string text;
};

// The GSD's limits on a configuration.
std::optional<CfgProblem> check_limits(const Profile& profile, const Configuration& c);
// A Chk_Cfg against the slave's own configuration `real`: malformed, different (the first
// differing entry), then the limits.
std::optional<CfgProblem> check_chk_cfg(const Profile& profile, const Configuration& real,
                                        std::span<const std::uint8_t> chk_cfg);

}  // namespace candp2::gsd_slave
