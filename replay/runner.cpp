#include "replay/runner.hpp"

#include <algorithm>
#include <functional>
#include <memory>
#include <optional>

#include "can/virtual_bus.hpp"
#include "common/hex.hpp"
#include "faults/can_fault.hpp"
#include "faults/drive_fault.hpp"
#include "gateway/gateway.hpp"
#include "profibus_sim/master/dp_master.hpp"
#include "profibus_sim/plc/page_driver.hpp"

namespace candp2::replay {

std::size_t RunResult::expectations() const {
  return static_cast<std::size_t>(std::count_if(
      steps.begin(), steps.end(), [](const StepResult& s) { return s.expectation || !s.passed; }));
}

std::size_t RunResult::failures() const {
  return static_cast<std::size_t>(
      std::count_if(steps.begin(), steps.end(), [](const StepResult& s) { return !s.passed; }));
}

namespace {

constexpr std::string_view kGatewayNode = "gateway";
constexpr std::string_view kTesterNode = "replay";
constexpr std::string_view kDrivePrefix = "drive:";  // endpoint names, as in the daemon
// Events at one instant before the runner declares a livelock (a timer that never moves on).
constexpr int kMaxEventsPerInstant = 100000;

std::string at_text(Time t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f ms", static_cast<double>(t.count()) / 1000.0);
  return buf;
}

// Log lines stamped with the virtual time.
class TimedLog final : public LogSink {
 public:
  TimedLog(const Time& now, LogLevel level, std::vector<LogEntry>& out)
      : now_(now), level_(level), out_(out) {}
  bool enabled(LogLevel level) const override { return level >= level_; }
  void write(LogLevel level, std::string_view component, std::string_view message) override {
    out_.push_back({now_, level, std::string(component), std::string(message)});
  }

 private:
  const Time& now_;
  LogLevel level_;
  std::vector<LogEntry>& out_;
};

// The gateway transmits through the fault layer (docs/faults.md), as in the daemon.
class FaultSink final : public can::FrameSink {
 public:
  explicit FaultSink(can::FrameSink& out) : out_(out) {}
  void send(const can::Frame& f) override {
    if (layer.pass_tx()) out_.send(f);
  }
  faults::CanFaultLayer layer;

 private:
  can::FrameSink& out_;
};

class Sim {
 public:
  Sim(const Scenario& sc, RunResult& res, LogLevel level)
      : sc_(sc),
        res_(res),
        log_(now_, level, res.log),
        gw_ep_(bus_.endpoint(std::string(kGatewayNode))),
        node_ep_(bus_.endpoint(std::string(kTesterNode))),
        master_(dp::MasterOptions{sc.master_address, milliseconds(1000)}, &log_) {
    bus_.add_tap([this](const can::Frame& f, Time t, std::string_view sender) {
      const bool from_gw = sender == kGatewayNode;
      if (from_gw) gw_frames_.push_back(res_.traffic.size());
      std::string drive;
      if (sender.starts_with(kDrivePrefix)) drive = sender.substr(kDrivePrefix.size());
      res_.traffic.push_back({t, f, from_gw, std::move(drive)});
    });
    const auto& g = sc.gateway;
    gw::GatewayOptions o;
    o.address = g.address;
    o.cia301_bootup = g.cia301_bootup;
    o.stored_wakeup_s = g.stored_wakeup_s;
    o.stored_sync_ms = g.stored_sync_ms;
    o.log = &log_;
    faults_ = std::make_unique<FaultSink>(*gw_ep_);
    gw_ = std::make_unique<gw::Gateway>(o, *faults_, now_);
    master_.add_slave(gw_->dp(), config::slave_parameters(g));
    if (sc.driver) setup_driver(*sc.driver);
    // Simulated drives on the same bus, wired as the daemon wires its drives (daemon/daemon.cpp).
    for (const auto& d : sc.drives) {
      drive::UnitekDrive::Options o;
      o.rx_id = d.rx_id;
      o.tx_id = d.tx_id;
      o.name = d.name;
      drives_.push_back({bus_.endpoint(std::string(kDrivePrefix) + d.name),
                         std::make_unique<faults::FaultyDrive>(o, &log_)});
    }
  }

