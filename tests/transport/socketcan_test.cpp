// SocketCAN: the pure conversions (run everywhere) and the open() error paths that this machine can
// reach (its kernel has no CAN support: socket(AF_CAN) fails). The data path runs in the channel
// contract suite inside the QEMU guest.
#include "can/socketcan.hpp"

#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>

#include "transport_test_support.hpp"

namespace candp2::can {
namespace {

using test::F;

bool kernel_has_can() {
  const int fd = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0) return false;
  ::close(fd);
  return true;
}

// --- Frame <-> struct can_frame (linux/can.h) ------------------------------------------------

TEST(SocketCanEncode, FlagsFollowLinuxCanH) {
  auto raw = socketcan::encode(F("123#1122"));
  EXPECT_EQ(raw.can_id, 0x123u);
  EXPECT_EQ(raw.len, 2);
  EXPECT_EQ(raw.data[0], 0x11);
  EXPECT_EQ(raw.data[1], 0x22);

  raw = socketcan::encode(F("1ABCDEF0#01"));
  EXPECT_EQ(raw.can_id, 0x1ABCDEF0u | CAN_EFF_FLAG);

  raw = socketcan::encode(F("00000005#"));  // 29-bit with a small value keeps CAN_EFF_FLAG
  EXPECT_EQ(raw.can_id, 0x5u | CAN_EFF_FLAG);

  raw = socketcan::encode(F("123#R4"));  // RTR: DLC carried in len, no data
  EXPECT_EQ(raw.can_id, 0x123u | CAN_RTR_FLAG);
  EXPECT_EQ(raw.len, 4);
  EXPECT_EQ(raw.data, (std::array<std::uint8_t, 8>{}));

  raw = socketcan::encode(F("1FFFFFFF#R8"));
  EXPECT_EQ(raw.can_id, 0x1FFFFFFFu | CAN_EFF_FLAG | CAN_RTR_FLAG);
  EXPECT_EQ(raw.len, 8);
}

TEST(SocketCanDecode, RoundTripsEveryKindOfFrame) {
  for (const char* text : {"000#", "7FF#0102030405060708", "00000000#", "1FFFFFFF#FF", "123#R",
                           "123#R8", "1ABCDEF0#R3"}) {
    SCOPED_TRACE(text);
    const auto back = socketcan::decode(socketcan::encode(F(text)));
    ASSERT_TRUE(back);
    EXPECT_EQ(format_candump(*back), text);
  }
}

TEST(SocketCanDecode, ErrorFramesAreNotDataAndBadLengthsAreClamped) {
  socketcan::RawFrame raw;
  raw.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
  raw.len = CAN_ERR_DLC;
  EXPECT_FALSE(socketcan::decode(raw));

  raw = {};
  raw.can_id = 0x123;
  raw.len = 15;  // never valid for classic CAN; the channel must not read past data[7]
  raw.data = {1, 2, 3, 4, 5, 6, 7, 8};
  const auto f = socketcan::decode(raw);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->dlc, 8);

  raw.can_id = 0x123 | CAN_RTR_FLAG;  // an RTR frame with stray data keeps the invariant
  raw.len = 2;
  const auto r = socketcan::decode(raw);
  ASSERT_TRUE(r);
  EXPECT_TRUE(r->remote);
  EXPECT_EQ(r->data, (std::array<std::uint8_t, 8>{}));
}

// --- Error frames (linux/can/error.h) -> bus state / IRQ_LOST -----------------------------------

socketcan::RawFrame error_frame(std::uint32_t cls, std::uint8_t ctrl = 0) {
  socketcan::RawFrame raw;
  raw.can_id = CAN_ERR_FLAG | cls;
  raw.len = CAN_ERR_DLC;
  raw.data[1] = ctrl;
  return raw;
}

