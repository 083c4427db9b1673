#include "bench/accuracy_table.h"

#include "ffd/worker_pool.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

#include "ffd/measure.h"
#include "ffd/step.h"
#include "ffd/surface_intersections.h"

namespace ffdbench {

namespace {

// An object is at rest when its lattice nodes' RMS speed (mass-weighted: its kinetic energy
// as a speed) is below this. Not its fastest node: a resting lattice keeps a node or two
// jittering between eq. 9's push and its springs (the hard bunnies: one node at 8-9 cm/s
// among 2,700 whose RMS speed is 0.5-1 cm/s).
constexpr double kRestSpeed = 0.05;  // m/s

}  // namespace

double resting_gap(const ffd::Model& model, const ffd::State& state, const ffd::SurfaceContactReport& contacts) {
  double worst = -1.0;
  for (const ffd::ObjectModel& object : model.objects) {
    if (!(rms_speed(model, state, object) <= kRestSpeed)) continue;
    // What it rests on is what it is nearest to; nothing within the search radius counts as
    // a gap of that radius (a lower bound).
    double nearest = contacts.search_radius_m;
    for (const ffd::SurfaceContact& c : contacts.contacts)
      if (c.a == object.name || c.b == object.name) nearest = std::min(nearest, c.penetration_m > 0.0 ? 0.0 : c.gap_m);
    worst = std::max(worst, nearest);
  }
  return worst;
}

AccuracyRun run_accuracy(const ffd::Model& model, const std::string& scene, ffd::Accuracy level, std::uint64_t steps,
                         std::uint64_t sample_every, const Progress& progress, int threads, ffd::ContactResponse response) {
  AccuracyRun run;
  run.scene = scene;
  run.level = level;
  run.response = response;
  run.steps = steps;
  ffd::State state = initial_state_at(model, level, response);
  ffd::Scratch scratch = ffd::make_scratch(model);
  ffd::WorkerPool pool(threads);
  ffd::attach_pool(model, scratch, pool);
  ffd::StepReport report;
  std::vector<double> collision_ms, step_ms, gaps, penetrations, penetrating, intersections;
  const ffd::SurfaceIntersections crossings(model);  // each surface's rest-shape pairs, found once
  collision_ms.reserve(steps);
  step_ms.reserve(steps);
  const std::string what = scene + ": level " + std::to_string(static_cast<int>(level)) + ", " + ffd::response_name(response);
  const std::uint64_t report_every = std::max<std::uint64_t>(1, steps / 100);
  for (std::uint64_t i = 1; i <= steps; ++i) {
    ffd::step(model, state, scratch, report);
    ffd::grow_scratch(model, scratch, report);
    run.finite = run.finite && report.finite;
    const std::int64_t collision_ns = stage(report, ffd::Stage::BoxUpdate) + stage(report, ffd::Stage::BroadPhase) +
                                      stage(report, ffd::Stage::NarrowPhase) + stage(report, ffd::Stage::Planes);
    collision_ms.push_back(static_cast<double>(collision_ns) * 1e-6);
    step_ms.push_back(static_cast<double>(report.total_ns) * 1e-6);
    if (i > steps / 2 && i % sample_every == 0 && run.finite) {
      const ffd::SurfaceContactReport contacts = ffd::measure_surface_contacts(model, state);
      const double gap = resting_gap(model, state, contacts);
      if (gap >= 0.0) gaps.push_back(gap * 1e3);
      penetrations.push_back(contacts.max_penetration_m * 1e3);
      penetrating.push_back(static_cast<double>(contacts.penetrating_vertices));
      run.penetrating_vertices_max = std::max(run.penetrating_vertices_max, contacts.penetrating_vertices);
      const std::size_t pairs = crossings.count(state).total();
      intersections.push_back(static_cast<double>(pairs));
      run.intersections_max = std::max(run.intersections_max, pairs);
    }
    if (i % report_every == 0 || i == steps) progress(what, i, steps);
  }
  run.samples = penetrations.size();
  run.rest_samples = gaps.size();
  run.collision_p50_ms = percentile(collision_ms, 0.5);
  run.collision_p99_ms = percentile(collision_ms, 0.99);
  run.step_p50_ms = percentile(step_ms, 0.5);
  run.gap_mean_mm = mean(gaps);
  run.gap_max_mm = gaps.empty() ? 0.0 : *std::max_element(gaps.begin(), gaps.end());
  run.penetration_mean_mm = mean(penetrations);
  run.penetration_max_mm = penetrations.empty() ? 0.0 : *std::max_element(penetrations.begin(), penetrations.end());
  run.penetrating_vertices_mean = mean(penetrating);
  run.intersections_mean = mean(intersections);
  run.intersecting_share = intersections.empty()
                               ? 0.0
                               : static_cast<double>(std::count_if(intersections.begin(), intersections.end(),
                                                                   [](double n) { return n > 0.0; })) /
                                     static_cast<double>(intersections.size());
  return run;
}

namespace {

const AccuracyRun* find_run(const std::vector<AccuracyRun>& runs, const std::string& scene, ffd::Accuracy level,
                            ffd::ContactResponse response) {
  for (const AccuracyRun& r : runs)
    if (r.scene == scene && r.level == level && r.response == response) return &r;
  return nullptr;
}

std::string gap_text(const AccuracyRun& r) { return r.rest_samples ? fixed(r.gap_max_mm, 2) + " mm" : "none at rest"; }

std::vector<std::string> scenes_of(const std::vector<AccuracyRun>& runs) {
  std::vector<std::string> scenes;
  for (const AccuracyRun& r : runs)
    if (std::find(scenes.begin(), scenes.end(), r.scene) == scenes.end()) scenes.push_back(r.scene);
  return scenes;
}

}  // namespace

std::string markdown_accuracy(const std::vector<AccuracyRun>& runs, const std::string& cpu, std::uint64_t steps) {
  std::ostringstream s;
  s << "Measured by `ffdsim accuracy` on " << cpu << ": each scene run " << steps
    << " steps (1 ms) at every level from the same start. Collision = box update + broad + narrow phase + planes, "
       "per step. Gap, penetration and penetrating vertices are measured on the exact embedded surfaces every 50 ms "
       "over the second half of the run. Gap: the widest gap between an object at rest (RMS speed of its lattice "
       "nodes below 5 cm/s) and the surface or floor it rests on; penetration: the deepest pair; penetrating vertices: "
       "summed over the pairs; intersecting pairs: triangle pairs of the surfaces that cross (between objects and "
       "within one, each surface's rest-shape crossings left out; exact predicates), with the share of samples that "
       "have any. Mean and max over the samples. Response: how the contacts were answered (paper: at "
       "once by eq. 7-9; solver: as constraints with the springs, whose time is then in the step, not in the "
       "collision column).\n\n";
  for (const std::string& scene : scenes_of(runs)) {
    s << "**" << scene << "**\n\n"
      << "| level | response | collision ms p50 | p99 | step ms p50 | gap mm mean | max | penetration mm mean | max | "
         "penetrating vertices mean | max | intersecting pairs mean | max | samples with any |\n"
      << "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const AccuracyRun& r : runs) {
      if (r.scene != scene) continue;
      s << "| " << static_cast<int>(r.level) << " " << ffd::accuracy_name(r.level) << (r.finite ? "" : " (NOT FINITE)")
        << " | " << ffd::response_name(r.response) << " | " << fixed(r.collision_p50_ms, 3) << " | " << fixed(r.collision_p99_ms, 3) << " | "
        << fixed(r.step_p50_ms, 2) << " | " << (r.rest_samples ? fixed(r.gap_mean_mm, 2) : "none at rest") << " | "
        << (r.rest_samples ? fixed(r.gap_max_mm, 2) : "-") << " | "
        << fixed(r.penetration_mean_mm, 2) << " | " << fixed(r.penetration_max_mm, 2) << " | "
        << fixed(r.penetrating_vertices_mean, 0) << " | " << r.penetrating_vertices_max << " | "
        << fixed(r.intersections_mean, 0) << " | " << r.intersections_max << " | "
        << fixed(100.0 * r.intersecting_share, 0) << " % |\n";
    }
    for (const ffd::ContactResponse response : {ffd::ContactResponse::Paper, ffd::ContactResponse::Solver}) {
      // Under the response "paper" the lines read as they always did; under "solver" they say so.
      const std::string under =
          response == ffd::ContactResponse::Paper ? "" : std::string(" (response ") + ffd::response_name(response) + ")";
      const AccuracyRun* paper = find_run(runs, scene, ffd::Accuracy::CentreOfMass, response);
      const AccuracyRun* exact = find_run(runs, scene, ffd::Accuracy::Exact, response);
      if (paper && exact && paper->collision_p50_ms > 0.0) {
        s << "\nLevel 2 (the paper's) against level 5 (exact)" << under << ": "
          << fixed(exact->collision_p50_ms / paper->collision_p50_ms, 1) << "x cheaper per step; gap max "
          << gap_text(*paper) << " vs " << gap_text(*exact) << "; penetration max " << fixed(paper->penetration_max_mm, 2)
          << " mm vs " << fixed(exact->penetration_max_mm, 2) << " mm.\n";
      }
      const AccuracyRun* surface = find_run(runs, scene, ffd::Accuracy::SampleNodes, response);
      if (paper && surface && paper->collision_p50_ms > 0.0) {
        s << "\nLevel 3 (surface nodes) against level 2" << under << ": "
          << fixed(surface->collision_p50_ms / paper->collision_p50_ms, 2) << "x the collision time; gap max "
          << gap_text(*surface) << " vs " << gap_text(*paper) << "; penetration max "
          << fixed(surface->penetration_max_mm, 2) << " mm vs " << fixed(paper->penetration_max_mm, 2) << " mm.\n";
      }
    }
    s << "\n";
  }
  return s.str();
}

