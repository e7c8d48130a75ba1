// A simulated Unitek DS/BAMOCAR servo drive on the CAN bus (docs/drive-simulator.md).
//
// Pure: frames come in through on_frame(), replies go out through a can::FrameSink, the caller
// passes the time. No clock, no sockets, no files (parameters persist through a ParameterStore).
// Deterministic: the same calls with the same times give the same frames, however the caller
// slices time into advance() calls (the motor model runs on a fixed 1 ms grid of the caller's
// time; see README.md "Time").
//
// Protocol (Unitek CAN manual V1 1011 and FW 378 short description, see regid_protocol.hpp):
//  - commands on the Rx ID (default 0x201) write registers; they are never answered;
//  - REGID 0x3D reads: time byte 0x00 once, 1..254 ms cyclic (up to 8 entries), 0xFF suspends;
//  - MODE 0x51 bit 2 disables the drive, bit 4 sends STATUS 0x40 when (status & mask 0x52)
//    changes; 0x68/0x69 change the Rx/Tx identifiers; 0x84 writes the EEPROM.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "can/channel.hpp"
#include "can/frame.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "drive_sim/parameter_store.hpp"
#include "drive_sim/regid_protocol.hpp"
#include "drive_sim/registers.hpp"

namespace candp2::drive {

// CAN manual "Setting CAN-BUS": receive address RPDO1 0x201..0x27F (default 0x201), transmit
// address TPDO1 0x181..0x1FF (default 0x181).
inline constexpr std::uint32_t kDefaultRxId = 0x201;
inline constexpr std::uint32_t kDefaultTxId = 0x181;
inline constexpr std::uint32_t kRxIdMin = 0x201, kRxIdMax = 0x27F;
inline constexpr std::uint32_t kTxIdMin = 0x181, kTxIdMax = 0x1FF;

// FW 378 §8 / German manual example 9: at most 8 time-triggered reply requests.
inline constexpr std::size_t kMaxCyclicEntries = 8;

// STATUS (0x40) bits the simulator sets, as the CAN manual examples 8-10 name them.
namespace status {
inline constexpr std::uint32_t kEnabled = 1u << 0;       // Ena, drive enabled (example 8)
inline constexpr std::uint32_t kLimitPlus = 1u << 2;     // Lim+ (example 9-1: 0x3185)
inline constexpr std::uint32_t kLimitMinus = 1u << 3;    // Lim- (example 9-1: 0x3189)
inline constexpr std::uint32_t kPosControl = 1u << 7;    // P-N position control (example 8)
inline constexpr std::uint32_t kSpeedControl = 1u << 8;  // N-I speed control (example 8)
inline constexpr std::uint32_t kCalibrated = 1u << 12;   // Cal, reference run done (example 9)
inline constexpr std::uint32_t kInTolerance = 1u << 13;  // Tol, position in window (example 9)
}  // namespace status

// MODE (0x51) bits (CAN manual examples 2 and 9).
namespace mode {
inline constexpr std::uint32_t kDisable = 1u << 2;      // example 2: 0x0004 inhibits the drive
inline constexpr std::uint32_t kStatusEvent = 1u << 4;  // example 9: 0x0010 status on event
}  // namespace mode

enum class ControlMode : std::uint8_t { Speed, Position, Torque };
std::string_view to_string(ControlMode m);

enum class LimitSwitch : std::uint8_t { Plus, Minus };

struct CyclicEntry {
  enum class State : std::uint8_t { Free, Active, Suspended };
  State state = State::Free;
  std::uint8_t regid = 0;
  std::uint8_t period_ms = 0;  // 1..254
  Time due{0};                 // next transmission (Active only)
};

class UnitekDrive {
 public:
  struct Options {
    std::uint32_t rx_id = kDefaultRxId;  // 11-bit; overridden by a stored 0x68
    std::uint32_t tx_id = kDefaultTxId;  // 11-bit; overridden by a stored 0x69
    std::string name = "drive";          // log component "drive:<name>"
    // The CAN manual V1 1011 (English) examples 8, 9, 9.2 and 12 show STATUS 0x40 and
    // ERR_BITMAP1 0x8F as 16-bit replies (DLC 4); the FW 378 register list and short description
    // make both 32-bit (DLC 6), as do the German manual's examples 10 and 10-1. Default: FW 378.
    bool status_16bit = false;
    // How long the simulated reference run (0x78) searches once the motor stands still.
    Duration reference_run_time = milliseconds(500);
  };

  // Throws std::invalid_argument when an identifier is not an 11-bit value or the reference run
  // time is negative. Loads the stored parameters from `store` when given (errors are logged).
  explicit UnitekDrive(Options options, LogSink* log = nullptr, ParameterStore* store = nullptr);
  UnitekDrive() : UnitekDrive(Options{}) {}

