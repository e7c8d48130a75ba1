// The serial PHY of docs/profibus.md on pseudo-terminal pairs (no hardware needed): 8E1 raw
// settings read back, bit rates (standard and termios2), bytes both ways, the pty:PATH link, echo
// suppression and PARMRK unescaping.
#include "serial/serial_port.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "serial/serial_linux.hpp"

namespace candp2::serial {
namespace {

namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir() {
    char tmpl[] = "/tmp/candp2-serial-XXXXXX";
    path_ = ::mkdtemp(tmpl);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string operator/(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

// The peer: opens PATH like any serial program would (raw).
int open_peer(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) return fd;
  termios tio;
  ::tcgetattr(fd, &tio);
  ::cfmakeraw(&tio);
  ::tcsetattr(fd, TCSANOW, &tio);
  return fd;
}

bool wait_readable(int fd, int timeout_ms = 2000) {
  pollfd p{fd, POLLIN, 0};
  return ::poll(&p, 1, timeout_ms) == 1 && (p.revents & POLLIN);
}

std::vector<std::uint8_t> read_peer(int fd, std::size_t want) {
  std::vector<std::uint8_t> got;
  while (got.size() < want && wait_readable(fd)) {
    std::uint8_t buf[256];
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n <= 0) break;
    got.insert(got.end(), buf, buf + n);
  }
  return got;
}

std::vector<RxByte> read_port(SerialPort& port, std::size_t want) {
  std::vector<RxByte> got;
  std::string error;
  while (got.size() < want && wait_readable(port.fd())) {
    if (port.read(got, Time(0), &error) < 0) break;
  }
  return got;
}

std::vector<RxByte> plain(std::initializer_list<std::uint8_t> bytes) {
  std::vector<RxByte> v;
  for (auto b : bytes) v.push_back({b, false});
  return v;
}

TEST(SerialBaud, SupportedRatesOfSpec10) {
  // docs/profibus.md: 9.6k, 19.2k, 45.45k, 93.75k, 187.5k, 500k, 1.5M
  for (std::uint32_t b : {9600u, 19200u, 45450u, 93750u, 187500u, 500000u, 1500000u})
    EXPECT_TRUE(phy::is_line_rate(b)) << b;
  EXPECT_FALSE(phy::is_line_rate(115200));
  EXPECT_FALSE(phy::is_line_rate(0));
  EXPECT_NE(phy::line_rates_text().find("93750"), std::string::npos);
}

TEST(SerialBaud, CharTimeIs11Bits) {
  // docs/profibus.md: 11 bits per character; 19200 baud: 572.9 µs -> 573 µs
  EXPECT_EQ(char_time(19200), Duration(573));
  EXPECT_EQ(char_time(1500000, 2), Duration(15));  // 22 bits / 1.5 Mbit/s = 14.7 µs
  EXPECT_EQ(char_time(12000000), Duration(1));
  EXPECT_EQ(char_time(0), Duration(1));
}

TEST(SerialPtyPort, ParsesPrefix) {
  std::string path;
  EXPECT_TRUE(parse_pty_port("pty:/tmp/pb", &path));
  EXPECT_EQ(path, "/tmp/pb");
  EXPECT_FALSE(parse_pty_port("/dev/ttyUSB0", &path));
}

TEST(ParmrkDecoder, UnescapesMarksAndDoubledFf) {
  ParmrkDecoder d;
  std::vector<RxByte> out;
  // 10 | FF FF (data FF) | FF 00 33 (33 with a parity error) | FF 00 00 (break) | 16
  const std::uint8_t in[] = {0x10, 0xFF, 0xFF, 0xFF, 0x00, 0x33, 0xFF, 0x00, 0x00, 0x16};
  d.feed(in, sizeof in, out);
  const std::vector<RxByte> want = {
      {0x10, false}, {0xFF, false}, {0x33, true}, {0x00, true}, {0x16, false}};
  EXPECT_EQ(out, want);
}

TEST(ParmrkDecoder, SequencesSplitAcrossReads) {
  ParmrkDecoder d;
  std::vector<RxByte> out;
  const std::uint8_t a[] = {0x68, 0xFF};
  const std::uint8_t b[] = {0x00};
  const std::uint8_t c[] = {0x7D, 0xFF};
  const std::uint8_t e[] = {0xFF, 0x16};
  d.feed(a, 1 + 1, out);
  EXPECT_EQ(out.size(), 1u);  // the FF waits for its second byte
  d.feed(b, 1, out);
  d.feed(c, 2, out);
  d.feed(e, 2, out);
  const std::vector<RxByte> want = {{0x68, false}, {0x7D, true}, {0xFF, false}, {0x16, false}};
  EXPECT_EQ(out, want);
}

TEST(ParmrkDecoder, LoneFfFollowedByDataPassesBoth) {
  ParmrkDecoder d;
  std::vector<RxByte> out;
  const std::uint8_t in[] = {0xFF, 0x12};
  d.feed(in, sizeof in, out);
  EXPECT_EQ(out, plain({0xFF, 0x12}));
}

TEST(EchoFilter, DropsExactlyTheEcho) {
  EchoFilter f;
  const std::uint8_t sent[] = {0x10, 0x03, 0x02, 0x49, 0x4E, 0x16};  // FDL_Status request, §10
  f.sent(sent, sizeof sent, Time(1000));
  // The echo comes back in two pieces, followed by the answer E5.
  std::vector<RxByte> rx = plain({0x10, 0x03, 0x02});
  f.filter(rx, 0, Time(100));
  EXPECT_TRUE(rx.empty());
  rx = plain({0x49, 0x4E, 0x16, 0xE5});
  f.filter(rx, 0, Time(200));
  EXPECT_EQ(rx, plain({0xE5}));
  EXPECT_EQ(f.dropped(), 6u);
  EXPECT_EQ(f.pending(), 0u);
}

TEST(EchoFilter, MismatchClearsExpectations) {
  EchoFilter f;
  const std::uint8_t sent[] = {0x10, 0x03};
  f.sent(sent, sizeof sent, Time(1000));
  std::vector<RxByte> rx = plain({0x10, 0x77, 0x03});
  f.filter(rx, 0, Time(10));
  EXPECT_EQ(rx, plain({0x77, 0x03}));  // after the mismatch nothing more is dropped
  EXPECT_EQ(f.lost(), 1u);
}

TEST(EchoFilter, ExpiredEchoIsForgotten) {
  EchoFilter f;
  const std::uint8_t sent[] = {0xE5};
  f.sent(sent, 1, Time(1000));
  std::vector<RxByte> rx = plain({0xE5});
  f.filter(rx, 0, Time(1001));  // too late: this E5 is someone else's
  EXPECT_EQ(rx, plain({0xE5}));
  EXPECT_EQ(f.lost(), 1u);
}

TEST(SerialPortPty, LinkSettingsAndBytesBothWays) {
  TempDir dir;
  const std::string link = dir / "pb";
  SerialOptions o;
  o.port = "pty:" + link;
  o.baud = 19200;
  std::string error;
  auto port = SerialPort::open(o, &error);
  ASSERT_TRUE(port) << error;
  EXPECT_TRUE(port->is_pty());
  // The link points to the terminal end.
  ASSERT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(fs::read_symlink(link).string(), port->terminal_path());
  EXPECT_EQ(port->terminal_path().rfind("/dev/pts/", 0), 0u);

  // 8E1 raw, read back (on a pty there is one termios, the terminal end's, also through our fd).
  EXPECT_FALSE(port->marks_parity());
  termios tio;
  ASSERT_EQ(::tcgetattr(port->fd(), &tio), 0);
  EXPECT_EQ(tio.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
  // PARENB: Linux ptys drop it (a pty has no wire; glibc then reports EINVAL and the port falls
  // back to 8N1 on a pty only), so it is not asserted here; never odd parity.
  EXPECT_FALSE(tio.c_cflag & PARODD);
  EXPECT_FALSE(tio.c_cflag & CSTOPB);
  EXPECT_TRUE(tio.c_cflag & CLOCAL);
  EXPECT_TRUE(tio.c_cflag & CREAD);
  EXPECT_FALSE(tio.c_cflag & CRTSCTS);
  // No parity marks on the terminal end: the peer must get a 0xFF as one byte.
  EXPECT_FALSE(tio.c_iflag & PARMRK);
  EXPECT_FALSE(tio.c_iflag & (IXON | IXOFF));
  EXPECT_FALSE(tio.c_lflag & (ECHO | ICANON));
  EXPECT_EQ(tio.c_cc[VMIN], 0);
  EXPECT_EQ(::cfgetospeed(&tio), static_cast<speed_t>(B19200));

  const int peer = open_peer(link);
  ASSERT_GE(peer, 0);
  // The terminal end (the peer's) has no parity marks: a 0xFF we send arrives as one 0xFF.
  termios peer_tio;
  ASSERT_EQ(::tcgetattr(peer, &peer_tio), 0);
  EXPECT_FALSE(peer_tio.c_iflag & PARMRK);
  // Peer -> port: an SD2 telegram with a 0xFF data byte (arrives doubled by PARMRK, unescaped).
  const std::uint8_t req[] = {0x68, 0x05, 0x05, 0x68, 0x83, 0x82, 0x6D, 0xFF, 0x3E, 0xAD, 0x16};
  ASSERT_EQ(::write(peer, req, sizeof req), static_cast<ssize_t>(sizeof req));
  auto got = read_port(*port, sizeof req);
  std::vector<RxByte> want;
  for (auto b : req) want.push_back({b, false});
  EXPECT_EQ(got, want);
  // Port -> peer.
  const std::uint8_t resp[] = {0xE5, 0xFF, 0x00};
  ASSERT_TRUE(port->write(resp, sizeof resp, Time(0), &error)) << error;
  EXPECT_EQ(port->pending(), 0u);
  EXPECT_EQ(read_peer(peer, 3), std::vector<std::uint8_t>(resp, resp + 3));
  ::close(peer);

  // The peer closed: our side does not hang up (we hold the terminal end) and a new peer works.
  pollfd p{port->fd(), POLLIN, 0};
  EXPECT_EQ(::poll(&p, 1, 50), 0) << "revents " << p.revents;
  const int peer2 = open_peer(link);
  ASSERT_GE(peer2, 0);
  const std::uint8_t sc[] = {0x10, 0x03, 0x02, 0x49, 0x4E, 0x16};
  ASSERT_EQ(::write(peer2, sc, sizeof sc), 6);
  EXPECT_EQ(read_port(*port, 6).size(), 6u);
  ::close(peer2);

  port.reset();
  EXPECT_FALSE(fs::exists(fs::symlink_status(link))) << "link removed at close";
}

TEST(SerialPortPty, StaleLinkReplacedRegularFileRefused) {
  TempDir dir;
  const std::string link = dir / "pb";
  fs::create_symlink("/dev/pts/does-not-exist", link);
  SerialOptions o;
  o.port = "pty:" + link;
  std::string error;
  auto port = SerialPort::open(o, &error);
  ASSERT_TRUE(port) << error;
  EXPECT_EQ(fs::read_symlink(link).string(), port->terminal_path());
  port.reset();

  const std::string file = dir / "file";
  {
    FILE* f = ::fopen(file.c_str(), "w");
    ::fputs("keep me", f);
    ::fclose(f);
  }
  o.port = "pty:" + file;
  EXPECT_FALSE(SerialPort::open(o, &error));
  EXPECT_NE(error.find("not a symbolic link"), std::string::npos) << error;
  EXPECT_TRUE(fs::is_regular_file(file));
}

TEST(SerialPortDevice, ProfibusRateThroughTermios2) {
  // The terminal end of a pty opened as a plain device path (what a `role: master` candp2d does on
  // the other side's link): 93750 baud is not a termios Bxxx constant, so it goes via BOTHER.
  TempDir dir;
  SerialOptions s;
  s.port = "pty:" + (dir / "pb");
  std::string error;
  auto server = SerialPort::open(s, &error);
  ASSERT_TRUE(server) << error;

  for (std::uint32_t baud : {45450u, 93750u, 187500u, 19200u, 1500000u}) {
    SerialOptions o;
    o.port = dir / "pb";
    o.baud = baud;
    auto dev = SerialPort::open(o, &error);
    ASSERT_TRUE(dev) << error;
    EXPECT_FALSE(dev->is_pty());
    termios tio;
    ASSERT_EQ(::tcgetattr(dev->fd(), &tio), 0);
    if (baud == 19200) {
      EXPECT_EQ(::cfgetospeed(&tio), static_cast<speed_t>(B19200));  // cfsetspeed
    } else if (baud == 1500000) {
      EXPECT_EQ(::cfgetospeed(&tio), static_cast<speed_t>(B1500000));
    } else {  // termios2 BOTHER
      std::uint32_t ispeed = 0, ospeed = 0;
      ASSERT_EQ(detail::get_baud_termios2(dev->fd(), &ispeed, &ospeed), 0);
      EXPECT_EQ(ospeed, baud);
      EXPECT_EQ(ispeed, baud);
      EXPECT_EQ(tio.c_cflag & CBAUD, static_cast<tcflag_t>(0010000));  // BOTHER (asm/termbits.h)
    }
    EXPECT_FALSE(tio.c_cflag & PARODD);
    EXPECT_EQ(tio.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
    // A device marks parity errors (INPCK + PARMRK) and we unescape them.
    EXPECT_TRUE(dev->marks_parity());
    EXPECT_TRUE(tio.c_iflag & INPCK);
    EXPECT_TRUE(tio.c_iflag & PARMRK);
    // Bytes from the device side reach the pty side.
    const std::uint8_t b[] = {0xDC, 0x03, 0x02};
    ASSERT_TRUE(dev->write(b, sizeof b, Time(0), &error)) << error;
    EXPECT_EQ(read_port(*server, 3), plain({0xDC, 0x03, 0x02}));
    // And back, with a 0xFF data byte: PARMRK doubles it on the device side, read() unescapes.
    const std::uint8_t back[] = {0x68, 0xFF, 0x16};
    ASSERT_TRUE(server->write(back, sizeof back, Time(0), &error)) << error;
    EXPECT_EQ(read_port(*dev, 3), plain({0x68, 0xFF, 0x16}));
  }
}

TEST(SerialPortDevice, ClearErrors) {
  std::string error;
  SerialOptions o;
  o.port = "/dev/candp2-no-such-tty";
  EXPECT_FALSE(SerialPort::open(o, &error));
  EXPECT_NE(error.find("/dev/candp2-no-such-tty"), std::string::npos) << error;
  EXPECT_NE(error.find("No such file"), std::string::npos) << error;

  o.port = "/dev/null";
  EXPECT_FALSE(SerialPort::open(o, &error));
  EXPECT_NE(error.find("not a serial device"), std::string::npos) << error;

  // RS-485 mode on a pty: the driver does not offer it.
  TempDir dir;
  SerialOptions s;
  s.port = "pty:" + (dir / "pb");
  auto server = SerialPort::open(s, &error);
  ASSERT_TRUE(server) << error;
  o.port = dir / "pb";
  o.rs485 = true;
  EXPECT_FALSE(SerialPort::open(o, &error));
  EXPECT_NE(error.find("TIOCSRS485"), std::string::npos) << error;
}

TEST(SerialPortPty, EchoSuppression) {
  // The peer plays an adapter that echoes: it sends back every byte we write, then its answer.
  TempDir dir;
  const std::string link = dir / "pb";
  SerialOptions o;
  o.port = "pty:" + link;
  o.echo = true;
  std::string error;
  auto port = SerialPort::open(o, &error);
  ASSERT_TRUE(port) << error;
  const int peer = open_peer(link);
  ASSERT_GE(peer, 0);
  const std::uint8_t req[] = {0x10, 0x03, 0x02, 0x49, 0x4E, 0x16};  // docs/profibus.md
  ASSERT_TRUE(port->write(req, sizeof req, Time(0), &error)) << error;
  auto echoed = read_peer(peer, sizeof req);
  ASSERT_EQ(echoed.size(), sizeof req);
  const std::uint8_t answer[] = {0x10, 0x02, 0x03, 0x00, 0x05, 0x16};
  echoed.insert(echoed.end(), answer, answer + sizeof answer);
  ASSERT_EQ(::write(peer, echoed.data(), echoed.size()), static_cast<ssize_t>(echoed.size()));
  std::vector<RxByte> got;
  while (got.size() < sizeof answer && wait_readable(port->fd())) port->read(got, Time(10), &error);
  EXPECT_EQ(got, plain({0x10, 0x02, 0x03, 0x00, 0x05, 0x16}));
  EXPECT_EQ(port->echo_filter().dropped(), sizeof req);
  ::close(peer);
}

}  // namespace
}  // namespace candp2::serial
