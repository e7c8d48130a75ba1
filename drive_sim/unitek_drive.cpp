#include "drive_sim/unitek_drive.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace candp2::drive {

namespace {

// German manual §7.1 "Drehzahl": speed values are ±32767 num = ±100 % = ±N max (0xC8, rpm).
constexpr std::int64_t kFullScale = 32767;
constexpr std::int64_t kMilli = 1000;  // the model keeps speed in 1/1000 num
// German manual §7.1 "Position": 65536 position counts per motor revolution.
constexpr std::int64_t kCountsPerRev = 65536;
// Position is kept in fine units of 1/kPosDen count, so that one 1 ms tick at v num moves it by
// exactly v * N max * 65536 fine units (v/32767 * Nmax rev/min / 60000 ms/min * 65536 counts/rev).
constexpr std::int64_t kPosDen = kFullScale * 60000;
// POS_ACTUAL (0x6D) is a signed 32-bit register: the model wraps like an int32 counter.
constexpr std::int64_t kPosHalfRange = (std::int64_t{1} << 31) * kPosDen;
// The rate used when a ramp time is 0 ms: any speed change completes within one tick.
constexpr std::int64_t kInstant = 2 * kFullScale * kMilli;
// Largest number of ticks integrated at once in steady state (keeps int64 sums in range).
constexpr std::int64_t kMaxJumpTicks = 16384;
// FW 378 short description §5, TORQUE_COMMAND: +100 % torque = 21845 num (±32767 = ±150 %).
constexpr std::int64_t kTorque100 = 21845;
// 0xF5 VO_Less_N0 "message speed < 1 %": 1 % of 32767 num.
constexpr std::int64_t kLessN0 = 328;
constexpr std::int64_t kUsPerTick = 1000;  // the model's tick: 1 ms

std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  std::int64_t q = a / b;
  if ((a % b != 0) && ((a < 0) != (b < 0))) --q;
  return q;
}

std::int64_t to_num(std::int64_t milli) {
  return milli >= 0 ? (milli + kMilli / 2) / kMilli : -((-milli + kMilli / 2) / kMilli);
}

// Ramp registers hold the time in ms for a change of 100 % (CAN manual example 6: "1000 ms
// acceleration"); only the low 16 bits count (the list's default 0x00010064 = 100 ms).
std::int64_t ramp_rate(std::uint32_t reg_value) {
  const std::int64_t ms = reg_value & 0xFFFFu;
  return ms == 0 ? kInstant : (kFullScale * kMilli) / ms;
}

std::int64_t wrap_position(std::int64_t fine) {
  if (fine >= kPosHalfRange) fine -= 2 * kPosHalfRange;
  if (fine < -kPosHalfRange) fine += 2 * kPosHalfRange;
  return fine;
}

// One tick of a speed ramp: `acc` applies while |speed| grows, `dec` while it shrinks; a change
// of sign first decelerates to zero.
std::int64_t ramp(std::int64_t cur, std::int64_t target, std::int64_t acc, std::int64_t dec) {
  if (cur == target) return cur;
  if (cur > 0 && target < cur) return std::max(std::max<std::int64_t>(target, 0), cur - dec);
  if (cur < 0 && target > cur) return std::min(std::min<std::int64_t>(target, 0), cur + dec);
  return target > cur ? std::min(target, cur + acc) : std::max(target, cur - acc);
}

std::int16_t as_i16(std::uint32_t v) {
  return static_cast<std::int16_t>(v & 0xFFFFu);
}
std::uint32_t from_i16(std::int64_t v) {
  return static_cast<std::uint16_t>(static_cast<std::int16_t>(v));
}

std::string hex(std::uint32_t v, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%0*X", digits, v);
  return buf;
}

// What the EEPROM write (0x84) stores: the RW registers of the list, except SPEED_CMD (0x31). The
// list marks it RW, but it is a set point: a drive restarted from its parameter memory must not
// start turning by itself.
bool is_persistent(const RegisterInfo& info) {
  return info.access == Access::RW && info.regid != reg::kSpeedCmd;
}

std::string reg_name(std::uint8_t regid) {
  return hex(regid, 2) + " (" + std::string(register_info(regid).name) + ")";
}

}  // namespace

