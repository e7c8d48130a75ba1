// A first-in first-out queue in one array that grows to the most it held (a power of two long)
// and then never allocates again: the CAN queues that take a frame at every send and every
// delivery (docs/can-bus.md "Performance": a std::deque walks and allocates its blocks).
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace candp2 {

template <class T>
class Ring {
 public:
  bool empty() const { return size_ == 0; }
  std::size_t size() const { return size_; }
  const T& front() const { return items_[head_]; }
  void push_back(const T& item) { push_back_slot() = item; }
  // A new last item to be filled in place (an item built whole and copied in is read back in
  // parts, a stall: docs/can-bus.md "Performance").
  T& push_back_slot() {
    if (size_ == items_.size()) grow();
    return items_[(head_ + size_++) & mask_];
  }
  void pop_front() {
    head_ = (head_ + 1) & mask_;
    --size_;
  }
  void clear() { head_ = size_ = 0; }

 private:
  // Full: twice as long, the items in order from 0. Out of line: push_back() is inlined where a
  // frame is queued (docs/can-bus.md "Performance").
  [[gnu::noinline]] void grow() {
    std::vector<T> grown(std::max<std::size_t>(8, 2 * items_.size()));
    for (std::size_t i = 0; i < size_; ++i) grown[i] = items_[(head_ + i) & mask_];
    items_.swap(grown);
    mask_ = items_.size() - 1;
    head_ = 0;
  }
  std::vector<T> items_;
  std::size_t mask_ = 0;  // items_.size() - 1 once it has items (kept: a division otherwise)
  std::size_t head_ = 0, size_ = 0;
};

}  // namespace candp2
