// The daemon configuration's watchdogs against the watchdog rule (docs/validate.md "The watchdog
// rule").
#include "config/watchdog_check.hpp"

#include <algorithm>

#include "config/slaves_config.hpp"
#include "profibus_sim/dp/dp_slave.hpp"

namespace candp2::config {

namespace {

fdl::WatchdogStation station(const dp::SlaveParameters& p, std::size_t diag_bytes) {
  const dp::ImageMap map = dp::map_image(p);
  return {map.out_len, map.in_len, p.prm.size(), p.cfg.size(), diag_bytes};
}

}  // namespace

fdl::WatchdogLine watchdog_line(const DaemonConfig& c) {
  fdl::WatchdogLine line;
  line.cycle_ms = c.cycle_ms;
  line.late_ms = c.profibus ? 0 : c.host_stall_ms;
  std::vector<bool> taken(128, false);
  // A CAN-DP/2 answers Slave_Diag with 11 bytes, a generic slave with 6 until a fault adds its
  // Ext_Diag_Data (docs/dp-slave.md "Diagnosis", docs/slaves.md).
  for (const auto& g : c.gateways) {
    line.stations.push_back(station(slave_parameters(g), dp::DpSlave::kDiagLen));
    taken[g.dp_address() & 0x7F] = true;
  }
  for (const auto& s : c.slaves) {
    line.stations.push_back(station(slave_parameters(s), dp::kDiagStdLen));
    taken[s.address & 0x7F] = true;
  }
  if (!c.line) return line;
  line.baud = c.line->baud;
  line.params = c.line->params;
  line.gap = false;  // a free address above the master's own up to HSA
  for (unsigned a = c.master_address + 1u; a <= std::min(line.params.hsa, 126u); ++a)
    line.gap = line.gap || !taken[a];
  return line;
}

std::vector<WatchdogProblem> check_watchdogs(const DaemonConfig& c) {
  std::vector<WatchdogProblem> out;
  if (c.profibus && c.profibus->role == ProfibusRole::Slaves) return out;
  const auto bounds = fdl::watchdog_bounds(watchdog_line(c));
  auto judge = [&](const std::string& station, const std::string& path, std::uint32_t ms) {
    auto f = fdl::judge_watchdog(bounds, ms);
    if (f.verdict != fdl::WatchdogVerdict::Holds)
      out.push_back({station, path, f.verdict, std::move(f.message)});
  };
  for (const auto& g : c.gateways)
    judge(g.json_path, g.json_path + ".parameters.watchdog_ms", g.watchdog_ms);
  for (const auto& s : c.slaves) judge(s.json_path, s.json_path + ".watchdog_ms", s.watchdog_ms);
  return out;
}

}  // namespace candp2::config
