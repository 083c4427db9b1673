#include "bench/pile_table.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>
#include <utility>

#include "ffd/random_pile.h"
#include "ffd/step.h"
#include "ffd/surface_intersections.h"
#include "ffd/worker_pool.h"

namespace ffdbench {

namespace {

constexpr double kRestSpeed = 0.05;  // m/s, RMS lattice-node speed of an object at rest (as accuracy_table.cpp)

bool all_at_rest(const ffd::Model& model, const ffd::State& state) {
  for (const ffd::ObjectModel& object : model.objects)
    if (!(rms_speed(model, state, object) <= kRestSpeed)) return false;
  return true;
}

// A row's response as the table names it, by what differs from the defaults: "paper",
// "paper + box_overlap", "solver without edge_contacts", "solver + solver_substeps".
std::string response_label(ffd::ContactResponse response, bool box_overlap, bool edge_contacts, bool substeps) {
  return std::string(ffd::response_name(response)) + (box_overlap ? " + box_overlap" : "") +
         (edge_contacts ? "" : " without edge_contacts") + (substeps ? " + solver_substeps" : "");
}

}  // namespace

PileRun run_pile(const ffd::Model& model, std::uint64_t seed, ffd::Accuracy level, ffd::ContactResponse response,
                 std::uint64_t steps, std::uint64_t sample_every, const Progress& progress, int threads) {
  PileRun run;
  run.seed = seed;
  run.level = level;
  run.response = response;
  run.box_overlap = model.settings.box_overlap;
  run.edge_contacts = model.settings.edge_contacts;
  run.substeps = response == ffd::ContactResponse::Solver && model.settings.solver_substeps;
  run.iterations = model.objects.empty() ? 0 : model.objects.front().mass_spring.iterations;
  run.steps = steps;
  run.sample_every = sample_every;
  ffd::State state = initial_state_at(model, level, response);
  ffd::Scratch scratch = ffd::make_scratch(model);
  ffd::WorkerPool pool(threads);
  ffd::attach_pool(model, scratch, pool);
  ffd::StepReport report;
  const ffd::SurfaceIntersections crossings(model);

  std::vector<double> step_ms;
  step_ms.reserve(steps);
  // Per pair of objects crossing now: the sample at which its crossing began.
  std::map<std::pair<ffd::Index, ffd::Index>, std::size_t> crossing_since;
  const double sample_ms = static_cast<double>(sample_every) * model.settings.dt * 1e3;
  const auto close = [&](const std::pair<ffd::Index, ffd::Index>& objects, std::size_t since, std::size_t until) {
    const double ms = static_cast<double>(until - since) * sample_ms;
    if (ms > run.longest_crossing_ms) {
      run.longest_crossing_ms = ms;
      run.longest_between = model.objects[objects.first].name + " / " + model.objects[objects.second].name;
    }
  };
  const auto steps_per_second = static_cast<std::uint64_t>(std::llround(1.0 / model.settings.dt));
  const std::uint64_t last_second_from = steps > steps_per_second ? steps - steps_per_second : 0;
  const std::string what = "pile " + std::to_string(seed) + ": level " + std::to_string(static_cast<int>(level)) + ", " +
                           ffd::response_name(response);
  const std::uint64_t report_every = std::max<std::uint64_t>(1, steps / 100);
  for (std::uint64_t i = 1; i <= steps; ++i) {
    ffd::step(model, state, scratch, report);
    ffd::grow_scratch(model, scratch, report);
    run.finite = run.finite && report.finite;
    step_ms.push_back(static_cast<double>(report.total_ns) * 1e-6);
    if (!run.finite) break;
    if (i % sample_every == 0) {
      const std::vector<ffd::TrianglePair> pairs = crossings.pairs(state);
      const std::size_t sample = run.pairs.size();
      run.pairs.push_back(pairs.size());
      run.pairs_max = std::max(run.pairs_max, pairs.size());
      if (i > last_second_from) run.last_second_max = std::max(run.last_second_max, pairs.size());
      std::map<std::pair<ffd::Index, ffd::Index>, std::size_t> now;
      for (const ffd::TrianglePair& p : pairs) {
        const std::pair<ffd::Index, ffd::Index> objects{p.first.mesh, p.second.mesh};
        const auto before = crossing_since.find(objects);
        now.emplace(objects, before == crossing_since.end() ? sample : before->second);
      }
      for (const auto& [objects, since] : crossing_since)
        if (!now.count(objects)) close(objects, since, sample);
      crossing_since = std::move(now);
    }
    if (i % report_every == 0 || i == steps) progress(what, i, steps);
  }
  for (const auto& [objects, since] : crossing_since) close(objects, since, run.pairs.size());  // still crossing
  run.at_rest = run.finite && all_at_rest(model, state);
  run.step_p50_ms = percentile(step_ms, 0.5);
  run.step_p99_ms = percentile(step_ms, 0.99);
  return run;
}

std::string markdown_piles(const std::vector<PileRun>& runs, const std::string& cpu, int objects) {
  if (runs.empty()) return "No piles were run.\n";
  std::vector<std::tuple<ffd::ContactResponse, bool, bool, bool, ffd::Accuracy>> keys;
  std::vector<std::uint64_t> seeds;
  for (const PileRun& r : runs) {
    const std::tuple key{r.response, r.box_overlap, r.edge_contacts, r.substeps, r.level};
    if (std::find(keys.begin(), keys.end(), key) == keys.end()) keys.push_back(key);
    if (std::find(seeds.begin(), seeds.end(), r.seed) == seeds.end()) seeds.push_back(r.seed);
  }
  std::ostringstream s;
  const std::uint64_t steps = runs.front().steps;
  s << "Measured by `ffdsim piles` on " << cpu << ": " << seeds.size() << " random piles (seeds " << seeds.front() << "-"
    << seeds.back() << ") of " << objects
    << " objects each (rings, tori, thin plates, bowls, letters; 3 to 12 cells of 1 cm across, lattices of "
    << ffd::kPileSpringStiffness << " N/m springs swept " << runs.front().iterations << " times a step), dropped into a box and run " << steps
    << " steps (1 ms) at each level and response. Intersecting triangle pairs of the surfaces (between objects and "
       "within one) counted every "
    << runs.front().sample_every
    << " ms. Clean: at rest at the end, no pair in the last second and no crossing longer than 50 ms. Longest "
       "crossing: the longest time one pair of objects (or one object with itself) stayed crossed.\n\n";
  s << "| Response | Level | Clean piles | Pairs, mean of piles' max | Pairs in the last second, max | Longest crossing "
       "| Step p50 / p99 |\n|---|---|---|---|---|---|---|\n";
  for (const auto& [response, box_overlap, edge_contacts, substeps, level] : keys) {
    std::size_t clean = 0, count = 0, last_max = 0;
    double max_sum = 0.0, longest = 0.0, p50 = 0.0, p99 = 0.0;
    const PileRun* longest_run = nullptr;
    for (const PileRun& r : runs) {
      if (r.response != response || r.box_overlap != box_overlap || r.edge_contacts != edge_contacts ||
          r.substeps != substeps || r.level != level)
        continue;
      ++count;
      clean += r.clean() ? 1 : 0;
      max_sum += static_cast<double>(r.pairs_max);
      last_max = std::max(last_max, r.last_second_max);
      if (!longest_run || r.longest_crossing_ms > longest) {
        longest = r.longest_crossing_ms;
        longest_run = &r;
      }
      p50 += r.step_p50_ms;
      p99 = std::max(p99, r.step_p99_ms);
    }
    s << "| " << response_label(response, box_overlap, edge_contacts, substeps) << " | " << static_cast<int>(level) << " "
      << ffd::accuracy_name(level) << " | " << clean << " / " << count << " | "
      << fixed(max_sum / static_cast<double>(count), 1) << " | " << last_max << " | "
      << (longest > 0.0 ? fixed(longest, 0) + " ms (pile " + std::to_string(longest_run->seed) + ": " +
                              longest_run->longest_between + ")"
                        : std::string("none"))
      << " | " << fixed(p50 / static_cast<double>(count), 3) << " / " << fixed(p99, 3) << " ms |\n";
  }
  return s.str();
}

std::string markdown_unclean_piles(const std::vector<PileRun>& runs) {
  std::ostringstream s;
  bool header = false;
  for (const PileRun& r : runs) {
    if (r.clean()) continue;
    if (!header) s << "Piles that are not clean:\n\n";
    header = true;
    s << "- pile " << r.seed << ", " << response_label(r.response, r.box_overlap, r.edge_contacts, r.substeps) << " level "
      << static_cast<int>(r.level) << ": " << (r.finite ? "" : "NOT FINITE; ")
      << (r.at_rest ? "" : "not at rest at the end; ") << r.last_second_max << " pairs in the last second (max "
      << r.pairs_max << "), longest crossing " << fixed(r.longest_crossing_ms, 0)
      << " ms" << (r.longest_between.empty() ? "" : " (" + r.longest_between + ")") << "\n";
  }
  return s.str();
}

nlohmann::json to_json(const std::vector<PileRun>& runs) {
  nlohmann::json out = nlohmann::json::array();
  for (const PileRun& r : runs)
    out.push_back({{"seed", r.seed},
                   {"level", static_cast<int>(r.level)},
                   {"response", ffd::response_name(r.response)},
                   {"box_overlap", r.box_overlap},
                   {"edge_contacts", r.edge_contacts},
                   {"solver_substeps", r.substeps},
                   {"iterations", r.iterations},
                   {"steps", r.steps},
                   {"sample_every_steps", r.sample_every},
                   {"pairs", r.pairs},
                   {"pairs_max", r.pairs_max},
                   {"last_second_max", r.last_second_max},
                   {"longest_crossing_ms", r.longest_crossing_ms},
                   {"longest_between", r.longest_between},
                   {"at_rest", r.at_rest},
                   {"step_p50_ms", r.step_p50_ms},
                   {"step_p99_ms", r.step_p99_ms},
                   {"finite", r.finite},
                   {"clean", r.clean()}});
  return out;
}

}  // namespace ffdbench
