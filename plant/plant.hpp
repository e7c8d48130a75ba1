// The plant (docs/architecture.md "The plant"): one configured installation, assembled once from
// the daemon's configuration — the CAN buses, every gateway behind its CAN fault layer, the
// simulated drives behind theirs, the DP master with its PLC process image and its cycle, and the
// stations of a PROFIBUS line. candp2d drives it from its event loop in real time; `candp2 replay`
// drives the very same object in virtual time.
//
// Pure like the engines it holds: no sockets, no threads, no clock, no global state. Time comes in
// through every entry point; the plant says when it next needs attention (next_deadline()) and
// does that work in advance(now). What needs the operating system is handed in by its driver: the
// CAN channels of SocketCAN and socketcand buses (Environment::open_channel), the drives'
// parameter files, the serial line's bytes (SlaveLine / MasterLine). Observers attach to the one
// tap (plant/tap.hpp); faults and other operator actions go through the control surface below,
// which logs each one and shows it on the tap as a note.
//
//   advance(now): gateways' and drives' timers → frames delivered between in-process endpoints →
//                 the master cycle when due (PLC program scan, Data_Exchanges) → frames delivered →
//                 cycle hooks
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "can/channel.hpp"
#include "can/virtual_bus.hpp"
#include "common/earliest.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "config/config.hpp"
#include "drive_sim/parameter_store.hpp"
#include "drive_sim/unitek_drive.hpp"
#include "faults/can_fault.hpp"
#include "faults/drive_fault.hpp"
#include "gateway/gateway.hpp"
#include "gsd_slave/gsd_slave.hpp"
#include "plant/control.hpp"
#include "plant/cycle_stats.hpp"
#include "plant/tap.hpp"
#include "plant/timed_line.hpp"
#include "plant/unit_views.hpp"
#include "plant/units.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::plant {

class MasterLine;
class SlaveLine;
class TimedLine;
class Plant;

// A gateway's stored wake-up and SYNC values (docs/dp-slave.md "User parameters": they survive a
// restart of the daemon when a state file is configured).
struct StoredValues {
  std::uint8_t wakeup_s = 0;
  std::uint16_t sync_ms = 0;
  friend bool operator==(const StoredValues&, const StoredValues&) = default;
};

// What the plant cannot do itself. candp2d opens sockets here; replay has no such buses.
class Environment {
 public:
  virtual ~Environment() = default;
  // The channel of `gateway` on a SocketCAN or socketcand bus; nullptr and *error when it cannot
  // be opened.
  virtual std::unique_ptr<can::Channel> open_channel(const config::BusConfig& bus,
                                                     const config::GatewayConfig& gateway,
                                                     std::string* error) = 0;
  // The parameter memory of a drive with a state_file; nullptr: none.
  virtual drive::ParameterStore* drive_store(const config::DriveConfig& /*drive*/) {
    return nullptr;
  }
};

struct Options {
  LogSink* log = nullptr;
  Environment* environment = nullptr;           // needed when a gateway is on a non-virtual bus
  std::map<std::uint8_t, StoredValues> stored;  // by DP address, from the state file
  // Replay: the `profibus` section is not used; the built-in master drives the gateways
  // in-process (docs/replay-format.md).
  bool ignore_profibus = false;
  // The first master cycle runs at build time (replay: cycles at 0, T, 2T, ...) instead of one
  // period later (candp2d, like its event loop's periodic timer).
  bool first_cycle_at_start = false;
  // The in-process master's DP services as the FDL telegrams they would be on a wire, on the
  // tap's on_dp() (docs/capture.md). Off unless a capture wants them: it costs an encoding per
  // service.
  bool wire_image = false;
  // The engines in time (the line, the buses) in steps: their events come due no closer than
  // this after the plant last advanced them, and the times computed for telegrams and frames stay
  // exact (docs/profibus.md "The line in time", docs/can-bus.md "In the plant": candp2d 1 ms;
  // replay and the tests 0, at every telegram's own bit and every frame's own microsecond).
  Duration step{0};
  // docs/can-bus.md "In the plant": when every bus in time only fills images (its receivers are
  // layer-2 gateways, nothing answers a frame or shows it live, no fault, every node error
  // active) and the line is not in time, the buses' events come due no closer than this after
  // the plant last advanced them (0 or not above `step`: `step`), and the buses are advanced
  // before each master cycle, so a frame still reaches the master's image at the same cycle
  // (candp2d 10 ms; replay and the tests 0).
  Duration image_bus_step{0};
  // The line in time: a master cycle due within a step starts at its own time (its grid point or
  // the end of the last rotation) when the plant wakes at most this much after that time; later,
  // the host kept the plant from running (candp2d with master.host_stall_ms 0): the cycle starts
  // when the plant woke, and the lateness reaches the world. 0: no limit (replay, the tests).
  Duration line_catch_up{0};
};

