#pragma once
// Subcommands of the ffdsim program. Each registers its options on the CLI11 app and runs
// when chosen; run() returns the process exit code.
#include <CLI/CLI.hpp>
#include <string>

namespace ffdsim {

struct SimulateOptions {
  std::string scene;  // empty = the default scene
  long long steps = 3000;
  std::string report_path;
  long long obj_every = 0;
  std::string out_dir;
  bool quiet = false;
};

void register_simulate(CLI::App& app, SimulateOptions& options);
int run_simulate(const SimulateOptions& options);

}  // namespace ffdsim
