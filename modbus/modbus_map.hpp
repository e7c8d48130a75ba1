// The Modbus/TCP face of the simulated DP master (emulator-spec §8), without sockets.
//
//  - MbapFramer splits a TCP byte stream into ADUs (Modbus Messaging on TCP/IP Implementation
//    Guide V1.0b §3.1.3, MBAP header);
//  - decode_request() validates one ADU's PDU: function code (exception 0x01), quantity and byte
//    count fields (0x03) — Modbus Application Protocol Specification V1.1b3 §6 ("MB spec");
//  - ProcessImageMap applies a request to the master's PLC process image and to the gateways'
//    status blocks and control registers: unit ID → gateway (0x0B), address ranges (0x02).
// The server (modbus_server.hpp) owns the sockets and answers through libmodbus.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "common/time.hpp"
#include "gateway/gateway.hpp"
#include "profibus_sim/master/dp_master.hpp"

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

// ---- the map of emulator-spec §8 -------------------------------------------------------------

inline constexpr std::uint16_t kImageRegisters = 4096;   // registers 0..4095 = image bytes 0..8191
inline constexpr std::uint32_t kImageBits = 65536;       // coils / discrete inputs 0..65535
inline constexpr std::uint16_t kStatusBase = 8192;       // input registers 8192.. per gateway
inline constexpr std::uint16_t kControlRegister = 8192;  // holding register 8192
// Fault injection (docs/faults.md): holding register 8193 = forced CAN controller state (0 real,
// 1 warning, 2 error-passive, 3 bus-off), 8194 = drop the next N received frames (reads:
// remaining).
inline constexpr std::uint16_t kForcedStateRegister = 8193;
inline constexpr std::uint16_t kDropRxRegister = 8194;
inline constexpr std::uint16_t kControlRegisters = 3;  // 8192..8194

// The status block from input register 8192 (docs/modbus.md). Offsets from kStatusBase.
namespace status {
inline constexpr std::uint16_t kDpState = 0;       // 0 Wait_Prm, 1 Wait_Cfg, 2 Data_Exch
inline constexpr std::uint16_t kDiag = 1;          // 1..11: diagnosis bytes 0..10
inline constexpr std::uint16_t kMasterState = 12;  // the master's view of this slave
inline constexpr std::uint16_t kBusState = 13;     // 0 ok, 1 warning, 2 error-passive, 3 bus-off
inline constexpr std::uint16_t kReleased = 14;     // CAN transmission released (emulator-spec §7)
inline constexpr std::uint16_t kNmtState =
    15;  // 0 initialising, 1 pre-op, 2 operational, 3 stopped
inline constexpr std::uint16_t kRxFrames = 16;   // 16-17, 32 bit, high word first
inline constexpr std::uint16_t kTxFrames = 18;   // 18-19
inline constexpr std::uint16_t kIrqLost = 20;    // 20-21 (emulator-spec §3)
inline constexpr std::uint16_t kMsgLost = 22;    // 22-23 (emulator-spec §3)
inline constexpr std::uint16_t kFifoLevel = 24;  // Communication Window FIFO (manual §5.3)
inline constexpr std::uint16_t kFifoHighWater = 25;
inline constexpr std::uint16_t kSyncMs = 26;         // effective SYNC time
inline constexpr std::uint16_t kWakeupS = 27;        // stored wake-up time
inline constexpr std::uint16_t kDataExchanges = 28;  // 28-29, gateway side
inline constexpr std::uint16_t kLedD = 30;           // manual table 3.3.1 (led:: codes)
inline constexpr std::uint16_t kLedE = 31;
inline constexpr std::uint16_t kLedP = 32;
inline constexpr std::uint16_t kLedC = 33;
inline constexpr std::uint16_t kDpAddress = 34;
inline constexpr std::uint16_t kParameterizations = 35;  // 35-36, master side
// ---- issue 14: the CAN bit rate (SocketCAN "bitrate": "check" / "apply", docs/transports.md).
// One contiguous group; 0 where unknown (not a SocketCAN bus, no Set_Prm yet, vcan).
inline constexpr std::uint16_t kBitrateMode = 37;        // 0 none, 1 check, 2 apply
inline constexpr std::uint16_t kBitrateConfigured = 38;  // 38-39 bit/s from Set_Prm byte 8
inline constexpr std::uint16_t kBitrateInterface = 40;   // 40-41 bit/s of the interface
inline constexpr std::uint16_t kBitrateMismatch = 42;    // 1 = they differ by more than 1 %
// The PROFIBUS line (emulator-spec §10; zero without a `profibus` section).
inline constexpr std::uint16_t kLineRole = 43;         // 0 in-process, 1 role slaves, 2 role master
inline constexpr std::uint16_t kLineTelegrams = 44;    // 44-45 good telegrams on the line
inline constexpr std::uint16_t kLineFcsErrors = 46;    // 46-47
inline constexpr std::uint16_t kLineOtherErrors = 48;  // 48-49 framing, parity, truncated
inline constexpr std::uint16_t kStationRequests = 50;  // 50-51 requests to this station
inline constexpr std::uint16_t kStationRetries = 52;   // 52-53 repetitions (FCB / master retries)
inline constexpr std::uint16_t kResponseUs = 54;       // last response time, µs (max 65535)
inline constexpr std::uint16_t kResponseMaxUs = 55;    // highest response time, µs
inline constexpr std::uint16_t kStationPresent = 56;   // 1 talking to a master / answering
// Fault injection and transport faults (docs/faults.md).
inline constexpr std::uint16_t kForcedState = 57;   // holding register 8193 as written (0 = real)
inline constexpr std::uint16_t kTxSuppressed = 58;  // 58-59 frames not sent in a forced bus-off
inline constexpr std::uint16_t kRxSuppressed = 60;  // 60-61 not received in a forced bus-off
inline constexpr std::uint16_t kRxDropRemaining = 62;  // holding register 8194 (saturates 0xFFFF)
inline constexpr std::uint16_t kAddressed = 63;   // 1 = the master addresses it, 0 = stopped (3)
inline constexpr std::uint16_t kReconnects = 64;  // 64-65 socketcand client reconnections
// The DP master's cycle (docs/daemon.md "Cycle timing"): the same value in every gateway's block.
inline constexpr std::uint16_t kCyclesMissed = 66;  // 66-67 grid points without a master cycle
inline constexpr std::uint16_t kCount = 68;
}  // namespace status

