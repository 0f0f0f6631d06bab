// A bounded single-producer single-consumer queue without locks: one reader thread pushes, the
// writer thread pops. A full queue refuses the push (the caller counts the loss: back-pressure
// is never silent) instead of blocking the device reader, which would lose bytes in the OS.
#pragma once

#include <atomic>
#include <cassert>
#include <cstddef>
#include <vector>

namespace imukit::capture {

template <typename T>
class SpscQueue {
 public:
  // Capacity is rounded up to a power of two.
  explicit SpscQueue(std::size_t capacity) {
    std::size_t n = 1;
    while (n < capacity) n <<= 1;
    slots_.resize(n);
    mask_ = n - 1;
  }

  // Producer only. False when full.
  bool push(T&& value) {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_cache_ > mask_) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head - tail_cache_ > mask_) return false;
    }
    slots_[head & mask_] = std::move(value);
    head_.store(head + 1, std::memory_order_release);
    // Against the consumer's current position: tail_cache_ is refreshed only when the queue
    // looks full, so measured against it the depth would be every value pushed so far.
    const std::size_t depth = head + 1 - tail_.load(std::memory_order_relaxed);
    if (depth > high_water_.load(std::memory_order_relaxed)) {
      high_water_.store(depth, std::memory_order_relaxed);
    }
    return true;
  }

  // Consumer only. False when empty.
  bool pop(T& out) {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_cache_) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail == head_cache_) return false;
    }
    out = std::move(slots_[tail & mask_]);
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  // Consumer only: nothing to pop now (the producer may push right after).
  bool empty() const {
    return tail_.load(std::memory_order_relaxed) == head_.load(std::memory_order_acquire);
  }

  std::size_t capacity() const { return mask_ + 1; }
  // Deepest the queue has been, as the producer saw it after each push (the consumer may have
  // taken values meanwhile, so this can exceed the true depth by what it took since).
  std::size_t high_water() const { return high_water_.load(std::memory_order_relaxed); }

 private:
  std::vector<T> slots_;
  std::size_t mask_ = 0;
  alignas(64) std::atomic<std::size_t> head_{0};
  std::size_t tail_cache_ = 0;  // producer's copy of tail_
  alignas(64) std::atomic<std::size_t> tail_{0};
  std::size_t head_cache_ = 0;  // consumer's copy of head_
  alignas(64) std::atomic<std::size_t> high_water_{0};
};

}  // namespace imukit::capture
