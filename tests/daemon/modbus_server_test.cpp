// The Modbus/TCP server on the event loop, driven from outside by libmodbus clients and raw
// sockets: answers, exceptions on the wire, partial and pipelined requests, garbage clients dropped
// while the others are served, many clients at once, the client limit.
#include "modbus/modbus_server.hpp"

#include <gtest/gtest.h>

#include <atomic>

#include "daemon_test_support.hpp"

namespace candp2::modbus {
namespace {

using namespace candp2::test;

struct FakeGateway : GatewayFace {
  explicit FakeGateway(std::uint8_t a) : address(a) {}
  std::uint8_t dp_address() const override { return address; }
  StatusBlock status(Time) override {
    StatusBlock b{};
    b[0] = 2;
    b[status::kDpAddress] = address;
    return b;
  }
  void control(Control, Time) override { ++commands; }
  std::uint8_t address;
  std::atomic<int> commands{0};
};

struct ServerFixture : ::testing::Test {
  ServerFixture() {
    std::string error;
    server = ModbusServer::listen({.host = "127.0.0.1", .port = 0, .max_clients = 4}, loop, map,
                                  &log, &error);
    if (!server) throw std::runtime_error(error);
    port = server->port();
    thread.start();
  }
  ~ServerFixture() override { thread.stop(); }

