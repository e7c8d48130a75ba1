// The replay steps' handlers (docs/replay-format.md), as the action table names them
// (replay/actions.cpp): time, frames, the process image, a station's DP state and counters, the
// Page-Mode driver's data blocks, faults, generic slaves. Faults go through the plant's control
// surface, the one candp2d's Modbus face uses.
#include <algorithm>

#include "can/frame_bits.hpp"
#include "common/hex.hpp"
#include "faults/drive_fault.hpp"
#include "plant/station_status.hpp"
#include "replay/sim.hpp"

namespace candp2::replay {

namespace {
constexpr std::string_view kOrigin = "by a replay step";
}

// The step gateway's frames from the cursor on, for failure messages.
std::string Sim::frames_since_cursor(std::size_t gateway, std::size_t max) const {
  const auto& frames = gw_frames_[gateway];
  const std::size_t from = cursor_[gateway];
  std::string s;
  std::size_t n = 0;
  for (std::size_t i = from; i < frames.size(); ++i, ++n) {
    if (n == max) return s + " ... (" + std::to_string(frames.size() - from) + " frames)";
    const auto& t = res_.traffic[frames[i]];
    s += (s.empty() ? "" : ", ") + can::format_candump(t.frame) + " @" + at_text(t.time);
  }
  return s.empty() ? "none" : s;
}

void Sim::nothing(const Step&, StepResult&) {}

void Sim::advance(const Step& s, StepResult&) {
  run_until(now_ + s.advance);
}

void Sim::cycles(const Step& s, StepResult&) {
  const std::uint64_t target = plant_->cycles() + s.cycles;
  run_until(plant_->next_cycle() + sc_.cycle * (s.cycles - 1),
            [&] { return plant_->cycles() >= target; });
}

void Sim::inject(const Step& s, StepResult&) {
  plant_->set_now(now_);
  for (const auto& f : s.frames) testers_.at(s.bus)->send(f);
  plant_->deliver(now_);
  drain_testers();
}

void Sim::expect_frame(const Step& s, StepResult& r) {
  const auto& mine = gw_frames_[s.gateway];
  std::size_t& cursor = cursor_[s.gateway];
  const auto& p = s.frame_patterns.front();
  std::optional<std::size_t> hit;
  auto check = [&] {
    for (std::size_t i = cursor; i < mine.size(); ++i)
      if (p.matches(res_.traffic[mine[i]].frame)) {
        hit = i;
        return true;
      }
    return false;
  };
  if (run_until(now_ + s.window.value_or(Duration{0}), check)) {
    const auto& t = res_.traffic[mine[*hit]];
    r.detail = can::format_candump(t.frame) + " at " + at_text(t.time);
    cursor = *hit + 1;
  } else {
    r.passed = false;
    r.detail = "no matching frame; the gateway sent: " + frames_since_cursor(s.gateway);
  }
}

void Sim::expect_frames(const Step& s, StepResult& r) {
  const auto& mine = gw_frames_[s.gateway];
  std::size_t& cursor = cursor_[s.gateway];
  const std::size_t n = s.frame_patterns.size();
  run_until(now_ + s.window.value_or(Duration{0}), [&] { return mine.size() - cursor >= n; });
  bool ok = mine.size() - cursor >= n;
  for (std::size_t i = 0; ok && i < n; ++i)
    ok = s.frame_patterns[i].matches(res_.traffic[mine[cursor + i]].frame);
  if (ok) {
    r.detail = "last at " + at_text(n ? res_.traffic[mine[cursor + n - 1]].time : now_);
    cursor += n;
  } else {
    r.passed = false;
    r.detail = "the gateway sent: " + frames_since_cursor(s.gateway);
    cursor = std::min(mine.size(), cursor + n);
  }
}

void Sim::expect_no_frame(const Step& s, StepResult& r) {
  const auto& mine = gw_frames_[s.gateway];
  std::size_t& cursor = cursor_[s.gateway];
  const auto& p = s.frame_patterns.front();
  run_until(now_ + s.window.value_or(Duration{0}));
  for (std::size_t i = cursor; i < mine.size(); ++i) {
    const auto& t = res_.traffic[mine[i]];
    if (p.matches(t.frame)) {
      r.passed = false;
      r.detail = "the gateway sent " + can::format_candump(t.frame) + " at " + at_text(t.time);
      break;
    }
  }
  cursor = mine.size();
}

void Sim::write(const Step& s, StepResult&) {
  auto& image = plant_->master().image();
  std::copy(s.bytes.begin(), s.bytes.end(), image.outputs.begin() + s.address);
}

void Sim::expect_image(const Step& s, StepResult& r) {
  auto& image = plant_->master().image();
  const bool in = s.action == Action::ExpectInput;
  r.passed = poll(
      s,
      [&](std::string& d) {
        const auto& img = in ? image.inputs : image.outputs;
        const auto got = std::span(img).subspan(s.address, s.pattern.size());
        d = hex_bytes(got);
        return s.pattern.matches(got);
      },
      r.detail);
  if (!r.passed) r.detail = "got " + r.detail;
}

dp::DpSlave& Sim::station(const Step& s) {
  if (s.slave) return plant_->slaves().at(*s.slave)->slave().dp();
  return gateway(s).gateway().dp();
}

void Sim::expect_diag(const Step& s, StepResult& r) {
  dp::DpSlave& st = station(s);
  r.passed = poll(
      s,
      [&](std::string& d) {
        if (s.slave) {
          // A generic slave: 6 + n bytes (docs/slaves.md); the pattern says how many.
          const auto diag = st.diagnosis(now_);
          d = hex_bytes(diag);
          return diag.size() == s.pattern.size() && s.pattern.matches(diag);
        }
        const auto diag = st.slave_diag(now_);
        d = hex_bytes(diag) + " (" + dp::describe_diag(diag) + ")";
        return s.pattern.matches(diag);
      },
      r.detail);
  if (!r.passed) r.detail = "got " + r.detail;
}

void Sim::expect_dp_state(const Step& s, StepResult& r) {
  dp::DpSlave& st = station(s);
  r.passed = poll(
      s,
      [&](std::string& d) {
        d = std::string(dp::to_string(st.state()));
        return st.state() == s.dp_state;
      },
      r.detail);
  if (!r.passed) r.detail = "state is " + r.detail;
}

// The counters as the station table reads them (station/status.hpp), from the gateway's own part
// of its status (plant/station_status.hpp).
void Sim::expect_counters(const Step& s, StepResult& r) {
  plant::GatewayUnit& g = gateway(s);
  r.passed = poll(
      s,
      [&](std::string& d) {
        station::Status st;
        station::add_gateway(st, g);
        bool all = true;
        d.clear();
        for (const auto& [name, want] : s.counters) {
          const std::uint64_t got = station::field(name)->get(st);
          d += (d.empty() ? "" : ", ") + name + " " + std::to_string(got);
          all = all && got == want;
        }
        return all;
      },
      r.detail);
  if (!r.passed) r.detail = "got " + r.detail;
}

plc::DbChain* Sim::chain(Db db) {
  switch (db) {
    case Db::WriteConfig:
      return &driver_->write_config_db();
    case Db::ReadConfig:
      return &driver_->read_config_db();
    case Db::Write:
      return &driver_->write_db();
    case Db::Read:
      return &driver_->read_db();
  }
  return nullptr;
}

// The identifiers of WRITE_CONFIG_DB / READ_CONFIG_DB as the driver reads them now.
std::optional<std::vector<gw::page::IdEntry>> Sim::idents(bool tx, std::string* why) {
  auto raw =
      plc::parse_config_chain(tx ? driver_->write_config_db() : driver_->read_config_db(), why);
  if (!raw) return std::nullopt;
  std::vector<gw::page::IdEntry> out;
  for (const auto& e : *raw) {
    auto entry = gw::page::decode_entry(e, why);
    if (!entry) return std::nullopt;
    out.push_back(*entry);
  }
  return out;
}

void Sim::freigabe(const Step& s, StepResult&) {
  driver_->set_freigabe(s.on);
}

void Sim::db_write(const Step& s, StepResult& r) {
  auto* c = chain(s.db);
  if (s.db_index >= c->size() || s.offset + s.bytes.size() > (*c)[s.db_index].size()) {
    r.passed = false;
    r.detail = std::string(to_string(s.db)) + " has no bytes " + std::to_string(s.offset) + ".." +
               std::to_string(s.offset + s.bytes.size() - 1) + " in DB " +
               std::to_string(s.db_index);
    return;
  }
  auto& db = (*c)[s.db_index];
  std::copy(s.bytes.begin(), s.bytes.end(), db.begin() + static_cast<std::ptrdiff_t>(s.offset));
}

void Sim::expect_db(const Step& s, StepResult& r) {
  r.passed = poll(
      s,
      [&](std::string& d) {
        auto* c = chain(s.db);
        if (s.db_index >= c->size() || s.offset + s.pattern.size() > (*c)[s.db_index].size()) {
          d = "DB has no such bytes";
          return false;
        }
        const auto got = std::span((*c)[s.db_index]).subspan(s.offset, s.pattern.size());
        d = hex_bytes(got);
        return s.pattern.matches(got);
      },
      r.detail);
  if (!r.passed) r.detail = "got " + r.detail;
}

void Sim::expect_ret_value(const Step& s, StepResult& r) {
  r.passed = poll(
      s,
      [&](std::string& d) {
        const auto v = static_cast<std::uint16_t>(driver_->ret_value());
        d = std::to_string(v) + " (" + std::string(plc::to_string(driver_->state())) + ")";
        return v == s.ret_value;
      },
      r.detail);
  if (!r.passed) r.detail = "got " + r.detail;
}

// set_tx / expect_rx: an identifier's entry in WRITE_DB / READ_DB.
void Sim::entry(const Step& s, StepResult& r) {
  const bool tx = s.action == Action::SetTx;
  std::string why;
  const auto ids = idents(tx, &why);
  const auto pos =
      ids ? plc::locate_data_entries(tx ? driver_->write_db() : driver_->read_db(), *ids, &why)
          : std::nullopt;
  if (!pos || s.entry > pos->size()) {
    r.passed = false;
    r.detail = pos ? std::string(tx ? "Tx" : "Rx") + " identifier " + std::to_string(s.entry) +
                         " not configured (" + std::to_string(pos->size()) + " are)"
                   : why;
    return;
  }
  const auto at = (*pos)[s.entry - 1];
  const std::size_t len = (*ids)[s.entry - 1].length;
  if (tx) {
    if (s.has_data && s.bytes.size() != len) {
      r.passed = false;
      r.detail = "Tx identifier " + std::to_string(s.entry) + " has " + std::to_string(len) +
                 " data bytes, " + std::to_string(s.bytes.size()) + " given";
      return;
    }
    auto& db = driver_->write_db()[at.db];
    if (s.force) db[at.offset + 1] = *s.force;
    if (s.has_data)
      std::copy(s.bytes.begin(), s.bytes.end(),
                db.begin() + static_cast<std::ptrdiff_t>(at.offset + 2));
    return;
  }
  r.passed = poll(
      s,
      [&](std::string& d) {
        const auto& db = driver_->read_db()[at.db];
        const auto got = std::span(db).subspan(at.offset + 1, 1 + len);
        d = "count_in " + std::to_string(got[0]) + " data " + hex_bytes(got.subspan(1));
        return (!s.count_in || got[0] == *s.count_in) &&
               (!s.has_data || s.pattern.matches(got.subspan(1)));
      },
      r.detail);
  if (!r.passed) r.detail = "got " + r.detail;
}

void Sim::slave_online(const Step& s, StepResult&) {
  plant_->set_slave_online(*plant_->slaves().at(*s.slave), s.on, now_, kOrigin);
}

void Sim::slave_alarm(const Step& s, StepResult&) {
  plant_->set_slave_alarm(*plant_->slaves().at(*s.slave), s.bytes, now_, kOrigin);
}

void Sim::slave_fault(const Step& s, StepResult&) {
  plant_->force_slave_fault(*plant_->slaves().at(*s.slave), s.action == Action::SlavePrmFault, s.on,
                            now_, kOrigin);
}

void Sim::field_write(const Step& s, StepResult& r) {
  plant::SlaveUnit& u = *plant_->slaves().at(*s.slave);
  if (!u.slave().write_inputs(s.offset, s.bytes)) {
    r.passed = false;
    r.detail = "the slave has " + std::to_string(u.slave().field_inputs().size()) + " input bytes";
  }
}

void Sim::expect_field(const Step& s, StepResult& r) {
  plant::SlaveUnit& u = *plant_->slaves().at(*s.slave);
  r.passed = poll(
      s,
      [&](std::string& d) {
        const auto out = u.slave().field_outputs();
        if (s.offset + s.pattern.size() > out.size()) {
          d = hex_bytes(out) + " (" + std::to_string(out.size()) + " output bytes)";
          return false;
        }
        const auto got = out.subspan(s.offset, s.pattern.size());
        d = hex_bytes(got);
        return s.pattern.matches(got);
      },
      r.detail);
  if (!r.passed) r.detail = "got " + r.detail;
}

std::uint8_t Sim::station_address(const Step& s) {
  return s.slave ? plant_->slaves().at(*s.slave)->config().address : gateway(s).gateway().address();
}

void Sim::power_cycle(const Step& s, StepResult&) {
  if (s.slave)
    plant_->power_cycle(*plant_->slaves().at(*s.slave), now_, kOrigin);
  else
    plant_->power_cycle(gateway(s), now_, kOrigin);
  drain_testers();
}

void Sim::reparameterize(const Step& s, StepResult&) {
  plant_->reparameterize(station_address(s), now_, kOrigin);
  drain_testers();
}

void Sim::set_addressed(const Step& s, StepResult&) {
  plant_->set_addressed(station_address(s), s.action == Action::MasterResume, now_, kOrigin);
  drain_testers();
}

void Sim::force_can_state(const Step& s, StepResult&) {
  plant_->force_can_state(gateway(s), s.can_state, now_, kOrigin);
  plant_->deliver(now_);
  drain_testers();
}

void Sim::drop_rx(const Step& s, StepResult&) {
  plant_->drop_rx(gateway(s), s.count, now_, kOrigin);
  drain_testers();
}

// The drive's Modbus fault registers 0..3 (docs/faults.md), one implementation.
void Sim::drive_fault(const Step& s, StepResult&) {
  auto& d = *plant_->drives().at(s.drive);
  std::uint16_t reg = faults::kDriveRestart, value = 1;
  if (s.action == Action::DriveMute) {
    reg = faults::kDriveMute;
    value = s.on ? 1 : 0;
  } else if (s.action == Action::DriveErrorBits) {
    reg = faults::kDriveErrorBits;
    value = s.bits;
  } else if (s.action == Action::DriveWarningBits) {
    reg = faults::kDriveWarningBits;
    value = s.bits;
  }
  plant_->set_drive_fault(d, reg, value, now_, kOrigin);
  drain_testers();
}

// ---------------------------------------------------------- the line in time (docs/faults.md)

void Sim::line_fault(const Step& s, StepResult& r) {
  if (!plant_->line_fault(s.line_fault, now_, kOrigin)) {
    r.passed = false;
    r.detail = "the plant refused the line fault (see the log)";
  }
}

// ------------------------------------------------- the CAN bus in time (docs/faults.md)

void Sim::can_fault(const Step& s, StepResult& r) {
  if (!plant_->can_fault(s.can_fault, now_, kOrigin)) {
    r.passed = false;
    r.detail = "the plant refused the CAN fault (see the log)";
  }
}

// The station's counters as an analyser on the line counts them (docs/profibus.md "Line
// statistics"), its live state and the measured bus cycle.
void Sim::expect_line(const Step& s, StepResult& r) {
  const fdl::LineStatistics* stats = plant_->line_statistics();
  const plant::TimedLine* line = plant_->timed_line();
  if (!stats || !line) {
    r.passed = false;
    r.detail = "the line has no baud rate ($.master.baud): nothing to count";
    return;
  }
  r.passed = poll(
      s,
      [&](std::string& d) {
        d.clear();
        bool all = true;
        auto add = [&](const std::string& text, bool ok) {
          d += (d.empty() ? "" : ", ") + text;
          all = all && ok;
        };
        if (s.station) {
          const fdl::StationCounters& c = stats->station(*s.station);
          for (const auto& [name, want] : s.counters) {
            const std::uint64_t got = c.*(fdl::station_counter(name)->member);
            add(name + " " + std::to_string(got), got == want);
          }
          if (!s.live.empty()) {
            const std::string live(fdl::to_string(stats->live(*s.station)));
            add("live " + live, live == s.live);
          }
        }
        if (s.bus_cycle_max_le) {
          const auto max = static_cast<std::uint64_t>(line->bus_cycle().max.count());
          add("bus cycle max " + std::to_string(max) + " µs", max <= *s.bus_cycle_max_le);
        }
        return all;
      },
      r.detail);
  if (!r.passed) r.detail = "got " + r.detail;
}

// ------------------------------------------------- the CAN bus in time (docs/can-bus.md)

// The bus's figures and one identifier's as GET /api/v1/status shows them (docs/can-bus.md "Seen
// from outside"); the report says what each measured.
void Sim::expect_bus(const Step& s, StepResult& r) {
  can::VirtualBus* vbus = plant_->buses().at(s.bus)->virtual_bus();
  const can::TimedBus* bus = vbus ? vbus->timed() : nullptr;
  if (!bus) {  // the parser allows only a bus with a bit rate
    r.passed = false;
    r.detail = "bus " + s.bus_name + " is not in time";
    return;
  }
  r.passed = poll(
      s,
      [&](std::string& d) {
        // A snapshot of the identifiers' statistics (TimedBus::identifiers()), kept for the checks.
        const auto ids = s.can_id ? bus->identifiers() : decltype(bus->identifiers()){};
        const can::TimedBus::IdStatistics* id = nullptr;
        if (s.can_id) {
          const auto it = ids.find(can::arbitration_key(*s.can_id, s.can_remote));
          if (it != ids.end()) id = &it->second;
        }
        const can::TimedBus::IdStatistics none{};
        const can::TimedBus::Confinement* node = nullptr;
        for (std::size_t n = 0; n < bus->nodes() && !s.bus_node.empty(); ++n)
          if (bus->present(n) && bus->name(n) == s.bus_node) node = &bus->confinement(n);
        d.clear();
        bool all = true;
        for (const auto& c : s.bus_checks) {
          d += (d.empty() ? "" : ", ") + std::string(c.figure->key) + " ";
          const bool of_id = c.figure->scope == BusScope::Identifier;
          const std::uint64_t frames = id ? id->frames : 0;
          if (of_id && frames < c.figure->frames_needed) {
            d += frames == 0 ? "none (no frame of " + can::ident_text(*s.can_id) + " yet)"
                             : "none (one frame of " + can::ident_text(*s.can_id) +
                                   " so far: it needs two)";
            all = false;
            continue;
          }
          if (c.figure->scope == BusScope::Node && !node) {
            d += "none (no node " + s.bus_node + " on the bus)";
            all = false;
            continue;
          }
          const double v = c.figure->get(*bus, of_id ? (id ? id : &none) : nullptr, node, now_);
          d += c.figure->text(v);
          all = all && c.bound.holds(v);
        }
        return all;
      },
      r.detail);
  if (!r.passed) r.detail = "got " + r.detail;
}

}  // namespace candp2::replay
