// SIGINT, SIGTERM and SIGHUP (a closed terminal or SSH session) as a stop request for the
// lifetime of a command (simulate, sweep): the command finishes what is under way, keeps what it
// wrote and exits with 128 + the signal.
#pragma once

#include <atomic>
#include <csignal>
#include <string>

namespace spacearm::cli {

// The signal that asked to stop, or 0.
inline std::atomic<int>& stop_signal() {
  static std::atomic<int> signal{0};
  static_assert(std::atomic<int>::is_always_lock_free, "set from a signal handler");
  return signal;
}

// The stop signals, and their names for messages.
constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP};
inline std::string signal_name(int sig) {
  return sig == SIGINT    ? "SIGINT"
         : sig == SIGTERM ? "SIGTERM"
         : sig == SIGHUP  ? "SIGHUP"
                          : "a signal";
}

// Handlers while an object lives; a signal the caller ignores (a background job's SIGINT,
// nohup's SIGHUP) stays ignored.
class StopOnSignals {
 public:
  StopOnSignals() {
    stop_signal() = 0;
    struct sigaction sa {};
    sa.sa_handler = [](int sig) { stop_signal() = sig; };
    sigemptyset(&sa.sa_mask);
    for (int k = 0; k < kCount; ++k) {
      sigaction(kStopSignals[k], nullptr, &old_[k]);
      if (old_[k].sa_handler != SIG_IGN) sigaction(kStopSignals[k], &sa, nullptr);
    }
  }
  ~StopOnSignals() {
    for (int k = 0; k < kCount; ++k) sigaction(kStopSignals[k], &old_[k], nullptr);
  }
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;

 private:
  static constexpr int kCount = sizeof kStopSignals / sizeof kStopSignals[0];
  struct sigaction old_[kCount] {};
};

}  // namespace spacearm::cli
