// candp2d's wiring (docs/daemon.md): the CAN buses, one emulated gateway per configured entry, the
// simulated DP master cycling them, the Modbus/TCP face of the master's process image, socketcand
// exports of virtual buses, simulated drives, the CAN log and the state file — all driven by one
// EventLoop (no threads). Time is CLOCK_MONOTONIC from the loop, passed into every engine.
//
//   Modbus client ──TCP──▶ ModbusServer ─▶ ProcessImageMap ─▶ DpMaster image (Q)
//                                                    master cycle ▼ every cycle_ms
//   socketcand client ◀─TCP─ SocketcandServer ◀─tap─ VirtualBus ◀─ Gateway (Data_Exchange)
//                     ──TCP─▶ SocketcandServer ─▶ endpoint ─▶ VirtualBus ─▶ Gateway ─▶ image (I)
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "can/virtual_bus.hpp"
#include "common/log.hpp"
#include "config/config.hpp"
#include "event_loop/event_loop.hpp"
#include "gateway/gateway.hpp"
#include "plant/plant.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::daemon {

class Daemon {
 public:
  // Opens every bus, listener and file of the configuration. nullptr and *error when something
  // cannot be set up ("bus \"hw\" ($.buses.hw): interface vcan0 does not exist"); nothing is left
  // registered in the loop then.
  static std::unique_ptr<Daemon> start(const config::DaemonConfig& config, EventLoop& loop,
                                       LogSink* log, std::string* error);
  virtual ~Daemon() = default;

  // The ports actually bound (the configuration may ask for port 0 = any free port).
  virtual std::uint16_t modbus_port() const = 0;
  virtual std::optional<std::uint16_t> socketcand_port(std::string_view bus) const = 0;
  // The HTTP face's port (status page, /api/v1/status, /metrics); nullopt when http.listen is off.
  virtual std::optional<std::uint16_t> http_port() const = 0;
  // A one-line summary for the log: "modbus 127.0.0.1:1502, bus can0 socketcand 127.0.0.1:29536".
  virtual std::string listening() const = 0;
  // Modbus/TCP clients connected now (the systemd STATUS= line, daemon/systemd_notify.hpp).
  virtual std::size_t modbus_clients() const = 0;

  // SIGHUP: reopen the CAN log (after logrotate moved it).
  virtual void reopen_can_log() = 0;
  // Stops the master, writes the state file; called before the loop ends.
  virtual void shutdown() = 0;

  // Inspection (tests, tools).
  virtual dp::DpMaster& master() = 0;
  virtual gw::Gateway* gateway(std::uint8_t dp_address) = 0;
  virtual can::VirtualBus* virtual_bus(std::string_view name) = 0;
  virtual plant::Plant& plant() = 0;
};

}  // namespace candp2::daemon
