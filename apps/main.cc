// ieslam: one binary, one subcommand per job (../shared/CLI.md is the interface).
#include <malloc.h>

#include <exception>
#include <iostream>
#include <string>

#include "apps/commands.h"
#include "apps/interrupt.h"
#include "core/error.h"

namespace ieslam {
namespace {

void PrintUsage(std::ostream& out) {
  out << "ieslam: information-efficient 3-D visual SLAM with a camera and a range imager\n"
         "(Zhou, Valls Miro & Dissanayake, IEEE T-RO 2008).\n\n"
         "Usage: ieslam <command> [flags]      ieslam <command> --help\n\nCommands:\n";
  for (const Command& command : Commands()) {
    std::string name = command.name;
    name.resize(10, ' ');
    out << "  " << name << command.summary;
    if (command.run == nullptr) out << "  [not built yet: " << command.status << "]";
    out << "\n";
  }
  out << "\nExit codes: 0 success, 2 bad usage or config, 3 bad input data, 130 interrupted.\n";
}

int Main(int argc, char** argv) {
  if (argc < 2) {
    PrintUsage(std::cerr);
    return 2;
  }
  const std::string name = argv[1];
  if (name == "--help" || name == "-h" || name == "help") {
    PrintUsage(std::cout);
    return 0;
  }
  if (name == "--version") {
    std::cout << "ieslam " << IESLAM_VERSION << "\n";
    return 0;
  }
  for (const Command& command : Commands()) {
    if (name != command.name) continue;
    if (command.run == nullptr) {
      std::cerr << "ieslam " << name << ": not built yet (" << command.status << ")\n";
      return 2;
    }
    try {
      ExitOnInterrupt();
      return command.run(CommandArgs(argv + 2, argv + argc));
    } catch (const ConfigError& e) {
      std::cerr << "ieslam " << name << ": " << e.what() << "\n";
      return 2;
    } catch (const DataError& e) {
      std::cerr << "ieslam " << name << ": " << e.what() << "\n";
      return 3;
    }
  }
  std::cerr << "ieslam: unknown command '" << name << "'\n\n";
  PrintUsage(std::cerr);
  return 2;
}

}  // namespace
}  // namespace ieslam

int main(int argc, char** argv) {
  // glibc's allocator gave SIFT's scale-space buffers (1-5 MB each, several per frame) back
  // to the kernel after every frame, unmapping them or trimming the heap, and took them again
  // page by page: on 7scenes-dev (500 frames) 1.7 M page faults and ~5 s of system time, a
  // fifth of the run's CPU. Served from the heap and kept there: 62 k faults, 0.3 s of system
  // time, 40 MB more peak memory. (32 MB is the largest mmap threshold glibc accepts.)
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  try {
    return ieslam::Main(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "ieslam: internal error: " << e.what() << "\n";
    return 1;
  }
}
