// Drives the physics loop with a script's commands and checks its assertions from the
// lossless telemetry (per step) and snapshots (surface measurements, off the 1 kHz thread).
#include "ffd/replay_runner.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <sstream>
#include <thread>

#include "ffd/measure.h"
#include "ffd/surface_intersections.h"
#include "ffd/surface_metrics.h"
#include "ffd/trilinear.h"

namespace ffd {

bool ReplayResult::passed() const {
  return std::all_of(assertions.begin(), assertions.end(), [](const AssertionResult& a) { return a.passed; });
}

namespace {

std::string number(double value, const char* unit) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.4g %s", value, unit);
  return buffer;
}

// The most intersecting triangle pairs one intersection assertion saw, over its snapshots.
struct IntersectionMeasure {
  std::uint64_t max_pairs = 0, worst_step = 0, samples = 0;
};

// Surface measurements of one gap assertion, over the snapshots it asked for.
struct GapMeasure {
  double max_gap_m = 0.0, max_penetration_m = 0.0;
  std::uint64_t samples = 0;
  std::uint64_t worst_gap_step = 0, worst_penetration_step = 0;
};

std::uint64_t gcd_of_sample_steps(const ReplayScript& script) {
  std::uint64_t g = 0;
  for (const GapLimit& gap : script.gaps) g = std::gcd(g, gap.every_steps);
  for (const IntersectionLimit& i : script.intersections) g = std::gcd(g, i.every_steps);
  for (const PositionLimit& p : script.positions) g = std::gcd(g, p.every_steps);
  if (script.rest.speed_max_m_s) g = std::gcd(g, script.rest.every_steps);
  for (const CreepLimit& c : script.creeps) g = std::gcd(g, c.every_steps);
  if (script.stability.inverted_steps_max) g = 1;  // runs of steps: every step
  return g;
}

// Mass-weighted centre of each object's lattice nodes.
void centres_of_mass(const Model& model, const std::vector<Vec3>& x, std::vector<Vec3>& out) {
  out.resize(model.objects.size());
  for (Index i = 0; i < model.objects.size(); ++i) out[i] = centre_of_mass(model, x, i);
}

std::string vector_text(const Vec3& v) {
  char buffer[160];
  std::snprintf(buffer, sizeof buffer, "[%.10g, %.10g, %.10g]", v.x(), v.y(), v.z());
  return buffer;
}

// One creep assertion over its samples: each object's centre at `from`, the farthest since.
struct CreepMeasure {
  std::uint64_t samples = 0;
  std::vector<Vec3> start;
  double worst_m = 0.0;
  std::uint64_t worst_step = 0;
  Index worst_object = 0;
};

// The force output over one window: |F| summed and squared (for its mean and deviation).
struct ForceWindowMeasure {
  std::uint64_t steps = 0;
  double sum = 0.0, sum_sq = 0.0, low = INFINITY, high = 0.0;
  double mean() const { return steps ? sum / static_cast<double>(steps) : 0.0; }
  double deviation() const {
    if (!steps) return 0.0;
    const double m = mean();
    return std::sqrt(std::max(0.0, sum_sq / static_cast<double>(steps) - m * m));
  }
};

// Positions of one position assertion over its samples.
struct PositionMeasure {
  std::uint64_t samples = 0;
  Vec3 low = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 high = Vec3::Constant(-std::numeric_limits<double>::infinity());
  double worst_outside_m = 0.0;  // farthest outside [min, max] along any axis (0: never outside)
  std::uint64_t worst_step = 0;
  Index worst_object = 0;
  Vec3 worst_position = Vec3::Zero();
};

std::uint64_t hash_interval(const ReplayScript& script) {
  if (script.hash_every) return script.hash_every;
  std::uint64_t g = 0;
  for (const HashCheck& h : script.hashes) g = std::gcd(g, h.step);
  return g;
}

void check_upper(std::vector<AssertionResult>& out, const std::string& name, const std::string& where,
                 const std::optional<double>& limit, double measured, const char* unit, bool skipped = false,
                 std::optional<std::uint64_t> at_step = std::nullopt) {
  if (!limit) return;
  AssertionResult a;
  a.name = name;
  a.where = where;
  a.skipped = skipped;
  a.measured = number(measured, unit);
  if (at_step) a.measured += " at step " + std::to_string(*at_step);
  a.limit = "<= " + number(*limit, unit);
  a.passed = skipped || measured <= *limit;
  out.push_back(a);
}

}  // namespace

