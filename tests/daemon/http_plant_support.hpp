// Helpers for the tests of the HTTP face's pure parts on a real plant (http_face_test.cpp,
// http_slave_test.cpp; the sources come from http::make_sources, as in candp2d): the plant run in
// virtual time, one live-view round run to its publication.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "common/time.hpp"
#include "http/live_view.hpp"
#include "http/plant_sources.hpp"
#include "modbus/plant_faces.hpp"
#include "plant/plant.hpp"

namespace candp2::test {

// Advances the plant deadline by deadline up to `end`; `now` is the last deadline reached.
inline void run_plant_until(plant::Plant& plant, Time& now, Time end) {
  while (const auto next = plant.next_deadline()) {
    if (*next > end) break;
    plant.advance(*next);
    now = *next;
  }
}

// Runs one live-view round to its publication; returns the number of steps.
inline int run_round(http::LiveView& view, Time now, std::vector<std::size_t> open,
                     std::vector<std::size_t> slaves = {}) {
  view.start_round(now, std::move(open), std::move(slaves));
  int steps = 1;
  while (!view.step(now)) ++steps;
  return steps;
}

}  // namespace candp2::test
