#pragma once
// Collision stages: FFD AABB update (section 4), spatial-hash broad phase (6.1), node-in-box
// narrow phase with immediate response (6.2, 7, Algorithm 1) and static planes.
#include "ffd/model.h"
#include "ffd/step.h"

namespace ffd {

// Eq. 2 for the 9 nodes of box b from its cell's 8 lattice nodes; marks it valid.
void update_box(const Model& model, const State& state, Scratch& scratch, Index b);

// How far back (in steps) a node's way into a box is trusted to pick the contact face
// (box_test.h, the velocity-aware node_in_box); shared by box pairs and the probe.
inline constexpr double kRecentEntrySteps = 2.0;

// Box b recomputed if a response made it stale (counted in `counters`).
void ensure_box(const Model& model, const State& state, Scratch& scratch, Index b, StageCounters& counters);

// Cells whose nodes moved: their boxes, and those of every cell sharing a node, are stale.
void invalidate_around(const Model& model, Scratch& scratch, Index cell);

// Mean velocity of a cell's 8 lattice nodes (m/s): the velocity eq. 8 works with.
Vec3 mean_velocity(const State& state, const std::array<Index, 8>& nodes);

// Teschner et al. 2003: hash of integer grid coordinates (two's complement wrap for
// negative ones) into `table_size` buckets.
inline Index spatial_hash(std::int64_t gx, std::int64_t gy, std::int64_t gz, Index table_size) {
  const std::uint64_t h = (static_cast<std::uint64_t>(gx) * 73856093ull) ^
                          (static_cast<std::uint64_t>(gy) * 19349663ull) ^
                          (static_cast<std::uint64_t>(gz) * 83492791ull);
  return static_cast<Index>(h % table_size);
}

// Integer hash-grid coordinate of a world coordinate; saturates far outside +-2^52 cells
// and maps NaN to 0, so no input is undefined behaviour.
std::int64_t hash_grid_coordinate(double x, double inv_cell);

// Fills scratch.bucket_begin / entries from the boxes' current nodes. Returns false when
// the entry buffer was too small (the boxes that did not fit are left out of this step).
bool build_spatial_hash(const Model& model, Scratch& scratch, StageCounters& counters);

// Algorithm 1 over the hash table: each overlapping box pair once, nodes of each box tested
// against the other, response applied and both boxes updated at once.
template <bool kFriction>
void collide_boxes(const Model& model, State& state, Scratch& scratch, StageCounters& counters, double& max_depth);

// Static planes: the deepest of a box's 9 nodes below a plane moves the cell out, whole
// correction on the moving side.
template <bool kFriction>
void collide_planes(const Model& model, State& state, Scratch& scratch, StageCounters& counters, double& max_depth);

// Candidate pairs the broad phase yields (each once), for tests and tools: (box a < box b).
std::vector<std::pair<Index, Index>> broad_phase_pairs(const Model& model, Scratch& scratch);
// The same into `pairs` (cleared first): no allocation once it has the capacity.
void broad_phase_pairs(const Model& model, const Scratch& scratch, std::vector<std::pair<Index, Index>>& pairs);

}  // namespace ffd
