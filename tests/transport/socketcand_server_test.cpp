// The socketcand server over real sockets on 127.0.0.1, checked byte for byte with a plain TCP
// client, and the socketcand client channel against a scripted server.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <thread>

#include "transport_test_support.hpp"

namespace candp2::test {
namespace {

using can::BusState;
using can::Frame;

// Sends `command` and returns as many reply bytes as `expected` has.
std::string ask(RawClient& c, const std::string& command, std::string_view expected) {
  c.send(command);
  return c.take(expected.size());
}

class SocketcandServerTest : public ::testing::Test {
 protected:
  // Connects a raw client and completes hi / open / rawmode, checking every byte.
  std::unique_ptr<RawClient> raw_mode_client(ServerRig& r) {
    auto c = std::make_unique<RawClient>(r.loop, r.server->port());
    EXPECT_EQ(c->take_like("< hi >"), "< hi >");
    c->send("< open vcan0 >");
    EXPECT_EQ(c->take_like("< ok >"), "< ok >");
    c->send("< rawmode >");
    EXPECT_EQ(c->take_like("< ok >"), "< ok >");
    return c;
  }
  std::optional<Frame> peer_receives(ServerRig& r) { return receive_within(r.loop, *r.peer); }

  ServerRig rig;
};

TEST_F(SocketcandServerTest, HandshakeAndFrameBytesExactly) {
  // doc/protocol.md / python-can: "< hi >", "< open vcan0 >" → "< ok >", "< rawmode >" → "< ok >".
  auto c = raw_mode_client(rig);
  EXPECT_EQ(rig.server->client_count(), 1u);
  struct Case {
    const char* frame;
    const char* line;
  } cases[] = {
      {"123#1122", "< frame 123 1700000000.000000 1122 >"},
      {"1ABCDEF0#01", "< frame 1ABCDEF0 1700000000.000000 01 >"},
      {"00000005#", "< frame 00000005 1700000000.000000  >"},
      {"7FF#0102030405060708", "< frame 7FF 1700000000.000000 0102030405060708 >"},
  };
  for (const auto& k : cases) {
    SCOPED_TRACE(k.frame);
    rig.peer->send(F(k.frame));
    EXPECT_EQ(c->take_like(k.line), k.line);
  }
  rig.wall = std::chrono::seconds(1700000000) + std::chrono::microseconds(42);
  rig.peer->send(F("001#0A"));
  EXPECT_EQ(c->take_like("< frame 001 1700000000.000042 0A >"),
            "< frame 001 1700000000.000042 0A >");
  // Nothing else was sent in between: an echo answers next.
  EXPECT_EQ(ask(*c, "< echo >", "< echo >"), "< echo >");
  EXPECT_EQ(rig.server->stats().frames_to_clients, 5u);
}

TEST_F(SocketcandServerTest, SendCommandsReachTheBus) {
  auto c = raw_mode_client(rig);
  struct Case {
    const char* command;
    const char* frame;
  } cases[] = {
      {"< send 123 0 >", "123#"},                     // doc/protocol.md
      {"< send 1AAAAAAA 2 1 f1 >", "1AAAAAAA#01F1"},  // doc/protocol.md
      {"< send 123 2 11 22 >", "123#1122"},           // brief / socketcandcl
      {"< send 12345 3 a b c >", "00012345#0A0B0C"},  // python-can writes ids unpadded
      {"< send 7FF 8 0 1 2 3 4 5 6 7 >", "7FF#0001020304050607"},
  };
  for (const auto& k : cases) {
    SCOPED_TRACE(k.command);
    c->send(k.command);
    const auto f = peer_receives(rig);
    ASSERT_TRUE(f);
    EXPECT_EQ(can::format_candump(*f), k.frame);
  }
  EXPECT_EQ(rig.server->stats().frames_from_clients, 5u);
  EXPECT_EQ(c->buffer(), "");  // sends are not answered
}

TEST_F(SocketcandServerTest, SeveralCommandsInOneSegmentAndSplitAcrossSegments) {
  auto c = raw_mode_client(rig);
  c->send("< send 101 1 01 >< send 102 1 02 >\n< send 10");
  auto f = peer_receives(rig);
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "101#01");
  f = peer_receives(rig);
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "102#02");
  c->send("3 1 03 >");
  f = peer_receives(rig);
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "103#03");
}

