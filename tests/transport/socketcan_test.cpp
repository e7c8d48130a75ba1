// SocketCAN: the pure conversions (run everywhere) and the open() error paths that this machine can
// reach (its kernel has no CAN support: socket(AF_CAN) fails). The data path runs in the channel
// contract suite inside the QEMU guest.
#include "can/socketcan.hpp"

#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>

#include "can/link_events.hpp"
#include "common/log.hpp"
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
  // docs/dp-slave.md "Diagnosis": IRQ_LOST counts SO_RXQ_OVFL drops and controller RX-overflow
  // error frames.
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

// --- Link events (rtnetlink RTMGRP_LINK), parsed without a kernel --------------------------------

// One RTM_NEWLINK/RTM_DELLINK message as the kernel writes it (linux/rtnetlink.h): nlmsghdr,
// ifinfomsg, then an IFLA_IFNAME attribute when `name` is given.
std::vector<std::uint8_t> link_message(std::uint16_t type, int index, unsigned flags,
                                       const char* name) {
  std::vector<std::uint8_t> m(NLMSG_LENGTH(sizeof(ifinfomsg)));
  ifinfomsg info{};
  info.ifi_index = index;
  info.ifi_flags = flags;
  std::memcpy(m.data() + NLMSG_HDRLEN, &info, sizeof info);
  if (name) {
    rtattr a{};
    a.rta_type = IFLA_IFNAME;
    a.rta_len = static_cast<unsigned short>(RTA_LENGTH(std::strlen(name) + 1));
    const std::size_t at = NLMSG_ALIGN(m.size());
    m.resize(at + RTA_ALIGN(a.rta_len));
    std::memcpy(m.data() + at, &a, sizeof a);
    std::memcpy(m.data() + at + RTA_LENGTH(0), name, std::strlen(name) + 1);
  }
  nlmsghdr h{};
  h.nlmsg_len = static_cast<std::uint32_t>(m.size());
  h.nlmsg_type = type;
  std::memcpy(m.data(), &h, sizeof h);
  return m;
}

TEST(LinkEvents, ParsesNewAndRemovedLinksInOrder) {
  std::vector<std::uint8_t> d = link_message(RTM_NEWLINK, 7, IFF_UP | IFF_RUNNING, "can0");
  const auto down = link_message(RTM_NEWLINK, 7, 0, "can0");
  const auto other = link_message(RTM_NEWADDR, 1, 0, nullptr);  // not a link message: skipped
  const auto removed = link_message(RTM_DELLINK, 7, 0, nullptr);
  for (const auto* part : {&down, &other, &removed}) d.insert(d.end(), part->begin(), part->end());
  const auto events = parse_link_events(d);
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].kind, LinkEvent::Kind::New);
  EXPECT_EQ(events[0].index, 7);
  EXPECT_TRUE(events[0].up);
  EXPECT_EQ(events[0].name, "can0");
  EXPECT_FALSE(events[1].up);
  EXPECT_EQ(events[2].kind, LinkEvent::Kind::Removed);
  EXPECT_EQ(events[2].name, "");
}

TEST(LinkEvents, TruncatedAndMalformedDatagramsAreSkipped) {
  auto m = link_message(RTM_NEWLINK, 3, IFF_UP, "vcan0");
  for (std::size_t n = 0; n < m.size(); ++n)  // every truncation: no crash, never a wrong event
    for (const auto& e : parse_link_events(std::span(m.data(), n))) EXPECT_EQ(e.index, 3);
  auto bad = m;
  bad[0] = 4;  // nlmsg_len below the header: the rest is dropped
  EXPECT_TRUE(parse_link_events(bad).empty());
  auto bad_attr = m;  // an attribute longer than the message: the event stays, without a name
  const std::size_t at = NLMSG_ALIGN(NLMSG_LENGTH(sizeof(ifinfomsg)));
  bad_attr[at] = 0xFF;
  bad_attr[at + 1] = 0x0F;
  const auto events = parse_link_events(bad_attr);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].name, "");
}

// --- A down interface, opened anyway (candp2d): event-driven recovery -------------------------

// Runs `ip link ...` (busybox in the QEMU guest). Needs root.
void ip(const std::string& args) {
  ASSERT_EQ(std::system(("ip link " + args).c_str()), 0) << "ip link " << args;
}

// Waits until the channel's poll_fd() is readable and drains it; the channel's bus state then
// tells what it learnt. Bounded by `ms`.
bool drain_until(Channel& ch, BusState want, int ms) {
  for (int waited = 0; waited <= ms; waited += 50) {
    while (ch.receive()) {
    }
    if (ch.bus_state() == want) return true;
    pollfd p{ch.poll_fd(), POLLIN, 0};
    ::poll(&p, 1, 50);
  }
  return false;
}

TEST(SocketCanDown, OpenedDownRecoversWhenTheInterfaceComesUpWithoutAFrame) {
  const char* iface = std::getenv("CANDP2_TEST_CAN_DOWN_IFACE");
  if (!iface || !kernel_has_can() || ::geteuid() != 0)
    GTEST_SKIP() << "needs kernel CAN, root and CANDP2_TEST_CAN_DOWN_IFACE";
  const std::string name = iface;
  MemoryLog log;
  std::string error;
  auto ch = open_socketcan(name, &error, {.log = &log, .allow_down = true});
  ASSERT_NE(ch, nullptr) << error;
  EXPECT_EQ(ch->bus_state(), BusState::BusOff);
  EXPECT_TRUE(log.contains("opened, but the interface is down")) << log.lines.back().message;
  EXPECT_FALSE(ch->receive());
  ip("set " + name + " up");  // no frame: the link event alone must wake the channel
  EXPECT_TRUE(drain_until(*ch, BusState::Ok, 5000));
  EXPECT_TRUE(log.contains("interface is up again"));
  ip("set " + name + " down");
  EXPECT_TRUE(drain_until(*ch, BusState::BusOff, 5000));
  EXPECT_TRUE(log.contains("interface went down"));
  // Removed and created again under the same name: a new index, the socket is bound anew and
  // frames flow (a second socket on the new interface sends, this one receives).
  ip("del " + name);
  EXPECT_TRUE(drain_until(*ch, BusState::BusOff, 5000));
  ip("add dev " + name + " type vcan");
  ip("set " + name + " up");
  EXPECT_TRUE(drain_until(*ch, BusState::Ok, 5000));
  EXPECT_TRUE(log.contains("interface was created again")) << log.lines.back().message;
  auto peer = open_socketcan(name, &error);
  ASSERT_NE(peer, nullptr) << error;
  peer->send(F("123#AB"));
  std::optional<Frame> got;
  for (int i = 0; i < 100 && !got; ++i) {
    pollfd p{ch->poll_fd(), POLLIN, 0};
    ::poll(&p, 1, 50);
    got = ch->receive();
  }
  ASSERT_TRUE(got);
  EXPECT_EQ(format_candump(*got), "123#AB");
  ip("set " + name + " down");  // as the guest script left it
}

}  // namespace
}  // namespace candp2::can
