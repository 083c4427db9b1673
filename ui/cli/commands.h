#pragma once
// Subcommands of the ffdsim program. Each registers its options on the CLI11 app and runs
// when chosen; run() returns the process exit code.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "ffd/run_exports.h"

namespace ffdsim {

// Exit codes shared by the subcommands (docs/command-line.md, "Exit codes"; tests/ui/exit_codes_test.cpp holds
// every command to it).
inline constexpr int kExitOk = 0;
inline constexpr int kExitUsage = 1;            // the command line: unknown command or option, a value out of range
inline constexpr int kExitBadInput = 2;         // a file given: a scene, script, mesh or recording is missing or
                                                // wrong, or an output cannot be written
inline constexpr int kExitRuntime = 3;          // the run failed: non-finite values, no window, a silent device
inline constexpr int kExitAssertionFailed = 4;  // a check failed: a replay assertion, a UI script cut short

// Create a folder, or the folder a file will be written into; throw naming it on failure.
// Called before a run, so that a bad output path fails before the run rather than after it.
void ensure_folder(const std::string& dir);
void ensure_parent_folder(const std::string& file_path);

// Threads a step is spread over (--threads): 0 means ffd::default_thread_count().
int thread_count(int option);
void add_threads_option(CLI::App& command, int& threads);

// --surfaces-every K --surfaces DIR --surface-format obj|ply --series FILE (run, replay;
// simulate has the surfaces): docs/command-line.md, "Exports".
struct ExportArguments {
  long long surfaces_every = 0;
  std::string surfaces_dir, surface_format = "obj", series_path;
  ffd::ExportOptions options() const;
};
void add_export_options(CLI::App& command, ExportArguments& arguments, bool series = true, bool older_names = false);

struct SimulateOptions {
  std::string scene;  // empty = the default scene
  long long steps = 3000;
  int threads = 0;
  std::string report_path;
  ExportArguments exports;  // the surfaces only (--obj-every K --out DIR are their older names)
  bool quiet = false;
};
void register_simulate(CLI::App& app, SimulateOptions& options);
int run_simulate(const SimulateOptions& options);

struct ReplayOptions {
  std::string script;
  bool fast = false, realtime = false;
  std::string report_path;
  double period_us = 1000.0, budget_us = 1000.0;
  bool skip_latency = false;
  int threads = 0;
  bool quiet = false;
  bool scene_from_recording = false;  // a recording: its embedded scene text, not the scene file
  bool allow_changed = false;         // a recording: the files as they are now, even if changed
  std::string response;               // empty: the scene's; "paper" or "solver" overrides it
  ExportArguments exports;
};
void register_replay(CLI::App& app, ReplayOptions& options);
int run_replay_command(const ReplayOptions& options);

struct RunOptions {
  std::string scene;  // empty = the default scene
  std::string sweep_dir, sweep_point;  // --sweep DIR --point ID: that point's scene instead
  bool headless = false;
  bool window = false;       // insist on a window (error without a display)
  std::string frames_dir;    // headless viewer: write PNG frames here
  double fps = 10.0;
  std::string input_script;  // UI input script (mouse and keys)
  int width = 1280, height = 720;
  double seconds = 0.0;  // 0: 10 s headless; the window runs until closed
  std::string record_path;
  long long hash_every = 100;
  std::string report_path;
  double period_us = 1000.0, budget_us = 1000.0, spin_us = 20.0;
  bool auto_accuracy = false;  // budget-aware accuracy from the scene's level up
  int threads = 0;
  bool quiet = false;
  // --device: a haptic device link (ui/device/device_link.h); empty: none.
  std::string device_url;
  bool device_allow_remote = false;
  double force_limit_n = -1.0, force_rate_limit = -1.0, watchdog_ms = -1.0;  // < 0: the scene's
  ExportArguments exports;
};
void register_run(CLI::App& app, RunOptions& options);
int run_run(const RunOptions& options);

struct BenchOptions {
  bool quick = false;
  std::string out_dir = "out/bench";
  std::vector<std::string> only;  // scenario keys; empty = all
  std::string results_page;       // --update-docs: the results page to write (docs/results/bench.md)
  int repetitions = 20;
  int threads = 0;                // the second thread count of every row (the first is 1)
  std::vector<std::string> responses = {"paper", "solver"};  // contact responses, a row each (spec.h)
  std::string compare;            // --compare: a bench.json to hold the whole-step p50s against
  bool quiet = false;
};
void register_bench(CLI::App& app, BenchOptions& options);
int run_bench(const BenchOptions& options);

struct AccuracyOptions {
  std::vector<std::string> scenes;  // empty: the two teapots and the five soft bunnies
  std::uint64_t steps = 3000;
  std::vector<int> levels;          // empty: all
  std::vector<std::string> responses = {"paper", "solver"};  // contact responses (spec.h)
  std::string out_dir = "out/accuracy";
  std::string results_page;         // --update-docs: the results page (its plot beside it, same name .png)
  std::string plot;                 // where the PNG is also copied
  int threads = 0;
  bool quiet = false;
};
void register_accuracy(CLI::App& app, AccuracyOptions& options);
int run_accuracy_command(const AccuracyOptions& options);

struct PilesOptions {
  std::vector<std::uint64_t> seeds;  // empty: the short set (1-3), or with --long 1-20
  bool long_set = false;
  int objects = 6;
  std::uint64_t steps = 3000;
  std::uint64_t sample_every = 10;   // steps between intersection counts
  std::vector<int> levels;           // empty: all
  std::vector<std::string> responses = {"paper", "solver"};
  std::string out_dir = "out/piles";
  std::string scenes_dir;            // also write each pile's scene file here
  bool box_overlap = false;          // every pile with [simulation] box_overlap = true
  bool edge_contacts = true;         // every pile with [simulation] edge_contacts = true (the default)
  bool solver_substeps = false;      // every pile with [simulation] solver_substeps = true
  int iterations = 4;                // every object's mass_spring.iterations
  std::string results_page;          // --update-docs: the results page to write
  bool require_clean = false;        // exit 4 unless every pile ends clean
  int threads = 0;
  bool quiet = false;
};
void register_piles(CLI::App& app, PilesOptions& options);
int run_piles_command(const PilesOptions& options);

struct SweepOptions {
  std::string sweep_file, dir, id, out;
  std::string results_page;  // merge --update-docs
  std::vector<std::string> axes;  // merge --axes A,B
  int jobs = 2;
  bool force = false, retry_failed = false, quiet = false;
};
void register_sweep(CLI::App& app, SweepOptions& options);
int run_sweep_command(const CLI::App& app, const SweepOptions& options);

struct HardCasesOptions {
  std::vector<std::string> scripts;  // replay scripts or folders; empty: scenarios/replays/hard
  std::vector<std::string> responses = {"paper", "solver"};
  std::string results_page;          // --update-docs: the results page to write
  int threads = 0;
  bool quiet = false;
};
void register_hard_cases(CLI::App& app, HardCasesOptions& options);
int run_hard_cases_command(const HardCasesOptions& options);

struct DeviceSimOptions {
  std::string script;          // a replay script: its [[probe_path]] is the device's motion
  std::string url;             // udp://HOST:PORT of `ffdsim run --device`
  std::string out_path, report_path;
  double drop = 0.0, duplicate = 0.0, reorder = 0.0;  // shares of the samples
  std::uint64_t seed = 1;
  double silence_at_ms = 0.0, silence_ms = 0.0;
  double linger_ms = 200.0;
  double wait_ms = 10000.0;    // for ffdsim to answer before the path starts
  bool quiet = false;
};
void register_device_sim(CLI::App& app, DeviceSimOptions& options);
int run_device_sim(const DeviceSimOptions& options);

}  // namespace ffdsim
