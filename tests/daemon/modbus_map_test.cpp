// The Modbus/TCP map of docs/modbus.md without sockets: MBAP framing, request decoding with the
// MB spec's exceptions (boundary values 0 and max+1 for every function code), and the process
// image / status block / control register rules.
#include "modbus/modbus_map.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <vector>

namespace candp2::modbus {
namespace {

// An ADU: MBAP (transaction 0x1234, protocol 0, length) + unit + PDU.
std::vector<std::uint8_t> adu(std::uint8_t unit, std::vector<std::uint8_t> pdu) {
  std::vector<std::uint8_t> a = {0x12, 0x34, 0x00, 0x00};
  const std::size_t len = pdu.size() + 1;
  a.push_back(static_cast<std::uint8_t>(len >> 8));
  a.push_back(static_cast<std::uint8_t>(len & 0xFF));
  a.push_back(unit);
  a.insert(a.end(), pdu.begin(), pdu.end());
  return a;
}

std::uint8_t hi(unsigned v) {
  return static_cast<std::uint8_t>(v >> 8);
}
std::uint8_t lo(unsigned v) {
  return static_cast<std::uint8_t>(v & 0xFF);
}

// fc + address + count
std::vector<std::uint8_t> pdu(std::uint8_t fc, unsigned address, unsigned count) {
  return {fc, hi(address), lo(address), hi(count), lo(count)};
}

std::vector<std::uint8_t> write_regs(unsigned address, std::vector<std::uint16_t> values) {
  std::vector<std::uint8_t> p = {0x10,
                                 hi(address),
                                 lo(address),
                                 hi(values.size()),
                                 lo(values.size()),
                                 static_cast<std::uint8_t>(2 * values.size())};
  for (auto v : values) {
    p.push_back(hi(v));
    p.push_back(lo(v));
  }
  return p;
}

std::optional<Exception> decode_error(const std::vector<std::uint8_t>& a) {
  auto r = decode_request(a);
  if (auto* f = std::get_if<DecodeFailure>(&r)) return f->exception;
  return std::nullopt;
}

// ------------------------------------------------------------------------------- framing

TEST(MbapFramer, SplitsPipelinedAndPartialFrames) {
  MbapFramer f;
  auto a = adu(5, pdu(0x03, 0, 1));
  auto b = adu(6, pdu(0x04, 1, 2));
  std::vector<std::uint8_t> stream = a;
  stream.insert(stream.end(), b.begin(), b.end());
  // The first frame and half the second arrive together, the rest later.
  f.append(std::span(stream).first(a.size() + 4));
  auto n = f.next();
  ASSERT_EQ(n.status, MbapFramer::Status::Frame);
  EXPECT_EQ(std::vector<std::uint8_t>(n.adu.begin(), n.adu.end()), a);
  EXPECT_EQ(f.next().status, MbapFramer::Status::NeedMore);
  f.append(std::span(stream).subspan(a.size() + 4));
  n = f.next();
  ASSERT_EQ(n.status, MbapFramer::Status::Frame);
  EXPECT_EQ(std::vector<std::uint8_t>(n.adu.begin(), n.adu.end()), b);
  EXPECT_EQ(f.next().status, MbapFramer::Status::NeedMore);
  EXPECT_EQ(f.buffered(), 0u);
}

TEST(MbapFramer, OneByteAtATime) {
  MbapFramer f;
  const auto a = adu(5, write_regs(86, {0x0A0B, 0x0C0D, 0x0E0F}));
  for (std::size_t i = 0; i + 1 < a.size(); ++i) {
    f.append(std::span(a).subspan(i, 1));
    ASSERT_EQ(f.next().status, MbapFramer::Status::NeedMore) << i;
  }
  f.append(std::span(a).last(1));
  EXPECT_EQ(f.next().adu.size(), a.size());
}

TEST(MbapFramer, GarbageIsNotResynchronized) {
  // TCP guide §3.1.3: protocol identifier 0; length = unit id + PDU (2..254).
  for (const auto& bytes : std::vector<std::vector<std::uint8_t>>{
           {0x00, 0x01, 0x00, 0x01, 0x00, 0x06, 0x05},  // protocol 1
           {0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x05},  // length 1: no function code
           {0x00, 0x01, 0x00, 0x00, 0x00, 0xFF, 0x05},  // length 255 > 254
           {'G', 'E', 'T', ' ', '/', ' ', 'H'}}) {      // HTTP
    MbapFramer f;
    f.append(bytes);
    EXPECT_EQ(f.next().status, MbapFramer::Status::Garbage);
  }
  MbapFramer f;
  f.append(std::vector<std::uint8_t>{0x00, 0x01, 0x00, 0x00, 0x00, 0xFE, 0x05});  // 254: fine
  EXPECT_EQ(f.next().status, MbapFramer::Status::NeedMore);
}

// ------------------------------------------------------------------------------- decoding

TEST(DecodeRequest, ReadsAndTheirQuantityLimits) {
  // MB spec §6.1-6.4: 1..2000 bits, 1..125 registers; 0 and max+1 are exception 0x03.
  for (std::uint8_t fc : {0x01, 0x02}) {
    EXPECT_EQ(decode_error(adu(1, pdu(fc, 0, 0))), Exception::IllegalDataValue);
    EXPECT_EQ(decode_error(adu(1, pdu(fc, 0, 2000))), std::nullopt);
    EXPECT_EQ(decode_error(adu(1, pdu(fc, 0, 2001))), Exception::IllegalDataValue);
  }
  for (std::uint8_t fc : {0x03, 0x04}) {
    EXPECT_EQ(decode_error(adu(1, pdu(fc, 0, 0))), Exception::IllegalDataValue);
    EXPECT_EQ(decode_error(adu(1, pdu(fc, 0, 125))), std::nullopt);
    EXPECT_EQ(decode_error(adu(1, pdu(fc, 0, 126))), Exception::IllegalDataValue);
  }
  auto r = std::get<Request>(decode_request(adu(9, pdu(0x04, 8192, 12))));
  EXPECT_EQ(r.unit, 9);
  EXPECT_EQ(r.transaction, 0x1234);
  EXPECT_EQ(r.table, Table::InputRegisters);
  EXPECT_EQ(r.address, 8192);
  EXPECT_EQ(r.count, 12);
  EXPECT_FALSE(r.writes());
}

TEST(DecodeRequest, WrongPduLengthIsIllegalDataValue) {
  auto p = pdu(0x03, 0, 1);
  p.push_back(0);
  EXPECT_EQ(decode_error(adu(1, p)), Exception::IllegalDataValue);
  EXPECT_EQ(decode_error(adu(1, {0x03, 0x00})), Exception::IllegalDataValue);
  EXPECT_EQ(decode_error(adu(1, {0x10, 0x00, 0x00, 0x00})), Exception::IllegalDataValue);
}

TEST(DecodeRequest, SingleWrites) {
  EXPECT_EQ(decode_error(adu(1, {0x05, 0, 1, 0xFF, 0x00})), std::nullopt);
  EXPECT_EQ(decode_error(adu(1, {0x05, 0, 1, 0x00, 0x00})), std::nullopt);
  // MB spec §6.5: only FF00 and 0000 are coil values.
  EXPECT_EQ(decode_error(adu(1, {0x05, 0, 1, 0x00, 0x01})), Exception::IllegalDataValue);
  const auto a = adu(1, {0x06, 0x00, 0x56, 0xAB, 0xCD});  // the request refers into its ADU
  auto r = std::get<Request>(decode_request(a));
  EXPECT_TRUE(r.writes());
  EXPECT_EQ(r.write_address, 86);
  EXPECT_EQ(r.register_value(0), 0xABCD);
}

TEST(DecodeRequest, MultipleWritesQuantityAndByteCount) {
  // MB spec §6.11: 1..1968 coils, byte count = ceil(n/8).
  auto coils = [](unsigned n, unsigned bytes) {
    std::vector<std::uint8_t> p = {0x0F, 0, 0, hi(n), lo(n), static_cast<std::uint8_t>(bytes)};
    p.resize(6 + bytes, 0x55);
    return adu(1, p);
  };
  EXPECT_EQ(decode_error(coils(0, 0)), Exception::IllegalDataValue);
  EXPECT_EQ(decode_error(coils(10, 2)), std::nullopt);
  EXPECT_EQ(decode_error(coils(10, 1)), Exception::IllegalDataValue);  // byte count too small
  EXPECT_EQ(decode_error(coils(1968, 246)), std::nullopt);
  EXPECT_EQ(decode_error(coils(1969, 247)), Exception::IllegalDataValue);
  // MB spec §6.12: 1..123 registers, byte count = 2n.
  EXPECT_EQ(decode_error(adu(1, write_regs(0, std::vector<std::uint16_t>(123, 1)))), std::nullopt);
  EXPECT_EQ(decode_error(adu(1, write_regs(0, std::vector<std::uint16_t>(124, 1)))),
            Exception::IllegalDataValue);
  auto p = write_regs(0, {1, 2});
  p[5] = 3;  // byte count disagrees with the quantity
  EXPECT_EQ(decode_error(adu(1, p)), Exception::IllegalDataValue);
  p = write_regs(0, {1, 2});
  p.pop_back();  // one data byte missing
  EXPECT_EQ(decode_error(adu(1, p)), Exception::IllegalDataValue);
  p = {0x10, 0, 0, 0, 0, 0};  // quantity 0
  EXPECT_EQ(decode_error(adu(1, p)), Exception::IllegalDataValue);
}

TEST(DecodeRequest, ReadWriteMultipleRegistersLimits) {
  auto rw = [](unsigned rn, unsigned wn) {
    std::vector<std::uint8_t> p = {0x17, 0,  0,      hi(rn), lo(rn),
                                   0,    10, hi(wn), lo(wn), static_cast<std::uint8_t>(2 * wn)};
    p.resize(10 + 2 * wn, 0);
    return adu(1, p);
  };
  // MB spec §6.17: read 1..125, write 1..121.
  EXPECT_EQ(decode_error(rw(125, 121)), std::nullopt);
  EXPECT_EQ(decode_error(rw(0, 1)), Exception::IllegalDataValue);
  EXPECT_EQ(decode_error(rw(126, 1)), Exception::IllegalDataValue);
  EXPECT_EQ(decode_error(rw(1, 0)), Exception::IllegalDataValue);
  EXPECT_EQ(decode_error(rw(1, 122)), Exception::IllegalDataValue);
}

TEST(DecodeRequest, UnsupportedFunctionsAreIllegalFunction) {
  for (std::uint8_t fc : {0x00, 0x07, 0x08, 0x11, 0x2B, 0x7F, 0x83, 0xFF})
    EXPECT_EQ(decode_error(adu(1, {fc, 0, 0, 0, 1})), Exception::IllegalFunction) << int(fc);
}

// ------------------------------------------------------------------------------- the map

struct FakeGateway : GatewayFace {
  explicit FakeGateway(std::uint8_t a) : address(a) {
    for (std::size_t i = 0; i < block.size(); ++i)
      block[i] = static_cast<std::uint16_t>(a * 100 + i);
  }
  std::uint8_t dp_address() const override { return address; }
  StatusBlock status(Time) override { return block; }
  void control(Control c, Time) override { commands.push_back(c); }
  bool force_bus_state(std::uint16_t code, Time) override {
    forced = code;
    return true;
  }
  std::uint16_t forced_bus_state() const override { return forced; }
  bool has_can_controller() const override { return can; }
  void drop_received(std::uint16_t n, Time) override { drop = n; }
  std::uint16_t drop_remaining() const override { return drop; }
  std::optional<std::string> refuses(Control c) const override {
    if (refused && c == *refused) return "not possible here";
    return std::nullopt;
  }
  std::uint8_t address;
  StatusBlock block{};
  std::vector<Control> commands;
  std::uint16_t forced = 0, drop = 0;
  std::optional<Control> refused;
  bool can = true;
};

struct MapFixture : ::testing::Test {
  dp::ProcessImage image;
  FakeGateway gw5{5}, gw6{6};
  ProcessImageMap map{image, {&gw5, &gw6}};
  ReadResult out;

