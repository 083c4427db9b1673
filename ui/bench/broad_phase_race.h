#pragma once
// The broad-phase race: the same recorded FFD AABBs through our broad phase
// (ffd::BroadPhase, the code step() runs) and through FCL 0.7's
// DynamicAABBTreeCollisionManager and SpatialHashingCollisionManager, timed in one process,
// with a coverage check: every pair FCL reports as overlapping must be one of our pairs.
#include <array>
#include <cstdint>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "ffd/model.h"
#include "ffd/step.h"
#include "ffd/types.h"

namespace ffdbench {

// One recorded set of FFD AABBs: where it comes from, and the boxes.
struct BoxSet {
  std::string scenario;            // e.g. "bunnies_soft"
  std::string moment;              // "early", "mid-pile", "settled"
  std::uint64_t step = 0;
  // The compiled scene the boxes belong to (our broad phase knows its lattices, as in a step).
  std::shared_ptr<const ffd::Model> model;
  double hash_cell_size = 0.0;     // m: FCL's spatial hash cell, the scene's largest lattice cell (> 0)
  ffd::Index hash_table_size = 0;  // FCL's spatial hash buckets: 2 per box, at least 4000 (the paper's)
  std::vector<std::array<ffd::Vec3, 9>> boxes;  // 9 world nodes per box (8 corners, centre)
};

// The boxes of a stepped scene as its broad phase sees them: Scratch::box_nodes (run
// ffd::update_all_boxes first for the boxes of the current State).
BoxSet record_boxes(std::shared_ptr<const ffd::Model> model, const ffd::Scratch& scratch, std::string scenario,
                    std::string moment, std::uint64_t step);

// A scene of `count` unconnected boxes (an object of one cell each), for boxes that come from
// no lattice (synthetic sets): every pair is a pair of objects.
std::shared_ptr<const ffd::Model> unconnected_boxes(std::size_t count);

struct RaceResult {
  std::string scenario, moment;
  std::uint64_t step = 0;
  std::size_t boxes = 0;

  // Pairs (a < b, each once) whose AABBs overlap (closed: touching counts), as each reports
  // them. FCL's spatial hash hands its callback every pair sharing a bucket; the callback
  // keeps those whose AABBs overlap (fcl_hash_candidates counts them all).
  std::size_t our_pairs = 0;
  std::size_t fcl_tree_pairs = 0, fcl_hash_pairs = 0;
  std::size_t fcl_hash_candidates = 0;
  // The pairs a step wants (boxes of different objects, or of one object's cells that share
  // no lattice node), and the time ours takes to find just those.
  std::size_t wanted_pairs = 0;
  double wanted_us = 0.0;

  // Median µs per run over the repetitions, after one untimed warm-up.
  //   ours:   find_all_pairs (AABBs from the 9 nodes, object bounds, grids, pairs), buffers reused.
  //   build:  registerObjects + setup + collide on an emptied manager (clear() untimed).
  //   update: objects registered, AABBs rewritten (untimed) -> update() + collide.
  // FCL's figures exclude computing the AABBs, which ours includes. The main figure of
  // each manager is the faster of its two variants: the one fairest to FCL.
  double our_us = 0.0;
  double fcl_tree_us = 0.0, fcl_hash_us = 0.0;
  double fcl_tree_build_us = 0.0, fcl_tree_update_us = 0.0;
  double fcl_hash_build_us = 0.0, fcl_hash_update_us = 0.0;

  // Coverage: FCL pairs not among ours (must be 0), over the tree's, the hash's, and the
  // distinct pairs of both (fcl_distinct_pairs of them).
  std::size_t missing_tree = 0, missing_hash = 0, missing_any = 0;
  std::size_t fcl_distinct_pairs = 0;
  // Our pairs a manager did not report. The tree tests the same AABBs with the same closed
  // overlap, so 0 expected; FCL's spatial hash loses pairs that only touch on a hash-cell
  // boundary (a box covers cells [floor(min / cell), ceil(max / cell)) there).
  std::size_t extra_vs_tree = 0, extra_vs_hash = 0;
};

// Races one set; repetitions >= 1 timed runs per method. Throws std::invalid_argument for
// a set without its model, or a non-positive cell size or table size.
RaceResult race(const BoxSet& set, int repetitions);

// A Markdown table, one row per result, with a note on how the figures were taken.
std::string markdown_table(const std::vector<RaceResult>& results);
// The results as a JSON array of objects (field names as in RaceResult; ratios are FCL time
// over ours, null when ours measured 0).
nlohmann::json to_json(const std::vector<RaceResult>& results);

}  // namespace ffdbench
