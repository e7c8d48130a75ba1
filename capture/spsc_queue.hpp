// A bounded lock-free queue of byte records between exactly one producer thread (the event loop)
// and one consumer thread (the capture writer): the producer never blocks and never allocates —
// a record that does not fit is refused, and the caller counts it as dropped (docs/decisions.md
// "pcapng captures"). Records are stored as a 4-byte length and the bytes, wrapping around a
// power-of-two ring. Only capture/ uses it: it is I/O plumbing, not protocol code.
#pragma once

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <span>
#include <vector>

namespace candp2::capture {

class SpscByteQueue {
 public:
  // Capacity rounded up to a power of two (at least 64 bytes).
  explicit SpscByteQueue(std::size_t capacity)
      : buf_(std::bit_ceil(capacity < 64 ? std::size_t{64} : capacity)), mask_(buf_.size() - 1) {}

  std::size_t capacity() const { return buf_.size(); }

  // Producer: appends one record made of `parts` (concatenated). False when it does not fit now.
  bool try_push(std::initializer_list<std::span<const std::uint8_t>> parts) {
    std::size_t len = 0;
    for (auto p : parts) len += p.size();
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    const std::uint64_t tail = tail_.load(std::memory_order_acquire);
    if (len > UINT32_MAX || head - tail + sizeof(std::uint32_t) + len > buf_.size()) return false;
    const auto n = static_cast<std::uint32_t>(len);
    std::uint8_t hdr[sizeof n];
    std::memcpy(hdr, &n, sizeof n);
    std::uint64_t at = head;
    copy_in(at, std::span<const std::uint8_t>(hdr, sizeof hdr));
    at += sizeof hdr;
    for (auto p : parts) {
      copy_in(at, p);
      at += p.size();
    }
    head_.store(at, std::memory_order_release);
    return true;
  }

  // Consumer: moves the oldest record into `out` (replacing its contents). False when empty.
  bool try_pop(std::vector<std::uint8_t>& out) {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    const std::uint64_t head = head_.load(std::memory_order_acquire);
    if (head == tail) return false;
    std::uint8_t hdr[sizeof(std::uint32_t)];
    copy_out(tail, hdr, sizeof hdr);
    std::uint32_t n = 0;
    std::memcpy(&n, hdr, sizeof n);
    out.resize(n);
    copy_out(tail + sizeof hdr, out.data(), n);
    tail_.store(tail + sizeof hdr + n, std::memory_order_release);
    return true;
  }

  bool empty() const {
    return head_.load(std::memory_order_acquire) == tail_.load(std::memory_order_acquire);
  }

 private:
  void copy_in(std::uint64_t at, std::span<const std::uint8_t> bytes) {
    if (bytes.empty()) return;
    const std::size_t pos = at & mask_;
    const std::size_t first = std::min(bytes.size(), buf_.size() - pos);
    std::memcpy(buf_.data() + pos, bytes.data(), first);
    std::memcpy(buf_.data(), bytes.data() + first, bytes.size() - first);
  }
  void copy_out(std::uint64_t at, std::uint8_t* dst, std::size_t n) const {
    if (n == 0) return;
    const std::size_t pos = at & mask_;
    const std::size_t first = std::min(n, buf_.size() - pos);
    std::memcpy(dst, buf_.data() + pos, first);
    std::memcpy(dst + first, buf_.data(), n - first);
  }

  std::vector<std::uint8_t> buf_;
  std::size_t mask_;
  // Bytes ever written / read; the difference is what the ring holds. Each on its own cache line.
  alignas(64) std::atomic<std::uint64_t> head_{0};
  alignas(64) std::atomic<std::uint64_t> tail_{0};
};

}  // namespace candp2::capture