  // A frame seen on the bus at `now`. Frames on other identifiers are ignored; replies go to `out`.
  void on_frame(const can::Frame& frame, Time now, can::FrameSink& out);
  // Runs the motor model and the cyclic transmissions up to `now`.
  void advance(Time now, can::FrameSink& out);
  // When advance() next has something to do (a cyclic reply is due or the motor is moving);
  // nullopt when nothing will happen until the next frame or input change.
  std::optional<Time> next_deadline() const;

  // Simulated hardware inputs (what NDrive shows as digital inputs); each may trigger a status
  // message (MODE bit 4).
  void set_enable_input(bool on, Time now, can::FrameSink& out);  // I_FRG 0xE8 (example 11)
  void set_limit_switch(LimitSwitch which, bool active, Time now, can::FrameSink& out);
  // Sets ERR_BITMAP1 (0x8F); any error bit drops ready (0xE2) and disables the drive.
  // REGID 0x8E (FUN_ERRCANCEL) clears it again.
  void set_errors(std::uint32_t bitmap, Time now, can::FrameSink& out);
  void set_power_ok(bool on, Time now, can::FrameSink& out);  // DC bus present (ready 0xE2)

  // Register contents as a read would send them (16-bit registers zero-extended). Computed
  // registers reflect the model as of the last on_frame()/advance()/input call.
  std::uint32_t reg(std::uint8_t regid) const { return regs_[regid]; }
  std::int32_t reg_signed(std::uint8_t regid) const;
  std::uint32_t rx_id() const { return regs_[reg::kCanIdRx]; }
  std::uint32_t tx_id() const { return regs_[reg::kCanIdTx]; }
  std::uint32_t status() const { return regs_[reg::kStatus]; }
  bool enabled() const;
  bool referenced() const { return referenced_; }
  bool referencing() const { return referencing_; }
  ControlMode control_mode() const { return control_; }
  std::int32_t position_actual() const;
  std::int16_t speed_actual() const;
  std::span<const CyclicEntry, kMaxCyclicEntries> cyclic_entries() const { return cyclic_; }
  const Options& options() const { return options_; }
  // What an EEPROM write (0x84) stores: every RW register except the set point SPEED_CMD 0x31.
  StoredParameters parameters() const;
  Width reply_width(std::uint8_t regid) const;

 private:
  struct Demand {
    std::int64_t target;  // speed target, milli-num
    std::int64_t acc;     // milli-num per ms away from zero
    std::int64_t dec;     // milli-num per ms towards zero
  };

  void start_clock(Time now);
  void run_until(Time now, can::FrameSink& out);
  bool steady() const;
  Demand demand() const;
  void step_tick();
  void integrate(std::int64_t ticks);
  void finish_reference_run();
  void update_outputs();
  void check_events(can::FrameSink& out);
  std::uint32_t compute_status() const;
  bool in_tolerance() const;
  std::int64_t position_counts() const;
  std::int64_t counts_per_tick_per_num() const;

  void handle_command(const Command& command, Time now, can::FrameSink& out);
  void handle_read(std::uint8_t regid, std::uint8_t time, Time now, can::FrameSink& out);
  void handle_write(const Command& command, can::FrameSink& out);
  void handle_function(std::uint8_t regid, std::uint32_t value);
  void set_control(ControlMode m);
  void send_register(std::uint8_t regid, can::FrameSink& out);
  void apply_parameters(const StoredParameters& params, std::string_view origin);
  std::optional<std::size_t> earliest_due() const;

  Options options_;
  Logger log_;
  ParameterStore* store_;
  std::array<std::uint32_t, 256> regs_{};
  std::array<CyclicEntry, kMaxCyclicEntries> cyclic_{};

  // Time: the model runs on ticks at whole milliseconds of the caller's time.
  bool clock_started_ = false;
  Time now_{0};
  std::int64_t tick_ms_ = 0;  // last tick processed

  // Motor model (README.md "Motor model").
  ControlMode control_ = ControlMode::Speed;
  std::int64_t speed_milli_ = 0;  // actual speed in 1/1000 num (32767 num = 100 %)
  std::int64_t pos_fine_ = 0;     // actual position in 1/kPosDen counts
  bool referencing_ = false;
  bool referenced_ = false;
  std::int64_t reference_ticks_ = 0;  // standstill ticks spent searching
  std::optional<ControlMode> after_reference_;

  // Inputs.
  bool power_ok_ = true;
  bool enable_input_ = true;
  bool limit_plus_ = false;
  bool limit_minus_ = false;
  std::uint32_t errors_ = 0;

  // Event reporting (MODE bit 4).
  std::uint32_t status_basis_ = 0;
  std::uint32_t errors_basis_ = 0;
};

// Formats the frame for logs: "201#3D4000".
std::string describe(const can::Frame& frame);

}  // namespace candp2::drive
