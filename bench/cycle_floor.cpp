// The machine's own floor for a periodic task (docs/daemon.md "Measurements"): a thread that does
// nothing but wake at the grid points of a period, as candp2d's master cycle does, and counts the
// grid points that passed more than one period late (missed, as plant/cycle_stats.hpp counts
// them) and the lateness p99/max. What it misses, no program on this machine can keep; run it
// under the same scheduling class as candp2d (chrt -f 20) for a like-for-like floor.
//
//   cycle_floor SECONDS PERIOD_US   → one JSON line
#include <time.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace {
std::int64_t now_ns() {
  timespec t{};
  ::clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}
}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
  const std::int64_t period = (argc > 2 ? std::atoll(argv[2]) : 1000) * 1000;
  if (seconds <= 0 || period <= 0) {
    std::fprintf(stderr, "usage: cycle_floor SECONDS PERIOD_US\n");
    return 2;
  }
  std::int64_t next = now_ns() + period;
  const std::int64_t end = next + static_cast<std::int64_t>(seconds * 1e9);
  std::vector<std::int64_t> late;
  std::int64_t missed = 0;
  while (next < end) {
    const timespec at{static_cast<time_t>(next / 1'000'000'000), next % 1'000'000'000};
    ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &at, nullptr);
    const std::int64_t l = now_ns() - next;
    late.push_back(l / 1000);
    const std::int64_t m = l / period;  // grid points passed without a wake-up of their own
    missed += m;
    next += (m + 1) * period;
  }
  std::sort(late.begin(), late.end());
  std::printf("{\"cycles\": %zu, \"missed\": %lld, \"p99_us\": %lld, \"max_us\": %lld}\n",
              late.size(), static_cast<long long>(missed),
              static_cast<long long>(late[late.size() * 99 / 100]),
              static_cast<long long>(late.back()));
  return 0;
}
