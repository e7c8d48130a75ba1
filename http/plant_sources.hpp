// The HTTP face's view of a plant (docs/development.md "Add a face"): it reads the plant through
// its accessors and its units' views (the status model's sources) and its tap (the bus monitors),
// never an engine, and builds both itself, so candp2d only wires.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "http/http_status.hpp"
#include "plant/plant.hpp"
#include "plant/station_status.hpp"
#include "plant/tap.hpp"

namespace candp2::http {

// Every CAN frame of the plant into the monitor of its bus (indexed like Plant::buses()), from the
// plant's tap: each frame exactly once, whatever the bus type (plant/tap.hpp).
class BusMonitors final : public plant::Tap {
 public:
  explicit BusMonitors(std::size_t buses) : buses_(buses) {}
  void on_can(const plant::CanRecord& r) override;
  const BusMonitor& at(std::size_t bus) const { return buses_.at(bus); }

 private:
  std::vector<BusMonitor> buses_;
};

// The status model's sources for `plant`: the master, its cycle and period; every gateway and
// generic slave (docs/slaves.md "Front panel and HTTP API") with its status as
// plant/station_status.hpp gathers it for every face (gateways with their bit rate group from
// `bitrate`), so the page, Modbus and /metrics never disagree; every bus with its monitor from
// `monitors` (none when null) and the CAN bit rate its first gateway is configured to (manual
// table 5.1.1); every drive; `modbus` for the Modbus server's figures (none when empty).
StatusSources make_sources(plant::Plant& plant, const BusMonitors* monitors = nullptr,
                           std::function<ModbusFigures()> modbus = {},
                           station::BitrateFn bitrate = {});

}  // namespace candp2::http