  Time now() const { return now_; }

  // Runs every event at or before `until`, stopping early (at the event's time) when `stop`
  // holds; it is also checked before any event. Returns whether `stop` held.
  bool run_until(Time until, const std::function<bool()>& stop = {}) {
    if (stop && stop()) return true;
    int same_instant = 0;
    Time last = now_;
    while (true) {
      Time next = next_cycle_;
      if (auto d = gw_->next_deadline(); d && *d < next) next = std::max(*d, now_);
      for (const auto& n : drives_)
        if (auto d = n.drive->next_deadline(); d && *d < next) next = std::max(*d, now_);
      if (next > until) break;
      if (next == last && ++same_instant > kMaxEventsPerInstant) {
        log_.write(LogLevel::Error, "replay",
                   "gateway timer does not advance; stopping at " + at_text(next));
        break;
      }
      if (next != last) same_instant = 0;
      last = next;
      now_ = next;
      bus_.set_now(now_);
      advance_nodes();
      if (now_ >= next_cycle_) {
        master_.cycle(now_);
        drain();
        next_cycle_ += sc_.cycle;
        ++cycles_;
      }
      if (stop && stop()) return true;
    }
    now_ = std::max(now_, until);
    bus_.set_now(now_);
    advance_nodes();
    return stop ? stop() : false;
  }

  StepResult execute(const Step& s, std::size_t index);

 private:
  void setup_driver(const DriverSpec& d) {
    driver_.emplace(d.options, &log_);
    driver_->set_freigabe(d.freigabe);
    const std::size_t per = d.ids_per_db;
    driver_->write_config_db() = d.write_config_db.value_or(plc::make_config_chain(d.tx, per));
    driver_->read_config_db() = d.read_config_db.value_or(plc::make_config_chain(d.rx, per));
    driver_->read_db() = d.read_db.value_or(plc::make_data_chain(d.rx, per));
    if (d.write_db) {
      driver_->write_db() = *d.write_db;
    } else {
      auto chain = plc::make_data_chain(d.tx, per);
      const auto pos = plc::locate_data_entries(chain, d.tx, nullptr);
      for (std::size_t i = 0; pos && i < d.tx.size(); ++i) {
        auto& db = chain[(*pos)[i].db];
        db[(*pos)[i].offset + 1] = d.tx_force[i];
        std::copy(d.tx_data[i].begin(), d.tx_data[i].end(),
                  db.begin() + static_cast<std::ptrdiff_t>((*pos)[i].offset + 2));
      }
      driver_->write_db() = std::move(chain);
    }
    master_.set_program(&*driver_);
  }

  // The gateway's and the drives' timers up to now, then the frames they sent.
  void advance_nodes() {
    gw_->advance(now_);
    for (auto& n : drives_) n.drive->advance(now_, *n.ep);
    drain();
  }

  // Delivers queued frames until no node has any left (a drive answers a gateway frame at once).
  void drain() {
    auto& fl = faults_->layer;
    for (bool work = true; work;) {
      work = false;
      gw_->set_controller_status(fl.state(gw_ep_->bus_state()), fl.rx_lost(gw_ep_->rx_lost()));
      while (auto f = gw_ep_->receive()) {
        work = true;
        if (fl.pass_rx()) gw_->on_can_frame(*f, now_);
      }
      for (auto& n : drives_)
        while (auto f = n.ep->receive()) {
          work = true;
          n.drive->on_frame(*f, now_, *n.ep);
        }
      while (node_ep_->receive()) {
      }
    }
    gw_->set_controller_status(fl.state(gw_ep_->bus_state()), fl.rx_lost(gw_ep_->rx_lost()));
  }

