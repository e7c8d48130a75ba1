// candp2d's PROFIBUS line in role "master" (emulator-spec §10, docs/profibus.md): the built-in DP
// master drives remote stations (a real CAN-DP/2, or another candp2d in role slaves) through the
// FDL master station (profibus_sim/fdl/fdl_master.hpp) on the serial PHY (serial/), in the one
// event loop; no threads.
//
//   dp::DpMaster ─request─▶ fdl::FdlMaster (station N) ─send─▶ serial fd
//   serial fd ──readable──▶ PARMRK/echo ─▶ FdlMaster::on_bytes / on_bad_char ─▶ DP completion
//   timers: idle ≥ TSYN after the last character (on_gap), FdlMaster::next_deadline (advance)
//
// A port that dies (the pty's other end closed, a USB adapter unplugged) is closed and opened again
// every kReopenInterval; meanwhile requests get no answer and the stations show
// Station_Non_Existent, as on a broken cable.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/log.hpp"
#include "config/config.hpp"
#include "event_loop/event_loop.hpp"
#include "modbus/modbus_map.hpp"
#include "profibus_sim/fdl/fdl_master.hpp"
#include "profibus_sim/master/dp_master.hpp"
#include "serial/serial_port.hpp"

namespace candp2::daemon {

// What the slot time is extended by for the PHY (docs/profibus.md "Timing in role master"): a
// pseudo-terminal hands bytes between two processes on a possibly busy host; a USB adapter without
// low-latency mode holds received bytes up to its latency timer (FTDI default 16 ms).
Duration master_latency_allowance(bool is_pty, bool low_latency);

class ProfibusMasterLine {
 public:
  // Opens the port; nullptr and *error ("PROFIBUS line ($.profibus.port): open ...") on failure.
  // `master_address` is this master's FDL address ($.master.address).
  static std::unique_ptr<ProfibusMasterLine> open(const config::ProfibusConfig& config,
                                                  std::uint8_t master_address, EventLoop& loop,
                                                  LogSink* log, std::string* error);
  ~ProfibusMasterLine();
  ProfibusMasterLine(const ProfibusMasterLine&) = delete;
  ProfibusMasterLine& operator=(const ProfibusMasterLine&) = delete;

  // The remote station at `address` as a DP link (for DpMaster::add_slave).
  dp::SlaveLink& station(std::uint8_t address) { return fdl_->station(address); }
  // Call after the DP master queued requests (its cycle, reparameterize): arms the slot timer.
  void rearm();
  // Logs stations that appear, are lost, return (from the master's view); call once a cycle.
  void check_presence(const dp::DpMaster& master);

  // The status block's line fields for the remote station at `address` (role 2).
  modbus::StatusInputs::Line status(std::uint8_t address, const dp::DpMaster& master) const;
  std::string describe() const;
  bool port_open() const { return port_ != nullptr; }
  const fdl::FdlMaster& fdl() const { return *fdl_; }

 private:
  ProfibusMasterLine(const config::ProfibusConfig& config, EventLoop& loop, LogSink* log);
  bool open_port(std::string* error);
  void close_port(const std::string& why);
  void on_readable(bool hangup);
  void send(std::span<const std::uint8_t> bytes);

  config::ProfibusConfig config_;
  EventLoop& loop_;
  LogSink* log_sink_;
  Logger log_;
  std::unique_ptr<serial::SerialPort> port_;
  std::unique_ptr<fdl::FdlMaster> fdl_;
  std::vector<serial::RxByte> rx_;
  std::string port_desc_;
  bool on_pty_ = false;  // the port is a pseudo-terminal: no wire time
  std::optional<Time> armed_;
  EventLoop::TimerId deadline_timer_ = 0;
  EventLoop::TimerId gap_timer_ = 0;
  EventLoop::TimerId reopen_timer_ = 0;
  std::map<std::uint8_t, bool> present_;  // stations the master has seen answer (logs)
  // Response times as the glue sees them (a pty does not pace bytes at the bit rate, so the
  // request's last character leaves at write time there; a serial port takes its wire time).
  struct Times {
    std::uint32_t last_us = 0, max_us = 0;
  };
  std::map<std::uint8_t, Times> times_;
  std::optional<std::uint8_t> sent_to_;  // station of the telegram on the line
  Time request_end_{0};
  std::uint64_t answers_before_ = 0;  // the station's valid answers before this telegram
  void note_answers(Time now);
};

// A remote station's Modbus face (emulator-spec §10 role master): DP state and diagnosis as the
// master last read them, CAN fields 0, the line group from the FDL master's statistics.
class RemoteStationFace final : public modbus::GatewayFace {
 public:
  RemoteStationFace(std::uint8_t address, std::string name, dp::DpMaster& master,
                    ProfibusMasterLine& line, LogSink* log)
      : address_(address),
        name_(std::move(name)),
        master_(master),
        line_(line),
        log_(log, "daemon") {}
  std::uint8_t dp_address() const override { return address_; }
  modbus::StatusBlock status(Time now) override;
  // 2 = re-parameterize (DpMaster::reparameterize).
  void control(modbus::Control command, Time now) override;
  // 1 = power cycle cannot reach a remote device: refused (exception 0x04) and logged.
  std::optional<std::string> refuses(modbus::Control command) const override;

 private:
  std::uint8_t address_;
  std::string name_;
  dp::DpMaster& master_;
  ProfibusMasterLine& line_;
  Logger log_;
};

}  // namespace candp2::daemon