class Plant final : public ControlSurface {
 public:
  // Assembles the configuration at time `now` (the gateways' power-on). nullptr and *error
  // ("gateway \"g1\" on bus \"hw\" ($.buses.hw): cannot open ...") when a part cannot be built.
  // The configuration is not copied: it must outlive the plant.
  static std::unique_ptr<Plant> build(const config::DaemonConfig& config, Options options, Time now,
                                      std::string* error);
  ~Plant();
  Plant(const Plant&) = delete;
  Plant& operator=(const Plant&) = delete;

  // ---- time ---------------------------------------------------------------------------------
  // The earliest time something is due: the next master cycle, a gateway's or drive's timer, a
  // start or end of frame on a bus in time.
  std::optional<Time> next_deadline() const;
  // Runs everything due at or before `now`. A master cycle whose time passed more than one period
  // ago is not run late a second time: it counts as missed (cycle_stats(), logged when a run of
  // misses starts and ends).
  void advance(Time now);
  // Delivers frames queued between in-process endpoints until none is left (a drive answers a
  // gateway at once). True when something was delivered. candp2d calls it after every event.
  bool deliver(Time now);
  // Frames waiting on a gateway's channel with a descriptor (SocketCAN, socketcand client).
  void receive(std::size_t gateway, Time now);
  // The time stamp for frames that enter a virtual bus from outside the plant's entry points (a
  // socketcand client of the daemon's export). Never goes back.
  void set_now(Time now);
  Time now() const { return now_; }

  // ---- observers ----------------------------------------------------------------------------
  // Taps are called in the order they were added; not owned; must outlive the plant or be
  // removed.
  void add_tap(Tap* tap);
  void remove_tap(Tap* tap);
  // After every cycle period, whether the built-in master runs (not in profibus role slaves).
  void on_cycle(std::function<void(Time now)> hook) { cycle_hooks_.push_back(std::move(hook)); }

  // ---- control surface: plant/control.hpp (docs/faults.md) ----------------------------------
  bool force_can_state(GatewayUnit& g, std::uint16_t code, Time now,
                       std::string_view origin) override;
  void drop_rx(GatewayUnit& g, std::uint32_t n, Time now, std::string_view origin) override;
  void power_cycle(GatewayUnit& g, Time now, std::string_view origin) override;
  bool reparameterize(std::uint8_t address, Time now, std::string_view origin) override;
  void set_addressed(std::uint8_t address, bool addressed, Time now,
                     std::string_view origin) override;
  void set_drive_fault(DriveUnit& d, std::uint16_t index, std::uint16_t value, Time now,
                       std::string_view origin) override;
  void set_slave_online(SlaveUnit& s, bool online, Time now, std::string_view origin) override;
  bool set_slave_alarm(SlaveUnit& s, std::vector<std::uint8_t> bytes, Time now,
                       std::string_view origin) override;
  void force_slave_fault(SlaveUnit& s, bool prm, bool on, Time now,
                         std::string_view origin) override;
  void power_cycle(SlaveUnit& s, Time now, std::string_view origin) override;
  void note(std::string_view text, Time now) override;
  bool line_fault(const LineFault& fault, Time now, std::string_view origin) override;
  bool can_fault(const CanFault& fault, Time now, std::string_view origin) override;
  // The CAN faults on cue in force on `bus` at `now`: the nodes' unplugged and wrong_bitrate in
  // the order given, then the error frames and noise (docs/can-bus.md "Seen from outside").
  std::vector<CanFaultView> can_faults(const BusUnit& bus, Time now) const;

