// Sim (replay/sim.hpp): the plant in virtual time, the tester's nodes, the traffic record and the
// execution of one step through the action table (replay/actions.hpp).
#include "replay/sim.hpp"

#include <algorithm>

#include "replay/actions.hpp"

namespace candp2::replay {

namespace {
constexpr std::string_view kTesterNode = "replay";
// Events at one instant before the runner declares a livelock (a timer that never moves on).
constexpr int kMaxEventsPerInstant = 100000;
}  // namespace

std::string at_text(Time t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f ms", static_cast<double>(t.count()) / 1000.0);
  return buf;
}

Sim::Sim(const Scenario& sc, RunResult& res, LogLevel level)
    : sc_(sc), res_(res), log_(now_, level, res.log) {
  plant::Options o;
  o.log = &log_;
  o.ignore_profibus = true;       // docs/replay-format.md: no serial line in virtual time
  o.first_cycle_at_start = true;  // the master cycles at 0, cycle, 2 × cycle, ...
  std::string error;
  plant_ = plant::Plant::build(sc.installation, std::move(o), now_, &error);
  if (!plant_) throw std::runtime_error(error);
  gw_frames_.resize(plant_->gateways().size());
  cursor_.resize(plant_->gateways().size());
  plant_->add_tap(this);
  for (auto& b : plant_->buses()) {
    testers_.push_back(b->virtual_bus()->endpoint(std::string(kTesterNode)));
    testers_.back()->set_tx_queue(can::kTesterTxQueue);
    // docs/can-bus.md "Error confinement": the tester listens like an analyser in listen-only
    // mode; a gateway alone on its bus with it is alone (nobody acknowledges its frames).
    testers_.back()->set_acknowledges(false);
  }
  if (sc.driver) setup_driver(*sc.driver);
}

Sim::~Sim() {
  plant_->remove_tap(this);
}

void Sim::on_can(const plant::CanRecord& r) {
  Traffic t;
  t.time = r.time;
  t.frame = r.frame;
  t.bus = r.bus;
  if (r.sender_kind == plant::SenderKind::Gateway) {
    t.from_gateway = true;
    t.gateway = plant_->gateways().at(r.sender_index)->name();
    gw_frames_.at(r.sender_index).push_back(res_.traffic.size());
  } else if (r.sender_kind == plant::SenderKind::Drive) {
    t.drive = plant_->drives().at(r.sender_index)->name();
  }
  res_.traffic.push_back(std::move(t));
}

// The tester's nodes only send: what they receive is discarded.
void Sim::drain_testers() {
  if (plant_->bus_changes() == drained_) return;  // nothing sent since
  drained_ = plant_->bus_changes();
  for (auto& t : testers_)
    while (t->receive()) {
    }
}

bool Sim::run_until(Time until, const std::function<bool()>& stop) {
  if (stop && stop()) return true;
  int same_instant = 0;
  Time last = now_;
  while (true) {
    const auto deadline = plant_->next_deadline();
    if (!deadline) break;
    const Time next = std::max(*deadline, now_);
    if (next > until) break;
    if (next == last && ++same_instant > kMaxEventsPerInstant) {
      log_.write(LogLevel::Error, "replay",
                 "gateway timer does not advance; stopping at " + at_text(next));
      break;
    }
    if (next != last) same_instant = 0;
    last = next;
    now_ = next;
    plant_->advance(now_);
    drain_testers();
    if (stop && stop()) return true;
  }
  now_ = std::max(now_, until);
  plant_->advance(now_);
  drain_testers();
  return stop ? stop() : false;
}

void Sim::setup_driver(const DriverSpec& d) {
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
  plant_->master().set_program(&*driver_);
}

bool Sim::poll(const Step& s, const std::function<bool(std::string&)>& check, std::string& detail) {
  const Time until = now_ + s.window.value_or(Duration{0});
  return run_until(until, [&] { return check(detail); });
}

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
  (this->*spec(s.action).run)(s, r);
  // A passed check reports when it held (with a window) and what it saw only when the pattern
  // had "??" bytes; otherwise the step line says it all.
  if (r.passed && spec(s.action).kind == Kind::ExpectPolled) {
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

}  // namespace candp2::replay
