// The plant's stations and drives as the Modbus map sees them (docs/modbus.md): the status block
// of a gateway, its control register and fault registers, a remote station's status in profibus
// role master, a drive's fault registers. Every action goes through the plant's control surface
// (plant/plant.hpp), the same one replay uses.
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "modbus/modbus_map.hpp"
#include "plant/plant.hpp"
#include "plant/slave_line.hpp"
#include "plant/station_status.hpp"

namespace candp2::modbus {

using BitrateFn = station::BitrateFn;

class PlantGatewayFace final : public GatewayFace {
 public:
  PlantGatewayFace(plant::Plant& plant, plant::GatewayUnit& unit, BitrateFn bitrate)
      : plant_(plant), unit_(unit), bitrate_(std::move(bitrate)) {}
  std::uint8_t dp_address() const override { return unit_.view().address; }
  StatusBlock status(Time now) override;
  void control(Control command, Time now) override;
  bool force_bus_state(std::uint16_t code, Time now) override;
  std::uint16_t forced_bus_state() const override { return unit_.faults().forced_code(); }
  bool has_can_controller() const override { return true; }
  void drop_received(std::uint16_t n, Time now) override;
  std::uint16_t drop_remaining() const override;
  std::vector<std::uint8_t> diagnosis(Time now) override;

 private:
  plant::Plant& plant_;
  plant::GatewayUnit& unit_;
  BitrateFn bitrate_;
};

// A remote station in profibus role master (docs/profibus.md): DP state and diagnosis as the
// master last read them, CAN fields 0, the line group from the FDL master's statistics.
class RemoteStationFace final : public GatewayFace {
 public:
  RemoteStationFace(plant::Plant& plant, std::uint8_t address, std::string name)
      : plant_(plant), address_(address), name_(std::move(name)) {}
  std::uint8_t dp_address() const override { return address_; }
  StatusBlock status(Time now) override;
  // 2 re-parameterize, 3 / 4 the master stops / resumes addressing it.
  void control(Control command, Time now) override;
  // 1 = power cycle cannot reach a remote device: refused (exception 0x04) and logged.
  std::optional<std::string> refuses(Control command) const override;
  // The last diagnosis the master read, as received (none before the first).
  std::vector<std::uint8_t> diagnosis(Time now) override;

 private:
  plant::Plant& plant_;
  std::uint8_t address_;
  std::string name_;
};

// A generic DP-V0 slave on its DP-address unit (docs/slaves.md "Modbus"): the status block with
// what applies (DP state, the first 11 diagnosis bytes, the master's view, the line group; CAN
// fields 0), control commands 1..4, and the slave fault registers (docs/faults.md).
class GenericSlaveFace final : public GatewayFace {
 public:
  GenericSlaveFace(plant::Plant& plant, plant::SlaveUnit& unit) : plant_(plant), unit_(unit) {}
  std::uint8_t dp_address() const override { return unit_.config().address; }
  StatusBlock status(Time now) override;
  void control(Control command, Time now) override;
  // 6 standard bytes and the Ext_Diag_Data (docs/slaves.md "Diagnosis").
  std::vector<std::uint8_t> diagnosis(Time now) override;
  bool has_slave_faults() const override { return true; }
  std::uint16_t slave_fault(std::uint16_t offset) const override;
  std::optional<DecodeFailure> write_slave_faults(std::uint16_t offset,
                                                  std::span<const std::uint16_t> values,
                                                  Time now) override;

 private:
  plant::Plant& plant_;
  plant::SlaveUnit& unit_;
  // The alarm bytes as last written (8199..): applied when the length (8198) is written.
  std::array<std::uint16_t, kSlaveAlarmMax / 2> alarm_{};
};

// A generic slave's field side on its field_unit.
class SlaveFieldFace final : public FieldFace {
 public:
  explicit SlaveFieldFace(plant::SlaveUnit& unit) : unit_(unit) {}
  std::uint8_t field_unit() const override { return unit_.config().field_unit.value_or(0); }
  std::span<const std::uint8_t> inputs() const override { return unit_.view().field_inputs; }
  std::span<const std::uint8_t> outputs() const override { return unit_.view().field_outputs; }
  void write_inputs(std::size_t offset, std::span<const std::uint8_t> bytes) override {
    unit_.slave().write_inputs(offset, bytes);
  }

