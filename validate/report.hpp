// The output of `candp2 validate` (docs/validate.md): a text report and a JSON document with the
// same content. Deterministic (golden tests compare it byte for byte).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "validate/validate.hpp"

namespace candp2::validate {

std::string format_text(const Report& r);
nlohmann::ordered_json to_json(const Report& r, int exit_code);

// Diagnosis bytes 8..10 explained in a sentence: the state and the fault, with its rule.
std::string explain_diagnosis(const GatewayReport& g);

}  // namespace candp2::validate
