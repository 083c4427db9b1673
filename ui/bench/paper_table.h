#pragma once
// The paper's Table 1, side by side with ours: every paper scenario run headless for a fixed
// number of steps after a warm-up, with the collision-handling time per step (FFD AABB
// update + broad phase + narrow phase with its responses + planes), the whole step and the
// contacts per step. `ffdsim bench` prints it and writes it as Markdown and JSON.
#include <cstdint>
#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "bench/broad_phase_race.h"
#include "ffd/step.h"

namespace ffdbench {

// A row of the paper's Table 1 (Pentium D 3.0 GHz, 2 GB RAM), as printed there.
struct PaperRow {
  std::string name;       // "teapots"
  double triangles = 0;   // in the scene
  double cells = 0;       // FFD grid cells in the scene
  double collision_ms = 0;  // collision handling per step
};

struct Scenario {
  std::string key;         // "bunnies_soft": names the row and the recorded box sets
  std::string scene_file;  // relative to the scenarios folder
  PaperRow paper;
  double target_p99_ms = 0;       // the collision target (p99 per step, ms, 2 threads on 2 cores)
  double target_step_p99_ms = 0;  // the whole-step target (p99, ms, 2 threads on 2 cores)
  std::uint64_t warmup_steps = 0, measured_steps = 0;  // full run
  std::uint64_t quick_warmup_steps = 0, quick_measured_steps = 0;
};

// The paper's four experiments (bunnies twice: soft and hard springs).
const std::vector<Scenario>& paper_scenarios();

// One measured run of a scenario on a number of threads.
struct ThreadRun {
  int threads = 1;
  double collision_mean_ms = 0, collision_p99_ms = 0;  // per measured step
  double step_mean_ms = 0, step_p50_ms = 0, step_p99_ms = 0;  // the whole step, dynamics included
  double dynamics_mean_ms = 0, box_update_mean_ms = 0;
  // The same figures over the first `steps` measured steps only: a quick run's window after
  // the full warm-up, what `--compare` holds a quick run against.
  struct Head {
    std::uint64_t steps = 0;
    double step_p50_ms = 0, step_mean_ms = 0, collision_mean_ms = 0, dynamics_mean_ms = 0, box_update_mean_ms = 0;
  } head;
  std::string state_hash;                              // after the last step
};

struct ScenarioResult {
  Scenario scenario;
  ffd::ContactResponse response = ffd::ContactResponse::Paper;  // every step answered so (spec.h)
  std::uint64_t warmup_steps = 0, measured_steps = 0;
  std::size_t objects = 0, triangles = 0, cells = 0, boxes = 0, nodes = 0, springs = 0, spring_projections = 0;
  double load_s = 0;                          // scene file to compiled model, s
  // The first run (1 thread), whose figures are also these fields, and the second (the
  // bench's thread count; the same states, the hashes must agree).
  double collision_mean_ms = 0, collision_p99_ms = 0;  // per measured step
  double step_mean_ms = 0, step_p99_ms = 0;            // the whole step, dynamics included
  double dynamics_mean_ms = 0;
  ThreadRun single, parallel;
  // Per element on 1 thread: a spring projection timed alone (ffd::time_spring_sweeps), the
  // box update over its boxes, ns.
  double ns_per_spring_projection = 0, ns_per_box_update = 0;
  double contacts_mean = 0;                   // inter + self + plane contacts per step
  std::uint32_t contacts_max = 0;
  double max_penetration_m = 0;               // deepest node-in-box depth of a measured step
  bool finite = true;
  std::string state_hash;                     // after the last step
  std::vector<BoxSet> box_sets;               // early, mid-pile, settled (for the race)
};

// Progress: what runs ("alphabets: warm-up"), steps done and steps in all.
using Progress = std::function<void(const std::string& what, std::uint64_t done, std::uint64_t total)>;

// Loads, warms up and measures one scenario under a contact response (switched as the live
// command switches it). Box sets are recorded at 15 % and 55 % of the run and at its end,
// under the paper's response. Throws on a bad scene file (the message names it).
// `threads`: the second run's thread count (the first runs on 1). Throws if the two runs end
// in different states (determinism across thread counts is part of what is measured).
// `compare_windows` (with `quick`): the full warm-up, then the quick run's measured steps, the
// stretch a full run records as ThreadRun::head.
ScenarioResult bench_scenario(const Scenario& scenario, const std::string& scenarios_dir, bool quick, int threads,
                              const Progress& progress, ffd::ContactResponse response = ffd::ContactResponse::Paper,
                              bool compare_windows = false);

// Figures shared by the bench tables.
double percentile(std::vector<double> values, double p);  // nearest rank, of a copy
double mean(const std::vector<double>& values);
std::int64_t stage(const ffd::StepReport& report, ffd::Stage s);  // ns, 0 for a stage not run
std::string fixed(double value, int decimals);
// The model's initial state switched to `level` and `response` by commands, the path a
// user's commands take.
ffd::State initial_state_at(const ffd::Model& model, ffd::Accuracy level, ffd::ContactResponse response);
// An object's lattice nodes' RMS speed, mass-weighted (its kinetic energy as a speed), m/s.
double rms_speed(const ffd::Model& model, const ffd::State& state, const ffd::ObjectModel& object);

// "Intel(R) Xeon(R) ... (2 cores)" from /proc/cpuinfo, or "unknown CPU".
std::string cpu_description();

// The table as Markdown (with the machine and how it was measured) and as JSON.
std::string markdown_table(const std::vector<ScenarioResult>& results, const std::string& cpu, bool quick);
nlohmann::json to_json(const std::vector<ScenarioResult>& results);

// `ffdsim bench --compare`: each row of `results` against the row of the same scenario and
// response in `reference` (a bench.json; `source` names it in messages), when `reference`
// was measured on `cpu`. A row whose whole-step p50 on the most threads is more than
// kSlowerAllowed above the reference's over the same steps (a run as long as the
// reference's: its p50; a shorter one after the same warm-up: the reference's p50 over as
// many first steps, ThreadRun::head) fails; its message names the scene, the response and
// the stage that grew the most. Throws std::runtime_error on a reference that is not a
// bench.json (the message names `source` and the field).
inline constexpr double kSlowerAllowed = 0.25;
struct Comparison {
  bool compared = false;          // false: the reference was measured on another CPU model
  std::string reference_cpu;
  std::vector<std::string> lines;     // one per row compared, "ok" or "SLOWER"
  std::vector<std::string> failures;  // the rows more than kSlowerAllowed slower
};
Comparison compare_to_reference(const std::vector<ScenarioResult>& results, const nlohmann::json& reference,
                                const std::string& cpu, const std::string& source);

}  // namespace ffdbench
