// The one table of status fields and counters (station/status.hpp, docs/architecture.md "One
// vocabulary"): its rows are consistent, and the Modbus status block is its rows one after the
// other.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>
#include <vector>

#include "modbus/registers.hpp"
#include "station/status.hpp"

namespace candp2::station {
namespace {

// The ranks of one column: 1, 2, ... n, each once.
template <typename Rank>
void expect_ranks(Rank rank, const char* what) {
  std::vector<int> ranks;
  for (const auto& f : fields())
    if (rank(f)) ranks.push_back(rank(f));
  std::sort(ranks.begin(), ranks.end());
  for (std::size_t i = 0; i < ranks.size(); ++i)
    EXPECT_EQ(ranks[i], static_cast<int>(i + 1)) << what << ": ranks 1.." << ranks.size();
}

TEST(StationTable, NamesAreUniqueAndEveryValueHasAGetter) {
  std::set<std::string> names;
  for (const auto& f : fields()) {
    EXPECT_TRUE(names.insert(std::string(f.name)).second) << f.name << " twice";
    EXPECT_FALSE(f.meaning.empty()) << f.name;
    EXPECT_TRUE(f.registers == 1 || f.registers == 2 || f.name == "diag") << f.name;
    EXPECT_EQ(f.get == nullptr, f.name == "diag") << f.name;  // the diagnosis: Status::diag
    EXPECT_EQ(field(f.name), &f);
  }
  EXPECT_EQ(field("no_such_field"), nullptr);
}

TEST(StationTable, RanksAreOneToN) {
  expect_ranks([](const Field& f) { return int{f.gateway_metric.rank}; }, "gateway metrics");
  expect_ranks([](const Field& f) { return int{f.slave_metric.rank}; }, "slave metrics");
  expect_ranks([](const Field& f) { return int{f.replay}; }, "expect_counters");
}

// A metric without a type continues the family ranked just before it (a second `reason`).
TEST(StationTable, AContinuedFamilyFollowsItsFirstSeries) {
  for (const auto& f : fields()) {
    const auto& m = f.gateway_metric;
    if (!m.rank || !m.type.empty()) continue;
    EXPECT_FALSE(m.reason.empty()) << f.name;
    const auto first = std::find_if(fields().begin(), fields().end(), [&](const Field& g) {
      return g.gateway_metric.rank + 1 == m.rank;
    });
    ASSERT_NE(first, fields().end()) << f.name;
    EXPECT_EQ(first->gateway_metric.name, m.name) << f.name;
    EXPECT_FALSE(first->gateway_metric.reason.empty()) << f.name;
  }
}

TEST(StationTable, TheStatusBlockIsTheRowsInOrder) {
  std::uint16_t at = 0;
  for (const auto& f : fields()) {
    EXPECT_EQ(modbus::offset_of(f), at) << f.name;
    at = static_cast<std::uint16_t>(at + f.registers);
  }
  EXPECT_EQ(at, modbus::status::kCount);
  // Each value lands in its registers: a 32-bit counter high word first, a 16-bit one saturated.
  Status s;
  s.gateway.rx_frames = 0x00012345;
  s.gateway.fifo_level = 0x12345;
  s.cycles_missed = 0x1'0000'0001ull;
  const auto b = modbus::encode_status(s);
  EXPECT_EQ(modbus::field_value(b, *field("rx_frames")), 0x00012345u);
  EXPECT_EQ(modbus::field_value(b, *field("fifo_level")), 0xFFFFu);
  EXPECT_EQ(modbus::field_value(b, *field("master_cycles_missed")), 0xFFFFFFFFu);
}

// Only the Modbus face saturates: the other faces read a value as the status holds it.
TEST(StationTable, TheGettersGiveTheValueAsItIs) {
  Status s;
  s.gateway.fifo_level = 0x12345;
  s.cycles_missed = 0x1'0000'0001ull;
  EXPECT_EQ(field("fifo_level")->get(s), 0x12345u);
  EXPECT_EQ(field("master_cycles_missed")->get(s), 0x1'0000'0001ull);
}

}  // namespace
}  // namespace candp2::station
