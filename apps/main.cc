// ieslam: one binary, one subcommand per job (../shared/CLI.md is the interface).
#include <iostream>
#include <string>

int main(int argc, char** argv) {
  (void)argc;
  (void)argv;
  std::cout << "ieslam\n";
  return 0;
}
