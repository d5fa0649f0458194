#include "apps/interrupt.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

namespace ieslam {
namespace {

// Runs `body` in a child process and returns its exit code (-1 if it did not exit normally).
template <typename Body>
int ExitCodeOf(Body body) {
  const pid_t child = fork();
  if (child == 0) {
    body();
    _exit(0);
  }
  int status = 0;
  waitpid(child, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(InterruptTest, TheFirstSigintUnderStopOnInterruptOnlySetsTheFlag) {
  EXPECT_EQ(ExitCodeOf([] {
              ExitOnInterrupt();
              const StopOnInterrupt interrupt;
              const auto poll = interrupt.Poll();
              if (interrupt.requested() || poll()) _exit(1);
              raise(SIGINT);
              if (!interrupt.requested() || !poll()) _exit(2);
            }),
            0);
}

TEST(InterruptTest, ASecondSigintOrOneWithoutStopOnInterruptExits130) {
  EXPECT_EQ(ExitCodeOf([] {
              ExitOnInterrupt();
              raise(SIGINT);
              _exit(1);  // not reached
            }),
            130);
  EXPECT_EQ(ExitCodeOf([] {
              ExitOnInterrupt();
              const StopOnInterrupt interrupt;
              raise(SIGINT);
              raise(SIGINT);
              _exit(1);
            }),
            130);
  // Once the command's StopOnInterrupt is gone, Ctrl-C exits again.
  EXPECT_EQ(ExitCodeOf([] {
              ExitOnInterrupt();
              { const StopOnInterrupt interrupt; }
              raise(SIGINT);
              _exit(1);
            }),
            130);
}

// A new StopOnInterrupt starts unrequested, whatever an earlier one saw.
TEST(InterruptTest, EachStopOnInterruptStartsClear) {
  EXPECT_EQ(ExitCodeOf([] {
              ExitOnInterrupt();
              {
                const StopOnInterrupt first;
                raise(SIGINT);
              }
              const StopOnInterrupt second;
              if (second.requested()) _exit(1);
            }),
            0);
}

// SIGTERM (batch schedulers) is handled as SIGINT, with its own exit code.
TEST(InterruptTest, SigtermIsHandledAsSigintWithExitCode143) {
  EXPECT_EQ(ExitCodeOf([] {
              ExitOnInterrupt();
              const StopOnInterrupt interrupt;
              if (interrupt.exit_code() != 0) _exit(1);
              raise(SIGTERM);
              if (!interrupt.requested() || interrupt.exit_code() != 143) _exit(2);
              raise(SIGINT);  // the second signal, whichever it is, exits
              _exit(3);
            }),
            130);
  EXPECT_EQ(ExitCodeOf([] {
              ExitOnInterrupt();
              raise(SIGTERM);
              _exit(1);
            }),
            143);
}

}  // namespace
}  // namespace ieslam