// LED codes in the status block (manual §3.3, table 3.3.1).
namespace led {
inline constexpr std::uint16_t kOff = 0;
inline constexpr std::uint16_t kOn = 1;
// LED E: n short flashes (3 = waiting for Set_Prm, 4 = waiting for Chk_Cfg) are the value n.
inline constexpr std::uint16_t kMorseE = 0x45;  // LED C: 'E' CAN error (error passive)
inline constexpr std::uint16_t kMorseW = 0x57;  // LED C: 'W' CAN warning
inline constexpr std::uint16_t kMorseO = 0x4F;  // LED C: 'O' CAN off (bus off)

// The four LEDs' codes for a gateway state (manual table 3.3.1): the status block, the HTTP face's
// page and its JSON all show these.
struct Codes {
  std::uint16_t p = kOn, d = kOff, e = kOff, c = kOn;
};
Codes codes(const gw::GatewayStatus& g);
}  // namespace led

// Holding register 8192 commands (emulator-spec §8).
enum class Control : std::uint16_t {
  None = 0,
  PowerCycle = 1,
  Reparameterize = 2,
  MasterStops = 3,    // the master stops addressing this gateway (docs/faults.md)
  MasterResumes = 4,  // the master addresses it again and parameterizes it
};
// Every command with the name the JSON map (map_json.hpp) and the candp2 Python package use.
struct ControlCommand {
  Control command;
  std::string_view name;
  std::string_view meaning;
};
std::span<const ControlCommand> control_commands();

// Unit IDs that address the first configured gateway (docs/modbus.md "Unit IDs": clients that
// always send 0 or 255 keep working).
inline constexpr std::array<std::uint8_t, 2> kFirstGatewayUnits = {0, 255};

using StatusBlock = std::array<std::uint16_t, status::kCount>;

// Everything a status block shows, gathered by the owner of gateway and master.
// The CAN bit rate group (kBitrate*): the daemon's view of the SocketCAN interface.
struct BitrateStatus {
  std::uint16_t mode = 0;        // 0 none, 1 check, 2 apply
  std::uint32_t configured = 0;  // bit/s, 0 before the first Set_Prm
  std::uint32_t interface = 0;   // bit/s, 0 = no bit timing (virtual) or not readable
  bool mismatch = false;
};

