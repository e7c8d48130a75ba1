// GSD revision 0 files (no GSD_Revision keyword, as real Siemens files of the 1990s) are
// accepted; a file that is not a GSD at all is refused with one line.
#include <gtest/gtest.h>

#include <filesystem>

#include "gsd/check.hpp"
#include "gsd/gsd.hpp"
#include "gsd/summary.hpp"

namespace candp2::gsd {
namespace {

// A 1990s-style revision 0 file, written for this test: no GSD_Revision, no module blocks beyond
// what the first GSD specification had.
const char* const kRev0 =
    ";=================================\n"
    "; GSD file, revision 0 style\n"
    ";=================================\n"
    "#Profibus_DP\n"
    "Vendor_Name=\"Old Vendor\"\n"
    "Model_Name=\"ET 100 style\"\n"
    "Revision=\"A1\"\n"
    "Ident_Number=0x0011\n"
    "Protocol_Ident=0\n"
    "Station_Type=0\n"
    "Hardware_Release=\"A1\"\n"
    "Software_Release=\"Z1\"\n"
    "9.6_supp=1\n"
    "19.2_supp=1\n"
    "MaxTsdr_9.6=60\n"
    "MaxTsdr_19.2=60\n"
    "Min_Slave_Intervall=20\n"
    "Modular_Station=0\n"
    "Module=\"8 DI\" 0x10\n"
    "EndModule\n";

TEST(GsdRevision0, AcceptedWithANoteInTheSummary) {
  const auto r = parse(kRev0);
  EXPECT_TRUE(r.ok());
  EXPECT_FALSE(r.not_gsd);
  EXPECT_FALSE(r.model.gsd_revision());
  for (const auto& d : check(r.model)) EXPECT_NE(d.severity, Severity::Error) << d.message;
  const std::string s = summary(r.model);
  EXPECT_NE(s.find("GSD_Revision"), std::string::npos) << s;
  EXPECT_NE(s.find("revision 0"), std::string::npos) << s;
}

TEST(GsdNotAGsd, TextWithoutHeaderOrKeywordsIsOneLine) {
  std::string text;
  for (int i = 0; i < 500; ++i)
    text += "Lorem ipsum dolor sit amet, line " + std::to_string(i) + "\n";
  const auto r = parse(text);
  EXPECT_TRUE(r.not_gsd);
  ASSERT_EQ(r.diagnostics.size(), 1u);
  EXPECT_EQ(r.diagnostics[0].message.rfind("not a GSD file: ", 0), 0u) << r.diagnostics[0].message;
}

TEST(GsdNotAGsd, BinaryIsOneLine) {
  std::string bin =
      "\x7F"
      "ELF";
  for (int i = 0; i < 2000; ++i) bin += static_cast<char>(i % 256);
  const auto r = parse(bin);
  EXPECT_TRUE(r.not_gsd);
  ASSERT_EQ(r.diagnostics.size(), 1u);
  EXPECT_NE(r.diagnostics[0].message.find("binary"), std::string::npos);
}

TEST(GsdNotAGsd, AFileWithoutHeaderButWithKeywordsIsStillParsed) {
  // Keeps the detailed diagnostics for broken GSDs (missing header).
  const auto r = parse("Vendor_Name = \"x\"\n");
  EXPECT_FALSE(r.not_gsd);
  EXPECT_FALSE(r.ok());
}

}  // namespace
}  // namespace candp2::gsd
