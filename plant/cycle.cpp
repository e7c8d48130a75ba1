// The plant in time (docs/architecture.md "The plant"): what each gateway waits for, kept until
// something reaches it; when the plant next needs attention, advancing to
// a time, the DP master's cycle on its grid with the missed grid points counted, and the delivery
// of frames between in-process endpoints. Part of plant::Plant (plant/plant.hpp); the assembly is
// in plant.cpp, the control surface in control.cpp.
#include <algorithm>
#include <bit>
#include <cstdlib>

#include "plant/master_line.hpp"
#include "plant/plant.hpp"
#include "plant/slave_line.hpp"
#include "plant/timed_line.hpp"

namespace candp2::plant {

// ------------------------------------------------- what a gateway waits for (GatewayUnit)

// docs/can-bus.md "Performance": only a frame that may move what the gateway waits for (an NMT
// command) has its deadline asked again. Its bus and controller state are the deliverer's:
// deliver() looks at them after the frames, Plant::receive() touches the gateway before them.
void GatewayUnit::receive(const can::Frame& frame, Time now) {
  if (faults_.pass_rx() && gateway_->on_can_frame(frame, now)) touched();
}

void GatewayUnit::update_controller() {
  // docs/can-bus.md "Error confinement": a gateway whose Set_Prm bit rate is not its timed bus's
  // cannot talk on it (its frames and the others' are errors to it).
  if (endpoint_ && gateway_->user_prm())
    endpoint_->set_own_bitrate(gw::bitrate_bps(gateway_->user_prm()->bitrate_index));
  // Given again only when it changed: the same state twice changes nothing in the engine, nor
  // what it waits for.
  const std::pair state{faults_.state(channel_->bus_state()), lost_total()};
  if (applied_ == state) return;
  applied_ = state;
  gateway_->set_controller_status(state.first, state.second);
  if (plant_) plant_->gateway_deadlines_.moved(index_);
}

void GatewayUnit::touched() {
  bus_seen_.reset();
  if (!plant_) return;
  plant_->mark_delivery(index_);
  plant_->gateway_deadlines_.moved(index_);
  if (!listed_) {
    listed_ = true;
    plant_->touched_.push_back(this);
  }
}

void Plant::touch_gateways() {
  for (auto& g : gateways_) g->touched();
  gateway_deadlines_.all_moved();  // one walk, not one heap entry each
}

// ------------------------------------------------------------------------------ the plant

std::optional<Time> Plant::next_deadline() const {
  // A rotation still on the timed line holds the next cycle back: the line says when it ends.
  std::optional<Time> next;
  if (!timed_line_ || !timed_line_->rotating()) next = next_cycle_;
  auto earliest = [&](std::optional<Time> d) {
    if (d && (!next || *d < *next)) next = d;
  };
  earliest(gateways_deadline());
  for (const auto& d : drives_) earliest(d->drive_->next_deadline());
  for (const auto& sl : slaves_) earliest(sl->slave_->next_deadline());
  if (master_line_) earliest(master_line_->next_deadline());
  if (timed_line_) earliest(timed_line_->next_deadline());
  if (const auto d = buses_deadline())
    earliest(
        std::max(*d, buses_handled_ + (images_only_ ? options_.image_bus_step : options_.step)));
  earliest(node_faults_deadline());
  return next;
}

std::optional<Time> Plant::gateways_deadline() const {
  const std::optional<Time> first = gateway_deadlines_.earliest(
      [this](std::size_t i) { return gateways_[i]->gateway_->next_deadline(); });
#ifndef NDEBUG  // the caches hold what the engines say (Debug builds, the sanitizer run)
  std::optional<Time> fresh;
  for (const auto& g : gateways_)
    if (const auto d = g->gateway_->next_deadline(); d && (!fresh || *d < *fresh)) fresh = d;
  if (fresh != first) std::abort();
#endif
  return first;
}

std::optional<Time> Plant::buses_deadline() const {
  return bus_deadlines_.earliest(
      [this](std::size_t i) { return timed_buses_[i]->next_deadline(); });
}

void Plant::set_now(Time now) {
  if (now < now_) return;
  now_ = now;  // the virtual buses read it (VirtualBus::use_clock)
}

void Plant::run_timers(Time now) {
  if (const auto first = gateways_deadline(); first && *first <= now)
    for (std::size_t i = 0; i < gateways_.size(); ++i)
      if (const auto d = gateway_deadlines_.at(i); d && *d <= now) {
        gateways_[i]->touched();
        gateways_[i]->gateway_->advance(now);
      }
  for (auto& d : drives_)
    if (const auto t = d->drive_->next_deadline(); t && *t <= now)
      d->drive_->advance(now, *d->endpoint_);
  for (auto& sl : slaves_)
    if (const auto t = sl->slave_->next_deadline(); t && *t <= now) sl->slave_->advance(now);
  if (master_line_)
    if (const auto t = master_line_->next_deadline(); t && *t <= now) master_line_->advance(now);
  if (timed_line_)
    if (const auto t = timed_line_->next_deadline(); t && *t <= now) timed_line_->advance(now);
  end_node_faults(now);
}

void Plant::advance(Time now) {
  set_now(now);
  run_timers(now_);
  deliver(now_);
  // docs/can-bus.md "In the plant": buses that only fill images wait for the plant's wakes; what
  // ended by now reaches the images before the master's cycle reads them.
  // At the cycle's own time the cycle goes first, as replay orders them (settle_buses() last).
  if (images_only_ && cycle_due()) settle_buses(now_ - Duration(1));
  // docs/profibus.md "The line in time": a cycle starts when the line's last rotation has ended;
  // when that is later than its grid point the cycles run back to back (missed grid points count).
  // On the timed line a cycle starts at its own time, not when the line step woke the plant: the
  // rest of the step's batch (its rotation, perhaps more of them) follows at the line's bits.
  while (const auto at = cycle_due()) {
    run_cycle(*at);
    if (timed_line_) timed_line_->advance(now_);
    deliver(now_);
    if (!timed_line_) break;
  }
  settle_buses(now_);
  if (options_.image_bus_step > options_.step && now_ >= images_checked_ + options_.image_bus_step)
    check_image_buses();
}

// docs/can-bus.md "The bus in time": every start and end of frame due by now, and what the
// receivers send back at once, until the buses wait for a later time. The buses due come from the
// deadlines' tree (docs/can-bus.md "Performance": not a walk over every bus), in the order of the
// configuration; advancing one bus changes no other's deadline.
void Plant::settle_buses(Time until) {
  while (true) {
    if (const auto first = buses_deadline(); !first || *first > until) break;
    due_buses_.clear();
    bus_deadlines_.due(until, due_buses_);
    if (due_buses_.empty()) break;
    for (const std::uint32_t i : due_buses_) timed_buses_[i]->advance(until);
    buses_handled_ = until;
    deliver(now_);
  }
}

// docs/can-bus.md "In the plant": a frame on a bus that only fills images changes nothing until
// the master's next cycle reads the images (or a document shows the counts), so such a bus needs
// no wake of its own every step. A bus is one when only its layer-2 gateways are on it (no drive,
// no socketcand export or client, no CANopen role: nothing answers a frame or shows it live), no
// fault is set on it and every node is error active; the line must not be in time (its cycles
// start within a line step). Asked again once an image step: a Set_Prm that gives a gateway a
// CANopen role, or an export attached, is seen within it.
void Plant::check_image_buses() {
  images_checked_ = now_;
  images_only_ = !timed_line_ && !timed_buses_.empty() &&
                 std::all_of(buses_.begin(), buses_.end(), [this](const auto& b) {
                   return !b->vbus_ || !b->vbus_->timed() || image_bus(*b);
                 });
}

bool Plant::image_bus(const BusUnit& bus) const {
  const can::VirtualBus& vb = *bus.vbus_;
  const can::TimedBus& timed = *vb.timed();
  // Two gateways at least: a gateway alone on its bus is not acknowledged (ACK errors).
  if (bus.gateways_.size() < 2 || vb.endpoint_count() != bus.gateways_.size()) return false;
  if (!timed.error_faults().empty() || !timed.all_receive()) return false;
  for (std::size_t n = 0; n < timed.nodes(); ++n)
    if (timed.confinement(n).state != can::BusState::Ok) return false;
  return std::all_of(bus.gateways_.begin(), bus.gateways_.end(), [this](const auto& on) {
    const auto& prm = gateways_[on.gateway]->gateway_->user_prm();
    return !prm || prm->role() == gw::CanopenRole::None;
  });
}

std::optional<Time> Plant::cycle_due() const {
  if (now_ < next_cycle_) return std::nullopt;
  // The first cycle anchors the grid where it runs (run_cycle()): when the driver first turns.
  if (!timed_line_ || !grid_started_) return now_;
  if (timed_line_->rotating()) return std::nullopt;
  // Its grid point, or the end of the last rotation (the TID2 after its token) if that is later.
  const Time at = std::max(next_cycle_, timed_line_->free_time());
  if (at > now_) return std::nullopt;
  const Duration limit = options_.line_catch_up;
  return limit > Duration(0) && now_ - at > limit ? now_ : at;
}

void Plant::run_cycle(Time now) {
  // The grid starts with the first cycle: the time between building the plant and its driver's
  // first turn (candp2d opening its listeners) is no lateness.
  if (!grid_started_) {
    grid_started_ = true;
    next_cycle_ = std::max(next_cycle_, now);
  }
  // A cycle whose grid point is more than one period past is not caught up: the grid points in
  // between are missed (counted, docs/daemon.md "Cycle timing"), and this cycle is as late as
  // its own grid point says.
  const Time due = next_cycle_;
  std::uint64_t missed = 0;
  if (period_.count() > 0 && next_cycle_ + period_ <= now) {
    missed = static_cast<std::uint64_t>((now - next_cycle_) / period_);
    next_cycle_ += period_ * static_cast<std::int64_t>(missed);
  }
  next_cycle_ += period_;
  touch_gateways();  // the master's requests reach them (on an ideal line at once)
  if (master_cycles_) {
    cycle_stats_.record(due, now, missed);
    log_misses(due, now, missed);
    if (timed_line_) timed_line_->begin_rotation(now);
    master_->cycle(now);
    if (timed_line_) timed_line_->end_issue(now);
    ++cycles_;
    if (master_line_) master_line_->check_presence(*master_);
  }
  if (slave_line_) slave_line_->check_presence(now);
  for (const auto& hook : cycle_hooks_) hook(now);
}

// One line when a run of missed cycles starts and one when it ends: after a second without a
// miss, with the count (docs/daemon.md "Cycle timing").
void Plant::log_misses(Time due, Time now, std::uint64_t missed) {
  auto ms = [](Duration d) {
    return std::to_string(d.count() / 1000) + "." + std::to_string(d.count() % 1000 / 100) + " ms";
  };
  if (missed > 0) {
    if (!miss_run_) {
      miss_run_ = MissRun{now, now, 0};
      log_.warn("master cycle: " + std::to_string(missed) + " cycle(s) missed, started " +
                ms(now - due) + " late (cycle " + std::to_string(period_.count() / 1000) +
                " ms); counting until the cycle keeps its grid for 1 s");
    }
    miss_run_->count += missed;
    miss_run_->last = now;
  } else if (miss_run_ && now - miss_run_->last >= seconds(1)) {
    log_.info("master cycle back on its grid: " + std::to_string(miss_run_->count) +
              " cycle(s) missed within " + ms(miss_run_->last - miss_run_->first) + " (" +
              std::to_string(cycle_stats_.missed()) + " since start)");
    miss_run_.reset();
  }
}

bool Plant::deliver(Time now) {
  set_now(now);
  // Nothing sent and no state changed since the last look: no frame waits anywhere, and only the
  // gateways reached since need their controller state again.
  if (bus_changes_ == delivered_changes_) {
    for (GatewayUnit* g : touched_) {
      g->listed_ = false;
      if (g->endpoint_) g->update_controller();
    }
    touched_.clear();
    if (bus_changes_ == delivered_changes_) return false;
  }
  bool any = false;
  for (bool work = true; work;) {
    work = false;
    // The marked gateways in order; one marked while this pass runs is taken in it when it comes
    // later in the order, else in the next pass (as a walk over all would).
    for (std::size_t w = 0; w < to_deliver_.size(); ++w) {
      std::uint64_t later = ~std::uint64_t{0};  // the bits after the gateway taken last
      while (const std::uint64_t word = to_deliver_[w] & later) {
        const auto bit = static_cast<unsigned>(std::countr_zero(word));
        to_deliver_[w] &= ~(std::uint64_t{1} << bit);
        later = bit == 63 ? 0 : ~std::uint64_t{0} << (bit + 1);
        GatewayUnit* g = gateways_[w * 64 + bit].get();
        if (!g->endpoint_) continue;
        // A quiet virtual bus (no frame, no state change since) has nothing for the gateway.
        const can::VirtualBus& bus = *g->bus_->vbus_;
        const std::uint64_t changes = bus.changes();
        if (g->bus_seen_ == changes) continue;
        // Only frames ended on its bus in time since it was last given its controller state: the
        // state is what it was, and so is its IRQ_LOST total unless a frame was lost on the way
        // (its receive queue full, or dropped on cue) (docs/can-bus.md "Performance").
        const bool same_state = g->bus_seen_ && g->state_seen_ == bus.state_changes();
        while (auto f = g->endpoint_->receive()) {
          g->receive(*f, now_);
          work = true;
        }
        if (!same_state || !g->applied_ || g->applied_->second != g->lost_total())
          g->update_controller();
        g->bus_seen_ = changes;
        g->state_seen_ = bus.state_changes();
      }
    }
    for (auto& d : drives_)
      while (auto f = d->endpoint_->receive()) {
        d->drive_->on_frame(*f, now_, *d->endpoint_);  // muted: stops answering
        work = true;
      }
    any = any || work;
  }
  delivered_changes_ = bus_changes_;
  for (GatewayUnit* g : touched_) g->listed_ = false;
  touched_.clear();
  return any;
}

void Plant::receive(std::size_t index, Time now) {
  set_now(now);
  GatewayUnit& g = *gateways_.at(index);
  g.touched();
  while (auto f = g.channel_->receive()) {
    if (g.logs_bus_) tap_can(*g.bus_, *f, "bus", now_);
    g.receive(*f, now_);
  }
  g.update_controller();
}

}  // namespace candp2::plant