nlohmann::json to_json(const std::vector<AccuracyRun>& runs) {
  nlohmann::json out = nlohmann::json::array();
  for (const AccuracyRun& r : runs) {
    out.push_back({{"scene", r.scene},
                   {"level", static_cast<int>(r.level)},
                   {"level_name", ffd::accuracy_name(r.level)},
                   {"response", ffd::response_name(r.response)},
                   {"steps", r.steps},
                   {"samples", r.samples},
                   {"rest_samples", r.rest_samples},
                   {"collision_p50_ms", r.collision_p50_ms},
                   {"collision_p99_ms", r.collision_p99_ms},
                   {"step_p50_ms", r.step_p50_ms},
                   {"gap_mean_mm", r.gap_mean_mm},
                   {"gap_max_mm", r.gap_max_mm},
                   {"penetration_mean_mm", r.penetration_mean_mm},
                   {"penetration_max_mm", r.penetration_max_mm},
                   {"penetrating_vertices_mean", r.penetrating_vertices_mean},
                   {"penetrating_vertices_max", r.penetrating_vertices_max},
                   {"intersections_mean", r.intersections_mean},
                   {"intersections_max", r.intersections_max},
                   {"intersecting_share", r.intersecting_share},
                   {"finite", r.finite}});
  }
  return out;
}

