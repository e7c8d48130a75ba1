// One contract for every can::Channel implementation (python-can's back2back_test
// does the same): two nodes `a` and `b` on one bus exchange frames in both directions.
// Instantiated by channel_contract_test.cpp (in-process and socketcand rigs) and
// socketcan_contract_test.cpp (SocketCAN, a separate executable that holds the CAN interface).
//
// Rigs:
//  - Virtual:    two VirtualBus endpoints;
//  - Socketcand: `a` is the socketcand client channel, connected over 127.0.0.1 to the socketcand
//                server that exports a VirtualBus; `b` is another node on that VirtualBus;
//  - SocketCan:  two raw sockets on $CANDP2_TEST_CAN_IFACE (default vcan0); skipped where the
//                kernel has no CAN support or the interface is missing (it runs in the QEMU guest).
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>

#include "can/socketcan.hpp"
#include "transport_test_support.hpp"

namespace candp2::test {

using can::Channel;
using can::Frame;

struct VirtualRig {
  static constexpr bool kRemoteFrames = true;
  bool setup(std::string*) {
    a_ = bus_.endpoint("a");
    b_ = bus_.endpoint("b");
    return true;
  }
  Channel& a() { return *a_; }
  Channel& b() { return *b_; }
  EventLoop loop;
  can::VirtualBus bus_;
  std::unique_ptr<can::VirtualEndpoint> a_, b_;
};

struct SocketcandRig {
  // socketcand has no remote frames (state_raw.c: RTR "TODO implement"; `< send >` has no flag).
  static constexpr bool kRemoteFrames = false;
  bool setup(std::string* why) {
    rig_ = std::make_unique<ServerRig>();
    client_ = rig_->connect_client(why);
    return client_ != nullptr;
  }
  Channel& a() { return *client_; }
  Channel& b() { return *rig_->peer; }
  std::unique_ptr<ServerRig> rig_;
  std::unique_ptr<Channel> client_;
  EventLoop& loop_ref() { return rig_->loop; }
};

struct SocketCanRig {
  static constexpr bool kRemoteFrames = true;
  bool setup(std::string* why) {
    const char* env = std::getenv("CANDP2_TEST_CAN_IFACE");
    const std::string iface = env ? env : "vcan0";
    std::string error;
    a_ = can::open_socketcan(iface, &error);
    if (a_) b_ = can::open_socketcan(iface, &error);
    if (!a_ || !b_) {
      *why = "SocketCAN not available here: " + error;
      return false;
    }
    loop.add_fd(a_->poll_fd(), EventLoop::kReadable, [](std::uint32_t) {});
    loop.add_fd(b_->poll_fd(), EventLoop::kReadable, [](std::uint32_t) {});
    return true;
  }
  Channel& a() { return *a_; }
  Channel& b() { return *b_; }
  EventLoop loop;
  std::unique_ptr<Channel> a_, b_;
};

template <typename Rig>
EventLoop& loop_of(Rig& rig) {
  if constexpr (requires { rig.loop_ref(); })
    return rig.loop_ref();
  else
    return rig.loop;
}

template <typename Rig>
class ChannelContract : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    if (!rig_.setup(&why)) {
      if constexpr (std::is_same_v<Rig, SocketCanRig>) GTEST_SKIP() << why;
      FAIL() << why;
    }
  }
  Channel& a() { return rig_.a(); }
  Channel& b() { return rig_.b(); }
  std::optional<Frame> next(Channel& ch) { return receive_within(loop_of(rig_), ch); }

  // Sends `frame` from `from` and expects exactly it at `to`.
  void expect_delivered(Channel& from, Channel& to, const Frame& frame) {
    from.send(frame);
    const auto got = next(to);
    ASSERT_TRUE(got) << "nothing arrived for " << can::format_candump(frame);
    EXPECT_EQ(can::format_candump(*got), can::format_candump(frame));
    EXPECT_EQ(*got, frame);
  }

  Rig rig_;
};

class RigNames {
 public:
  template <typename T>
  static std::string GetName(int) {
    if (std::is_same_v<T, VirtualRig>) return "Virtual";
    if (std::is_same_v<T, SocketcandRig>) return "Socketcand";
    return "SocketCan";
  }
};
TYPED_TEST_SUITE_P(ChannelContract);

TYPED_TEST_P(ChannelContract, StartsHealthy) {
  EXPECT_EQ(this->a().bus_state(), can::BusState::Ok);
  EXPECT_EQ(this->b().bus_state(), can::BusState::Ok);
  EXPECT_EQ(this->a().rx_lost(), 0u);
  EXPECT_EQ(this->a().tx_dropped(), 0u);
  EXPECT_FALSE(this->a().name().empty());
  EXPECT_FALSE(this->a().receive());
}

TYPED_TEST_P(ChannelContract, StandardFrameAToB) {
  this->expect_delivered(this->a(), this->b(), F("123#1122334455667788"));
}