TEST_F(SocketcandServerTest, BcmModeSendsButForwardsNoFrames) {
  RawClient c(rig.loop, rig.server->port());
  EXPECT_EQ(c.take_like("< hi >"), "< hi >");
  EXPECT_EQ(ask(c, "< open vcan0 >", "< ok >"), "< ok >");
  c.send("< send 222 1 22 >");
  const auto f = peer_receives(rig);
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "222#22");
  rig.peer->send(F("333#33"));  // BCM mode without subscriptions: not forwarded
  rig.loop.run_once(Duration(0));
  EXPECT_EQ(ask(c, "< echo >", "< echo >"), "< echo >");
  EXPECT_EQ(ask(c, "< subscribe 0 0 123 >",
                "< error bcm commands are not supported by this server, use rawmode >"),
            "< error bcm commands are not supported by this server, use rawmode >");
  EXPECT_EQ(ask(c, "< rawmode >", "< ok >"), "< ok >");
  rig.peer->send(F("333#34"));
  EXPECT_EQ(c.take_like("< frame 333 1700000000.000000 34 >"),
            "< frame 333 1700000000.000000 34 >");
  EXPECT_EQ(ask(c, "< bcmmode >", "< ok >"), "< ok >");
}

TEST_F(SocketcandServerTest, CommandsBeforeOpenAreUnknown) {
  // state_nobus.c answers everything but open (and interface configuration) this way.
  RawClient c(rig.loop, rig.server->port());
  EXPECT_EQ(c.take_like("< hi >"), "< hi >");
  for (const char* cmd : {"< rawmode >", "< send 123 0 >", "< echo >", "< hello >"}) {
    SCOPED_TRACE(cmd);
    EXPECT_EQ(ask(c, cmd, "< error unknown command >"), "< error unknown command >");
  }
  EXPECT_EQ(ask(c, "< vcan0 B 500000 0 0 0 0 0 0 0 >",
                "< error interface configuration not supported by this server >"),
            "< error interface configuration not supported by this server >");
  EXPECT_EQ(ask(c, "< open vcan0 >", "< ok >"), "< ok >");
  EXPECT_EQ(rig.server->stats().frames_from_clients, 0u);
}

TEST_F(SocketcandServerTest, BadCommandsAreAnsweredAndTheServerKeepsServing) {
  auto c = raw_mode_client(rig);
  struct Case {
    const char* command;
    const char* reply;
  } cases[] = {
      {"< foo >", "< error unknown command >"},
      {"< >", "< error unknown command >"},
      {"< open vcan0 >", "< error unknown command >"},         // already open
      {"< subscribe 0 0 123 >", "< error unknown command >"},  // BCM command in raw mode
      {"< isotpmode >", "< error mode not supported by this server >"},
      {"< send 123 9 1 2 3 4 5 6 7 8 9 >", "< error DLC 9 above 8 >"},
      {"< send 123 2 11 >", "< error DLC 2 but 1 data bytes >"},
      {"< send xyz 0 >", "< error bad identifier 'xyz' (1 to 8 hex digits) >"},
      {"< send 20000000 0 >", "< error identifier 20000000 above 1FFFFFFF >"},
      {"< send 123 1 100 >", "< error bad data byte '100' (1 or 2 hex digits) >"},
      {"< send \x01\x02 >", "< error malformed command >"},
  };
  for (const auto& k : cases) {
    SCOPED_TRACE(k.command);
    EXPECT_EQ(ask(*c, k.command, k.reply), k.reply);
  }
  EXPECT_EQ(rig.server->stats().frames_from_clients, 0u);
  EXPECT_TRUE(rig.log.contains("rejected '< foo >'"));
  // Still serving this client, in both directions.
  c->send("< send 123 1 01 >");
  const auto f = peer_receives(rig);
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "123#01");
  rig.peer->send(F("456#02"));
  EXPECT_EQ(c->take_like("< frame 456 1700000000.000000 02 >"),
            "< frame 456 1700000000.000000 02 >");
  EXPECT_EQ(rig.server->stats().clients_dropped, 0u);
}

