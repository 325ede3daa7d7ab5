#pragma once
/// \file rt/spsc_ring.hpp
/// A lock-free single-producer single-consumer ring of trivially copyable values: the loop thread
/// pushes, one other thread pops (recording, state stream, commands into the loop). The storage is
/// allocated once in the constructor; push() and pop() are wait-free.

#include <atomic>
#include <cstddef>
#include <type_traits>
#include <vector>

#include "alphainv/error.hpp"

namespace alphainv::rt {

/// Bounded SPSC ring (see the file comment). Exactly one thread may call push(), exactly one
/// (other) thread pop(); size queries are approximate from either side.
template <class T>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<T>, "SpscRing holds trivially copyable values");

 public:
  /// Allocates room for `capacity` values (rounded up to a power of two, ≥ 2). Not real-time;
  /// throws alphainv::Error if capacity is 0 or above 2^30.
  explicit SpscRing(std::size_t capacity) {
    if (capacity == 0 || capacity > (std::size_t{1} << 30)) {
      throw Error("expected 1 ≤ capacity ≤ 2^30, got " + std::to_string(capacity), {}, 0,
                  "capacity");
    }
    std::size_t n = 2;
    while (n < capacity) n <<= 1;
    slots_.resize(n);
    mask_ = n - 1;
  }

  /// Appends `value`; false (and nothing changes) when full. Producer only.
  /// Real-time safe: no allocation, no locks, no I/O.
  [[nodiscard]] bool push(const T& value) noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) > mask_) return false;
    slots_[head & mask_] = value;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  /// Removes the oldest value into `out`; false when empty. Consumer only.
  /// Real-time safe: no allocation, no locks, no I/O.
  [[nodiscard]] bool pop(T& out) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return false;
    out = slots_[tail & mask_];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  /// Values in the ring now (approximate while the other side runs). Real-time safe.
  std::size_t size() const noexcept {
    return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_acquire);
  }
  /// Most values the ring holds. Real-time safe.
  std::size_t capacity() const noexcept { return mask_ + 1; }

 private:
  std::vector<T> slots_;
  std::size_t mask_ = 0;
  alignas(64) std::atomic<std::size_t> head_{0};  ///< next slot to write (producer)
  alignas(64) std::atomic<std::size_t> tail_{0};  ///< next slot to read (consumer)
};

}  // namespace alphainv::rt
