// SocketCAN on a real kernel: the channel contract on two raw sockets, plus what only a kernel can
// show (error frames → bus state, receive queue overflow → rx_lost). Interface:
// $CANDP2_TEST_CAN_IFACE (default vcan0). Every test skips where the kernel has no CAN support or
// the interface is missing; they run in the QEMU guest (tools/qemu/run-guest). A separate
// executable so that ctest can serialize it (RESOURCE_LOCK): tests sharing one interface see each
// other's frames.
#include <linux/can.h>
#include <linux/can/error.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include "can/socketcan.hpp"
#include "channel_contract.hpp"

namespace candp2::test {
namespace {

INSTANTIATE_TYPED_TEST_SUITE_P(Transports, ChannelContract, ::testing::Types<SocketCanRig>,
                               RigNames);

std::string test_interface() {
  const char* env = std::getenv("CANDP2_TEST_CAN_IFACE");
  return env ? env : "vcan0";
}

// Writes raw struct can_frames on the interface, error frames included (a vcan loops them back to
// every socket whose CAN_RAW_ERR_FILTER matches, like a controller's driver would report them).
class RawInjector {
 public:
  bool open(const std::string& iface) {
    fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
    if (fd_ < 0) return false;
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = static_cast<int>(::if_nametoindex(iface.c_str()));
    return addr.can_ifindex != 0 &&
           ::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  }
  ~RawInjector() {
    if (fd_ >= 0) ::close(fd_);
  }
  bool write(canid_t id, std::initializer_list<std::uint8_t> data = {}) {
    can_frame f{};
    f.can_id = id;
    f.len = static_cast<std::uint8_t>(data.size());
    std::copy(data.begin(), data.end(), f.data);
    if (::write(fd_, &f, sizeof f) == static_cast<ssize_t>(sizeof f)) return true;
    // A socket reports an interface that went down (sk_err = ENETDOWN) once, on its next call.
    return errno == ENETDOWN && ::write(fd_, &f, sizeof f) == static_cast<ssize_t>(sizeof f);
  }

 private:
  int fd_ = -1;
};

class SocketCanKernel : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string error;
    ch_ = can::open_socketcan(test_interface(), &error, {.receive_own = false, .log = &log_});
    if (!ch_) GTEST_SKIP() << "SocketCAN not available here: " << error;
    ASSERT_TRUE(inject_.open(test_interface()));
    loop_.add_fd(ch_->poll_fd(), EventLoop::kReadable, [](std::uint32_t) {});
  }
  // Injects a marker data frame and reads until it arrives; error frames before it are handled.
  void settle() {
    ASSERT_TRUE(inject_.write(0x7EE, {0x4D}));
    const auto f = receive_within(loop_, *ch_);
    ASSERT_TRUE(f);
    EXPECT_EQ(can::format_candump(*f), "7EE#4D");
  }

  EventLoop loop_;
  MemoryLog log_;
  std::unique_ptr<can::Channel> ch_;
  RawInjector inject_;
};

TEST_F(SocketCanKernel, ErrorFramesDriveTheBusState) {
  // linux/can/error.h classes and controller bits; never returned by receive().
  ASSERT_TRUE(
      inject_.write(CAN_ERR_FLAG | CAN_ERR_CRTL, {0, CAN_ERR_CRTL_RX_WARNING, 0, 0, 0, 0, 0, 0}));
  settle();
  EXPECT_EQ(ch_->bus_state(), can::BusState::Warning);
  ASSERT_TRUE(
      inject_.write(CAN_ERR_FLAG | CAN_ERR_CRTL, {0, CAN_ERR_CRTL_TX_PASSIVE, 0, 0, 0, 0, 0, 0}));
  settle();
  EXPECT_EQ(ch_->bus_state(), can::BusState::ErrorPassive);
  ASSERT_TRUE(inject_.write(CAN_ERR_FLAG | CAN_ERR_BUSOFF, {0, 0, 0, 0, 0, 0, 0, 0}));
  settle();
  EXPECT_EQ(ch_->bus_state(), can::BusState::BusOff);
  ASSERT_TRUE(inject_.write(CAN_ERR_FLAG | CAN_ERR_RESTARTED, {0, 0, 0, 0, 0, 0, 0, 0}));
  settle();
  EXPECT_EQ(ch_->bus_state(), can::BusState::Ok);
  EXPECT_TRUE(log_.contains("bus state error-passive -> bus-off"));
  EXPECT_EQ(ch_->rx_lost(), 0u);
}