TEST(SocketCanErrors, ControllerStatesMapToBusState) {
  // channel.hpp / manual §3.4.2: 00 OK, 40 WARN, 80 ERROR_PASSIVE, C0 BUS_OFF.
  struct Case {
    std::uint32_t cls;
    std::uint8_t ctrl;
    std::optional<BusState> state;
  } cases[] = {
      {CAN_ERR_CRTL, CAN_ERR_CRTL_RX_WARNING, BusState::Warning},
      {CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING, BusState::Warning},
      {CAN_ERR_CRTL, CAN_ERR_CRTL_RX_PASSIVE, BusState::ErrorPassive},
      {CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE, BusState::ErrorPassive},
      {CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING | CAN_ERR_CRTL_RX_PASSIVE, BusState::ErrorPassive},
      {CAN_ERR_CRTL, CAN_ERR_CRTL_ACTIVE, BusState::Ok},
      {CAN_ERR_CRTL, CAN_ERR_CRTL_UNSPEC, std::nullopt},
      {CAN_ERR_BUSOFF, 0, BusState::BusOff},
      {CAN_ERR_BUSOFF | CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE, BusState::BusOff},
      {CAN_ERR_RESTARTED, 0, BusState::Ok},
      {CAN_ERR_PROT | CAN_ERR_BUSERROR, 0, std::nullopt},
      {CAN_ERR_ACK, 0, std::nullopt},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(testing::Message() << std::hex << "class " << c.cls << " ctrl " << int(c.ctrl));
    const auto e = socketcan::decode_error(error_frame(c.cls, c.ctrl));
    EXPECT_EQ(e.state, c.state);
    EXPECT_EQ(e.rx_lost, 0u);
    EXPECT_FALSE(e.description.empty());
  }
}

TEST(SocketCanErrors, ControllerRxOverflowCountsALostFrame) {
  // emulator-spec §3: IRQ_LOST counts SO_RXQ_OVFL drops and controller RX-overflow error frames.
  const auto e = socketcan::decode_error(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_OVERFLOW));
  EXPECT_EQ(e.rx_lost, 1u);
  EXPECT_FALSE(e.state);
  EXPECT_NE(e.description.find("rx-overflow"), std::string::npos);
}

TEST(SocketCanErrors, RxqOverflowCounterIsCumulative) {
  socketcan::OverflowCounter c;
  EXPECT_EQ(c.observe(0), 0u);
  EXPECT_EQ(c.observe(5), 5u);
  EXPECT_EQ(c.observe(5), 0u);
  EXPECT_EQ(c.observe(7), 2u);
  EXPECT_EQ(c.observe(0xFFFFFFFFu), 0xFFFFFFF8u);
  EXPECT_EQ(c.observe(2), 3u);  // wraps modulo 2^32
}

// --- open() error paths -------------------------------------------------------------------------

TEST(SocketCanOpen, MissingInterfaceIsNamed) {
  std::string error;
  EXPECT_EQ(open_socketcan("candp2nope0", &error), nullptr);
  EXPECT_NE(error.find("interface candp2nope0 does not exist"), std::string::npos) << error;
}

TEST(SocketCanOpen, BadNamesAreRefused) {
  std::string error;
  EXPECT_EQ(open_socketcan("", &error), nullptr);
  EXPECT_NE(error.find("invalid CAN interface name"), std::string::npos) << error;
  EXPECT_EQ(open_socketcan("a-name-longer-than-15", &error), nullptr);
  EXPECT_NE(error.find("invalid CAN interface name 'a-name-longer-than-15'"), std::string::npos);
}

TEST(SocketCanOpen, ExistingInterfaceWithoutKernelCanOrNotCan) {
  // "lo" exists everywhere. Without kernel CAN the socket fails first (this machine); with it
  // (the QEMU guest) "lo" is refused as not a CAN interface.
  std::string error;
  EXPECT_EQ(open_socketcan("lo", &error), nullptr);
  if (kernel_has_can()) {
    EXPECT_NE(error.find("interface lo is not a CAN interface"), std::string::npos) << error;
  } else {
    EXPECT_NE(error.find("interface lo"), std::string::npos) << error;
    EXPECT_NE(error.find("this kernel has no CAN support (socket(AF_CAN) failed: "),
              std::string::npos)
        << error;
  }
}

TEST(SocketCanOpen, DownInterfaceIsReported) {
  // Needs a CAN interface that exists but is down: `ip link add dev vcan9 type vcan` (no `up`),
  // named in CANDP2_TEST_CAN_DOWN_IFACE (the QEMU guest script does this).
  const char* iface = std::getenv("CANDP2_TEST_CAN_DOWN_IFACE");
  if (!iface || !kernel_has_can())
    GTEST_SKIP() << "needs kernel CAN and CANDP2_TEST_CAN_DOWN_IFACE";
  std::string error;
  EXPECT_EQ(open_socketcan(iface, &error), nullptr);
  EXPECT_NE(error.find(std::string("interface ") + iface + " is down"), std::string::npos) << error;
}

}  // namespace
}  // namespace candp2::can
