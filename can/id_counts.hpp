// A bus in time's statistics per identifier (docs/can-bus.md "The bus in time": frames, period,
// jitter, queueing latency), counted at each start of frame without error. Kept for speed at every
// frame (docs/can-bus.md "Performance"): each identifier's counts in one cache line, densely in the
// order the identifiers first started, found through the entry its node's frame used after the
// node's last frame the time before (a node sends its frames in the same order cycle after cycle),
// else through a small index by arbitration key. Entries are numbered from 1 (0: none).
//
// Pure: no sockets, no clock, no threads; time passed in.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <vector>

#include "can/frame.hpp"
#include "common/time.hpp"

namespace candp2::can {

// Per identifier (the arbitration field: identifier, IDE and RTR; a remote frame apart from the
// data frames of its identifier). Period: the time between two starts of frame; jitter: the
// largest period less the smallest. Latency: send request to start of frame. The last, smallest
// and largest period and latency are kept up to 2^32 − 1 µs (71 min 35 s); the sums are exact.
struct IdStatistics {
  Ident id;
  bool remote = false;
  std::uint64_t frames = 0;
  Time last_start{0};
  Duration period_last{0}, period_min{0}, period_max{0}, period_sum{0};
  Duration latency_last{0}, latency_max{0}, latency_sum{0};
  Duration period_mean() const;
  Duration jitter() const { return period_max - period_min; }
  Duration latency_mean() const;
};

class IdCounts {
 public:
  // The entry of the frame with arbitration key `key` that a node starts now, whose last frame's
  // entry was `last`: the one that followed `last` the time before, else the index's (0: the key
  // has none yet).
  std::uint32_t find(std::uint32_t last, std::uint32_t key) const {
    if (last != 0)
      if (const std::uint32_t next = counts_[last - 1].after;
          next != 0 && counts_[next - 1].key == key)
        return next;
    return find_in_index(key);
  }
  // The entry of `key`, made on its first frame.
  std::uint32_t add(std::uint32_t key);
  // The entry's line, wanted soon.
  void prefetch(std::uint32_t entry) const { __builtin_prefetch(&counts_[entry - 1], 1); }
  // The lines of the few entries after `last`: those of the next frames when the bus repeats the
  // order in which its identifiers first started, fetched together.
  void prefetch_after(std::uint32_t last) const;
  // A frame of `entry` that started at `at`, requested at `requested`, sent by a node whose last
  // frame's entry is `last` (this entry from now on).
  void count(std::uint32_t& last, std::uint32_t entry, Time at, Time requested);

  // By arbitration_key (the order of priority), built at each call.
  std::map<std::uint32_t, IdStatistics> identifiers() const;
  // The same in the same order as a list, into `out` (cleared, its storage kept).
  void identifiers(std::vector<IdStatistics>& out) const;

 private:
  // One identifier's counts, in one cache line: periods and latencies in microseconds up to
  // 2^32 − 1, larger ones read as that. `after`: the entry of the frame its node started next the
  // last time.
  struct alignas(64) Entry {
    std::uint32_t key = 0;
    std::uint32_t after = 0;
    std::uint64_t frames = 0;
    std::int64_t last_start = 0;  // µs since the epoch of Time
    std::int64_t period_sum = 0, latency_sum = 0;
    std::uint32_t period_last = 0, period_min = 0, period_max = 0;
    std::uint32_t latency_last = 0, latency_max = 0;
  };
  static_assert(sizeof(Entry) == 64);
  // The index: open addressing, linear probing, at most half full (a std::unordered_map's node
  // walk, then a std::map's node apart from every other, cost more than the rest of a start of
  // frame).
  struct Slot {
    std::uint32_t key = 0;
    std::uint32_t index = 0;  // the entry; 0: empty
  };
  static constexpr std::size_t kAhead = 6;  // prefetch_after()'s entries
  static IdStatistics statistics(const Entry& e);
  // The slot of `key`, or the empty slot where it would go.
  std::size_t slot(std::uint32_t key) const;
  std::uint32_t find_in_index(std::uint32_t key) const;
  std::vector<Slot> index_;
  std::vector<Entry> counts_;
};

}  // namespace candp2::can
