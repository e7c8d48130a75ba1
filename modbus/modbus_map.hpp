// The Modbus/TCP face of the simulated DP master (docs/modbus.md), without sockets:
// ProcessImageMap applies a decoded request (modbus/mbap.hpp) to the master's PLC process image,
// the gateways' status blocks and control and fault registers (modbus/registers.hpp), the drives'
// fault registers and the generic slaves' field sides: unit ID → station (0x0B), address ranges
// (0x02). The server (modbus_server.hpp) owns the sockets and answers through libmodbus.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/time.hpp"
#include "modbus/mbap.hpp"
#include "modbus/registers.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::modbus {

// The line block (docs/modbus.md "Line block") of every station, on a line whose statistics
// the daemon counts.
class LineAccess {
 public:
  virtual ~LineAccess() = default;
  virtual LineBlock block(std::uint8_t address, Time now) const = 0;
  virtual std::uint16_t fault_register(std::uint8_t address, std::uint16_t offset,
                                       Time now) const = 0;
  // Checked first, applied after (all or nothing); writing the kind applies the fault.
  virtual std::optional<DecodeFailure> write_faults(std::uint8_t address, std::uint16_t offset,
                                                    std::span<const std::uint16_t> values,
                                                    Time now) = 0;
};

// The CAN fault block (docs/modbus.md "CAN fault block") of the gateways on a bus in time.
class CanFaultAccess {
 public:
  virtual ~CanFaultAccess() = default;
  virtual std::uint16_t fault_register(std::uint8_t address, std::uint16_t offset) const = 0;
  // Checked first, applied after (all or nothing); writing the kind applies the fault.
  virtual std::optional<DecodeFailure> write_faults(std::uint8_t address, std::uint16_t offset,
                                                    std::span<const std::uint16_t> values,
                                                    Time now) = 0;
};

// One gateway as the map sees it.
class GatewayFace {
 public:
  virtual ~GatewayFace() = default;
  // Its line block; null: no line statistics (those addresses are outside the map).
  LineAccess* line() const { return line_; }
  void set_line(LineAccess* line) { line_ = line; }
  // Its CAN fault block; null: not on a bus in time (those addresses are outside the map).
  CanFaultAccess* can_faults() const { return can_faults_; }
  void set_can_faults(CanFaultAccess* access) { can_faults_ = access; }
  virtual std::uint8_t dp_address() const = 0;
  virtual StatusBlock status(Time now) = 0;
  virtual void control(Control command, Time now) = 0;
  // Holding register 8193: forced CAN controller state; false = value refused (exception 0x03).
  virtual bool force_bus_state(std::uint16_t /*code*/, Time /*now*/) { return false; }
  virtual std::uint16_t forced_bus_state() const { return 0; }
  // Holding register 8194: drop the next n received frames; reads give the remaining count.
  // Stations without a CAN controller here (remote stations, generic slaves) refuse it.
  virtual bool has_can_controller() const { return false; }
  virtual void drop_received(std::uint16_t /*n*/, Time /*now*/) {}
  virtual std::uint16_t drop_remaining() const { return 0; }
  // A command this gateway cannot carry out: the reason (the write gets exception 0x04 and the
  // control register keeps its value). profibus role master: a power cycle cannot reach a remote
  // device (docs/profibus.md, docs/modbus.md).
  virtual std::optional<std::string> refuses(Control /*command*/) const { return std::nullopt; }
  // The whole Slave_Diag answer (input registers kDiagnosisBase..); by default the status block's
  // 11 diagnosis bytes.
  virtual std::vector<std::uint8_t> diagnosis(Time now);
  // A generic slave's fault registers (holding registers kSlaveFaultBase.., docs/faults.md
  // "Generic slaves"); gateways have none (those addresses are outside their map).
  virtual bool has_slave_faults() const { return false; }
  virtual std::uint16_t slave_fault(std::uint16_t /*offset*/) const { return 0; }
  // Values written from `offset` on; a failure (nothing applied) for a value out of range.
  virtual std::optional<DecodeFailure> write_slave_faults(std::uint16_t /*offset*/,
                                                          std::span<const std::uint16_t> /*v*/,
                                                          Time /*now*/) {
    return DecodeFailure{Exception::IllegalDataAddress, "no fault registers"};
  }

 private:
  LineAccess* line_ = nullptr;
  CanFaultAccess* can_faults_ = nullptr;
};

// A generic slave's field side on its own unit ID (docs/slaves.md "Field side"): holding registers
// = the inputs the slave reports (a test writes them), input registers = the outputs it applies.
class FieldFace {
 public:
  virtual ~FieldFace() = default;
  virtual std::uint8_t field_unit() const = 0;
  virtual std::span<const std::uint8_t> inputs() const = 0;
  virtual std::span<const std::uint8_t> outputs() const = 0;
  virtual void write_inputs(std::size_t offset, std::span<const std::uint8_t> bytes) = 0;
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

// docs/modbus.md. Single-threaded: a request is applied as a whole between two master cycles,
// which makes multi-register writes atomic with respect to the DP cycle.
class ProcessImageMap final : public Handler {
 public:
  // The first gateway is the one unit IDs 0 and 255 address.
  ProcessImageMap(dp::ProcessImage& image, std::vector<GatewayFace*> gateways,
                  std::vector<DriveFace*> drives = {}, std::vector<FieldFace*> fields = {});
  // profibus role slaves (docs/profibus.md): the output image shows what an external master
  // sent; writes to it (holding registers 0..4095, coils) get exception 0x04.
  void set_outputs_read_only(bool read_only) { outputs_read_only_ = read_only; }
  std::optional<DecodeFailure> handle(const Request& request, ReadResult& out, Time now) override;
  // The last command written to a gateway's control register (reads of holding register 8192).
  std::uint16_t last_control(std::uint8_t dp_address) const;
  // The host block's source (docs/modbus.md "Host block"); unset: zeros (a world that never
  // stalls, as in replay).
  void set_host_stalls(std::function<HostStalls()> source) { host_stalls_ = std::move(source); }

 private:
  GatewayFace* resolve(std::uint8_t unit) const;
  std::optional<DecodeFailure> read_registers(Table t, GatewayFace& g, std::uint16_t address,
                                              std::uint16_t count, ReadResult& out, Time now);
  std::optional<DecodeFailure> handle_drive(DriveFace& d, const Request& r, ReadResult& out,
                                            Time now);
  std::optional<DecodeFailure> handle_field(FieldFace& f, const Request& r, ReadResult& out);
  std::optional<DecodeFailure> bits(const Request& r, ReadResult& out);
  std::optional<DecodeFailure> write_registers(GatewayFace& g, const Request& r, ReadResult& out,
                                               Time now);
  std::optional<DecodeFailure> write_control(GatewayFace& g, std::uint16_t first,
                                             std::span<const std::uint16_t> values, Time now);

  dp::ProcessImage& image_;
  std::vector<GatewayFace*> gateways_;
  std::vector<std::uint16_t> last_control_;  // per gateway
  bool outputs_read_only_ = false;
  std::vector<DriveFace*> drives_;
  std::vector<FieldFace*> fields_;
  std::function<HostStalls()> host_stalls_;
};

}  // namespace candp2::modbus