struct StatusInputs {
  gw::GatewayStatus gateway;
  BitrateStatus bitrate;
  dp::DpSlave::Diag diag{};
  std::optional<dp::MasterSlaveState> master_state;
  std::uint32_t parameterizations = 0;
  std::uint8_t dp_address = 0;
  struct Line {
    std::uint16_t role = 0;  // 1 slaves, 2 master
    std::uint32_t telegrams = 0, fcs_errors = 0, other_errors = 0;
    std::uint32_t requests = 0, retries = 0;
    std::uint32_t response_us = 0, response_max_us = 0;
    bool present = false;
  };
  std::optional<Line> line;
  bool addressed = true;
  // Fault injection (docs/faults.md).
  std::uint16_t forced_state = 0;
  std::uint32_t tx_suppressed = 0;
  std::uint32_t rx_suppressed = 0;
  std::uint32_t rx_drop_remaining = 0;
  std::uint32_t reconnects = 0;
  std::uint64_t cycles_missed = 0;  // the master's (saturates at 2^32 - 1)
};
StatusBlock encode_status(const StatusInputs& in);

// One gateway as the map sees it.
class GatewayFace {
 public:
  virtual ~GatewayFace() = default;
  virtual std::uint8_t dp_address() const = 0;
  virtual StatusBlock status(Time now) = 0;
  virtual void control(Control command, Time now) = 0;
  // Holding register 8193: forced CAN controller state; false = value refused (exception 0x03).
  virtual bool force_bus_state(std::uint16_t /*code*/, Time /*now*/) { return false; }
  virtual std::uint16_t forced_bus_state() const { return 0; }
  // Holding register 8194: drop the next n received frames; reads give the remaining count.
  virtual void drop_received(std::uint16_t /*n*/, Time /*now*/) {}
  virtual std::uint16_t drop_remaining() const { return 0; }
  // A command this gateway cannot carry out: the reason (the write gets exception 0x04 and the
  // control register keeps its value). profibus role master: a power cycle cannot reach a remote
  // device (emulator-spec §10, docs/modbus.md).
  virtual std::optional<std::string> refuses(Control /*command*/) const { return std::nullopt; }
};

// A simulated drive's fault registers (docs/faults.md), holding registers 0..3 of its own unit ID:
// 0 mute (1 = stops answering), 1 error bits (ERR_BITMAP1 0x8F bits 0..15), 2 warning bits
// (0x8F bits 16..31), 3 restart (write 1; reads 0).
inline constexpr std::uint16_t kDriveRegisters = 4;
class DriveFace {
 public:
  virtual ~DriveFace() = default;
  virtual std::uint8_t modbus_unit() const = 0;
  virtual std::uint16_t fault_register(std::uint16_t index) const = 0;
  virtual void set_fault_register(std::uint16_t index, std::uint16_t value, Time now) = 0;
};

class Handler {
 public:
  virtual ~Handler() = default;
  // Applies the request; on success fills `out` with the values of the read range (reads, FC 23).
  virtual std::optional<DecodeFailure> handle(const Request& request, ReadResult& out,
                                              Time now) = 0;
};

// emulator-spec §8. Single-threaded: a request is applied as a whole between two master cycles,
// which makes multi-register writes atomic with respect to the DP cycle.
class ProcessImageMap final : public Handler {
 public:
  // The first gateway is the one unit IDs 0 and 255 address.
  ProcessImageMap(dp::ProcessImage& image, std::vector<GatewayFace*> gateways,
                  std::vector<DriveFace*> drives = {});
  // profibus role slaves (emulator-spec §10): the output image shows what an external master
  // sent; writes to it (holding registers 0..4095, coils) get exception 0x04.
  void set_outputs_read_only(bool read_only) { outputs_read_only_ = read_only; }
  std::optional<DecodeFailure> handle(const Request& request, ReadResult& out, Time now) override;
  // The last command written to a gateway's control register (reads of holding register 8192).
  std::uint16_t last_control(std::uint8_t dp_address) const;

 private:
  GatewayFace* resolve(std::uint8_t unit) const;
  std::optional<DecodeFailure> read_registers(Table t, GatewayFace& g, std::uint16_t address,
                                              std::uint16_t count, ReadResult& out, Time now);

  dp::ProcessImage& image_;
  std::vector<GatewayFace*> gateways_;
  std::vector<std::uint16_t> last_control_;  // per gateway
  bool outputs_read_only_ = false;
  std::vector<DriveFace*> drives_;
};

// The status block's fields, for `candp2d --print-modbus-map` and logs.
struct StatusField {
  std::uint16_t offset;     // from kStatusBase
  std::uint16_t registers;  // 1, or 2 for 32-bit values (high word first)
  std::string_view name;
  std::string_view meaning;
};
std::span<const StatusField> status_fields();

}  // namespace candp2::modbus