TEST_F(SocketcandServerTest, WrongBusIsRefusedAndTheConnectionClosed) {
  // state_nobus.c: "< error could not open bus >", then the connection ends.
  RawClient c(rig.loop, rig.server->port());
  EXPECT_EQ(c.take_like("< hi >"), "< hi >");
  EXPECT_EQ(ask(c, "< open can9 >", "< error could not open bus >"),
            "< error could not open bus >");
  EXPECT_TRUE(c.wait_closed());
  EXPECT_EQ(c.buffer(), "");
  EXPECT_TRUE(rig.log.contains("asked for bus 'can9'"));
  EXPECT_EQ(rig.server->client_count(), 0u);
}

TEST_F(SocketcandServerTest, AFewStrayBytesAreIgnoredWithALogLine) {
  auto c = raw_mode_client(rig);
  EXPECT_EQ(ask(*c, "hello\r\n< echo >", "< echo >"), "< echo >");
  EXPECT_TRUE(rig.log.contains("ignored 5 bytes outside < >: 'hello'"));
  EXPECT_EQ(rig.server->client_count(), 1u);
}

TEST_F(SocketcandServerTest, OversizedGarbageDropsThatClientOnly) {
  auto bad = raw_mode_client(rig);
  auto good = raw_mode_client(rig);
  ASSERT_EQ(rig.server->client_count(), 2u);
  bad->send(std::string(4096, 'A'));
  EXPECT_TRUE(bad->wait_closed());
  EXPECT_EQ(rig.server->client_count(), 1u);
  EXPECT_EQ(rig.server->stats().clients_dropped, 1u);
  EXPECT_TRUE(rig.log.contains("bytes outside < > (limit 256; not a socketcand client?)"));
  // The other client is unaffected.
  rig.peer->send(F("123#11"));
  EXPECT_EQ(good->take_like("< frame 123 1700000000.000000 11 >"),
            "< frame 123 1700000000.000000 11 >");
  good->send("< send 124 0 >");
  const auto f = peer_receives(rig);
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "124#");
}

TEST_F(SocketcandServerTest, OverlongCommandDropsTheClient) {
  auto bad = raw_mode_client(rig);
  bad->send("< send " + std::string(1000, '1'));
  EXPECT_TRUE(bad->wait_closed());
  EXPECT_TRUE(rig.log.contains("command longer than 256 bytes"));
  EXPECT_EQ(rig.server->stats().clients_dropped, 1u);
  // The server still accepts and serves new clients.
  auto again = raw_mode_client(rig);
  EXPECT_EQ(ask(*again, "< echo >", "< echo >"), "< echo >");
}

TEST_F(SocketcandServerTest, TwoClientsSeeTheBusAndEachOther) {
  auto a = raw_mode_client(rig);
  auto b = raw_mode_client(rig);
  rig.peer->send(F("100#01"));
  EXPECT_EQ(a->take_like("< frame 100 1700000000.000000 01 >"),
            "< frame 100 1700000000.000000 01 >");
  EXPECT_EQ(b->take_like("< frame 100 1700000000.000000 01 >"),
            "< frame 100 1700000000.000000 01 >");
  // a's frame reaches the bus and b (each socketcand client has its own raw socket), not a.
  a->send("< send 321 1 aa >");
  EXPECT_EQ(b->take_like("< frame 321 1700000000.000000 AA >"),
            "< frame 321 1700000000.000000 AA >");
  const auto f = peer_receives(rig);
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "321#AA");
  rig.peer->send(F("101#02"));
  EXPECT_EQ(a->take_like("< frame 101 1700000000.000000 02 >"),
            "< frame 101 1700000000.000000 02 >");  // the next thing a sees
  EXPECT_EQ(b->take_like("< frame 101 1700000000.000000 02 >"),
            "< frame 101 1700000000.000000 02 >");
}

