#include "progress.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>

namespace geardyn::cli {
namespace {

std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int /*signal*/) { g_interrupted = true; }

}  // namespace

ProgressBar::ProgressBar(std::string label, std::string unit)
    : label_(std::move(label)), unit_(std::move(unit)), tty_(isatty(2) != 0) {}

void ProgressBar::show(double fraction, const std::string& detail) {
  using namespace std::chrono;
  const double elapsed = duration<double>(steady_clock::now() - start_).count();
  if (elapsed < kQuietSeconds) return;
  const int percent = static_cast<int>(fraction * 100.0);
  if (!tty_ && percent < last_percent_ + 10 && elapsed < last_line_s_ + kLogSeconds) return;
  last_percent_ = percent;
  last_line_s_ = elapsed;
  constexpr int kWidth = 30;
  const int filled = static_cast<int>(fraction * kWidth);
  const double left = fraction > 0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
  fmt::print(stderr, "{}{} [{:<{}}] {}, {:.1f} s left{}", tty_ ? "\r" : "", label_,
             std::string(std::clamp(filled, 0, kWidth), '#'), kWidth, detail, left,
             tty_ ? "" : "\n");
  std::fflush(stderr);
  shown_ = true;
}

bool ProgressBar::operator()(double fraction) {
  show(fraction, fmt::format("{:3d}%", static_cast<int>(fraction * 100.0)));
  return true;
}

bool ProgressBar::points(double done, std::size_t total) {
  show(done / static_cast<double>(std::max<std::size_t>(total, 1)),
       fmt::format("{:.1f}/{} {}", done, total, unit_));
  return true;
}

bool ProgressBar::operator()(std::size_t done, std::size_t total) {
  show(static_cast<double>(done) / static_cast<double>(std::max<std::size_t>(total, 1)),
       fmt::format("{}/{} {}", done, total, unit_));
  return true;
}

void ProgressBar::finish() {
  if (shown_ && tty_) fmt::print(stderr, "\n");
  shown_ = false;
}

InterruptWatch::InterruptWatch() {
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
}

InterruptWatch::~InterruptWatch() {
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
}

bool interrupted() { return g_interrupted.load(); }

}  // namespace geardyn::cli