std::string gnuplot_script(const std::vector<AccuracyRun>& runs, const std::string& png) {
  std::ostringstream s;
  s << "set terminal pngcairo size 1100,480 font 'DejaVu Sans,10' noenhanced\n"
    << "set output '" << png << "'\n"
    << "set multiplot layout 1,2 title 'What accuracy costs: contact error against collision time per step "
       "(numbers: accuracy level)'\n"
    << "set logscale x\nset grid\nset key top right\nset offsets 0, 0, graph 0.1, 0\n"
    << "set xlabel 'collision time per step, ms (p50, log scale)'\n";
  const char* panels[2][2] = {{"gap", "widest gap between surfaces at rest, mm (max)"},
                              {"penetration", "deepest penetration, mm (max)"}};
  for (const auto& panel : panels) {
    const bool gap = std::string(panel[0]) == "gap";
    // A level where nothing came to rest has no gap to show.
    auto shown = [gap](const AccuracyRun& r) { return !gap || r.rest_samples > 0; };
    // A series per scene and response.
    struct Series {
      std::string scene;
      ffd::ContactResponse response;
    };
    std::vector<Series> scenes;
    for (const std::string& scene : scenes_of(runs))
      for (const ffd::ContactResponse response : {ffd::ContactResponse::Paper, ffd::ContactResponse::Solver})
        if (std::any_of(runs.begin(), runs.end(),
                        [&](const AccuracyRun& r) { return r.scene == scene && r.response == response && shown(r); }))
          scenes.push_back({scene, response});
    const bool both = std::any_of(runs.begin(), runs.end(), [](const AccuracyRun& r) {
      return r.response != ffd::ContactResponse::Paper;
    });
    s << "set ylabel '" << panel[1] << "'\n";
    if (scenes.empty()) {
      s << "set label 1 'nothing came to rest' at graph 0.5, 0.5 center\nplot [1:10] [0:1] NaN notitle\nunset label 1\n";
      continue;
    }
    s << "plot ";
    for (std::size_t i = 0; i < scenes.size(); ++i) {
      const std::string title =
          both ? scenes[i].scene + ", " + ffd::response_name(scenes[i].response) : scenes[i].scene;
      s << (i ? ", " : "") << "'-' using 1:2 with points pt 7 ps 1.3 lc " << i + 1 << " title '" << title
        << "', '-' using 1:2:3 with labels offset 0.8,0.8 tc lt " << i + 1 << " notitle";
    }
    s << "\n";
    for (const Series& series : scenes)
      for (int copy = 0; copy < 2; ++copy) {
        for (const AccuracyRun& r : runs) {
          if (r.scene != series.scene || r.response != series.response || !shown(r)) continue;
          const double y = gap ? r.gap_max_mm : r.penetration_max_mm;
          s << std::max(r.collision_p50_ms, 1e-3) << " " << y << " " << static_cast<int>(r.level) << "\n";
        }
        s << "e\n";
      }
  }
  s << "unset multiplot\n";
  return s.str();
}

}  // namespace ffdbench
