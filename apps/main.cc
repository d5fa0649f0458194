// ieslam: one binary, one subcommand per job.
#include <malloc.h>

#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iostream>
#include <string>

#include "apps/commands.h"
#include "apps/interrupt.h"
#include "core/data_directory.h"
#include "core/error.h"
#include "core/version.h"

namespace ieslam {
namespace {

void PrintUsage(std::ostream& out) {
  out << "ieslam: information-efficient 3-D visual SLAM with a camera and a range imager\n"
         "(Zhou, Valls Miro & Dissanayake, IEEE T-RO 2008).\n\n"
         "Usage: ieslam <command> [flags]      ieslam <command> --help\n\nCommands:\n";
  for (const Command& command : Commands()) {
    std::string name = command.name;
    name.resize(10, ' ');
    out << "  " << name << command.summary << "\n";
  }
  out << "\nExit codes: 0 success, 2 bad usage or config, 3 bad input data, 4 output not\n"
         "writable, 130 interrupted (143 for SIGTERM).\n";
}

// The shipped data is searched for in $IESLAM_DATA_DIR, then beside the executable as
// `cmake --install` lays it out, then in the source tree (core/data_directory.h).
void FindShippedData() {
  std::error_code ec;
  const std::filesystem::path executable = std::filesystem::read_symlink("/proc/self/exe", ec);
  SetDataDirectoryCandidates(
      DataDirectoryCandidates(std::getenv("IESLAM_DATA_DIR"), ec ? "" : executable.string()));
}

int Main(int argc, char** argv) {
  FindShippedData();
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
    std::cout << "ieslam " << IeslamVersion() << "\n";
    return 0;
  }
  for (const Command& command : Commands()) {
    if (name != command.name) continue;
    try {
      ExitOnInterrupt();
      return command.run(CommandArgs(argv + 2, argv + argc));
    } catch (const ConfigError& e) {
      std::cerr << "ieslam " << name << ": " << e.what() << "\n";
      return 2;
    } catch (const DataError& e) {
      std::cerr << "ieslam " << name << ": " << e.what() << "\n";
      return 3;
    } catch (const OutputError& e) {
      std::cerr << "ieslam " << name << ": " << e.what() << "\n";
      return 4;
    }
  }
  std::cerr << "ieslam: unknown command '" << name << "'\n\n";
  PrintUsage(std::cerr);
  return 2;
}

}  // namespace
}  // namespace ieslam

int main(int argc, char** argv) {
  // SIFT's scale-space buffers (megabytes each, several per frame) are kept on the heap
  // instead of being returned to the kernel after every frame and faulted in again page by
  // page (docs/performance.md). 32 MB is the largest mmap threshold glibc accepts.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  try {
    return ieslam::Main(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "ieslam: internal error: " << e.what() << "\n";
    return 1;
  }
}
