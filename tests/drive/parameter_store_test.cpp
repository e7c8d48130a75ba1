// EEPROM persistence (CAN manual example 7, REGID 0x84): the state file format and a round trip
// through a real file.
#include "drive_sim/parameter_store.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "drive_sim/file_parameter_store.hpp"
#include "drive_sim/unitek_drive.hpp"
#include "replay.hpp"

namespace candp2::drive::test {
namespace {

namespace fs = std::filesystem;

// A fresh directory per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    std::string templ = (fs::temp_directory_path() / "candp2-drive-XXXXXX").string();
    if (!mkdtemp(templ.data())) throw std::runtime_error("mkdtemp failed");
    path_ = templ;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  fs::path file(const char* name) const { return path_ / name; }

 private:
  fs::path path_;
};

std::string read_all(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(StateFile, FormatAndParseRoundTrip) {
  StoredParameters p;
  p.values = {{0x35, 0x000001F4}, {0x68, 0x0210}, {0x2F, 0x10000000}};
  const std::string text = format_state_file(p);
  EXPECT_NE(text.find("0x35 = 0x000001F4  # SPEED_DELTAMA\n"), std::string::npos) << text;
  EXPECT_NE(text.find("0x68 = 0x0210  # CAN_ID_RX\n"), std::string::npos) << text;
  const auto parsed = parse_state_file(text);
  ASSERT_TRUE(parsed.parameters) << parsed.error;
  EXPECT_EQ(*parsed.parameters, p);
}

TEST(StateFile, AcceptsCommentsBlankLinesAndCrLf) {
  const auto parsed =
      parse_state_file("# header\r\n\r\n  0x31=0x0CCD # speed\r\n0X6e = 0xffffff00\n");
  ASSERT_TRUE(parsed.parameters) << parsed.error;
  EXPECT_EQ(parsed.parameters->values.at(0x31), 0x0CCDu);
  EXPECT_EQ(parsed.parameters->values.at(0x6E), 0xFFFFFF00u);
}

TEST(StateFile, RejectsMalformedLinesNamingTheLine) {
  struct Bad {
    const char* text;
    std::size_t line;
    const char* message;
  } cases[] = {
      {"0x35 0x01F4\n", 1, "expected 'REGID = VALUE'"},
      {"# ok\n0x135 = 0x1\n", 2, "REGID must be a hex number 0x00..0xFF"},
      {"0x35 = 500\n", 1, "value must be a hex number"},
      {"0x35 = 0x123456789\n", 1, "value must be a hex number"},
      {"0x31 = 0x10000\n", 1, "does not fit the 16-bit register SPEED_CMD"},
      {"0x35 = 0x1\n0x35 = 0x2\n", 2, "REGID listed twice"},
      {"0x35 = 0x1z\n", 1, "value must be a hex number"},
  };
  for (const auto& c : cases) {
    const auto parsed = parse_state_file(c.text);
    EXPECT_FALSE(parsed.parameters) << c.text;
    EXPECT_EQ(parsed.line, c.line) << c.text;
    EXPECT_NE(parsed.error.find(c.message), std::string::npos) << c.text << ": " << parsed.error;
  }
}

// CAN manual example 7 on a real file: parameters written by 0x84 come back at the next start.
TEST(StateFile, EepromWriteSurvivesARestart) {
  TempDir dir;
  FileParameterStore store(dir.file("drive.eeprom").string());
  CollectSink out;
  {
    UnitekDrive d({}, nullptr, &store);
    d.on_frame(can::Frame::std_data(0x201, std::array<std::uint8_t, 3>{0x35, 0xF4, 0x01}), Time{0},
               out);
    d.on_frame(can::Frame::std_data(0x201, std::array<std::uint8_t, 3>{0x68, 0x10, 0x02}), Time{0},
               out);
    d.on_frame(can::Frame::std_data(0x210, std::array<std::uint8_t, 3>{0x31, 0xCD, 0x0C}), Time{0},
               out);  // a set point (RW in the list, but never stored)
    EXPECT_FALSE(fs::exists(dir.file("drive.eeprom")));
    d.on_frame(can::Frame::std_data(0x210, std::array<std::uint8_t, 3>{0x84, 0x00, 0x00}), Time{0},
               out);
  }
  ASSERT_TRUE(fs::exists(dir.file("drive.eeprom")));
  EXPECT_FALSE(fs::exists(dir.file("drive.eeprom.tmp")));
  const std::string text = read_all(dir.file("drive.eeprom"));
  EXPECT_NE(text.find("0x35 = 0x000001F4"), std::string::npos);
  EXPECT_NE(text.find("0x68 = 0x0210"), std::string::npos);
  EXPECT_EQ(text.find("0x31 ="), std::string::npos);

  MemoryLog log;
  UnitekDrive d({}, &log, &store);
  EXPECT_EQ(d.reg(reg::kAccRamp), 0x1F4u);
  EXPECT_EQ(d.rx_id(), 0x210u);
  EXPECT_EQ(d.reg(reg::kSpeedCmd), 0u);
  EXPECT_TRUE(log.contains("loaded"));
  EXPECT_TRUE(out.frames.empty());  // writes are never answered
}

TEST(StateFile, CorruptFileStartsFromDefaultsAndSaysWhy) {
  TempDir dir;
  {
    std::ofstream f(dir.file("bad.eeprom"));
    f << "0x35 = 0x000001F4\nthis is not a parameter\n";
  }
  FileParameterStore store(dir.file("bad.eeprom").string());
  MemoryLog log;
  UnitekDrive d({}, &log, &store);
  EXPECT_EQ(d.reg(reg::kAccRamp), register_info(reg::kAccRamp).default_value);
  EXPECT_TRUE(log.contains("rejected, line 2: expected 'REGID = VALUE'"));
  for (const auto& l : log.lines)
    if (l.message.find("rejected") != std::string::npos) {
      EXPECT_EQ(l.level, LogLevel::Error);
    }
}

TEST(StateFile, StoredValuesThatAreNoParametersAreIgnored) {
  MemoryParameterStore store;
  store.stored = StoredParameters{{{0x30, 0x1234}, {0x31, 0x7FFF}, {0x68, 0x0300}, {0x35, 0x03E8}}};
  MemoryLog log;
  UnitekDrive d({}, &log, &store);
  EXPECT_EQ(d.reg(reg::kSpeedActual), 0u);
  EXPECT_EQ(d.reg(reg::kSpeedCmd), 0u);
  EXPECT_EQ(d.rx_id(), 0x201u);
  EXPECT_EQ(d.reg(reg::kAccRamp), 0x3E8u);
  EXPECT_TRUE(log.contains("0x30 (SPEED_ACTUAL) ignored: not a stored parameter"));
  EXPECT_TRUE(log.contains("0x31 (SPEED_CMD) ignored: not a stored parameter"));
  EXPECT_TRUE(log.contains("ignored: outside the manual's range"));
}

TEST(StateFile, SaveFailureIsLoggedAndTheDriveCarriesOn) {
  TempDir dir;
  FileParameterStore store((dir.file("no-such-dir") / "drive.eeprom").string());
  Replay r({});
  MemoryLog log;
  UnitekDrive d({}, &log, &store);
  CollectSink out;
  d.on_frame(can::Frame::std_data(0x201, std::array<std::uint8_t, 3>{0x84, 0x00, 0x00}), Time{0},
             out);
  EXPECT_TRUE(log.contains("EEPROM write (0x84) failed: cannot create"));
  d.on_frame(can::Frame::std_data(0x201, std::array<std::uint8_t, 3>{0x3D, 0xE2, 0x00}), Time{0},
             out);
  EXPECT_EQ(out.frames.size(), 1u);
}

TEST(StateFile, EepromWriteWithoutStoreWarns) {
  MemoryLog log;
  UnitekDrive d({}, &log);
  CollectSink out;
  d.on_frame(can::Frame::std_data(0x201, std::array<std::uint8_t, 3>{0x84, 0x00, 0x00}), Time{0},
             out);
  EXPECT_TRUE(log.contains("without a state store"));
}

TEST(StateFile, ParaReadReloadsTheStore) {
  // REGID 0x83 FUN_PARAREAD: back to the stored parameters.
  Replay r({});
  ASSERT_TRUE(r.run({"> 201#35F401", "> 201#840000", "$ saves 1", "> 201#35E803", "? 35 = 000003E8",
                     "> 201#830000", "? 35 = 000001F4"}));
}

}  // namespace
}  // namespace candp2::drive::test