std::string_view to_string(ControlMode m) {
  switch (m) {
    case ControlMode::Speed:
      return "speed";
    case ControlMode::Position:
      return "position";
    case ControlMode::Torque:
      return "torque";
  }
  return "?";
}

std::string describe(const can::Frame& frame) {
  return can::format_candump(frame);
}

UnitekDrive::UnitekDrive(Options options, LogSink* log, ParameterStore* store)
    : options_(std::move(options)), log_(log, "drive:" + options_.name), store_(store) {
  if (options_.rx_id > can::kMaxStdId || options_.tx_id > can::kMaxStdId)
    throw std::invalid_argument("drive Rx/Tx identifiers must be 11-bit values (0x000..0x7FF)");
  if (options_.reference_run_time.count() < 0)
    throw std::invalid_argument("drive reference run time must not be negative");
  for (const RegisterInfo& info : register_table()) regs_[info.regid] = info.default_value;
  regs_[reg::kCanIdRx] = options_.rx_id;
  regs_[reg::kCanIdTx] = options_.tx_id;
  if (store_) {
    std::string error;
    if (auto params = store_->load(&error))
      apply_parameters(*params, "state store");
    else if (!error.empty())
      log_.error(error + "; starting with the register list's defaults");
  }
  // The list's POS_ACTUAL default (a reading of a real drive) is where the simulated motor stands.
  pos_fine_ =
      static_cast<std::int64_t>(static_cast<std::int32_t>(regs_[reg::kPosActual])) * kPosDen;
  update_outputs();
  status_basis_ = regs_[reg::kStatus];
  errors_basis_ = errors_;
  log_.info("Unitek drive: Rx ID " + hex(rx_id(), 3) + ", Tx ID " + hex(tx_id(), 3) +
            (options_.status_16bit ? ", 16-bit status replies (manual V1 1011)" : ""));
}

std::int32_t UnitekDrive::reg_signed(std::uint8_t regid) const {
  if (register_info(regid).width == Width::W16) return as_i16(regs_[regid]);
  return static_cast<std::int32_t>(regs_[regid]);
}

bool UnitekDrive::enabled() const {
  return power_ok_ && errors_ == 0 && enable_input_ && !(regs_[reg::kMode] & mode::kDisable);
}

std::int32_t UnitekDrive::position_actual() const {
  return static_cast<std::int32_t>(regs_[reg::kPosActual]);
}

std::int16_t UnitekDrive::speed_actual() const {
  return as_i16(regs_[reg::kSpeedActual]);
}

Width UnitekDrive::reply_width(std::uint8_t regid) const {
  // FW 378 short description §3: upper byte 01 in REGID 0xDC makes every reply 6 bytes long.
  if (((regs_[reg::kDefineDac] >> 8) & 0xFFu) == 0x01) return Width::W32;
  if (options_.status_16bit && (regid == reg::kStatus || regid == reg::kErrBitmap))
    return Width::W16;
  return register_info(regid).width;
}

StoredParameters UnitekDrive::parameters() const {
  StoredParameters p;
  for (const RegisterInfo& info : register_table())
    if (is_persistent(info)) p.values[info.regid] = regs_[info.regid];
  return p;
}

void UnitekDrive::apply_parameters(const StoredParameters& params, std::string_view origin) {
  std::size_t applied = 0;
  for (const auto& [regid, value] : params.values) {
    const RegisterInfo& info = register_info(regid);
    if (!is_persistent(info)) {
      log_.warn("stored value for " + reg_name(regid) + " ignored: not a stored parameter");
      continue;
    }
    if (info.width == Width::W16 && value > 0xFFFFu) {
      log_.warn("stored value for " + reg_name(regid) + " ignored: wider than 16 bits");
      continue;
    }
    if ((regid == reg::kCanIdRx && (value < kRxIdMin || value > kRxIdMax)) ||
        (regid == reg::kCanIdTx && (value < kTxIdMin || value > kTxIdMax))) {
      log_.warn("stored CAN identifier " + reg_name(regid) + " = " + hex(value, 3) +
                " ignored: outside the manual's range");
      continue;
    }
    regs_[regid] = value;
    ++applied;
  }
  log_.info("loaded " + std::to_string(applied) + " parameters from the " + std::string(origin));
}

// ---------------------------------------------------------------------------------------------
// Time

void UnitekDrive::start_clock(Time now) {
  clock_started_ = true;
  now_ = now;
  tick_ms_ = floor_div(now.count(), kUsPerTick);
}

