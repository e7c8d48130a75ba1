// The one table of replay actions (docs/replay-format.md, docs/development.md "Add a replay
// step"): per action its step key, whether it acts or expects (and whether a passed expectation
// was polled), what it concerns (a gateway, a station, a generic slave, a drive, the Page-Mode
// driver, a bus), how its value is parsed (replay/parse_step.cpp), how it runs (Sim, replay/
// sim.cpp, replay/steps.cpp) and how the report describes it. The parser, the runner and the
// report read only this table; a row without parser, handler or description does not compile
// (replay/actions.cpp).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>

#include "replay/scenario.hpp"

namespace candp2::replay {

class Sim;
struct StepResult;

// A step's value as its parser gets it.
struct StepInput {
  const nlohmann::json& value;
  const std::string& path;  // of the value: "$.steps[3].write"
  const std::string& key;   // the action key: "write"
  const Scenario& scenario;
  bool slave = false;  // the step names a generic slave ("slave": NAME)
};

enum class Kind : std::uint8_t {
  Act,
  Expect,        // a check; it fails the scenario when it does not hold
  ExpectPolled,  // a check polled over its window: a pass reports when it held (runner.cpp)
};

// What a step concerns, and so which keys it takes besides its action (docs/replay-format.md).
enum class Target : std::uint8_t {
  None,     // time only
  Bus,      // inject: "bus" or "gateway" (that gateway's bus)
  Gateway,  // "gateway" (needed with several)
  Station,  // "gateway" or "slave": a gateway's or a generic slave's DP side
  Slave,    // "slave" (needed with several)
  Drive,    // "drive" (needed with several)
  Driver,   // the scenario's Page-Mode driver ("page_driver")
};

struct ActionSpec {
  Action action;
  std::string_view key;
  Kind kind;
  Target target;
  std::string_view window;  // the window key of an expectation: "within_ms" or "for_ms"
  void (*parse)(Step& s, const StepInput& in);
  void (Sim::*run)(const Step& s, StepResult& r);
  std::string (*describe)(const Step& s, std::string text);  // text: the key
};

// force_can_state values, as holding register 8193 (docs/faults.md).
inline constexpr const char* kCanStates[] = {"real", "warning", "error-passive", "bus-off"};

// Every action's row, indexed by the action.
std::span<const ActionSpec> actions();
const ActionSpec& spec(Action a);

}  // namespace candp2::replay
