#include "geardyn/parallel.hpp"

#include <algorithm>
#include <exception>
#include <thread>
#include <vector>

namespace geardyn {

bool WorkTicker::tick() {
  if (!progress_) {
    ++done_;
    return !stop_;
  }
  // The count is taken under the lock that orders the calls, so the callback hears the
  // counts in increasing order and its last call is the total.
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!progress_(++done_, total_)) stop_ = true;
  return !stop_;
}

ParallelRun parallel_for(std::size_t jobs, unsigned threads, std::size_t total_units,
                         const WorkTicker::Progress& progress,
                         const std::function<void(std::size_t, WorkTicker&)>& job) {
  ParallelRun out;
  if (threads == 0) threads = std::max(1U, std::thread::hardware_concurrency());
  threads = static_cast<unsigned>(std::min<std::size_t>(threads, std::max<std::size_t>(jobs, 1)));
  out.threads = threads;
  WorkTicker ticker(total_units, progress);
  std::atomic<std::size_t> next{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  const auto worker = [&] {
    for (std::size_t i = next++; i < jobs && !ticker.stopped(); i = next++) {
      try {
        job(i, ticker);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(failure_mutex);
        if (!failure) failure = std::current_exception();
        ticker.stop();
        return;
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(threads);
  for (unsigned t = 0; t < threads; ++t) pool.emplace_back(worker);
  for (std::thread& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
  out.stopped = ticker.stopped();
  return out;
}

}  // namespace geardyn