  // ---- inspection ---------------------------------------------------------------------------
  const config::DaemonConfig& config() const { return config_; }
  dp::DpMaster& master() { return *master_; }
  const dp::DpMaster& master() const { return *master_; }
  // False in profibus role slaves: an external master drives the gateways.
  bool master_runs() const { return master_cycles_; }
  std::vector<std::unique_ptr<BusUnit>>& buses() { return buses_; }
  // (A unit's engine is reached through GatewayUnit::gateway(), which marks it touched.)
  std::vector<std::unique_ptr<GatewayUnit>>& gateways() { return gateways_; }
  const std::vector<std::unique_ptr<GatewayUnit>>& gateways() const { return gateways_; }
  std::vector<std::unique_ptr<DriveUnit>>& drives() { return drives_; }
  std::vector<std::unique_ptr<SlaveUnit>>& slaves() { return slaves_; }
  const std::vector<std::unique_ptr<SlaveUnit>>& slaves() const { return slaves_; }
  SlaveUnit* slave(std::string_view name);
  SlaveUnit* slave_at(std::uint8_t dp_address);
  BusUnit* bus(std::string_view name);
  GatewayUnit* gateway(std::string_view name);
  GatewayUnit* gateway_at(std::uint8_t dp_address);
  DriveUnit* drive(std::string_view name);
  // The stored values of every gateway now (for the daemon's state file).
  std::map<std::uint8_t, StoredValues> stored() const;
  const CycleStats& cycle_stats() const { return cycle_stats_; }
  std::uint64_t cycles() const { return cycles_; }
  Duration cycle_period() const { return period_; }
  Time next_cycle() const { return next_cycle_; }
  // profibus role slaves / role master: the line's stations; nullptr otherwise.
  SlaveLine* slave_line() {
    touch_gateways();  // an external master's telegrams reach the gateways through it
    return slave_line_.get();
  }
  MasterLine* master_line() { return master_line_.get(); }
  // With $.master.baud: the in-process line in time (plant/timed_line.hpp), whose bus_cycle() is
  // the measured bus cycle; nullptr on the ideal line.
  TimedLine* timed_line() { return timed_line_.get(); }
  const TimedLine* timed_line() const { return timed_line_.get(); }
  // What an analyser counts on the PROFIBUS line (docs/profibus.md "Line statistics"): the timed
  // line's, or in role master the FDL master's; nullptr on an ideal line and in role slaves.
  const fdl::LineStatistics* line_statistics() const;
  LogSink* log_sink() const { return log_sink_; }
  // Frames sent and state changes on all virtual buses so far (a driver skips quiet buses).
  std::uint64_t bus_changes() const { return bus_changes_; }

 private:
  bool line_noise(Duration duration, std::string_view origin);
  // A node's unplugged or wrong_bitrate on cue, kept to end it after its for_ms and to show it
  // (docs/faults.md "CAN faults on cue").
  struct NodeFault {
    can::VirtualEndpoint* node = nullptr;
    const BusUnit* bus = nullptr;
    std::string name;  // the unit's, for the log
    CanFaultKind kind = CanFaultKind::None;
    std::optional<Time> until;  // nullopt: until a none
  };
  std::vector<NodeFault> node_faults_;
  std::optional<Time> node_faults_deadline() const;
  // Ends the node faults whose time is up by `now`.
  void end_node_faults(Time now);
  static void set_node_fault(can::VirtualEndpoint& node, CanFaultKind kind, bool on);
  friend class GatewayUnit;
  Plant(const config::DaemonConfig& config, Options options, Time now);
  bool build_parts(std::string* error);
  bool add_bus(const config::BusConfig& cfg, std::string* error);
  bool add_gateway(const config::GatewayConfig& cfg, std::string* error);
  bool add_drive(const config::DriveConfig& cfg, std::string* error);
  bool add_slave(const config::SlaveConfig& cfg, std::string* error);
  // The built-in master reaches an emulated station in-process (through its wire image when
  // Options::wire_image); `power cycled` stations start again with FDL_Status there.
  // On a timed line `max_tsdr` is the station's MaxTsdr at the line's rate (its GSD).
  // `unit`: the gateway whose engine the station is (its deadline cache is touched by requests).
  void add_in_process(dp::DpSlave& slave, dp::SlaveParameters params, std::uint8_t address,
                      std::optional<std::uint32_t> max_tsdr = std::nullopt,
                      GatewayUnit* unit = nullptr);
  void add_timed(dp::DpSlave& slave, dp::SlaveParameters params, std::uint8_t address,
                 std::optional<std::uint32_t> max_tsdr, GatewayUnit* unit);
  void restarted(std::uint8_t address);
  void touch_gateways();
  bool add_remote_stations(std::string* error);
  void run_timers(Time now);
  void run_cycle(Time now);
  // The time the master cycle due by now_ starts at (docs/profibus.md "The line in time"), if any.
  std::optional<Time> cycle_due() const;
  // Every start and end of frame due by `until`, and the answers.
  void settle_buses(Time until);
  // Options::image_bus_step: whether every bus in time only fills images (images_only_), asked
  // again at most once an image step (at the end of advance()) and false at once when a CAN
  // fault is set.
  void check_image_buses();
  bool image_bus(const BusUnit& bus) const;
  void log_misses(Time due, Time now, std::uint64_t missed);
  void tap_can(const BusUnit& bus, const can::Frame& frame, std::string_view sender, Time time);
  // The emulated gateway or drive whose endpoint is named `sender`, or SenderKind::Outside.
  std::pair<SenderKind, std::size_t> sender_of(std::string_view sender) const;
  // The same for a frame tapped on `bus`: its gateways' and drives' endpoints first.
  std::pair<SenderKind, std::size_t> known_sender(const BusUnit& bus,
                                                  std::string_view sender) const;
  void tap_note(std::string text, Time now);
  void tap_in_process(std::span<const std::uint8_t> telegram, Time time, std::uint32_t baud = 0);
  void tap_line(std::span<const std::uint8_t> telegram, bool from_emulation, Time time);
  std::string station_name(std::uint8_t address);

