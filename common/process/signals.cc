#include "common/process/signals.h"

#include <signal.h>

#include <chrono>

namespace rumi {
namespace {

std::atomic<bool> g_stop{false};
std::atomic<int> g_stop_signal{0};
std::atomic<bool> g_reload{false};
std::atomic<bool> g_finish{false};
std::atomic<bool> g_installed{false};

void OnStop(int sig) {
  if (g_stop.exchange(true)) {
    // Second request: the user means it. Default action, now.
    ::signal(sig, SIG_DFL);
    ::raise(sig);
    return;
  }
  g_stop_signal.store(sig);
}

void OnHangup(int) { g_reload.store(true); }

void OnFinish(int) { g_finish.store(true); }

}  // namespace

void ProcessSignals::Install() {
  if (g_installed.exchange(true)) return;
  struct sigaction sa {};
  sigemptyset(&sa.sa_mask);
  sa.sa_handler = OnStop;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  sa.sa_handler = OnHangup;
  sigaction(SIGHUP, &sa, nullptr);
  sa.sa_handler = OnFinish;
  sigaction(SIGUSR1, &sa, nullptr);
  sa.sa_handler = SIG_IGN;
  sigaction(SIGPIPE, &sa, nullptr);
}

const std::atomic<bool>* ProcessSignals::stop() { return &g_stop; }

int ProcessSignals::stop_signal() { return g_stop_signal.load(); }

bool ProcessSignals::TakeReload() { return g_reload.exchange(false); }

const std::atomic<bool>* ProcessSignals::finish() { return &g_finish; }

ReloadOnHangup::ReloadOnHangup(std::function<void()> on_reload)
    : thread_([this, f = std::move(on_reload)] {
        while (!quit_.load()) {
          if (ProcessSignals::TakeReload()) f();
          std::this_thread::sleep_for(std::chrono::milliseconds(200));
        }
      }) {}

ReloadOnHangup::~ReloadOnHangup() {
  quit_.store(true);
  thread_.join();
}

}  // namespace rumi
