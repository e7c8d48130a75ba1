// The SocketCAN bit rate rules (docs/transports.md "Bit rate"; manual §5.1.2 /
// docs/dp-slave.md "User parameters" Set_Prm byte 8) against a fake interface, and the pure helpers
// of can/can_link.hpp. The real netlink path runs in the QEMU guest
// (tests/qemu/socketcan_sja1000.sh).
#include "bitrate/bitrate_supervisor.hpp"

#include <errno.h>
#include <gtest/gtest.h>

#include <algorithm>

namespace candp2::bitrate {
namespace {

struct FakeLink final : LinkOps {
  std::optional<std::uint32_t> bitrate = 125000;  // nullopt: no bit timing
  bool controller = true;                         // false = vcan (no controller, no bit timing)
  bool up = true;
  bool exists = true;
  int refuse = 0;  // errno for set_bitrate
  int reads = 0;
  std::vector<std::pair<std::uint32_t, std::optional<std::uint32_t>>> sets;
  std::optional<can::LinkInfo> info() override {
    ++reads;
    if (!exists) return std::nullopt;
    can::LinkInfo i;
    i.up = up;
    i.controller = controller;
    if (controller && bitrate) i.bittiming = can::BitTiming{*bitrate, 875};
    return i;
  }
  std::optional<can::LinkError> set_bitrate(std::uint32_t b,
                                            std::optional<std::uint32_t> restart_ms) override {
    if (refuse) return can::LinkError{refuse, "ip link set down failed: Operation not permitted"};
    sets.emplace_back(b, restart_ms);
    bitrate = b;
    up = true;  // CanLink::set_bitrate: down, bit rate, restart-ms, up
    return std::nullopt;
  }
};

struct Fixture {
  MemoryLog log;
  FakeLink* link = nullptr;
  std::unique_ptr<BitrateSupervisor> sup;
  Fixture(config::BitrateMode mode, std::optional<std::uint32_t> restart_ms = std::nullopt) {
    auto l = std::make_unique<FakeLink>();
    link = l.get();
    sup = std::make_unique<BitrateSupervisor>("can0", mode, restart_ms, std::move(l), &log);
  }
  std::size_t count(std::string_view needle) const {
    return std::count_if(log.lines.begin(), log.lines.end(), [&](const auto& l) {
      return l.message.find(needle) != std::string::npos;
    });
  }
};

const Time t0{0};

TEST(BitrateSupervisor, ApplySetsTheSetPrmBitrateAndAgainOnChange) {
  Fixture f(config::BitrateMode::Apply, 100);
  const auto gw = f.sup->add_gateway("gw5");
  f.sup->update(gw, std::nullopt, t0);  // before Set_Prm: nothing
  EXPECT_TRUE(f.link->sets.empty());
  f.sup->update(gw, 500000, t0);  // docs/dp-slave.md "User parameters" byte 8 = 2
  ASSERT_EQ(f.link->sets.size(), 1u);
  EXPECT_EQ(f.link->sets[0].first, 500000u);
  EXPECT_EQ(f.link->sets[0].second, 100u);
  EXPECT_TRUE(f.log.contains("bit rate set to 500 kbit/s from the Set_Prm of gateway gw5"));
  const auto s = f.sup->status(gw);
  EXPECT_EQ(s.mode, 2);
  EXPECT_EQ(s.configured, 500000u);
  EXPECT_EQ(s.interface, 500000u);
  EXPECT_FALSE(s.mismatch);
  f.sup->update(gw, 500000, t0 + seconds(1));  // the same Set_Prm again: no restart
  EXPECT_EQ(f.link->sets.size(), 1u);
  f.sup->update(gw, 250000, t0 + seconds(2));  // re-parameterized to 250k (byte 8 = 4)
  ASSERT_EQ(f.link->sets.size(), 2u);
  EXPECT_EQ(f.link->sets[1].first, 250000u);
  EXPECT_EQ(f.sup->status(gw).interface, 250000u);
}

TEST(BitrateSupervisor, ApplyLeavesAMatchingInterfaceAlone) {
  Fixture f(config::BitrateMode::Apply);
  f.link->bitrate = 125000;
  const auto gw = f.sup->add_gateway("gw5");
  f.sup->update(gw, 125000, t0);
  EXPECT_TRUE(f.link->sets.empty());
  EXPECT_TRUE(f.log.contains("already set"));
}

TEST(BitrateSupervisor, ApplyWithoutCapNetAdminSaysHowAndShowsTheMismatch) {
  Fixture f(config::BitrateMode::Apply);
  f.link->refuse = EPERM;
  const auto gw = f.sup->add_gateway("gw5");
  f.sup->update(gw, 500000, t0);
  EXPECT_TRUE(f.link->sets.empty());
  EXPECT_TRUE(f.log.contains("CAP_NET_ADMIN")) << f.log.lines.back().message;
  EXPECT_TRUE(f.log.contains("packaging/systemd/candp2d-bitrate-apply.conf"));
  EXPECT_TRUE(f.log.contains("setcap cap_net_admin+ep"));
  const auto s = f.sup->status(gw);
  EXPECT_EQ(s.configured, 500000u);
  EXPECT_EQ(s.interface, 125000u);
  EXPECT_TRUE(s.mismatch);
  EXPECT_EQ(f.count("bit rate mismatch"), 1u);
}

TEST(BitrateSupervisor, CheckReportsAMismatchOnceAndItsEnd) {
  Fixture f(config::BitrateMode::Check);
  f.link->bitrate = 250000;
  const auto gw = f.sup->add_gateway("gw5");
  f.sup->update(gw, 500000, t0);
  EXPECT_TRUE(f.link->sets.empty());  // check never sets
  auto s = f.sup->status(gw);
  EXPECT_EQ(s.mode, 1);
  EXPECT_TRUE(s.mismatch);
  EXPECT_EQ(s.interface, 250000u);
  EXPECT_EQ(f.count("bit rate mismatch: gateway gw5 is parameterized for 500 kbit/s"), 1u);
  for (int i = 1; i <= 20; ++i) f.sup->update(gw, 500000, t0 + seconds(i));  // no spam
  EXPECT_EQ(f.count("bit rate mismatch"), 1u);
  EXPECT_LE(f.link->reads, 1 + 20 / 5 + 1);  // re-read every 5 s, not every cycle
  f.link->bitrate = 500000;                  // an operator fixed it: seen at the next re-read
  f.sup->update(gw, 500000, t0 + seconds(30));
  EXPECT_FALSE(f.sup->status(gw).mismatch);
  EXPECT_TRUE(f.log.contains("bit rate 500 kbit/s matches gateway gw5"));
}

TEST(BitrateSupervisor, VirtualInterfaceSaidOnceNoWarnings) {
  for (auto mode : {config::BitrateMode::Check, config::BitrateMode::Apply}) {
    Fixture f(mode);
    f.link->controller = false;
    const auto gw = f.sup->add_gateway("gw5");
    for (int i = 0; i < 30; ++i) f.sup->update(gw, 125000 + (i / 10) * 1000, t0 + seconds(i));
    EXPECT_EQ(f.count("no bit timing (virtual interface)"), 1u);
    EXPECT_TRUE(std::none_of(f.log.lines.begin(), f.log.lines.end(),
                             [](const auto& l) { return l.level >= LogLevel::Warn; }));
    EXPECT_FALSE(f.sup->status(gw).mismatch);
    EXPECT_EQ(f.sup->status(gw).interface, 0u);
    EXPECT_TRUE(f.link->sets.empty());
  }
}

// Two gateways on one interface: a second Set_Prm with another bit rate is refused at run time;
// the interface keeps the first gateway's rate and the second shows the mismatch.
TEST(BitrateSupervisor, SharedInterfaceRefusesAConflictingSetPrm) {
  Fixture f(config::BitrateMode::Apply);
  const auto a = f.sup->add_gateway("gw5");
  const auto b = f.sup->add_gateway("gw6");
  f.sup->update(a, 500000, t0);
  f.sup->update(b, 250000, t0);
  ASSERT_EQ(f.link->sets.size(), 1u);
  EXPECT_EQ(f.link->bitrate, 500000u);
  EXPECT_TRUE(f.log.contains("gateway gw6: Set_Prm bit rate 250 kbit/s refused: gateway gw5"));
  EXPECT_FALSE(f.sup->status(a).mismatch);
  EXPECT_TRUE(f.sup->status(b).mismatch);
  f.sup->update(b, 500000, t0 + seconds(1));  // re-parameterized to agree
  EXPECT_FALSE(f.sup->status(b).mismatch);
  EXPECT_EQ(f.link->sets.size(), 1u);
}

// An interface as it is after boot: down at some bit rate, or down without any bit timing. apply
// sets the Set_Prm's rate (and restart-ms) and brings it up once the rate is known.
TEST(BitrateSupervisor, ApplyBringsUpADownInterfaceAtTheSetPrmRate) {
  for (const std::optional<std::uint32_t> before :
       {std::optional<std::uint32_t>(125000), std::optional<std::uint32_t>()}) {
    Fixture f(config::BitrateMode::Apply, 100);
    f.link->up = false;
    f.link->bitrate = before;
    const auto gw = f.sup->add_gateway("gw5");
    f.sup->update(gw, std::nullopt, t0);  // before Set_Prm the rate is unknown: nothing yet
    EXPECT_TRUE(f.link->sets.empty());
    EXPECT_EQ(f.link->reads, 0);
    f.sup->update(gw, 500000, t0);  // manual table 5.1.1: Set_Prm byte 8 = 2
    ASSERT_EQ(f.link->sets.size(), 1u);
    EXPECT_EQ(f.link->sets[0], std::make_pair(500000u, std::optional<std::uint32_t>(100)));
    EXPECT_TRUE(f.link->up);
    EXPECT_TRUE(f.log.contains(std::string("bit rate set to 500 kbit/s from the Set_Prm of "
                                           "gateway gw5 (was ") +
                               (before ? "125 kbit/s" : "no bit timing") +
                               ", down), restart-ms 100; interface up"))
        << f.log.lines.back().message;
    EXPECT_FALSE(f.sup->status(gw).mismatch);
    EXPECT_EQ(f.count("is down"), 0u);
  }
}

// Someone takes the interface down later: apply does not fight them (it would race with their
// `ip link set ... type can ...`); the log says how to bring it up, and that it is up again.
TEST(BitrateSupervisor, ApplyReportsAnInterfaceTakenDownLaterAndItsReturn) {
  Fixture f(config::BitrateMode::Apply, 100);
  const auto gw = f.sup->add_gateway("gw5");
  f.sup->update(gw, 500000, t0);
  ASSERT_EQ(f.link->sets.size(), 1u);
  f.link->up = false;
  f.sup->update(gw, 500000, t0 + seconds(5));
  EXPECT_EQ(f.link->sets.size(), 1u);
  EXPECT_TRUE(
      f.log.contains("interface can0 is down: the gateways on it report bus-off until it "
                     "is up at 500 kbit/s (Set_Prm of gateway gw5): `ip link set can0 up`"))
      << f.log.lines.back().message;
  for (int i = 6; i < 30; ++i) f.sup->update(gw, 500000, t0 + seconds(i));
  EXPECT_EQ(f.count("is down"), 1u);
  f.link->up = true;
  f.sup->update(gw, 500000, t0 + seconds(30));
  EXPECT_TRUE(f.log.contains("interface can0 is up at 500 kbit/s"));
}

// Without CAP_NET_ADMIN the log line is the exact command to run, with the real values.
TEST(BitrateSupervisor, ApplyWithoutCapNetAdminOnADownInterfaceGivesTheCommand) {
  Fixture f(config::BitrateMode::Apply, 100);
  f.link->up = false;
  f.link->refuse = EPERM;
  const auto gw = f.sup->add_gateway("gw5");
  f.sup->update(gw, 500000, t0);
  EXPECT_TRUE(
      f.log.contains("run `ip link set can0 type can bitrate 500000 restart-ms 100 && ip "
                     "link set can0 up` as root"))
      << f.log.lines.front().message;
  EXPECT_TRUE(f.sup->status(gw).mismatch);
  EXPECT_EQ(f.count("is down"), 1u);
}

// check: a down interface is not an error; the log gives the command with the Set_Prm rate, the
// status block the mismatch, and both end when the interface is up at the rate.
TEST(BitrateSupervisor, CheckReportsADownInterfaceWithTheCommandAndItsRecovery) {
  Fixture f(config::BitrateMode::Check);
  f.link->up = false;
  f.link->bitrate = 125000;
  const auto gw = f.sup->add_gateway("gw5");
  f.sup->update(gw, std::nullopt, t0);
  EXPECT_EQ(f.link->reads, 0);  // before Set_Prm: nothing to say
  f.sup->update(gw, 500000, t0);
  EXPECT_TRUE(f.link->sets.empty());
  EXPECT_TRUE(
      f.log.contains("interface can0 is down: the gateways on it report bus-off until it "
                     "is up at 500 kbit/s (Set_Prm of gateway gw5): `ip link set can0 type "
                     "can bitrate 500000 && ip link set can0 up`"))
      << f.log.lines.back().message;
  EXPECT_EQ(f.count("bit rate mismatch"), 0u);  // the down line says it all
  EXPECT_TRUE(f.sup->status(gw).mismatch);
  f.link->bitrate = 500000;  // the operator ran the command
  f.link->up = true;
  f.sup->update(gw, 500000, t0 + seconds(5));
  EXPECT_FALSE(f.sup->status(gw).mismatch);
  EXPECT_EQ(f.sup->status(gw).interface, 500000u);
  EXPECT_TRUE(f.log.contains("interface can0 is up at 500 kbit/s"));
  EXPECT_EQ(f.count("is down"), 1u);
}

TEST(BitrateSupervisor, CheckOnAControllerWithoutBitTiming) {
  Fixture f(config::BitrateMode::Check);
  f.link->up = false;
  f.link->bitrate = std::nullopt;
  const auto gw = f.sup->add_gateway("gw5");
  f.sup->update(gw, 250000, t0);
  EXPECT_TRUE(
      f.log.contains("interface can0 is down and has no bit timing: the gateways on it "
                     "report bus-off until it is up at 250 kbit/s (Set_Prm of gateway "
                     "gw5): `ip link set can0 type can bitrate 250000 && ip link set can0 "
                     "up`"));
  EXPECT_TRUE(f.sup->status(gw).mismatch);
  EXPECT_EQ(f.sup->status(gw).interface, 0u);
  EXPECT_EQ(f.count("no bit timing (virtual interface)"), 0u);
}

TEST(CanLink, IpLinkCommand) {
  EXPECT_EQ(can::ip_link_command("can0", 500000, 100, false),
            "ip link set can0 type can bitrate 500000 restart-ms 100 && ip link set can0 up");
  EXPECT_EQ(can::ip_link_command("can0", 250000, std::nullopt, true),
            "ip link set can0 down && ip link set can0 type can bitrate 250000 && ip link set "
            "can0 up");
  EXPECT_EQ(can::ip_link_command("can1", 0, std::nullopt, false), "ip link set can1 up");
}

// manual table 5.1.1 rates: 666.6k and 333.3k are never exact on a real controller clock.
TEST(CanLink, BitrateMatchesWithinOnePercent) {
  EXPECT_TRUE(can::bitrate_matches(500000, 500000));
  EXPECT_TRUE(can::bitrate_matches(666600, 666666));
  EXPECT_TRUE(can::bitrate_matches(333300, 333333));
  EXPECT_FALSE(can::bitrate_matches(500000, 250000));
  EXPECT_FALSE(can::bitrate_matches(125000, 100000));
  EXPECT_FALSE(can::bitrate_matches(10000, 10200));
}

TEST(CanLink, Helpers) {
  EXPECT_EQ(can::to_bus_state(can::ControllerState::ErrorActive), can::BusState::Ok);
  EXPECT_EQ(can::to_bus_state(can::ControllerState::ErrorWarning), can::BusState::Warning);
  EXPECT_EQ(can::to_bus_state(can::ControllerState::ErrorPassive), can::BusState::ErrorPassive);
  EXPECT_EQ(can::to_bus_state(can::ControllerState::BusOff), can::BusState::BusOff);
  EXPECT_EQ(can::to_bus_state(can::ControllerState::Stopped), can::BusState::BusOff);
  const auto text =
      can::describe_link_error("can0", {EOPNOTSUPP, "x failed"}, "ip link set can0 up");
  EXPECT_EQ(text.find("CAP_NET_ADMIN"), std::string::npos) << text;
}

// The host kernel of CI machines has no CAN: asking a missing interface fails cleanly.
TEST(CanLink, MissingInterfaceHasNoBitTiming) {
  std::string error;
  EXPECT_FALSE(can::CanLink("nosuchcan9").bittiming(&error));
  EXPECT_NE(error.find("nosuchcan9"), std::string::npos) << error;
  EXPECT_FALSE(can::CanLink("nosuchcan9").state());
}

}  // namespace
}  // namespace candp2::bitrate