TEST_F(SocketcandServerTest, FramesTheBusDropsReachNoOtherClient) {
  auto a = raw_mode_client(rig);
  auto b = raw_mode_client(rig);
  rig.bus.set_bus_state(BusState::BusOff);  // fault injection: nothing gets onto the bus
  a->send("< send 321 1 aa >");
  EXPECT_EQ(ask(*a, "< echo >", "< echo >"), "< echo >");  // the send has been handled
  EXPECT_TRUE(rig.log.contains("frame 321#AA not sent, the bus dropped it (bus state bus-off)"));
  EXPECT_EQ(rig.server->stats().frames_from_clients, 0u);
  rig.bus.set_bus_state(BusState::Ok);
  a->send("< send 322 1 bb >");
  EXPECT_EQ(b->take_like("< frame 322 1700000000.000000 BB >"),
            "< frame 322 1700000000.000000 BB >");  // the first frame b sees
  const auto f = peer_receives(rig);
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "322#BB");
}

TEST_F(SocketcandServerTest, RemoteFramesAreNotForwarded) {
  auto c = raw_mode_client(rig);
  rig.peer->send(F("123#R4"));
  rig.peer->send(F("124#01"));
  EXPECT_EQ(c->take_like("< frame 124 1700000000.000000 01 >"),
            "< frame 124 1700000000.000000 01 >");
  EXPECT_EQ(rig.server->stats().remote_frames_skipped, 1u);
  EXPECT_TRUE(rig.log.contains("the socketcand protocol has no remote frames"));
}

TEST(SocketcandServerLimits, SlowClientIsDroppedWithoutBlockingTheLoop) {
  auto options = ServerRig::default_options();
  options.max_output_bytes = 64 * 1024;
  ServerRig rig(options);
  // A client that completes the handshake and then never reads (small receive buffer).
  auto slow = std::make_unique<RawClient>(rig.loop, rig.server->port(), /*reading=*/true, 4096);
  ASSERT_EQ(slow->take_like("< hi >"), "< hi >");
  slow->send("< open vcan0 >");
  ASSERT_EQ(slow->take_like("< ok >"), "< ok >");
  slow->send("< rawmode >");
  ASSERT_EQ(slow->take_like("< ok >"), "< ok >");
  rig.loop.remove_fd(slow->fd());  // from now on nobody reads it
  const auto t0 = EventLoop::monotonic_now();
  int published = 0;
  while (rig.server->client_count() == 1 && published < 2000000) {
    rig.server->publish(F("123#1122334455667788"), rig.wall);
    ++published;
  }
  EXPECT_EQ(rig.server->client_count(), 0u) << "after " << published << " frames";
  EXPECT_LT(EventLoop::monotonic_now() - t0, std::chrono::seconds(20));
  EXPECT_EQ(rig.server->stats().clients_dropped, 1u);
  EXPECT_TRUE(rig.log.contains("dropped: not reading:"));
  // The server keeps serving.
  RawClient next(rig.loop, rig.server->port());
  EXPECT_EQ(next.take_like("< hi >"), "< hi >");
  slow.reset();
}

TEST(SocketcandServerLimits, ANewClientEvictsTheIdlestOneAtTheLimit) {
  // Idle clients cannot lock others out; clients not in raw mode go first.
  auto options = ServerRig::default_options();
  options.max_clients = 2;
  ServerRig rig(options);
  RawClient raw(rig.loop, rig.server->port());
  EXPECT_EQ(raw.take_like("< hi >"), "< hi >");
  raw.send("< open vcan0 >< rawmode >");
  EXPECT_EQ(raw.take_like("< ok >< ok >"), "< ok >< ok >");
  RawClient idle(rig.loop, rig.server->port());
  EXPECT_EQ(idle.take_like("< hi >"), "< hi >");
  RawClient third(rig.loop, rig.server->port());
  EXPECT_EQ(third.take_like("< hi >"), "< hi >");
  EXPECT_TRUE(idle.wait_closed());  // never opened the bus: evicted before the raw-mode client
  EXPECT_FALSE(raw.closed());
  EXPECT_TRUE(rig.log.contains("evicted for"));
  EXPECT_EQ(rig.server->client_count(), 2u);
  EXPECT_EQ(rig.server->stats().clients_evicted, 1u);
}

