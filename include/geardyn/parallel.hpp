// geardyn: the one thread pool, for the independent pieces of sweeps, maps and studies.
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <mutex>

namespace geardyn {

// What a job sees of the work it is part of: the count of units done and whether to stop.
class WorkTicker {
 public:
  using Progress = std::function<bool(std::size_t done, std::size_t total)>;
  WorkTicker(std::size_t total_units, const Progress& progress)
      : total_(total_units), progress_(progress) {}

  // One unit of work done: counted, and reported to the progress callback (one call at a
  // time, the counts in increasing order). Returns false once the work is to stop.
  bool tick();
  // True once the progress callback returned false or a job threw: start no further unit.
  bool stopped() const { return stop_.load(); }
  void stop() { stop_ = true; }

 private:
  std::size_t total_;
  const Progress& progress_;
  std::atomic<std::size_t> done_{0};
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
};

struct ParallelRun {
  unsigned threads = 0;  // threads used
  bool stopped = false;  // the progress callback stopped the work
};

// Runs job(i, ticker) for every i in [0, jobs) on up to `threads` threads (0: all cores; never
// more threads than jobs), each index once, in any order. Jobs count their units of work with
// ticker.tick() (total_units in all) and `progress(done, total_units)` hears of each, one call
// at a time; a false return stops the work (jobs see ticker.stopped()). The first exception a
// job throws stops the others and is rethrown once all threads have ended.
ParallelRun parallel_for(std::size_t jobs, unsigned threads, std::size_t total_units,
                         const WorkTicker::Progress& progress,
                         const std::function<void(std::size_t, WorkTicker&)>& job);

}  // namespace geardyn