void UnitekDrive::advance(Time now, can::FrameSink& out) {
  if (!clock_started_) {
    start_clock(now);
    return;
  }
  if (now < now_) {
    log_.debug("time went backwards (" + std::to_string(now.count()) + " us < " +
               std::to_string(now_.count()) + " us); ignored");
    return;
  }
  now_ = now;
  run_until(now, out);
}

std::optional<std::size_t> UnitekDrive::earliest_due() const {
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < cyclic_.size(); ++i) {
    if (cyclic_[i].state != CyclicEntry::State::Active) continue;
    if (!best || cyclic_[i].due < cyclic_[*best].due) best = i;
  }
  return best;
}

void UnitekDrive::run_until(Time now, can::FrameSink& out) {
  for (;;) {
    const Time tick_time{(tick_ms_ + 1) * kUsPerTick};
    const std::optional<std::size_t> due = earliest_due();
    // A tick and a cyclic reply at the same time: the tick first, so the reply carries the
    // value of that instant.
    if (!due || tick_time <= cyclic_[*due].due) {
      if (tick_time > now) break;
      if (steady()) {
        const Time limit = due ? std::min(now, cyclic_[*due].due) : now;
        const std::int64_t ticks = floor_div(limit.count(), kUsPerTick) - tick_ms_;
        integrate(ticks);
        tick_ms_ += ticks;
        update_outputs();
      } else {
        ++tick_ms_;
        step_tick();
        update_outputs();
        check_events(out);
      }
    } else {
      CyclicEntry& e = cyclic_[*due];
      if (e.due > now) break;
      send_register(e.regid, out);
      e.due += milliseconds(e.period_ms);
    }
  }
}

std::optional<Time> UnitekDrive::next_deadline() const {
  if (!clock_started_) return std::nullopt;
  std::optional<Time> t;
  if (const auto due = earliest_due()) t = cyclic_[*due].due;
  if (!steady()) {
    const Time tick{(tick_ms_ + 1) * kUsPerTick};
    t = t ? std::min(*t, tick) : tick;
  }
  return t;
}

// ---------------------------------------------------------------------------------------------
// Motor model (README.md "Motor model")

std::int64_t UnitekDrive::counts_per_tick_per_num() const {
  // Fine position units moved per 1 ms tick at 1 num: N max (0xC8, rpm) * 65536 counts/rev.
  return static_cast<std::int64_t>(regs_[reg::kSpeedRpmMax] & 0xFFFFu) * kCountsPerRev;
}

std::int64_t UnitekDrive::position_counts() const {
  return floor_div(pos_fine_, kPosDen);
}

