// The earliest of many deadlines that move one at a time (docs/architecture.md "The plant"): a
// line in time reaches one gateway a telegram, and a walk over every gateway's deadline each
// time would cost more than the line itself.
//
// Items 0..n-1 each have an optional deadline, asked of the owner (`deadline_of(i)`) only for the
// items marked moved since the last look. A lazy min-heap: a moved item gets a new entry, its old
// entry is dropped when it comes to the top (or when stale entries outnumber the live ones).
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <vector>

#include "common/time.hpp"

namespace candp2 {

class EarliestDeadline {
 public:
  // n items, every deadline asked again.
  void resize(std::size_t n) {
    stamp_.assign(n, 0);
    at_.assign(n, std::nullopt);
    pending_flag_.assign(n, false);
    pending_.clear();
    all_ = true;
  }
  std::size_t size() const { return stamp_.size(); }

  // Item i's deadline must be asked again (an item beyond size() is asked when it is added).
  void moved(std::size_t i) {
    if (all_ || i >= stamp_.size() || pending_flag_[i]) return;
    pending_flag_[i] = true;
    pending_.push_back(static_cast<std::uint32_t>(i));
  }
  // Every item's deadline must be asked again.
  void all_moved() { all_ = true; }
  // Nothing was marked since the last look: earliest() gives what it gave.
  bool settled() const { return !all_ && pending_.empty(); }

  // Item i's deadline as it was last asked (the look before: earliest() asks the moved ones).
  std::optional<Time> at(std::size_t i) const { return at_[i]; }

  // The earliest deadline; `deadline_of(i)` -> std::optional<Time>.
  template <class F>
  std::optional<Time> earliest(F&& deadline_of) {
    if (!settled()) refresh(deadline_of);
    return first_;
  }

 private:
  template <class F>
  void refresh(F& deadline_of) {
    if (all_) {
      heap_.clear();
      for (std::size_t i = 0; i < stamp_.size(); ++i) {
        ++stamp_[i];
        if (const std::optional<Time> d = at_[i] = deadline_of(i))
          heap_.push_back({*d, static_cast<std::uint32_t>(i), stamp_[i]});
      }
      std::make_heap(heap_.begin(), heap_.end(), later);
      for (const std::uint32_t i : pending_) pending_flag_[i] = false;
      pending_.clear();
      all_ = false;
    } else {
      for (const std::uint32_t i : pending_) {
        pending_flag_[i] = false;
        ++stamp_[i];
        if (const std::optional<Time> d = at_[i] = deadline_of(i)) {
          heap_.push_back({*d, i, stamp_[i]});
          std::push_heap(heap_.begin(), heap_.end(), later);
        }
      }
      pending_.clear();
      if (heap_.size() > 2 * stamp_.size() + 16) {  // stale entries piled up below the top
        std::erase_if(heap_, [this](const Entry& e) { return e.stamp != stamp_[e.item]; });
        std::make_heap(heap_.begin(), heap_.end(), later);
      }
    }
    while (!heap_.empty() && heap_.front().stamp != stamp_[heap_.front().item]) {
      std::pop_heap(heap_.begin(), heap_.end(), later);
      heap_.pop_back();
    }
    first_ = heap_.empty() ? std::nullopt : std::optional<Time>(heap_.front().at);
  }

  struct Entry {
    Time at;
    std::uint32_t item;
    std::uint64_t stamp;
  };
  static bool later(const Entry& a, const Entry& b) { return a.at > b.at; }

  std::vector<Entry> heap_;
  std::vector<std::uint64_t> stamp_;  // an entry is live while its stamp is the item's
  std::vector<std::optional<Time>> at_;
  std::vector<bool> pending_flag_;
  std::vector<std::uint32_t> pending_;
  bool all_ = true;
  std::optional<Time> first_;  // what the last refresh found
};

}  // namespace candp2