  std::optional<Exception> run(std::uint8_t unit, std::vector<std::uint8_t> p) {
    const auto a = adu(unit, std::move(p));
    auto r = decode_request(a);
    if (auto* f = std::get_if<DecodeFailure>(&r)) return f->exception;
    auto f = map.handle(std::get<Request>(r), out, Time{0});
    return f ? std::optional(f->exception) : std::nullopt;
  }
};

TEST_F(MapFixture, HoldingRegistersAreTheOutputImageBigEndian) {
  // Manual §5.1.4 output slot at Q 172..177 = holding registers 86..88 (docs/modbus.md).
  ASSERT_EQ(run(5, write_regs(86, {0x0A0B, 0x0C0D, 0x0E0F})), std::nullopt);
  EXPECT_EQ(image.outputs[172], 0x0A);
  EXPECT_EQ(image.outputs[173], 0x0B);
  EXPECT_EQ(image.outputs[177], 0x0F);
  ASSERT_EQ(run(5, pdu(0x03, 86, 3)), std::nullopt);
  EXPECT_EQ(out.registers[0], 0x0A0B);
  EXPECT_EQ(out.registers[2], 0x0E0F);
  // Outputs are not inputs.
  ASSERT_EQ(run(5, pdu(0x04, 86, 1)), std::nullopt);
  EXPECT_EQ(out.registers[0], 0);
}

TEST_F(MapFixture, InputRegistersAreTheInputImage) {
  image.inputs[8190] = 0x12;
  image.inputs[8191] = 0x34;
  ASSERT_EQ(run(5, pdu(0x04, 4095, 1)), std::nullopt);
  EXPECT_EQ(out.registers[0], 0x1234);
}

TEST_F(MapFixture, CoilsAndDiscreteInputsAreImageBits) {
  // Bit b = byte b/8, bit b%8 (docs/modbus.md).
  ASSERT_EQ(run(5, {0x05, hi(1377), lo(1377), 0xFF, 0x00}), std::nullopt);
  EXPECT_EQ(image.outputs[172], 0x02);
  ASSERT_EQ(run(5, {0x0F, hi(1380), lo(1380), 0, 10, 2, 0xFF, 0x01}), std::nullopt);
  EXPECT_EQ(image.outputs[172], 0xF2);  // bits 4..7
  EXPECT_EQ(image.outputs[173], 0x1F);  // coils 1384..1388 on, 1389 off
  ASSERT_EQ(run(5, pdu(0x01, 1376, 16)), std::nullopt);
  const std::vector<std::uint8_t> expected = {0, 1, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 0, 0, 0};
  EXPECT_EQ(std::vector<std::uint8_t>(out.bits.begin(), out.bits.begin() + 16), expected);
  image.inputs[8191] = 0x80;
  ASSERT_EQ(run(5, pdu(0x02, 65535, 1)), std::nullopt);
  EXPECT_EQ(out.bits[0], 1);
  EXPECT_EQ(run(5, pdu(0x02, 65535, 2)), Exception::IllegalDataAddress);
  ASSERT_EQ(run(5, {0x05, hi(1377), lo(1377), 0x00, 0x00}), std::nullopt);
  EXPECT_EQ(image.outputs[172], 0xF0);
}

TEST_F(MapFixture, AddressBoundaries) {
  // Registers 0..4095; 4096..8191 lie outside every table.
  EXPECT_EQ(run(5, pdu(0x03, 4095, 1)), std::nullopt);
  EXPECT_EQ(run(5, pdu(0x03, 4095, 2)), Exception::IllegalDataAddress);
  EXPECT_EQ(run(5, pdu(0x03, 4096, 1)), Exception::IllegalDataAddress);
  EXPECT_EQ(run(5, pdu(0x04, 8191, 1)), Exception::IllegalDataAddress);
  EXPECT_EQ(run(5, write_regs(4095, {1, 2})), Exception::IllegalDataAddress);
  EXPECT_EQ(image.outputs[8190], 0) << "a refused write must not write anything";
  EXPECT_EQ(run(5, {0x06, hi(4096), lo(4096), 0, 1}), Exception::IllegalDataAddress);
  // Status block 8192 .. 8192+count-1 in input registers only, the whole diagnosis right after
  // it (WholeDiagnosisAfterTheStatusBlock), then nothing.
  EXPECT_EQ(run(5, pdu(0x04, 8192 + status::kCount - 1, 1)), std::nullopt);
  EXPECT_EQ(run(5, pdu(0x04, 8192 + status::kCount - 1, 2)), Exception::IllegalDataAddress);
  EXPECT_EQ(run(5, pdu(0x04, 8192 + status::kCount + kDiagnosisRegisters, 1)),
            Exception::IllegalDataAddress);
  EXPECT_EQ(run(5, pdu(0x04, 8190, 4)), Exception::IllegalDataAddress);
  // Holding registers 8192..8194: control, forced CAN state, drop count (docs/faults.md).
  EXPECT_EQ(run(5, pdu(0x03, 8192, 3)), std::nullopt);
  EXPECT_EQ(run(5, pdu(0x03, 8192, 4)), Exception::IllegalDataAddress);
  EXPECT_EQ(run(5, pdu(0x03, 8195, 1)), Exception::IllegalDataAddress);
  EXPECT_EQ(run(5, pdu(0x04, 65535, 1)), Exception::IllegalDataAddress);
}

TEST_F(MapFixture, RoleSlavesOutputImageIsReadOnly) {
  // docs/profibus.md role slaves: the output image is what the external master sent; writes to
  // it get exception 0x04, reads, the status block and the control register still work.
  image.outputs[172] = 0x11;
  map.set_outputs_read_only(true);
  EXPECT_EQ(run(5, write_regs(86, {0x0A0B})), Exception::ServerDeviceFailure);
  EXPECT_EQ(run(5, pdu(0x06, 86, 0x0A0B)), Exception::ServerDeviceFailure);
  EXPECT_EQ(run(5, pdu(0x05, 1376, 0xFF00)), Exception::ServerDeviceFailure);  // coil
  EXPECT_EQ(image.outputs[172], 0x11);
  ASSERT_EQ(run(5, pdu(0x03, 86, 1)), std::nullopt);
  EXPECT_EQ(out.registers[0], 0x1100);
  ASSERT_EQ(run(5, write_regs(8192, {1})), std::nullopt);
  ASSERT_EQ(gw5.commands.size(), 1u);
  EXPECT_EQ(run(5, write_regs(4096, {1})), Exception::IllegalDataAddress);  // 0x02 stays first
  map.set_outputs_read_only(false);
  EXPECT_EQ(run(5, write_regs(86, {0x0A0B})), std::nullopt);
}

TEST_F(MapFixture, RefusedControlCommandIsException04AndNotExecuted) {
  // docs/profibus.md role master: a power cycle cannot reach a remote station (docs/modbus.md):
  // exception 0x04, the command is not carried out and the register keeps its last value.
  gw5.refused = Control::PowerCycle;
  ASSERT_EQ(run(5, write_regs(8192, {2})), std::nullopt);
  EXPECT_EQ(run(5, write_regs(8192, {1})), Exception::ServerDeviceFailure);
  EXPECT_EQ(run(5, pdu(0x06, 8192, 1)), Exception::ServerDeviceFailure);
  ASSERT_EQ(gw5.commands.size(), 1u);
  EXPECT_EQ(gw5.commands[0], Control::Reparameterize);
  ASSERT_EQ(run(5, pdu(0x03, 8192, 1)), std::nullopt);
  EXPECT_EQ(out.registers[0], 2);
  // Other gateways are not affected; out-of-range values (above 4, docs/faults.md) are still 0x03.
  ASSERT_EQ(run(6, write_regs(8192, {1})), std::nullopt);
  EXPECT_EQ(gw6.commands.size(), 1u);
  EXPECT_EQ(run(5, write_regs(8192, {5})), Exception::IllegalDataValue);
}

TEST_F(MapFixture, UnitIdsSelectTheGatewayOfStatusAndControl) {
  ASSERT_EQ(run(6, pdu(0x04, 8192, 2)), std::nullopt);
  EXPECT_EQ(out.registers[0], 600);
  EXPECT_EQ(out.registers[1], 601);
  // docs/modbus.md: unit IDs 0 and 255 address the first configured gateway.
  for (std::uint8_t unit : {0, 255}) {
    ASSERT_EQ(run(unit, pdu(0x04, 8192, 1)), std::nullopt);
    EXPECT_EQ(out.registers[0], 500);
  }
  // Any other unknown unit ID: 0x0B, for the image too.
  EXPECT_EQ(run(7, pdu(0x04, 8192, 1)), Exception::GatewayTargetFailed);
  EXPECT_EQ(run(1, pdu(0x03, 0, 1)), Exception::GatewayTargetFailed);
  EXPECT_EQ(run(7, write_regs(0, {1})), Exception::GatewayTargetFailed);
  EXPECT_EQ(image.outputs[1], 0);
  // The image is shared: what unit 5 writes, unit 6 reads.
  ASSERT_EQ(run(5, write_regs(10, {0xBEEF})), std::nullopt);
  ASSERT_EQ(run(6, pdu(0x03, 10, 1)), std::nullopt);
  EXPECT_EQ(out.registers[0], 0xBEEF);
}

TEST_F(MapFixture, ControlRegister) {
  ASSERT_EQ(run(6, {0x06, hi(8192), lo(8192), 0, 1}), std::nullopt);
  ASSERT_EQ(run(0, write_regs(8192, {2})), std::nullopt);
  EXPECT_EQ(gw6.commands, std::vector<Control>{Control::PowerCycle});
  EXPECT_EQ(gw5.commands, std::vector<Control>{Control::Reparameterize});
  ASSERT_EQ(run(6, pdu(0x03, 8192, 1)), std::nullopt);
  EXPECT_EQ(out.registers[0], 1);  // reads the last command
  EXPECT_EQ(run(6, {0x06, hi(8192), lo(8192), 0, 5}), Exception::IllegalDataValue);
  EXPECT_EQ(run(6, write_regs(8192, {1, 1, 1, 1})), Exception::IllegalDataAddress);
  EXPECT_EQ(gw6.commands.size(), 1u);
  // 3 = the master stops addressing the gateway, 4 = it resumes (docs/faults.md).
  ASSERT_EQ(run(6, {0x06, hi(8192), lo(8192), 0, 3}), std::nullopt);
  ASSERT_EQ(run(6, {0x06, hi(8192), lo(8192), 0, 4}), std::nullopt);
  EXPECT_EQ(gw6.commands, (std::vector<Control>{Control::PowerCycle, Control::MasterStops,
                                                Control::MasterResumes}));
}

TEST_F(MapFixture, FaultRegisters) {
  // docs/faults.md: 8193 forced CAN state 0..3, 8194 drop the next N received frames.
  ASSERT_EQ(run(5, {0x06, hi(8193), lo(8193), 0, 3}), std::nullopt);
  EXPECT_EQ(gw5.forced, 3);
  EXPECT_EQ(gw6.forced, 0);
  EXPECT_EQ(run(5, {0x06, hi(8193), lo(8193), 0, 4}), Exception::IllegalDataValue);
  EXPECT_EQ(gw5.forced, 3);
  ASSERT_EQ(run(5, write_regs(8193, {2, 7})), std::nullopt);
  EXPECT_EQ(gw5.forced, 2);
  EXPECT_EQ(gw5.drop, 7);
  ASSERT_EQ(run(5, pdu(0x03, 8192, 3)), std::nullopt);
  EXPECT_EQ(out.registers[1], 2);
  EXPECT_EQ(out.registers[2], 7);
  // All or nothing: a bad forced state in a multi-register write changes nothing.
  EXPECT_EQ(run(5, write_regs(8192, {2, 9, 1})), Exception::IllegalDataValue);
  EXPECT_TRUE(gw5.commands.empty());
  EXPECT_EQ(gw5.drop, 7);
  // A station without a CAN controller here (a remote station, a generic slave) refuses 8194.
  gw6.can = false;
  EXPECT_EQ(run(6, {0x06, hi(8194), lo(8194), 0, 5}), Exception::IllegalDataValue);
  EXPECT_EQ(gw6.drop, 0);
}

TEST_F(MapFixture, WholeDiagnosisAfterTheStatusBlock) {
  // docs/modbus.md "Whole diagnosis": 8260 = length, 8261.. = two bytes a register, high first.
  // By default a station's diagnosis is the status block's 11 diagnosis bytes.
  ASSERT_EQ(run(5, pdu(0x04, kDiagnosisBase, 7)), std::nullopt);
  EXPECT_EQ(out.registers[0], dp::DpSlave::kDiagLen);
  auto byte = [&](unsigned i) { return (gw5.block[status::kDiag + i]) & 0xFF; };
  EXPECT_EQ(out.registers[1], byte(0) << 8 | byte(1));
  EXPECT_EQ(out.registers[5], byte(8) << 8 | byte(9));
  EXPECT_EQ(out.registers[6], byte(10) << 8);  // byte 11 does not exist: 0
  // The whole range, one request; past it and in the holding registers: outside the map.
  EXPECT_EQ(kDiagnosisBase, kStatusBase + status::kCount);
  EXPECT_EQ(run(5, pdu(0x04, kDiagnosisBase, kDiagnosisRegisters)), std::nullopt);
  EXPECT_EQ(out.registers[kDiagnosisRegisters - 1], 0);
  EXPECT_EQ(run(5, pdu(0x04, kDiagnosisBase + kDiagnosisRegisters - 1, 1)), std::nullopt);
  EXPECT_EQ(run(5, pdu(0x04, kDiagnosisBase + kDiagnosisRegisters, 1)),
            Exception::IllegalDataAddress);
  EXPECT_EQ(run(5, pdu(0x04, kDiagnosisBase - 1, 2)), Exception::IllegalDataAddress);
  EXPECT_EQ(run(5, pdu(0x03, kDiagnosisBase, 1)), Exception::IllegalDataAddress);
}

struct LongDiagGateway : FakeGateway {
  using FakeGateway::FakeGateway;
  std::vector<std::uint8_t> diagnosis(Time) override { return diag; }
  std::vector<std::uint8_t> diag;
};

TEST(WholeDiagnosis, LongerThanTheStatusBlockAndOddLength) {
  // A generic slave's 6 standard bytes and a 9-byte device-related block (docs/slaves.md).
  dp::ProcessImage image;
  LongDiagGateway slave(8);
  slave.diag = {0x08, 0x0C, 0x00, 0x01, 0x0C, 0x2D, 0x0A, 1, 2, 3, 4, 5, 6, 7, 8, 9};
  slave.diag.push_back(0xAB);  // 17 bytes: the last register's low byte is 0
  ProcessImageMap map{image, {&slave}};
  const auto a = adu(8, pdu(0x04, kDiagnosisBase, 10));
  ReadResult out;
  ASSERT_EQ(map.handle(std::get<Request>(decode_request(a)), out, Time{0}), std::nullopt);
  EXPECT_EQ(out.registers[0], 17);
  EXPECT_EQ(out.registers[1], 0x080C);
  EXPECT_EQ(out.registers[4], 0x0A01);
  EXPECT_EQ(out.registers[8], 0x0809);
  EXPECT_EQ(out.registers[9], 0xAB00);
  slave.diag.clear();  // none yet (a remote station the master has not read)
  ASSERT_EQ(map.handle(std::get<Request>(decode_request(a)), out, Time{0}), std::nullopt);
  EXPECT_EQ(out.registers[0], 0);
  EXPECT_EQ(out.registers[1], 0);
}

TEST_F(MapFixture, MaskWriteRegister) {
  image.outputs[20] = 0x12;
  image.outputs[21] = 0x34;
  // MB spec §6.16 example: 0x12 AND F2 OR 25 → 0x17 (low byte here, high byte kept by AND FF).
  ASSERT_EQ(run(5, {0x16, 0, 10, 0xFF, 0xF2, 0x00, 0x25}), std::nullopt);
  EXPECT_EQ(image.outputs[20], 0x12);
  EXPECT_EQ(image.outputs[21], (0x34 & 0xF2) | (0x25 & ~0xF2 & 0xFF));  // 0x35
}

TEST_F(MapFixture, ReadWriteMultipleIsAllOrNothing) {
  // Write 2 registers at 100, read 3 from 99.
  std::vector<std::uint8_t> p = {0x17, 0, 99, 0, 3, 0, 100, 0, 2, 4, 0xAA, 0xBB, 0xCC, 0xDD};
  ASSERT_EQ(run(5, p), std::nullopt);
  EXPECT_EQ(out.registers[0], 0);
  EXPECT_EQ(out.registers[1], 0xAABB);
  EXPECT_EQ(out.registers[2], 0xCCDD);
  // A read range outside the map: nothing is written.
  p = {0x17, hi(4095), lo(4095), 0, 2, 0, 50, 0, 1, 2, 0x11, 0x22};
  EXPECT_EQ(run(5, p), Exception::IllegalDataAddress);
  EXPECT_EQ(image.outputs[100], 0);
}

TEST(StatusBlock, EncodesGatewayMasterAndLeds) {
  StatusInputs in;
  in.gateway.dp_state = dp::SlaveState::DataExch;
  in.gateway.bus_state = can::BusState::Warning;
  in.gateway.released = true;
  in.gateway.rx_frames = 0x00012345;
  in.gateway.irq_lost = 7;
  in.diag = {0x00, 0x0C, 0x00, 0x01, 0x04, 0xA4, 0x05, 0x04, 0x40, 0x07, 0x00};
  in.master_state = dp::MasterSlaveState::DataExch;
  in.parameterizations = 3;
  in.dp_address = 5;
  const auto b = encode_status(in);
  EXPECT_EQ(b[status::kDpState], 2);
  EXPECT_EQ(b[status::kDiag + 5], 0xA4);
  EXPECT_EQ(b[status::kDiag + 8], 0x40);
  EXPECT_EQ(b[status::kMasterState], 4);
  EXPECT_EQ(b[status::kBusState], 1);
  EXPECT_EQ(b[status::kReleased], 1);
  EXPECT_EQ(b[status::kRxFrames], 0x0001);
  EXPECT_EQ(b[status::kRxFrames + 1], 0x2345);
  EXPECT_EQ(b[status::kIrqLost + 1], 7);
  EXPECT_EQ(b[status::kLedD], led::kOn);
  EXPECT_EQ(b[status::kLedE], led::kOff);
  EXPECT_EQ(b[status::kLedC], led::kMorseW);  // manual table 3.3.1: 'W' = CAN warning
  EXPECT_EQ(b[status::kDpAddress], 5);
  EXPECT_EQ(b[status::kParameterizations + 1], 3);
  in.gateway.dp_state = dp::SlaveState::WaitCfg;
  in.gateway.bus_state = can::BusState::BusOff;
  const auto c = encode_status(in);
  EXPECT_EQ(c[status::kLedE], 4);  // 4 short flashes: waiting for the configuration telegram
  EXPECT_EQ(c[status::kLedD], led::kOff);
  EXPECT_EQ(c[status::kLedC], led::kMorseO);
}

TEST(StatusBlock, FieldTableCoversEveryRegisterOnce) {
  std::vector<int> seen(status::kCount, 0);
  for (const auto& f : status_fields())
    for (int i = 0; i < f.registers; ++i) ++seen.at(f.offset + i);
  for (std::size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i], 1) << "offset " << i;
}

}  // namespace
}  // namespace candp2::modbus

namespace candp2::modbus {
namespace {

TEST(StatusBlock, DocumentedInDocsModbusMd) {
  std::ifstream in(CANDP2_SOURCE_DIR "/docs/modbus.md");
  ASSERT_TRUE(in) << "docs/modbus.md";
  std::stringstream text;
  text << in.rdbuf();
  for (const auto& f : status_fields()) {
    const unsigned a = kStatusBase + f.offset;
    const std::string reg = f.registers == 1
                                ? std::to_string(a)
                                : std::to_string(a) + ".." + std::to_string(a + f.registers - 1);
    const std::string row = "| " + reg + " | " + std::string(f.name) + " |";
    EXPECT_NE(text.str().find(row), std::string::npos) << "docs/modbus.md lacks the row " << row;
  }
}

}  // namespace
}  // namespace candp2::modbus