UnitekDrive::Demand UnitekDrive::demand() const {
  // Speed limits: SPEED_LIMIT 0x34 for both directions, SPEED_CLIP_PO 0x3F / SPEED_CLIP_NE 0x3E.
  const std::int64_t limit = std::max<std::int64_t>(0, as_i16(regs_[reg::kSpeedLimit]));
  const std::int64_t clip_pos = std::max<std::int64_t>(0, as_i16(regs_[reg::kSpeedClipPos]));
  const std::int64_t clip_neg = std::min<std::int64_t>(
      kFullScale, std::max<std::int64_t>(0, -as_i16(regs_[reg::kSpeedClipNeg])));
  const std::int64_t vmax_pos = std::min(limit, clip_pos) * kMilli;
  const std::int64_t vmax_neg = std::min(limit, clip_neg) * kMilli;

  Demand d{0, ramp_rate(regs_[reg::kAccRamp]), ramp_rate(regs_[reg::kDecRamp])};
  if (!referencing_ && enabled()) {
    switch (control_) {
      case ControlMode::Speed: {
        const std::int64_t cmd = as_i16(regs_[reg::kSpeedCmd]) * kMilli;
        d.target = std::clamp(cmd, -vmax_neg, vmax_pos);
        break;
      }
      case ControlMode::Torque: {
        // No load: the torque accelerates the motor towards the speed limit; 100 % torque
        // accelerates at the ACC ramp's rate. Zero torque lets it run down at the DEC rate.
        const std::int64_t torque = as_i16(regs_[reg::kTorqueCmd]);
        if (torque > 0) d.target = vmax_pos;
        if (torque < 0) d.target = -vmax_neg;
        if (torque != 0)
          d.acc = std::max<std::int64_t>(1, d.acc * (torque < 0 ? -torque : torque) / kTorque100);
        break;
      }
      case ControlMode::Position: {
        const std::int64_t goal =
            static_cast<std::int64_t>(static_cast<std::int32_t>(regs_[reg::kPosDest])) * kPosDen;
        const std::int64_t err = goal - pos_fine_;
        const std::int64_t vmax = err > 0 ? vmax_pos : vmax_neg;
        if (err != 0 && vmax > 0) {
          // Trapezoidal profile: the highest speed from which the DEC ramp still stops at the
          // target, capped by the speed limit, at least 1 num so the target is always reached.
          const double c = static_cast<double>(counts_per_tick_per_num());
          const double dist = std::fabs(static_cast<double>(err));
          double v = static_cast<double>(vmax);
          if (c > 0)
            v = std::min(v, std::sqrt(2.0 * kMilli * static_cast<double>(d.dec) * dist / c));
          std::int64_t speed = std::max<std::int64_t>(kMilli, std::llround(v));
          speed = std::min(speed, vmax);
          d.target = err > 0 ? speed : -speed;
          // Braking follows the profile exactly (it may ask a little more than the DEC rate).
          if ((speed_milli_ > 0 && d.target > 0 && d.target < speed_milli_) ||
              (speed_milli_ < 0 && d.target < 0 && d.target > speed_milli_))
            d.dec = kInstant;
        }
        break;
      }
    }
  }
  // A limit switch stops motion in its direction with the emergency ramp R-Lim (0xC7, "limit
  // switch for 100 % speed command").
  const std::int64_t emergency = ramp_rate(regs_[reg::kEmergencyRamp]);
  if (limit_plus_ && d.target > 0) d.target = 0;
  if (limit_minus_ && d.target < 0) d.target = 0;
  if ((limit_plus_ && speed_milli_ > 0) || (limit_minus_ && speed_milli_ < 0)) d.dec = emergency;
  return d;
}

bool UnitekDrive::steady() const {
  if (referencing_) return false;
  const Demand d = demand();
  if (speed_milli_ != d.target) return false;
  // Positioning: steady only at standstill (at the target, or blocked by a limit).
  if (control_ == ControlMode::Position && enabled()) return speed_milli_ == 0;
  return true;
}

void UnitekDrive::integrate(std::int64_t ticks) {
  const std::int64_t per_tick = to_num(speed_milli_) * counts_per_tick_per_num();
  while (ticks > 0) {
    const std::int64_t n = std::min(ticks, kMaxJumpTicks);
    pos_fine_ = wrap_position(pos_fine_ + n * per_tick);
    ticks -= n;
  }
}

void UnitekDrive::step_tick() {
  if (referencing_ && !enabled()) {
    referencing_ = false;
    if (after_reference_) control_ = *after_reference_;
    after_reference_.reset();
    log_.warn("reference run aborted: drive disabled");
  }
  const Demand d = demand();
  speed_milli_ = ramp(speed_milli_, d.target, d.acc, d.dec);

  const std::int64_t delta = to_num(speed_milli_) * counts_per_tick_per_num();
  if (control_ == ControlMode::Position && enabled() && !referencing_) {
    const std::int64_t goal =
        static_cast<std::int64_t>(static_cast<std::int32_t>(regs_[reg::kPosDest])) * kPosDen;
    const std::int64_t err = goal - pos_fine_;
    if (err != 0 && delta != 0 && (err > 0) == (delta > 0) &&
        (delta > 0 ? delta >= err : delta <= err)) {
      pos_fine_ = goal;  // reaches the target within this tick and stops there
      speed_milli_ = 0;
      return;
    }
  }
  pos_fine_ = wrap_position(pos_fine_ + delta);

  if (referencing_ && speed_milli_ == 0) {
    ++reference_ticks_;
    if (reference_ticks_ * kUsPerTick >= options_.reference_run_time.count())
      finish_reference_run();
  }
}

