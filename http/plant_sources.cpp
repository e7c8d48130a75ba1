#include "http/plant_sources.hpp"

#include "gateway/user_prm.hpp"

namespace candp2::http {

void BusMonitors::on_can(const plant::CanRecord& r) {
  if (r.bus < buses_.size()) buses_[r.bus].on_frame(r.frame, r.time);
}

StatusSources make_sources(plant::Plant& plant, const BusMonitors* monitors,
                           std::function<ModbusFigures()> modbus, station::BitrateFn bitrate) {
  StatusSources src;
  src.master = &plant.master();
  src.cycle_ms = plant.config().cycle_ms;
  src.cycle = &plant.cycle_stats();
  src.line = plant.timed_line();
  src.line_stats = plant.line_statistics();
  if (src.line)
    src.line_baud = src.line->baud();
  else if (plant.master_line())
    src.line_baud = plant.config().profibus->baud;  // role master: the real line's rate
  src.modbus = std::move(modbus);
  for (const auto& g : plant.gateways())
    src.gateways.push_back({&g->config(), g.get(), [&plant, unit = g.get(), bitrate](Time now) {
                              return station::gateway_status(plant, *unit, now, bitrate);
                            }});
  for (const auto& b : plant.buses()) {
    BusSource bs{&b->config(),
                 monitors ? &monitors->at(b->index()) : nullptr,
                 0,
                 b->virtual_bus() ? b->virtual_bus()->timed() : nullptr,
                 {}};
    if (bs.timed)
      bs.faults = [&plant, unit = b.get()](Time now) { return plant.can_faults(*unit, now); };
    for (const auto& g :
         plant.gateways())  // manual table 5.1.1: the bit rate the gateway is set to
      if (&g->bus() == b.get() && !bs.bitrate)
        bs.bitrate = gw::bitrate_bps(g->config().parameters.bitrate_index).value_or(0);
    src.buses.push_back(bs);
  }
  for (const auto& d : plant.drives()) src.drives.push_back({&d->config(), d.get()});
  for (const auto& s : plant.slaves())
    src.slaves.push_back(
        {&s->config(), s.get(),
         [&plant, unit = s.get()](Time now) { return station::slave_status(plant, *unit, now); },
         [unit = s.get()](Time now) { return station::slave_diagnosis(*unit, now); },
         plant.slave_line() != nullptr});
  return src;
}

}  // namespace candp2::http
