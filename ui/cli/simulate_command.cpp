// `ffdsim simulate`: runs a scene headless as fast as it can and reports.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>

#include "commands.h"
#include "ffd/measure.h"
#include "ffd/mesh_import.h"
#include "ffd/scene_loader.h"
#include "ffd/step.h"
#include "ffd/worker_pool.h"
#include "json_report.h"
#include "output_files.h"

namespace ffdsim {

namespace {

void print_summary(const RunSummary& run, const ffd::Model& model, const ffd::StepStatistics& stats) {
  std::printf("scene %s: %llu steps of %.3g ms\n", run.scene.c_str(), static_cast<unsigned long long>(run.steps),
              run.dt * 1e3);
  std::printf("state_hash %s  finite %s  energy %.6g J\n", ffd::hash_hex(run.state_hash).c_str(), run.finite ? "true" : "false",
              run.energy.total());
  std::printf("surface contacts: max penetration %.3g mm, max gap %.3g mm\n", run.contacts.max_penetration_m * 1e3,
              run.contacts.max_gap_m * 1e3);
  for (const ffd::SurfaceContact& c : run.contacts.contacts)
    std::printf("  %-20s %-20s penetration %8.3f mm  gap %8.3f mm\n", c.a.c_str(), c.b.c_str(), c.penetration_m * 1e3,
                c.gap_m * 1e3);
  std::printf("surface intersections: %zu triangle pairs between objects, %zu within one (the rest shapes cross in %zu, left out)\n",
              run.intersections.between, run.intersections.within, run.rest_intersections);
  std::printf("%-14s %9s %9s %9s %9s\n", "stage", "mean us", "p50 us", "p99 us", "max us");
  for (ffd::Stage stage : model.pipeline) {
    const ffd::TimeSummary t = stats.stage_time(stage);
    std::printf("%-14s %9.2f %9.2f %9.2f %9.2f\n", ffd::stage_name(stage), t.mean_us, t.p50_us, t.p99_us, t.max_us);
  }
  const ffd::TimeSummary t = stats.step_time();
  std::printf("%-14s %9.2f %9.2f %9.2f %9.2f\n", "whole step", t.mean_us, t.p50_us, t.p99_us, t.max_us);
  if (ffd::has(model.settings.effects, ffd::Effect::Sleeping))
    for (const auto& [name, c] : stats.counters(ffd::Stage::Sleep))
      if (name == "objects_asleep")
        std::printf("objects asleep: %.1f on average, at most %u of %zu\n", c.mean, c.max, model.objects.size());
}

// Resident memory of this process (bytes), from /proc/self/statm; 0 where unreadable.
double resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  double pages_total = 0.0, pages_resident = 0.0;
  if (!(statm >> pages_total >> pages_resident)) return 0.0;
  return pages_resident * static_cast<double>(sysconf(_SC_PAGESIZE));
}

// Before the first step of a large scene: what it holds in memory, about how long its steps
// will take, and what makes it smaller. The step time is a rough cost model (ns per spring,
// shape-matching member or quarter volume constraint, and per FFD AABB, measured on filled
// boxes of 10 k to 550 k nodes, Intel Xeon, 2 threads); the progress bar gives the real rate
// once steps run.
void estimate_large_scene(const ffd::Model& model, long long steps) {
  constexpr double kSecondsPerSpring = 35e-9, kSecondsPerBox = 200e-9;
  const double work = static_cast<double>(model.springs.size() + model.region_members.size() + 4 * model.tetrahedra.size());
  const double step_s = kSecondsPerSpring * work + kSecondsPerBox * static_cast<double>(model.box_count());
  const double memory = resident_bytes();
  if (step_s < 0.01 && memory < 512e6) return;  // small: a few seconds for 3000 steps
  const double total_s = step_s * static_cast<double>(steps);
  std::fprintf(stderr,
               "ffdsim: a large scene: %zu lattice nodes, %zu cells; %.2f GB in memory now; a step takes about %.3g s, "
               "%lld steps about %s\n"
               "ffdsim: a larger cell_size in each [[object]] makes it smaller (twice the size: about 8 times fewer "
               "cells, nodes and springs), as does --steps\n",
               model.node_count(), model.cell_count(), memory / 1e9, step_s, steps, duration_text(total_s).c_str());
}

}  // namespace

