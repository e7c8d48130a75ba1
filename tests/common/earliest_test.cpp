// The earliest of many moving deadlines (common/earliest.hpp, docs/architecture.md "The plant"):
// against a walk over all of them, through a random sequence of moves.
#include "common/earliest.hpp"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace candp2 {
namespace {

std::optional<Time> walk(const std::vector<std::optional<Time>>& d) {
  std::optional<Time> first;
  for (const auto& x : d)
    if (x && (!first || *x < *first)) first = x;
  return first;
}

TEST(EarliestDeadline, AgreesWithAWalkOverAllThroughRandomMoves) {
  std::mt19937 rng(29);
  std::vector<std::optional<Time>> d(40);
  std::vector<int> asked(d.size(), 0);
  EarliestDeadline e;
  e.resize(d.size());
  const auto of = [&](std::size_t i) {
    ++asked[i];
    return d[i];
  };
  EXPECT_EQ(e.earliest(of), std::nullopt);  // all asked once
  EXPECT_EQ(std::count(asked.begin(), asked.end(), 1), static_cast<long>(d.size()));
  for (int step = 0; step < 20000; ++step) {
    const auto i = static_cast<std::size_t>(rng() % d.size());
    const unsigned what = rng() % 10;
    if (what == 0)
      d[i].reset();
    else
      d[i] = Time{microseconds(static_cast<std::int64_t>(rng() % 1000))};
    if (what == 1) {
      e.all_moved();
    } else {
      e.moved(i);
      e.moved(i);  // twice before a look: asked once
    }
    std::fill(asked.begin(), asked.end(), 0);
    ASSERT_EQ(e.earliest(of), walk(d)) << "step " << step;
    for (std::size_t k = 0; k < d.size(); ++k) ASSERT_EQ(e.at(k), d[k]) << "step " << step;
    if (what != 1) {
      EXPECT_EQ(asked[i], 1);
      EXPECT_EQ(std::count(asked.begin(), asked.end(), 0), static_cast<long>(d.size()) - 1);
    }
  }
}

// The tree (the timed buses' deadlines) against the walk, and the items due by a time in order.
TEST(DeadlineTree, AgreesWithAWalkOverAllThroughRandomMoves) {
  std::mt19937 rng(36);
  for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{2}, std::size_t{61}}) {
    std::vector<std::optional<Time>> d(n);
    DeadlineTree t;
    t.resize(n);
    const auto of = [&](std::size_t i) { return d[i]; };
    EXPECT_EQ(t.earliest(of), std::nullopt);
    for (int step = 0; n > 0 && step < 20000; ++step) {
      const auto i = static_cast<std::size_t>(rng() % n);
      if (rng() % 10 == 0)
        d[i].reset();
      else
        d[i] = Time{microseconds(static_cast<std::int64_t>(rng() % 1000))};
      t.moved(i);
      ASSERT_EQ(t.earliest(of), walk(d)) << "n " << n << " step " << step;
      const Time now{microseconds(static_cast<std::int64_t>(rng() % 1000))};
      std::vector<std::uint32_t> due, expect;
      t.due(now, due);
      for (std::size_t k = 0; k < n; ++k)
        if (d[k] && *d[k] <= now) expect.push_back(static_cast<std::uint32_t>(k));
      ASSERT_EQ(due, expect) << "n " << n << " step " << step;
    }
  }
}

TEST(EarliestDeadline, SettledUntilAMoveAndNoneWithoutDeadlines) {
  EarliestDeadline e;
  e.resize(3);
  EXPECT_FALSE(e.settled());
  const auto none = [](std::size_t) { return std::optional<Time>{}; };
  EXPECT_EQ(e.earliest(none), std::nullopt);
  EXPECT_TRUE(e.settled());
  e.moved(7);  // beyond the items: nothing
  EXPECT_TRUE(e.settled());
  e.moved(1);
  EXPECT_FALSE(e.settled());
  EXPECT_EQ(e.earliest([](std::size_t i) { return std::optional<Time>{Time{microseconds(i)}}; }),
            Time{microseconds(1)});
}

}  // namespace
}  // namespace candp2
