// candp2d's PROFIBUS line (emulator-spec §10, docs/profibus.md): the serial PHY (serial/) in the
// one event loop, with the FDL slave front end (role "slaves") answering for every emulated
// gateway.
//
//   serial fd ──readable──▶ PARMRK/echo ─▶ fdl::StreamParser ─▶ fdl::SlaveFrontEnd ─▶ dp::DpSlave
//                                                                 │ reply + earliest send time
//   serial fd ◀──write── at not_before (a loop timer; at once when already due) ◀┘
//
// After every answered request the station's process data are copied into the Modbus image at the
// configured PLC addresses (outputs as received, inputs as sent), so Modbus clients see the wire.
// Idle after a partial telegram (≥ TSYN = 33 bit times) is signalled to the parser by a timer.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/log.hpp"
#include "config/config.hpp"
#include "event_loop/event_loop.hpp"
#include "modbus/modbus_map.hpp"
#include "profibus_sim/fdl/fdl_slave.hpp"
#include "profibus_sim/master/dp_master.hpp"
#include "serial/serial_port.hpp"

namespace candp2::daemon {

// The serial port options of a `profibus` section (emulator-spec §10), for either role.
serial::SerialOptions serial_options(const config::ProfibusConfig& config, LogSink* log);
// "pty /tmp/pb -> /dev/pts/3" for a pty we created, else the configured port.
std::string port_text(const serial::SerialPort& port, const std::string& configured);

class ProfibusSlaveLine {
 public:
  // Opens the port; nullptr and *error ("$.profibus.port: open /dev/ttyUSB9: ...") on failure.
  static std::unique_ptr<ProfibusSlaveLine> open(const config::ProfibusConfig& config,
                                                 EventLoop& loop, dp::ProcessImage& image,
                                                 LogSink* log, std::string* error);
  ~ProfibusSlaveLine();
  ProfibusSlaveLine(const ProfibusSlaveLine&) = delete;
  ProfibusSlaveLine& operator=(const ProfibusSlaveLine&) = delete;

  // Serves `slave` at its DP address; `params` gives the PLC addresses of its slots for the image.
  bool add(dp::DpSlave& slave, const dp::SlaveParameters& params, std::string name);

  // The status block's line fields for the station at `address` (nullopt: not served here).
  std::optional<modbus::StatusInputs::Line> status(std::uint8_t address) const;
  // "pty /tmp/pb -> /dev/pts/3, 19200 baud" / "/dev/ttyUSB0, 19200 baud"
  std::string describe() const;
  const serial::SerialPort& port() const { return *port_; }
  const fdl::SlaveFrontEnd& front_end() const { return front_; }

 private:
  struct Station {
    dp::DpSlave* slave = nullptr;
    std::string name;
    dp::ImageMap map;  // where its bytes appear in the Modbus image
    std::uint32_t response_us = 0, response_max_us = 0;
    std::optional<Time> last_request;
    bool present = false;
  };

  ProfibusSlaveLine(const config::ProfibusConfig& config, EventLoop& loop, dp::ProcessImage& image,
                    LogSink* log);
  void on_readable();
  void on_gap_timer();
  void handle(std::optional<fdl::Reply> reply, Time request_end);
  void send(std::vector<std::uint8_t> bytes, std::uint8_t station, Time request_end);
  void mirror(Station& st);
  void check_presence();
  Station* station(std::uint8_t address);

  config::ProfibusConfig config_;
  EventLoop& loop_;
  dp::ProcessImage& image_;
  Logger log_;
  std::unique_ptr<serial::SerialPort> port_;
  fdl::SlaveFrontEnd front_;
  std::vector<std::unique_ptr<Station>> stations_;
  std::vector<serial::RxByte> rx_;
  bool watching_ = false;
  EventLoop::TimerId gap_timer_ = 0;
  EventLoop::TimerId send_timer_ = 0;
  EventLoop::TimerId presence_timer_ = 0;
};

}  // namespace candp2::daemon