void UnitekDrive::finish_reference_run() {
  referencing_ = false;
  referenced_ = true;
  // The reference point becomes POS_REF_OFFSE (0x72, "reference zero offset").
  const std::int32_t zero = static_cast<std::int32_t>(regs_[reg::kPosRefOffset]);
  pos_fine_ = static_cast<std::int64_t>(zero) * kPosDen;
  if (after_reference_) {
    control_ = *after_reference_;
  } else {
    control_ = ControlMode::Position;  // hold the reference position
    regs_[reg::kPosDest] = static_cast<std::uint32_t>(zero);
  }
  after_reference_.reset();
  log_.info("reference run done: position " + std::to_string(zero) + ", " +
            std::string(to_string(control_)) + " control");
}

std::uint32_t UnitekDrive::compute_status() const {
  std::uint32_t s = status::kPosControl | status::kSpeedControl;
  if (enabled()) s |= status::kEnabled;
  if (limit_plus_) s |= status::kLimitPlus;
  if (limit_minus_) s |= status::kLimitMinus;
  if (referenced_) s |= status::kCalibrated;
  if (in_tolerance()) s |= status::kInTolerance;
  return s;
}

bool UnitekDrive::in_tolerance() const {
  if (control_ != ControlMode::Position || referencing_) return false;
  const std::int64_t dest = static_cast<std::int32_t>(regs_[reg::kPosDest]);
  const std::int64_t err = dest - position_counts();
  const std::int64_t window = regs_[reg::kPosWindow] & 0xFFFFu;
  return (err < 0 ? -err : err) <= window;
}

void UnitekDrive::update_outputs() {
  const std::int64_t v = to_num(speed_milli_);
  const std::int64_t pos = position_counts();
  const bool en = enabled();
  const bool ready = power_ok_ && errors_ == 0;
  regs_[reg::kSpeedActual] = from_i16(v);
  regs_[reg::kSpeedRef] = from_i16(v);
  regs_[reg::kSpeedActualFilt] = from_i16(v);
  regs_[reg::kPosActual] = static_cast<std::uint32_t>(static_cast<std::int32_t>(pos));
  if (control_ == ControlMode::Position) {
    const std::int64_t dest = static_cast<std::int32_t>(regs_[reg::kPosDest]);
    const std::int64_t err = std::clamp<std::int64_t>(dest - pos, INT32_MIN, INT32_MAX);
    regs_[reg::kPosError] = static_cast<std::uint32_t>(static_cast<std::int32_t>(err));
    regs_[reg::kPosCommand] = regs_[reg::kPosDest];
  } else {
    regs_[reg::kPosError] = 0;
    regs_[reg::kPosCommand] = regs_[reg::kPosActual];
  }
  regs_[reg::kTorqueOut] =
      (control_ == ControlMode::Torque && en) ? (regs_[reg::kTorqueCmd] & 0xFFFFu) : 0;
  regs_[reg::kErrBitmap] = errors_;
  regs_[reg::kReady] = ready ? 1 : 0;
  regs_[reg::kGo] = en ? 1 : 0;
  regs_[reg::kLimitPlus] = limit_plus_ ? 1 : 0;
  regs_[reg::kLimitMinus] = limit_minus_ ? 1 : 0;
  regs_[reg::kEnableInput] = enable_input_ ? 1 : 0;
  regs_[reg::kNoFault] = errors_ == 0 ? 1 : 0;
  regs_[reg::kBrake] = en ? 0 : 1;
  regs_[reg::kInTolerance] = in_tolerance() ? 1 : 0;
  regs_[reg::kLessN0] = (v < kLessN0 && v > -kLessN0) ? 1 : 0;
  regs_[reg::kStatus] = compute_status();
}

// ---------------------------------------------------------------------------------------------
// Events and replies

void UnitekDrive::check_events(can::FrameSink& out) {
  const bool events = regs_[reg::kMode] & mode::kStatusEvent;
  const std::uint32_t s = regs_[reg::kStatus];
  // CAN manual example 9: with MODE bit 4 the drive sends STATUS when a bit selected by
  // STATUS_MASK 0x52 changes.
  if (events && ((s ^ status_basis_) & regs_[reg::kStatusMask])) send_register(reg::kStatus, out);
  status_basis_ = s;
  // CAN manual example 9.2: a change of ERR_BITMAP1 is sent (the manual leaves the MODE bit open;
  // this product uses bit 4 as well).
  if (events && errors_ != errors_basis_) send_register(reg::kErrBitmap, out);
  errors_basis_ = errors_;
}

