#include "can/frame.hpp"

#include <gtest/gtest.h>

#include "common/hex.hpp"

namespace candp2::can {
namespace {

// The candump notation of can-utils (cansend/candump): golden round trips.
struct Golden {
  const char* text;
  std::uint32_t id;
  bool extended;
  bool remote;
  std::uint8_t dlc;
};

class CandumpGolden : public ::testing::TestWithParam<Golden> {};

TEST_P(CandumpGolden, ParsesAndFormatsBack) {
  const auto& g = GetParam();
  auto r = parse_candump(g.text);
  ASSERT_TRUE(r) << r.error.message;
  EXPECT_EQ(r.frame->id, g.id);
  EXPECT_EQ(r.frame->extended, g.extended);
  EXPECT_EQ(r.frame->remote, g.remote);
  EXPECT_EQ(r.frame->dlc, g.dlc);
  EXPECT_EQ(format_candump(*r.frame), g.text);
}

INSTANTIATE_TEST_SUITE_P(Issue2, CandumpGolden,
                         ::testing::Values(Golden{"123#1122", 0x123, false, false, 2},
                                           Golden{"12345678#", 0x12345678, true, false, 0},
                                           Golden{"123#R", 0x123, false, true, 0},
                                           Golden{"123#R4", 0x123, false, true, 4},
                                           Golden{"7FF#0011223344556677", 0x7FF, false, false, 8},
                                           Golden{"000#0100", 0x000, false, false, 2},
                                           Golden{"080#", 0x080, false, false, 0}));

// One text for an identifier everywhere (logs, sniff, validate): candump's digits.
TEST(IdentText, ThreeDigitsStandardEightExtended) {
  EXPECT_EQ(ident_text({0x181, false}), "181");
  EXPECT_EQ(ident_text({0x7, false}), "007");
  EXPECT_EQ(ident_text({0x1234567, true}), "01234567");
  EXPECT_EQ(ident_text({0x1FFFFFFF, true}), "1FFFFFFF");
}

TEST(Candump, DataBytesAreStored) {
  auto r = parse_candump("201#3D4000");
  ASSERT_TRUE(r);
  EXPECT_EQ(r.frame->data[0], 0x3D);
  EXPECT_EQ(r.frame->data[1], 0x40);
  EXPECT_EQ(r.frame->data[2], 0x00);
  EXPECT_EQ(r.frame->data[3], 0x00);  // bytes past dlc stay zero
}

TEST(Candump, DotSeparatorsAccepted) {
  auto r = parse_candump("123#11.22.33");
  ASSERT_TRUE(r);
  EXPECT_EQ(format_candump(*r.frame), "123#112233");
}

struct Bad {
  const char* text;
  std::size_t column;
  const char* fragment;
};
class CandumpMalformed : public ::testing::TestWithParam<Bad> {};

TEST_P(CandumpMalformed, ClearError) {
  auto r = parse_candump(GetParam().text);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error.column, GetParam().column);
  EXPECT_NE(r.error.message.find(GetParam().fragment), std::string::npos) << r.error.message;
}

INSTANTIATE_TEST_SUITE_P(
    Issue2, CandumpMalformed,
    ::testing::Values(Bad{"1231122", 7, "'#'"}, Bad{"12#11", 0, "3 (11-bit) or 8"},
                      Bad{"800#11", 0, "above 0x7FF"}, Bad{"3FFFFFFF#", 0, "above 0x1FFFFFFF"},
                      Bad{"12G#11", 2, "hex digit"}, Bad{"123#112", 6, "odd number"},
                      Bad{"123#1Z", 5, "hex digit"},
                      Bad{"123#001122334455667788", 20, "more than 8"}, Bad{"123#R9", 5, "0..8"},
                      Bad{"123#R4x", 6, "after remote"}));

TEST(CandumpLog, ParsesAndFormats) {
  auto r = parse_log_line("(1700000000.123456) can0 123#1122");
  ASSERT_TRUE(r) << r.error.message;
  EXPECT_EQ(r.line->sec, 1700000000);
  EXPECT_EQ(r.line->usec, 123456u);
  EXPECT_EQ(r.line->interface, "can0");
  EXPECT_EQ(format_candump(r.line->frame), "123#1122");
  EXPECT_EQ(format_log_line(*r.line), "(1700000000.123456) can0 123#1122");
}

TEST(CandumpLog, MalformedLinesNameTheProblem) {
  EXPECT_NE(parse_log_line("1700000000.123456 can0 123#11").error.message.find("'('"),
            std::string::npos);
  EXPECT_NE(parse_log_line("(1700000000.12) can0 123#11").error.message.find("6 fraction"),
            std::string::npos);
  auto r = parse_log_line("(1700000000.123456) can0 123#1");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error.column, 29u);  // column of the lone digit inside the whole line
}

TEST(Frame, BuildersKeepInvariants) {
  const std::uint8_t nine[9] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  auto f = Frame::std_data(0xFFFF, nine);
  EXPECT_EQ(f.id, 0x7FFu);
  EXPECT_EQ(f.dlc, 8);
  auto r = Frame::rtr(0x181, false, 12);
  EXPECT_EQ(r.dlc, 8);
  EXPECT_TRUE(r.payload().empty());
}

TEST(Hex, Bytes) {
  const std::uint8_t b[] = {0x00, 0xAB, 0x0F};
  EXPECT_EQ(hex_bytes(b), "00 AB 0F");
}

}  // namespace
}  // namespace candp2::can
