// How late the DP master cycle starts against its grid (docs/daemon.md "Cycle timing"): the loop's
// periodic timer fires at first + k * period; each start's lateness (now - grid point) is kept in
// a ring of the last kSamples cycles. record() is two stores; summary() sorts a copy and is only
// called when someone asks (GET /api/v1/status, /metrics). Pure: time is passed in.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "common/time.hpp"

namespace candp2::plant {

class CycleStats {
 public:
  static constexpr std::size_t kSamples = 4096;  // ~41 s of 10 ms cycles

  void start(Time first, Duration period) {
    first_ = first;
    period_ = period;
    count_ = 0;
    max_ = Duration{0};
  }
  // A cycle started at `now` (a missed tick shows as its successor's lateness modulo the period).
  void record(Time now) {
    if (period_.count() <= 0 || now < first_) return;
    const Duration late = (now - first_) % period_;
    ring_[count_ % kSamples] = static_cast<std::uint32_t>(late.count());
    ++count_;
    max_ = std::max(max_, late);
  }

  struct Summary {
    std::uint64_t cycles = 0;  // since start
    std::size_t samples = 0;   // in the window below
    std::uint32_t p50_us = 0;  // over the last `samples` cycles
    std::uint32_t p99_us = 0;
    std::uint32_t max_us = 0;       // over the last `samples` cycles
    std::uint32_t max_ever_us = 0;  // since start
  };
  Summary summary() const {
    Summary s;
    s.cycles = count_;
    s.samples = static_cast<std::size_t>(std::min<std::uint64_t>(count_, kSamples));
    s.max_ever_us = static_cast<std::uint32_t>(max_.count());
    if (s.samples == 0) return s;
    std::vector<std::uint32_t> v(ring_.begin(), ring_.begin() + static_cast<long>(s.samples));
    std::sort(v.begin(), v.end());
    auto at = [&](double q) {
      return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
    };
    s.p50_us = at(0.50);
    s.p99_us = at(0.99);
    s.max_us = v.back();
    return s;
  }

 private:
  Time first_{0};
  Duration period_{0};
  std::uint64_t count_ = 0;
  Duration max_{0};
  std::array<std::uint32_t, kSamples> ring_{};
};

}  // namespace candp2::plant