TYPED_TEST_P(ChannelContract, StandardFrameBToA) {
  this->expect_delivered(this->b(), this->a(), F("321#AABB"));
}

TYPED_TEST_P(ChannelContract, ElevenBitBoundaries) {
  for (const char* f : {"000#00", "7FF#FF", "001#", "400#0102"}) {
    SCOPED_TRACE(f);
    this->expect_delivered(this->a(), this->b(), F(f));
    this->expect_delivered(this->b(), this->a(), F(f));
  }
}

TYPED_TEST_P(ChannelContract, TwentyNineBitIdentifiersBothWays) {
  // 00000123 is a 29-bit frame with a small value: it must stay 29-bit (socketcand: 8 digits).
  for (const char* f :
       {"1ABCDEF0#0102", "1FFFFFFF#FF", "00000123#11", "00000000#", "00000800#01"}) {
    SCOPED_TRACE(f);
    this->expect_delivered(this->a(), this->b(), F(f));
    this->expect_delivered(this->b(), this->a(), F(f));
  }
}

TYPED_TEST_P(ChannelContract, EveryDlcFromZeroToEight) {
  for (std::uint8_t dlc = 0; dlc <= 8; ++dlc) {
    std::vector<std::uint8_t> bytes;
    for (std::uint8_t i = 0; i < dlc; ++i) bytes.push_back(static_cast<std::uint8_t>(0xA0 + i));
    const Frame f = Frame::std_data(0x100 + dlc, bytes);
    SCOPED_TRACE(can::format_candump(f));
    this->expect_delivered(this->a(), this->b(), f);
    this->expect_delivered(this->b(), this->a(), Frame::ext_data(0x1000 + dlc, bytes));
  }
}

TYPED_TEST_P(ChannelContract, RemoteFramesWithDlc) {
  const Frame marker = F("7FE#4D");
  for (const char* text : {"123#R", "123#R4", "1ABCDEF0#R8"}) {
    SCOPED_TRACE(text);
    const Frame rtr = F(text);
    if constexpr (TypeParam::kRemoteFrames) {
      this->expect_delivered(this->a(), this->b(), rtr);
      this->expect_delivered(this->b(), this->a(), rtr);
    } else {
      // The link cannot carry remote frames: the client refuses to send one (counted), the server
      // does not forward one; the next data frame arrives as the very next frame.
      const auto dropped = this->a().tx_dropped();
      this->a().send(rtr);
      EXPECT_EQ(this->a().tx_dropped(), dropped + 1);
      this->expect_delivered(this->a(), this->b(), marker);
      this->b().send(rtr);
      this->expect_delivered(this->b(), this->a(), marker);
    }
  }
}

TYPED_TEST_P(ChannelContract, SenderDoesNotReceiveItsOwnFrames) {
  this->a().send(F("111#01"));
  this->expect_delivered(this->b(), this->a(), F("222#02"));  // the next frame at a is b's
  const auto at_b = this->next(this->b());
  ASSERT_TRUE(at_b);
  EXPECT_EQ(*at_b, F("111#01"));
}

TYPED_TEST_P(ChannelContract, ManyFramesKeepTheirOrderBothWays) {
  // 1000 frames each way, in bursts of 100 (a real kernel socket buffer holds a few hundred).
  for (auto [from, to] : {std::pair{&this->a(), &this->b()}, std::pair{&this->b(), &this->a()}}) {
    std::uint32_t expected = 0;
    for (std::uint32_t burst = 0; burst < 10; ++burst) {
      for (std::uint32_t i = 0; i < 100; ++i) {
        const std::uint32_t n = burst * 100 + i;
        const std::uint8_t bytes[] = {static_cast<std::uint8_t>(n >> 8),
                                      static_cast<std::uint8_t>(n)};
        from->send(n % 2 ? Frame::ext_data(0x10000 + n, bytes) : Frame::std_data(n % 0x800, bytes));
      }
      for (std::uint32_t i = 0; i < 100; ++i, ++expected) {
        const auto got = this->next(*to);
        ASSERT_TRUE(got) << "frame " << expected << " missing";
        ASSERT_EQ(got->dlc, 2);
        ASSERT_EQ((got->data[0] << 8) | got->data[1], static_cast<int>(expected));
        ASSERT_EQ(got->extended, expected % 2 == 1);
      }
    }
    EXPECT_EQ(from->tx_dropped(), 0u);
    EXPECT_EQ(to->rx_lost(), 0u);
  }
}

REGISTER_TYPED_TEST_SUITE_P(ChannelContract, StartsHealthy, StandardFrameAToB, StandardFrameBToA,
                            ElevenBitBoundaries, TwentyNineBitIdentifiersBothWays,
                            EveryDlcFromZeroToEight, RemoteFramesWithDlc,
                            SenderDoesNotReceiveItsOwnFrames, ManyFramesKeepTheirOrderBothWays);

}  // namespace candp2::test
