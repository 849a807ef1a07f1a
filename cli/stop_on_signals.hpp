// SIGINT and SIGTERM as a stop request for the lifetime of a command (simulate, sweep): the
// command finishes what is under way, keeps what it wrote and exits with 128 + the signal.
#pragma once

#include <atomic>
#include <csignal>

namespace spacearm::cli {

// The signal that asked to stop, or 0.
inline std::atomic<int>& stop_signal() {
  static std::atomic<int> signal{0};
  static_assert(std::atomic<int>::is_always_lock_free, "set from a signal handler");
  return signal;
}

// Handlers while an object lives; a signal the caller ignores (a background job's SIGINT)
// stays ignored.
class StopOnSignals {
 public:
  StopOnSignals() {
    stop_signal() = 0;
    struct sigaction sa {};
    sa.sa_handler = [](int sig) { stop_signal() = sig; };
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, nullptr, &old_int_);
    sigaction(SIGTERM, nullptr, &old_term_);
    if (old_int_.sa_handler != SIG_IGN) sigaction(SIGINT, &sa, nullptr);
    if (old_term_.sa_handler != SIG_IGN) sigaction(SIGTERM, &sa, nullptr);
  }
  ~StopOnSignals() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;

 private:
  struct sigaction old_int_ {
  }, old_term_{};
};

}  // namespace spacearm::cli
