#pragma once
// The JSON run report of `ffdsim simulate` (format in docs/command-line.md, "Run report").
#include <nlohmann/json.hpp>
#include <string>

#include "ffd/measure.h"
#include "ffd/step_statistics.h"
#include "ffd/surface_intersections.h"

namespace ffdsim {

struct RunSummary {
  std::string scene;
  std::uint64_t steps = 0;
  double dt = 0.0;
  std::uint64_t state_hash = 0;
  bool finite = true;
  ffd::SurfaceContactReport contacts;
  // Intersecting triangle pairs of the surfaces at the end, each surface's rest-shape pairs
  // left out (surface_intersections.h).
  ffd::IntersectionCount intersections;
  std::size_t rest_intersections = 0;
  ffd::Energy energy;
};

// {mean_us, p50_us, p99_us, p99_9_us, max_us}
nlohmann::json time_summary_json(const ffd::TimeSummary& t);
nlohmann::json make_report(const ffd::Model& model, const RunSummary& run, const ffd::StepStatistics& stats);

}  // namespace ffdsim
