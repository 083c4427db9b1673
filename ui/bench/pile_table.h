#pragma once
// Random piles (ffd/random_pile.h) at each accuracy level and response: do the surfaces end
// apart, and how long does a crossing last? `ffdsim piles` runs a set of seeds and prints a
// table; the tests run a short set.
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "bench/paper_table.h"
#include "ffd/model.h"

namespace ffdbench {

struct PileRun {
  std::uint64_t seed = 0;
  ffd::Accuracy level = ffd::Accuracy::CentreOfMass;
  ffd::ContactResponse response = ffd::ContactResponse::Paper;
  bool box_overlap = false;    // the scene's [simulation] box_overlap
  bool edge_contacts = false;  // the scene's [simulation] edge_contacts (the paper's response has them at levels 4 and 5 always)
  bool substeps = false;       // the solver's sweeps ran as substeps ([simulation] solver_substeps)
  int iterations = 0;          // the objects' mass_spring.iterations (a pile gives every object the same)
  std::uint64_t steps = 0, sample_every = 0;
  // Intersecting triangle pairs (surface_intersections.h: between objects and within one,
  // rest-shape pairs left out) every `sample_every` steps, from the start.
  std::vector<std::size_t> pairs;
  std::size_t pairs_max = 0;
  std::size_t last_second_max = 0;  // over the samples of the run's last second
  // The longest run of consecutive samples in which one pair of objects (or one object with
  // itself) crossed, ms (samples x sample interval), and which objects; 0 and "" for none.
  double longest_crossing_ms = 0.0;
  std::string longest_between;
  bool at_rest = false;  // at the end, every object's RMS lattice-node speed below 5 cm/s
  double step_p50_ms = 0.0, step_p99_ms = 0.0;
  bool finite = true;
  // The bar (issue: surfaces that never stay inside each other): finite, at rest, no pair in
  // the last second, no crossing longer than 50 ms.
  bool clean() const { return finite && at_rest && last_second_max == 0 && longest_crossing_ms <= 50.0; }
};

// Runs the pile `model` (seed `seed`, for the record) for `steps` steps at `level` under
// `response`, counting crossings every `sample_every` steps outside the timed step.
PileRun run_pile(const ffd::Model& model, std::uint64_t seed, ffd::Accuracy level, ffd::ContactResponse response,
                 std::uint64_t steps, std::uint64_t sample_every, const Progress& progress, int threads = 1);

// Markdown: a row per response and level over all seeds (clean piles, pairs, longest crossing,
// step time); and a line per run that is not clean (empty if none).
std::string markdown_piles(const std::vector<PileRun>& runs, const std::string& cpu, int objects);
std::string markdown_unclean_piles(const std::vector<PileRun>& runs);
nlohmann::json to_json(const std::vector<PileRun>& runs);

}  // namespace ffdbench
