// A PROFIBUS line's serial port in candp2d's one event loop (docs/profibus.md): the PHY of
// serial/ (termios 8E1 or a pty) feeding the line's stations in the plant, in either role. The
// stations themselves (FDL slave front end, FDL master station) are pure and live in the plant
// (plant/slave_line.hpp, plant/master_line.hpp); this room only moves bytes and arms the
// character-level timers: idle ≥ TSYN after a partial telegram, a slave's answer at its
// min_TSDR, the reopening of a dead port.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/log.hpp"
#include "config/config.hpp"
#include "event_loop/event_loop.hpp"
#include "plant/master_line.hpp"
#include "plant/slave_line.hpp"
#include "profibus_sim/fdl/fdl_slave.hpp"
#include "serial/serial_port.hpp"

namespace candp2::profibus_line {

// The serial port options of a `profibus` section, for either role.
serial::SerialOptions serial_options(const config::ProfibusConfig& config, LogSink* log);
// "pty /tmp/pb -> /dev/pts/3" for a pty we created, else the configured port.
std::string port_text(const serial::SerialPort& port, const std::string& configured);

// What the slot time is extended by for the PHY (docs/profibus.md "Timing in role master"): a
// pseudo-terminal hands bytes between two processes on a possibly busy host; a USB adapter without
// low-latency mode holds received bytes up to its latency timer (FTDI default 16 ms).
Duration master_latency_allowance(bool is_pty, bool low_latency);

// Role slaves: an external master drives the plant's gateways over this port.
class SlaveLinePort {
 public:
  // Opens the port; nullptr and *error ("PROFIBUS line ($.profibus.port): open ...") on failure.
  static std::unique_ptr<SlaveLinePort> open(const config::ProfibusConfig& config,
                                             plant::SlaveLine& line, EventLoop& loop, LogSink* log,
                                             std::string* error);
  ~SlaveLinePort();
  SlaveLinePort(const SlaveLinePort&) = delete;
  SlaveLinePort& operator=(const SlaveLinePort&) = delete;

  // "pty /tmp/pb -> /dev/pts/3, 19200 baud, role slaves"
  std::string describe() const;
  const serial::SerialPort& port() const { return *port_; }

 private:
  SlaveLinePort(const config::ProfibusConfig& config, plant::SlaveLine& line, EventLoop& loop,
                LogSink* log);
  void on_readable();
  void answer();
  void send(const fdl::Reply& reply);

  config::ProfibusConfig config_;
  plant::SlaveLine& line_;
  EventLoop& loop_;
  Logger log_;
  std::unique_ptr<serial::SerialPort> port_;
  std::vector<serial::RxByte> rx_;
  bool watching_ = false;
  EventLoop::TimerId gap_timer_ = 0;
  EventLoop::TimerId send_timer_ = 0;
};

// Role master: the plant's DP master drives remote stations over this port. A port that dies
// (the pty's other end closed, a USB adapter unplugged) is closed and opened again every
// kReopenInterval; meanwhile requests get no answer and the stations show
// Station_Non_Existent, as on a broken cable.
class MasterLinePort {
 public:
  static constexpr Duration kReopenInterval = milliseconds(200);

  static std::unique_ptr<MasterLinePort> open(const config::ProfibusConfig& config,
                                              plant::MasterLine& line, EventLoop& loop,
                                              LogSink* log, std::string* error);
  ~MasterLinePort();
  MasterLinePort(const MasterLinePort&) = delete;
  MasterLinePort& operator=(const MasterLinePort&) = delete;

  // "/dev/ttyUSB0, 19200 baud, role master"
  std::string describe() const;
  bool port_open() const { return port_ != nullptr; }

 private:
  MasterLinePort(const config::ProfibusConfig& config, plant::MasterLine& line, EventLoop& loop,
                 LogSink* log);
  bool open_port(std::string* error);
  void close_port(const std::string& why);
  void on_readable(bool hangup);
  void write(std::span<const std::uint8_t> bytes);

  config::ProfibusConfig config_;
  plant::MasterLine& line_;
  EventLoop& loop_;
  LogSink* log_sink_;
  Logger log_;
  std::unique_ptr<serial::SerialPort> port_;
  std::vector<serial::RxByte> rx_;
  std::string port_desc_;
  EventLoop::TimerId gap_timer_ = 0;
  EventLoop::TimerId reopen_timer_ = 0;
};

}  // namespace candp2::profibus_line
