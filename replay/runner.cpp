#include "replay/runner.hpp"

#include <algorithm>

#include "replay/sim.hpp"

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
  for (auto& b : plant_->buses())
    testers_.push_back(b->virtual_bus()->endpoint(std::string(kTesterNode)));
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
  switch (s.action) {
    case Action::Note:
      break;
    case Action::Advance:
      run_until(now_ + s.advance);
      break;
    case Action::Cycles: {
      const std::uint64_t target = plant_->cycles() + s.cycles;
      run_until(plant_->next_cycle() + sc_.cycle * (s.cycles - 1),
                [&] { return plant_->cycles() >= target; });
      break;
    }
    case Action::Inject:
    case Action::ExpectFrame:
    case Action::ExpectFrames:
    case Action::ExpectNoFrame:
      frames(s, r);
      break;
    case Action::Write:
    case Action::ExpectInput:
    case Action::ExpectOutput:
      image(s, r);
      break;
    case Action::ExpectDiag:
    case Action::ExpectDpState:
    case Action::ExpectCounters:
      gateway_state(s, r);
      break;
    case Action::SlaveOnline:
    case Action::SlaveAlarm:
    case Action::SlavePrmFault:
    case Action::SlaveCfgFault:
    case Action::FieldWrite:
    case Action::ExpectField:
      slave_step(s, r);
      break;
    case Action::Freigabe:
    case Action::DbWrite:
    case Action::ExpectDb:
    case Action::SetTx:
    case Action::ExpectRx:
    case Action::ExpectRetValue:
      driver(s, r);
      break;
    default:
      fault(s, r);
  }
  // A passed check reports when it held (with a window) and what it saw only when the pattern
  // had "??" bytes; otherwise the step line says it all.
  const bool polled = s.action == Action::ExpectInput || s.action == Action::ExpectOutput ||
                      s.action == Action::ExpectDiag || s.action == Action::ExpectDb ||
                      s.action == Action::ExpectRx || s.action == Action::ExpectRetValue ||
                      s.action == Action::ExpectDpState || s.action == Action::ExpectField;
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

RunResult run(const Scenario& scenario, LogLevel level) {
  RunResult res;
  Sim sim(scenario, res, level);
  for (std::size_t i = 0; i < scenario.steps.size(); ++i)
    res.steps.push_back(sim.execute(scenario.steps[i], i + 1));
  res.end = sim.now();
  return res;
}

}  // namespace candp2::replay
