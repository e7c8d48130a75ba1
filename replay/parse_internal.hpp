// The parts of the scenario parser that its two files share (replay/parse_step.cpp,
// replay/parse_scenario.cpp). Errors are thrown as config::json_reader::Failure (JSON path and
// what was expected) and turned into a config::ConfigError by parse_scenario().
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "replay/scenario.hpp"

namespace candp2::replay::parse {

Duration as_ms(const nlohmann::json& j, const std::string& path, std::uint64_t max = 86400000);
// One step of "steps"; `sc` holds the installation and the driver already parsed.
Step parse_step(const nlohmann::json& j, const std::string& path, const Scenario& sc);

}  // namespace candp2::replay::parse
