// The drive simulator beyond the manuals' examples: the REGID wire format, malformed input, the
// cyclic table, event rules, the motor model, time handling and the register table.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "can/virtual_bus.hpp"
#include "drive_sim/regid_protocol.hpp"
#include "drive_sim/registers.hpp"
#include "drive_sim/unitek_drive.hpp"
#include "replay.hpp"
#include "tests/vendor_files.hpp"

namespace candp2::drive::test {
namespace {

can::Frame frame(std::string_view text) {
  auto r = can::parse_candump(text);
  EXPECT_TRUE(r) << text << ": " << r.error.message;
  return r ? *r.frame : can::Frame{};
}

// ---------------------------------------------------------------------------------------------
// Wire format (CAN manual "CAN Format", "DLC-Bits"; FW 378 §1-2; German manual §5.1)

TEST(RegidProtocol, DecodesSixteenAndThirtyTwoBitCommands) {
  auto d = decode_command(frame("201#31CD0C"));
  ASSERT_TRUE(d.command);
  EXPECT_EQ(d.command->regid, 0x31);
  EXPECT_EQ(d.command->data, 0x0CCDu);
  EXPECT_FALSE(d.command->wide);

  d = decode_command(frame("201#6EC0C62D00"));  // CAN manual example 4
  ASSERT_TRUE(d.command);
  EXPECT_EQ(d.command->data, 3000000u);
  EXPECT_TRUE(d.command->wide);
}

TEST(RegidProtocol, LongerFramesAreEvaluatedAsFiveBytes) {
  // German manual §5.1: up to 8 bytes are received and evaluated as a 5-byte packet.
  for (const char* text : {"201#6E10CAE111AA", "201#6E10CAE111AABB", "201#6E10CAE111AABBCC"}) {
    const auto d = decode_command(frame(text));
    ASSERT_TRUE(d.command) << text;
    EXPECT_EQ(d.command->data, 0x11E1CA10u) << text;  // German manual §5.8: 300010000
  }
}

TEST(RegidProtocol, RejectsRemoteExtendedAndOddLengths) {
  EXPECT_EQ(decode_command(frame("201#R3")).reject, Reject::Remote);
  EXPECT_EQ(decode_command(frame("00000201#3D4000")).reject, Reject::Extended);
  for (const char* text : {"201#", "201#3D", "201#3D40", "201#3D400000"}) {
    const auto d = decode_command(frame(text));
    EXPECT_FALSE(d.command) << text;
    EXPECT_EQ(d.reject, Reject::BadDlc) << text;
  }
}

TEST(RegidProtocol, WidthConversion) {
  // FW 378 §1: 16-bit data into a 32-bit register is sign-extended ...
  Command c{0x6E, 0xFF00, false};
  EXPECT_EQ(value_for_register(c, Width::W32), 0xFFFFFF00u);
  c = {0x35, 0x03E8, false};
  EXPECT_EQ(value_for_register(c, Width::W32), 0x000003E8u);
  // ... and 32-bit data into a 16-bit register loses the upper half.
  c = {0x31, 0x12340CCD, true};
  EXPECT_EQ(value_for_register(c, Width::W16), 0x0CCDu);
  EXPECT_EQ(value_for_register(c, Width::W32), 0x12340CCDu);
}

TEST(RegidProtocol, RepliesCarryAStuffByte) {
  EXPECT_EQ(encode_reply(0x181, 0x40, 0x0181, Width::W16), frame("181#40810100"));
  EXPECT_EQ(encode_reply(0x181, 0x40, 0x3181, Width::W32), frame("181#408131000000"));
  EXPECT_EQ(encode_reply(0x190, 0x30, 0x12347FFF, Width::W16), frame("190#30FF7F00"));
  EXPECT_TRUE(is_well_formed_reply(frame("181#E2010000")));
  EXPECT_TRUE(is_well_formed_reply(frame("181#6EC0C62D0000")));
  EXPECT_FALSE(is_well_formed_reply(frame("181#E20100")));         // DLC 3
  EXPECT_FALSE(is_well_formed_reply(frame("181#E2010001")));       // stuff byte not 0
  EXPECT_FALSE(is_well_formed_reply(frame("181#R4")));             // remote
  EXPECT_FALSE(is_well_formed_reply(frame("00000181#E2010000")));  // 29-bit
}

// ---------------------------------------------------------------------------------------------
// Malformed and foreign input: no reply, a debug log line, no state change

TEST(DriveInput, MalformedFramesGetNoReply) {
  Replay r({});
  const std::uint32_t mode_before = r.drive().reg(reg::kMode);
  EXPECT_TRUE(r.run({
      "> 201#",             // DLC 0
      "> 201#3D",           // DLC 1
      "> 201#3D40",         // DLC 2
      "> 201#3D400000",     // DLC 4: neither a 16- nor a 32-bit command
      "> 201#510400",       // a valid one in between still works
      "> 201#R3",           // remote request for the Rx ID: ignored (FW 378 §1)
      "> 00000201#3D4000",  // 29-bit identifier with the same value
      "> 202#3D4000",       // another drive's identifier
      "> 181#3D4000",       // our own Tx identifier
  }));
  EXPECT_EQ(r.drive().reg(reg::kMode), 0x0004u);
  EXPECT_NE(mode_before, r.drive().reg(reg::kMode));
  EXPECT_TRUE(r.log().contains("ignored 201#3D400000: DLC is neither 3"));
  EXPECT_TRUE(r.log().contains("ignored 201#R3: remote frame"));
  for (const auto& line : r.log().lines)
    if (line.message.starts_with("ignored")) {
      EXPECT_EQ(line.level, LogLevel::Debug);
    }
}

TEST(DriveInput, EightByteReadIsAnswered) {
  Replay r({});
  EXPECT_TRUE(r.run({"> 201#3D40000000000000", "< 181#408101000000"}));
}

TEST(DriveInput, WritesToReadOnlyAndFunctionRegistersAreIgnored) {
  Replay r({});
  EXPECT_TRUE(r.run({"> 201#300100", "? 30 = 0000", "> 201#E20000", "? E2 = 0001",
                     "> 201#4000000000", "? 40 = 00000181", "> 201#170100"}));
  EXPECT_TRUE(r.log().contains("write to read-only 0x30 (SPEED_ACTUAL) ignored"));
  EXPECT_TRUE(r.log().contains("function 0x17 (CAPTURE_READ) is not simulated"));
}

TEST(DriveInput, FiveByteDataIntoSixteenBitRegisterAndThreeByteIntoThirtyTwo) {
  Replay r({});
  EXPECT_TRUE(r.run({"> 201#31CD0C3412", "? 31 = 0CCD", "> 201#7200FF", "? 72 = FFFFFF00",
                     "> 201#3D7200", "< 181#7200FFFFFF00"}));
}

TEST(DriveInput, IdentifierChangesOutsideTheManualRangeAreRefused) {
  // CAN manual "Setting CAN-BUS": Rx 0x201..0x27F, Tx 0x181..0x1FF.
  Replay r({});
  EXPECT_TRUE(
      r.run({"> 201#688002", "> 201#690002", "> 201#680002", "> 201#688001", "> 201#69FF01",
             "? 69 = 01FF", "> 201#3DE200", "< 1FF#E2010000", "> 201#697F01", "? 69 = 01FF"}));
  EXPECT_EQ(r.drive().rx_id(), 0x201u);
  EXPECT_TRUE(r.log().contains("new Rx ID 0x280 refused"));
  EXPECT_TRUE(r.log().contains("new Tx ID 0x17F refused"));
}

TEST(DriveInput, RegisterDcMakesEveryReplySixBytes) {
  // FW 378 short description §3: upper byte 01 in REGID 0xDC -> all replies 6 bytes.
  Replay r({});
  EXPECT_TRUE(r.run({"> 201#3DE200", "< 181#E2010000", "> 201#DC3001", "> 201#3DE200",
                     "< 181#E20100000000", "# 16-bit values travel sign-extended", "> 201#3D3E00",
                     "< 181#3E0080FFFF00", "> 201#DC3000", "> 201#3DE200", "< 181#E2010000"}));
}

TEST(DriveInput, OptionsAreValidated) {
  UnitekDrive::Options o;
  o.rx_id = 0x800;
  EXPECT_THROW(UnitekDrive{o}, std::invalid_argument);
  o.rx_id = 0x201;
  o.reference_run_time = milliseconds(-1);
  EXPECT_THROW(UnitekDrive{o}, std::invalid_argument);
}

TEST(DriveInput, TimeGoingBackwardsIsIgnored) {
  MemoryLog log;
  UnitekDrive d({}, &log);
  CollectSink out;
  d.on_frame(frame("201#3D3064"), Time{1'000'000}, out);
  ASSERT_EQ(out.frames.size(), 1u);
  d.advance(Time{900'000}, out);  // earlier: nothing happens
  EXPECT_EQ(out.frames.size(), 1u);
  EXPECT_TRUE(log.contains("time went backwards"));
  d.on_frame(frame("201#3D4000"), Time{950'000}, out);  // handled at the latest time seen
  EXPECT_EQ(out.frames.size(), 2u);
  d.advance(Time{1'100'000}, out);
  EXPECT_EQ(out.frames.size(), 3u);
}

// ---------------------------------------------------------------------------------------------
// Cyclic table (FW 378 §8: up to 8 entries, suspended entries can be overwritten)

TEST(DriveCyclic, EightEntriesThenFullUntilOneIsSuspended) {
  Replay r({});
  std::vector<std::string_view> script;
  const std::vector<std::string> reqs = {"> 201#3D2064", "> 201#3D3064", "> 201#3D3264",
                                         "> 201#3D4064", "> 201#3D6D64", "> 201#3DA864",
                                         "> 201#3DE264", "> 201#3DE864"};
  const std::vector<std::string> replies = {
      "< 181#20**0000",     "< 181#30000000", "< 181#32000000", "< 181#40**********",
      "< 181#6D**********", "< 181#A8000000", "< 181#E2010000", "< 181#E8010000"};
  for (std::size_t i = 0; i < reqs.size(); ++i) {
    script.push_back(reqs[i]);
    script.push_back(replies[i]);
  }
  ASSERT_TRUE(r.run(script));
  for (const auto& e : r.drive().cyclic_entries()) EXPECT_EQ(e.state, CyclicEntry::State::Active);

  // The ninth is refused (no reply, a warning) ...
  ASSERT_TRUE(r.run({"> 201#3DF464"}));
  EXPECT_TRUE(r.log().contains("refused: all 8 cyclic entries are active"));
  // ... until one is suspended; then the newcomer takes the suspended entry.
  ASSERT_TRUE(r.run({"> 201#3D32FF", "> 201#3DF464", "< 181#F4000000"}));
  EXPECT_EQ(r.drive().cyclic_entries()[2].regid, 0xF4);
  EXPECT_EQ(r.drive().cyclic_entries()[2].state, CyclicEntry::State::Active);
}

TEST(DriveCyclic, FreeEntriesAreUsedBeforeSuspendedOnes) {
  Replay r({});
  ASSERT_TRUE(r.run(
      {"> 201#3D3064", "< 181#30000000", "> 201#3D30FF", "> 201#3D4064", "< 181#408101000000"}));
  EXPECT_EQ(r.drive().cyclic_entries()[0].state, CyclicEntry::State::Suspended);
  EXPECT_EQ(r.drive().cyclic_entries()[1].regid, 0x40);
}

TEST(DriveCyclic, RepeatedRequestRetimesTheSameEntry) {
  Replay r({});
  ASSERT_TRUE(r.run({"> 201#3DE264", "< 181#E2010000", "~ 50", "> 201#3DE20A", "< 181#E2010000",
                     "~ 30", "< 181#E2010000", "< 181#E2010000", "< 181#E2010000", "> 201#3DE2FF",
                     "~ 500", "# stopping an unknown REGID", "> 201#3D31FF"}));
  int used = 0;
  for (const auto& e : r.drive().cyclic_entries()) used += e.state != CyclicEntry::State::Free;
  EXPECT_EQ(used, 1);
}

TEST(DriveCyclic, PeriodsOf1And254Ms) {
  Replay r({});
  ASSERT_TRUE(r.run({"> 201#3DE201", "< 181#E2010000", "~ 3", "< 181#E2010000", "< 181#E2010000",
                     "< 181#E2010000", "> 201#3DE2FE", "< 181#E2010000", "~ 253", "~ 1",
                     "< 181#E2010000"}));
}

TEST(DriveCyclic, AReplyDueWithATickCarriesTheValueOfThatTick) {
  // Time origin on a whole millisecond: replies and model ticks coincide; the tick goes first.
  Replay r({}, Time{1'000'000});
  ASSERT_TRUE(r.run({"> 201#35E803", "> 201#31FF7F", "> 201#3D3001", "< 181#30000000", "~ 1",
                     "< 181#30210000",            // 32.767 num after one tick -> 33
                     "~ 1", "< 181#30420000"}));  // 65.534 -> 66
}

TEST(DriveCyclic, NextDeadlineFollowsTheTable) {
  UnitekDrive d;
  CollectSink out;
  EXPECT_FALSE(d.next_deadline());  // no time seen yet
  d.advance(Time{10'000}, out);
  EXPECT_FALSE(d.next_deadline());  // idle motor, nothing scheduled
  d.on_frame(frame("201#3D3014"), Time{10'500}, out);
  ASSERT_TRUE(d.next_deadline());
  EXPECT_EQ(*d.next_deadline(), Time{30'500});
  d.on_frame(frame("201#31FF7F"), Time{11'000}, out);  // the motor starts: 1 ms ticks
  ASSERT_TRUE(d.next_deadline());
  EXPECT_EQ(*d.next_deadline(), Time{12'000});
  d.advance(Time{500'000}, out);  // at full speed: steady again
  EXPECT_EQ(*d.next_deadline(), Time{510'500});
}

// ---------------------------------------------------------------------------------------------
// Status events (CAN manual example 9)

TEST(DriveEvents, SubscribingSendsTheStatusOnceAndOnlyOnTheRisingEdge) {
  Replay r({});
  EXPECT_TRUE(r.run({"> 201#511000", "< 181#408101000000", "> 201#511000",
                     "# changes outside the default mask 0x3000 are silent", "> 201#511400",
                     "> 201#511000", "! limit+ 1", "# Ena in the mask", "> 201#520100",
                     "> 201#511400", "< 181#408401000000", "> 201#510000", "# events off: silent",
                     "> 201#511000", "< 181#408501000000"}));
}

TEST(DriveEvents, ReferenceRunCompletionIsAnEvent) {
  Replay r({});
  EXPECT_TRUE(r.run({"> 201#511000", "< 181#408101000000", "> 201#780100", "~ 499", "~ 2",
                     "< 181#408131000000", "? 6D = 00000000", "? 6E = 00000000"}));
}

// ---------------------------------------------------------------------------------------------
// Motor model (drive_sim/README.md "Motor model")

TEST(DriveModel, DisableRunsTheMotorDownWithTheDecRampAndEnableResumes) {
  Replay r({});
  ASSERT_TRUE(r.run({"> 201#35E803", "> 201#EDD007", "> 201#31FF7F", "~ 1000", "? 30 = 7FFF",
                     "> 201#510400", "~ 1000", "? 30 = 4000", "~ 1100", "? 30 = 0000",
                     "> 201#510000", "~ 500", "? 30 = 4000"}));
}

TEST(DriveModel, RampTimeZeroIsImmediate) {
  Replay r({});
  ASSERT_TRUE(r.run({"> 201#350000", "> 201#ED0000", "> 201#31FF7F", "~ 1", "? 30 = 7FFF",
                     "> 201#310080", "~ 1", "? 30 = 0000", "~ 1", "? 30 = 8001"}));
}

TEST(DriveModel, LessThanOnePercentFlag) {
  // 0xF5 VO_Less_N0 "message speed < 1 %": 1 % of 32767 = 327.67.
  Replay r({});
  ASSERT_TRUE(
      r.run({"? F5 = 0001", "> 201#314801", "~ 10", "? 30 = 0148", "? F5 = 0000", "> 201#314701",
             "~ 10", "? F5 = 0001", "> 201#31B8FE", "~ 10", "? F5 = 0000"}));
}

TEST(DriveModel, HardwareEnableInputAndPowerGateTheDrive) {
  Replay r({});
  ASSERT_TRUE(r.run({"! enable 0", "? E8 = 0000", "? 40 = 00000180", "? E2 = 0001", "! enable 1",
                     "! power 0", "? E2 = 0000", "? 40 = 00000180", "> 201#780100", "! power 1",
                     "? 40 = 00000181"}));
  EXPECT_FALSE(r.drive().referencing());
  EXPECT_TRUE(r.log().contains("reference run (0x78) refused"));
}

TEST(DriveModel, SpeedIsLimitedBySpeedLimitAndClips) {
  Replay r({});
  ASSERT_TRUE(
      r.run({"> 201#340040", "> 201#31FF7F", "~ 500", "? 30 = 4000", "> 201#3F0020", "~ 500",
             "? 30 = 2000", "> 201#3E00F0", "> 201#310180", "~ 500", "? 30 = F000"}));
}

TEST(DriveModel, LimitSwitchStopsMotionTowardsIt) {
  Replay r({});
  ASSERT_TRUE(r.run({"> 201#31FF7F", "~ 500", "! limit+ 1", "# R-Lim 0xC7 = 10 ms for 100 %",
                     "~ 10", "? 30 = 0000", "? E4 = 0001", "> 201#310080", "~ 500", "? 30 = 8001",
                     "! limit- 1", "~ 10", "? 30 = 0000"}));
}

TEST(DriveModel, PositionReachesTargetExactlyWithSlowRampsAndSmallMoves) {
  Replay r({});
  ASSERT_TRUE(
      r.run({"> 201#780100", "~ 600", "> 201#EDFFFF", "> 201#6E01000000", "~ 100",
             "? 6D = 00000001", "> 201#6EFFFFFFFF", "~ 100", "? 6D = FFFFFFFF", "> 201#ED6400",
             "> 201#6E00E1F505", "~ 30000", "? 6D = 05F5E100", "? 30 = 0000", "? F4 = 0001"}));
  EXPECT_EQ(r.drive().control_mode(), ControlMode::Position);
  EXPECT_FALSE(r.drive().next_deadline());  // at rest
}

TEST(DriveModel, PositionCommandDuringReferenceRunStartsAfterIt) {
  Replay r({});
  ASSERT_TRUE(r.run({"> 201#780100", "~ 100", "> 201#6EC0C62D00", "~ 300", "? 6D = 000086B9",
                     "~ 2000", "? 6D = 002DC6C0", "? 40 = 00003181"}));
}

TEST(DriveModel, ReferenceRunAbortsWhenDisabled) {
  Replay r({});
  ASSERT_TRUE(r.run({"> 201#780100", "~ 100", "> 201#510400", "~ 1000", "? 40 = 00000180"}));
  EXPECT_FALSE(r.drive().referencing());
  EXPECT_FALSE(r.drive().referenced());
  EXPECT_TRUE(r.log().contains("reference run aborted"));
}

TEST(DriveModel, PositionIntegratesExactlyOverLongRunsAndWrapsLikeInt32) {
  // 100 % speed = N max 3600 rpm = 60 rev/s = 3932160 counts/s (German manual §7.1: 65536
  // counts per revolution); one hour later the int32 position has wrapped many times.
  Replay r({});
  ASSERT_TRUE(r.run({"> 201#31FF7F", "~ 1000"}));
  const std::int64_t start = r.drive().position_actual();
  const std::int64_t per_second = 3932160;  // 3600 rpm / 60 * 65536, exact at 32767 num
  ASSERT_TRUE(r.run({"~ 3600000"}));
  const std::int64_t expected = start + per_second * 3600;
  EXPECT_EQ(r.drive().position_actual(),
            static_cast<std::int32_t>(static_cast<std::uint32_t>(expected)));
}

TEST(DriveModel, TorqueModeAcceleratesInProportionToTorque) {
  // 100 % torque (21845) accelerates at the ACC ramp's rate: ACC 1000 ms -> 32767 in 1 s.
  Replay r({});
  // 500 ms at 32.767 num/ms = 16383.5 -> 16384; then 50 % torque adds 500 * 16.384 -> 24576;
  // zero torque runs down at DEC (2000 ms: 16.383 num/ms): 100 ms later 22937.
  ASSERT_TRUE(
      r.run({"> 201#35E803", "> 201#EDD007", "> 201#905555", "~ 500", "? 30 = 4000", "> 201#90AB2A",
             "~ 500", "? 30 = 6000", "> 201#900000", "~ 100", "? 30 = 5999", "? A0 = 0000"}));
}

// ---------------------------------------------------------------------------------------------
// On a virtual bus, as the daemon or a test bench would wire it

TEST(DriveOnBus, AnswersAMasterOnTheVirtualBus) {
  can::VirtualBus bus;
  auto master = bus.endpoint("master");
  auto drive_ep = bus.endpoint("drive");
  UnitekDrive drive;
  Time now{0};
  auto pump = [&] {
    while (auto f = drive_ep->receive()) drive.on_frame(*f, now, *drive_ep);
    drive.advance(now, *drive_ep);
  };
  master->send(frame("201#3D4000"));
  pump();
  auto reply = master->receive();
  ASSERT_TRUE(reply);
  EXPECT_EQ(*reply, frame("181#408101000000"));
  master->send(frame("201#3D300A"));
  pump();
  for (int i = 0; i < 5; ++i) {
    now += milliseconds(10);
    pump();
  }
  int replies = 0;
  while (auto f = master->receive()) {
    EXPECT_EQ(*f, frame("181#30000000"));
    ++replies;
  }
  EXPECT_EQ(replies, 6);  // at once, then 5 x 10 ms
}

// ---------------------------------------------------------------------------------------------
// The register table against the list it was transcribed from: the REGID register list of the
// Unitek short description FW 378, a vendor manual (docs/development.md "Vendor files"). The test
// reads the plain-text manual in the folder CANDP2_MANUALS names that holds the list (the file with
// its header row "RegNr Typ Hex value ...").

// The lines of the first .txt file in `dir` with the register list's header row.
std::vector<std::string> register_list_lines(const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.is_regular_file() && e.path().extension() == ".txt") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    std::ifstream in(f);
    std::vector<std::string> lines;
    bool has_list = false;
    for (std::string l; std::getline(in, l);) {
      has_list = has_list || l.starts_with("RegNr\tTyp\tHex value");
      lines.push_back(l);
    }
    if (has_list) return lines;
  }
  return {};
}

TEST(VendorManual, RegisterTableMatchesTheRegisterList) {
  CANDP2_VENDOR_DIR(manuals, candp2::test::kManualsVar);
  const std::vector<std::string> lines = register_list_lines(manuals);
  ASSERT_FALSE(lines.empty()) << "no REGID register list (\"RegNr\tTyp\tHex value\") in "
                              << manuals;
  const std::regex row(R"(^0x([0-9a-f]{2})\t\((RO|RW|SP|FN|UK)\)\t(?:: )?0x([0-9a-f]+)\t.*$)");
  for (const RegisterInfo& info : register_table()) {
    SCOPED_TRACE("REGID " + std::to_string(info.regid));
    ASSERT_LT(info.source_line - 1u, lines.size());
    std::smatch m;
    const std::string& text = lines[info.source_line - 1];
    ASSERT_TRUE(std::regex_match(text, m, row)) << text;
    EXPECT_EQ(std::stoul(m[1], nullptr, 16), info.regid);
    EXPECT_EQ(m[2].str(), to_string(info.access));
    const std::string hex = m[3];
    EXPECT_EQ(info.width, hex.size() == 8 ? Width::W32 : Width::W16);
    const unsigned long printed =
        std::stoul(hex, nullptr, 16) & (hex.size() == 8 ? 0xFFFFFFFFu : 0xFFFFu);
    // STATUS_MASK: CAN manual example 9 and docs/drive-simulator.md give the default 0x3000.
    EXPECT_EQ(info.default_value, info.regid == reg::kStatusMask ? 0x3000u : printed);
  }
}

TEST(RegisterTable, WidthsTheExamplesDependOn) {
  EXPECT_EQ(register_info(reg::kStatus).width, Width::W32);
  EXPECT_EQ(register_info(reg::kPosDest).width, Width::W32);
  EXPECT_EQ(register_info(reg::kAccRamp).width, Width::W32);
  EXPECT_EQ(register_info(reg::kSpeedCmd).width, Width::W16);
  EXPECT_EQ(register_info(reg::kSpeedActual).width, Width::W16);
  EXPECT_EQ(register_info(reg::kCanIdRx).default_value, 0x201u);
  EXPECT_EQ(register_info(reg::kCanIdTx).default_value, 0x181u);
}

}  // namespace
}  // namespace candp2::drive::test
