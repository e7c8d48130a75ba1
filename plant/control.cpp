// The plant's control surface (docs/faults.md): every operator action in one place, logged with
// its origin and shown on the tap as a note, whether it came over Modbus or from a replay step.
#include "plant/plant.hpp"

namespace candp2::plant {

bool Plant::force_can_state(GatewayUnit& g, std::uint16_t code, Time now, std::string_view origin) {
  set_now(now);
  if (!g.faults_.force(code)) return false;
  const std::string what = code == faults::kForceReal
                               ? std::string("no longer forced (real state)")
                               : "forced to " + std::string(can::to_string(*g.faults_.forced()));
  log_.warn(g.name() + ": CAN controller state " + what + " " + std::string(origin));
  tap_note("gateway " + g.name() + ": CAN controller state " + what, now_);
  g.update_controller();
  return true;
}

void Plant::drop_rx(GatewayUnit& g, std::uint32_t n, Time now, std::string_view origin) {
  set_now(now);
  g.faults_.drop_next(n);
  const std::string what =
      "the next " + std::to_string(n) + " received frame(s) will be dropped (IRQ_LOST)";
  log_.warn(g.name() + ": " + what + " " + std::string(origin));
  tap_note("gateway " + g.name() + ": " + what, now_);
}

void Plant::power_cycle(GatewayUnit& g, Time now, std::string_view origin) {
  set_now(now);
  // The master notices the missing Data_Exchange answer and parameterizes again after its retry
  // delay, as a real master would.
  log_.info(g.name() + ": power cycle requested " + std::string(origin));
  tap_note("gateway " + g.name() + ": power cycle", now_);
  g.gateway_->power_cycle(now_);
  deliver(now_);
}

bool Plant::reparameterize(std::uint8_t address, Time now, std::string_view origin) {
  set_now(now);
  const GatewayUnit* g = gateway_at(address);
  const std::string name = g ? g->name() : "station " + std::to_string(address);
  if (slave_line_) {
    // docs/profibus.md role slaves: the external master parameterizes; it cannot be forced.
    log_.warn(name + ": re-parameterization requested " + std::string(origin) +
              " ignored: an external PROFIBUS master drives this gateway (write 1 to "
              "power-cycle it)");
    return false;
  }
  log_.info(name + ": re-parameterization requested " + std::string(origin));
  tap_note(name + ": re-parameterization", now_);
  master_->reparameterize(address, now_);
  return true;
}

void Plant::set_addressed(std::uint8_t address, bool addressed, Time now, std::string_view origin) {
  set_now(now);
  const GatewayUnit* g = gateway_at(address);
  const std::string name = g ? g->name() : "station " + std::to_string(address);
  if (addressed)
    log_.info(name + ": the master addresses it again (requested " + std::string(origin) + ")");
  else
    log_.warn(name + ": the master stops addressing it (requested " + std::string(origin) + ")");
  tap_note(name + (addressed ? ": the master resumes addressing it" : ": the master stops"), now_);
  master_->set_addressed(address, addressed, now_);
}

void Plant::set_drive_fault(DriveUnit& d, std::uint16_t index, std::uint16_t value, Time now,
                            std::string_view origin) {
  set_now(now);
  static constexpr std::string_view kNames[] = {"mute", "error bits", "warning bits", "restart"};
  if (index < std::size(kNames))
    tap_note(
        "drive " + d.name() + ": " + std::string(kNames[index]) + " = " + std::to_string(value),
        now_);
  d.drive_->set_fault_register(index, value, now_, *d.endpoint_,
                               "requested " + std::string(origin));
  deliver(now_);
}

void Plant::note(std::string_view text, Time now) {
  set_now(now);
  tap_note(std::string(text), now_);
}

}  // namespace candp2::plant
