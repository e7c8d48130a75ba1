// The simulated drive's units and the arithmetic of its motor model (internal to drive_sim/):
// speed in 1/1000 num, position in fine units of 1/kPosDen count, time in 1 ms ticks
// (README.md "Motor model"). Shared by unitek_drive.cpp (commands, replies) and motor_model.cpp.
#pragma once

#include <algorithm>
#include <cstdint>

namespace candp2::drive::detail {

// German manual §7.1 "Drehzahl": speed values are ±32767 num = ±100 % = ±N max (0xC8, rpm).
inline constexpr std::int64_t kFullScale = 32767;
inline constexpr std::int64_t kMilli = 1000;  // the model keeps speed in 1/1000 num
// German manual §7.1 "Position": 65536 position counts per motor revolution.
inline constexpr std::int64_t kCountsPerRev = 65536;
// Position is kept in fine units of 1/kPosDen count, so that one 1 ms tick at v num moves it by
// exactly v * N max * 65536 fine units (v/32767 * Nmax rev/min / 60000 ms/min * 65536 counts/rev).
inline constexpr std::int64_t kPosDen = kFullScale * 60000;
// POS_ACTUAL (0x6D) is a signed 32-bit register: the model wraps like an int32 counter.
inline constexpr std::int64_t kPosHalfRange = (std::int64_t{1} << 31) * kPosDen;
// The rate used when a ramp time is 0 ms: any speed change completes within one tick.
inline constexpr std::int64_t kInstant = 2 * kFullScale * kMilli;
// Largest number of ticks integrated at once in steady state (keeps int64 sums in range).
inline constexpr std::int64_t kMaxJumpTicks = 16384;
// FW 378 short description §5, TORQUE_COMMAND: +100 % torque = 21845 num (±32767 = ±150 %).
inline constexpr std::int64_t kTorque100 = 21845;
// 0xF5 VO_Less_N0 "message speed < 1 %": 1 % of 32767 num.
inline constexpr std::int64_t kLessN0 = 328;
inline constexpr std::int64_t kUsPerTick = 1000;  // the model's tick: 1 ms

inline std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  std::int64_t q = a / b;
  if ((a % b != 0) && ((a < 0) != (b < 0))) --q;
  return q;
}

inline std::int64_t to_num(std::int64_t milli) {
  return milli >= 0 ? (milli + kMilli / 2) / kMilli : -((-milli + kMilli / 2) / kMilli);
}

// Ramp registers hold the time in ms for a change of 100 % (CAN manual example 6: "1000 ms
// acceleration"); only the low 16 bits count (the list's default 0x00010064 = 100 ms).
inline std::int64_t ramp_rate(std::uint32_t reg_value) {
  const std::int64_t ms = reg_value & 0xFFFFu;
  return ms == 0 ? kInstant : (kFullScale * kMilli) / ms;
}

inline std::int64_t wrap_position(std::int64_t fine) {
  if (fine >= kPosHalfRange) fine -= 2 * kPosHalfRange;
  if (fine < -kPosHalfRange) fine += 2 * kPosHalfRange;
  return fine;
}

// One tick of a speed ramp: `acc` applies while |speed| grows, `dec` while it shrinks; a change
// of sign first decelerates to zero.
inline std::int64_t ramp(std::int64_t cur, std::int64_t target, std::int64_t acc,
                         std::int64_t dec) {
  if (cur == target) return cur;
  if (cur > 0 && target < cur) return std::max(std::max<std::int64_t>(target, 0), cur - dec);
  if (cur < 0 && target > cur) return std::min(std::min<std::int64_t>(target, 0), cur + dec);
  return target > cur ? std::min(target, cur + acc) : std::max(target, cur - acc);
}

inline std::int16_t as_i16(std::uint32_t v) {
  return static_cast<std::int16_t>(v & 0xFFFFu);
}
inline std::uint32_t from_i16(std::int64_t v) {
  return static_cast<std::uint16_t>(static_cast<std::int16_t>(v));
}

}  // namespace candp2::drive::detail
