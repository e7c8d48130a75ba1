// A fault on cue on a CAN bus in time (docs/faults.md "CAN faults") as one type from the parser
// on: replay's can_fault step and the Modbus CAN fault block build it, the plant's control surface
// takes it (plant/control.hpp), the timed bus applies it (can/timed_bus.hpp). The vocabulary is
// the line faults' (plant/line_fault.hpp): a count of frames, one in every `every`, or a time.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "can/frame.hpp"
#include "common/time.hpp"

namespace candp2::plant {

enum class CanFaultKind : std::uint8_t {
  None = 0,          // cancels the node's (or the bus's) faults
  ErrorFrames = 1,   // the next frames of an identifier or a node end in an error frame
  Unplugged = 2,     // the node leaves the bus: it sends nothing and acknowledges nothing
  WrongBitrate = 3,  // the node runs at another bit rate: its frames and the others' are errors
  Noise = 4,         // every frame that starts on the bus for a time ends in an error frame
};
inline constexpr std::array<std::string_view, 5> kCanFaultNames{"none", "error_frames", "unplugged",
                                                                "wrong_bitrate", "noise"};

constexpr std::string_view to_string(CanFaultKind k) {
  return kCanFaultNames[static_cast<std::size_t>(k)];
}
inline std::optional<CanFaultKind> can_fault_kind(std::string_view name) {
  for (std::size_t i = 0; i < kCanFaultNames.size(); ++i)
    if (kCanFaultNames[i] == name) return static_cast<CanFaultKind>(i);
  return std::nullopt;
}

// Which node a fault is for: a gateway's controller (its DP address), a drive (its name), or
// none (error frames of an identifier, noise: the bus).
struct CanNode {
  std::optional<std::uint8_t> gateway;
  std::string drive;
  bool any() const { return gateway.has_value() || !drive.empty(); }
};

struct CanFault {
  CanFaultKind kind = CanFaultKind::None;
  std::string bus;               // the bus (a node's fault: may stay empty, the node's bus)
  CanNode node;                  // error_frames of a node, unplugged, wrong_bitrate, none
  std::optional<can::Ident> id;  // error_frames of an identifier (any sender)
  std::uint32_t count = 1;       // frames faulted, without a duration
  std::uint32_t every = 1;       // one frame in every `every`
  // How long instead of a count (error_frames); noise: required; unplugged, wrong_bitrate: until
  // it passes (without it: until a none).
  std::optional<Duration> duration;
};

// A CAN fault on cue in force on a bus, as the plant shows it (Plant::can_faults; docs/can-bus.md
// "Seen from outside"): its kind, its node (the endpoint's name, "gw:NAME") or identifier, what is
// left of its count (0 with a time) and of its time (0 with a count or until none), the line
// fault's vocabulary (plant/timed_line.hpp StationFault).
struct CanFaultView {
  CanFaultKind kind = CanFaultKind::None;
  std::string node;              // empty: an identifier's error frames, noise
  std::optional<can::Ident> id;  // error frames of an identifier
  std::uint32_t remaining = 0, every = 1;
  Duration remaining_time{0};
};

}  // namespace candp2::plant
