// How punctual the DP master cycle is (docs/daemon.md "Cycle timing"). The cycle is due at the
// grid points first + k * period. A cycle that starts at `now` for the grid point `due` is
// `now - due` late, however late that is (an overrun of several periods included); the grid points
// that passed meanwhile without a cycle of their own are missed and counted. Lateness is kept in
// a ring of the last kSamples cycles: record() is a few stores; summary() selects the quantiles
// from a copy and is only called when someone asks (the HTTP face, /metrics). Pure: time is
// passed in.
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

  void start(Duration period) {
    period_ = period;
    count_ = 0;
    missed_ = 0;
    max_ = Duration{0};
  }
  // A cycle due at `due` started at `now`; `missed` grid points after `due` passed without a
  // cycle (they are not run late: the next cycle is due at the next grid point after `now`).
  void record(Time due, Time now, std::uint64_t missed) {
    const Duration late = std::max(Duration{0}, now - due);
    ring_[count_ % kSamples] =
        static_cast<std::uint32_t>(std::min<std::int64_t>(late.count(), UINT32_MAX));
    ++count_;
    missed_ += missed;
    max_ = std::max(max_, late);
  }
  std::uint64_t cycles() const { return count_; }
  std::uint64_t missed() const { return missed_; }
  Duration period() const { return period_; }

  struct Summary {
    std::uint64_t cycles = 0;  // run since start
    std::uint64_t missed = 0;  // grid points without a cycle since start
    std::size_t samples = 0;   // in the window below
    std::uint32_t p50_us = 0;  // over the last `samples` cycles
    std::uint32_t p99_us = 0;
    std::uint32_t max_us = 0;       // over the last `samples` cycles
    std::uint32_t max_ever_us = 0;  // since start
  };
  Summary summary() const {
    Summary s;
    s.cycles = count_;
    s.missed = missed_;
    s.samples = static_cast<std::size_t>(std::min<std::uint64_t>(count_, kSamples));
    s.max_ever_us = static_cast<std::uint32_t>(std::min<std::int64_t>(max_.count(), UINT32_MAX));
    if (s.samples == 0) return s;
    std::vector<std::uint32_t> v(ring_.begin(), ring_.begin() + static_cast<long>(s.samples));
    auto at = [&](double q) {
      const auto k = static_cast<long>(q * static_cast<double>(v.size() - 1));
      std::nth_element(v.begin(), v.begin() + k, v.end());
      return v[static_cast<std::size_t>(k)];
    };
    s.max_us = at(1.0);
    s.p99_us = at(0.99);
    s.p50_us = at(0.50);
    return s;
  }

 private:
  Duration period_{0};
  std::uint64_t count_ = 0;
  std::uint64_t missed_ = 0;
  Duration max_{0};
  std::array<std::uint32_t, kSamples> ring_{};
};

}  // namespace candp2::plant
