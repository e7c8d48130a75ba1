// The replay runner's simulation (replay/runner.hpp): the scenario's installation as a plant in
// virtual time, the tester's nodes on every bus, the Page-Mode driver, the record of the traffic,
// and the execution of one step through its handler in the action table (replay/actions.hpp).
// Defined in replay/sim.cpp, the handlers in replay/steps.cpp. Internal to replay/.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "can/virtual_bus.hpp"
#include "plant/plant.hpp"
#include "plc/page_driver.hpp"
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

  // The handlers of the action table (replay/actions.cpp), one per action or family of actions.
  void nothing(const Step& s, StepResult& r);  // note
  void advance(const Step& s, StepResult& r);
  void cycles(const Step& s, StepResult& r);
  void write(const Step& s, StepResult& r);
  void inject(const Step& s, StepResult& r);
  void expect_frame(const Step& s, StepResult& r);
  void expect_frames(const Step& s, StepResult& r);
  void expect_no_frame(const Step& s, StepResult& r);
  void expect_image(const Step& s, StepResult& r);  // expect_input, expect_output
  void expect_diag(const Step& s, StepResult& r);
  void expect_dp_state(const Step& s, StepResult& r);
  void expect_counters(const Step& s, StepResult& r);
  void freigabe(const Step& s, StepResult& r);
  void db_write(const Step& s, StepResult& r);
  void expect_db(const Step& s, StepResult& r);
  void entry(const Step& s, StepResult& r);  // set_tx, expect_rx
  void expect_ret_value(const Step& s, StepResult& r);
  void power_cycle(const Step& s, StepResult& r);
  void reparameterize(const Step& s, StepResult& r);
  void set_addressed(const Step& s, StepResult& r);  // master_stop, master_resume
  void force_can_state(const Step& s, StepResult& r);
  void drop_rx(const Step& s, StepResult& r);
  void drive_fault(const Step& s, StepResult& r);  // drive_mute, drive_*_bits, drive_restart
  void slave_online(const Step& s, StepResult& r);
  void slave_alarm(const Step& s, StepResult& r);
  void slave_fault(const Step& s, StepResult& r);  // slave_prm_fault, slave_cfg_fault
  void field_write(const Step& s, StepResult& r);
  void expect_field(const Step& s, StepResult& r);
  void line_fault(const Step& s, StepResult& r);
  void can_fault(const Step& s, StepResult& r);
  void expect_line(const Step& s, StepResult& r);
  void expect_bus(const Step& s, StepResult& r);

 private:
  void on_can(const plant::CanRecord& r) override;
  void drain_testers();
  void setup_driver(const DriverSpec& d);
  plant::GatewayUnit& gateway(const Step& s) { return *plant_->gateways().at(s.gateway); }
  // Polls `check` (which fills `detail`) over the step's window, or once without one.
  bool poll(const Step& s, const std::function<bool(std::string&)>& check, std::string& detail);
  // The station a step is about: its DP slave (a gateway's or a generic slave's).
  dp::DpSlave& station(const Step& s);
  // The DP address of the station a step is about.
  std::uint8_t station_address(const Step& s);
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
  std::uint64_t drained_ = ~std::uint64_t{0};  // the plant's bus_changes() at the last drain
};

}  // namespace candp2::replay