 private:
  plant::SlaveUnit& unit_;
};

class PlantDriveFace final : public DriveFace {
 public:
  PlantDriveFace(plant::Plant& plant, plant::DriveUnit& unit) : plant_(plant), unit_(unit) {}
  std::uint8_t modbus_unit() const override { return unit_.config().modbus_unit.value_or(0); }
  std::uint16_t fault_register(std::uint16_t index) const override {
    return unit_.drive().fault_register(index);
  }
  void set_fault_register(std::uint16_t index, std::uint16_t value, Time now) override {
    plant_.set_drive_fault(unit_, index, value, now, "over Modbus");
  }

 private:
  plant::Plant& plant_;
  plant::DriveUnit& unit_;
};

// Every face of a plant: its stations, the drives that have a Modbus unit, the generic slaves'
// field sides.
// Stations: the gateways (or remote stations) in configuration order, then the generic slaves.
// The line block of every station (docs/modbus.md "Line block") from the plant's line statistics,
// its faults through the plant's control surface.
class PlantLineAccess final : public LineAccess {
 public:
  explicit PlantLineAccess(plant::Plant& plant) : plant_(plant) {}
  LineBlock block(std::uint8_t address, Time now) const override;
  std::uint16_t fault_register(std::uint8_t address, std::uint16_t offset, Time now) const override;
  std::optional<DecodeFailure> write_faults(std::uint8_t address, std::uint16_t offset,
                                            std::span<const std::uint16_t> values,
                                            Time now) override;

 private:
  struct Pending {
    std::uint16_t count = 1, every = 1, for_ms = 0;
  };
  plant::Plant& plant_;
  std::array<Pending, 128> pending_{};  // count, every, for_ms as last written, per address
};

// The CAN fault block of the gateways on a bus in time (docs/modbus.md "CAN fault block"): their
// faults as plant::CanFault through the plant's control surface. Reads give the kind last applied
// and count, every, for_ms as last written (the plant's progress through a fault is not read
// back).
class PlantCanFaults final : public CanFaultAccess {
 public:
  // `buses`: the bus in time of the gateway at each DP address that has one.
  PlantCanFaults(plant::ControlSurface& control, std::map<std::uint8_t, std::string> buses)
      : control_(control), buses_(std::move(buses)) {}
  std::uint16_t fault_register(std::uint8_t address, std::uint16_t offset) const override;
  std::optional<DecodeFailure> write_faults(std::uint8_t address, std::uint16_t offset,
                                            std::span<const std::uint16_t> values,
                                            Time now) override;

 private:
  struct Registers {
    std::uint16_t kind = 0, count = 1, every = 1, for_ms = 0;
  };
  plant::ControlSurface& control_;
  std::map<std::uint8_t, std::string> buses_;
  std::array<Registers, 128> registers_{};  // per DP address
};

struct PlantFaces {
  std::unique_ptr<PlantLineAccess> line;       // with line statistics only
  std::unique_ptr<PlantCanFaults> can_faults;  // with a gateway on a bus in time only
  std::vector<std::unique_ptr<GatewayFace>> gateways;
  std::vector<std::unique_ptr<DriveFace>> drives;
  std::vector<std::unique_ptr<FieldFace>> fields;
  std::vector<GatewayFace*> gateway_list() const;
  std::vector<DriveFace*> drive_list() const;
  std::vector<FieldFace*> field_list() const;
};
PlantFaces make_faces(plant::Plant& plant, BitrateFn bitrate = {});

}  // namespace candp2::modbus
