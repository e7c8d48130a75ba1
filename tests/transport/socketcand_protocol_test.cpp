// socketcand wire format as pure functions: linux-can/socketcand doc/protocol.md examples and the
// formats of src/state_raw.c (frames) and python-can's socketcand interface (sends).
#include <gtest/gtest.h>

#include "can/socketcand.hpp"
#include "transport_test_support.hpp"

namespace candp2::can::socketcand {
namespace {

using test::F;

const Time kStamp = std::chrono::seconds(1700000000);

TEST(SocketcandFormat, FrameLinesAsStateRawWritesThem) {
  // state_raw.c: "< frame %03X %lld.%06lld " + "%02X" per byte + " >"; 29-bit ids "%08X".
  EXPECT_EQ(format_frame(F("123#1122"), kStamp), "< frame 123 1700000000.000000 1122 >");
  // doc/protocol.md: "< frame 123 23.424242 1A220344 >".
  EXPECT_EQ(format_frame(F("123#1A220344"), Time(23424242)), "< frame 123 23.424242 1A220344 >");
  EXPECT_EQ(format_frame(F("1ABCDEF0#01"), kStamp), "< frame 1ABCDEF0 1700000000.000000 01 >");
  EXPECT_EQ(format_frame(F("00000005#"), kStamp), "< frame 00000005 1700000000.000000  >");
  EXPECT_EQ(format_frame(F("001#0A"), kStamp + Time(42)), "< frame 001 1700000000.000042 0A >");
  EXPECT_EQ(format_frame(F("7FF#0102030405060708"), Time(-5)),  // a negative stamp clamps to 0
            "< frame 7FF 0.000000 0102030405060708 >");
}

TEST(SocketcandFormat, SendLinesAsTheProtocolDocumentsThem) {
  // doc/protocol.md: "< send 123 0 >", "< send 1AAAAAAA 2 1 f1 >" (lower case, unpadded).
  EXPECT_EQ(format_send(F("123#")), "< send 123 0 >");
  EXPECT_EQ(format_send(F("1AAAAAAA#01F1")), "< send 1AAAAAAA 2 1 f1 >");
  EXPECT_EQ(format_send(F("123#1122")), "< send 123 2 11 22 >");
  EXPECT_EQ(format_send(F("00000123#00FF")), "< send 00000123 2 0 ff >");
}

TEST(SocketcandParse, SendCommandsThatAreAccepted) {
  struct Case {
    const char* element;
    const char* frame;
  } cases[] = {
      {"< send 123 0 >", "123#"},
      {"< send 1AAAAAAA 2 1 f1 >", "1AAAAAAA#01F1"},
      {"< send 123 2 11 22 >", "123#1122"},
      {"< send 7ff 8 0 1 2 3 4 5 6 7 >", "7FF#0001020304050607"},
      {"< send 00000123 1 AA >", "00000123#AA"},  // 8 digits: 29-bit (state_raw.c)
      {"< send 12345 1 a >", "00012345#0A"},      // python-can: {:X}, unpadded → 29-bit by value
      {"< send 800 0 >", "00000800#"},
      {"<send 123 1 01>", "123#01"},  // spacing is not significant
      {"< send  123\t1  01 >", "123#01"},
      {"< send 123 08 1 2 3 4 5 6 7 8 >", "123#0102030405060708"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.element);
    const auto r = parse_send(c.element);
    ASSERT_TRUE(r.frame) << r.error;
    EXPECT_EQ(format_candump(*r.frame), c.frame);
  }
}

TEST(SocketcandParse, SendCommandsThatAreRefused) {
  struct Case {
    const char* element;
    const char* error;
  } cases[] = {
      {"< send >", "send needs an identifier and a DLC"},
      {"< send 123 >", "send needs an identifier and a DLC"},
      {"< send xyz 0 >", "bad identifier 'xyz'"},
      {"< send 123456789 0 >", "bad identifier '123456789'"},
      {"< send 20000000 0 >", "identifier 20000000 above 1FFFFFFF"},
      {"< send 123 9 1 2 3 4 5 6 7 8 9 >", "DLC 9 above 8"},
      {"< send 123 x >", "bad DLC 'x'"},
      {"< send 123 -1 >", "bad DLC '-1'"},
      {"< send 123 2 11 >", "DLC 2 but 1 data bytes"},
      {"< send 123 1 11 22 >", "DLC 1 but 2 data bytes"},
      {"< send 123 1 100 >", "bad data byte '100'"},
      {"< send 123 1 zz >", "bad data byte 'zz'"},
      {"< frame 123 1.0 11 >", "not a send command"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.element);
    const auto r = parse_send(c.element);
    EXPECT_FALSE(r.frame);
    EXPECT_NE(r.error.find(c.error), std::string::npos) << r.error;
    EXPECT_EQ(r.error.find_first_of("<>"), std::string::npos) << "would break the framing";
  }
}

TEST(SocketcandParse, FramesInRawAndBcmStyle) {
  struct Case {
    const char* element;
    const char* frame;
  } cases[] = {
      {"< frame 123 23.424242 1A220344 >", "123#1A220344"},  // doc/protocol.md
      {"< frame 123 1700000000.000000  >", "123#"},
      {"< frame 1ABCDEF0 1.000001 01 >", "1ABCDEF0#01"},
      {"< frame 00000123 1.000001 01 >", "00000123#01"},
      {"< frame 123 1.5 11 22 33 >", "123#112233"},  // BCM mode: "%02X " per byte
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.element);
    const auto r = parse_frame(c.element);
    ASSERT_TRUE(r.frame) << r.error;
    EXPECT_EQ(format_candump(*r.frame), c.frame);
  }
  for (const char* bad : {"< frame >", "< frame 123 >", "< frame 123 now 11 >",
                          "< frame 123 1.0 112 >", "< frame 123 1.0 010203040506070809 >",
                          "< frame 123 1.0 GG >", "< frame 1234567890 1.0 >"}) {
    SCOPED_TRACE(bad);
    EXPECT_FALSE(parse_frame(bad).frame);
  }
}

TEST(SocketcandParse, ErrorFramesVersusTextErrors) {
  // state_raw.c: "< error %03X %lld.%06lld >" with the error class.
  auto raw = parse_error_frame("< error 040 1700000000.000001 >");
  ASSERT_TRUE(raw);
  EXPECT_EQ(socketcan::decode_error(*raw).state, BusState::BusOff);
  raw = parse_error_frame("< error 100 1.000000 >");
  ASSERT_TRUE(raw);
  EXPECT_EQ(socketcan::decode_error(*raw).state, BusState::Ok);
  raw = parse_error_frame("< error 004 1.000000 00 20 00 00 00 00 00 00 >");  // BCM: with data
  ASSERT_TRUE(raw);
  EXPECT_EQ(socketcan::decode_error(*raw).state, BusState::ErrorPassive);
  EXPECT_FALSE(parse_error_frame("< error unknown command >"));
  EXPECT_FALSE(parse_error_frame("< error could not open bus >"));
  EXPECT_FALSE(parse_error_frame("< error 040 >"));
}

TEST(SocketcandSplitter, ElementsAcrossReadsWhitespaceAndStrayBytes) {
  ElementSplitter s;
  std::vector<ElementSplitter::Item> items;
  s.feed("< hi >< o", items);
  ASSERT_EQ(items.size(), 1u);
  EXPECT_EQ(items[0].text, "< hi >");
  EXPECT_EQ(s.buffered(), 3u);
  items.clear();
  s.feed("k >\r\n  junk < echo >", items);
  ASSERT_EQ(items.size(), 3u);
  EXPECT_EQ(items[0].kind, ElementSplitter::Kind::Element);
  EXPECT_EQ(items[0].text, "< ok >");
  EXPECT_EQ(items[1].kind, ElementSplitter::Kind::Stray);
  EXPECT_EQ(items[1].text, "junk");
  EXPECT_EQ(items[1].bytes, 4u);
  EXPECT_EQ(items[2].text, "< echo >");
  EXPECT_EQ(s.buffered(), 0u);
}

TEST(SocketcandSplitter, UnclosedElementFollowedByANewOneIsStray) {
  ElementSplitter s;
  std::vector<ElementSplitter::Item> items;
  s.feed("< send 123 < echo >", items);
  ASSERT_EQ(items.size(), 2u);
  EXPECT_EQ(items[0].kind, ElementSplitter::Kind::Stray);
  EXPECT_EQ(items[0].text, "< send 123 ");
  EXPECT_EQ(items[1].text, "< echo >");
}

TEST(SocketcandSplitter, OverlongElementIsReportedOnce) {
  ElementSplitter s(16);
  std::vector<ElementSplitter::Item> items;
  s.feed("< " + std::string(15, 'x'), items);
  ASSERT_EQ(items.size(), 1u);
  EXPECT_EQ(items[0].kind, ElementSplitter::Kind::Overflow);
  EXPECT_EQ(items[0].bytes, 17u);
  EXPECT_EQ(s.buffered(), 0u);  // nothing kept: memory stays bounded
  items.clear();
  s.feed("< ok >", items);
  ASSERT_EQ(items.size(), 1u);
  EXPECT_EQ(items[0].text, "< ok >");
}

TEST(SocketcandSplitter, StrayRunsKeepOnlyAPrefixButCountEveryByte) {
  ElementSplitter s;
  std::vector<ElementSplitter::Item> items;
  s.feed(std::string(100000, 'A'), items);
  ASSERT_EQ(items.size(), 1u);
  EXPECT_EQ(items[0].bytes, 100000u);
  EXPECT_EQ(items[0].text.size(), 64u);
}

TEST(SocketcandWords, SplitsBetweenTheBrackets) {
  EXPECT_EQ(words("< send 123 0 >"), (std::vector<std::string_view>{"send", "123", "0"}));
  EXPECT_EQ(words("<open vcan0>"), (std::vector<std::string_view>{"open", "vcan0"}));
  EXPECT_TRUE(words("< >").empty());
}

}  // namespace
}  // namespace candp2::can::socketcand