void register_simulate(CLI::App& app, SimulateOptions& o) {
  CLI::App* cmd = app.add_subcommand("simulate", "Run a scene headless as fast as possible and report");
  cmd->add_option("scene", o.scene, "Scene file (TOML); default: two teapots dropped on a floor");
  cmd->add_option("--steps", o.steps, "Number of fixed steps to run")->check(CLI::Range(1LL, 1000000000LL));
  cmd->add_option("--report", o.report_path, "Write the JSON run report to this file");
  add_export_options(*cmd, o.exports, /*series=*/false, /*older_names=*/true);
  add_threads_option(*cmd, o.threads);
  cmd->add_flag("--quiet,-q", o.quiet, "Print only errors");
}

int run_simulate(const SimulateOptions& o) {
  try {
    const std::string scene_path = o.scene.empty() ? ffd::default_scene_path() : o.scene;
    const ffd::SceneSpec spec = ffd::load_scene_file(scene_path);
    std::vector<std::string> log;
    const ffd::Model model = ffd::compile_scene(spec, scene_path, log);
    if (!o.quiet)
      for (const std::string& line : log) std::fprintf(stderr, "ffdsim: %s\n", line.c_str());
    if (!o.report_path.empty()) ensure_parent_folder(o.report_path);
    ffd::State state = ffd::initial_state(model);
    ffd::Scratch scratch = ffd::make_scratch(model);
    ffd::WorkerPool pool(thread_count(o.threads));
    ffd::attach_pool(model, scratch, pool);
    ffd::StepStatistics stats;
    stats.reserve(static_cast<std::size_t>(o.steps));
    ffd::StepReport report;
    if (!o.quiet) estimate_large_scene(model, o.steps);
    // On a terminal only: a log or CI gets the summary alone.
    ProgressBar progress("ffdsim simulate", o.quiet, /*lines_off_terminal=*/false);
    const std::uint64_t total = static_cast<std::uint64_t>(o.steps);
    std::vector<std::string> sources;
    for (const ffd::ObjectSpec& object : spec.objects) sources.push_back(object.source);
    std::optional<ffd::RunExports> exports;
    if (o.exports.surfaces_every > 0) exports.emplace(model, state, std::move(sources), o.exports.options());
    for (long long i = 0; i < o.steps; ++i) {
      ffd::step(model, state, scratch, report);
      stats.add(report);
      ffd::grow_scratch(model, scratch, report);
      if (exports) {
        exports->snapshot(state.step, state.x);
        if (!exports->error().empty()) throw std::runtime_error(exports->error());
      }
      progress(spec.name, static_cast<std::uint64_t>(i + 1), total);
    }
    progress.clear();
    RunSummary run;
    run.scene = spec.name;
    run.steps = state.step;
    run.dt = model.settings.dt;
    run.state_hash = ffd::state_hash(state);
    run.finite = stats.all_finite();
    run.energy = ffd::compute_energy(model, state);
    if (run.finite) {
      run.contacts = ffd::measure_surface_contacts(model, state);
      const ffd::SurfaceIntersections intersections(model);
      run.intersections = intersections.count(state);
      run.rest_intersections = intersections.rest_pairs();
    }
    const nlohmann::json json = make_report(model, run, stats);
    if (!o.report_path.empty()) {
      std::ofstream out(o.report_path);
      out << json.dump(2) << '\n';
      if (!out) throw std::runtime_error(o.report_path + ": cannot write report");
    }
    if (!o.quiet) {
      std::printf("threads %d, SIMD %s\n", pool.threads(), ffd::simd_target_name());
      print_summary(run, model, stats);
    }
    return run.finite ? kExitOk : kExitRuntime;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }
}

}  // namespace ffdsim