  // Gateway frames from the cursor on, for failure messages.
  std::string frames_since_cursor(std::size_t max = 12) const {
    std::string s;
    std::size_t n = 0;
    for (std::size_t i = cursor_; i < gw_frames_.size(); ++i, ++n) {
      if (n == max) return s + " ... (" + std::to_string(gw_frames_.size() - cursor_) + " frames)";
      const auto& t = res_.traffic[gw_frames_[i]];
      s += (s.empty() ? "" : ", ") + can::format_candump(t.frame) + " @" + at_text(t.time);
    }
    return s.empty() ? "none" : s;
  }

  plc::DbChain* chain(Db db) {
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
  std::optional<std::vector<gw::page::IdEntry>> idents(bool tx, std::string* why) {
    auto raw =
        plc::parse_config_chain(tx ? driver_->write_config_db() : driver_->read_config_db(), why);
    if (!raw) return std::nullopt;
    std::vector<gw::page::IdEntry> out;
    for (const auto& r : *raw) {
      auto e = gw::page::decode_entry(r, why);
      if (!e) return std::nullopt;
      out.push_back(*e);
    }
    return out;
  }

  // Polls `check` (which fills `detail`) over the step's window, or once without one.
  bool poll(const Step& s, const std::function<bool(std::string&)>& check, std::string& detail) {
    const Time until = now_ + s.window.value_or(Duration{0});
    return run_until(until, [&] { return check(detail); });
  }

  const Scenario& sc_;
  RunResult& res_;
  Time now_{0};
  Time next_cycle_{0};
  std::uint64_t cycles_ = 0;
  TimedLog log_;
  can::VirtualBus bus_;
  std::unique_ptr<can::VirtualEndpoint> gw_ep_, node_ep_;
  std::unique_ptr<FaultSink> faults_;
  std::unique_ptr<gw::Gateway> gw_;
  dp::DpMaster master_;
  std::optional<plc::PageDriver> driver_;
  struct DriveNode {
    std::unique_ptr<can::VirtualEndpoint> ep;
    std::unique_ptr<faults::FaultyDrive> drive;
  };
  std::vector<DriveNode> drives_;
  std::vector<std::size_t> gw_frames_;  // indices into res_.traffic of the gateway's frames
  std::size_t cursor_ = 0;              // first gateway frame not yet matched or passed
};

StepResult Sim::execute(const Step& s, std::size_t index) {
  StepResult r;
  r.index = index;
  r.step = &s;
  r.expectation = s.expectation();
  r.log_begin = res_.log.size();
  if (s.at) {
    if (*s.at < now_) {
      r.passed = false;
      r.detail = "at_ms " + at_text(*s.at) + " lies before the current time " + at_text(now_) +
                 " (earlier steps took longer)";
      r.start = r.end = now_;
      r.log_end = res_.log.size();
      return r;
    }
    run_until(*s.at);
  }
  r.start = now_;
  auto& image = master_.image();
  switch (s.action) {
    case Action::Note:
      break;
    case Action::Advance:
      run_until(now_ + s.advance);
      break;
    case Action::Cycles: {
      const std::uint64_t target = cycles_ + s.cycles;
      run_until(next_cycle_ + sc_.cycle * (s.cycles - 1), [&] { return cycles_ >= target; });
      break;
    }
    case Action::Write:
      std::copy(s.bytes.begin(), s.bytes.end(), image.outputs.begin() + s.address);
      break;
    case Action::Inject:
      for (const auto& f : s.frames) node_ep_->send(f);
      drain();
      break;
    case Action::ExpectFrame: {
      const auto& p = s.frame_patterns.front();
      std::optional<std::size_t> hit;
      auto check = [&] {
        for (std::size_t i = cursor_; i < gw_frames_.size(); ++i)
          if (p.matches(res_.traffic[gw_frames_[i]].frame)) {
            hit = i;
            return true;
          }
        return false;
      };
      if (run_until(now_ + s.window.value_or(Duration{0}), check)) {
        const auto& t = res_.traffic[gw_frames_[*hit]];
        r.detail = can::format_candump(t.frame) + " at " + at_text(t.time);
        cursor_ = *hit + 1;
      } else {
        r.passed = false;
        r.detail = "no matching frame; the gateway sent: " + frames_since_cursor();
      }
      break;
    }
    case Action::ExpectFrames: {
      const std::size_t n = s.frame_patterns.size();
      run_until(now_ + s.window.value_or(Duration{0}),
                [&] { return gw_frames_.size() - cursor_ >= n; });
      bool ok = gw_frames_.size() - cursor_ >= n;
      for (std::size_t i = 0; ok && i < n; ++i)
        ok = s.frame_patterns[i].matches(res_.traffic[gw_frames_[cursor_ + i]].frame);
      if (ok) {
        r.detail = "last at " + at_text(n ? res_.traffic[gw_frames_[cursor_ + n - 1]].time : now_);
        cursor_ += n;
      } else {
        r.passed = false;
        r.detail = "the gateway sent: " + frames_since_cursor();
        cursor_ = std::min(gw_frames_.size(), cursor_ + n);
      }
      break;
    }
    case Action::ExpectNoFrame: {
      const auto& p = s.frame_patterns.front();
      run_until(now_ + s.window.value_or(Duration{0}));
      for (std::size_t i = cursor_; i < gw_frames_.size(); ++i) {
        const auto& t = res_.traffic[gw_frames_[i]];
        if (p.matches(t.frame)) {
          r.passed = false;
          r.detail = "the gateway sent " + can::format_candump(t.frame) + " at " + at_text(t.time);
          break;
        }
      }
      cursor_ = gw_frames_.size();
      break;
    }
    case Action::ExpectInput:
    case Action::ExpectOutput: {
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
      break;
    }
    case Action::ExpectDiag:
      r.passed = poll(
          s,
          [&](std::string& d) {
            const auto diag = gw_->dp().slave_diag(now_);
            d = hex_bytes(diag) + " (" + dp::describe_diag(diag) + ")";
            return s.pattern.matches(diag);
          },
          r.detail);
      if (!r.passed) r.detail = "got " + r.detail;
      break;
    case Action::ExpectDpState:
      r.passed = poll(
          s,
          [&](std::string& d) {
            d = std::string(dp::to_string(gw_->dp().state()));
            return gw_->dp().state() == s.dp_state;
          },
          r.detail);
      if (!r.passed) r.detail = "state is " + r.detail;
      break;
    case Action::Freigabe:
      driver_->set_freigabe(s.on);
      break;
    case Action::DbWrite: {
      auto* c = chain(s.db);
      if (s.db_index >= c->size() || s.offset + s.bytes.size() > (*c)[s.db_index].size()) {
        r.passed = false;
        r.detail = std::string(to_string(s.db)) + " has no bytes " + std::to_string(s.offset) +
                   ".." + std::to_string(s.offset + s.bytes.size() - 1) + " in DB " +
                   std::to_string(s.db_index);
        break;
      }
      auto& db = (*c)[s.db_index];
      std::copy(s.bytes.begin(), s.bytes.end(), db.begin() + static_cast<std::ptrdiff_t>(s.offset));
      break;
    }
    case Action::ExpectDb:
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
      break;
    case Action::SetTx:
    case Action::ExpectRx: {
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
        break;
      }
      const auto at = (*pos)[s.entry - 1];
      const std::size_t len = (*ids)[s.entry - 1].length;
      if (tx) {
        if (s.has_data && s.bytes.size() != len) {
          r.passed = false;
          r.detail = "Tx identifier " + std::to_string(s.entry) + " has " + std::to_string(len) +
                     " data bytes, " + std::to_string(s.bytes.size()) + " given";
          break;
        }
        auto& db = driver_->write_db()[at.db];
        if (s.force) db[at.offset + 1] = *s.force;
        if (s.has_data)
          std::copy(s.bytes.begin(), s.bytes.end(),
                    db.begin() + static_cast<std::ptrdiff_t>(at.offset + 2));
        break;
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
      break;
    }
    case Action::PowerCycle:
      gw_->power_cycle(now_);
      drain();
      break;
    case Action::Reparameterize:
      master_.reparameterize(gw_->address(), now_);
      break;
    case Action::MasterStop:
    case Action::MasterResume:
      master_.set_addressed(gw_->address(), s.action == Action::MasterResume, now_);
      break;
    case Action::ForceCanState:
      faults_->layer.force(s.can_state);
      drain();
      break;
    case Action::DropRx:
      faults_->layer.drop_next(s.count);
      break;
    case Action::DriveMute:
    case Action::DriveErrorBits:
    case Action::DriveWarningBits:
    case Action::DriveRestart: {
      // The drive's Modbus fault registers 0..3 (docs/faults.md), one implementation.
      auto& n = drives_[s.drive];
      const std::uint16_t reg = s.action == Action::DriveMute          ? faults::kDriveMute
                                : s.action == Action::DriveErrorBits   ? faults::kDriveErrorBits
                                : s.action == Action::DriveWarningBits ? faults::kDriveWarningBits
                                                                       : faults::kDriveRestart;
      const std::uint16_t value = s.action == Action::DriveMute      ? (s.on ? 1 : 0)
                                  : s.action == Action::DriveRestart ? 1
                                                                     : s.bits;
      n.drive->set_fault_register(reg, value, now_, *n.ep, "requested by a replay step");
      drain();
      break;
    }
    case Action::ExpectCounters:
      r.passed = poll(
          s,
          [&](std::string& d) {
            const auto st = gw_->status();
            const auto& fl = faults_->layer;
            bool all = true;
            d.clear();
            for (const auto& [name, want] : s.counters) {
              const std::uint32_t got = name == "irq_lost"        ? st.irq_lost
                                        : name == "msg_lost"      ? st.msg_lost
                                        : name == "rx_frames"     ? st.rx_frames
                                        : name == "tx_frames"     ? st.tx_frames
                                        : name == "tx_suppressed" ? fl.tx_suppressed()
                                                                  : fl.rx_suppressed();
              d += (d.empty() ? "" : ", ") + name + " " + std::to_string(got);
              all = all && got == want;
            }
            return all;
          },
          r.detail);
      if (!r.passed) r.detail = "got " + r.detail;
      break;
    case Action::ExpectRetValue:
      r.passed = poll(
          s,
          [&](std::string& d) {
            const auto v = static_cast<std::uint16_t>(driver_->ret_value());
            d = std::to_string(v) + " (" + std::string(plc::to_string(driver_->state())) + ")";
            return v == s.ret_value;
          },
          r.detail);
      if (!r.passed) r.detail = "got " + r.detail;
      break;
  }
  // A passed check reports when it held (with a window) and what it saw only when the pattern
  // had "??" bytes; otherwise the step line says it all.
  const bool polled = s.action == Action::ExpectInput || s.action == Action::ExpectOutput ||
                      s.action == Action::ExpectDiag || s.action == Action::ExpectDb ||
                      s.action == Action::ExpectRx || s.action == Action::ExpectRetValue ||
                      s.action == Action::ExpectDpState;
  if (r.passed && polled) {
    const bool wild =
        std::any_of(s.pattern.care.begin(), s.pattern.care.end(), [](bool c) { return !c; });
    std::string d = s.window ? "at " + at_text(now_) : "";
    if (wild) d += (d.empty() ? "" : ": ") + r.detail;
    r.detail = d;
  }
  r.end = now_;
  r.log_end = res_.log.size();
  return r;
}

}  // namespace

RunResult run(const Scenario& scenario, LogLevel level) {
  RunResult res;
  Sim sim(scenario, res, level);
  for (std::size_t i = 0; i < scenario.steps.size(); ++i)
    res.steps.push_back(sim.execute(scenario.steps[i], i + 1));
  res.end = sim.now();
  return res;
}

}  // namespace candp2::replay
