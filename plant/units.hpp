// The plant's units (docs/architecture.md "The plant"): one CAN bus, one emulated gateway behind
// its CAN fault layer, one simulated drive, one generic DP-V0 slave. plant::Plant (plant/plant.hpp)
// assembles them and alone changes them; the faces read them through their views.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "can/channel.hpp"
#include "can/virtual_bus.hpp"
#include "common/time.hpp"
#include "config/config.hpp"
#include "faults/can_fault.hpp"
#include "faults/drive_fault.hpp"
#include "gateway/gateway.hpp"
#include "gsd_slave/gsd_slave.hpp"
#include "plant/tap.hpp"
#include "plant/unit_views.hpp"

namespace candp2::plant {

class Plant;

// One CAN bus of the configuration.
class BusUnit {
 public:
  const config::BusConfig& config() const { return *cfg_; }
  const std::string& name() const { return cfg_->name; }
  std::uint16_t index() const { return index_; }
  // The name a capture or a CAN log shows: the SocketCAN interface, else the exported bus name.
  const std::string& interface() const;
  // The in-process bus (virtual buses only): the daemon attaches its socketcand export here.
  can::VirtualBus* virtual_bus() { return vbus_.get(); }

 private:
  friend class Plant;
  const config::BusConfig* cfg_ = nullptr;
  std::uint16_t index_ = 0;
  std::unique_ptr<can::VirtualBus> vbus_;
  // The gateways on it (virtual buses): index and endpoint (on_changed looks at its frames).
  struct OnBus {
    std::size_t gateway = 0;
    const can::VirtualEndpoint* endpoint = nullptr;
  };
  std::vector<OnBus> gateways_;
  // Its gateways' and drives' endpoints by the address of their name, with what sender_of()
  // says of that name: a tapped frame's sender is the sending endpoint's own name, found here
  // without hashing or comparing it (docs/can-bus.md "Performance").
  struct KnownSender {
    std::string_view name;
    std::pair<SenderKind, std::size_t> who;
  };
  std::vector<KnownSender> known_senders_;
};

// One emulated gateway: its channel, the fault layer in between, the firmware engine.
class GatewayUnit final : private can::FrameSink {
 public:
  const config::GatewayConfig& config() const { return *cfg_; }
  const std::string& name() const { return cfg_->name; }
  std::size_t index() const { return index_; }
  // Whoever holds the engine may change what it waits for: its deadline is asked again.
  gw::Gateway& gateway() {
    touched();
    return *gateway_;
  }
  const gw::Gateway& gateway() const { return *gateway_; }
  GatewayView view() const;
  const faults::CanFaultLayer& faults() const { return faults_; }
  can::Channel& channel() { return *channel_; }
  const can::Channel& channel() const { return *channel_; }
  BusUnit& bus() { return *bus_; }
  const BusUnit& bus() const { return *bus_; }
  // socketcand client channels: reconnections so far (status block).
  std::uint32_t reconnects() const { return channel_->reconnects(); }

 private:
  friend class Plant;
  void send(const can::Frame& frame) override;  // the gateway transmits
  void receive(const can::Frame& frame, Time now);
  void update_controller();
  // The IRQ_LOST total given to the engine: the channel's lost frames and the fault layer's.
  std::uint32_t lost_total() const { return faults_.rx_lost(channel_->rx_lost()); }
  // Something reached the engine: its deadline is asked again (docs/architecture.md "The plant":
  // a line in time wakes the plant for every telegram, and a scan of every gateway's slots each
  // time would cost more than the line itself), its bus looked at.
  void touched();

  Plant* plant_ = nullptr;
  const config::GatewayConfig* cfg_ = nullptr;
  std::size_t index_ = 0;
  BusUnit* bus_ = nullptr;
  std::unique_ptr<can::Channel> channel_;
  can::VirtualEndpoint* endpoint_ = nullptr;  // == channel_ on virtual buses
  bool logs_bus_ = false;                     // taps its (non-virtual) bus: the first gateway on it
  std::string sender_;  // "gw:NAME": the endpoint name on a virtual bus, the tap's sender
  faults::CanFaultLayer faults_;
  std::unique_ptr<gw::Gateway> gateway_;
  std::optional<std::uint64_t> bus_seen_;  // the virtual bus's changes() when last delivered
  std::uint64_t state_seen_ = 0;           // and its state_changes()
  bool listed_ = false;                    // in the plant's touched list
  // The controller state and IRQ_LOST total last given to the engine (update_controller).
  std::optional<std::pair<can::BusState, std::uint32_t>> applied_;
};

// One simulated drive on a virtual bus, behind its fault layer.
class DriveUnit {
 public:
  const config::DriveConfig& config() const { return *cfg_; }
  const std::string& name() const { return cfg_->name; }
  DriveStatus status() const;
  faults::FaultyDrive& drive() { return *drive_; }
  const faults::FaultyDrive& drive() const { return *drive_; }
  can::VirtualEndpoint& endpoint() { return *endpoint_; }

 private:
  friend class Plant;
  const config::DriveConfig* cfg_ = nullptr;
  std::unique_ptr<can::VirtualEndpoint> endpoint_;
  std::unique_ptr<faults::FaultyDrive> drive_;
};

// One generic DP-V0 slave from its GSD (docs/slaves.md): in-process under the built-in master or
// on a profibus line in role slaves.
class SlaveUnit {
 public:
  const config::SlaveConfig& config() const { return *cfg_; }
  const std::string& name() const { return cfg_->name; }
  std::size_t index() const { return index_; }
  gsd_slave::GsdSlave& slave() { return *slave_; }
  const gsd_slave::GsdSlave& slave() const { return *slave_; }
  SlaveView view() const;

 private:
  friend class Plant;
  const config::SlaveConfig* cfg_ = nullptr;
  std::size_t index_ = 0;
  std::unique_ptr<gsd_slave::GsdSlave> slave_;
};

}  // namespace candp2::plant
