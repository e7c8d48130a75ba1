// Worst-case response times of the messages on one CAN bus (docs/can-bus.md "Response times"):
// the schedulability analysis of Davis, Burns, Bril and Lukkien, "Controller Area Network (CAN)
// schedulability analysis: refuted, revisited and revised" (Real-Time Systems 35, 2007), in its
// revised form: the priority level-m busy period, every instance of the message inside it, and
// blocking by the longest lower-priority frame. Frame lengths are the paper's worst case
// (can/frame_bits.hpp, frame_bits_worst). Pure: numbers in, numbers out; no clock. `candp2
// validate` predicts each timed bus with it (docs/validate.md "CAN buses").
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "can/frame.hpp"

namespace candp2::can {

// One periodic or sporadic message: a stream of frames of one identifier from one node, queued at
// most once every `period` (a sporadic message's minimum inter-arrival time), each up to `jitter`
// after its release. Its deadline is its period.
struct RtaMessage {
  Ident id;
  bool remote = false;
  std::uint8_t dlc = 0;
  std::chrono::nanoseconds period{0};  // T; 0 or less: the message cannot be analysed
  std::chrono::nanoseconds jitter{0};  // J
  // The node's transmit queue: 0, its frames contend in priority order (the paper's assumption);
  // n > 0, the messages with the same n share one first-in-first-out queue, whose head alone
  // contends (docs/can-bus.md "Response times": each is analysed at the lowest priority of its
  // queue, with all of the queue's messages as interference).
  std::uint32_t fifo = 0;
};

struct RtaResult {
  std::uint32_t frame_bits = 0;             // the worst-case length (frame_bits_worst)
  std::chrono::nanoseconds transmission{};  // C
  std::chrono::nanoseconds blocking{};      // B: the longest frame of lower priority
  // t: the priority level-m busy period (paper eq. 7); none when it does not end (the messages
  // of this priority and higher load the bus to 100 % or more).
  std::optional<std::chrono::nanoseconds> busy_period;
  std::uint64_t instances = 0;  // Q: instances of the message inside the busy period (eq. 8)
  // R: the worst case over the Q instances (eq. 9-11); none when the busy period does not end.
  std::optional<std::chrono::nanoseconds> response;
  std::optional<std::chrono::nanoseconds> response_first;  // R(0): the first instance's alone
  std::uint64_t worst_instance = 0;                        // the q whose R(q) is R
  bool schedulable = false;                                // R <= period
};

struct RtaReport {
  std::uint32_t bitrate = 0;
  double utilisation = 0;           // sum of C/T over every message (worst-case lengths)
  std::vector<RtaResult> messages;  // in the order of the input
  bool schedulable() const;         // every message meets its deadline
};

// The analysis of `messages` on one bus at `bitrate` bit/s. Priority is bitwise arbitration
// (arbitration_key): two messages with the same identifier and kind (two nodes sending it) are
// each counted as higher priority than the other, which is pessimistic. The analysis gives up,
// and reports no bound, on a busy period longer than kRtaHorizon or after kRtaMaxSteps iteration
// steps for one message.
RtaReport analyse_response_times(std::span<const RtaMessage> messages, std::uint32_t bitrate);

inline constexpr std::chrono::nanoseconds kRtaHorizon = std::chrono::hours(1);
inline constexpr std::uint64_t kRtaMaxSteps = 1'000'000;

}  // namespace candp2::can
