#include "apps/interrupt.h"

#include <atomic>
#include <csignal>

#include <unistd.h>

namespace ieslam {
namespace {

// A signal handler can reach only globals; lock-free atomics are safe to use from one.
std::atomic<bool> g_stop_on_interrupt{false};
std::atomic<bool> g_interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free, "a signal handler needs a lock-free flag");

extern "C" void OnInterrupt(int) {
  // The first SIGINT under a StopOnInterrupt asks the command to stop; any other ends it.
  if (g_stop_on_interrupt.load() && !g_interrupted.exchange(true)) return;
  _exit(130);  // async-signal-safe, unlike exit()
}

void InstallHandler() {
  struct sigaction action = {};
  action.sa_handler = OnInterrupt;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;  // reads and writes in progress carry on
  sigaction(SIGINT, &action, nullptr);
}

}  // namespace

void ExitOnInterrupt() {
  g_stop_on_interrupt.store(false);
  InstallHandler();
}

StopOnInterrupt::StopOnInterrupt() {
  g_interrupted.store(false);
  g_stop_on_interrupt.store(true);
  InstallHandler();
}

StopOnInterrupt::~StopOnInterrupt() { ExitOnInterrupt(); }

bool StopOnInterrupt::requested() const { return g_interrupted.load(); }

std::function<bool()> StopOnInterrupt::Poll() const {
  return [] { return g_interrupted.load(); };
}

}  // namespace ieslam
