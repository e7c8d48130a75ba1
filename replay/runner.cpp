#include "replay/runner.hpp"

#include <algorithm>

#include "replay/sim.hpp"

namespace candp2::replay {

std::size_t RunResult::expectations() const {
  return static_cast<std::size_t>(std::count_if(
      steps.begin(), steps.end(), [](const StepResult& s) { return s.expectation || !s.passed; }));
}

std::size_t RunResult::failures() const {
  return static_cast<std::size_t>(
      std::count_if(steps.begin(), steps.end(), [](const StepResult& s) { return !s.passed; }));
}

RunResult run(const Scenario& scenario, LogLevel level) {
  RunResult res;
  Sim sim(scenario, res, level);
  for (std::size_t i = 0; i < scenario.steps.size(); ++i)
    res.steps.push_back(sim.execute(scenario.steps[i], i + 1));
  res.end = sim.now();
  return res;
}

}  // namespace candp2::replay
