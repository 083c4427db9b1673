#pragma once
// Running the ffdsim program from a test, as a user would from a shell.
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace test {

struct ProgramResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

// A shell command line, its output (stdout and stderr) and exit code.
inline ProgramResult run_shell(const std::string& command_line) {
  ProgramResult r;
  const std::string command = "(" + command_line + ") 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  REQUIRE(pipe != nullptr);
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe)) r.output += buffer;
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// `prefix` goes before the program (an `env ...` to change its environment).
inline ProgramResult run_ffdsim(const std::string& arguments, const std::string& prefix = "") {
  return run_shell(prefix + std::string(FFDSIM_BINARY) + " " + arguments);
}

// The folders this test process made under the system's temporary folder: test_main.cpp
// removes them when every test passed and keeps them to look at when one failed.
inline std::vector<std::filesystem::path>& temp_dirs_made() {
  static std::vector<std::filesystem::path> dirs;
  return dirs;
}

// An empty folder of this test process's own under the system's temporary folder (the
// process id in its name: two test runs at once never share one).
inline std::filesystem::path fresh_temp_dir(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("ffdsim_test_" + name + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  temp_dirs_made().push_back(dir);
  return dir;
}

// A file's whole content ("" when it cannot be read).
inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace test
