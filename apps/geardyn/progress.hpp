// The command line's progress display and its Ctrl-C: what every long command shows while it
// works, and how it stops where it is without losing what was done.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace geardyn::cli {

// The one progress display of the command line: a bar on stderr once the work has taken more
// than a second, redrawn in place on a terminal and in a log a line per 10 %, or after 10 s
// without one (a continuation that snakes about one value of its key does not advance).
class ProgressBar {
 public:
  explicit ProgressBar(std::string label, std::string unit = "");
  ~ProgressBar() { finish(); }
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;
  ProgressBar(ProgressBar&&) = delete;
  ProgressBar& operator=(ProgressBar&&) = delete;

  // `fraction` done in [0, 1], with what to show beside the bar.
  void show(double fraction, const std::string& detail);
  // The fraction as a percentage; true (go on).
  bool operator()(double fraction);
  // `done` of `total` points, a share of each point under way included; true.
  bool points(double done, std::size_t total);
  // `done` of `total` whole items; true.
  bool operator()(std::size_t done, std::size_t total);
  // Ends the bar's line (on a terminal); the next output starts on its own line.
  void finish();

 private:
  static constexpr double kQuietSeconds = 1.0;
  static constexpr double kLogSeconds = 10.0;
  std::string label_, unit_;
  bool tty_;
  bool shown_ = false;
  int last_percent_ = -10;
  double last_line_s_ = 0;  // when the log's last line was printed, s from the start
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

// While one lives, Ctrl-C (SIGINT) and a polite kill (SIGTERM) set interrupted() instead of
// ending the process: the work under way polls it through its progress callback and stops where
// it is, its part kept. Its destructor puts the default handlers back.
class InterruptWatch {
 public:
  InterruptWatch();
  ~InterruptWatch();
  InterruptWatch(const InterruptWatch&) = delete;
  InterruptWatch& operator=(const InterruptWatch&) = delete;
  InterruptWatch(InterruptWatch&&) = delete;
  InterruptWatch& operator=(InterruptWatch&&) = delete;
};

// True once Ctrl-C or SIGTERM arrived under an InterruptWatch.
bool interrupted();

// Runs `work` under an InterruptWatch and then ends `bar`'s line: a long command's study, which
// polls interrupted() through its progress callback. Returns what `work` returns.
template <class Work>
auto interruptible(ProgressBar& bar, Work&& work) {
  auto result = [&] {
    const InterruptWatch watch;
    return work();
  }();
  bar.finish();
  return result;
}

}  // namespace geardyn::cli
