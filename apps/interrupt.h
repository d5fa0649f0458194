// Ctrl-C (SIGINT) and SIGTERM (what batch schedulers send) for every subcommand: exit code
// 128 + the signal (130 for SIGINT, 143 for SIGTERM), and the outputs of what was processed
// still written.
//
// By default (ExitOnInterrupt, installed by main) either signal ends the process at once: the
// command has nothing partial worth writing; outputs are written atomically (temp file +
// rename), and the temp files of the writes in progress are removed, so none is left
// half-written or behind.
// A command that can stop early and still write what it has done (run, simulate, register,
// synth) holds a StopOnInterrupt while it works: the first signal then only sets a flag that
// the command polls between frames, pairs or rows (and run in its refinement and map); a
// second one ends the process at once as above, for a user who does not want to wait.
#pragma once

#include <functional>

namespace ieslam {

// Installs the default: SIGINT and SIGTERM exit with code 128 + the signal.
void ExitOnInterrupt();

class StopOnInterrupt {
 public:
  StopOnInterrupt();
  ~StopOnInterrupt();  // back to ExitOnInterrupt
  StopOnInterrupt(const StopOnInterrupt&) = delete;
  StopOnInterrupt& operator=(const StopOnInterrupt&) = delete;

  // True once SIGINT or SIGTERM has arrived.
  bool requested() const;
  // 128 + the signal that arrived first (130 SIGINT, 143 SIGTERM); 0 before one arrived.
  int exit_code() const;
  // requested() as the polled callback the libraries take.
  std::function<bool()> Poll() const;
};

}  // namespace ieslam