void UnitekDrive::send_register(std::uint8_t regid, can::FrameSink& out) {
  const Width width = reply_width(regid);
  std::uint32_t value = regs_[regid];
  // A 16-bit register widened by 0xDC travels sign-extended, like 16-bit data written to a
  // 32-bit register.
  if (width == Width::W32 && register_info(regid).width == Width::W16)
    value = static_cast<std::uint32_t>(static_cast<std::int32_t>(as_i16(value)));
  const can::Frame reply = encode_reply(tx_id(), regid, value, width);
  if (log_.enabled(LogLevel::Debug)) log_.debug("tx " + describe(reply));
  out.send(reply);
}

// ---------------------------------------------------------------------------------------------
// Commands

void UnitekDrive::on_frame(const can::Frame& frame, Time now, can::FrameSink& out) {
  advance(now, out);
  if (frame.id != rx_id()) return;
  const Decoded decoded = decode_command(frame);
  if (!decoded.command) {
    if (log_.enabled(LogLevel::Debug))
      log_.debug("ignored " + describe(frame) + ": " + std::string(to_string(decoded.reject)));
    return;
  }
  if (log_.enabled(LogLevel::Debug)) log_.debug("rx " + describe(frame));
  handle_command(*decoded.command, now_, out);
  update_outputs();
  check_events(out);
}

void UnitekDrive::handle_command(const Command& command, Time now, can::FrameSink& out) {
  if (command.regid == reg::kRead) {
    handle_read(command.byte(0), command.byte(1), now, out);
    return;
  }
  handle_write(command, out);
}

void UnitekDrive::handle_read(std::uint8_t regid, std::uint8_t time, Time now,
                              can::FrameSink& out) {
  if (time == kReadOnce) {
    send_register(regid, out);
    return;
  }
  if (time == kReadStop) {
    for (CyclicEntry& e : cyclic_) {
      if (e.state == CyclicEntry::State::Active && e.regid == regid) {
        e.state = CyclicEntry::State::Suspended;
        log_.info("cyclic transmission of " + reg_name(regid) + " suspended");
        return;
      }
    }
    log_.debug("stop request for " + reg_name(regid) + ": no cyclic transmission active");
    return;
  }
  // FW 378 §8: up to 8 time-triggered requests; suspended entries can be overwritten by newer
  // requests. A request for a REGID that already has an entry re-uses it.
  std::optional<std::size_t> slot;
  for (std::size_t i = 0; i < cyclic_.size() && !slot; ++i)
    if (cyclic_[i].state != CyclicEntry::State::Free && cyclic_[i].regid == regid) slot = i;
  for (std::size_t i = 0; i < cyclic_.size() && !slot; ++i)
    if (cyclic_[i].state == CyclicEntry::State::Free) slot = i;
  for (std::size_t i = 0; i < cyclic_.size() && !slot; ++i)
    if (cyclic_[i].state == CyclicEntry::State::Suspended) slot = i;
  if (!slot) {
    log_.warn("cyclic request for " + reg_name(regid) + " every " + std::to_string(time) +
              " ms refused: all " + std::to_string(kMaxCyclicEntries) +
              " cyclic entries are active (FW 378 §8); stop one with time byte 0xFF");
    return;
  }
  cyclic_[*slot] = {CyclicEntry::State::Active, regid, time, now + milliseconds(time)};
  log_.info("cyclic transmission of " + reg_name(regid) + " every " + std::to_string(time) +
            " ms (entry " + std::to_string(*slot) + ")");
  send_register(regid, out);  // the first reply at once, then every period
}

void UnitekDrive::set_control(ControlMode m) {
  if (referencing_) {
    after_reference_ = m;  // takes over when the reference run is done
    return;
  }
  control_ = m;
}

