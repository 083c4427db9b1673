// Catch2 entry point. Floating-point exceptions (invalid, divide by zero, overflow) trap in
// every test, so a NaN or Inf born anywhere in the runtime fails the test where it is made.
// The viewer keeps a list of recent scenes under $XDG_CONFIG_HOME: the tests (and the
// programs they start) get a folder of their own, so that running them leaves the user's list
// as it was.
#define CATCH_CONFIG_RUNNER
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cfenv>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

#include "support/run_ffdsim.h"

int main(int argc, char* argv[]) {
  const std::filesystem::path config =
      std::filesystem::temp_directory_path() / ("ffdsim_test_config_" + std::to_string(getpid()));
  setenv("XDG_CONFIG_HOME", config.c_str(), 1);
  feenableexcept(FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW);
  const int result = Catch::Session().run(argc, argv);
  std::error_code ignored;
  std::filesystem::remove_all(config, ignored);
  if (result == 0)
    for (const std::filesystem::path& dir : test::temp_dirs_made()) std::filesystem::remove_all(dir, ignored);
  return result;
}
