// The one table of replay actions (replay/actions.cpp, docs/development.md "Add a replay step"):
// the build already refuses an action without its row; here every row has its parser, its
// handler and its description, and every key is taken once.
#include "replay/actions.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace candp2::replay {
namespace {

TEST(ReplayActions, EveryRowIsComplete) {
  std::set<std::string> keys;
  for (const auto& a : actions()) {
    SCOPED_TRACE(std::string(a.key));
    EXPECT_NE(a.parse, nullptr);
    EXPECT_NE(a.run, nullptr);
    EXPECT_NE(a.describe, nullptr);
    EXPECT_TRUE(keys.insert(std::string(a.key)).second) << "key used twice";
    EXPECT_EQ(&spec(a.action), &a);
  }
  EXPECT_EQ(keys.size(), static_cast<std::size_t>(Action::Count));
}

}  // namespace
}  // namespace candp2::replay
