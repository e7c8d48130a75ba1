// The Unitek manuals' examples 1-12, replayed frame for frame against the simulator.
//
// Sources (the vendor manuals):
//   EN = Unitek CAN-BUS manual issue V1 1011 (English), examples 1-12
//   DE = German CAN-BUS manual (Beispiel 1-12) after the FW 378 short description
// Frames marked "as printed" are the manuals' frames; lines under "# setup" or "# check" are not
// in the manual: setup puts the drive into the state the example assumes, checks show the
// behaviour the example describes in words. Where a manual misprints a frame, the row says so.
//
// Reply widths: the English examples 8, 9, 9-1, 9.2 and 12, and the German examples 8 and 12, show
// STATUS (0x40) / ERR_BITMAP1 (0x8F) replies with DLC 4; the German examples 10 and 10-1, the FW
// 378 short description §7 and the register list make them 32-bit (DLC 6). The simulator defaults
// to FW 378; rows marked kV1011 run with Options::status_16bit (see drive_sim/README.md).
#include <gtest/gtest.h>

#include "replay.hpp"

namespace candp2::drive::test {
namespace {

enum class Firmware { kFw378, kV1011 };

struct ExampleCase {
  const char* id;      // test name suffix
  const char* source;  // manual and example number
  Firmware firmware;
  std::vector<std::string_view> script;
};

UnitekDrive::Options options_for(Firmware fw) {
  UnitekDrive::Options o;
  o.status_16bit = fw == Firmware::kV1011;
  return o;
}

// Example 10 (EN) / Beispiel 9 (DE): the request goes to 0x210 and the replies come from 0x190,
// the identifiers left by example 1 (Rx 0x210) and a Tx change the manuals do not show.
const std::vector<std::string_view> kCyclicSpeed = {
    "# setup: example 1's Rx ID 0x210, Tx ID 0x190, motor at 100 % speed",
    "> 201#681002",
    "> 210#699001",
    "> 210#31FF7F",
    "~ 200",
    "# as printed: REGID 0x3D, SPEED_ACTUAL 0x30, time 0x64 = 100 ms",
    "> 210#3D3064",
    "# as printed: 190#30FF7F.. (100 % = 0x7FFF); the first reply comes at once, then every 100 ms",
    "< 190#30FF7F00",
    "~ 100",
    "< 190#30FF7F00",
    "~ 100",
    "< 190#30FF7F00",
    "~ 50",
    "~ 50",
    "< 190#30FF7F00",
    "# as printed: abort with time byte 0xFF",
    "> 210#3D30FF",
    "~ 1000",
    "# check: the old identifiers are deaf now",
    "> 201#3D3000",
};

// Example 11 (both manuals): speed routine. The manuals print the cyclic values as "xx"; the
// values here follow the ramps (ACC 500 ms, DEC 1000 ms for 100 %), see README "Motor model".
const std::vector<std::string_view> kSpeedRoutine = {
    "> 201#3DE200",    "< 181#E2010000",  // BTB (ready) read once: 1
    "> 201#510400",                       // inhibit (MODE bit 2)
    "> 201#3DE800",    "< 181#E8010000",  // hardware enable input read once: 1
    "> 201#510000",                       // release
    "> 201#35F401",                       // ACC ramp 500 ms
    "> 201#EDE803",                       // DEC ramp 1000 ms
    "> 201#31D403",                       // speed 0x03D4 (the manuals say "30 %"; 0x03D4 is 3 %)
    "> 201#3D3064",                       // SPEED_ACTUAL every 100 ms
    "< 181#30000000",                     // at once: still standing
    "~ 100",
    "< 181#30D40300",  // 980 reached after 15 ms
    "> 201#31A47F",    // 100 % = 0x7FA4
    "~ 500",
    "< 181#306D1D00",  // 980 + 100 ms * 65.534/ms = 7533
    "< 181#30073700",  // 14087
    "< 181#30A05000",  // 20640
    "< 181#303A6A00",  // 27194
    "< 181#30A47F00",  // 32676 reached
    "> 201#310000",    // speed zero: DEC 1000 ms for 100 % = 32.767/ms
    "~ 1000",
    "< 181#30D77200",  // 29399
    "< 181#300B6600",  // 26123
    "< 181#303E5900",  // 22846
    "< 181#30714C00",  // 19569
    "< 181#30A53F00",  // 16293
    "< 181#30D83200",  // 13016
    "< 181#300B2600",  // 9739
    "< 181#303E1900",  // 6462
    "< 181#30720C00",  // 3186
    "< 181#30000000",  // standing
    "> 201#510400",    // inhibit
    "? 40 = 00000180",
};

// Example 12 (both manuals): reference run, to 3000000 and back to zero.
const std::vector<std::string_view> kPositionRoutine = {
    "> 201#3DE200",
    "< 181#E2010000",  // BTB
    "> 201#510400",    // inhibit
    "> 201#310000",    // speed zero
    "> 201#3DE800",
    "< 181#E8010000",  // enable input
    "> 201#510000",    // release
    "> 201#780100",    // start reference run
    "# the master waits for the reference run (500 ms search)",
    "~ 600",
    "> 201#523000",  // STATUS_MASK 0x0030 as printed (bits 4, 5: no event during this routine)
    "> 201#511000",  // status message on event
    "# as printed 181#40xxxxxx: the current status, Ena P-N N-I Cal Tol",
    "< 181#40813100",
    "> 201#6EC0C62D00",  // target 3000000
    "~ 2000",
    "? 6D = 002DC6C0",
    "> 201#3DF400",
    "< 181#F4010000",    // in tolerance
    "> 201#6E00000000",  // target zero
    "~ 2000",
    "? 6D = 00000000",
    "# the manuals print this reply (DE with DLC 3, EN 'f4 01 00') without a request before it;",
    "# the master polls again",
    "> 201#3DF400",
    "< 181#F4010000",
    "> 201#510400",  // inhibit (also ends the status events: MODE bit 4 cleared)
    "! limit+ 1",    // check: no more status messages
};

const ExampleCase kExamples[] = {
    {"En1_RxIdChange",
     "EN example 1 / DE Beispiel 1: Rx ID 0x201 -> 0x210 via REGID 0x68",
     Firmware::kFw378,
     {"> 201#681002", "? 68 = 0210", "# check: the old Rx ID is ignored, the new one answers",
      "> 201#3D6800", "> 210#3D6800", "< 181#68100200"}},
    {"En2_Inhibit",
     "EN example 2 / DE Beispiel 2: MODE 0x51 bit 2 inhibits the drive",
     Firmware::kFw378,
     {"? 40 = 00000181", "> 201#510400", "? 51 = 0004", "# check: Ena (bit 0) is gone",
      "? 40 = 00000180", "? E3 = 0000", "> 201#510000", "? 40 = 00000181"}},
    {"En3_SpeedSetpoint",
     "EN example 3 / DE Beispiel 3: 10 % speed = 0x0CCD into 0x31",
     Firmware::kFw378,
     {"> 201#31CD0C", "? 31 = 0CCD", "# check: with the default 100 ms ramp it is reached at once",
      "~ 200", "? 30 = 0CCD", "? A8 = 0CCD"}},
    {"En4_PositionSetpoint",
     "EN example 4 / DE Beispiel 4: position 3000000 = 0x2DC6C0 into 0x6E",
     Firmware::kFw378,
     {"> 201#6EC0C62D00", "? 6E = 002DC6C0", "# check: the motor gets there", "~ 3000",
      "? 6D = 002DC6C0", "? F4 = 0001", "? 40 = 00002181"}},
    {"En5_TorqueSetpoint",
     "EN example 5 / DE Beispiel 5: 50 % torque = 0x3FFC into 0x90",
     Firmware::kFw378,
     {"> 201#90FC3F", "? 90 = 3FFC", "? A0 = 3FFC", "# check: the unloaded motor accelerates",
      "~ 1000", "? 30 = 7FFF"}},
    {"En6_AccRamp",
     "EN example 6 / DE Beispiel 6: ACC ramp 0x35 (the text says 1000 ms = 0x03E8, the frame as "
     "printed carries 0x0CCD; 16-bit data sign-extended into the 32-bit register)",
     Firmware::kFw378,
     {"> 201#35CD0C", "? 35 = 00000CCD", "# check: the value the text means", "> 201#35E803",
      "? 35 = 000003E8"}},
    {"En7_EepromWrite",
     "EN example 7 / DE Beispiel 7: EEPROM write 0x84 level 0",
     Firmware::kFw378,
     {"$ saves 0", "> 201#840000", "$ saves 1"}},
    {"En8_StatusOnce",
     "EN example 8: read STATUS once; printed '181 0 3 40 81 01' (DLC 3 is a misprint for 4: "
     "REGID + 2 data bytes + stuff byte)",
     Firmware::kV1011,
     {"> 201#3D4000", "< 181#40810100"}},
    {"De8_StatusOnce",
     "DE Beispiel 8: read STATUS once, printed 181 4 40 81 01 **",
     Firmware::kV1011,
     {"> 201#3D4000", "< 181#408101**"}},
    {"Fw378_StatusOnce",
     "FW 378 short description §7: STATUS request once -> TxID 6 0x40 + 4 data bytes + stuff",
     Firmware::kFw378,
     {"> 201#3D4000", "< 181#408101000000"}},
    {"En9_StatusOnEvent",
     "EN example 9: MODE bit 4, default mask 0x3000: status 0x3181 (Ena P-S S-I Cal Tol)",
     Firmware::kV1011,
     {"# setup: referenced and holding position (Cal, Tol)", "> 201#780100", "~ 600",
      "# as printed", "> 201#511000", "< 181#40813100",
      "# check: a change of bit 13 (Tol) is an event, both ways", "> 201#6EC0C62D00",
      "< 181#40811100", "~ 2000", "< 181#40813100",
      "# check: a change outside the mask (Ena) is not", "> 201#510410"}},
    {"De10_StatusOnEvent",
     "DE Beispiel 10: MODE bit 4, reply 181 6 40 81 31 00 00 ** (the table's text value 0x0181 "
     "contradicts its own frame and bit list: 0x3181)",
     Firmware::kFw378,
     {"# setup: referenced and holding position (Cal, Tol)", "> 201#780100", "~ 600",
      "# as printed", "> 201#511000", "< 181#4081310000**"}},
    {"En9_1_StatusMaskLimitSwitch",
     "EN example 9-1: mask 0x0012, a limit switch occupied -> 0x3185 (Lim+)",
     Firmware::kV1011,
     {"# setup: referenced, holding position, limit switch + occupied", "> 201#780100", "~ 600",
      "! limit+ 1", "# as printed", "> 201#521200", "> 201#511000", "< 181#40853100",
      "# check: mask 0x000C selects the limit switch bits 2 and 3 the example shows",
      "> 201#520C00", "! limit+ 0", "< 181#40813100", "! limit- 1",
      "# the example's other value, 0x3189", "< 181#40893100"}},
    {"De10_1_StatusMaskLimitSwitch",
     "DE Beispiel 10-1: mask 0x0012, limit switch occupied -> 181 6 40 85 31 00 00 **",
     Firmware::kFw378,
     {"# setup: referenced, holding position, limit switch + occupied", "> 201#780100", "~ 600",
      "! limit+ 1", "# as printed", "> 201#521200", "> 201#511000", "< 181#4085310000**"}},
    {"En9_2_ErrorOnEvent",
     "EN example 9.2: ERR_BITMAP1 0x8F sent on change, motor temperature = bit 6 -> 8f 40 00 "
     "(the manual prints the request as 0x?? 0x??; this product uses MODE bit 4)",
     Firmware::kV1011,
     {"> 201#511000", "< 181#40810100", "! errors 40", "< 181#8F400000",
      "# check: the error disables the drive and drops ready; 0x8E clears it", "? 40 = 00000180",
      "? E2 = 0000", "> 201#8E0000", "< 181#8F000000", "? 40 = 00000181"}},
    {"En10_CyclicSpeed", "EN example 10: speed actual every 100 ms, 0xFF stops", Firmware::kFw378,
     kCyclicSpeed},
    {"De9_CyclicSpeed", "DE Beispiel 9: speed actual every 100 ms, 0xFF stops", Firmware::kFw378,
     kCyclicSpeed},
    {"En11_SpeedRoutine", "EN example 11: routine for simple speed control", Firmware::kFw378,
     kSpeedRoutine},
    {"De11_SpeedRoutine", "DE Beispiel 11: Routine fuer einfache Drehzahl-Regelung",
     Firmware::kFw378, kSpeedRoutine},
    {"En12_PositionRoutine", "EN example 12: reference and drive to a position and back",
     Firmware::kV1011, kPositionRoutine},
    {"De12_PositionRoutine", "DE Beispiel 12: Routine fuer einfache Positions-Regelung",
     Firmware::kV1011, kPositionRoutine},
};

class ManualExample : public ::testing::TestWithParam<ExampleCase> {};

TEST_P(ManualExample, ReplaysFrameForFrame) {
  const ExampleCase& c = GetParam();
  SCOPED_TRACE(c.source);
  Replay replay(options_for(c.firmware));
  EXPECT_TRUE(replay.run(c.script));
}

// The same scripts, with time sliced into 1 ms and 7 ms advance() calls: identical traces.
TEST_P(ManualExample, TraceDoesNotDependOnHowTimeIsSliced) {
  const ExampleCase& c = GetParam();
  SCOPED_TRACE(c.source);
  Replay whole(options_for(c.firmware));
  ASSERT_TRUE(whole.run(c.script));
  for (std::int64_t step : {1, 7}) {
    Replay sliced(options_for(c.firmware), Time{5'000'250}, step);
    ASSERT_TRUE(sliced.run(c.script)) << "step " << step << " ms";
    ASSERT_EQ(sliced.trace().size(), whole.trace().size()) << "step " << step << " ms";
    for (std::size_t i = 0; i < whole.trace().size(); ++i)
      EXPECT_EQ(sliced.trace()[i].frame, whole.trace()[i].frame) << "frame " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(UnitekManuals, ManualExample, ::testing::ValuesIn(kExamples),
                         [](const auto& info) { return std::string(info.param.id); });

}  // namespace
}  // namespace candp2::drive::test
