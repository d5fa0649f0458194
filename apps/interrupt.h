// Ctrl-C for every subcommand: exit code 130, and the outputs of what was processed still
// written.
//
// By default (ExitOnInterrupt, installed by main) SIGINT ends the process at once with exit
// code 130: the command has nothing partial worth writing, and as outputs are written
// atomically (temp file + rename) none is left half-written.
// A command that can stop early and still write what it has done (run, simulate, register,
// synth) holds a StopOnInterrupt while it works: the first SIGINT then only sets a flag that
// the command polls between frames, pairs or rows; a second one ends the process at once as
// above, for a user who does not want to wait.
#pragma once

#include <functional>

namespace ieslam {

// Installs the default: SIGINT exits with code 130.
void ExitOnInterrupt();

class StopOnInterrupt {
 public:
  StopOnInterrupt();
  ~StopOnInterrupt();  // back to ExitOnInterrupt
  StopOnInterrupt(const StopOnInterrupt&) = delete;
  StopOnInterrupt& operator=(const StopOnInterrupt&) = delete;

  // True once SIGINT has arrived.
  bool requested() const;
  // requested() as the polled callback the libraries take.
  std::function<bool()> Poll() const;
};

}  // namespace ieslam
