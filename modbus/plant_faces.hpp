// The plant's stations and drives as the Modbus map sees them (docs/modbus.md): the status block
// of a gateway, its control register and fault registers, a remote station's status in profibus
// role master, a drive's fault registers. Every action goes through the plant's control surface
// (plant/plant.hpp), the same one replay uses.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "modbus/modbus_map.hpp"
#include "plant/plant.hpp"
#include "plant/slave_line.hpp"

namespace candp2::modbus {

// The CAN bit rate group of gateway `index` (the daemon's SocketCAN supervisor), if any.
using BitrateFn = std::function<std::optional<BitrateStatus>(std::size_t gateway)>;

class PlantGatewayFace final : public GatewayFace {
 public:
  PlantGatewayFace(plant::Plant& plant, plant::GatewayUnit& unit, BitrateFn bitrate)
      : plant_(plant), unit_(unit), bitrate_(std::move(bitrate)) {}
  std::uint8_t dp_address() const override { return unit_.gateway().address(); }
  StatusBlock status(Time now) override;
  void control(Control command, Time now) override;
  bool force_bus_state(std::uint16_t code, Time now) override;
  std::uint16_t forced_bus_state() const override { return unit_.faults().forced_code(); }
  void drop_received(std::uint16_t n, Time now) override;
  std::uint16_t drop_remaining() const override;

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

 private:
  plant::Plant& plant_;
  std::uint8_t address_;
  std::string name_;
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

// Every face of a plant: its gateways (or remote stations) in configuration order, then the
// drives that have a Modbus unit.
struct PlantFaces {
  std::vector<std::unique_ptr<GatewayFace>> gateways;
  std::vector<std::unique_ptr<DriveFace>> drives;
  std::vector<GatewayFace*> gateway_list() const;
  std::vector<DriveFace*> drive_list() const;
};
PlantFaces make_faces(plant::Plant& plant, BitrateFn bitrate = {});

// The line group of the status block from the plant's line figures.
StatusInputs::Line line_inputs(const plant::LineStatus& l);

}  // namespace candp2::modbus
