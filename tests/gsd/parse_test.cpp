// GSD syntax: comments, continuation, case, numbers, strings, blocks, unknown keywords, and
// line-numbered diagnostics for broken files (the parser never stops at an error).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/hex.hpp"
#include "gsd/gsd.hpp"

namespace candp2::gsd {
namespace {

using ::testing::HasSubstr;

std::string dump(const ParseResult& r) {
  std::string s;
  for (const auto& d : r.diagnostics) s += format(d, "t.gsd") + "\n";
  return s;
}

TEST(GsdParse, KeywordsAreCaseInsensitiveAndNumbersDecimalOrHex) {
  const ParseResult r = parse(
      "#profibus_dp\n"
      "gsd_revision = 5\n"
      "VENDOR_NAME=\"ACME\"\n"
      "Ident_Number = 0x04a4\n"
      "Max_Input_Len=0244\n"  // leading zero: still decimal
      "MaxTsdr_1.5M = 150\n");
  EXPECT_TRUE(r.diagnostics.empty()) << dump(r);
  EXPECT_TRUE(r.model.has_header);
  EXPECT_EQ(r.model.gsd_revision(), 5);
  EXPECT_EQ(r.model.vendor_name(), "ACME");
  EXPECT_EQ(r.model.ident_number(), 0x04A4);
  EXPECT_EQ(r.model.number("max_input_len"), 244);
  EXPECT_EQ(r.model.number("MAXTSDR_1.5m"), 150);
  EXPECT_EQ(r.model.find("Vendor_Name")->line, 3);
}

TEST(GsdParse, CommentsAndContinuationsAlsoInsideStringsAndBeforeComments) {
  const ParseResult r = parse(
      "; header comment\n"
      "#Profibus_DP ; trailing comment\n"
      "User_Prm_Data = 0x01,0x02,\\   ; comment after the continuation\n"
      "                0x03\n"
      "Info_Text = \"a;b \\\n"
      "c\"  ; not part of the string\n"
      "Module = \"M\" \\\n"
      "0x10\n"
      "EndModule\n");
  EXPECT_TRUE(r.diagnostics.empty()) << dump(r);
  ASSERT_TRUE(r.model.user_prm_data());
  EXPECT_EQ(hex_bytes(*r.model.user_prm_data()), "01 02 03");
  EXPECT_EQ(r.model.string("Info_Text"), "a;b c");
  ASSERT_EQ(r.model.modules.size(), 1u);
  EXPECT_EQ(hex_bytes(r.model.modules[0].config), "10");
  EXPECT_EQ(r.model.modules[0].line, 7);
}

TEST(GsdParse, CrLfAndBomAndLatin1) {
  const ParseResult r = parse("\xEF\xBB\xBF#Profibus_DP\r\nModel_Name=\"Z\xE4hler\"\r\n");
  EXPECT_TRUE(r.diagnostics.empty()) << dump(r);
  EXPECT_EQ(r.model.model_name(), "Z\xE4hler");  // kept as written
  EXPECT_EQ(to_utf8(r.model.model_name()), "Z\xC3\xA4hler");
  EXPECT_EQ(to_utf8("Z\xC3\xA4hler"), "Z\xC3\xA4hler");  // valid UTF-8 stays
}

TEST(GsdParse, PrmTextAndExtUserPrmDataForms) {
  const ParseResult r = parse(
      "#Profibus_DP\n"
      "PrmText = 7\n"
      "Text(0) = \"Off\"\n"
      "Text(1)=\"On   \"\n"
      "EndPrmText\n"
      "ExtUserPrmData = 1 \"Flag\"\n"
      "Bit(3) 1 0-1\n"
      "Prm_Text_Ref = 7\n"
      "Changeable = 0\n"
      "Visible = 0\n"
      "X_Vendor_Thing = 4\n"
      "EndExtUserPrmData\n"
      "ExtUserPrmData=2 \"Area\"\n"
      "BitArea( 4 - 6 ) 5 0,2,5,7\n"
      "EndExtUserPrmData\n"
      "ExtUserPrmData=3 \"Signed\" Signed16 -2 -100--1\n"  // type on the header line
      "EndExtUserPrmData\n"
      "EXTUSERPRMDATA=4 \"U32\"\n"
      "unsigned32 0x10000 0-0xFFFFFFFF\n"
      "endextuserprmdata\n");
  EXPECT_TRUE(r.diagnostics.empty()) << dump(r);
  const Model& m = r.model;
  ASSERT_NE(m.prm_text(7), nullptr);
  EXPECT_EQ(m.prm_text(7)->value_for("on"), 1);
  ASSERT_EQ(m.ext_user_prm_data.size(), 4u);
  const ExtUserPrmData* f = m.ext_user_prm(1);
  EXPECT_EQ(f->name, "Flag");
  EXPECT_EQ(f->type, PrmType::Bit);
  EXPECT_EQ(f->first_bit, 3);
  EXPECT_EQ(f->default_value, 1);
  EXPECT_EQ(f->min, 0);
  EXPECT_EQ(f->max, 1);
  EXPECT_EQ(f->prm_text_ref, 7);
  EXPECT_FALSE(f->changeable);
  EXPECT_FALSE(f->visible);
  ASSERT_EQ(f->other.size(), 1u);
  EXPECT_EQ(f->other[0].key, "X_Vendor_Thing");
  const ExtUserPrmData* a = m.ext_user_prm(2);
  EXPECT_EQ(a->type, PrmType::BitArea);
  EXPECT_EQ(a->first_bit, 4);
  EXPECT_EQ(a->last_bit, 6);
  EXPECT_EQ(a->allowed, (std::vector<std::int64_t>{0, 2, 5, 7}));
  EXPECT_TRUE(a->allows(5));
  EXPECT_FALSE(a->allows(4));
  const ExtUserPrmData* s = m.ext_user_prm(3);
  EXPECT_EQ(s->type, PrmType::Signed16);
  EXPECT_EQ(s->default_value, -2);
  EXPECT_EQ(s->min, -100);
  EXPECT_EQ(s->max, -1);
  EXPECT_EQ(m.ext_user_prm(4)->type, PrmType::Unsigned32);
  EXPECT_EQ(m.ext_user_prm(4)->max, 0xFFFFFFFF);
}

TEST(GsdParse, ModulesWithReferenceParametersAndDataArea) {
  const ParseResult r = parse(
      "#Profibus_DP\n"
      "Module=\"Leermodul\"0x00\n"  // no blank between name and bytes (as in vendor files)
      "EndModule\n"
      "Module = \"PRM\" 0xC1,0x0F,0x0F,0x00\n"
      "6\n"
      "Ext_Module_Prm_Data_Len = 3\n"
      "Ext_User_Prm_Data_Const(0) = 0x05,0x00,0x00\n"
      "Ext_User_Prm_Data_Ref(1) = 2\n"
      "Preset = 1\n"
      "Data_Area_Beg\n"
      "Area_Ref = 1\n"
      "Data_Area_End\n"
      "EndModule\n");
  EXPECT_TRUE(r.diagnostics.empty()) << dump(r);
  ASSERT_EQ(r.model.modules.size(), 2u);
  EXPECT_EQ(hex_bytes(r.model.modules[0].config), "00");
  const Module& m = r.model.modules[1];
  EXPECT_EQ(m.name, "PRM");
  EXPECT_EQ(hex_bytes(m.config), "C1 0F 0F 00");
  EXPECT_EQ(m.reference, 6);
  EXPECT_EQ(m.ext_module_prm_data_len, 3);
  ASSERT_EQ(m.prm.consts.size(), 1u);
  EXPECT_EQ(hex_bytes(m.prm.consts[0].bytes), "05 00 00");
  ASSERT_EQ(m.prm.refs.size(), 1u);
  EXPECT_EQ(m.prm.refs[0].offset, 1);
  EXPECT_EQ(m.prm.refs[0].ref, 2);
  ASSERT_EQ(m.settings.size(), 1u);
  EXPECT_EQ(m.settings[0].key, "Preset");
  ASSERT_EQ(m.blocks.size(), 1u);
  EXPECT_EQ(m.blocks[0].keyword, "Data_Area_Beg");
  ASSERT_EQ(m.blocks[0].settings.size(), 1u);
  EXPECT_EQ(m.blocks[0].settings[0].key, "Area_Ref");
  EXPECT_EQ(r.model.module(" prm "), &m);
}

TEST(GsdParse, SlotsUnitDiagAndOtherBlocks) {
  const ParseResult r = parse(
      "#Profibus_DP\n"
      "SlotDefinition\n"
      "Slot(1) = \"Interface\" 1 2-3\n"
      "Slot(2) = \"Other\" 4 4,5\n"
      "EndSlotDefinition\n"
      "Unit_Diag_Bit( 0) = \"Invalid sensor\"\n"
      "Unit_Diag_Not_Bit(024) = \"Not ready\"\n"
      "Unit_Diag_Area = 16-17\n"
      "Value(0) = \"OK\"\n"
      "Value(3) = \"Broken\"\n"
      "Unit_Diag_Area_End\n"
      "UnitDiagType = 5\n"
      "X_Unit_Diag_Bit(3) = \"x\"\n"
      "EndUnitDiagType\n"
      "Version_Firmware_Download\n"
      "Whatever = 1\n"
      "End_Version_Firmware_Download\n");
  EXPECT_TRUE(r.diagnostics.empty()) << dump(r);
  const Model& m = r.model;
  ASSERT_EQ(m.slots.size(), 2u);
  EXPECT_EQ(m.slots[0].name, "Interface");
  EXPECT_EQ(m.slots[0].default_ref, 1);
  EXPECT_EQ(m.slots[0].min, 2);
  EXPECT_EQ(m.slots[0].max, 3);
  EXPECT_EQ(m.slots[1].allowed, (std::vector<std::int64_t>{4, 5}));
  ASSERT_EQ(m.unit_diag_bits.size(), 2u);
  EXPECT_EQ(m.unit_diag_bits[1].bit, 24);
  EXPECT_TRUE(m.unit_diag_bits[1].negated);
  ASSERT_EQ(m.unit_diag_areas.size(), 1u);
  EXPECT_EQ(m.unit_diag_areas[0].first, 16);
  EXPECT_EQ(m.unit_diag_areas[0].values.size(), 2u);
  ASSERT_EQ(m.blocks.size(), 2u);
  EXPECT_EQ(m.blocks[0].keyword, "UnitDiagType");
  EXPECT_EQ(m.blocks[0].header, "5");
  EXPECT_EQ(m.blocks[1].settings.size(), 1u);
}

TEST(GsdParse, UnknownKeywordsAreKeptAsKeyValue) {
  const ParseResult r = parse(
      "#Profibus_DP\n"
      "Slave_Family = 3@Digital@24V\n"
      "X_Something(3) = \"text\"\n"
      "Frob = 0x01,0x02\n"
      "DP_Encoder_profile_version = 1.1\n"
      "Hardware_Release =\n");
  const Model& m = r.model;
  ASSERT_EQ(m.settings.size(), 5u);
  EXPECT_EQ(m.find("slave_family")->value.kind, Value::Kind::Text);
  EXPECT_EQ(m.string("Slave_Family"), "3@Digital@24V");
  const Setting* x = m.find("X_Something", 3);
  ASSERT_NE(x, nullptr);
  EXPECT_EQ(x->value.text, "text");
  EXPECT_EQ(m.find("Frob")->value.numbers, (std::vector<std::int64_t>{1, 2}));
  EXPECT_EQ(m.find("DP_Encoder_profile_version")->value.text, "1.1");
  // An empty value of a string keyword is an error, but the keyword is still kept.
  ASSERT_EQ(r.diagnostics.size(), 1u) << dump(r);
  EXPECT_EQ(format(r.diagnostics[0], "t.gsd"),
            "t.gsd:6: Hardware_Release expects a quoted string, found ''");
  EXPECT_EQ(m.find("Hardware_Release")->value.kind, Value::Kind::None);
}

struct ErrorCase {
  const char* name;
  const char* text;
  int line;
  const char* message_part;
};

// Table of broken files: each gives an error on the stated physical line.
TEST(GsdParse, SyntaxErrorsCarryTheRightLineNumber) {
  const ErrorCase cases[] = {
      {"missing header", "; c\n\nVendor_Name = \"x\"\n", 3, "statement before the '#Profibus_DP'"},
      {"bare text", "#Profibus_DP\nVendor_Name=\"x\"\nhello world\n", 3,
       "expected 'Keyword = value', found 'hello world'"},
      {"unterminated string", "#Profibus_DP\nVendor_Name = \"abc\nModel_Name=\"m\"\n", 2,
       "unterminated string"},
      {"bad byte on a continuation line",
       "#Profibus_DP\nUser_Prm_Data = 0x00,\\\n 0x01,\\\n 0x1G\n", 4,
       "User_Prm_Data: expected a byte value, found '0x1G'"},
      {"byte too large on a continuation line",
       "#Profibus_DP\nModule = \"m\" 0x10,\\\n 0x100\nEndModule\n", 3,
       "value 256 does not fit in a byte"},
      {"stray end keyword", "#Profibus_DP\nEndPrmText\n", 2,
       "'EndPrmText' without a matching block start"},
      {"missing EndModule",
       "#Profibus_DP\nModule = \"m\" 0x10\nPreset = 1\n\nPrmText = 1\nText(0)=\"a\"\nEndPrmText\n",
       5, "missing EndModule for the Module started at line 2"},
      {"missing EndPrmText", "#Profibus_DP\nPrmText = 1\nText(0)=\"a\"\nVendor_Name=\"x\"\n", 4,
       "missing EndPrmText for the PrmText started at line 2"},
      {"unknown data type",
       "#Profibus_DP\nExtUserPrmData = 1 \"x\"\n; comment\nFloat32 0 0-1\nEndExtUserPrmData\n", 4,
       "unknown data type 'Float32'"},
      {"type line missing", "#Profibus_DP\nExtUserPrmData = 1 \"x\"\nEndExtUserPrmData\n", 2,
       "has no data type line"},
      {"end of file inside a block", "#Profibus_DP\n\nExtUserPrmData = 9 \"x\"\nBit(0) 0 0-1\n", 3,
       "missing EndExtUserPrmData (end of file reached)"},
      {"malformed range", "#Profibus_DP\nExtUserPrmData = 1 \"x\"\nUnsigned8 0 0-\n", 3,
       "expected the maximum after '-'"},
      {"index not a number", "#Profibus_DP\nUnit_Diag_Bit(x) = \"a\"\n", 2,
       "index of 'Unit_Diag_Bit' is not a number: 'x'"},
      {"unsigned keyword with text", "#Profibus_DP\nIdent_Number = \"1234\"\n", 2,
       "Ident_Number expects an unsigned number"},
      {"module without bytes", "#Profibus_DP\n\n\nModule = \"empty\"\nEndModule\n", 4,
       "has no configuration bytes"},
      {"number too large", "#Profibus_DP\nUser_Prm_Data = 99999999999999999999\n", 2,
       "is too large"},
      {"missing keyword", "#Profibus_DP\n = 5\n", 2, "missing keyword before '='"},
      {"foreign end keyword inside a block",
       "#Profibus_DP\nModule = \"m\" 0x10\nEndPrmText\nEndModule\n", 3,
       "unexpected 'EndPrmText' inside the Module started at line 2 (expected EndModule)"},
      {"no header at all", "Vendor_Name = \"x\"\n", 1, "missing '#Profibus_DP' header"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const ParseResult r = parse(c.text);
    EXPECT_FALSE(r.ok());
    bool found = false;
    for (const auto& d : r.diagnostics)
      if (d.severity == Severity::Error && d.line == c.line &&
          d.message.find(c.message_part) != std::string::npos)
        found = true;
    EXPECT_TRUE(found) << "expected line " << c.line << ": " << c.message_part << "\ngot:\n"
                       << dump(r);
  }
}

TEST(GsdParse, ParsingContinuesAfterAnError) {
  const ParseResult r = parse(
      "#Profibus_DP\n"
      "Ident_Number = zz\n"
      "Module = \"a\" 0x10\n"
      "Module = \"b\" 0x20\n"  // EndModule of "a" missing
      "EndModule\n"
      "Vendor_Name = \"v\"\n");
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.diagnostics.size(), 2u) << dump(r);
  ASSERT_EQ(r.model.modules.size(), 2u);
  EXPECT_EQ(r.model.modules[1].name, "b");
  EXPECT_EQ(r.model.vendor_name(), "v");
}

TEST(GsdParse, DuplicateKeywordWarnsAndFirstWins) {
  const ParseResult r = parse("#Profibus_DP\nMax_Module = 4\nmax_module = 8\n");
  ASSERT_EQ(r.diagnostics.size(), 1u);
  EXPECT_EQ(r.diagnostics[0].severity, Severity::Warning);
  EXPECT_EQ(format(r.diagnostics[0], "x.gsd"),
            "x.gsd:3: warning: duplicate keyword 'max_module' (first at line 2; that one is used)");
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.model.number("Max_Module"), 4);
}

TEST(GsdParse, DiagnosticsAreInLineOrder) {
  const ParseResult r = parse("#Profibus_DP\nA=\"\nB\nC=(\n\nExtUserPrmData=1 \"x\"\n");
  ASSERT_GE(r.diagnostics.size(), 3u);
  for (std::size_t i = 1; i < r.diagnostics.size(); ++i)
    EXPECT_LE(r.diagnostics[i - 1].line, r.diagnostics[i].line);
}

TEST(GsdParse, FileHelper) {
  const ParseResult missing = parse_file("/nonexistent/file.gsd");
  ASSERT_EQ(missing.diagnostics.size(), 1u);
  EXPECT_EQ(format(missing.diagnostics[0], "/nonexistent/file.gsd"),
            "/nonexistent/file.gsd:0: cannot open the file");
  const ParseResult shipped = parse_file(CANDP2_SOURCE_DIR "/gsd/CDPS04A4.GSD");
  EXPECT_TRUE(shipped.ok());
  EXPECT_EQ(shipped.model.ident_number(), 0x04A4);
}

}  // namespace
}  // namespace candp2::gsd