  const config::DaemonConfig& config_;
  Options options_;
  LogSink* log_sink_;
  Logger log_;
  Time now_{0};
  std::vector<std::unique_ptr<BusUnit>> buses_;
  std::vector<can::VirtualBus*> timed_buses_;  // the virtual buses with a bit rate
  Time buses_handled_{0};                      // when settle_buses() last advanced one
  bool images_only_ = false;                   // Options::image_bus_step applies
  Time images_checked_{0};                     // when check_image_buses() last looked
  // The timed buses' deadlines, asked again only of the buses whose deadline moved.
  mutable DeadlineTree bus_deadlines_;
  std::vector<std::uint32_t> due_buses_;  // settle_buses(): the timed buses due (indices)
  std::vector<std::unique_ptr<GatewayUnit>> gateways_;
  std::vector<std::unique_ptr<DriveUnit>> drives_;
  // sender_of(): the gateways' and drives' endpoint names, filled as they are added (the first
  // of a name wins, as a walk over gateways then drives would find it). A tapped frame from a
  // gateway or drive is found by its bus first (BusUnit::known_senders_).
  std::map<std::string, std::pair<SenderKind, std::size_t>, std::less<>> senders_;
  std::vector<std::unique_ptr<SlaveUnit>> slaves_;
  std::unique_ptr<dp::DpMaster> master_;
  std::unique_ptr<SlaveLine> slave_line_;
  std::unique_ptr<MasterLine> master_line_;
  std::unique_ptr<TimedLine> timed_line_;
  // The earliest of the gateways' deadlines: a touched gateway's is asked again, the others'
  // are kept (common/earliest.hpp).
  mutable EarliestDeadline gateway_deadlines_;
  // Frames and state changes on all virtual buses, and that count when deliver() last looked:
  // while it stands still and no gateway was touched, there is nothing to deliver.
  std::uint64_t bus_changes_ = 0, delivered_changes_ = ~std::uint64_t{0};
  std::vector<GatewayUnit*> touched_;  // gateways reached since deliver() last looked
  // A bit per gateway that may have frames or a controller state to take: its bus changed or it
  // was touched since deliver() last took them. deliver() looks at these, in the gateways' order,
  // not at every gateway (docs/can-bus.md "Performance").
  std::vector<std::uint64_t> to_deliver_;
  void mark_delivery(std::size_t gateway) {
    to_deliver_[gateway / 64] |= std::uint64_t{1} << (gateway % 64);
  }
  std::optional<Time> gateways_deadline() const;
  // The earliest deadline of the timed buses (bus_deadlines_).
  std::optional<Time> buses_deadline() const;
  std::vector<std::unique_ptr<dp::SlaveLink>> links_;  // the master's in-process links
  std::map<std::uint8_t, dp::SlaveLink*> wire_links_;  // fdl::WireImageLink by DP address
  std::vector<Tap*> taps_;
  std::vector<std::function<void(Time)>> cycle_hooks_;
  bool master_cycles_ = true;
  Duration period_{0};
  Time next_cycle_{0};
  bool grid_started_ = false;  // the first cycle ran (it anchors the grid)
  std::uint64_t cycles_ = 0;
  CycleStats cycle_stats_;
  struct MissRun {
    Time first, last;  // the first and the latest cycle that found missed grid points
    std::uint64_t count = 0;
  };
  std::optional<MissRun> miss_run_;  // a run of missed cycles being logged
};

}  // namespace candp2::plant
