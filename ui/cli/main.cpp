// ffdsim: one program, subcommands. `ffdsim --help` lists them.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>

#include "commands.h"
#include "ffd/worker_pool.h"

namespace ffdsim {
int thread_count(int option) { return option > 0 ? option : ffd::default_thread_count(); }

void add_threads_option(CLI::App& command, int& threads) {
  command
      .add_option("--threads", threads,
                  "Threads a step is spread over, this one included (default: 2 on a machine with 2 cores or "
                  "more); the results are bit-identical whatever the count")
      ->check(CLI::Range(1, 64));
}

void ensure_folder(const std::string& dir) {
  if (dir.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw std::runtime_error(dir + ": cannot create folder: " + ec.message());
}

void ensure_parent_folder(const std::string& file_path) {
  ensure_folder(std::filesystem::path(file_path).parent_path().string());
}
}  // namespace ffdsim

int main(int argc, char** argv) {
  CLI::App app{
      "ffdsim: deformable objects embedded in FFD lattices, with FFD AABB collision handling.\n"
      "Run `ffdsim <command> --help` for the options of a command."};
  app.require_subcommand(1);
  ffdsim::SimulateOptions simulate;
  ffdsim::register_simulate(app, simulate);
  ffdsim::ReplayOptions replay;
  ffdsim::register_replay(app, replay);
  ffdsim::RunOptions run;
  ffdsim::register_run(app, run);
  ffdsim::BenchOptions bench;
  ffdsim::register_bench(app, bench);
  ffdsim::AccuracyOptions accuracy;
  ffdsim::register_accuracy(app, accuracy);
  ffdsim::DeviceSimOptions device_sim;
  ffdsim::register_device_sim(app, device_sim);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (app.got_subcommand("simulate")) return ffdsim::run_simulate(simulate);
  if (app.got_subcommand("replay")) return ffdsim::run_replay_command(replay);
  if (app.got_subcommand("run")) return ffdsim::run_run(run);
  if (app.got_subcommand("bench")) return ffdsim::run_bench(bench);
  if (app.got_subcommand("device-sim")) return ffdsim::run_device_sim(device_sim);
  if (app.got_subcommand("accuracy")) return ffdsim::run_accuracy_command(accuracy);
  return ffdsim::kExitUsage;
}
