// The simulated drive's time and motor model (drive_sim/unitek_drive.hpp): the 1 ms tick grid of
// the caller's time, the cyclic replies falling due on it, the speed/position/torque model and
// the registers it computes (README.md "Motor model").
#include <algorithm>
#include <cmath>

#include "drive_sim/model_units.hpp"
#include "drive_sim/unitek_drive.hpp"

namespace candp2::drive {

using namespace detail;

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

}  // namespace candp2::drive
