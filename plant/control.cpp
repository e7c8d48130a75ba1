// The plant's control surface (docs/faults.md): every operator action in one place, logged with
// its origin and shown on the tap as a note, whether it came over Modbus or from a replay step.
#include "common/hex.hpp"
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
  g.touched();
  g.gateway_->power_cycle(now_);
  restarted(g.gateway_->address());
  deliver(now_);
}

std::string Plant::station_name(std::uint8_t address) {
  if (const GatewayUnit* g = gateway_at(address)) return g->name();
  if (const SlaveUnit* s = slave_at(address)) return s->name();
  for (const auto& g : config_.gateways)
    if (g.dp_address() == address) return g.name;
  for (const auto& s : config_.slaves)
    if (s.address == address) return s.name;
  return "station " + std::to_string(address);
}

bool Plant::reparameterize(std::uint8_t address, Time now, std::string_view origin) {
  set_now(now);
  const std::string name = station_name(address);
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
  const std::string name = station_name(address);
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

void Plant::set_slave_online(SlaveUnit& s, bool online, Time now, std::string_view origin) {
  set_now(now);
  const std::string what = online ? "back on the bus" : "leaves the bus (no answer at all)";
  (online ? log_.info(s.name() + ": " + what + " " + std::string(origin))
          : log_.warn(s.name() + ": " + what + " " + std::string(origin)));
  tap_note("slave " + s.name() + ": " + what, now_);
  s.slave_->set_online(online);
}

bool Plant::set_slave_alarm(SlaveUnit& s, std::vector<std::uint8_t> bytes, Time now,
                            std::string_view origin) {
  set_now(now);
  if (bytes.empty()) {
    s.slave_->clear_device_diag();
    log_.info(s.name() + ": diagnosis alarm cleared " + std::string(origin));
    tap_note("slave " + s.name() + ": diagnosis alarm cleared", now_);
    return true;
  }
  const std::string text = hex_bytes(bytes);
  if (!s.slave_->set_device_diag(std::move(bytes))) return false;
  log_.warn(s.name() + ": diagnosis alarm " + text + " " + std::string(origin));
  tap_note("slave " + s.name() + ": diagnosis alarm " + text, now_);
  return true;
}

void Plant::force_slave_fault(SlaveUnit& s, bool prm, bool on, Time now, std::string_view origin) {
  set_now(now);
  const std::string what =
      std::string(prm ? "Prm" : "Cfg") + " fault " + (on ? "forced" : "no longer forced");
  (on ? log_.warn(s.name() + ": " + what + " " + std::string(origin))
      : log_.info(s.name() + ": " + what + " " + std::string(origin)));
  tap_note("slave " + s.name() + ": " + what, now_);
  if (prm)
    s.slave_->force_prm_fault(on, now_);
  else
    s.slave_->force_cfg_fault(on, now_);
}

void Plant::power_cycle(SlaveUnit& s, Time now, std::string_view origin) {
  set_now(now);
  log_.info(s.name() + ": power cycle requested " + std::string(origin));
  tap_note("slave " + s.name() + ": power cycle", now_);
  s.slave_->dp().reset(now_);
  restarted(s.config().address);
}

bool Plant::line_fault(const LineFault& fault, Time now, std::string_view origin) {
  set_now(now);
  if (fault.kind == LineFaultKind::Noise)
    return line_noise(fault.duration.value_or(Duration{0}), origin);
  const std::uint8_t address = fault.station;
  const std::string name = station_name(address);
  if (!timed_line_) {
    log_.warn(name + ": line fault requested " + std::string(origin) +
              " ignored: the line has no baud rate ($.master.baud, docs/profibus.md)");
    return false;
  }
  if (!timed_line_->inject(fault, now_)) {
    log_.warn("line fault requested " + std::string(origin) + " for station " +
              std::to_string(address) + " ignored: no such station on the line");
    return false;
  }
  std::string what = "line fault " + std::string(to_string(fault.kind));
  if (fault.kind != LineFaultKind::None) {
    what += fault.duration ? " for " + std::to_string(fault.duration->count() / 1000) + " ms"
                           : ", " + std::to_string(fault.count) + " answer(s)";
    if (fault.every > 1) what += ", one in every " + std::to_string(fault.every);
  }
  log_.warn(name + ": " + what + " " + std::string(origin));
  tap_note(name + ": " + what, now_);
  return true;
}

bool Plant::can_fault(const CanFault& fault, Time now, std::string_view origin) {
  set_now(now);
  // docs/faults.md "CAN faults on cue": the node (a gateway by DP address, a drive by name) or the
  // bus, then its bus in time.
  can::VirtualEndpoint* node = nullptr;
  std::string name = fault.bus;
  BusUnit* b = fault.bus.empty() ? nullptr : bus(fault.bus);
  auto refuse = [&](const std::string& why) {
    log_.warn("CAN fault " + std::string(to_string(fault.kind)) + " requested " +
              std::string(origin) + " ignored: " + why);
    return false;
  };
  if (fault.node.gateway) {
    GatewayUnit* g = gateway_at(*fault.node.gateway);
    if (!g) return refuse("no gateway at DP address " + std::to_string(*fault.node.gateway));
    if (!g->endpoint_) return refuse("gateway " + g->name() + " is not on a virtual bus");
    node = g->endpoint_;
    name = g->name();
    if (!b) b = g->bus_;
    if (b != g->bus_) return refuse("gateway " + g->name() + " is not on bus " + fault.bus);
  } else if (!fault.node.drive.empty()) {
    DriveUnit* d = drive(fault.node.drive);
    if (!d) return refuse("no drive \"" + fault.node.drive + "\"");
    node = d->endpoint_.get();
    name = d->name();
    BusUnit* db = bus(d->config().bus);
    if (!b) b = db;
    if (b != db) return refuse("drive " + d->name() + " is not on bus " + fault.bus);
  }
  if (!b)
    return refuse(fault.bus.empty() ? "it names no bus and no node"
                                    : "no bus \"" + fault.bus + "\"");
  can::VirtualBus* vb = b->virtual_bus();
  if (!vb || !vb->timed())
    return refuse("bus " + b->name() + " has no bit rate ($.buses." + b->name() +
                  ".bitrate, docs/can-bus.md)");
  const bool needs_node =
      fault.kind == CanFaultKind::Unplugged || fault.kind == CanFaultKind::WrongBitrate;
  if (needs_node && !node) return refuse("it names no node (a gateway or a drive)");
  // docs/can-bus.md "In the plant": a fault is set on buses advanced to now, and from now on
  // the buses in time step as buses with a node that answers (asked again an image step later).
  if (images_only_) settle_buses(now_);
  images_only_ = false;
  images_checked_ = now_;
  std::string what = "CAN fault " + std::string(to_string(fault.kind));
  can::TimedBus::ErrorFault e;
  // docs/faults.md "CAN faults on cue": a node's unplugged or wrong_bitrate lasts until a none,
  // or ends by itself after its for_ms (end_node_faults()).
  std::erase_if(node_faults_, [&](const NodeFault& f) {
    return node ? f.node == node && (fault.kind == CanFaultKind::None || f.kind == fault.kind)
                : fault.kind == CanFaultKind::None && f.bus == b;
  });
  switch (fault.kind) {
    case CanFaultKind::None:
      node ? node->clear_faults() : vb->clear_faults();
      break;
    case CanFaultKind::Unplugged:
    case CanFaultKind::WrongBitrate:
      set_node_fault(*node, fault.kind, true);
      node_faults_.push_back(
          {node, b, name, fault.kind,
           fault.duration ? std::optional(now_ + *fault.duration) : std::nullopt});
      if (fault.duration) what += " for " + std::to_string(fault.duration->count() / 1000) + " ms";
      break;
    case CanFaultKind::ErrorFrames:
    case CanFaultKind::Noise:
      if (fault.kind == CanFaultKind::Noise && !fault.duration)
        return refuse("noise needs a duration (for_ms)");
      if (fault.kind == CanFaultKind::ErrorFrames) {
        if (node) e.node = node->timed_node();
        e.id = fault.id;
        e.count = fault.count;
        e.every = fault.every;
        if (fault.id) what += " on " + can::ident_text(*fault.id);
      }
      if (fault.duration) e.until = now_ + *fault.duration;
      vb->inject_errors(e);
      what += fault.duration ? " for " + std::to_string(fault.duration->count() / 1000) + " ms"
                             : ", " + std::to_string(fault.count) + " frame(s)";
      if (fault.every > 1) what += ", one in every " + std::to_string(fault.every);
      break;
  }
  log_.warn(name + ": " + what + " " + std::string(origin));
  tap_note(name + ": " + what, now_);
  return true;
}

// A node's unplugged or wrong_bitrate, on or off.
void Plant::set_node_fault(can::VirtualEndpoint& node, CanFaultKind kind, bool on) {
  kind == CanFaultKind::Unplugged ? node.set_unplugged(on) : node.set_wrong_bitrate(on);
}

std::optional<Time> Plant::node_faults_deadline() const {
  std::optional<Time> first;
  for (const auto& f : node_faults_)
    if (f.until && (!first || *f.until < *first)) first = f.until;
  return first;
}

void Plant::end_node_faults(Time now) {
  for (auto it = node_faults_.begin(); it != node_faults_.end();) {
    if (!it->until || *it->until > now) {
      ++it;
      continue;
    }
    set_node_fault(*it->node, it->kind, false);
    const std::string what = "CAN fault " + std::string(to_string(it->kind)) + " over";
    log_.warn(it->name + ": " + what + " (its for_ms has passed)");
    tap_note(it->name + ": " + what, now);
    it = node_faults_.erase(it);
  }
}

std::vector<CanFaultView> Plant::can_faults(const BusUnit& bus, Time now) const {
  std::vector<CanFaultView> out;
  const can::TimedBus* t = bus.vbus_ ? bus.vbus_->timed() : nullptr;
  if (!t) return out;
  auto left = [&](std::optional<Time> until) { return until ? *until - now : Duration(0); };
  for (const auto& f : node_faults_) {
    if (f.bus != &bus || (f.until && *f.until <= now)) continue;
    CanFaultView v;
    v.kind = f.kind;
    v.node = f.node->name();
    v.remaining_time = left(f.until);
    out.push_back(std::move(v));
  }
  for (const auto& e : t->error_faults()) {
    if (e.until && *e.until <= now) continue;  // over; it goes at the next start of frame
    CanFaultView v;
    v.kind = e.node || e.id ? CanFaultKind::ErrorFrames : CanFaultKind::Noise;
    if (e.node) v.node = t->name(*e.node);
    v.id = e.id;
    v.remaining = e.until ? 0 : e.count;
    v.every = e.every;
    v.remaining_time = left(e.until);
    out.push_back(std::move(v));
  }
  return out;
}

bool Plant::line_noise(Duration duration, std::string_view origin) {
  if (!timed_line_) {
    log_.warn("line noise requested " + std::string(origin) +
              " ignored: the line has no baud rate ($.master.baud, docs/profibus.md)");
    return false;
  }
  timed_line_->noise(duration, now_);
  const std::string what = "line noise for " + std::to_string(duration.count() / 1000) + " ms";
  log_.warn(what + " " + std::string(origin));
  tap_note(what, now_);
  return true;
}

void Plant::note(std::string_view text, Time now) {
  set_now(now);
  tap_note(std::string(text), now_);
}

}  // namespace candp2::plant
