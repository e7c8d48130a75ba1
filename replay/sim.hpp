// The replay runner's simulation (replay/runner.hpp): the scenario's installation as a plant in
// virtual time, the tester's nodes on every bus, the Page-Mode driver, the record of the traffic,
// and the execution of one step. Internal to replay/.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "can/virtual_bus.hpp"
#include "plant/plant.hpp"
#include "profibus_sim/plc/page_driver.hpp"
#include "replay/runner.hpp"

namespace candp2::replay {

std::string at_text(Time t);

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

class Sim final : private plant::Tap {
 public:
  Sim(const Scenario& sc, RunResult& res, LogLevel level);
  ~Sim() override;
  Time now() const { return now_; }
  // Runs every event at or before `until`, stopping early (at the event's time) when `stop`
  // holds; it is also checked before any event. Returns whether `stop` held.
  bool run_until(Time until, const std::function<bool()>& stop = {});
  StepResult execute(const Step& s, std::size_t index);

 private:
  void on_can(const plant::CanRecord& r) override;
  void drain_testers();
  void setup_driver(const DriverSpec& d);
  plant::GatewayUnit& gateway(const Step& s) { return *plant_->gateways().at(s.gateway); }
  // Polls `check` (which fills `detail`) over the step's window, or once without one.
  bool poll(const Step& s, const std::function<bool(std::string&)>& check, std::string& detail);

  // The step families (replay/steps.cpp).
  void frames(const Step& s, StepResult& r);
  void image(const Step& s, StepResult& r);
  void gateway_state(const Step& s, StepResult& r);
  void driver(const Step& s, StepResult& r);
  void fault(const Step& s, StepResult& r);
  void slave_step(const Step& s, StepResult& r);
  // The station a step is about: its DP slave (a gateway's or a generic slave's).
  dp::DpSlave& station(const Step& s);
  std::string frames_since_cursor(std::size_t gateway, std::size_t max = 12) const;
  plc::DbChain* chain(Db db);
  std::optional<std::vector<gw::page::IdEntry>> idents(bool tx, std::string* why);

  const Scenario& sc_;
  RunResult& res_;
  Time now_{0};
  TimedLog log_;
  std::unique_ptr<plant::Plant> plant_;
  std::vector<std::unique_ptr<can::VirtualEndpoint>> testers_;  // per bus
  std::optional<plc::PageDriver> driver_;
  // Per gateway: indices into res_.traffic of its frames, and the first one not yet matched.
  std::vector<std::vector<std::size_t>> gw_frames_;
  std::vector<std::size_t> cursor_;
};

}  // namespace candp2::replay
