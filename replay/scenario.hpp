// A replay scenario (docs/replay-format.md, format "candp2-replay"): the installation the steps run
// against — version 1: one emulated gateway configured exactly like a daemon "gateways" entry, the
// simulated DP master's cycle time, optional simulated Unitek drives; version 2 may instead name a
// whole candp2d configuration ("config") with several gateways, drives and buses — an optional
// Page-Mode driver (the FB2 equivalent), and timed steps: write PLC outputs, inject CAN frames,
// advance time, expect frames / input bytes / diagnosis, inject faults. Steps that concern one
// gateway name it ("gateway") when the installation has more than one.
// Parsing is strict: every error names the file and the JSON path.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "can/frame.hpp"
#include "common/time.hpp"
#include "config/config.hpp"
#include "gateway/page_mode.hpp"
#include "plant/can_fault.hpp"
#include "plant/line_fault.hpp"
#include "plc/page_driver.hpp"
#include "profibus_sim/dp/dp_slave.hpp"
#include "replay/bus_figures.hpp"

namespace candp2::replay {

inline constexpr std::string_view kFormat = "candp2-replay";
inline constexpr int kVersion = 2;  // the newest version this candp2 reads (1 and 2)

// Hex bytes where "??" matches any byte: "00 33 ?? 00".
struct BytePattern {
  std::vector<std::uint8_t> bytes;
  std::vector<bool> care;  // false = "??"
  bool matches(std::span<const std::uint8_t> actual) const;
  std::size_t size() const { return bytes.size(); }
  std::string text() const;
};

// A frame in candump notation ("201#0102", "12345678#R"), "201#*" for any data frame on 201, "*"
// for any frame.
struct FramePattern {
  bool any = false;
  bool any_data = false;
  can::Frame frame;
  bool matches(const can::Frame& f) const;
  std::string text() const;
};

// FB2's data blocks (manual §6.5.1).
enum class Db : std::uint8_t { WriteConfig, ReadConfig, Write, Read };  // DB94, DB95, DB96, DB97
std::string_view to_string(Db db);

// The actions of a step, one row each in the action table (replay/actions.hpp), in its order.
enum class Action : std::uint8_t {
  Note,            // only a "note" line in the report
  Advance,         // advance_ms
  Cycles,          // cycles: run through the next n DP cycles
  Write,           // write: PLC output bytes (Q) at an address
  Inject,          // inject: CAN frame(s) from another node
  ExpectFrame,     // expect_frame: a matching frame from the gateway within the window
  ExpectFrames,    // expect_frames: exactly these next frames from the gateway, in order
  ExpectNoFrame,   // expect_no_frame: no matching frame from the gateway for the window
  ExpectInput,     // expect_input: PLC input bytes (I) at an address
  ExpectOutput,    // expect_output: PLC output bytes (Q) at an address (what a driver wrote)
  ExpectDiag,      // expect_diag: the 11 Slave_Diag bytes
  ExpectDpState,   // expect_dp_state: wait_prm / wait_cfg / data_exch
  Freigabe,        // freigabe: the page driver's FREIGABE bit
  DbWrite,         // db_write: bytes into one of the driver's data blocks
  ExpectDb,        // expect_db: bytes of one of the driver's data blocks
  SetTx,           // set_tx: force and/or data of Tx identifier n in WRITE_DB
  ExpectRx,        // expect_rx: count_in and/or data of Rx identifier n in READ_DB
  ExpectRetValue,  // expect_ret_value: the driver's RET_VALUE (manual table 6.5.7)
  // Faults (docs/faults.md).
  PowerCycle,      // power_cycle: the gateway restarts (Modbus control 1)
  Reparameterize,  // reparameterize: the master parameterizes again (control 2)
  MasterStop,      // master_stop: the master stops addressing the gateway (control 3)
  MasterResume,    // master_resume: it addresses it again (control 4)
  ForceCanState,   // force_can_state: real / warning / error-passive / bus-off (register 8193)
  DropRx,          // drop_rx: the next N received frames are lost, IRQ_LOST (register 8194)
  ExpectCounters,  // expect_counters: irq_lost, msg_lost, rx/tx_frames, rx/tx_suppressed
  // Drive faults (docs/faults.md; the drive's Modbus holding registers 0..3).
  DriveMute,         // drive_mute: the drive stops answering / answers again (register 0)
  DriveErrorBits,    // drive_error_bits: ERR_BITMAP1 0x8F bits 0..15 (register 1)
  DriveWarningBits,  // drive_warning_bits: ERR_BITMAP1 0x8F bits 16..31 (register 2)
  DriveRestart,      // drive_restart: power-on state, cyclic requests lost (register 3)
  // Generic slaves (docs/slaves.md; the slave's fault registers and field side on Modbus).
  SlaveOnline,    // slave_online: false = it leaves the bus (no answer at all), true = it is back
  SlaveAlarm,     // slave_alarm: a diagnosis alarm (device-related Ext_Diag bytes; "" clears)
  SlavePrmFault,  // slave_prm_fault: every Set_Prm refused while true
  SlaveCfgFault,  // slave_cfg_fault: every Chk_Cfg refused while true
  FieldWrite,     // field_write: input bytes the slave reports, from an offset
  ExpectField,    // expect_field: output bytes the slave applies, from an offset
  // The line in time (docs/faults.md "Line faults", docs/profibus.md "Line statistics").
  LineFault,   // line_fault: a station's answers corrupt/silent/late/double_address, or noise
  ExpectLine,  // expect_line: a station's line counters and live state, the bus cycle
  // The CAN bus in time (docs/faults.md "CAN faults on cue", docs/can-bus.md).
  CanFault,  // can_fault: error frames on a node or an identifier, unplugged, wrong bit rate, noise
  // The CAN bus in time (docs/can-bus.md "Seen from outside").
  ExpectBus,  // expect_bus: a timed bus's load, frames, lost frames; an identifier's latency
  Count,      // not an action: the number of actions (the action table's size)
};
std::string_view to_string(Action a);

struct Step {
  Action action = Action::Note;
  std::string path;  // "$.steps[3]"
  std::string note;
  std::optional<Duration> at;      // at_ms: run the step at this absolute time
  std::optional<Duration> window;  // within_ms (expectations) / for_ms (expect_no_frame)
  Duration advance{0};
  std::uint32_t cycles = 0;
  std::uint16_t address = 0;
  std::vector<std::uint8_t> bytes;  // write, db_write, set_tx data
  BytePattern pattern;              // expect_input/output/diag/db, expect_rx data
  std::vector<can::Frame> frames;   // inject
  std::vector<FramePattern> frame_patterns;
  dp::SlaveState dp_state = dp::SlaveState::DataExch;
  bool on = true;
  Db db = Db::Write;
  std::size_t db_index = 0;  // which DB of the chain
  std::size_t offset = 0;
  std::size_t entry = 0;                 // set_tx / expect_rx: identifier number, 1-based
  std::optional<std::uint8_t> force;     // set_tx
  std::optional<std::uint8_t> count_in;  // expect_rx
  bool has_data = false;                 // set_tx / expect_rx carry data
  std::uint16_t ret_value = 0;
  std::uint16_t can_state = 0;  // force_can_state: 0 real, 1 warning, 2 error-passive, 3 bus-off
  std::uint32_t count = 0;      // drop_rx
  std::size_t drive = 0;        // drive_*: index into Scenario::drives
  std::string drive_name;       // drive_*: its name (for the report)
  std::uint16_t bits = 0;       // drive_error_bits / drive_warning_bits
  // expect_counters: name → value, names as the Modbus status block (docs/modbus.md).
  std::vector<std::pair<std::string, std::uint32_t>> counters;
  // line_fault (docs/replay-format.md): the fault as the plant takes it, kind parsed once.
  plant::LineFault line_fault;
  // can_fault (docs/replay-format.md): the fault as the plant takes it.
  plant::CanFault can_fault;
  // expect_line: the station's DP address (none: only the bus cycle), the bus cycle's bound in µs.
  std::optional<std::uint8_t> station;
  std::optional<Duration> duration;
  std::string live;  // expect_line: "ok", "missing", "phantom", "none"; empty: not checked
  std::optional<std::uint64_t> bus_cycle_max_le;
  // expect_bus: the identifier whose figures it checks (its remote frames apart) and the figures'
  // ranges (replay/bus_figures.hpp); the bus is `bus`, named `bus_name`.
  std::optional<can::Ident> can_id;
  bool can_remote = false;
  std::string bus_node;  // expect_bus: the node whose counters it checks ("gw:NAME")
  std::vector<BusCheck> bus_checks;
  // The gateway the step concerns (index into Scenario::installation.gateways) and, for inject,
  // the bus the frames enter (index into installation.buses).
  std::size_t gateway = 0;
  std::string gateway_name;
  std::size_t bus = 0;
  std::string bus_name;
  // A step about a generic slave instead ("slave": NAME; index into installation.slaves).
  std::optional<std::size_t> slave;
  std::string slave_name;

