// The watchdog rule (docs/validate.md "The watchdog rule"): the bounds from the line's arithmetic
// and the verdicts at their edges. Expected bit counts are written out from the telegram layouts
// (docs/profibus.md "The line in time": 11 bits a character, SD1 6, SD2 9 + data unit, SD4 3, SC
// 1; TID1 37 and TID2 60 with the default Tset 1, Tqui 0), not taken from the code.
#include "profibus_sim/fdl/watchdog_rule.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace candp2::fdl {
namespace {

Duration at_9600(std::uint64_t bits) {  // rounded up to the microsecond
  return Duration{static_cast<std::int64_t>(std::ceil(static_cast<double>(bits) * 1e6 / 9600))};
}

// One CAN-DP/2 at 9.6 kbit/s: 5 output and 6 input bytes, a 16-byte Set_Prm, 10 Chk_Cfg bytes,
// an 11-byte diagnosis.
WatchdogLine line_9600(std::uint32_t cycle_ms, std::uint32_t late_ms) {
  WatchdogLine l;
  l.baud = 9600;
  l.params = *default_bus_parameters(9600);
  l.cycle_ms = cycle_ms;
  l.late_ms = late_ms;
  l.stations.push_back(
      {.outputs = 5, .inputs = 6, .prm_bytes = 16, .cfg_bytes = 10, .diag_bytes = 11});
  return l;
}

// Data_Exchange: TID1 37 + request SD2 (9 + 5) x 11 + min_TSDR 11 + answer (9 + 6) x 11.
constexpr std::uint64_t kDx = 37 + 154 + 11 + 165;
constexpr std::uint64_t kToken = 33 + 60;  // SD4 and TID2
constexpr std::uint64_t kGap = 66 + 100;   // FDL_Status into the GAP and the slot time
// FDL_Status (SD1 both ways), Slave_Diag (SD2 with the SAPs; 2 + 11 bytes back) twice, Set_Prm
// (2 + 16, SC back), Chk_Cfg (2 + 10, SC back), the first Data_Exchange.
constexpr std::uint64_t kParameterize = (37 + 66 + 11 + 66) + 2 * (37 + 121 + 11 + 242) +
                                        (37 + 297 + 11 + 11) + (37 + 231 + 11 + 11) + kDx;

TEST(WatchdogRule, BoundsFromTheLine) {
  const auto b = watchdog_bounds(line_9600(10, 0));
  EXPECT_EQ(b.bus_cycle, at_9600(kToken + kDx + kGap));
  EXPECT_EQ(b.cycle, at_9600(kToken + kDx + kGap));  // longer than cycle_ms 10
  EXPECT_EQ(b.retries, at_9600(154 + 100));          // retry_limit 1: the request and a slot time
  EXPECT_EQ(b.startup, at_9600(kToken + kGap + kParameterize));
  EXPECT_EQ(startup_rotation_bits(line_9600(10, 0).params, line_9600(10, 0).stations, true),
            kToken + kGap + kParameterize);
  EXPECT_EQ(b.needed(), b.startup);
  // A long master cycle takes over every term but the retries it carries.
  const auto slow = watchdog_bounds(line_9600(300, 50));
  EXPECT_EQ(slow.cycle, milliseconds(300));
  EXPECT_EQ(slow.startup, milliseconds(300));
  EXPECT_EQ(slow.needed(), milliseconds(350) + at_9600(254));
}

TEST(WatchdogRule, VerdictsAtTheEdges) {
  const auto b = watchdog_bounds(line_9600(10, 50));
  const auto cycle_ms = b.cycle.count() / 1000;                     // 65 ms
  EXPECT_EQ(judge_watchdog(b, 0).verdict, WatchdogVerdict::Holds);  // off
  const auto never = judge_watchdog(b, static_cast<std::uint32_t>(cycle_ms));
  EXPECT_EQ(never.verdict, WatchdogVerdict::NeverHolds);
  EXPECT_EQ(never.message,
            "watchdog 65 ms is shorter than the bus cycle itself (65.21 ms): it expires between "
            "two Data_Exchanges every rotation and can never hold; set watchdog_ms to at least "
            "290");
  const auto expire = judge_watchdog(b, 66);
  EXPECT_EQ(expire.verdict, WatchdogVerdict::WillExpire);
  EXPECT_EQ(expire.message,
            "watchdog 66 ms is shorter than the time the master may take to come back (286.88 ms: "
            "the rotation that parameterizes every station 236.88 ms, up to 50.00 ms late): it "
            "will expire; set watchdog_ms to at least 290");
  EXPECT_EQ(judge_watchdog(b, 286).verdict, WatchdogVerdict::WillExpire);
  EXPECT_EQ(judge_watchdog(b, 287).verdict, WatchdogVerdict::Holds);
}

TEST(WatchdogRule, TheIdealLineIsTheMasterCycle) {
  WatchdogLine l;  // baud 0
  l.cycle_ms = 20;
  l.late_ms = 50;
  l.stations.push_back({});
  const auto b = watchdog_bounds(l);
  EXPECT_EQ(b.needed(), milliseconds(70));
  EXPECT_EQ(judge_watchdog(b, 19).message,
            "watchdog 19 ms is shorter than the master cycle itself (20.00 ms): it expires "
            "between two Data_Exchanges every rotation and can never hold; set watchdog_ms to at "
            "least 70");
  EXPECT_EQ(judge_watchdog(b, 20).message,
            "watchdog 20 ms is shorter than the time the master may take to come back (70.00 ms: "
            "the master cycle 20.00 ms, up to 50.00 ms late): it will expire; set watchdog_ms to "
            "at least 70");
  EXPECT_EQ(judge_watchdog(b, 70).verdict, WatchdogVerdict::Holds);
}

}  // namespace
}  // namespace candp2::fdl
