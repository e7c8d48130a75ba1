#include "can/id_counts.hpp"

#include <algorithm>
#include <limits>

#include "can/frame_bits.hpp"

namespace candp2::can {

namespace {
// An arbitration key's first slot in an index of `size` (a power of two) slots: Fibonacci hashing
// (the identifiers of one bus are often consecutive).
std::size_t slot_of(std::uint32_t key, std::size_t size) {
  return static_cast<std::size_t>((std::uint64_t{key} * 0x9E3779B97F4A7C15ull) >> 32) & (size - 1);
}

// A period or a latency as an entry keeps it (neither is negative: a frame starts at or after its
// request, after the last start of its identifier).
std::uint32_t micros32(Duration d) {
  return static_cast<std::uint32_t>(
      std::clamp<std::int64_t>(d.count(), 0, std::numeric_limits<std::uint32_t>::max()));
}
}  // namespace

Duration IdStatistics::period_mean() const {
  return frames > 1 ? period_sum / static_cast<std::int64_t>(frames - 1) : Duration(0);
}

Duration IdStatistics::latency_mean() const {
  return frames ? latency_sum / static_cast<std::int64_t>(frames) : Duration(0);
}

void IdCounts::prefetch_after(std::uint32_t last) const {
  const std::size_t size = counts_.size();
  // `last` is its entry's index + 1: the position of the entry after it.
  for (std::size_t k = 0, e = last < size ? last : 0; k < kAhead && k < size;
       ++k, e = e + 1 == size ? 0 : e + 1)
    __builtin_prefetch(&counts_[e], 1);
}

void IdCounts::count(std::uint32_t& last, std::uint32_t entry, Time at, Time requested) {
  Entry& c = counts_[entry - 1];
  // The node's order: its last frame's entry leads to this one.
  if (last != 0) counts_[last - 1].after = entry;
  last = entry;
  if (c.frames > 0) {
    const Duration period = at - Time(c.last_start);
    const std::uint32_t p = micros32(period);
    c.period_last = p;
    c.period_min = c.frames == 1 ? p : std::min(c.period_min, p);
    c.period_max = std::max(c.period_max, p);
    c.period_sum += period.count();
  }
  const Duration latency = at - requested;
  c.latency_last = micros32(latency);
  c.latency_max = std::max(c.latency_max, c.latency_last);
  c.latency_sum += latency.count();
  c.last_start = at.count();
  ++c.frames;
}

std::size_t IdCounts::slot(std::uint32_t key) const {
  std::size_t i = slot_of(key, index_.size());
  while (index_[i].index && index_[i].key != key) i = (i + 1) & (index_.size() - 1);
  return i;
}

std::uint32_t IdCounts::find_in_index(std::uint32_t key) const {
  return index_.empty() ? 0 : index_[slot(key)].index;
}

std::uint32_t IdCounts::add(std::uint32_t key) {
  if (2 * (counts_.size() + 1) > index_.size()) {  // grow: at most half full
    std::vector<Slot> old(std::max<std::size_t>(64, 2 * index_.size()));
    old.swap(index_);
    for (const Slot& s : old)
      if (s.index) index_[slot(s.key)] = s;
  }
  Slot& s = index_[slot(key)];
  if (!s.index) {
    counts_.emplace_back().key = key;
    s = Slot{key, static_cast<std::uint32_t>(counts_.size())};
  }
  return s.index;
}

IdStatistics IdCounts::statistics(const Entry& c) {
  IdStatistics s;
  const ArbitrationField field = arbitration_field(c.key);
  s.id = field.id;
  s.remote = field.remote;
  s.frames = c.frames;
  s.last_start = Time(c.last_start);
  s.period_last = Duration(c.period_last);
  s.period_min = Duration(c.period_min);
  s.period_max = Duration(c.period_max);
  s.period_sum = Duration(c.period_sum);
  s.latency_last = Duration(c.latency_last);
  s.latency_max = Duration(c.latency_max);
  s.latency_sum = Duration(c.latency_sum);
  return s;
}

std::map<std::uint32_t, IdStatistics> IdCounts::identifiers() const {
  std::map<std::uint32_t, IdStatistics> out;
  for (const Entry& c : counts_) out.emplace(c.key, statistics(c));
  return out;
}

void IdCounts::identifiers(std::vector<IdStatistics>& out) const {
  // The entries are in the order their identifiers first started: sorted by key here.
  std::vector<const Entry*> order;
  order.reserve(counts_.size());
  for (const Entry& c : counts_) order.push_back(&c);
  std::sort(order.begin(), order.end(),
            [](const Entry* a, const Entry* b) { return a->key < b->key; });
  out.clear();
  for (const Entry* c : order) out.push_back(statistics(*c));
}

}  // namespace candp2::can
