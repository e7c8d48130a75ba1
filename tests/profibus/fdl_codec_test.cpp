// Golden tests of the FDL codec and stream parser (docs/profibus.md), against the capture in
// docs/profibus.md and public references: pyprofibus (github.com/mbuesch/pyprofibus
// pyprofibus/fdl.py at e7c98158) and profirust (github.com/Rahix/profirust src/fdl/telegram.rs
// tests at 860b938e), which publish the IEC 61158-4-3 / EN 50170 telegram facts.
#include <gtest/gtest.h>

#include "fdl_capture.hpp"
#include "profibus_sim/fdl/fdl.hpp"

namespace candp2::fdl::test {
namespace {

Telegram decoded(const char* hex) {
  const auto r = decode(B(hex));
  EXPECT_EQ(r.error, Error::None) << hex << ": " << to_string(r.error);
  return r.telegram.value_or(Telegram{});
}

// ---- the capture in docs/profibus.md "A real master's first telegrams": decode reads it, encode
// reproduces it ---

TEST(FdlCodec, CaptureFdlStatusRequest) {
  // docs/profibus.md: SD1, FC 0x49 = request, FDL_Status (0x9), FCB=0, FCV=0.
  const auto t = decoded(kCapFdlStatus);
  EXPECT_EQ(t.kind, Kind::SD1);
  EXPECT_EQ(t.da, 3);
  EXPECT_EQ(t.sa, 2);
  EXPECT_TRUE(t.is_request());
  EXPECT_EQ(t.function(), kFcFdlStatus);
  EXPECT_FALSE(t.fcb());
  EXPECT_FALSE(t.fcv());
  EXPECT_EQ(H(encode(Telegram::no_data(3, 2, request_fc(kFcFdlStatus)))), kCapFdlStatus);
}

TEST(FdlCodec, ProfirustFdlStatusRequestAndResponse) {
  // profirust src/fdl/telegram.rs tests generate_fdl_status_telegram / parse_fdl_response_telegram:
  // FDL_Status to 34 from 2 is 10 22 02 49 6D 16; the slave's answer is 10 02 22 00 24 16.
  EXPECT_EQ(H(encode(Telegram::no_data(34, 2, request_fc(kFcFdlStatus)))), "10 22 02 49 6D 16");
  const auto rsp = decoded("10 02 22 00 24 16");
  EXPECT_FALSE(rsp.is_request());
  EXPECT_EQ(rsp.function(), kFcOk);
  EXPECT_EQ(rsp.fc & kFcStationTypeMask, kStationSlave);
  EXPECT_EQ(H(encode(Telegram::no_data(2, 34, response_fc(kFcOk)))), "10 02 22 00 24 16");
}

TEST(FdlCodec, CaptureSlaveDiagRequestWithSaps) {
  // docs/profibus.md: DA 0x83 = 3 + SAP follows, SA 0x82 = 2 + SAP; DSAP 60, SSAP 62; FC 0x6D =
  // SRD high with FCB=1, FCV=0 (the first request after FDL_Status).
  const auto t = decoded(kCapSlaveDiag1);
  EXPECT_EQ(t.kind, Kind::SD2);
  EXPECT_EQ(t.da, 3);
  EXPECT_EQ(t.sa, 2);
  EXPECT_EQ(t.dsap, kSapSlaveDiag);
  EXPECT_EQ(t.ssap, kSapChkCfg);
  EXPECT_EQ(t.function(), kFcSrdHigh);
  EXPECT_TRUE(t.fcb());
  EXPECT_FALSE(t.fcv());
  EXPECT_TRUE(t.du.empty());
  EXPECT_EQ(H(encode(Telegram::with_data(3, 2, request_fc(kFcSrdHigh, true, false), kSapSlaveDiag,
                                         kSapChkCfg, {}))),
            kCapSlaveDiag1);
  // The later Slave_Diag: FCB=0, FCV=1.
  const auto t2 = decoded(kCapSlaveDiag2);
  EXPECT_FALSE(t2.fcb());
  EXPECT_TRUE(t2.fcv());
  EXPECT_EQ(H(encode(t2)), kCapSlaveDiag2);
}

TEST(FdlCodec, CaptureSetPrm) {
  // docs/profibus.md: Set_Prm, DSAP 61, WD on (Station_Status 0x88), WD 30 x 1 x 10 ms = 300 ms,
  // Ident 04 A4, user bytes 00 02 00 01 00 00 FF FF FF; LE 0x15 = 3 + 2 SAPs + 16.
  const auto t = decoded(kCapSetPrm);
  EXPECT_EQ(t.dsap, kSapSetPrm);
  EXPECT_EQ(t.ssap, kSapChkCfg);
  EXPECT_EQ(t.fc, 0x5D);
  EXPECT_EQ(H(t.du), "88 1E 01 00 04 A4 00 00 02 00 01 00 00 FF FF FF");
  EXPECT_EQ(H(encode(t)), kCapSetPrm);
}

TEST(FdlCodec, CaptureChkCfg) {
  const auto t = decoded(kCapChkCfg);
  EXPECT_EQ(t.dsap, kSapChkCfg);
  EXPECT_EQ(t.fc, 0x7D);  // FCB=1, FCV=1
  EXPECT_EQ(H(t.du), "43 85 02 89 B8 83 85 03 09 B8");
  EXPECT_EQ(H(encode(t)), kCapChkCfg);
}

TEST(FdlCodec, CaptureDataExchangeFcbAlternating) {
  // docs/profibus.md: Data_Exchange is an SRD without SAPs to the default SAP.
  const auto a = decoded(kCapDataExch1);
  const auto b = decoded(kCapDataExch2);
  EXPECT_FALSE(a.dsap);
  EXPECT_FALSE(a.ssap);
  EXPECT_TRUE(a.fcb());
  EXPECT_FALSE(b.fcb());
  EXPECT_TRUE(a.fcv() && b.fcv());
  EXPECT_EQ(H(a.du), "11 22 33 44 55 66");
  EXPECT_EQ(a.du, b.du);
  EXPECT_EQ(H(encode(Telegram::with_data(3, 2, request_fc(kFcSrdHigh, false, true), std::nullopt,
                                         std::nullopt, B("11 22 33 44 55 66")))),
            kCapDataExch2);
}

// ---- responses ------------------------------------------------------------------------------

TEST(FdlCodec, ShortAcknowledgeAndToken) {
  // pyprofibus fdl.py FdlTelegram.SC = 0xE5 (a single character), SD4 = 0xDC DA SA.
  EXPECT_EQ(H(encode(Telegram::sc())), "E5");
  EXPECT_EQ(decoded("E5").kind, Kind::SC);
  EXPECT_EQ(H(encode(Telegram::token(3, 2))), "DC 03 02");
  const auto tok = decoded("DC 03 02");
  EXPECT_EQ(tok.kind, Kind::SD4);
  EXPECT_EQ(tok.da, 3);
}

TEST(FdlCodec, SlaveDiagResponseSwapsSaps) {
  // docs/profibus.md: SD2, DSAP 62 / SSAP 60, FC DL (0x08). FCS = sum of 82 83 08 3E 3C + 11
  // diagnosis bytes (docs/dp-slave.md "Diagnosis" layout: 02 05 00 FF 04 A4 05 04 00 00 00).
  const auto diag = B("02 05 00 FF 04 A4 05 04 00 00 00");
  const auto bytes =
      encode(Telegram::with_data(2, 3, response_fc(kFcDl), kSapChkCfg, kSapSlaveDiag, diag));
  EXPECT_EQ(H(bytes), "68 10 10 68 82 83 08 3E 3C 02 05 00 FF 04 A4 05 04 00 00 00 3E 16");
  const auto t = decoded(H(bytes).c_str());
  EXPECT_EQ(t.dsap, kSapChkCfg);
  EXPECT_EQ(t.ssap, kSapSlaveDiag);
  EXPECT_EQ(t.du, diag);
}

TEST(FdlCodec, DataExchangeResponsesSd2Sd3) {
  // 6 input bytes: SD2; exactly 8: SD3 (A2 DA SA FC DU(8) FCS ED), as profirust telegram.rs
  // serialize picks SD3 for LE 11.
  EXPECT_EQ(H(encode(Telegram::with_data(2, 3, response_fc(kFcDl), std::nullopt, std::nullopt,
                                         B("0A 0B 0C 0D 0E 0F")))),
            "68 09 09 68 02 03 08 0A 0B 0C 0D 0E 0F 58 16");
  const auto sd3 = Telegram::with_data(2, 3, response_fc(kFcDh), std::nullopt, std::nullopt,
                                       B("01 02 03 04 05 06 07 08"));
  EXPECT_EQ(sd3.kind, Kind::SD3);
  EXPECT_EQ(H(encode(sd3)), "A2 02 03 0A 01 02 03 04 05 06 07 08 33 16");
  EXPECT_EQ(decoded("A2 02 03 0A 01 02 03 04 05 06 07 08 33 16"), sd3);
  // RS: SD1, FC 0x03 (no service activated).
  EXPECT_EQ(H(encode(Telegram::no_data(2, 3, response_fc(kFcRs)))), "10 02 03 03 08 16");
}

TEST(FdlCodec, EncodeRefusesImpossibleTelegrams) {
  EXPECT_TRUE(encode(Telegram::no_data(128, 2, 0x49)).empty());  // address > 127
  Telegram sd3 = Telegram::with_data(2, 3, 0x08, std::nullopt, std::nullopt, B("01 02"));
  sd3.kind = Kind::SD3;
  EXPECT_TRUE(encode(sd3).empty());  // SD3 needs exactly 8 bytes
  Telegram big = Telegram::with_data(2, 3, 0x08, std::nullopt, std::nullopt,
                                     std::vector<std::uint8_t>(kMaxDataUnit + 1));
  EXPECT_TRUE(encode(big).empty());
  big.du.pop_back();
  EXPECT_EQ(encode(big).size(), kMaxTelegramLen);
}

// ---- decode errors ----------------------------------------------------------------------------

TEST(FdlCodec, DecodeErrorsAreTyped) {
  EXPECT_EQ(decode({}).error, Error::Empty);
  EXPECT_EQ(decode(B("00 03 02 49 4E 16")).error, Error::BadStart);
  EXPECT_EQ(decode(B("10 03 02 49 4F 16")).error, Error::BadFcs);
  EXPECT_EQ(decode(B("10 03 02 49 4E 17")).error, Error::MissingEd);
  EXPECT_EQ(decode(B("10 03 02 49 4E")).error, Error::Truncated);
  EXPECT_EQ(decode(B("10 03 02 49 4E 16 E5")).error, Error::TrailingBytes);
  EXPECT_EQ(decode(B("68 09 08 68 03 02 7D 11 22 33 44 55 66 E7 16")).error, Error::LeMismatch);
  EXPECT_EQ(decode(B("68 02 02 68 03 02 16")).error, Error::LeOutOfRange);
  EXPECT_EQ(decode(B("68 FA FA 68")).error, Error::LeOutOfRange);
  EXPECT_EQ(decode(B("68 09 09 69 03 02 7D 11 22 33 44 55 66 E7 16")).error, Error::BadSd2Repeat);
  // DA and SA announce two SAPs, LE 4 leaves room for one.
  EXPECT_EQ(decode(B("68 04 04 68 83 82 6D 3C AE 16")).error, Error::SapMissing);
  // DSAP with bit 6 set (segment address): not supported.
  EXPECT_EQ(decode(B("68 05 05 68 83 82 6D 7C 3E 2C 16")).error, Error::BadSap);
}

TEST(FdlCodec, Sd2WithLe3IsAcceptedOnReceive) {
  // pyprofibus fdl.py and profirust telegram.rs both accept LE >= 3 (an SD2 without data); the
  // codec is liberal in what it receives and never sends it (docs/decisions.md "FDL on the wire").
  const auto r = decode(B("68 03 03 68 02 03 08 0D 16"));
  ASSERT_EQ(r.error, Error::None);
  EXPECT_TRUE(r.telegram->du.empty());
}

// ---- stream parser
// -------------------------------------------------------------------------------

std::vector<std::uint8_t> capture_stream() {
  std::vector<std::uint8_t> s;
  for (const char* h : {kCapFdlStatus, kCapSlaveDiag1, kCapSetPrm, kCapChkCfg, kCapSlaveDiag2,
                        kCapDataExch1, kCapDataExch2}) {
    const auto b = B(h);
    s.insert(s.end(), b.begin(), b.end());
  }
  return s;
}

struct Collected {
  std::vector<std::string> telegrams;  // hex of each telegram
  std::vector<Error> errors;
};

Collected drain(StreamParser& p) {
  Collected c;
  while (auto e = p.next()) {
    if (e->error == Error::None) {
      c.telegrams.push_back(H(encode(e->telegram)));
      EXPECT_EQ(H(e->raw), c.telegrams.back());
    } else {
      c.errors.push_back(e->error);
    }
  }
  return c;
}

const std::vector<std::string> kCaptureHex = {kCapFdlStatus, kCapSlaveDiag1, kCapSetPrm,
                                              kCapChkCfg,    kCapSlaveDiag2, kCapDataExch1,
                                              kCapDataExch2};

TEST(FdlStream, WholeCaptureInOneChunk) {
  StreamParser p;
  p.feed(capture_stream());
  const auto c = drain(p);
  EXPECT_EQ(c.telegrams, kCaptureHex);
  EXPECT_TRUE(c.errors.empty());
  EXPECT_EQ(p.stats().telegrams, 7u);
  EXPECT_EQ(p.stats().garbage_bytes, 0u);
  EXPECT_EQ(p.buffered(), 0u);
}

TEST(FdlStream, OneByteChunks) {
  StreamParser p;
  std::vector<std::uint64_t> offsets;
  for (auto b : capture_stream()) {
    p.feed(b);
    // A telegram is emitted the moment its ED arrives.
    while (auto e = p.next()) offsets.push_back(e->offset);
  }
  ASSERT_EQ(offsets.size(), 7u);
  EXPECT_EQ(offsets[0], 0u);
  EXPECT_EQ(offsets[1], 6u);   // after the 6-byte FDL_Status
  EXPECT_EQ(offsets[2], 17u);  // after the 11-byte Slave_Diag
}

TEST(FdlStream, GarbageBeforeAndBetweenTelegrams) {
  StreamParser p;
  // 00 FF: garbage; 10 starts an SD1 candidate that fails (no ED), 68 an SD2 candidate that fails
  // (LE != LEr); scanning resumes after each start delimiter and finds the good telegram.
  p.feed(B("00 FF 10 68 42"));
  p.feed(B(kCapFdlStatus));
  p.feed(B("77 A2 01"));
  p.feed(B(kCapSlaveDiag1));
  p.gap();
  const auto c = drain(p);
  EXPECT_EQ(c.telegrams, (std::vector<std::string>{kCapFdlStatus, kCapSlaveDiag1}));
  EXPECT_GE(c.errors.size(), 3u);
  EXPECT_GT(p.stats().garbage_bytes, 3u);
  EXPECT_GT(p.stats().framing_errors, 1u);
}

TEST(FdlStream, DelimiterBytesInsideDataDoNotSplitTheTelegram) {
  // A Data_Exchange whose outputs contain E5, 10 and a whole valid SD1 telegram.
  const auto t = Telegram::with_data(3, 2, request_fc(kFcSrdHigh, true, true), std::nullopt,
                                     std::nullopt, B("E5 10 03 02 49 4E 16 DC 68"));
  StreamParser p;
  p.feed(encode(t));
  const auto c = drain(p);
  ASSERT_EQ(c.telegrams.size(), 1u);
  EXPECT_EQ(c.telegrams[0], H(encode(t)));
}

TEST(FdlStream, FalseLongCandidateIsResolvedByTheGap) {
  // Noise that looks like an SD2 header with LE 0xF0 swallows the good telegram behind it until
  // the line goes idle (TSYN); then the candidate is abandoned and the good telegram found.
  StreamParser p;
  p.feed(B("68 F0 F0 68"));
  p.feed(B(kCapSlaveDiag2));
  EXPECT_FALSE(p.has_event());
  p.gap();
  const auto c = drain(p);
  EXPECT_EQ(c.telegrams, (std::vector<std::string>{kCapSlaveDiag2}));
  ASSERT_FALSE(c.errors.empty());
  EXPECT_EQ(c.errors[0], Error::Truncated);
}

TEST(FdlStream, WrongFcsIsCountedAndTheNextTelegramSurvives) {
  StreamParser p;
  p.feed(B("68 09 09 68 03 02 7D 11 22 33 44 55 66 E8 16"));  // FCS off by one
  p.feed(B(kCapDataExch2));
  const auto c = drain(p);
  EXPECT_EQ(c.telegrams, (std::vector<std::string>{kCapDataExch2}));
  ASSERT_FALSE(c.errors.empty());
  EXPECT_EQ(c.errors[0], Error::BadFcs);
  EXPECT_EQ(p.stats().fcs_errors, 1u);
}

TEST(FdlStream, WrongLeAndMissingEd) {
  StreamParser p;
  p.feed(B("68 09 0A 68 03 02 7D 11 22 33 44 55 66 E7 16"));  // LEr differs
  p.feed(B("10 03 02 49 4E 00"));                             // ED missing
  p.feed(B(kCapFdlStatus));
  p.gap();
  const auto c = drain(p);
  EXPECT_EQ(c.telegrams, (std::vector<std::string>{kCapFdlStatus}));
  ASSERT_GE(c.errors.size(), 2u);
  EXPECT_EQ(c.errors[0], Error::LeMismatch);
  EXPECT_NE(std::find(c.errors.begin(), c.errors.end(), Error::MissingEd), c.errors.end());
}

TEST(FdlStream, TruncatedTelegramEndsAtTheGap) {
  StreamParser p;
  const auto full = B(kCapSetPrm);
  p.feed(std::span(full).first(10));
  EXPECT_FALSE(p.has_event());
  p.gap();  // the master stopped mid-telegram
  p.feed(B(kCapChkCfg));
  const auto c = drain(p);
  EXPECT_EQ(c.telegrams, (std::vector<std::string>{kCapChkCfg}));
  ASSERT_FALSE(c.errors.empty());
  EXPECT_EQ(c.errors[0], Error::Truncated);
  EXPECT_EQ(p.buffered(), 0u);
}

TEST(FdlStream, ParityErrorDiscardsTheTelegram) {
  // docs/profibus.md: a parity error: the telegram is ignored.
  StreamParser p;
  const auto t = B(kCapDataExch1);
  p.feed(std::span(t).first(7));
  p.feed_bad_char(t[7]);
  p.feed(std::span(t).subspan(8));
  p.feed(B(kCapDataExch2));
  const auto c = drain(p);
  EXPECT_EQ(c.telegrams, (std::vector<std::string>{kCapDataExch2}));
  ASSERT_FALSE(c.errors.empty());
  EXPECT_EQ(c.errors[0], Error::ParityError);
  EXPECT_EQ(p.stats().parity_errors, 1u);
}

TEST(FdlStream, TokenAndShortAcknowledgeBetweenTelegrams) {
  StreamParser p;
  p.feed(B("DC 03 02 E5"));
  p.feed(B(kCapFdlStatus));
  const auto c = drain(p);
  EXPECT_EQ(c.telegrams, (std::vector<std::string>{"DC 03 02", "E5", kCapFdlStatus}));
}

}  // namespace
}  // namespace candp2::fdl::test
