// One parallel-for for the library's data-parallel loops (scene batches, PPDA windows, Allan
// variance tasks), so that each does not hand-roll a thread pool, and none loses an exception.
// Internal header: not part of the installed interface.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace imukit {

// Threads for n items: `threads` (0 = std::thread::hardware_concurrency()), at most n, at least 1.
inline unsigned thread_count(unsigned threads, std::size_t n) {
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  if (n < threads) threads = static_cast<unsigned>(std::max<std::size_t>(n, 1));
  return threads;
}

// Calls body(item, worker) for every item in [0, n) on thread_count(threads, n) threads, the
// caller being worker 0 (worker < thread_count, so per-worker scratch can be indexed by it).
// Items are handed out in increasing order from a shared counter. After an exception no further
// item starts; once every worker has stopped, the exception of the lowest item that threw is
// rethrown. Every item below it was started (items are handed out in order) and runs to its end,
// so which exception wins does not depend on timing or the thread count. Output must go to
// per-item slots, so that it does not depend on the thread count either.
template <class Body>
void parallel_for(std::size_t n, unsigned threads, Body&& body) {
  if (n == 0) return;
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex error_mutex;
  std::size_t error_item = n;
  std::exception_ptr error;
  const auto worker = [&](unsigned w) {
    while (!failed.load(std::memory_order_acquire)) {
      const std::size_t item = next.fetch_add(1);
      if (item >= n) return;
      try {
        body(item, w);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(error_mutex);
        if (item < error_item) {
          error_item = item;
          error = std::current_exception();
        }
        failed.store(true, std::memory_order_release);
      }
    }
  };
  const unsigned count = thread_count(threads, n);
  {
    std::vector<std::jthread> pool;  // joined when the block ends, also when a spawn throws
    pool.reserve(count - 1);
    for (unsigned w = 1; w < count; ++w) pool.emplace_back(worker, w);
    worker(0);
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace imukit