TEST(SocketcandServerListen, BadAddressAndBusNameAreRefused) {
  can::VirtualBus bus;
  auto ep = bus.endpoint("x");
  std::string error;
  auto o = ServerRig::default_options();
  o.host = "localhost-not-numeric";
  EXPECT_FALSE(can::SocketcandServer::listen(o, *ep, nullptr, &error));
  EXPECT_NE(error.find("bad listen address"), std::string::npos) << error;
  o = ServerRig::default_options();
  o.channel = "has space";
  EXPECT_FALSE(can::SocketcandServer::listen(o, *ep, nullptr, &error));
  EXPECT_NE(error.find("bus name"), std::string::npos) << error;
  // A port in use.
  ServerRig rig;
  o = ServerRig::default_options();
  o.port = rig.server->port();
  EXPECT_FALSE(can::SocketcandServer::listen(o, *ep, nullptr, &error));
  EXPECT_NE(error.find("cannot listen on 127.0.0.1:"), std::string::npos) << error;
}

// --- the client channel -------------------------------------------------------------------------

TEST(SocketcandClient, ConnectFailuresAreExplained) {
  std::string error;
  // A port nobody listens on: bind one, read its number, close it.
  std::uint16_t port = 0;
  {
    ServerRig rig;
    port = rig.server->port();
  }
  EXPECT_FALSE(can::connect_socketcand("127.0.0.1", port, "vcan0", &error, 2000));
  EXPECT_NE(error.find("cannot connect to socketcand at 127.0.0.1:"), std::string::npos) << error;
  EXPECT_NE(error.find("refused"), std::string::npos) << error;

  EXPECT_FALSE(can::connect_socketcand("127.0.0.1", 1, "bad bus name", &error));
  EXPECT_NE(error.find("bus name 'bad bus name'"), std::string::npos) << error;

  ServerRig rig;
  EXPECT_FALSE(connect_served(rig.loop, rig.server->port(), "can7", &error));
  EXPECT_NE(error.find("refused bus can7: could not open bus"), std::string::npos) << error;
}

TEST(SocketcandClient, HandshakeTimesOutAgainstASilentServer) {
  // A listening socket that never greets: the kernel completes the TCP connect, nobody answers.
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  ASSERT_EQ(::listen(fd, 4), 0);
  socklen_t len = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  std::string error;
  const auto t0 = EventLoop::monotonic_now();
  EXPECT_FALSE(can::connect_socketcand("127.0.0.1", ntohs(addr.sin_port), "vcan0", &error, 200));
  EXPECT_LT(EventLoop::monotonic_now() - t0, std::chrono::seconds(5));
  EXPECT_NE(error.find("timed out"), std::string::npos) << error;
  ::close(fd);
}