  MemoryLog log;
  EventLoop loop{nullptr};
  dp::ProcessImage image;
  FakeGateway gw5{5};
  ProcessImageMap map{image, {&gw5}};
  std::unique_ptr<ModbusServer> server;
  std::uint16_t port = 0;
  LoopThread thread{loop};
};

// A raw request ADU.
std::vector<std::uint8_t> adu(std::uint16_t tid, std::uint8_t unit, std::vector<std::uint8_t> pdu) {
  std::vector<std::uint8_t> a(7 + pdu.size());
  a[0] = static_cast<std::uint8_t>(tid >> 8);
  a[1] = static_cast<std::uint8_t>(tid & 0xFF);
  a[5] = static_cast<std::uint8_t>(pdu.size() + 1);
  a[6] = unit;
  std::copy(pdu.begin(), pdu.end(), a.begin() + 7);
  return a;
}

void send_all(int fd, const std::vector<std::uint8_t>& b) {
  ASSERT_EQ(::send(fd, b.data(), b.size(), MSG_NOSIGNAL), static_cast<ssize_t>(b.size()));
}

TEST_F(ServerFixture, WritesAndReadsThroughLibmodbus) {
  ModbusClient c(port, 5);
  EXPECT_EQ(c.write(86, {0x0A0B, 0x0C0D, 0x0E0F}), 0);
  auto r = c.read_holding(86, 3);
  ASSERT_TRUE(std::holds_alternative<std::vector<std::uint16_t>>(r));
  EXPECT_EQ(std::get<0>(r), (std::vector<std::uint16_t>{0x0A0B, 0x0C0D, 0x0E0F}));
  auto s = c.read_input(8192 + status::kDpAddress, 1);
  ASSERT_TRUE(std::holds_alternative<std::vector<std::uint16_t>>(s));
  EXPECT_EQ(std::get<0>(s)[0], 5);
  std::uint8_t bits[16];
  ASSERT_EQ(modbus_read_bits(c.ctx(), 1376, 16, bits), 16);
  // Byte 172 = 0x0A = 0000 1010: bits 1 and 3 (docs/modbus.md: bit b = byte b/8, bit b%8).
  EXPECT_EQ(std::vector<std::uint8_t>(bits, bits + 8),
            (std::vector<std::uint8_t>{0, 1, 0, 1, 0, 0, 0, 0}));
  ASSERT_EQ(modbus_write_bit(c.ctx(), 1376, 1), 1);
  std::uint16_t v = 0;
  ASSERT_EQ(modbus_read_registers(c.ctx(), 86, 1, &v), 1);
  EXPECT_EQ(v, 0x0B0B);
  std::uint16_t rw_in[2] = {0x1111, 0x2222}, rw_out[3] = {};
  ASSERT_EQ(modbus_write_and_read_registers(c.ctx(), 10, 2, rw_in, 9, 3, rw_out), 3);
  EXPECT_EQ(rw_out[1], 0x1111);
  ASSERT_EQ(modbus_mask_write_register(c.ctx(), 10, 0x00FF, 0x3300), 1);
  ASSERT_EQ(modbus_read_registers(c.ctx(), 10, 1, &v), 1);
  EXPECT_EQ(v, 0x3311);
}

TEST_F(ServerFixture, ExceptionsOnTheWireAndTheServerServesOn) {
  ModbusClient c(port, 5);
  // docs/modbus.md: outside the tables → 0x02; unknown unit → 0x0B.
  EXPECT_EQ(std::get<int>(c.read_holding(4096, 1)), EMBXILADD);
  EXPECT_EQ(std::get<int>(c.read_input(kDiagnosisBase + kDiagnosisRegisters, 1)), EMBXILADD);
  EXPECT_EQ(c.write_one(8192, 9), EMBXILVAL);
  c.unit(9);
  EXPECT_EQ(std::get<int>(c.read_holding(0, 1)), EMBXGTAR);
  c.unit(255);
  EXPECT_TRUE(std::holds_alternative<std::vector<std::uint16_t>>(c.read_holding(0, 1)));
  EXPECT_EQ(c.write_one(8192, 2), 0);
  EXPECT_EQ(gw5.commands.load(), 1);
}

// docs/daemon.md "Logging": a write the daemon refuses says why, once, then throttled per
// exception (one a second with the count); a refused read is not a warning.
TEST_F(ServerFixture, ARefusedWriteIsLoggedOnceWithItsReason) {
  ModbusClient c(port, 5);
  EXPECT_EQ(std::get<int>(c.read_holding(4096, 1)), EMBXILADD);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(c.write_one(8192, 9), EMBXILVAL);
  EXPECT_EQ(c.write_one(4096, 1), EMBXILADD);
  thread.stop();
  auto warnings = [&](std::string_view needle) {
    int n = 0;
    for (const auto& l : log.lines)
      n += l.level == LogLevel::Warn && l.message.find(needle) != std::string::npos;
    return n;
  };
  EXPECT_EQ(warnings(": unit 5: write (function 6) refused with exception 0x03 (illegal data "
                     "value): "),
            1)
      << "the first refused write at once, the next two counted, not written";
  EXPECT_EQ(warnings("write (function 6) refused with exception 0x02"), 1)
      << "another exception is another kind: not hidden behind the first";
  EXPECT_EQ(warnings("function 3"), 0) << "a refused read is no warning";
}

TEST_F(ServerFixture, QuantityZeroAndMaxPlusOneOnTheWire) {
  // libmodbus clients refuse to send such requests, so they go out raw. MB spec §7: the answer is
  // function | 0x80 and exception code 0x03; the server must answer at once (libmodbus's own
  // exception path would sleep and flush the socket).
  const int fd = connect_tcp(port);
  for (const auto& [pdu, fc] : std::vector<std::pair<std::vector<std::uint8_t>, std::uint8_t>>{
           {{0x03, 0, 0, 0, 0}, 0x03},
           {{0x03, 0, 0, 0, 126}, 0x03},
           {{0x01, 0, 0, 0x07, 0xD1}, 0x01},
           {{0x10, 0, 0, 0, 0, 0}, 0x10},
           {{0x42, 0, 0, 0, 1}, 0x42}}) {
    send_all(fd, adu(0x0102, 5, pdu));
    const auto answer = read_bytes(fd, 9);
    ASSERT_EQ(answer.size(), 9u);
    EXPECT_EQ(answer[0], 0x01);  // transaction id echoed
    EXPECT_EQ(answer[1], 0x02);
    EXPECT_EQ(answer[5], 3);  // length: unit + 2
    EXPECT_EQ(answer[6], 5);  // unit
    EXPECT_EQ(answer[7], fc | 0x80);
    EXPECT_EQ(answer[8], fc == 0x42 ? 0x01 : 0x03);
  }
  ::close(fd);
}

TEST_F(ServerFixture, PartialAndPipelinedRequests) {
  const int fd = connect_tcp(port);
  const auto write = adu(1, 5, {0x06, 0x00, 0x05, 0xAB, 0xCD});
  // Half a request: the server waits for the rest and meanwhile serves other clients.
  send_all(fd, std::vector<std::uint8_t>(write.begin(), write.begin() + 5));
  {
    ModbusClient other(port, 5);
    EXPECT_TRUE(std::holds_alternative<std::vector<std::uint16_t>>(other.read_holding(0, 1)));
  }
  std::vector<std::uint8_t> rest(write.begin() + 5, write.end());
  // The rest of the write and two more requests in one segment.
  const auto read1 = adu(2, 5, {0x03, 0x00, 0x05, 0x00, 0x01});
  const auto read2 = adu(3, 5, {0x04, 0x20, 0x00, 0x00, 0x01});
  rest.insert(rest.end(), read1.begin(), read1.end());
  rest.insert(rest.end(), read2.begin(), read2.end());
  send_all(fd, rest);
  const auto answers = read_bytes(fd, 12 + 11 + 11);
  ASSERT_EQ(answers.size(), 34u);
  EXPECT_EQ(std::vector<std::uint8_t>(answers.begin(), answers.begin() + 12), write);  // echo
  EXPECT_EQ(answers[12 + 1], 2);     // transaction 2
  EXPECT_EQ(answers[12 + 9], 0xAB);  // the value just written
  EXPECT_EQ(answers[12 + 10], 0xCD);
  EXPECT_EQ(answers[23 + 1], 3);
  EXPECT_EQ(answers[23 + 10], 2);  // dp_state of the fake status block
  ::close(fd);
}

TEST_F(ServerFixture, GarbageClientIsDroppedOthersAreServed) {
  ModbusClient good(port, 5);
  const int bad = connect_tcp(port);
  const std::string http = "GET / HTTP/1.0\r\n\r\n";
  ASSERT_EQ(::send(bad, http.data(), http.size(), MSG_NOSIGNAL), static_cast<ssize_t>(http.size()));
  EXPECT_TRUE(closed_by_peer(bad));
  ::close(bad);
  EXPECT_EQ(good.write(0, {1, 2, 3}), 0);
  thread.stop();
  EXPECT_EQ(server->stats().clients_dropped, 1u);
  EXPECT_TRUE(log.contains("not Modbus/TCP")) << "the drop is logged with its reason";
}

TEST_F(ServerFixture, ManyClientsAtOnce) {
  constexpr int kClients = 4, kRequests = 300;
  std::vector<std::thread> clients;
  std::atomic<int> ok{0};
  for (int i = 0; i < kClients; ++i)
    clients.emplace_back([&, i] {
      ModbusClient c(port, 5);
      for (int n = 0; n < kRequests; ++n) {
        const auto value = static_cast<std::uint16_t>(i * 1000 + n);
        if (c.write(100 + 2 * i, {value, value}) != 0) return;
        auto r = c.read_holding(101 + 2 * i, 1);
        if (!std::holds_alternative<std::vector<std::uint16_t>>(r) || std::get<0>(r)[0] != value)
          return;
        ++ok;
      }
    });
  for (auto& t : clients) t.join();
  EXPECT_EQ(ok.load(), kClients * kRequests);
}

TEST_F(ServerFixture, ClientLimitEvictsTheClientIdleLongest) {
  // At max_clients a new connection evicts the client idle longest.
  std::vector<std::unique_ptr<ModbusClient>> clients;
  for (int i = 0; i < 4; ++i) clients.push_back(std::make_unique<ModbusClient>(port, 5));
  for (auto& c : clients)  // client 0 had its last request first: it is idle longest
    ASSERT_TRUE(std::holds_alternative<std::vector<std::uint16_t>>(c->read_holding(0, 1)));
  ModbusClient fifth(port, 5);
  EXPECT_TRUE(std::holds_alternative<std::vector<std::uint16_t>>(fifth.read_holding(0, 1)));
  EXPECT_TRUE(closed_by_peer(modbus_get_socket(clients[0]->ctx())));
  EXPECT_TRUE(std::holds_alternative<std::vector<std::uint16_t>>(clients[1]->read_holding(0, 1)));
}

TEST(ModbusServerListen, PortInUseIsAClearError) {
  EventLoop loop;
  dp::ProcessImage image;
  ProcessImageMap map{image, {}};
  std::string error;
  auto first = ModbusServer::listen({.host = "127.0.0.1", .port = 0}, loop, map, nullptr, &error);
  ASSERT_TRUE(first) << error;
  auto second = ModbusServer::listen({.host = "127.0.0.1", .port = first->port()}, loop, map,
                                     nullptr, &error);
  EXPECT_FALSE(second);
  EXPECT_NE(error.find("cannot listen on 127.0.0.1:" + std::to_string(first->port())),
            std::string::npos)
      << error;
}

}  // namespace
}  // namespace candp2::modbus
