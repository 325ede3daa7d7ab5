#pragma once
/// \file parallel_for.hpp
/// Private plumbing (src/common, not installed): the one thread pool of alphainv, used where
/// independent simulations run side by side (validation runs, output-error Jacobians, diagnose's
/// candidates). Not real-time safe (starts threads, allocates).

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <functional>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

namespace alphainv::common {

/// How many threads run `jobs` jobs: `requested`, or one per hardware thread when 0; never more
/// than the jobs and at least 1.
inline unsigned thread_count(unsigned requested, std::size_t jobs) {
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  const unsigned n = requested ? requested : hw;
  return std::max(1u, std::min<unsigned>(n, static_cast<unsigned>(std::max<std::size_t>(jobs, 1))));
}

/// Runs f(i) once for every i in [0, n) on thread_count(threads, n) threads, the calling thread
/// one of them. Indices are handed out in increasing order to whichever thread is free, so the
/// thread that runs a given i varies; results are reproducible when f(i) writes only its own
/// slot (no reduction across jobs in here). Returns when every job has finished.
///
/// Exceptions: the first one a job throws is rethrown here once all threads have stopped; jobs
/// not yet started are then skipped. If a thread cannot be started, the jobs run on fewer.
inline void parallel_for(std::size_t n, unsigned threads,
                         const std::function<void(std::size_t)>& f) {
  std::atomic<std::size_t> next{0};
  std::mutex error_mutex;
  std::exception_ptr first_error;
  auto worker = [&]() noexcept {
    for (std::size_t i = next++; i < n; i = next++) {
      try {
        f(i);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(error_mutex);
        if (!first_error) first_error = std::current_exception();
        next = n;  // start no further jobs
      }
    }
  };
  const unsigned t = thread_count(threads, n);
  std::vector<std::thread> pool;
  pool.reserve(t - 1);
  for (unsigned k = 1; k < t; ++k) {
    try {
      pool.emplace_back(worker);
    } catch (const std::system_error&) {
      break;  // no more threads: the ones running take the remaining jobs
    }
  }
  worker();
  for (auto& th : pool) th.join();
  if (first_error) std::rethrow_exception(first_error);
}

}  // namespace alphainv::common
