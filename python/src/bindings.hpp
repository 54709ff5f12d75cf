// The Python bindings: one bind_<area>.cpp per library area, registered by module.cpp.
#pragma once

#include <pybind11/pybind11.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>

namespace geardyn::python {

// Long work from Python: run_interruptible runs it on a thread of its own, without the GIL,
// while the calling thread watches for Ctrl-C every kSignalPollSeconds (Python runs signal
// handlers on the main thread only). The work's progress calls go through the Hook, which
// calls the user's `progress` (when not None) with the GIL and says stop once Ctrl-C came, the
// callback returned a false value or raised.
constexpr double kSignalPollSeconds = 0.05;

class Hook {
 public:
  explicit Hook(pybind11::object progress) : progress_(std::move(progress)) {}
  // Called from the work's thread, without the GIL; true to go on.
  template <class... A>
  bool operator()(A... args) {
    if (stop_) return false;
    if (progress_.is_none()) return true;
    const pybind11::gil_scoped_acquire gil;
    try {
      const pybind11::object r = progress_(args...);
      if (!r.is_none() && !r.cast<bool>()) stop_ = true;
    } catch (pybind11::error_already_set& e) {
      // Ctrl-C inside the callback stops like Ctrl-C elsewhere; another error stops the work
      // and is raised once it has returned.
      if (e.matches(PyExc_KeyboardInterrupt)) {
        interrupted_ = true;
      } else {
        error_ = std::make_unique<pybind11::error_already_set>(std::move(e));
      }
      stop_ = true;
    }
    return !stop_;
  }
  // False once the callback stopped the work or Ctrl-C came.
  bool going() const { return !stop_; }
  void interrupt() {
    interrupted_ = true;
    stop_ = true;
  }
  bool interrupted() const { return interrupted_; }
  // Raises the callback's error, if it failed (with the GIL held).
  void rethrow() {
    if (error_) throw pybind11::error_already_set(std::move(*error_));
  }

 private:
  pybind11::object progress_;
  std::atomic<bool> stop_{false}, interrupted_{false};
  std::unique_ptr<pybind11::error_already_set> error_;
};

// Runs work() (which takes no Python objects) on its own thread; called with the GIL held.
// Rethrows what work() threw, then the callback's error.
template <class F>
void run_interruptible(Hook& hook, F&& work) {
  std::mutex m;
  std::condition_variable cv;
  bool done = false;
  std::exception_ptr failure;
  std::thread worker([&] {
    try {
      work();
    } catch (...) {
      failure = std::current_exception();
    }
    const std::lock_guard<std::mutex> lock(m);
    done = true;
    cv.notify_all();
  });
  for (;;) {
    {
      const pybind11::gil_scoped_release release;
      std::unique_lock<std::mutex> lock(m);
      cv.wait_for(lock, std::chrono::duration<double>(kSignalPollSeconds), [&] { return done; });
      if (done) break;
    }
    if (PyErr_CheckSignals() != 0) {
      PyErr_Clear();
      hook.interrupt();
    }
  }
  worker.join();
  // A Ctrl-C that came as the work ended is the work's too: otherwise Python would raise it
  // at its next line, without the result.
  if (PyErr_CheckSignals() != 0) {
    PyErr_Clear();
    hook.interrupt();
  }
  if (failure) std::rethrow_exception(failure);
  hook.rethrow();
}

// A run whose options carry a progress callback (the coupled model's, a train's) from Python:
// run(c, options) without the GIL as run_interruptible does, then read(result) gives its
// (summary.json text, arrays); returns (text, arrays, whether Ctrl-C interrupted it).
template <class Options, class CaseT, class Run, class Read>
pybind11::tuple run_from_python(const CaseT& c, const pybind11::object& progress, const Run& run,
                                const Read& read) {
  Hook hook(progress);
  Options o;
  o.progress = [&hook](double fraction) { return hook(fraction); };
  decltype(run(c, o)) r;
  run_interruptible(hook, [&] { r = run(c, o); });
  const pybind11::tuple out = read(r);
  return pybind11::make_tuple(out[0], out[1], hook.interrupted());
}

void bind_case(pybind11::module_& m);
void bind_geometry(pybind11::module_& m);
void bind_stiffness(pybind11::module_& m);
void bind_run(pybind11::module_& m);
void bind_sweep(pybind11::module_& m);
void bind_orbit(pybind11::module_& m);
void bind_train(pybind11::module_& m);
void bind_validation(pybind11::module_& m);
void bind_study(pybind11::module_& m);

}  // namespace geardyn::python
