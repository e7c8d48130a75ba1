// The PROFIBUS line's arithmetic (docs/profibus.md "The line in time"): every telegram type's wire
// time at all ten rates, the default bus parameters against the rules, TID1/TID2. Expected values
// come from the formulas (11 bits a character, the telegram layouts of IEC 61158-4-3 as encode()
// builds them, TSM = 2 + 2 Tset + Tqui), not from the code's output.
#include "profibus_sim/fdl/line_timing.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "profibus_sim/fdl/fdl.hpp"

namespace candp2::fdl {
namespace {

// µs for `bits` at `baud`, rounded up, in floating point (independent of bits_to_time).
std::int64_t us(std::uint64_t bits, std::uint32_t baud) {
  return static_cast<std::int64_t>(
      std::ceil(static_cast<long double>(bits) * 1e6L / static_cast<long double>(baud) - 1e-9L));
}

// A telegram of each type with `n` SAP + data bytes, built and encoded by the codec.
std::vector<std::uint8_t> wire(Kind kind, std::size_t n) {
  switch (kind) {
    case Kind::SD1:
      return encode(Telegram::no_data(3, 1, request_fc(kFcFdlStatus)));
    case Kind::SD2:
    case Kind::SD3:
      return encode(Telegram::with_data(3, 1, request_fc(kFcSrdHigh), std::nullopt, std::nullopt,
                                        std::vector<std::uint8_t>(n, 0x55)));
    case Kind::SD4:
      return encode(Telegram::token(1, 1));
    case Kind::SC:
      return encode(Telegram::sc());
  }
  return {};
}

TEST(LineTiming, EveryTelegramTypeAtEveryRate) {
  for (const std::uint32_t baud : kLineRates) {
    SCOPED_TRACE(baud);
    for (const Kind k : {Kind::SD1, Kind::SD4, Kind::SC}) {
      const auto bytes = wire(k, 0);
      ASSERT_FALSE(bytes.empty());
      EXPECT_EQ(telegram_bits(k), 11u * bytes.size()) << to_string(k);
      EXPECT_EQ(bits_to_time(baud, telegram_bits(k)).count(), us(11u * bytes.size(), baud));
    }
    // SD2 with 0..244 data bytes: the data unit as the codec sends it (SD3 at exactly 8).
    for (std::size_t n = 0; n <= 244; ++n) {
      const bool sd1 = n == 0;  // no data: an SD1 (an SD2 needs LE >= 4)
      const Kind k = sd1 ? Kind::SD1 : n == kSd3DataLen ? Kind::SD3 : Kind::SD2;
      const auto bytes = sd1 ? wire(Kind::SD1, 0) : wire(Kind::SD2, n);
      ASSERT_FALSE(bytes.empty()) << n;
      ASSERT_EQ(decode(bytes).telegram->kind, k) << n;
      EXPECT_EQ(telegram_bits(k, n), 11u * bytes.size()) << n;
      EXPECT_EQ(data_exchange_request_bits(n), 11u * bytes.size()) << n;
      EXPECT_EQ(bits_to_time(baud, telegram_bits(k, n)).count(), us(11u * bytes.size(), baud));
    }
    // An SD2 answer with 244 inputs, and an SC for none.
    EXPECT_EQ(data_exchange_response_bits(0), 11u);
    EXPECT_EQ(data_exchange_response_bits(244), 11u * (244 + 9));
  }
}

TEST(LineTiming, PublishedExamples) {
  // The figures: 50 bytes each way at 1.5 Mbit/s ≈ 0.9 ms for a whole exchange with the
  // overheads; at 9.6 kbit/s the two telegrams alone are 2 × 59 × 11 bits = 135 ms.
  EXPECT_EQ(telegram_bits(Kind::SD2, 50), 59u * 11u);
  EXPECT_EQ(bits_to_time(9600, 2 * telegram_bits(Kind::SD2, 50)).count(), us(1298, 9600));
}

TEST(LineTiming, DefaultsObeyTheRules) {
  for (const std::uint32_t baud : kLineRates) {
    const auto p = default_bus_parameters(baud);
    ASSERT_TRUE(p) << baud;
    EXPECT_TRUE(check_bus_parameters(*p).empty()) << baud;
    EXPECT_LE(p->max_tsdr_bits + 15, p->slot_time_bits) << baud;
    EXPECT_LE(35 + 2 * p->tset_bits + p->tqui_bits, p->max_tsdr_bits) << baud;
  }
  EXPECT_FALSE(default_bus_parameters(31250));  // not a DP rate (PA only)
  EXPECT_FALSE(default_bus_parameters(115200));
  const auto p12 = *default_bus_parameters(12000000);
  EXPECT_EQ(p12.slot_time_bits, 1000u);
  EXPECT_EQ(p12.max_tsdr_bits, 800u);
  EXPECT_EQ(p12.tset_bits, 16u);
  EXPECT_EQ(p12.tqui_bits, 9u);
  const auto p15 = *default_bus_parameters(1500000);
  EXPECT_EQ(p15.slot_time_bits, 300u);
  EXPECT_EQ(p15.max_tsdr_bits, 150u);
  const auto p96 = *default_bus_parameters(9600);
  EXPECT_EQ(p96.slot_time_bits, 100u);
  EXPECT_EQ(p96.max_tsdr_bits, 60u);
}

TEST(LineTiming, RulesNameTheParameter) {
  auto keys = [](BusParameters p) {
    std::vector<std::string> k;
    for (const auto& e : check_bus_parameters(p)) k.push_back(e.key);
    return k;
  };
  BusParameters p = *default_bus_parameters(1500000);
  p.slot_time_bits = p.max_tsdr_bits + 14;
  EXPECT_EQ(keys(p), std::vector<std::string>{"slot_time_bits"});
  p = *default_bus_parameters(1500000);
  p.tset_bits = 60;  // 35 + 120 > 150
  EXPECT_EQ(keys(p), std::vector<std::string>{"max_tsdr_bits"});
  p = *default_bus_parameters(1500000);
  p.min_tsdr_bits = 10;
  EXPECT_EQ(keys(p), std::vector<std::string>{"min_tsdr_bits"});
  p = *default_bus_parameters(1500000);
  p.retry_limit = 0;
  p.gap_factor = 101;
  EXPECT_EQ(keys(p), (std::vector<std::string>{"retry_limit", "gap_factor"}));
  p = *default_bus_parameters(1500000);
  p.max_tsdr_bits = 1024;
  p.slot_time_bits = 16384;
  EXPECT_EQ(keys(p), (std::vector<std::string>{"slot_time_bits", "max_tsdr_bits"}));
}

TEST(LineTiming, IdleTimes) {
  for (const std::uint32_t baud : kLineRates) {
    const auto p = *default_bus_parameters(baud);
    const std::uint32_t tsm = 2 + 2 * p.tset_bits + p.tqui_bits;
    EXPECT_EQ(tsm_bits(p), tsm);
    EXPECT_EQ(tid1_bits(p), std::max(33 + tsm, p.min_tsdr_bits)) << baud;
    EXPECT_EQ(tid2_bits(p), std::max(33 + tsm, p.max_tsdr_bits)) << baud;
  }
  // 1.5 Mbit/s: Tset 1, Tqui 0 → TID1 = 33 + 4 = 37, TID2 = max_TSDR 150.
  EXPECT_EQ(tid1_bits(*default_bus_parameters(1500000)), 37u);
  EXPECT_EQ(tid2_bits(*default_bus_parameters(1500000)), 150u);
  BusParameters slow = *default_bus_parameters(9600);
  slow.min_tsdr_bits = 50;
  EXPECT_EQ(tid1_bits(slow), 50u);  // min_TSDR longer than TSYN + TSM
}

TEST(LineTiming, BitsAndTime) {
  EXPECT_EQ(bits_to_time(12000000, 12).count(), 1);
  EXPECT_EQ(bits_to_time(12000000, 13).count(), 2);    // rounded up
  EXPECT_EQ(time_to_bits(9600, Duration(1000)), 10u);  // 9.6 bits → 10
  for (const std::uint32_t baud : kLineRates)
    for (std::uint64_t bits : {1ull, 33ull, 1000ull, 123457ull})
      EXPECT_GE(time_to_bits(baud, bits_to_time(baud, bits)), bits);
}

// docs/profibus.md "The bus cycle": the published rule of thumb, (380 + 300·stations + 11·bytes)
// bit times + 75 µs, claims ±10 % above 500 kbit/s. It allows a master slower than the standard's
// idle times; ours sends after exactly TID1, so the line is never longer than the rule, and at
// 12 Mbit/s (where TID1 is 76 bit times) within 10 % of it for stations with 10 bytes and more
// each way.
TEST(LineTiming, ThePublishedEstimate) {
  for (const std::size_t io : {4u, 10u, 20u})
    for (const std::uint32_t baud : {1500000u, 3000000u, 6000000u, 12000000u})
      for (const std::size_t n : {8u, 32u, 122u}) {
        SCOPED_TRACE(std::to_string(n) + " stations of " + std::to_string(io) +
                     " bytes each way at " + std::to_string(baud));
        const std::vector<CycleStation> st(n, CycleStation{.outputs = io, .inputs = io});
        const double predicted = static_cast<double>(
            predict_cycle(baud, *default_bus_parameters(baud), st).mean.count());
        const double estimate =
            static_cast<double>(380 + 300 * n + 11 * 2 * io * n) * 1e6 / baud + 75.0;
        EXPECT_LE(predicted, estimate);
        if (baud == 12000000u && io >= 10) {
          EXPECT_NEAR(predicted, estimate, estimate * 0.10);
        }
      }
}

}  // namespace
}  // namespace candp2::fdl