TEST_F(SocketCanKernel, ControllerRxOverflowCountsInRxLost) {
  ASSERT_TRUE(
      inject_.write(CAN_ERR_FLAG | CAN_ERR_CRTL, {0, CAN_ERR_CRTL_RX_OVERFLOW, 0, 0, 0, 0, 0, 0}));
  settle();
  EXPECT_EQ(ch_->rx_lost(), 1u);
  EXPECT_EQ(ch_->bus_state(), can::BusState::Ok);
}

TEST_F(SocketCanKernel, SocketQueueOverflowCountsInRxLost) {
  // Fill the channel's receive queue without reading; SO_RXQ_OVFL reports the drops with the next
  // frame queued after them.
  for (int i = 0; i < 20000; ++i) {
    if (!inject_.write(0x100, {static_cast<std::uint8_t>(i)})) break;  // ENOBUFS ends the burst
  }
  while (ch_->receive()) {
  }
  settle();
  EXPECT_GT(ch_->rx_lost(), 0u);
  EXPECT_TRUE(log_.contains("frames lost (SO_RXQ_OVFL)"));
}

// Sets the interface up or down (needs CAP_NET_ADMIN, i.e. root in the guest).
bool set_link_up(const std::string& iface, bool up) {
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) return false;
  ifreq ifr{};
  std::snprintf(ifr.ifr_name, sizeof ifr.ifr_name, "%s", iface.c_str());
  bool ok = ::ioctl(fd, SIOCGIFFLAGS, &ifr) == 0;
  if (ok) {
    ifr.ifr_flags = static_cast<short>(up ? (ifr.ifr_flags | IFF_UP) : (ifr.ifr_flags & ~IFF_UP));
    ok = ::ioctl(fd, SIOCSIFFLAGS, &ifr) == 0;
  }
  ::close(fd);
  return ok;
}

TEST_F(SocketCanKernel, InterfaceGoingDownIsBusOffAndDropsSends) {
  if (!set_link_up(test_interface(), false)) GTEST_SKIP() << "cannot set the link down (not root)";
  ch_->send(test::F("123#01"));  // ENETDOWN
  EXPECT_EQ(ch_->tx_dropped(), 1u);
  EXPECT_EQ(ch_->bus_state(), can::BusState::BusOff);
  EXPECT_FALSE(ch_->receive());  // consumes the socket's pending ENETDOWN error
  ASSERT_TRUE(set_link_up(test_interface(), true));
  ch_->send(test::F("123#02"));
  EXPECT_EQ(ch_->tx_dropped(), 1u);
  EXPECT_EQ(ch_->bus_state(), can::BusState::Ok);
  settle();
  EXPECT_TRUE(log_.contains("dropped: Network is down"));
}

// A down/up the channel only notices afterwards (a bit rate change by "bitrate": "apply", issue
// 14): the pending ENETDOWN meets an interface that is up, so the controller restarted
// error-active.
TEST_F(SocketCanKernel, DownAndUpAgainIsARestartNotABusOff) {
  ASSERT_TRUE(
      inject_.write(CAN_ERR_FLAG | CAN_ERR_CRTL, {0, CAN_ERR_CRTL_TX_PASSIVE, 0, 0, 0, 0, 0, 0}));
  settle();
  ASSERT_EQ(ch_->bus_state(), can::BusState::ErrorPassive);
  if (!set_link_up(test_interface(), false)) GTEST_SKIP() << "cannot set the link down (not root)";
  ASSERT_TRUE(set_link_up(test_interface(), true));
  settle();  // receive() meets the stale ENETDOWN first
  EXPECT_EQ(ch_->bus_state(), can::BusState::Ok);
  EXPECT_TRUE(log_.contains("interface was restarted (down and up); controller error-active"));
  EXPECT_FALSE(log_.contains("interface went down"));
}

}  // namespace
}  // namespace candp2::test
