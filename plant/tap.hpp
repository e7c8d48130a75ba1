// The plant's one tap (docs/architecture.md "The plant"): every CAN frame on every bus and every DP
// telegram on every PROFIBUS side, with its sender and time, and the operator's actions (fault
// injections, power cycles, re-parameterizations) as notes. Observers (the CAN log, pcapng
// captures, the HTTP face's bus monitors, replay's traffic record) attach here; the plant calls
// them synchronously, in time order, and never waits for them. An observer must not call back
// into the plant.
//
// Time is the plant's time (candp2::Time, µs): CLOCK_MONOTONIC in candp2d, virtual time in
// replay. Observers that need wall-clock stamps add their own offset.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "can/frame.hpp"
#include "common/time.hpp"

namespace candp2::plant {

// Who sent a CAN frame: an emulated gateway or a simulated drive, by its index in the plant
// (Plant::gateways(), Plant::drives()), or anyone outside the emulation (a socketcand client,
// another device on a real bus, a replay injection).
enum class SenderKind : std::uint8_t { Outside, Gateway, Drive };

// One CAN frame as it appeared on a bus.
struct CanRecord {
  Time time{0};
  std::uint16_t bus = 0;       // index of the bus in the configuration ($.buses[i])
  std::string_view bus_name;   // the configuration's bus name
  std::string_view interface;  // the interface name a capture shows ("can0", "vcan0", "demo")
  const can::Frame& frame;
  // The name of the endpoint that sent it, for display and to tell endpoints apart; who it is
  // comes with sender_kind and sender_index (never parse the name).
  std::string_view sender;
  SenderKind sender_kind = SenderKind::Outside;
  std::size_t sender_index = 0;  // into Plant::gateways() or Plant::drives(); 0 when Outside
  // True when the emulated equipment sent it (a gateway or a drive), false when it received it.
  bool from_emulation = false;
};

// One DP telegram as FDL bytes, exactly as it is (or would be) on the wire: on a `profibus` line
// the bytes that travelled; with the in-process master, the FDL telegram each DP service request
// and its answer would be (docs/capture.md).
struct DpRecord {
  Time time{0};
  std::uint16_t line = 0;      // 0 = the in-process master's side, 1 = the `profibus` line
  std::string_view line_name;  // "in-process" or the port ("/dev/ttyUSB0", "pty:/tmp/pb")
  std::span<const std::uint8_t> telegram;
  // True when the emulated side sent it: a gateway's or generic slave's answer (in-process and
  // role slaves), or the built-in master's request on a line in role master (there the emulated
  // side is the master). In-process, the master's requests count as received by the gateway.
  bool from_emulation = false;
};

// Something the operator or a test did to the plant (docs/faults.md): "gateway g1: CAN
// controller state forced to bus-off", "gateway g1: power cycle". Captures show it as a comment.
struct NoteRecord {
  Time time{0};
  std::string_view text;
};

class Tap {
 public:
  virtual ~Tap() = default;
  virtual void on_can(const CanRecord& record) = 0;
  virtual void on_dp(const DpRecord& /*record*/) {}
  virtual void on_note(const NoteRecord& /*record*/) {}
};

}  // namespace candp2::plant
