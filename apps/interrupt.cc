#include "apps/interrupt.h"

#include <atomic>
#include <csignal>

#include <unistd.h>

#include "core/file_util.h"

namespace ieslam {
namespace {

// A signal handler can reach only globals; lock-free atomics are safe to use from one.
std::atomic<bool> g_stop_on_interrupt{false};
std::atomic<int> g_signal{0};  // the first SIGINT or SIGTERM under a StopOnInterrupt; 0: none
static_assert(std::atomic<int>::is_always_lock_free, "a signal handler needs a lock-free flag");

extern "C" void OnInterrupt(int signal) {
  // The first signal under a StopOnInterrupt asks the command to stop; any other ends it,
  // without the temp files of the writes it cuts short.
  int none = 0;
  if (g_stop_on_interrupt.load() && g_signal.compare_exchange_strong(none, signal)) return;
  RemoveTempFilesInProgress();
  _exit(128 + signal);  // async-signal-safe, unlike exit()
}

void InstallHandler() {
  struct sigaction action = {};
  action.sa_handler = OnInterrupt;
  sigemptyset(&action.sa_mask);
  sigaddset(&action.sa_mask, SIGINT);
  sigaddset(&action.sa_mask, SIGTERM);
  action.sa_flags = SA_RESTART;  // reads and writes in progress carry on
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

}  // namespace

void ExitOnInterrupt() {
  g_stop_on_interrupt.store(false);
  InstallHandler();
}

StopOnInterrupt::StopOnInterrupt() {
  g_signal.store(0);
  g_stop_on_interrupt.store(true);
  InstallHandler();
}

StopOnInterrupt::~StopOnInterrupt() { ExitOnInterrupt(); }

bool StopOnInterrupt::requested() const { return g_signal.load() != 0; }

int StopOnInterrupt::exit_code() const {
  const int signal = g_signal.load();
  return signal == 0 ? 0 : 128 + signal;
}

std::function<bool()> StopOnInterrupt::Poll() const {
  return [] { return g_signal.load() != 0; };
}

}  // namespace ieslam
