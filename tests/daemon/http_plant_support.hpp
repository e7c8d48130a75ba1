// Helpers for the tests of the HTTP face's pure parts on a real plant (http_face_test.cpp,
// http_slave_test.cpp): the status model's sources wired as the daemon wires them
// (daemon/daemon.cpp start_http), the plant run in virtual time, one live-view round run to its
// publication.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "common/time.hpp"
#include "http/http_status.hpp"
#include "http/live_view.hpp"
#include "modbus/plant_faces.hpp"
#include "plant/plant.hpp"

namespace candp2::test {

// Every gateway and generic slave with its Modbus face, every bus with its monitor from
// `monitors` (indexed like the plant's buses; none when null) at 500 kbit/s.
inline http::StatusSources status_sources(plant::Plant& plant, modbus::PlantFaces& faces,
                                          std::vector<http::BusMonitor>* monitors = nullptr) {
  http::StatusSources src;
  src.master = &plant.master();
  src.cycle = &plant.cycle_stats();
  for (auto& g : plant.gateways())
    src.gateways.push_back({&g->config(), &g->gateway(), faces.gateways.at(g->index()).get()});
  for (auto& s : plant.slaves())
    src.slaves.push_back({&s->config(), &s->slave(),
                          faces.gateways.at(plant.gateways().size() + s->index()).get(), false});
  for (auto& b : plant.buses())
    src.buses.push_back({&b->config(), monitors ? &monitors->at(b->index()) : nullptr, 500000});
  return src;
}

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
