// CAN faults on cue and error confinement in the plant (docs/faults.md "CAN faults on cue",
// docs/can-bus.md "Error confinement"): a gateway's Set_Prm bit rate against its timed bus's,
// Plant::can_fault resolving a gateway to its node, and its refusals.
#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <variant>

#include "config/config.hpp"
#include "plant/plant.hpp"

namespace candp2 {
namespace {

// gw3 with one output slot (sent at its first Data_Exchange) on a 125 kbit/s bus; `rate` its
// Set_Prm bit rate.
std::string config(const char* rate, const char* bus_rate) {
  return std::string(R"({
  "master": { "address": 1, "cycle_ms": 10 },
  "buses": { "can0": { "type": "virtual")") +
         (bus_rate ? std::string(", \"bitrate\": \"") + bus_rate + "\"" : std::string()) +
         R"( } },
  "gateways": [ { "name": "gw3", "address": 3, "bus": "can0",
                  "parameters": { "can_bitrate": ")" +
         rate + R"(" },
                  "slots": [ { "io": "output", "address": 0, "length": 2, "comment": "02,01,00" } ] } ]
})";
}

struct Bench {
  config::DaemonConfig cfg;
  std::unique_ptr<plant::Plant> plant;
  std::unique_ptr<can::VirtualEndpoint> listener;
  explicit Bench(const std::string& text) {
    auto parsed = config::parse_daemon(text, "bus.json");
    cfg = std::get<config::DaemonConfig>(parsed);
    std::string error;
    plant = plant::Plant::build(cfg, plant::Options{}, Time{0}, &error);
    // A second node on the bus: it acknowledges gw3's frames.
    listener = plant->buses().at(0)->virtual_bus()->endpoint("listener");
  }
  void until(Time t) {
    while (const auto next = plant->next_deadline()) {
      if (*next > t) break;
      plant->advance(*next);
    }
  }
  plant::GatewayUnit& gw() { return *plant->gateways().at(0); }
  // A fault on cue on gw3's node at `at`.
  bool on_gw3(plant::CanFaultKind kind, Time at, std::uint32_t count = 1,
              std::optional<Duration> duration = std::nullopt) {
    plant::CanFault f;
    f.kind = kind;
    f.node.gateway = 3;
    f.count = count;
    f.duration = duration;
    return plant->can_fault(f, at, "(test)");
  }
  const can::TimedBus& bus() { return *plant->buses().at(0)->virtual_bus()->timed(); }
};

TEST(CanFaultInThePlant, AGatewayAtTheBussBitRateTalks) {
  Bench r(config("125k", "125k"));
  r.until(Time{200'000});
  EXPECT_EQ(r.gw().channel().bus_state(), can::BusState::Ok);
  EXPECT_GE(r.bus().frames(), 1u);
  EXPECT_EQ(r.bus().error_frames(), 0u);
  EXPECT_TRUE(r.listener->receive().has_value());
}

// Set_Prm says 250 kbit/s on a 125 kbit/s bus: every frame it sends is an error (its TEC rises to
// bus-off), nobody gets it.
TEST(CanFaultInThePlant, AGatewayAtAnotherBitRateCannotTalk) {
  Bench r(config("250k", "125k"));
  r.until(Time{200'000});
  EXPECT_EQ(r.bus().frames(), 0u);
  EXPECT_GE(r.bus().error_frames(), 32u);
  EXPECT_EQ(r.bus().name(0), "gw:gw3");
  EXPECT_GE(r.bus().confinement(0).bus_off, 1u);
  EXPECT_FALSE(r.listener->receive().has_value());
}

TEST(CanFaultInThePlant, CanFaultResolvesAGatewayAndRefusesWhatItCannot) {
  Bench r(config("125k", "125k"));
  r.until(Time{200'000});
  EXPECT_TRUE(r.on_gw3(plant::CanFaultKind::ErrorFrames, Time{200'000}, 13));
  plant::CanFault none;
  none.node.gateway = 9;  // no such gateway
  EXPECT_FALSE(r.plant->can_fault(none, Time{200'000}, "(test)"));
  plant::CanFault unplugged;
  unplugged.kind = plant::CanFaultKind::Unplugged;
  unplugged.bus = "can0";  // a node's fault without a node
  EXPECT_FALSE(r.plant->can_fault(unplugged, Time{200'000}, "(test)"));
  // Thirteen error frames on its next frame, then it gets through: TEC 13 × 8 − 1 = 103, warning.
  r.gw().channel().send(*can::parse_candump("201#0102").frame);
  r.until(Time{300'000});
  EXPECT_EQ(r.bus().error_frames(), 13u);
  EXPECT_EQ(r.bus().confinement(0).tec, 103u);
  EXPECT_EQ(r.gw().channel().bus_state(), can::BusState::Warning);
}

// docs/faults.md "CAN faults on cue": unplugged and wrong_bitrate with for_ms end by themselves.
// gw3 is the listener's only acknowledger: while it is out for 50 ms the listener's frame is an
// ACK error at every attempt (TEC + 8 to 128, error passive, where ACK errors no longer count);
// once the time is up gw3 acknowledges again, the frame gets through and the TEC counts down.
void a_node_out_for_50_ms(plant::CanFaultKind kind) {
  Bench r(config("125k", "125k"));
  r.until(Time{200'000});
  ASSERT_TRUE(r.on_gw3(kind, Time{200'000}, 1, milliseconds(50)));
  // The plant wakes when the time is up, whatever else it waits for.
  ASSERT_TRUE(r.plant->next_deadline().has_value());
  EXPECT_LE(*r.plant->next_deadline(), Time{250'000});
  const std::uint64_t frames = r.bus().frames();
  r.listener->send(*can::parse_candump("301#0102").frame);
  r.until(Time{249'000});
  const can::TimedBus::Confinement& peer = *r.listener->confinement();
  EXPECT_EQ(peer.tec, 128u);
  EXPECT_EQ(peer.state, can::BusState::ErrorPassive);
  EXPECT_EQ(r.bus().frames(), frames);
  EXPECT_GE(r.bus().error_frames(), 16u);
  r.until(Time{252'000});
  EXPECT_EQ(r.bus().frames(), frames + 1);  // acknowledged again
  EXPECT_EQ(peer.tec, 127u);
  r.listener->send(*can::parse_candump("301#0304").frame);
  r.until(Time{260'000});
  EXPECT_EQ(peer.tec, 126u);
  EXPECT_EQ(r.bus().frames(), frames + 2);
  EXPECT_TRUE(r.plant->can_faults(*r.plant->buses().at(0), Time{260'000}).empty());
}

TEST(CanFaultInThePlant, UnpluggedForMsEndsByItself) {
  a_node_out_for_50_ms(plant::CanFaultKind::Unplugged);
}

TEST(CanFaultInThePlant, WrongBitrateForMsEndsByItself) {
  a_node_out_for_50_ms(plant::CanFaultKind::WrongBitrate);
}

TEST(CanFaultInThePlant, WithoutForMsANodeStaysOutUntilNone) {
  Bench r(config("125k", "125k"));
  r.until(Time{200'000});
  ASSERT_TRUE(r.on_gw3(plant::CanFaultKind::Unplugged, Time{200'000}));
  r.listener->send(*can::parse_candump("301#0102").frame);
  const std::uint64_t frames = r.bus().frames();
  r.until(Time{1'000'000});
  EXPECT_EQ(r.bus().frames(), frames);
  ASSERT_TRUE(r.on_gw3(plant::CanFaultKind::None, Time{1'000'000}));
  r.until(Time{1'010'000});
  EXPECT_EQ(r.bus().frames(), frames + 1);
}

TEST(CanFaultInThePlant, WithoutABitRateACanFaultIsRefused) {
  Bench r(config("125k", nullptr));
  plant::CanFault f;
  f.kind = plant::CanFaultKind::ErrorFrames;
  f.node.gateway = 3;
  EXPECT_FALSE(r.plant->can_fault(f, Time{0}, "(test)"));
}

}  // namespace
}  // namespace candp2