void UnitekDrive::handle_write(const Command& command, can::FrameSink& out) {
  const std::uint8_t regid = command.regid;
  const RegisterInfo& info = register_info(regid);
  const std::uint32_t value = value_for_register(command, info.width);
  if (info.access == Access::RO) {
    log_.debug("write to read-only " + reg_name(regid) + " ignored");
    return;
  }
  if (info.access == Access::FN) {
    handle_function(regid, value);
    return;
  }
  switch (regid) {
    case reg::kCanIdRx:
    case reg::kCanIdTx: {
      // CAN manual "Setting CAN-BUS": Rx 0x201..0x27F, Tx 0x181..0x1FF. Example 1: the new
      // identifier takes effect at once.
      const bool rx = regid == reg::kCanIdRx;
      if (rx ? (value < kRxIdMin || value > kRxIdMax) : (value < kTxIdMin || value > kTxIdMax)) {
        log_.warn("new " + std::string(rx ? "Rx" : "Tx") + " ID " + hex(value, 3) +
                  " refused: outside " + hex(rx ? kRxIdMin : kTxIdMin, 3) + ".." +
                  hex(rx ? kRxIdMax : kTxIdMax, 3) + " (CAN manual, Setting CAN-BUS)");
        return;
      }
      regs_[regid] = value;
      log_.info(std::string(rx ? "Rx" : "Tx") + " ID now " + hex(value, 3));
      return;
    }
    case reg::kMode: {
      const std::uint32_t old = regs_[reg::kMode];
      regs_[reg::kMode] = value;
      update_outputs();
      if (!(old & mode::kStatusEvent) && (value & mode::kStatusEvent)) {
        // Subscribing sends the current status once, so the master starts from a known state.
        status_basis_ = regs_[reg::kStatus];
        errors_basis_ = errors_;
        send_register(reg::kStatus, out);
      }
      return;
    }
    case reg::kSpeedCmd:
      regs_[regid] = value;
      set_control(ControlMode::Speed);
      return;
    case reg::kPosDest:
      regs_[regid] = value;
      set_control(ControlMode::Position);
      return;
    case reg::kTorqueCmd:
      regs_[regid] = value;
      set_control(ControlMode::Torque);
      return;
    default:
      regs_[regid] = value;
      return;
  }
}

void UnitekDrive::handle_function(std::uint8_t regid, std::uint32_t value) {
  switch (regid) {
    case reg::kRefStart:
      if (!enabled()) {
        log_.warn("reference run (0x78) refused: the drive is not enabled");
        return;
      }
      referencing_ = true;
      referenced_ = false;
      reference_ticks_ = 0;
      after_reference_.reset();
      log_.info("reference run started");
      return;
    case reg::kParaWrite: {
      // CAN manual example 7: EEPROM level in the data (0, 1, 2); all levels store the same set.
      if (!store_) {
        log_.warn("EEPROM write (0x84) without a state store: parameters are not persisted");
        return;
      }
      std::string error;
      if (store_->save(parameters(), &error))
        log_.info("EEPROM write (level " + std::to_string(value & 0xFFFFu) + "): parameters saved");
      else
        log_.error("EEPROM write (0x84) failed: " + error);
      return;
    }
    case reg::kParaRead: {
      if (!store_) {
        log_.warn("EEPROM read (0x83) without a state store: nothing to load");
        return;
      }
      std::string error;
      if (auto params = store_->load(&error))
        apply_parameters(*params, "state store (0x83)");
      else
        log_.error("EEPROM read (0x83): " + (error.empty() ? "nothing stored" : error));
      return;
    }
    case reg::kErrCancel:
      if (errors_) log_.info("error list cleared (0x8E), was " + hex(errors_, 8));
      errors_ = 0;
      return;
    default:
      log_.debug("function " + reg_name(regid) + " is not simulated; write ignored");
      return;
  }
}

// ---------------------------------------------------------------------------------------------
// Inputs

void UnitekDrive::set_enable_input(bool on, Time now, can::FrameSink& out) {
  advance(now, out);
  enable_input_ = on;
  update_outputs();
  check_events(out);
}

void UnitekDrive::set_limit_switch(LimitSwitch which, bool active, Time now, can::FrameSink& out) {
  advance(now, out);
  (which == LimitSwitch::Plus ? limit_plus_ : limit_minus_) = active;
  update_outputs();
  check_events(out);
}

void UnitekDrive::set_errors(std::uint32_t bitmap, Time now, can::FrameSink& out) {
  advance(now, out);
  if (bitmap != errors_) log_.warn("error bitmap (0x8F) now " + hex(bitmap, 8));
  errors_ = bitmap;
  update_outputs();
  check_events(out);
}

void UnitekDrive::set_power_ok(bool on, Time now, can::FrameSink& out) {
  advance(now, out);
  power_ok_ = on;
  update_outputs();
  check_events(out);
}

}  // namespace candp2::drive
