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
    pending_flag_.assign(n, 0);
    pending_.clear();
    all_ = true;
  }
  std::size_t size() const { return stamp_.size(); }

  // Item i's deadline must be asked again (an item beyond size() is asked when it is added).
  void moved(std::size_t i) {
    if (all_ || i >= stamp_.size() || pending_flag_[i]) return;
    pending_flag_[i] = 1;
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
      for (const std::uint32_t i : pending_) pending_flag_[i] = 0;
      pending_.clear();
      all_ = false;
    } else {
      for (const std::uint32_t i : pending_) {
        pending_flag_[i] = 0;
        // The same deadline: its live entry stands (a gateway that took a frame mostly waits for
        // what it waited for; docs/can-bus.md "Performance").
        const std::optional<Time> d = deadline_of(i);
        if (d == at_[i]) continue;
        ++stamp_[i];
        if ((at_[i] = d)) {
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
  std::vector<std::uint8_t> pending_flag_;  // bytes: tested and set at every move
  std::vector<std::uint32_t> pending_;
  bool all_ = true;
  std::optional<Time> first_;  // what the last refresh found
};

// The same for items whose deadlines move at almost every look (the timed buses: a request, a
// start or an end of frame moves one; docs/can-bus.md "Performance"): a tournament tree, each
// inner node the earliest of its two children. A moved item's leaf is set and the path above it
// recomputed up to where nothing changes; nothing goes stale. due() finds the items due without a
// walk over all.
class DeadlineTree {
 public:
  // n items, every deadline asked again.
  void resize(std::size_t n) {
    leaves_ = 1;
    while (leaves_ < n) leaves_ *= 2;
    tree_.assign(2 * leaves_, kNone);
    pending_flag_.assign(n, 0);
    pending_.clear();
    all_ = true;
  }
  std::size_t size() const { return pending_flag_.size(); }

  // Item i's deadline must be asked again.
  void moved(std::size_t i) {
    if (all_ || i >= size() || pending_flag_[i]) return;
    pending_flag_[i] = 1;
    pending_.push_back(static_cast<std::uint32_t>(i));
  }

  // The earliest deadline; `deadline_of(i)` -> std::optional<Time>.
  template <class F>
  std::optional<Time> earliest(F&& deadline_of) {
    if (all_) {
      for (std::size_t i = 0; i < size(); ++i) tree_[leaves_ + i] = deadline_of(i).value_or(kNone);
      for (std::size_t k = leaves_; k-- > 1;) tree_[k] = std::min(tree_[2 * k], tree_[2 * k + 1]);
      for (const std::uint32_t i : pending_) pending_flag_[i] = 0;
      pending_.clear();
      all_ = false;
    }
    for (const std::uint32_t i : pending_) {
      pending_flag_[i] = 0;
      std::size_t k = leaves_ + i;
      tree_[k] = deadline_of(i).value_or(kNone);
      for (k /= 2; k >= 1; k /= 2) {
        const Time m = std::min(tree_[2 * k], tree_[2 * k + 1]);
        if (m == tree_[k]) break;  // nor anything above it
        tree_[k] = m;
      }
    }
    pending_.clear();
    return tree_[1] == kNone ? std::nullopt : std::optional<Time>(tree_[1]);
  }

  // Appends to `out` the items whose deadline, as earliest() last asked it, is at or before
  // `now`, in the items' order; only the subtrees holding one are looked at. Call it right after
  // earliest().
  void due(Time now, std::vector<std::uint32_t>& out) const {
    walk_.assign(1, 1);
    while (!walk_.empty()) {
      const std::size_t k = walk_.back();
      walk_.pop_back();
      if (tree_[k] > now) continue;
      if (k >= leaves_) {
        out.push_back(static_cast<std::uint32_t>(k - leaves_));
      } else {
        walk_.push_back(2 * k + 1);  // the right after the left
        walk_.push_back(2 * k);
      }
    }
  }

 private:
  static constexpr Time kNone = Time::max();
  std::size_t leaves_ = 1;
  std::vector<Time> tree_ = std::vector<Time>(2, kNone);  // [1] the root, [leaves_ + i] item i
  std::vector<std::uint8_t> pending_flag_;                // bytes: tested and set at every move
  std::vector<std::uint32_t> pending_;
  bool all_ = true;
  mutable std::vector<std::size_t> walk_;  // due()'s nodes still to look at
};

}  // namespace candp2
