// Error confinement on the CAN bus in time (docs/can-bus.md "Error confinement"): ACK errors,
// error frames on cue, bus-off and its recovery, a node unplugged or at a wrong bit rate, noise,
// to the bit. Frame lengths are the hand-worked frames of frame_bits_test.cpp: 080# 51 bits
// (38 stuffed + 13), 7FF#FFFFFFFFFFFFFFFF 126 bits, 123#1122334455667788 112 bits (99 + 13).
// An error frame is 6 + 8 + 3 = 17 bits after the bit the error is detected at.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "can/frame_bits.hpp"
#include "can/timed_bus.hpp"

namespace candp2::can {
namespace {

Frame F(const char* text) {
  return *parse_candump(text).frame;
}

// "start_bit end_bit node frame [E] tec" of every attempt at its end (E: in error), with the
// sender's TEC after it; and every change of a node's state.
struct Trace {
  std::vector<std::string> lines, states;
  explicit Trace(TimedBus& bus) {
    bus.on_end([this, &bus](const TimedBus::OnBus& f) {
      lines.push_back(std::to_string(f.start_bit) + " " + std::to_string(f.end_bit) + " " +
                      std::to_string(f.node) + " " + format_candump(f.frame) +
                      (f.error != TimedBus::Error::None ? " E " : " ") +
                      std::to_string(bus.confinement(f.node).tec));
    });
    bus.on_state([this, &bus](std::size_t node, BusState s) {
      states.push_back(std::to_string(node) + " " + std::string(to_string(s)) + " " +
                       std::to_string(bus.confinement(node).tec));
    });
  }
};

void run(TimedBus& bus) {
  while (const auto d = bus.next_deadline()) bus.advance(*d);
}

void run_until(TimedBus& bus, Time until) {
  while (const auto d = bus.next_deadline()) {
    if (*d > until) break;
    bus.advance(*d);
  }
}

std::string state(const TimedBus& bus, std::size_t node) {
  return std::string(to_string(bus.confinement(node).state));
}

TimedBus::ErrorFault on_node(std::size_t node, std::uint32_t count) {
  TimedBus::ErrorFault f;
  f.node = node;
  f.count = count;
  return f;
}

// A bus at 125 kbit/s (8 µs a bit) that checks acknowledgement, traced.
struct TimedBusErrors : ::testing::Test {
  TimedBus bus{125000, Time(0)};
  Trace trace{bus};
  TimedBusErrors() { bus.check_acknowledgement(true); }
};

// A lone node at 125 kbit/s (8 µs a bit): nobody acknowledges 080#, an ACK error at the ACK slot
// (38 stuffed bits + CRC delimiter + ACK slot = 40), then the error frame: 57 bits an attempt.
// TEC 8, 16, …, warning at 96, error passive at 128; then each attempt is 8 bits of suspend
// transmission later (65 bits apart) and its ACK errors leave TEC at 128: never bus-off.
TEST_F(TimedBusErrors, ALoneNodesAckErrorsStopAtErrorPassive) {
  const auto a = bus.add_node(8);
  ASSERT_TRUE(bus.request(a, F("080#"), Time(0)));
  run_until(bus, Time(39'560));  // between attempt 77's end (bit 4942) and 78's start (4950)
  ASSERT_EQ(trace.lines.size(), 78u);
  for (std::size_t k = 0; k < 16; ++k)
    EXPECT_EQ(trace.lines[k], std::to_string(57 * k) + " " + std::to_string(57 * k + 57) +
                                  " 0 080# E " + std::to_string(8 * (k + 1)))
        << k;
  for (std::size_t k = 16; k < 78; ++k)
    EXPECT_EQ(trace.lines[k], std::to_string(920 + 65 * (k - 16)) + " " +
                                  std::to_string(977 + 65 * (k - 16)) + " 0 080# E 128")
        << k;
  // Attempt 17 starts at bit 985: 7880 µs.
  EXPECT_EQ(bus.time_of(985), Time(7880));
  EXPECT_EQ(trace.states, (std::vector<std::string>{"0 warning 96", "0 error-passive 128"}));
  EXPECT_EQ(state(bus, a), "error-passive");
  EXPECT_EQ(bus.confinement(a).tec, 128u);
  EXPECT_EQ(bus.frames(), 0u);
  EXPECT_EQ(bus.error_frames(), trace.lines.size());
  EXPECT_EQ(bus.confinement(a).error_frames_sent, trace.lines.size());
  // A second node joins: the next attempt is acknowledged, TEC 127: error passive no more.
  bus.add_node(8);
  run(bus);
  EXPECT_EQ(trace.lines.back().substr(trace.lines.back().size() - 9), " 080# 127");
  EXPECT_EQ(state(bus, a), "warning");
  EXPECT_EQ(bus.frames(), 1u);
}

// Error frames on cue on node a's frames, 32 of them: the error at the last CRC bit (38), 55 bits
// an attempt; error passive after 16 (TEC 128), then 8 bits of suspend each (63 apart); the 32nd
// (bits 1833..1888) takes TEC to 256: bus-off, its queue emptied. Its error delimiter and
// intermission (bits 1877..1888) begin the first run of 11 recessive bits: on an idle bus it is
// error active again after 128 × 11 = 1408 bits, at bit 3285 (26 280 µs).
TEST_F(TimedBusErrors, ErrorFramesOnANodeTakeItBusOffAndItRecovers) {
  const auto a = bus.add_node(8), b = bus.add_node(8);
  bus.inject_errors(on_node(a, 32));
  bus.request(a, F("080#"), Time(0));
  bus.request(a, F("081#"), Time(0));
  run(bus);
  ASSERT_EQ(trace.lines.size(), 32u);
  EXPECT_EQ(trace.lines[0], "0 55 0 080# E 8");
  EXPECT_EQ(trace.lines[15], "825 880 0 080# E 128");
  EXPECT_EQ(trace.lines[16], "888 943 0 080# E 136");
  EXPECT_EQ(trace.lines[31], "1833 1888 0 080# E 256");
  EXPECT_EQ(trace.states, (std::vector<std::string>{"0 warning 96", "0 error-passive 128",
                                                    "0 bus-off 256", "0 ok 0"}));
  EXPECT_EQ(bus.confinement(a).discarded, 2u);
  EXPECT_EQ(bus.confinement(a).bus_off, 1u);
  EXPECT_EQ(bus.confinement(b).rec, 32u);
  EXPECT_EQ(bus.confinement(b).error_frames_seen, 32u);
  EXPECT_EQ(state(bus, a), "ok");
  EXPECT_EQ(bus.confinement(a).tec, 0u);
}

TEST_F(TimedBusErrors, BusOffRecoveryOnAnIdleBusToTheBit) {
  const auto a = bus.add_node(8);
  bus.add_node(8);
  bus.inject_errors(on_node(a, 32));
  bus.request(a, F("080#"), Time(0));
  bus.advance(Time(1888 * 8));
  EXPECT_EQ(state(bus, a), "bus-off");
  EXPECT_FALSE(bus.request(a, F("082#"), Time(1888 * 8)));  // refused while bus-off
  EXPECT_EQ(bus.lost(), 0u);
  EXPECT_EQ(bus.next_deadline(), Time(3285 * 8));
  bus.advance(Time(3285 * 8 - 1));
  EXPECT_EQ(state(bus, a), "bus-off");
  bus.advance(Time(3285 * 8));
  EXPECT_EQ(state(bus, a), "ok");
  EXPECT_EQ(bus.confinement(a).rec, 0u);
  EXPECT_TRUE(bus.request(a, F("082#"), Time(3285 * 8)));
}

// On a busy bus each frame's end (ACK delimiter, end of frame, intermission: 11 recessive bits)
// counts one occurrence: b's back-to-back 080# from bit 1888 (51 bits each) recover a at the end
// of b's 127th frame, bit 1888 + 127 × 51 = 8365 (with the one run a's own error frame ended).
TEST_F(TimedBusErrors, BusOffRecoveryOnABusyBusCountsOneRunAFrame) {
  const auto a = bus.add_node(8), b = bus.add_node(400);
  bus.add_node(8);  // acknowledges b's frames while a is bus-off
  bus.inject_errors(on_node(a, 32));
  bus.request(a, F("080#"), Time(0));
  bus.advance(Time(1888 * 8));
  ASSERT_EQ(state(bus, a), "bus-off");
  for (int k = 0; k < 300; ++k) bus.request(b, F("080#"), Time(1888 * 8));
  bus.advance(Time(8365 * 8 - 1));
  EXPECT_EQ(state(bus, a), "bus-off");
  bus.advance(Time(8365 * 8));
  EXPECT_EQ(state(bus, a), "ok");
  EXPECT_EQ(trace.lines.back(), "8314 8365 1 080# 0");
}

// Error frames on an identifier, one in every 3, twice: the 1st and 4th attempts of 123# end in
// an error frame at the last CRC bit (99 + 17 = 116 bits) and are sent again; the receiver's REC
// rises by 1 for each and falls by 1 for each frame it gets.
TEST_F(TimedBusErrors, ErrorFramesOnAnIdentifierEveryKRaiseTheReceiversRec) {
  const auto a = bus.add_node(8), b = bus.add_node(8);
  TimedBus::ErrorFault fault;
  fault.id = Ident{0x123, false};
  fault.count = 2;
  fault.every = 3;
  bus.inject_errors(fault);
  for (int k = 0; k < 4; ++k) bus.request(a, F("123#1122334455667788"), Time(0));
  bus.request(b, F("7FF#FFFFFFFFFFFFFFFF"), Time(0));
  run(bus);
  EXPECT_EQ(trace.lines,
            (std::vector<std::string>{
                "0 116 0 123#1122334455667788 E 8", "116 228 0 123#1122334455667788 7",
                "228 340 0 123#1122334455667788 6", "340 456 0 123#1122334455667788 E 14",
                "456 568 0 123#1122334455667788 13", "568 680 0 123#1122334455667788 12",
                "680 806 1 7FF#FFFFFFFFFFFFFFFF 0"}));
  EXPECT_EQ(bus.confinement(b).error_frames_seen, 2u);
  EXPECT_EQ(bus.confinement(b).rec, 0u);  // +1, −1, −1, +1, −1, −1
  EXPECT_EQ(bus.confinement(a).error_frames_sent, 2u);
  EXPECT_EQ(bus.frames(), 5u);
  EXPECT_EQ(bus.error_frames(), 2u);
  EXPECT_EQ(bus.identifiers().at(arbitration_key(F("123#"))).frames, 4u);
}

// A receiver's REC: a node at a wrong bit rate sees every frame of the others as an error (REC
// +1, it gets nothing): error passive at 128; back at the bus's bit rate, the next frame it gets
// takes REC from above 127 to 127 (the model's choice in 119..127): error active (warning) again.
TEST_F(TimedBusErrors, AReceiversRecToErrorPassiveAndBackTo127) {
  TimedBus fast(1000000, Time(0));  // 1 µs a bit
  fast.check_acknowledgement(true);
  Trace fast_trace(fast);
  const auto a = fast.add_node(8), b = fast.add_node(200);
  fast.add_node(8);
  fast.set_wrong_bitrate(a, true);
  for (int k = 0; k < 130; ++k) fast.request(b, F("080#"), Time(0));
  run(fast);
  EXPECT_FALSE(fast.receives(a));
  EXPECT_EQ(fast.confinement(a).rec, 130u);
  EXPECT_EQ(fast.confinement(a).error_frames_seen, 130u);
  EXPECT_EQ(state(fast, a), "error-passive");
  EXPECT_EQ(fast.frames(), 130u);  // acknowledged by the third node
  fast.clear_faults(a);
  EXPECT_TRUE(fast.receives(a));
  fast.request(b, F("080#"), Time(200'000));
  run(fast);
  EXPECT_EQ(fast.confinement(a).rec, 127u);
  EXPECT_EQ(fast_trace.states,
            (std::vector<std::string>{"0 warning 0", "0 error-passive 0", "0 warning 0"}));
}

// A node at a wrong bit rate: the others see an error within the first six bits of each of its
// frames (6 + 17 = 23 bits an attempt), its TEC rises by 8 each, theirs REC by 1. Error passive
// after 16, it suspends 8 bits, and b's 7FF# gets through (received by c, an error to a); a goes
// on to bus-off at its 32nd attempt (bits 959..982) and recovers 1408 − 11 bits later.
TEST_F(TimedBusErrors, ANodeAtAWrongBitRateErrsItsFramesAndGoesBusOff) {
  const auto a = bus.add_node(8), b = bus.add_node(8), c = bus.add_node(8);
  bus.set_wrong_bitrate(a, true);
  bus.request(a, F("080#"), Time(0));
  bus.request(b, F("7FF#FFFFFFFFFFFFFFFF"), Time(0));
  run(bus);
  ASSERT_EQ(trace.lines.size(), 33u);
  EXPECT_EQ(trace.lines[0], "0 23 0 080# E 8");
  EXPECT_EQ(trace.lines[15], "345 368 0 080# E 128");
  EXPECT_EQ(trace.lines[16], "368 494 1 7FF#FFFFFFFFFFFFFFFF 0");
  EXPECT_EQ(trace.lines[17], "494 517 0 080# E 136");
  EXPECT_EQ(trace.lines[32], "959 982 0 080# E 256");
  EXPECT_EQ(bus.confinement(b).rec, 32u);  // b transmits between: its REC stays
  EXPECT_EQ(bus.confinement(c).rec, 31u);  // 16, 15 after b's frame, then 16 more
  EXPECT_EQ(bus.confinement(a).bus_off, 1u);
  EXPECT_EQ(state(bus, a), "ok");  // recovered at bit 982 − 11 + 1408
  EXPECT_EQ(trace.states.back(), "0 ok 0");
  EXPECT_EQ(bus.frames(), 1u);
}

// An unplugged node sends nothing (its queue waits), acknowledges nothing and counts nothing:
// a alone with it gets an ACK error; plugged back, b acknowledges a's next attempt and sends.
TEST_F(TimedBusErrors, AnUnpluggedNodeNeitherSendsNorAcknowledges) {
  const auto a = bus.add_node(8), b = bus.add_node(8);
  bus.set_unplugged(b, true);
  EXPECT_FALSE(bus.receives(b));
  bus.request(b, F("7FF#FFFFFFFFFFFFFFFF"), Time(0));
  bus.request(a, F("080#"), Time(0));
  bus.advance(Time(455));  // a's first attempt on the bus, bits 0..57
  EXPECT_EQ(bus.confinement(b).rec, 0u);
  bus.clear_faults(b);
  run(bus);
  EXPECT_EQ(trace.lines, (std::vector<std::string>{"0 57 0 080# E 8", "57 108 0 080# 7",
                                                   "108 234 1 7FF#FFFFFFFFFFFFFFFF 0"}));
  // Plugged back during a's error frame, b takes part in its end (counters change at the end of
  // a frame): REC 1, then 0 with a's frame.
  EXPECT_EQ(bus.confinement(b).error_frames_seen, 1u);
  EXPECT_EQ(bus.confinement(b).rec, 0u);
}

// Noise until 1 ms: every frame that starts in it ends in an error frame (at the last CRC bit,
// 55 bits for 080#); the first to start after it gets through.
TEST_F(TimedBusErrors, NoiseErrsEveryFrameStartingInIt) {
  const auto a = bus.add_node(8), b = bus.add_node(8);
  TimedBus::ErrorFault noise;
  noise.until = Time(1000);
  bus.inject_errors(noise);
  bus.request(a, F("080#"), Time(0));
  run(bus);
  EXPECT_EQ(trace.lines, (std::vector<std::string>{"0 55 0 080# E 8", "55 110 0 080# E 16",
                                                   "110 165 0 080# E 24", "165 216 0 080# 23"}));
  EXPECT_EQ(bus.confinement(b).rec, 2u);
  EXPECT_EQ(bus.error_frames(), 3u);
}

// Without a fault, with acknowledgement checked and every node present, the bus is as before
// (timed_bus_test.cpp ThreeNodesContendSmallestIdentifierFirstToTheBit).
TEST_F(TimedBusErrors, WithoutFaultsNothingChanges) {
  const auto a = bus.add_node(8), b = bus.add_node(8), c = bus.add_node(8);
  bus.request(a, F("123#1122334455667788"), Time(0));
  bus.request(b, F("080#"), Time(0));
  bus.request(c, F("000#"), Time(0));
  run(bus);
  EXPECT_EQ(trace.lines, (std::vector<std::string>{"0 53 2 000# 0", "53 104 1 080# 0",
                                                   "104 216 0 123#1122334455667788 0"}));
  EXPECT_TRUE(trace.states.empty());
  EXPECT_EQ(bus.error_frames(), 0u);
}

}  // namespace
}  // namespace candp2::can
