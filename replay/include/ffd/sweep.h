#pragma once
// Parameter sweeps over a replay script (docs/sweeps.md): a sweep file names a replay and the
// values of scene parameters to run it with, as a grid or a list of points. A planned sweep is
// a folder: plan.json (the jobs, each a point), jobs.tsv (the same, a line each), sweep.sbatch
// (a Slurm job array) and parallel.sh (GNU parallel); each job's result lands in
// results/ID.json, written whole or not at all, so a sweep killed half-way resumes where it
// stopped, and any engine that can run `ffdsim sweep run-one DIR ID` can run it.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "ffd/replay_script.h"

namespace ffd {

inline constexpr int kSweepFormatVersion = 1;
inline constexpr std::size_t kMaxSweepJobs = 100'000;

// A parameter's value: a number, an integer, a flag or a name ("solver").
using SweepValue = std::variant<double, std::int64_t, bool, std::string>;
std::string sweep_value_text(const SweepValue& value);  // 0.5, 3, true, solver

struct SweepJob {
  std::string id;                   // "0001", ...: fixed width, in plan order
  std::vector<SweepValue> values;   // one per SweepPlan::parameters
};

struct SweepPlan {
  std::string sweep_file;           // the sweep file, absolute
  std::string replay;               // the replay script it runs, absolute
  std::string description;
  int threads = 1;                  // threads a job's step is spread over
  std::vector<std::string> parameters;  // names, in the file's order
  std::vector<SweepJob> jobs;
  double plan_s = 0.0;              // wall seconds `sweep plan` took (read, checked, written)
};

// Reads a sweep file. Throws InputError "file:line:col: field: problem" for anything wrong:
// an unknown parameter, a value out of its range, an empty grid, too many jobs.
SweepPlan load_sweep_file(const std::string& path);
SweepPlan parse_sweep(const std::string& text, const std::string& origin, const std::string& base_dir);

// The replay with job `values` applied to its scene (and its hash checks dropped: a point
// that changes the physics changes the state). Throws InputError naming the parameter.
LoadedReplay load_sweep_job(const SweepPlan& plan, const SweepJob& job);

// The scene of job `job` as a scene file's text: the replay's scene with the job's values and
// the replay's own step-0 settings (α, β, accuracy, response, stiffness, probe stiffness)
// written in, and its mesh and font paths absolute, so that `ffdsim run` opens the point the
// sweep found. Throws InputError where that cannot be written (an object of a [[group]] named
// alone).
std::string sweep_point_scene(const SweepPlan& plan, const SweepJob& job);

// The plan's folder: plan.json, jobs.tsv, sweep.sbatch, parallel.sh, results/ and logs/;
// the scripts run `program` (this ffdsim, by its absolute path). Throws std::runtime_error
// naming the file it could not write.
void write_sweep_plan(const SweepPlan& plan, const std::string& dir, const std::string& program);
// Reads DIR/plan.json back, its parameters and values checked. Throws InputError naming the file.
SweepPlan read_sweep_plan(const std::string& dir);
const SweepJob* find_sweep_job(const SweepPlan& plan, const std::string& id);

std::string sweep_result_path(const std::string& dir, const std::string& id);

// A job's result as results/ID.json holds it: its parameters, "done" (every assertion held)
// or "failed" with the exit code `ffdsim replay` would give, the metrics (docs/sweeps.md),
// every assertion with its measured value, the ffdsim version and the scene's content hash.
inline constexpr int kSweepExitDiverged = 3, kSweepExitAssertionFailed = 4;  // as `ffdsim replay`'s
struct ReplayResult;
// `load_s` and `run_s`: the wall seconds the job took to load its replay and scene, and to run it.
std::string sweep_job_result_json(const SweepPlan& plan, const SweepJob& job, const LoadedReplay& replay,
                                  const ReplayResult& result, double load_s, double run_s);
// A job that could not run or did not end (a bad point, a crash): its exit code and why.
std::string sweep_job_failure_json(const SweepPlan& plan, const SweepJob& job, int exit_code, const std::string& why);

// Writes `text` to `path` whole or not at all: a temporary file beside it, then a rename.
void write_file_atomically(const std::string& path, const std::string& text);

enum class JobState { Done, Failed, Missing };
// What results/ID.json says of the job: done (its replay ran and its assertions held),
// failed (it ran and an assertion failed, or it crashed or could not start), or missing (no
// result, or one left by another plan's job of the same id).
JobState sweep_job_state(const SweepPlan& plan, const std::string& dir, const SweepJob& job);

// What the jobs done so far cost, in seconds: their own time, what `ffdsim replay` of each
// point takes (loading its replay and scene, running it), and what running them as a sweep's
// jobs added (processes started, the plan read, the result written).
struct SweepTimes {
  std::size_t jobs = 0;  // with every figure in their result
  double load_s = 0.0, run_s = 0.0, overhead_s = 0.0;
};
SweepTimes sweep_times(const SweepPlan& plan, const std::string& dir);

struct SweepMerge {
  std::size_t done = 0, failed = 0, missing = 0;
  std::string csv_path, summary_path;
  // gnuplot scripts, one per ranked metric, each drawing DIR/heatmaps/METRIC.png over the
  // sweep's first two numeric parameters (none if it has fewer than two)
  std::vector<std::string> heat_map_scripts;
};
// DIR/results.csv (a row per job: its parameters, state, metrics), DIR/summary.md (the best
// point per metric) and the heat maps' gnuplot scripts (the caller runs gnuplot on them).
// `axes`: the two parameters the heat maps are drawn over (empty: the first two numeric ones);
// a name that is not a numeric parameter of the plan is an InputError.
SweepMerge merge_sweep(const std::string& dir, const std::vector<std::string>& axes = {});

}  // namespace ffd
