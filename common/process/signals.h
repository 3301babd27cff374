#pragma once
// Signal handling of every rumi process, installed once by its main():
//  - SIGTERM / SIGINT: the first one sets the stop flag: the process stops
//    taking work, saves what it must and exits; a second one ends it at once
//    (the default action: every save is atomic, nothing half-written stays).
//  - SIGHUP: sets the reload flag: re-read the config and apply what can
//    change live (the log level).
//  - SIGUSR1: sets the finish flag: rumid's "the source ended": a back or a
//    manager run by rumid ends once its producers closed and its work is done
//    (without it they wait for a producer that may be restarted).
//  - SIGPIPE is ignored (a vanished socket peer is an error return, not death).
#include <atomic>
#include <functional>
#include <thread>

namespace rumi {

class ProcessSignals {
 public:
  // Idempotent. Handlers only store to lock-free atomics.
  static void Install();
  // The stop flag, for the Run* entries (set by the first SIGTERM/SIGINT).
  static const std::atomic<bool>* stop();
  // The signal that set the stop flag (0: none yet).
  static int stop_signal();
  // True once per SIGHUP received since the last call.
  static bool TakeReload();
  // The finish flag (set by SIGUSR1).
  static const std::atomic<bool>* finish();
};

// Calls on_reload (on its own thread) after each SIGHUP, until destroyed.
class ReloadOnHangup {
 public:
  explicit ReloadOnHangup(std::function<void()> on_reload);
  ~ReloadOnHangup();
  ReloadOnHangup(const ReloadOnHangup&) = delete;
  ReloadOnHangup& operator=(const ReloadOnHangup&) = delete;

 private:
  std::atomic<bool> quit_{false};
  std::thread thread_;
};

}  // namespace rumi
