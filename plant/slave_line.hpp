// The stations of a PROFIBUS line in role "slaves" (docs/profibus.md): every emulated gateway
// answers an external DP master over FDL at its DP address. Pure: the serial port and its timers
// are the driver's (profibus_line/); bytes and times come in here, replies and their earliest send
// time go out.
//
//   received bytes ─▶ fdl::SlaveFrontEnd (every telegram to the tap) ─▶ reply + not_before
//                    ─▶ take_reply() ─▶ the port
//
// After every answered request the station's process data are copied into the master's PLC image
// at the configured addresses (outputs as received, inputs as sent), so the Modbus face shows what
// travels on the wire (docs/profibus.md "The line inside candp2d").
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/log.hpp"
#include "common/time.hpp"
#include "config/config.hpp"
#include "plant/tap.hpp"
#include "profibus_sim/fdl/fdl.hpp"
#include "profibus_sim/fdl/fdl_slave.hpp"
#include "profibus_sim/master/dp_master.hpp"
#include "station/line_status.hpp"

namespace candp2::plant {

class SlaveLine {
 public:
  // A station is "present" while its master sent it a request within this time.
  static constexpr Duration kPresenceTimeout = milliseconds(1000);
  SlaveLine(const config::ProfibusConfig& config, dp::ProcessImage& image, LogSink* log);

  // Serves `slave` at its DP address; `params` gives the PLC addresses of its slots.
  bool add(dp::DpSlave& slave, const dp::SlaveParameters& params, std::string name);
  void set_tap(std::function<void(std::span<const std::uint8_t>, bool from_emulation, Time)> tap);

  // The PHY's input: runs of good characters, a character with a parity error, idle ≥ TSYN.
  void on_bytes(std::span<const std::uint8_t> bytes, Time now);
  void on_bad_char(std::uint8_t byte, Time now);
  void on_gap(Time now);
  // A partial telegram is buffered: the driver signals on_gap() after bit_times(phy::kTsynBits)
  // idle.
  bool partial() { return front_.parser().buffered() > 0; }
  Duration bit_times(std::uint32_t bits) const { return front_.bit_times(bits); }

  // The answer to the last complete request, if any (a newer request supersedes an answer still
  // waiting for its min_TSDR); the driver writes it at not_before and then calls sent().
  std::optional<fdl::Reply> take_reply();
  void sent(const fdl::Reply& reply, Time now);

  // Logs a station whose master went silent; call periodically.
  void check_presence(Time now);

  std::optional<station::LineStatus> status(std::uint8_t address) const;
  const fdl::ParserStats& line_stats() const { return front_.line_stats(); }
  const fdl::SlaveFrontEnd& front_end() const { return front_; }

 private:
  struct Station {
    dp::DpSlave* slave = nullptr;
    std::string name;
    dp::ImageMap map;
    std::uint32_t response_us = 0, response_max_us = 0;
    std::optional<Time> last_request;
    Time request_end{0};
    bool present = false;
  };
  void handled(std::optional<fdl::Reply> reply, Time request_end);
  void mirror(Station& st);
  Station* station(std::uint8_t address);

  config::ProfibusConfig config_;
  dp::ProcessImage& image_;
  Logger log_;
  fdl::SlaveFrontEnd front_;
  std::vector<std::unique_ptr<Station>> stations_;
  std::optional<fdl::Reply> reply_;
  std::function<void(std::span<const std::uint8_t>, bool, Time)> tap_;
};

}  // namespace candp2::plant
