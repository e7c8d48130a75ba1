// check(): one finding per kind of inconsistency, on the line that causes it; a minimal valid
// GSD has none.
#include "gsd/check.hpp"

#include <gtest/gtest.h>

#include "gsd/gsd.hpp"
#include "tools/candp2/gsd_reading.hpp"

namespace candp2::gsd {
namespace {

// 20 lines, no findings.
const std::string kBase =
    "#Profibus_DP\n"
    "GSD_Revision=1\n"
    "Vendor_Name=\"v\"\n"
    "Model_Name=\"m\"\n"
    "Revision=\"1\"\n"
    "Ident_Number=0x1234\n"
    "Protocol_Ident=0\n"
    "Station_Type=0\n"
    "Hardware_Release=\"1\"\n"
    "Software_Release=\"1\"\n"
    "9.6_supp=1\n"
    "MaxTsdr_9.6=60\n"
    "Min_Slave_Intervall=1\n"
    "Modular_Station=1\n"
    "Max_Module=4\n"
    "Max_Input_Len=16\n"
    "Max_Output_Len=16\n"
    "Max_User_Prm_Data_Len=4\n"
    "Module=\"in\" 0x13\n"
    "EndModule\n";
constexpr int kBaseLines = 20;

std::string dump(const std::vector<Diagnostic>& ds) {
  std::string s;
  for (const auto& d : ds) s += format(d, "t.gsd") + "\n";
  return s;
}

std::string without(std::string text, const std::string& line) {
  const auto at = text.find(line);
  if (at != std::string::npos) text.erase(at, line.size());
  return text;
}

TEST(GsdCheck, MinimalValidFileHasNoFindings) {
  const ParseResult r = parse(kBase);
  ASSERT_TRUE(r.diagnostics.empty());
  EXPECT_TRUE(check(r.model).empty()) << dump(check(r.model));
}

struct Case {
  const char* name;
  std::string text;
  int line;  // 0 = file level; > 0: line in text
  Severity severity;
  const char* part;
};

TEST(GsdCheck, Findings) {
  const int L = kBaseLines;
  const std::string eupd = "ExtUserPrmData=1 \"a\"\n";
  const Case cases[] = {
      {"mandatory keyword", without(kBase, "Vendor_Name=\"v\"\n"), 0, Severity::Error,
       "mandatory keyword Vendor_Name is missing"},
      {"no baud rate", without(kBase, "9.6_supp=1\n"), 0, Severity::Error,
       "no supported baud rate"},
      {"baud without MaxTsdr", kBase + "12M_supp=1\n", L + 1, Severity::Warning,
       "12M_supp without MaxTsdr_12M"},
      {"modular limits", without(kBase, "Max_Module=4\n"), 14, Severity::Error,
       "modular station without Max_Module"},
      {"limit out of range", without(kBase, "Max_Input_Len=16\n") + "Max_Input_Len=245\n", L,
       Severity::Error, "Max_Input_Len = 245 outside 0..244"},
      {"undefined ExtUserPrmData", kBase + "Ext_User_Prm_Data_Ref(0) = 7\n", L + 1, Severity::Error,
       "Ext_User_Prm_Data_Ref(0) = 7 refers to an undefined ExtUserPrmData"},
      {"undefined PrmText", kBase + eupd + "Bit(0) 0 0-1\nPrm_Text_Ref=9\nEndExtUserPrmData\n",
       L + 1, Severity::Error, "Prm_Text_Ref = 9 refers to an undefined PrmText"},
      {"default out of range", kBase + eupd + "Unsigned8 200 0-100\nEndExtUserPrmData\n", L + 1,
       Severity::Error, "default 200 outside the range 0-100"},
      {"default not in list", kBase + eupd + "Unsigned8 3 0,1,2\nEndExtUserPrmData\n", L + 1,
       Severity::Error, "default 3 not in the allowed values 0,1,2"},
      {"range beyond type", kBase + eupd + "Unsigned8 0 0-300\nEndExtUserPrmData\n", L + 1,
       Severity::Error, "range 0-300 exceeds what Unsigned8 holds (0..255)"},
      {"bit number", kBase + eupd + "Bit(9) 0 0-1\nEndExtUserPrmData\n", L + 1, Severity::Error,
       "Bit(9) outside 0..7"},
      {"bit area order", kBase + eupd + "BitArea(6-2) 0 0-1\nEndExtUserPrmData\n", L + 1,
       Severity::Error, "BitArea(6-2) is not within 0..7 in ascending order"},
      {"duplicate definition",
       kBase + eupd + "Bit(0) 0 0-1\nEndExtUserPrmData\n" + eupd + "Bit(1) 0 0-1\nEnd" +
           "ExtUserPrmData\n",
       L + 4, Severity::Error, "ExtUserPrmData 1 \"a\" defined twice (first at line 21)"},
      {"duplicate PrmText",
       kBase + "PrmText=2\nText(0)=\"x\"\nEndPrmText\nPrmText=2\n" + "Text(0)=\"y\"\nEndPrmText\n",
       L + 4, Severity::Error, "PrmText 2 defined twice"},
      {"ref beyond Max_User_Prm_Data_Len",
       kBase + eupd + "Unsigned16 0 0-9\nEndExtUserPrmData\nExt_User_Prm_Data_Ref(3) = 1\n", L + 4,
       Severity::Error,
       "Ext_User_Prm_Data_Ref(3) \"a\" ends at byte 5, beyond Max_User_Prm_Data_Len = 4"},
      {"const beyond Max_User_Prm_Data_Len", kBase + "Ext_User_Prm_Data_Const(2) = 1,2,3\n", L + 1,
       Severity::Error, "Ext_User_Prm_Data_Const(2) ends at byte 5"},
      {"ref beyond User_Prm_Data_Len",
       without(kBase, "Max_User_Prm_Data_Len=4\n") + "User_Prm_Data_Len=2\n" +
           "Ext_User_Prm_Data_Const(0) = 1,2,3\n",
       L + 1, Severity::Error, "ends at byte 3, beyond User_Prm_Data_Len = 2"},
      {"legacy bytes disagree",
       kBase + "User_Prm_Data=0x00,0x80\n" + eupd + "Bit(7) 0 0-1\nEndExtUserPrmData\n" +
           "Ext_User_Prm_Data_Const(0)=0,0\nExt_User_Prm_Data_Ref(1)=1\n",
       L + 1, Severity::Warning,
       "User_Prm_Data byte 1 is 80, the Ext_User_Prm_Data defaults give 00"},
      {"overlapping parameters",
       kBase + eupd + "BitArea(0-3) 0 0-15\nEndExtUserPrmData\nExtUserPrmData=2 \"b\"\n" +
           "Bit(2) 0 0-1\nEndExtUserPrmData\nExt_User_Prm_Data_Ref(0)=1\n" +
           "Ext_User_Prm_Data_Ref(0)=2\n",
       L + 8, Severity::Warning, "\"b\" overlaps \"a\" (line 27)"},
      {"malformed module", kBase + "Module=\"bad\" 0x45,0x8F,0xFF\nEndModule\n", L + 1,
       Severity::Error,
       "Module \"bad\": malformed configuration: byte 0 (0x45): Chk_Cfg truncated: "
       "manufacturer bytes missing"},
      // dp::decode_chk_cfg reads m = 15 like any other count: 15 bytes are missing here.
      {"manufacturer length 15", kBase + "Module=\"r\" 0x4F,0x00\nEndModule\n", L + 1,
       Severity::Error, "byte 0 (0x4F): Chk_Cfg truncated: manufacturer bytes missing"},
      {"module too long", kBase + "Module=\"big\" 0x40,0x9F\nEndModule\n", L + 1, Severity::Error,
       "32 input bytes exceed Max_Input_Len 16"},
      {"module parameters beyond their length",
       kBase + eupd + "Unsigned16 0 0-9\nEndExtUserPrmData\nModule=\"p\" 0x10\n" +
           "Ext_Module_Prm_Data_Len=2\nExt_User_Prm_Data_Ref(1)=1\nEndModule\n",
       L + 6, Severity::Error, "beyond Ext_Module_Prm_Data_Len = 2"},
      {"slot refers to an unknown module",
       kBase + "SlotDefinition\nSlot(1) = \"s\" 7 7\nEndSlotDefinition\n", L + 2, Severity::Error,
       "default module reference 7 is not defined"},
      {"CAN-DP/2 slot rules",
       without(kBase, "Ident_Number=0x1234\n") + "Ident_Number=0x04A4\n" +
           "Module=\"w\" 0x43,0x47,0x01,0x81,0x00\nEndModule\n",
       L + 1, Severity::Error, "the CAN-DP/2 rejects this entry (Cfg fault code 2"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const ParseResult r = parse(c.text);
    for (const auto& d : r.diagnostics) ADD_FAILURE() << "parse: " << format(d, "t.gsd");
    const auto findings = check(r.model, &cli::candp2_reader());
    bool found = false;
    for (const auto& d : findings)
      if (d.line == c.line && d.severity == c.severity &&
          d.message.find(c.part) != std::string::npos)
        found = true;
    EXPECT_TRUE(found) << "expected line " << c.line << ": " << c.part << "\ngot:\n"
                       << dump(findings);
  }
}

}  // namespace
}  // namespace candp2::gsd
