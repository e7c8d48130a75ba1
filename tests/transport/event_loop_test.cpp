// The daemon's event loop: timers, descriptors, signals, deferred hooks, stop(). Every wait is
// bounded by run_until()/run_once() timeouts; nothing sleeps.
#include "event_loop/event_loop.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <vector>

#include "can/virtual_bus.hpp"
#include "event_loop/deadline_timer.hpp"
#include "transport_test_support.hpp"

namespace candp2 {
namespace {

using namespace std::chrono_literals;
using test::kWait;

struct Pipe {
  Pipe() {
    if (::pipe2(fds, O_CLOEXEC | O_NONBLOCK) != 0) throw std::runtime_error("pipe2");
  }
  ~Pipe() {
    for (int fd : fds)
      if (fd >= 0) ::close(fd);
  }
  void put(char c = 'x') { [[maybe_unused]] auto n = ::write(fds[1], &c, 1); }
  void drain() {
    char buf[64];
    while (::read(fds[0], buf, sizeof buf) > 0) {
    }
  }
  void close_writer() {
    ::close(fds[1]);
    fds[1] = -1;
  }
  int r() const { return fds[0]; }
  int w() const { return fds[1]; }
  int fds[2] = {-1, -1};
};

TEST(EventLoop, TimersFireInDeadlineOrderAndNotEarly) {
  EventLoop loop;
  std::vector<int> order;
  const Time start = loop.now();
  std::vector<Time> fired_at(3);
  loop.add_timer(30ms, [&] { order.push_back(30), fired_at[2] = loop.now(); });
  loop.add_timer(10ms, [&] { order.push_back(10), fired_at[0] = loop.now(); });
  loop.add_timer(20ms, [&] { order.push_back(20), fired_at[1] = loop.now(); });
  ASSERT_TRUE(loop.run_until([&] { return order.size() == 3; }, kWait));
  EXPECT_EQ(order, (std::vector<int>{10, 20, 30}));
  EXPECT_GE(fired_at[0] - start, 10ms);
  EXPECT_GE(fired_at[1] - start, 20ms);
  EXPECT_GE(fired_at[2] - start, 30ms);
  EXPECT_EQ(loop.timer_count(), 0u);
}

TEST(EventLoop, TimersDueTogetherFireInArmingOrder) {
  EventLoop loop;
  std::vector<int> order;
  for (int i = 0; i < 5; ++i) loop.add_timer(0ms, [&order, i] { order.push_back(i); });
  EXPECT_EQ(loop.run_once(0ms), 5u);
  EXPECT_EQ(order, (std::vector<int>{0, 1, 2, 3, 4}));
}

TEST(EventLoop, TimerArmedByATimerWaitsForTheNextRound) {
  EventLoop loop;
  bool first = false, second = false;
  loop.add_timer(0ms, [&] {
    first = true;
    loop.add_timer(0ms, [&] { second = true; });
  });
  loop.run_once(0ms);
  EXPECT_TRUE(first);
  EXPECT_FALSE(second);
  loop.run_once(0ms);
  EXPECT_TRUE(second);
}

TEST(EventLoop, PeriodicTimerRepeatsUntilItCancelsItself) {
  EventLoop loop;
  int ticks = 0;
  EventLoop::TimerId id = 0;
  id = loop.add_periodic(2ms, [&] {
    if (++ticks == 5) {
      EXPECT_TRUE(loop.cancel_timer(id));
    }
  });
  ASSERT_NE(id, 0u);
  ASSERT_TRUE(loop.run_until([&] { return ticks == 5; }, kWait));
  loop.run_once(20ms);
  EXPECT_EQ(ticks, 5);
  EXPECT_EQ(loop.timer_count(), 0u);
  EXPECT_FALSE(loop.cancel_timer(id));
  EXPECT_EQ(loop.add_periodic(0ms, [] {}), 0u);  // a zero period would spin
}

TEST(EventLoop, PeriodicTimerSkipsMissedTicksInsteadOfReplayingThem) {
  EventLoop loop;
  std::vector<Time> at;
  const Time start = loop.now();  // the timer's phase origin is at or just after this
  loop.add_periodic(10ms, [&] { at.push_back(loop.now()); });
  ASSERT_TRUE(loop.run_until([&] { return at.size() == 1; }, kWait));
  // Keep the loop busy until start + 45 ms: the ticks due at 20, 30 and 40 ms are late.
  while (loop.now() < start + 45ms) {
  }
  ASSERT_TRUE(loop.run_until([&] { return at.size() == 3; }, kWait));
  EXPECT_GE(at[0] - start, 10ms);
  EXPECT_GE(at[1] - start, 45ms);  // one late tick for the whole busy period...
  EXPECT_GE(at[2] - start, 50ms);  // ...then the next one on the original phase, not 30 or 40
}

TEST(EventLoop, CancelledTimerNeverFires) {
  EventLoop loop;
  bool cancelled_fired = false, sentinel = false;
  const auto id = loop.add_timer(5ms, [&] { cancelled_fired = true; });
  loop.add_timer(15ms, [&] { sentinel = true; });
  EXPECT_TRUE(loop.cancel_timer(id));
  EXPECT_FALSE(loop.cancel_timer(id));
  ASSERT_TRUE(loop.run_until([&] { return sentinel; }, kWait));
  EXPECT_FALSE(cancelled_fired);
}

TEST(EventLoop, TimerCancelledByAnEarlierTimerInTheSameRound) {
  EventLoop loop;
  EventLoop::TimerId second = 0;
  bool second_fired = false;
  loop.add_timer(0ms, [&] { loop.cancel_timer(second); });
  second = loop.add_timer(0ms, [&] { second_fired = true; });
  loop.run_once(0ms);
  EXPECT_FALSE(second_fired);
}

TEST(EventLoop, FdCallbackRunsWhileReadableAndNotAfterRemoval) {
  EventLoop loop;
  Pipe p;
  int calls = 0;
  std::uint32_t seen = 0;
  ASSERT_TRUE(loop.add_fd(p.r(), EventLoop::kReadable, [&](std::uint32_t ev) {
    ++calls;
    seen = ev;
    p.drain();
  }));
  EXPECT_TRUE(loop.watching(p.r()));
  std::string error;
  EXPECT_FALSE(loop.add_fd(
      p.r(), EventLoop::kReadable, [](std::uint32_t) {}, &error));
  EXPECT_NE(error.find("already watched"), std::string::npos);
  p.put();
  ASSERT_TRUE(loop.run_until([&] { return calls == 1; }, kWait));
  EXPECT_TRUE(seen & EventLoop::kReadable);
  EXPECT_TRUE(loop.remove_fd(p.r()));
  EXPECT_FALSE(loop.remove_fd(p.r()));
  p.put();
  EXPECT_EQ(loop.run_once(20ms), 0u);
  EXPECT_EQ(calls, 1);
}

TEST(EventLoop, CallbackRemovingAnotherReadyDescriptorSuppressesIt) {
  EventLoop loop;
  Pipe p1, p2;
  int calls = 0;
  loop.add_fd(p1.r(), EventLoop::kReadable, [&](std::uint32_t) {
    ++calls;
    loop.remove_fd(p2.r());
  });
  loop.add_fd(p2.r(), EventLoop::kReadable, [&](std::uint32_t) {
    ++calls;
    loop.remove_fd(p1.r());
  });
  p1.put();
  p2.put();
  loop.run_once(kWait);  // both are ready in the same round
  EXPECT_EQ(calls, 1);
}

TEST(EventLoop, WritableInterestAndModify) {
  EventLoop loop;
  Pipe p;
  std::uint32_t seen = 0;
  loop.add_fd(p.w(), EventLoop::kWritable, [&](std::uint32_t ev) { seen |= ev; });
  ASSERT_TRUE(loop.run_until([&] { return seen != 0; }, kWait));
  EXPECT_TRUE(seen & EventLoop::kWritable);
  ASSERT_TRUE(loop.modify_fd(p.w(), 0));  // no interest: never called again
  seen = 0;
  loop.run_once(10ms);
  EXPECT_EQ(seen, 0u);
  EXPECT_FALSE(loop.modify_fd(12345, EventLoop::kReadable));
}

TEST(EventLoop, HangupIsReported) {
  EventLoop loop;
  Pipe p;
  std::uint32_t seen = 0;
  loop.add_fd(p.r(), EventLoop::kReadable, [&](std::uint32_t ev) {
    seen = ev;
    loop.remove_fd(p.r());
  });
  p.close_writer();
  ASSERT_TRUE(loop.run_until([&] { return seen != 0; }, kWait));
  EXPECT_TRUE(seen & EventLoop::kHangup);
}

TEST(EventLoop, RegularFilesAreRefusedWithAReason) {
  EventLoop loop;
  FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  std::string error;
  EXPECT_FALSE(loop.add_fd(
      ::fileno(f), EventLoop::kReadable, [](std::uint32_t) {}, &error));
  EXPECT_NE(error.find("cannot watch descriptor"), std::string::npos) << error;
  EXPECT_FALSE(loop.watching(::fileno(f)));
  std::fclose(f);
}

TEST(EventLoop, SighupArrivesThroughSignalfd) {
  EventLoop loop;
  int got = 0;
  ASSERT_TRUE(loop.add_signal(SIGHUP, [&](int signo) { got = signo; }));
  ASSERT_EQ(::raise(SIGHUP), 0);  // blocked now: pending until the loop reads it
  ASSERT_TRUE(loop.run_until([&] { return got != 0; }, kWait));
  EXPECT_EQ(got, SIGHUP);
}

TEST(EventLoop, SigtermCallbackStopsRun) {
  EventLoop loop;
  int signals = 0;
  bool watchdog = false;
  loop.add_signal(SIGTERM, [&](int) {
    ++signals;
    loop.stop();
  });
  loop.add_signal(SIGINT, [&](int) { ++signals; });
  loop.add_timer(1ms, [] { ::raise(SIGINT), ::raise(SIGTERM); });
  loop.add_timer(kWait, [&] {
    watchdog = true;
    loop.stop();
  });
  loop.run();
  EXPECT_FALSE(watchdog) << "SIGTERM did not stop the loop";
  EXPECT_EQ(signals, 2);
}

TEST(EventLoop, StopEndsRunAndAnEarlyStopReturnsAtOnce) {
  EventLoop loop;
  int ticks = 0;
  loop.add_periodic(1ms, [&] {
    if (++ticks == 3) loop.stop();
  });
  loop.run();
  EXPECT_EQ(ticks, 3);
  EXPECT_FALSE(loop.stop_requested());
  loop.stop();
  loop.run();  // returns at once
  EXPECT_EQ(ticks, 3);
}

TEST(EventLoop, RunOnceWaitsAtMostItsTimeout) {
  EventLoop loop;
  const Time t0 = loop.now();
  EXPECT_EQ(loop.run_once(20ms), 0u);
  const Duration waited = loop.now() - t0;
  EXPECT_GE(waited, 19ms);
  EXPECT_LT(waited, 5s);
}

TEST(EventLoop, NowIsMonotonicAndWallIsEpochTime) {
  const Time a = EventLoop::monotonic_now();
  const Time b = EventLoop::monotonic_now();
  EXPECT_LE(a, b);
  EXPECT_GT(EventLoop::wall_now(), std::chrono::seconds(1600000000));  // after 2020
}

TEST(EventLoop, DeferredHooksSettleInProcessTrafficInOneDispatch) {
  // Two nodes on a VirtualBus play ping-pong through deferred hooks (how the daemon drains
  // in-process endpoints): one timer callback starts it; all 10 exchanges settle in that dispatch.
  EventLoop loop;
  can::VirtualBus bus;
  auto x = bus.endpoint("x");
  auto y = bus.endpoint("y");
  int received = 0;
  auto bounce = [&](can::VirtualEndpoint& ep) {
    bool any = false;
    while (auto f = ep.receive()) {
      any = true;
      ++received;
      if (f->data[0] < 10) {
        const std::uint8_t next[] = {static_cast<std::uint8_t>(f->data[0] + 1)};
        ep.send(can::Frame::std_data(0x100, next));
      }
    }
    return any;
  };
  loop.add_deferred([&] { return bounce(*x); });
  const auto id_y = loop.add_deferred([&] { return bounce(*y); });
  loop.add_timer(0ms, [&] {
    const std::uint8_t first[] = {0};
    x->send(can::Frame::std_data(0x100, first));
  });
  loop.run_once(0ms);
  EXPECT_EQ(received, 11);  // values 0..10
  EXPECT_TRUE(loop.remove_deferred(id_y));
  EXPECT_FALSE(loop.remove_deferred(id_y));
}

TEST(EventLoop, DeferredHooksAlsoRunAtTheStartOfEveryRound) {
  // Work queued outside any callback (a test or a tool sending on an endpoint) is not left waiting.
  EventLoop loop;
  int runs = 0;
  loop.add_deferred([&] {
    ++runs;
    return false;
  });
  loop.run_once(0ms);
  EXPECT_GE(runs, 1);
}

// DeadlineTimer (event_loop/deadline_timer.hpp): one loop timer at a moving deadline.
TEST(DeadlineTimer, ArmsOneLoopTimerAndRearmsOnlyWhenTheDeadlineChanges) {
  EventLoop loop;
  int fired = 0;
  DeadlineTimer t(loop, [&] { ++fired; });
  const Time now = loop.now();
  t.arm(now + 20ms, now);
  t.arm(now + 20ms, now);  // the same deadline: still one timer
  EXPECT_EQ(loop.timer_count(), 1u);
  t.arm(now + 10ms, now);  // moved: the old loop timer is cancelled
  EXPECT_EQ(loop.timer_count(), 1u);
  EXPECT_EQ(t.at(), now + 10ms);
  ASSERT_TRUE(loop.run_until([&] { return fired == 1; }, kWait));
  EXPECT_GE(loop.now() - now, 10ms);
  EXPECT_EQ(t.at(), std::nullopt);  // disarmed after firing
  EXPECT_EQ(loop.timer_count(), 0u);
  t.arm(loop.now() + 5ms, loop.now());
  t.arm(std::nullopt, loop.now());  // no deadline: nothing fires
  EXPECT_EQ(loop.timer_count(), 0u);
  loop.run_once(20ms);
  EXPECT_EQ(fired, 1);
}

TEST(DeadlineTimer, ArmEarlierOnlyMovesTheDeadlineForward) {
  EventLoop loop;
  DeadlineTimer t(loop, [] {});
  const Time now = loop.now();
  t.arm_earlier(std::nullopt, now);
  EXPECT_EQ(t.at(), std::nullopt);
  t.arm_earlier(now + 50ms, now);
  EXPECT_EQ(t.at(), now + 50ms);
  t.arm_earlier(now + 80ms, now);  // later: the earlier timer stays
  EXPECT_EQ(t.at(), now + 50ms);
  t.arm_earlier(now + 30ms, now);
  EXPECT_EQ(t.at(), now + 30ms);
  EXPECT_EQ(loop.timer_count(), 1u);
}

TEST(DeadlineTimer, DestructionCancelsTheLoopTimer) {
  EventLoop loop;
  {
    DeadlineTimer t(loop, [] { FAIL() << "fired after destruction"; });
    t.arm(loop.now() + 1ms, loop.now());
    EXPECT_EQ(loop.timer_count(), 1u);
  }
  EXPECT_EQ(loop.timer_count(), 0u);
  loop.run_once(10ms);
}

}  // namespace
}  // namespace candp2