// A scripted socketcand server on a helper thread (blocking sockets with receive timeouts), for
// what our own server never sends: coalesced replies, BCM-style data, error frames, odd lines.
class ScriptedServer {
 public:
  ScriptedServer() {
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    ::listen(listen_fd_, 1);
    socklen_t len = sizeof addr;
    ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
  }
  ~ScriptedServer() {
    if (conn_ >= 0) ::close(conn_);
    ::close(listen_fd_);
  }
  std::uint16_t port() const { return port_; }
  bool accept() {
    conn_ = ::accept(listen_fd_, nullptr, nullptr);
    timeval tv{5, 0};
    ::setsockopt(conn_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    return conn_ >= 0;
  }
  void write(std::string_view s) {
    [[maybe_unused]] auto n = ::send(conn_, s.data(), s.size(), MSG_NOSIGNAL);
  }
  std::string read_exactly(std::size_t n) {
    std::string out;
    char buf[256];
    while (out.size() < n) {
      const ssize_t r = ::recv(conn_, buf, std::min(sizeof buf, n - out.size()), 0);
      if (r <= 0) break;  // timeout or closed
      out.append(buf, static_cast<std::size_t>(r));
    }
    return out;
  }
  void close_connection() {
    ::close(conn_);
    conn_ = -1;
  }

 private:
  int listen_fd_ = -1;
  int conn_ = -1;
  std::uint16_t port_ = 0;
};

TEST(SocketcandClient, ParsesWhatARealSocketcandSends) {
  ScriptedServer server;
  std::string seen_open, seen_rawmode;
  std::thread script([&] {
    if (!server.accept()) return;
    server.write("< hi >");
    seen_open = server.read_exactly(14);
    server.write("< ok >");
    seen_rawmode = server.read_exactly(11);
    // Replies and frames coalesced in one segment (python-can would choke on this; we must not).
    server.write("< ok >< frame 123 23.424242 1A220344 >< frame 12345678 1.000001  >");
  });
  std::string error;
  MemoryLog log;
  auto ch = can::connect_socketcand("127.0.0.1", server.port(), "vcan0", &error, 5000, &log);
  script.join();
  ASSERT_TRUE(ch) << error;
  EXPECT_EQ(seen_open, "< open vcan0 >");
  EXPECT_EQ(seen_rawmode, "< rawmode >");
  EventLoop loop;
  loop.add_fd(ch->poll_fd(), EventLoop::kReadable, [](std::uint32_t) {});
  auto f = receive_within(loop, *ch);
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "123#1A220344");
  f = receive_within(loop, *ch);
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "12345678#");

  std::string sent;
  script = std::thread([&] {
    server.write("< frame 124 1.5 11 22 >");                         // BCM style
    server.write("< frame 125 1.000000 XYZ >");                      // unusable: counted in rx_lost
    server.write("< error 004 1.000000 00 01 00 00 00 00 00 00 >");  // CRTL RX overflow (BCM)
    server.write("< error 040 1700000000.000000 >");                 // CAN_ERR_BUSOFF
    server.write("< frame 126 1.000000 01 >");
    sent = server.read_exactly(std::strlen("< send 321 2 de ad >"));
  });
  f = receive_within(loop, *ch);
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "124#1122");
  f = receive_within(loop, *ch);
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "126#01");
  EXPECT_EQ(ch->rx_lost(), 2u);  // the unusable frame and the controller's RX overflow
  EXPECT_EQ(ch->bus_state(), BusState::BusOff);
  EXPECT_TRUE(log.contains("bus state ok -> bus-off"));
  ch->send(F("321#DEAD"));
  script.join();
  EXPECT_EQ(sent, "< send 321 2 de ad >");

  script = std::thread([&] {
    server.write("< error 100 1700000000.000000 >");  // CAN_ERR_RESTARTED
    server.write("< error unknown command >");
    server.write("< frame 127 1.000000 02 >");
  });
  f = receive_within(loop, *ch);
  script.join();
  ASSERT_TRUE(f);
  EXPECT_EQ(can::format_candump(*f), "127#02");
  EXPECT_EQ(ch->bus_state(), BusState::Ok);
  EXPECT_TRUE(log.contains("the server answered: '< error unknown command >'"));

  // The server goes away: the channel reports bus-off and counts what it cannot send.
  server.close_connection();
  loop.run_until([&] { return !ch->receive() && ch->bus_state() == BusState::BusOff; }, kWait);
  EXPECT_EQ(ch->bus_state(), BusState::BusOff);
  const auto dropped = ch->tx_dropped();
  ch->send(F("123#01"));
  EXPECT_EQ(ch->tx_dropped(), dropped + 1);
  EXPECT_TRUE(log.contains("the server closed the connection"));
}

TEST(SocketcandClient, RejectsAServerThatIsNotSocketcand) {
  ScriptedServer server;
  std::thread script([&] {
    if (server.accept()) server.write("< hello >");
  });
  std::string error;
  EXPECT_FALSE(can::connect_socketcand("127.0.0.1", server.port(), "vcan0", &error, 2000));
  script.join();
  EXPECT_NE(error.find("expected the greeting '< hi >', got '< hello >'"), std::string::npos)
      << error;
}

}  // namespace
}  // namespace candp2::test
