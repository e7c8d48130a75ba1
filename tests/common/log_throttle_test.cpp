// One repeated event gives one log line a second with the count (common/log_throttle.hpp,
// docs/daemon.md "Logging"), in virtual time.
#include "common/log_throttle.hpp"

#include <gtest/gtest.h>

namespace candp2 {
namespace {

TEST(LogThrottle, FirstAtOnceThenOneASecondWithTheCount) {
  MemoryLog sink;
  LogThrottle t(Logger(&sink, "modbus"));
  // 1000 clients dropped within 0.999 s: one line now, the rest counted.
  for (int i = 0; i < 1000; ++i)
    t.log(Time{microseconds(i * 999)}, "dropped", LogLevel::Warn,
          "client 127.0.0.1:" + std::to_string(40000 + i) + " dropped");
  ASSERT_EQ(sink.lines.size(), 1u);
  EXPECT_EQ(sink.lines[0].message, "client 127.0.0.1:40000 dropped");
  EXPECT_EQ(t.suppressed(), 999u);
  ASSERT_TRUE(t.next_flush());
  EXPECT_EQ(*t.next_flush(), Time{seconds(1)});
  t.flush(Time{milliseconds(999)});  // the second is not over
  EXPECT_EQ(sink.lines.size(), 1u);
  t.flush(Time{seconds(1)});
  ASSERT_EQ(sink.lines.size(), 2u);
  EXPECT_EQ(sink.lines[1].message,
            "999 more in the last second, the last: client 127.0.0.1:40999 dropped");
  EXPECT_EQ(sink.lines[1].level, LogLevel::Warn);
  EXPECT_EQ(t.suppressed(), 0u);
  EXPECT_FALSE(t.next_flush());
}

TEST(LogThrottle, ALineAfterSuppressedOnesCarriesTheirCount) {
  MemoryLog sink;
  LogThrottle t(Logger(&sink, "http"));
  t.log(Time{0}, "idle", LogLevel::Info, "a");
  t.log(Time{milliseconds(10)}, "idle", LogLevel::Info, "b");
  t.log(Time{milliseconds(20)}, "idle", LogLevel::Info, "c");
  t.log(Time{milliseconds(1500)}, "idle", LogLevel::Info, "d");
  ASSERT_EQ(sink.lines.size(), 2u);
  EXPECT_EQ(sink.lines[1].message, "d (and 2 more like it before)");
}

TEST(LogThrottle, KindsAreCountedApart) {
  MemoryLog sink;
  LogThrottle t(Logger(&sink, "modbus"));
  for (int i = 0; i < 3; ++i) {
    t.log(Time{milliseconds(i)}, "connected", LogLevel::Info, "c" + std::to_string(i));
    t.log(Time{milliseconds(i)}, "dropped", LogLevel::Warn, "d" + std::to_string(i));
  }
  ASSERT_EQ(sink.lines.size(), 2u);  // the first of each kind
  EXPECT_EQ(sink.lines[0].message, "c0");
  EXPECT_EQ(sink.lines[1].message, "d0");
  t.flush(Time{seconds(5)});
  ASSERT_EQ(sink.lines.size(), 4u);
  EXPECT_EQ(sink.lines[2].message, "2 more in the last second, the last: c2");
  EXPECT_EQ(sink.lines[3].message, "2 more in the last second, the last: d2");
}

}  // namespace
}  // namespace candp2