ReplayResult run_replay(const LoadedReplay& replay, const ReplayRunOptions& run_options) {
  const ReplayScript& script = replay.script;
  const Model& model = replay.model;
  ReplayResult result;
  result.pacing = run_options.pacing;

  LoopOptions options;
  options.pacing = run_options.pacing;
  options.period_ns = run_options.period_ns;
  options.budget_ns = run_options.budget_ns;
  options.threads = run_options.threads;
  options.stop_at_step = script.steps;
  options.hash_every = static_cast<std::uint32_t>(hash_interval(script));
  // Every step when the energy gain is asserted: impact peaks last a step or two.
  RunExports* exports = run_options.exports;
  const bool series = exports && !exports->options().series_path.empty();
  options.energy_every = script.stability.energy_gain_max_j || series ? 1 : 10;
  options.frame_every = 0;  // nobody looks
  options.snapshot_every = static_cast<std::uint32_t>(
      std::gcd(gcd_of_sample_steps(script), exports ? exports->surfaces_every() : std::uint64_t{0}));
  // Commands for the whole run wait in the loop's queue from the start.
  options.command_capacity = std::max<std::size_t>(1 << 12, script.commands.size() + 16);
  PhysicsLoop loop(model, initial_state(model), options);
  for (const Command& c : script.commands) loop.push(c);

  std::vector<std::int64_t> compute_ns, lateness_ns;
  compute_ns.reserve(script.steps);
  lateness_ns.reserve(script.steps);
  std::vector<GapMeasure> gaps(script.gaps.size());
  std::vector<IntersectionMeasure> intersections(script.intersections.size());
  std::optional<SurfaceIntersections> crossings;  // the rest shapes' crossings, found once if asked for
  if (!script.intersections.empty()) crossings.emplace(model);
  double largest_cell = 0.0;
  for (const ObjectModel& o : model.objects) largest_cell = std::max(largest_cell, o.cell_size);
  State surface_state = initial_state(model);  // holds a snapshot's lattice for deformed_surface()
  std::vector<PositionMeasure> positions(script.positions.size());
  std::vector<CreepMeasure> creeps(script.creeps.size());
  std::vector<ForceWindowMeasure> force_windows(script.force_windows.size());
  std::vector<std::uint64_t> inverted_run;  // per cell: consecutive snapshots inside out so far
  if (script.stability.inverted_steps_max) inverted_run.assign(model.cell_count(), 0);
  double motion_rms = 0.0, motion_kinetic = 0.0, motion_fastest = 0.0;
  std::uint64_t motion_rms_step = 0, motion_kinetic_step = 0, motion_fastest_step = 0, motion_steps = 0;
  std::vector<Vec3> centres, rest_centres;  // this snapshot's centres of mass; the last rest sample's
  std::optional<std::uint64_t> rest_step;   // the step of the last rest sample
  double rest_max_speed = 0.0;
  std::uint64_t rest_samples = 0, rest_worst_step = 0;
  Index rest_worst_object = 0;
  std::optional<std::uint64_t> last_moving_step;  // the last step the nodes' RMS speed was at kRestRmsSpeed or above

  // The probe's work: the device moves by d_k - d_(k-1) at the start of step k against the
  // coupling force output F (the force on the device), so the device puts in
  // -(F_(k-1) + F_k) / 2 . (d_k - d_(k-1)) (trapezoidal rule; exact for the spring alone).
  // A coupling stiffness change k -> k' adds (k' - k) |x - d|^2 / 2 to the coupling spring.
  // Device poses, stiffness changes and resets come from the script, in step order.
  const State initial = initial_state(model);
  result.initial_energy_j = compute_energy(model, initial).total();
  std::size_t next_command = 0;
  Vec3 device = initial.probe.device, device_before = device, probe_before = initial.probe.x;
  Vec3 force_before = Vec3::Zero();
  double coupling_stiffness = initial.params.probe_stiffness;

  auto drain = [&] {
    Telemetry t;
    while (loop.pop_telemetry(t)) {
      ++result.steps;
      compute_ns.push_back(t.compute_ns);
      lateness_ns.push_back(t.lateness_ns);
      if (!t.finite && result.finite) {
        result.finite = false;
        result.first_non_finite_step = t.step;
      }
      auto track = [&](double value, double& max, std::uint64_t& at) {
        if (value > max) {
          max = value;
          at = t.step;
        }
      };
      // Commands stamped for steps before t.step were applied before this step.
      for (; next_command < script.commands.size() && script.commands[next_command].step < t.step; ++next_command) {
        const Command& c = script.commands[next_command];
        if (c.kind == CommandKind::ProbePose) {
          device = c.vector;
        } else if (c.kind == CommandKind::SetProbeStiffness) {
          result.probe_work_j += 0.5 * (c.value - coupling_stiffness) * (probe_before - device_before).squaredNorm();
          coupling_stiffness = c.value;
        } else if (c.kind == CommandKind::Reset) {  // back to the initial energy, nothing put in
          device = device_before = probe_before = initial.probe.device;
          force_before = Vec3::Zero();
          coupling_stiffness = initial.params.probe_stiffness;
          result.probe_work_j = 0.0;
        }
      }
      result.probe_work_j -= 0.5 * (force_before + t.probe_force_n).dot(device - device_before);
      force_before = t.probe_force_n;
      device_before = device;
      probe_before = t.probe_position;
      if (t.has_energy) {
        track(t.energy_j, result.max_energy_j, result.max_energy_step);
        const double gain = t.energy_j - result.initial_energy_j - result.probe_work_j;
        if (gain > result.max_energy_gain_j) {
          result.max_energy_gain_j = gain;
          result.max_energy_gain_step = t.step;
          result.probe_work_at_max_gain_j = result.probe_work_j;
        }
      }
      track(t.max_speed_m_s, result.max_speed_m_s, result.max_speed_step);
      if (!(t.rms_speed_m_s < kRestRmsSpeed)) last_moving_step = t.step;
      if (t.step > script.motion.from_step) {
        ++motion_steps;
        track(t.rms_speed_m_s, motion_rms, motion_rms_step);
        track(t.kinetic_energy_j, motion_kinetic, motion_kinetic_step);
        track(t.max_speed_m_s, motion_fastest, motion_fastest_step);
      }
      for (std::size_t i = 0; i < script.force_windows.size(); ++i) {
        const ForceWindow& w = script.force_windows[i];
        if (t.step <= w.from_step || t.step > w.to_step) continue;
        const double f = t.probe_force_n.norm();
        ForceWindowMeasure& m = force_windows[i];
        ++m.steps;
        m.sum += f;
        m.sum_sq += f * f;
        m.low = std::min(m.low, f);
        m.high = std::max(m.high, f);
      }
      track(t.max_penetration_m, result.max_penetration_m, result.max_penetration_step);
      result.mean_contacts += t.contacts;  // summed here, divided at the end
      if (t.step > script.contact.contacts_from_step && t.contacts < result.min_contacts) {
        result.min_contacts = t.contacts;
        result.min_contacts_step = t.step;
      }
      track(t.probe_force_n.norm(), result.peak_force_n, result.peak_force_step);
      if (t.has_hash) {
        result.hashes.emplace_back(t.step, t.state_hash);
      }
      if (exports) exports->telemetry(t);
    }
    while (Snapshot* s = loop.pop_snapshot()) {
      std::copy(s->x.begin(), s->x.end(), surface_state.x.begin());
      const std::uint64_t step = s->step;
      loop.recycle(s);
      if (exports) exports->snapshot(step, surface_state.x);
      if (!inverted_run.empty()) {
        std::uint64_t inverted = 0;
        for (Index c = 0; c < model.cell_count(); ++c) {
          const std::array<Index, 8>& corner = model.cell_nodes[c];
          if (!cell_inside_out([&](int j) -> const Vec3& { return surface_state.x[corner[j]]; })) {
            inverted_run[c] = 0;
            continue;
          }
          ++inverted;
          if (++inverted_run[c] > result.longest_inversion_steps) {
            result.longest_inversion_steps = inverted_run[c];
            result.longest_inversion_step = step;
            result.longest_inversion_cell = c;
          }
        }
        if (inverted > result.most_inverted_cells) {
          result.most_inverted_cells = inverted;
          result.most_inverted_step = step;
        }
      }
      if (!script.positions.empty() || script.rest.speed_max_m_s || !script.creeps.empty())
        centres_of_mass(model, surface_state.x, centres);
      for (std::size_t i = 0; i < script.creeps.size(); ++i) {
        const CreepLimit& c = script.creeps[i];
        if (step < c.from_step || step > c.to_step || step % c.every_steps != 0) continue;
        CreepMeasure& m = creeps[i];
        if (m.samples++ == 0) {
          m.start = centres;
          continue;
        }
        for (Index object : c.objects) {
          const double moved = (centres[object] - m.start[object]).norm();
          if (moved > m.worst_m) {
            m.worst_m = moved;
            m.worst_step = step;
            m.worst_object = object;
          }
        }
      }
      for (std::size_t i = 0; i < script.positions.size(); ++i) {
        const PositionLimit& p = script.positions[i];
        if (step < p.from_step || step > p.to_step || step % p.every_steps != 0) continue;
        PositionMeasure& out = positions[i];
        ++out.samples;
        for (Index object : p.objects) {
          const Vec3 c = centres[object] - (p.relative_to ? centres[*p.relative_to] : Vec3::Zero());
          out.low = out.low.cwiseMin(c);
          out.high = out.high.cwiseMax(c);
          const double outside = std::max((p.min - c).maxCoeff(), (c - p.max).maxCoeff());
          if (outside > out.worst_outside_m) {
            out.worst_outside_m = outside;
            out.worst_step = step;
            out.worst_object = object;
            out.worst_position = c;
          }
        }
      }
      if (script.rest.speed_max_m_s && step >= script.rest.from_step && step % script.rest.every_steps == 0) {
        if (rest_step) {
          const double seconds = static_cast<double>(step - *rest_step) * model.settings.dt;
          for (std::size_t o = 0; o < centres.size(); ++o) {
            const double speed = (centres[o] - rest_centres[o]).norm() / seconds;
            if (speed > rest_max_speed) {
              rest_max_speed = speed;
              rest_worst_step = step;
              rest_worst_object = static_cast<Index>(o);
            }
          }
          ++rest_samples;
        }
        rest_centres = centres;
        rest_step = step;
      }
      for (std::size_t i = 0; i < script.intersections.size(); ++i) {
        const IntersectionLimit& limit = script.intersections[i];
        if (step < limit.from_step || step > limit.to_step || step % limit.every_steps != 0) continue;
        const std::uint64_t pairs = crossings->count(surface_state).total();
        IntersectionMeasure& out = intersections[i];
        if (pairs > out.max_pairs || out.samples == 0) {
          out.max_pairs = pairs;
          out.worst_step = step;
        }
        ++out.samples;
      }
      for (std::size_t i = 0; i < script.gaps.size(); ++i) {
        const GapLimit& g = script.gaps[i];
        if (step < g.from_step || step > g.to_step || step % g.every_steps != 0) continue;
        const double radius = std::max(2.0 * g.max_gap_m.value_or(0.0), largest_cell);
        const PairContactMetrics m = measure_pair(deformed_surface(model, surface_state, g.object_a),
                                                  deformed_surface(model, surface_state, g.object_b), radius);
        const double gap = m.near ? m.gap_m : radius;
        GapMeasure& out = gaps[i];
        ++out.samples;
        if (gap > out.max_gap_m || out.samples == 1) {
          out.max_gap_m = gap;
          out.worst_gap_step = step;
        }
        if (m.penetration_m > out.max_penetration_m) {
          out.max_penetration_m = m.penetration_m;
          out.worst_penetration_step = step;
        }
      }
    }
  };

  loop.start();
  while (!loop.finished()) {
    drain();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  loop.join();
  drain();

  result.final_hash = state_hash(loop.state());
  // A check at the last step off the hash interval (a recording ends on its last step's hash).
  if (result.hashes.empty() || result.hashes.back().first != loop.state().step)
    result.hashes.emplace_back(loop.state().step, result.final_hash);
  const LoopCounters counters = loop.counters();
  result.commands_rejected = counters.commands_rejected;
  result.latency.steps = result.steps;
  if (result.steps > 0) result.mean_contacts /= static_cast<double>(result.steps);
  if (result.steps > 0 && (!last_moving_step || *last_moving_step < loop.state().step))
    result.time_to_rest_s = static_cast<double>(last_moving_step.value_or(0)) * model.settings.dt;
  for (const ForceWindowMeasure& m : force_windows)
    if (m.steps > 0 && m.mean() > 0.0)
      result.force_ripple = std::max(result.force_ripple.value_or(0.0), m.deviation() / m.mean());
  result.latency.compute = summarize_times(compute_ns);
  result.latency.lateness = summarize_times(lateness_ns);
  result.latency.deadline_misses = counters.deadline_misses;
  result.latency.overruns = counters.overruns;
  result.latency.realtime_priority = counters.realtime_priority;
  result.latency.memory_locked = counters.memory_locked;

  std::vector<AssertionResult>& out = result.assertions;
  {
    AssertionResult a;
    a.name = "run.steps";
    a.measured = std::to_string(result.steps) + " steps";
    a.limit = "== " + std::to_string(script.steps) + " steps";
    a.passed = result.steps == script.steps;
    out.push_back(a);
  }
  if (result.commands_rejected) {
    AssertionResult a;
    a.name = "run.commands_rejected";
    a.measured = std::to_string(result.commands_rejected);
    a.limit = "== 0";
    a.passed = false;
    out.push_back(a);
  }
  const bool fast = run_options.pacing == Pacing::Fast || !run_options.check_latency;
  const bool skip_compute = !run_options.check_latency;
  const LatencyLimits& lat = script.latency;
  check_upper(out, "latency.compute_p50_us", "", lat.compute_p50_us, result.latency.compute.p50_us, "us", skip_compute);
  check_upper(out, "latency.compute_p99_us", "", lat.compute_p99_us, result.latency.compute.p99_us, "us", skip_compute);
  check_upper(out, "latency.compute_max_us", "", lat.compute_max_us, result.latency.compute.max_us, "us", skip_compute);
  check_upper(out, "latency.lateness_p50_us", "", lat.lateness_p50_us, result.latency.lateness.p50_us, "us", fast);
  check_upper(out, "latency.lateness_p99_us", "", lat.lateness_p99_us, result.latency.lateness.p99_us, "us", fast);
  check_upper(out, "latency.lateness_max_us", "", lat.lateness_max_us, result.latency.lateness.max_us, "us", fast);
  if (lat.deadline_misses) {
    check_upper(out, "latency.deadline_misses", "", static_cast<double>(*lat.deadline_misses),
                static_cast<double>(result.latency.deadline_misses), "steps", fast);
  }
  if (script.stability.finite) {
    AssertionResult a;
    a.name = "stability.finite";
    a.measured = result.finite ? "finite" : "not finite from step " + std::to_string(*result.first_non_finite_step);
    a.limit = "finite";
    a.passed = result.finite;
    out.push_back(a);
  }
  check_upper(out, "stability.energy_max_j", "", script.stability.energy_max_j, result.max_energy_j, "J", false,
              result.max_energy_step);
  if (script.stability.energy_gain_max_j) {
    AssertionResult a;
    a.name = "stability.energy_gain_max_j";
    const double energy_at_max = result.max_energy_gain_j + result.initial_energy_j + result.probe_work_at_max_gain_j;
    const double rounding = kEnergyRounding * (std::abs(energy_at_max) + std::abs(result.initial_energy_j) +
                                               std::abs(result.probe_work_at_max_gain_j));  // J
    a.measured = number(result.max_energy_gain_j, "J") + " at step " + std::to_string(result.max_energy_gain_step) +
                 " (energy " + number(energy_at_max, "J") + ", initial " + number(result.initial_energy_j, "J") +
                 " + probe work " + number(result.probe_work_at_max_gain_j, "J") + ")";
    a.limit = "<= " + number(*script.stability.energy_gain_max_j, "J") +
              " above the initial energy + probe work, to the sums' rounding (" + number(rounding, "J") + ")";
    a.passed = result.steps > 0 && result.max_energy_gain_j <= *script.stability.energy_gain_max_j + rounding;
    out.push_back(a);
  }
  check_upper(out, "stability.speed_max_m_s", "", script.stability.speed_max_m_s, result.max_speed_m_s, "m/s", false,
              result.max_speed_step);
  if (script.stability.inverted_steps_max) {
    AssertionResult a;
    a.name = "stability.inverted_steps_max";
    if (result.longest_inversion_steps == 0) {
      a.measured = "no cell inside out";
    } else {
      const Index object = model.cell_object[result.longest_inversion_cell];
      a.measured = std::to_string(result.longest_inversion_steps) + " steps (cell " +
                   std::to_string(result.longest_inversion_cell - model.objects[object].cell_begin) + " of '" +
                   model.objects[object].name + "', to step " + std::to_string(result.longest_inversion_step) +
                   "); at most " + std::to_string(result.most_inverted_cells) + " cells at once (step " +
                   std::to_string(result.most_inverted_step) + ")";
    }
    a.limit = "<= " + std::to_string(*script.stability.inverted_steps_max) + " consecutive steps inside out";
    a.passed = result.steps > 0 && result.longest_inversion_steps <= *script.stability.inverted_steps_max;
    out.push_back(a);
  }
  check_upper(out, "contact.max_penetration_m", "", script.contact.max_penetration_m, result.max_penetration_m, "m",
              false, result.max_penetration_step);
  if (script.contact.min_contacts) {
    AssertionResult a;
    a.name = "contact.min_contacts";
    const bool measured = result.min_contacts != ~std::uint64_t{0};
    a.measured = measured ? std::to_string(result.min_contacts) + " at step " + std::to_string(result.min_contacts_step) +
                                " (mean over the run " + number(result.mean_contacts, "per step") + ")"
                          : "no steps in the window";
    a.limit = ">= " + std::to_string(*script.contact.min_contacts) + " every step from step " +
              std::to_string(script.contact.contacts_from_step + 1);
    a.passed = measured && result.min_contacts >= *script.contact.min_contacts;
    out.push_back(a);
  }
  for (std::size_t i = 0; i < script.gaps.size(); ++i) {
    const GapLimit& g = script.gaps[i];
    const std::string name = "gap[" + g.a + ", " + g.b + "]";
    if (gaps[i].samples == 0) {
      AssertionResult a;
      a.name = name;
      a.where = g.where;
      a.measured = "no samples (snapshots dropped or the run ended early)";
      a.limit = "at least one sample";
      a.passed = false;
      out.push_back(a);
      continue;
    }
    check_upper(out, name + ".max_gap_m", g.where, g.max_gap_m, gaps[i].max_gap_m, "m", false, gaps[i].worst_gap_step);
    check_upper(out, name + ".max_penetration_m", g.where, g.max_penetration_m, gaps[i].max_penetration_m, "m", false,
                gaps[i].worst_penetration_step);
  }
  for (std::size_t i = 0; i < script.intersections.size(); ++i) {
    const IntersectionLimit& limit = script.intersections[i];
    const IntersectionMeasure& m = intersections[i];
    AssertionResult a;
    a.name = "intersections.max_pairs";
    a.where = limit.where;
    a.measured = m.samples ? std::to_string(m.max_pairs) + " at step " + std::to_string(m.worst_step)
                           : "no samples (snapshots dropped or the run ended early)";
    a.limit = "<= " + std::to_string(limit.max_pairs) + " from step " + std::to_string(limit.from_step) + " to " +
              std::to_string(limit.to_step);
    a.passed = m.samples > 0 && m.max_pairs <= limit.max_pairs;
    out.push_back(a);
  }
  for (std::size_t i = 0; i < script.positions.size(); ++i) {
    const PositionLimit& p = script.positions[i];
    const PositionMeasure& m = positions[i];
    AssertionResult a;
    a.name = "position[" + p.pattern + (p.relative_to ? " - " + p.relative_to_name : std::string()) + "]";
    a.where = p.where;
    a.limit = "within " + vector_text(p.min) + " .. " + vector_text(p.max) + " m";
    if (m.samples == 0) {
      a.measured = "no samples (snapshots dropped or the run ended early)";
      a.passed = false;
    } else if (m.worst_outside_m > 0.0) {
      a.measured = model.objects[m.worst_object].name + " at " + vector_text(m.worst_position) + " m at step " +
                   std::to_string(m.worst_step) + ", " + number(m.worst_outside_m, "m") + " outside";
      a.passed = false;
    } else {
      a.measured = "from " + vector_text(m.low) + " to " + vector_text(m.high) + " m over " +
                   std::to_string(m.samples) + " samples";
    }
    out.push_back(a);
  }
  if (script.rest.speed_max_m_s) {
    AssertionResult a;
    a.name = "rest.speed_max_m_s";
    a.limit = "<= " + number(*script.rest.speed_max_m_s, "m/s") + " from step " + std::to_string(script.rest.from_step);
    if (rest_samples == 0) {
      a.measured = "no samples (snapshots dropped or the run ended early)";
      a.passed = false;
    } else {
      a.measured = number(rest_max_speed, "m/s") + " (" + model.objects[rest_worst_object].name + ", step " +
                   std::to_string(rest_worst_step) + ")";
      a.passed = rest_max_speed <= *script.rest.speed_max_m_s;
    }
    out.push_back(a);
  }
  if (script.motion.rms_speed_max_m_s || script.motion.kinetic_energy_max_j || script.motion.speed_max_m_s) {
    if (motion_steps == 0) {
      AssertionResult a;
      a.name = "motion";
      a.measured = "no steps after step " + std::to_string(script.motion.from_step);
      a.limit = "at least one step";
      a.passed = false;
      out.push_back(a);
    } else {
      const std::string from = " from step " + std::to_string(script.motion.from_step + 1);
      check_upper(out, "motion.rms_speed_max_m_s" + from, "", script.motion.rms_speed_max_m_s, motion_rms, "m/s", false,
                  motion_rms_step);
      check_upper(out, "motion.kinetic_energy_max_j" + from, "", script.motion.kinetic_energy_max_j, motion_kinetic, "J",
                  false, motion_kinetic_step);
      check_upper(out, "motion.speed_max_m_s" + from, "", script.motion.speed_max_m_s, motion_fastest, "m/s", false,
                  motion_fastest_step);
    }
  }
  for (std::size_t i = 0; i < script.creeps.size(); ++i) {
    const CreepLimit& c = script.creeps[i];
    const CreepMeasure& m = creeps[i];
    AssertionResult a;
    a.name = "creep[" + c.pattern + "]";
    a.where = c.where;
    a.limit = "<= " + number(c.max_m, "m") + " from step " + std::to_string(c.from_step) + " to " + std::to_string(c.to_step);
    if (m.samples < 2) {
      a.measured = "fewer than two samples (snapshots dropped or the run ended early)";
      a.passed = false;
    } else {
      a.measured = number(m.worst_m, "m") + " (" + model.objects[m.worst_object].name + ", step " +
                   std::to_string(m.worst_step) + ")";
      a.passed = m.worst_m <= c.max_m;
    }
    out.push_back(a);
  }
  for (std::size_t i = 0; i < script.force_windows.size(); ++i) {
    const ForceWindow& w = script.force_windows[i];
    const ForceWindowMeasure& m = force_windows[i];
    AssertionResult a;
    a.name = "force_window[" + std::to_string(w.from_step) + ", " + std::to_string(w.to_step) + "]";
    a.where = w.where;
    std::string limit;
    if (w.relative_std_max) limit += "deviation <= " + number(100.0 * *w.relative_std_max, "%") + " of the mean";
    if (w.mean_min_n) limit += std::string(limit.empty() ? "" : ", ") + "mean >= " + number(*w.mean_min_n, "N");
    if (w.mean_max_n) limit += std::string(limit.empty() ? "" : ", ") + "mean <= " + number(*w.mean_max_n, "N");
    if (w.above_previous) limit += std::string(limit.empty() ? "" : ", ") + "mean above the window before";
    a.limit = limit;
    if (m.steps == 0) {
      a.measured = "no steps in the window";
      a.passed = false;
    } else {
      const double mean = m.mean(), deviation = m.deviation();
      a.measured = "mean " + number(mean, "N") + ", deviation " + number(deviation, "N") + " (" +
                   number(mean > 0.0 ? 100.0 * deviation / mean : 0.0, "%") + "), from " + number(m.low, "N") + " to " +
                   number(m.high, "N");
      a.passed = true;
      if (w.relative_std_max) a.passed = a.passed && mean > 0.0 && deviation <= *w.relative_std_max * mean;
      if (w.mean_min_n) a.passed = a.passed && mean >= *w.mean_min_n;
      if (w.mean_max_n) a.passed = a.passed && mean <= *w.mean_max_n;
      if (w.above_previous) a.passed = a.passed && mean > force_windows[i - 1].mean();
    }
    out.push_back(a);
  }
  check_upper(out, "force.max_n", "", script.force.max_n, result.peak_force_n, "N", false, result.peak_force_step);
  if (script.force.peak_min_n) {
    AssertionResult a;
    a.name = "force.peak_min_n";
    a.measured = number(result.peak_force_n, "N");
    a.limit = ">= " + number(*script.force.peak_min_n, "N");
    a.passed = result.peak_force_n >= *script.force.peak_min_n;
    out.push_back(a);
  }
  if (!script.hashes.empty()) {
    AssertionResult a;
    a.name = "determinism.state_hash";
    std::size_t checked = 0;
    std::optional<std::uint64_t> last_equal;
    for (const HashCheck& h : script.hashes) {
      const auto it = std::find_if(result.hashes.begin(), result.hashes.end(),
                                   [&](const auto& p) { return p.first == h.step; });
      if (it == result.hashes.end()) continue;
      ++checked;
      if (it->second == h.value) {
        last_equal = h.step;
        continue;
      }
      // The first check that differs: the run diverged after the last equal one.
      result.first_divergence = h.step;
      a.passed = false;
      a.where = h.where;
      a.measured = "diverged: state hash at step " + std::to_string(h.step) + " is " + hash_hex(it->second) + " (" +
                   (last_equal ? "last equal at step " + std::to_string(*last_equal) : "no earlier check") + ")";
      a.limit = "== " + hash_hex(h.value);
      break;
    }
    if (a.passed) {
      a.measured = std::to_string(checked) + " of " + std::to_string(script.hashes.size()) + " hashes equal";
      a.limit = "all equal";
      a.passed = checked == script.hashes.size();
    }
    out.push_back(a);
  }
  return result;
}

std::string format_replay_result(const ReplayScript& script, const ReplayResult& result) {
  std::ostringstream s;
  const LatencyReport& l = result.latency;
  s << script.path << ": " << result.steps << " steps, "
    << (result.pacing == Pacing::Fast ? "fast" : "real time") << "\n";
  char line[256];
  std::snprintf(line, sizeof line, "  compute  us: p50 %.1f  p99 %.1f  p99.9 %.1f  max %.1f\n", l.compute.p50_us,
                l.compute.p99_us, l.compute.p999_us, l.compute.max_us);
  s << line;
  if (result.pacing == Pacing::RealTime) {
    std::snprintf(line, sizeof line, "  lateness us: p50 %.1f  p99 %.1f  p99.9 %.1f  max %.1f; deadline misses %llu\n",
                  l.lateness.p50_us, l.lateness.p99_us, l.lateness.p999_us, l.lateness.max_us,
                  static_cast<unsigned long long>(l.deadline_misses));
    s << line;
  }
  std::size_t failed = 0;
  for (const AssertionResult& a : result.assertions) {
    const char* verdict = a.skipped ? "SKIP" : a.passed ? "PASS" : "FAIL";
    if (!a.passed) ++failed;
    s << verdict << ' ' << a.name << ": " << a.measured << " (limit " << a.limit << ")";
    if (a.skipped) s << " [not checked in this run]";
    if (!a.passed && !a.where.empty()) s << " at " << a.where;
    s << "\n";
  }
  s << (failed ? "FAILED: " + std::to_string(failed) + " of " : "passed: all ")
    << result.assertions.size() << " assertions" << "\n";
  return s.str();
}

std::string replay_result_json(const ReplayScript& script, const ReplayResult& result) {
  using nlohmann::json;
  auto dist = [](const TimeSummary& d) {
    return json{{"p50_us", d.p50_us}, {"p99_us", d.p99_us}, {"p99_9_us", d.p999_us}, {"max_us", d.max_us}};
  };
  json j;
  j["script"] = script.path;
  j["scene"] = script.scene_origin;
  j["mode"] = result.pacing == Pacing::Fast ? "fast" : "realtime";
  j["steps"] = result.steps;
  j["mean_contacts"] = result.mean_contacts;
  j["passed"] = result.passed();
  j["latency"] = {{"compute", dist(result.latency.compute)},
                  {"lateness", dist(result.latency.lateness)},
                  {"deadline_misses", result.latency.deadline_misses},
                  {"overruns", result.latency.overruns},
                  {"sched_fifo", result.latency.realtime_priority},
                  {"memory_locked", result.latency.memory_locked}};
  j["finite"] = result.finite;
  j["max_energy_j"] = result.max_energy_j;
  j["initial_energy_j"] = result.initial_energy_j;
  j["probe_work_j"] = result.probe_work_j;
  if (script.stability.energy_gain_max_j) j["max_energy_gain_j"] = result.max_energy_gain_j;
  j["max_speed_m_s"] = result.max_speed_m_s;
  if (script.stability.inverted_steps_max) {
    j["longest_inversion_steps"] = result.longest_inversion_steps;
    j["most_inverted_cells"] = result.most_inverted_cells;
  }
  j["max_penetration_m"] = result.max_penetration_m;
  j["peak_force_n"] = result.peak_force_n;
  j["final_state_hash"] = hash_hex(result.final_hash);
  json assertions = json::array();
  for (const AssertionResult& a : result.assertions) {
    assertions.push_back({{"name", a.name},
                          {"where", a.where},
                          {"result", a.skipped ? "skip" : a.passed ? "pass" : "fail"},
                          {"measured", a.measured},
                          {"limit", a.limit}});
  }
  j["assertions"] = assertions;
  return j.dump(2) + "\n";
}

}  // namespace ffd
