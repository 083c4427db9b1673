#pragma once
// Runs a replay script on the physics loop (fast or real time), checks its assertions while
// the telemetry streams in, and says which failed with the measured values.
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ffd/physics_loop.h"
#include "ffd/replay_script.h"
#include "ffd/run_exports.h"
#include "ffd/step_statistics.h"

namespace ffd {

struct LatencyReport {
  std::uint64_t steps = 0;
  TimeSummary compute, lateness;
  std::uint64_t deadline_misses = 0;
  std::uint64_t overruns = 0;
  bool realtime_priority = false, memory_locked = false;
};

struct AssertionResult {
  std::string name;      // "latency.compute_p99_us", "gap[teapot_low, teapot_high].max_gap_m", ...
  std::string where;     // file:line:col of the assertion, when known
  bool skipped = false;  // not measurable in this mode (lateness in a fast run)
  bool passed = true;
  std::string measured;  // with units
  std::string limit;     // "<= 5000 us"
};

struct ReplayResult {
  Pacing pacing = Pacing::Fast;
  std::uint64_t steps = 0;             // steps the loop took
  LatencyReport latency;
  bool finite = true;
  std::optional<std::uint64_t> first_non_finite_step;
  double max_energy_j = 0, max_speed_m_s = 0, max_penetration_m = 0, peak_force_n = 0;
  // Fewest contacts of one step from ContactLimits::contacts_from_step on, and that step.
  std::uint64_t min_contacts = ~std::uint64_t{0}, min_contacts_step = 0;
  double mean_contacts = 0.0;  // contacts per step over the whole run
  // The step each maximum above was reached at.
  std::uint64_t max_energy_step = 0, max_speed_step = 0, max_penetration_step = 0, peak_force_step = 0;
  // Energy against what went in: the initial total energy, the work the probe's device has
  // done (trapezoidal rule over the coupling force and the device's moves), and the most the
  // total energy rose above their sum, with the step and the probe work up to that step.
  double initial_energy_j = 0.0, probe_work_j = 0.0;
  double max_energy_gain_j = -std::numeric_limits<double>::infinity(), probe_work_at_max_gain_j = 0.0;
  std::uint64_t max_energy_gain_step = 0;
  // Cells inside out (when StabilityLimits::inverted_steps_max is asked): the longest run of
  // consecutive steps one cell stayed so, that cell and the step the run reached its length;
  // the most cells inside out at once and its step.
  std::uint64_t longest_inversion_steps = 0, longest_inversion_step = 0;
  Index longest_inversion_cell = 0;
  std::uint64_t most_inverted_cells = 0, most_inverted_step = 0;
  // When the scene came to rest: from this time on (s) the lattice nodes' RMS speed stayed
  // below kRestRmsSpeed to the end; none if it was still moving at the end.
  std::optional<double> time_to_rest_s;
  // The probe force's ripple while held: over the script's [[assert.force_window]] spans, the
  // largest standard deviation of |F| as a share of its mean; none without such a window.
  std::optional<double> force_ripple;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> hashes;  // (step, state hash) the run produced
  std::optional<std::uint64_t> first_divergence;  // first hash check that differed
  std::uint64_t final_hash = 0;
  std::uint64_t commands_rejected = 0;
  std::vector<AssertionResult> assertions;
  bool passed() const;
};

inline constexpr double kRestRmsSpeed = 0.005;  // m/s: ReplayResult::time_to_rest_s
// The energy is a sum over every node, good to about this share of its size: a gain below
// kEnergyRounding x (the energies compared) is the sums' rounding, not energy put in
// (stability.energy_gain_max_j).
inline constexpr double kEnergyRounding = 1e-12;

struct ReplayRunOptions {
  Pacing pacing = Pacing::Fast;
  std::int64_t period_ns = 1'000'000;
  std::int64_t budget_ns = 1'000'000;
  // false: every latency limit is reported as SKIP (sanitizer or debug builds, where a step
  // is tens of times slower and time limits say nothing about the product).
  bool check_latency = true;
  int threads = 1;  // a step spread over this many threads (the same results whatever the count)
  RunExports* exports = nullptr;  // surfaces and time series to write as the run goes (not owned)
};

ReplayResult run_replay(const LoadedReplay& replay, const ReplayRunOptions& options);

// One line per assertion ("PASS latency.compute_p99_us: 812 us (limit <= 5000 us)") and a
// summary line.
std::string format_replay_result(const ReplayScript& script, const ReplayResult& result);

// The result as JSON text (for --report).
std::string replay_result_json(const ReplayScript& script, const ReplayResult& result);

}  // namespace ffd
