// User parameter encoding rules on synthetic GSDs: constants, then references; Bit and BitArea
// replace only their bits; 16/32-bit values big-endian; signed values two's complement;
// validation against ranges, value lists and the data type.
#include "gsd/prm.hpp"

#include <gtest/gtest.h>

#include "common/hex.hpp"
#include "gsd/gsd.hpp"

namespace candp2::gsd {
namespace {

Model model(const std::string& body) {
  ParseResult r = parse("#Profibus_DP\n" + body);
  for (const auto& d : r.diagnostics) ADD_FAILURE() << format(d, "t.gsd");
  return std::move(r.model);
}

const char* const kDefs =
    "PrmText=1\nText(0)=\"off\"\nText(1)=\"on\"\nEndPrmText\n"
    "ExtUserPrmData=1 \"Flag\"\nBit(3) 1 0-1\nPrm_Text_Ref=1\nEndExtUserPrmData\n"
    "ExtUserPrmData=2 \"Mode\"\nBitArea(4-6) 5 0,2,5,7\nEndExtUserPrmData\n"
    "ExtUserPrmData=3 \"Word\"\nUnsigned16 0x1234 0-65535\nEndExtUserPrmData\n"
    "ExtUserPrmData=4 \"Long\"\nUnsigned32 0x01020304 0-0xFFFFFFFF\nEndExtUserPrmData\n"
    "ExtUserPrmData=5 \"Offset\"\nSigned16 -2 -100-100\nEndExtUserPrmData\n"
    "ExtUserPrmData=6 \"Small\"\nSigned8 -1 -128-127\nEndExtUserPrmData\n";

TEST(GsdPrm, ConstThenRefsWithBitInsertionAndBigEndian) {
  const Model m = model(std::string(kDefs) +
                        "Ext_User_Prm_Data_Const(0) = 0xFF,0xFF,0x00,0x00,0x00,0x00,0x00,0x00,"
                        "0x00,0x00,0x00\n"
                        "Ext_User_Prm_Data_Ref(0) = 1\n"     // bit 3 of FF stays 1
                        "Ext_User_Prm_Data_Ref(1) = 2\n"     // bits 4-6 of FF := 5
                        "Ext_User_Prm_Data_Ref(2) = 3\n"     // 12 34
                        "Ext_User_Prm_Data_Ref(4) = 4\n"     // 01 02 03 04
                        "Ext_User_Prm_Data_Ref(8) = 5\n"     // FF FE
                        "Ext_User_Prm_Data_Ref(10) = 6\n");  // FF
  const EncodeResult r = encode_user_prm(m);
  EXPECT_TRUE(r.ok());
  // byte 1: (0xFF & ~0x70) | (5 << 4) = 0xDF
  EXPECT_EQ(hex_bytes(r.bytes), "FF DF 12 34 01 02 03 04 FF FE FF");
}

TEST(GsdPrm, OverridesByNumberAndByText) {
  const Model m = model(std::string(kDefs) +
                        "Ext_User_Prm_Data_Const(0) = 0x00,0x00\n"
                        "Ext_User_Prm_Data_Ref(0) = 1\n"
                        "Ext_User_Prm_Data_Ref(0) = 2\n"
                        "Ext_User_Prm_Data_Ref(1) = 6\n");
  EXPECT_EQ(hex_bytes(encode_user_prm(m).bytes), "58 FF");  // 0x08 | 5<<4, -1
  const std::vector<PrmOverride> ov = {
      {" flag ", std::string("OFF")}, {"Mode", 7}, {"Small", -128}};
  const EncodeResult r = encode_user_prm(m, ov);
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(hex_bytes(r.bytes), "70 80");
}

TEST(GsdPrm, ValidationAgainstListRangeAndType) {
  const Model m =
      model(std::string(kDefs) + "Ext_User_Prm_Data_Ref(0) = 2\nExt_User_Prm_Data_Ref(1) = 5\n");
  struct Case {
    PrmOverride ov;
    const char* error;
  };
  const Case cases[] = {
      {{"Mode", 3}, "\"Mode\" value 3: not in the allowed values 0,2,5,7"},
      {{"Mode", 8}, "\"Mode\" value 8: outside what BitArea holds (0..7)"},
      {{"Offset", 101}, "\"Offset\" value 101: outside the range -100-100"},
      {{"Offset", std::string("0x10")}, ""},  // a number given as text is accepted
      {{"Flag", 1}, "\"Flag\": not referenced by these parameter bytes"},
      {{"Nope", 1}, "\"Nope\": no such parameter (ExtUserPrmData name)"},
  };
  for (const auto& c : cases) {
    const EncodeResult r = encode_user_prm(m, {&c.ov, 1});
    if (*c.error == 0) {
      EXPECT_TRUE(r.ok()) << c.ov.name;
      continue;
    }
    ASSERT_EQ(r.errors.size(), 1u) << c.ov.name;
    EXPECT_EQ(r.errors[0], c.error);
  }
  // Values outside the type's bit width are never written into neighbouring bits.
  const PrmOverride bad{"Mode", 0xFF};
  EXPECT_EQ(hex_bytes(encode_user_prm(m, {&bad, 1}).bytes), "50 FF FE");
}

TEST(GsdPrm, LengthComesFromDeclarationsLegacyBytesAndLayout) {
  // User_Prm_Data_Len longer than the layout: zero padded.
  EXPECT_EQ(hex_bytes(encode_user_prm(model("User_Prm_Data_Len = 4\n")).bytes), "00 00 00 00");
  // Legacy bytes only.
  EXPECT_EQ(hex_bytes(encode_user_prm(model("User_Prm_Data = 1,2,3\n")).bytes), "01 02 03");
  // Constants override the legacy bytes.
  EXPECT_EQ(hex_bytes(encode_user_prm(model("User_Prm_Data = 1,2,3\n"
                                            "Ext_User_Prm_Data_Const(1) = 9\n"))
                          .bytes),
            "01 09 03");
  // Nothing declared: no bytes.
  EXPECT_TRUE(encode_user_prm(model("")).bytes.empty());
}

TEST(GsdPrm, BrokenReferencesAreErrorsNotCrashes) {
  const Model m = model(
      "ExtUserPrmData=1 \"Bad bit\"\nBit(9) 0 0-1\nEndExtUserPrmData\n"
      "Ext_User_Prm_Data_Ref(0) = 1\n"
      "Ext_User_Prm_Data_Ref(1) = 42\n"
      "Ext_User_Prm_Data_Ref(300) = 1\n"
      "Ext_User_Prm_Data_Const(236) = 1,2\n");
  const EncodeResult r = encode_user_prm(m);
  ASSERT_EQ(r.errors.size(), 4u);
  EXPECT_NE(r.errors[0].find("reaches beyond the 237-byte limit"), std::string::npos);
  EXPECT_NE(r.errors[1].find("bit position outside 0..7"), std::string::npos);
  EXPECT_NE(r.errors[2].find("no ExtUserPrmData 42"), std::string::npos);
  EXPECT_NE(r.errors[3].find("reaches beyond"), std::string::npos);
  EXPECT_EQ(r.bytes.size(), 2u);
}

TEST(GsdPrm, ModuleParameters) {
  const Model m = model(std::string(kDefs) +
                        "Module = \"M\" 0x10\n"
                        "Ext_Module_Prm_Data_Len = 4\n"
                        "Ext_User_Prm_Data_Const(0) = 0x05\n"
                        "Ext_User_Prm_Data_Ref(1) = 3\n"
                        "EndModule\n");
  ASSERT_EQ(m.modules.size(), 1u);
  EXPECT_EQ(hex_bytes(encode_module_prm(m, m.modules[0]).bytes), "05 12 34 00");
  const PrmOverride ov{"Word", 0xBEEF};
  EXPECT_EQ(hex_bytes(encode_module_prm(m, m.modules[0], {&ov, 1}).bytes), "05 BE EF 00");
}

TEST(GsdPrm, ParseOverride) {
  auto a = parse_override("CAN-Bitrate=2");
  ASSERT_TRUE(a);
  EXPECT_EQ(a->name, "CAN-Bitrate");
  EXPECT_EQ(std::get<std::int64_t>(a->value), 2);
  auto b = parse_override(" CAN-Bitrate = 125 kbit/s ");
  ASSERT_TRUE(b);
  EXPECT_EQ(std::get<std::string>(b->value), "125 kbit/s");
  // Names containing '=': the last '=' splits, or the model's longest matching name.
  auto c = parse_override("Sync Time (0=Off, 65535=Default)=0x3E8");
  ASSERT_TRUE(c);
  EXPECT_EQ(c->name, "Sync Time (0=Off, 65535=Default)");
  EXPECT_EQ(std::get<std::int64_t>(c->value), 1000);
  const Model m = model(
      "PrmText=1\nText(0)=\"a=b\"\nEndPrmText\n"
      "ExtUserPrmData=1 \"X (0=Off)\"\nUnsigned8 0 0-1\nPrm_Text_Ref=1\nEndExtUserPrmData\n");
  auto d = parse_override("x (0=off) = a=b", &m);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->name, "x (0=off)");
  EXPECT_EQ(std::get<std::string>(d->value), "a=b");
  auto e = parse_override("\"X (0=Off)\"=\"a=b\"", &m);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->name, "X (0=Off)");
  EXPECT_EQ(std::get<std::string>(e->value), "a=b");
  EXPECT_FALSE(parse_override("no equals sign"));
  EXPECT_FALSE(parse_override("=5"));
}

}  // namespace
}  // namespace candp2::gsd
