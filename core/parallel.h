// A minimal parallel loop for independent per-frame work (decoding,
// detection, overlays). Results must be stored per index by the body, so
// the outcome does not depend on the number of threads or their timing.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace oslam {

// The thread count for `requested` (0 = one per core), at most `work` items.
inline int ThreadCount(int requested, size_t work) {
  int threads = requested > 0 ? requested
                              : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return static_cast<int>(std::max<size_t>(1, std::min<size_t>(threads, work)));
}

// Calls body(i) for i in [begin, end) on up to `threads` threads (the
// caller's included). When bodies throw, the exception of the lowest
// failing index is rethrown here, the same one whatever the timing: indices
// are handed out in order, so every index below a failing one has started
// and is finished; indices above it are not started.
template <typename Body>
void ParallelFor(size_t begin, size_t end, int threads, const Body& body) {
  if (end <= begin) return;
  const int count = ThreadCount(threads, end - begin);
  std::atomic<size_t> next{begin};
  std::atomic<size_t> first_failure{end};
  std::vector<std::exception_ptr> errors(end - begin);
  auto work = [&] {
    for (size_t i = next++; i < end && i < first_failure; i = next++) {
      try {
        body(i);
      } catch (...) {
        errors[i - begin] = std::current_exception();
        size_t seen = first_failure;
        while (i < seen && !first_failure.compare_exchange_weak(seen, i)) {
        }
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < count; ++t) pool.emplace_back(work);
  work();
  for (std::thread& thread : pool) thread.join();
  for (const std::exception_ptr& error : errors)
    if (error) std::rethrow_exception(error);
}

}  // namespace oslam
