// The PROFIBUS line in role "master" (docs/profibus.md): the built-in DP master drives remote
// stations (a real CAN-DP/2, or another candp2d in role slaves) through the FDL master station.
// Pure: the serial port, its timers and its reopening after a hangup are the driver's
// (profibus_line/); it hands received bytes in and writes what transmit() gives it.
//
//   dp::DpMaster ─request─▶ fdl::FdlMaster (station N) ─▶ the tap ─▶ Port::write
//   received bytes ─▶ FdlMaster::on_bytes / on_bad_char / on_gap ─▶ DP completion
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/log.hpp"
#include "common/time.hpp"
#include "config/config.hpp"
#include "plant/slave_line.hpp"
#include "profibus_sim/fdl/fdl_master.hpp"
#include "profibus_sim/fdl/line_stats.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::plant {

class MasterLine {
 public:
  MasterLine(const config::ProfibusConfig& config, std::uint8_t master_address, LogSink* log);

  // The port the telegrams go to. `paced`: the port takes the bytes' wire time (a serial port),
  // false for a pseudo-terminal, which hands them over at once. Without a port (it died and is
  // being reopened) telegrams are lost on the wire and the slot time expires.
  using WriteFn = std::function<void(std::span<const std::uint8_t> bytes)>;
  void set_port(WriteFn write, bool paced, Duration latency_allowance);
  void clear_port() { write_ = nullptr; }
  bool has_port() const { return static_cast<bool>(write_); }
  void set_tap(std::function<void(std::span<const std::uint8_t>, bool from_emulation, Time)> tap) {
    tap_ = std::move(tap);
  }

  // The remote station at `address` as a DP link (for DpMaster::add_slave).
  dp::SlaveLink& station(std::uint8_t address) { return fdl_.station(address); }
  // A remote station the master drives: named in logs, configured in the line statistics.
  void add_remote(std::uint8_t address, std::string name);

  // The PHY's input, and the timers the driver arms: idle ≥ TSYN after the last character
  // (on_gap after bit_times(phy::kTsynBits)) and the FDL master's slot time (advance at
  // next_deadline()).
  void on_bytes(std::span<const std::uint8_t> bytes, Time now);
  void on_bad_char(std::uint8_t byte, Time now);
  void on_gap(Time now) { fdl_.on_gap(now); }
  std::optional<Time> next_deadline() const { return fdl_.next_deadline(); }
  void advance(Time now) { fdl_.advance(now); }
  Duration bit_times(std::uint64_t bits) const { return fdl_.bit_times(bits); }

  // Logs stations that appear, are lost, return (from the master's view); call once a cycle.
  void check_presence(const dp::DpMaster& master);
  station::LineStatus status(std::uint8_t address, const dp::DpMaster& master) const;
  const fdl::FdlMaster& fdl() const { return fdl_; }
  // What an analyser on this line counts (docs/profibus.md "Line statistics in role master"):
  // every telegram the master sends and every one it receives, the dropped ones as illegal.
  const fdl::LineStatistics& statistics() const { return statistics_; }

 private:
  void transmit(std::span<const std::uint8_t> bytes, Time now);
  // When a received telegram's first character started: a serial port paces the bytes, so it
  // began a wire time before the read; a pty hands them over at once.
  Time received_start(std::size_t bytes, Time now) const {
    return now - (paced_ ? fdl_.wire_time(bytes) : Duration(0));
  }

  Logger log_;
  fdl::FdlMaster fdl_;
  WriteFn write_;
  bool paced_ = false;
  std::function<void(std::span<const std::uint8_t>, bool, Time)> tap_;
  std::map<std::uint8_t, std::string> names_;
  fdl::LineStatistics statistics_;
  std::map<std::uint8_t, bool> present_;  // stations the master has seen answer (logs)
  // Response times: the request's last character → the answer (a pty does not pace bytes at the
  // bit rate, so the request's last character leaves at write time there).
  struct Times {
    std::uint32_t last_us = 0, max_us = 0;
  };
  std::map<std::uint8_t, Times> times_;
  std::optional<std::uint8_t> sent_to_;  // station of the telegram on the line
  Time request_end_{0};
  std::uint64_t answers_before_ = 0;  // the station's valid answers before this telegram
};

}  // namespace candp2::plant
