// Modbus/TCP framing and request decoding, without sockets (docs/modbus.md):
//
//  - MbapFramer splits a TCP byte stream into ADUs (Modbus Messaging on TCP/IP Implementation
//    Guide V1.0b §3.1.3, MBAP header);
//  - decode_request() validates one ADU's PDU: function code (exception 0x01), quantity and byte
//    count fields (0x03) — Modbus Application Protocol Specification V1.1b3 §6 ("MB spec").
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace candp2::modbus {

// MB spec §6: function codes this server implements.
enum class Function : std::uint8_t {
  ReadCoils = 0x01,
  ReadDiscreteInputs = 0x02,
  ReadHoldingRegisters = 0x03,
  ReadInputRegisters = 0x04,
  WriteSingleCoil = 0x05,
  WriteSingleRegister = 0x06,
  WriteMultipleCoils = 0x0F,
  WriteMultipleRegisters = 0x10,
  MaskWriteRegister = 0x16,
  ReadWriteMultipleRegisters = 0x17,
};

// MB spec §7: exception codes this server answers with.
enum class Exception : std::uint8_t {
  IllegalFunction = 0x01,
  IllegalDataAddress = 0x02,
  IllegalDataValue = 0x03,
  ServerDeviceFailure = 0x04,  // role slaves: outputs are the wire's; role master: no power cycle
  GatewayTargetFailed = 0x0B,  // "gateway target device failed to respond": unknown unit ID
};
std::string_view to_string(Exception e);

// MBAP header (TCP guide §3.1.3): transaction id 2, protocol id 2 (0 = Modbus), length 2 (unit id +
// PDU), unit id 1. MB spec §4.1: a PDU has at most 253 bytes, so an ADU at most 260.
inline constexpr std::size_t kMbapLen = 7;
inline constexpr std::size_t kMaxPduLen = 253;
inline constexpr std::size_t kMaxAduLen = kMbapLen + kMaxPduLen;

// MB spec §6.1-§6.17 quantity limits.
inline constexpr std::uint16_t kMaxReadBits = 2000;           // 0x07D0 (FC 01, 02)
inline constexpr std::uint16_t kMaxReadRegisters = 125;       // 0x007D (FC 03, 04, 23 read)
inline constexpr std::uint16_t kMaxWriteBits = 1968;          // 0x07B0 (FC 15)
inline constexpr std::uint16_t kMaxWriteRegisters = 123;      // 0x007B (FC 16)
inline constexpr std::uint16_t kMaxReadWriteWriteRegs = 121;  // 0x0079 (FC 23 write)
inline constexpr std::uint16_t kCoilOn = 0xFF00;              // MB spec §6.5
inline constexpr std::uint16_t kCoilOff = 0x0000;

// Splits a byte stream into ADUs. Garbage — a protocol id other than 0, or a length field outside
// 2..254 — cannot be resynchronized (TCP has no frame markers), so the connection must be dropped.
class MbapFramer {
 public:
  enum class Status { NeedMore, Frame, Garbage };
  struct Next {
    Status status = Status::NeedMore;
    std::span<const std::uint8_t> adu;  // Frame: valid until the next append() or next()
    std::string why;                    // Garbage: what was wrong
  };
  void append(std::span<const std::uint8_t> bytes);
  Next next();
  std::size_t buffered() const { return buffer_.size() - start_; }

 private:
  std::vector<std::uint8_t> buffer_;
  std::size_t start_ = 0;  // first byte not handed out yet
};

enum class Table : std::uint8_t { Coils, DiscreteInputs, HoldingRegisters, InputRegisters };
std::string_view to_string(Table t);

// One decoded request. Write values are kept as the PDU carries them (registers big-endian).
struct Request {
  std::uint16_t transaction = 0;
  std::uint8_t unit = 0;
  Function function = Function::ReadHoldingRegisters;
  Table table = Table::HoldingRegisters;
  std::uint16_t address = 0;  // read range (reads, FC 23) or the written range (writes)
  std::uint16_t count = 0;
  // Writes: FC 05/06 one value; FC 15 packed coil bytes; FC 16/23 register values.
  std::uint16_t write_address = 0;
  std::uint16_t write_count = 0;
  std::span<const std::uint8_t> values;     // into the ADU
  std::uint16_t and_mask = 0, or_mask = 0;  // FC 22

  bool writes() const;
  std::uint16_t register_value(std::size_t i) const {
    return static_cast<std::uint16_t>((values[2 * i] << 8) | values[2 * i + 1]);
  }
  bool coil_value(std::size_t i) const { return values[i / 8] & (1u << (i % 8)); }
};

struct DecodeFailure {
  Exception exception;
  std::string why;
};
// `adu` is one whole ADU from MbapFramer. Checks MB spec §6 request formats in the order of the
// spec's state diagrams: function code supported (0x01), then quantity, byte count and PDU length
// (0x03). Address ranges are checked by the map (0x02), unit IDs too (0x0B).
std::variant<Request, DecodeFailure> decode_request(std::span<const std::uint8_t> adu);

// What a successful read returns (values of the request's read range).
struct ReadResult {
  std::array<std::uint16_t, kMaxReadRegisters> registers{};
  std::array<std::uint8_t, kMaxReadBits> bits{};  // one byte per bit, 0 or 1 (libmodbus layout)
};

}  // namespace candp2::modbus