  bool expectation() const;      // the action table's kind (replay/actions.hpp)
  std::string describe() const;  // one line for the report
  std::string describe_action() const;
};

// The Page-Mode driver of a scenario (key "page_driver").
struct DriverSpec {
  plc::PageDriverOptions options;
  bool freigabe = true;
  std::vector<gw::page::IdEntry> tx, rx;
  std::vector<std::uint8_t> tx_force;              // initial force per Tx identifier
  std::vector<std::vector<std::uint8_t>> tx_data;  // initial data per Tx identifier
  std::size_t ids_per_db = 0;                      // split the DBs (DD chains); 0 = one DB each
  // Raw data blocks replacing the ones built from tx/rx (hex per DB).
  std::optional<plc::DbChain> write_config_db, read_config_db, write_db, read_db;
};

struct Scenario {
  std::string file;
  int version = 1;
  std::string name;
  std::string description;
  Duration cycle = milliseconds(10);
  std::uint8_t master_address = 1;
  // What the steps run against, as candp2d would run it: built from "gateway", "drives",
  // "cycle_ms" and "master_address" (one virtual bus named after the gateway's bus, "can0" by
  // default), or loaded from "config" (version 2; `config_file` is its path). Replay opens none of
  // its sockets and serial lines (docs/replay-format.md).
  config::DaemonConfig installation;
  std::string config_file;
  // The Page-Mode driver and the gateway it drives (index into installation.gateways).
  std::optional<DriverSpec> driver;
  std::size_t driver_gateway = 0;
  std::vector<Step> steps;
  std::vector<config::ConfigError> warnings;

  // The only gateway of a version-1 scenario (the first one of a configuration).
  const config::GatewayConfig& gateway() const { return installation.gateways.at(0); }
  const std::vector<config::DriveConfig>& drives() const { return installation.drives; }
};

config::Result<Scenario> parse_scenario(const std::string& text, const std::string& file);
config::Result<Scenario> load_scenario(const std::string& path);

}  // namespace candp2::replay
