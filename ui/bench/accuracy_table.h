#pragma once
// What accuracy costs in time: a scene run at every accuracy level (spec.h, Accuracy) from
// the same start, with the collision time per step from the step's own stage timers and the
// contact accuracy measured on the exact embedded surfaces outside the timed path (gap
// between surfaces at rest on each other, penetration, penetrating vertices, intersecting
// triangle pairs).
// `ffdsim accuracy` prints the table and plots accuracy against time per step.
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "bench/paper_table.h"
#include "ffd/measure.h"
#include "ffd/model.h"

namespace ffdbench {

struct AccuracyRun {
  std::string scene;  // the scene's name
  ffd::Accuracy level = ffd::Accuracy::CentreOfMass;
  ffd::ContactResponse response = ffd::ContactResponse::Paper;  // how the contacts were answered
  std::uint64_t steps = 0;
  std::uint64_t samples = 0;       // surface samples over the second half of the run
  std::uint64_t rest_samples = 0;  // of those, the ones where some object was at rest
  double collision_p50_ms = 0, collision_p99_ms = 0;  // box update + broad + narrow + planes
  double step_p50_ms = 0;
  // Over the surface samples of the second half of the run. Gap: in each sample with an
  // object at rest, the widest of their gaps to what they rest on (resting_gap). Penetration
  // and penetrating vertices: each sample's deepest pair and its total.
  double gap_mean_mm = 0, gap_max_mm = 0;
  double penetration_mean_mm = 0, penetration_max_mm = 0;
  double penetrating_vertices_mean = 0;
  std::size_t penetrating_vertices_max = 0;
  // Intersecting triangle pairs of the surfaces (surface_intersections.h: between objects and
  // within one, rest-shape pairs left out) over the same samples, and the share of samples
  // with any: the crossings that vertex depths miss (edge through edge).
  double intersections_mean = 0;
  std::size_t intersections_max = 0;
  double intersecting_share = 0;
  bool finite = true;
};

// The floating gap of the objects at rest (RMS lattice-node speed below 5 cm/s), m: for
// each, the distance to the nearest other surface or plane (0 where they penetrate, the
// report's search radius where nothing is that near), and the widest of those. -1 when no
// object is at rest. An object lying beside another without resting on it is nearest to what
// it does rest on, so that neighbour does not count.
double resting_gap(const ffd::Model& model, const ffd::State& state, const ffd::SurfaceContactReport& contacts);

// Runs `model` for `steps` steps at `level` under `response` on `threads` threads; samples the
// surfaces every `sample_every` steps over the second half.
AccuracyRun run_accuracy(const ffd::Model& model, const std::string& scene, ffd::Accuracy level, std::uint64_t steps,
                         std::uint64_t sample_every, const Progress& progress, int threads = 1,
                         ffd::ContactResponse response = ffd::ContactResponse::Paper);

// Markdown: one table per scene (a row per response and level), and lines per scene and
// response on what level 2 costs against levels 3 and 5.
std::string markdown_accuracy(const std::vector<AccuracyRun>& runs, const std::string& cpu, std::uint64_t steps);
nlohmann::json to_json(const std::vector<AccuracyRun>& runs);

// A gnuplot script that draws `png`: max gap and max penetration (mm) against the collision
// time per step (ms, p50), one series per scene, points labelled with their level.
std::string gnuplot_script(const std::vector<AccuracyRun>& runs, const std::string& png);

}  // namespace ffdbench
