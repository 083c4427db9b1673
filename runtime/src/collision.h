#pragma once
// Collision stages: FFD AABB update (section 4), broad phase (6.1), node-in-box
// narrow phase with immediate response (6.2, 7, Algorithm 1) and static planes, at the
// accuracy level the State asks for (spec.h, Accuracy).
#include "ffd/box_test.h"
#include "ffd/model.h"
#include "ffd/step.h"
#include "paper_response.h"

namespace ffd {

// What an accuracy level collides: a box set, and which nodes of each box it tests.
struct BoxLevel {
  const BoxSet* boxes;
  // Box nodes [first_node, end_node) are tested: 0-7 the corners, 8 the centre of mass.
  int first_node;
  int end_node;
  bool samples;      // also Model::box_samples, the surface nodes (level 3)
  bool exact;        // level 5: surface vertices against triangles; boxes only pair cells
  // Levels 4 and 5 under the paper's response, and levels 0-3 with [simulation]
  // edge_contacts, in a scene with inter-collision: the exact surfaces' edges against the
  // other object's triangles too (collision.cpp, test_edges), and the planes answered first
  // (step.cpp). The one place that decides it.
  bool edges;
  // m, the gap a box keeps the tested nodes of another object's boxes from its faces:
  // Model::box_skin ("box_overlap"; 0 when off), at level 4 the larger of it and
  // Model::sub_box_skin.
  double skin;
};
BoxLevel box_level(const Model& model, Accuracy accuracy);

// Eq. 2 for the 9 nodes of box b of `boxes` from its cell's 8 lattice nodes; marks it valid.
void update_box(const Model& model, const BoxSet& boxes, const State& state, Scratch& scratch, Index b);
void update_boxes(const Model& model, const BoxSet& boxes, const State& state, Scratch& scratch);

// Box b recomputed if a response made it stale (counted in `counters`).
void ensure_box(const Model& model, const BoxSet& boxes, const State& state, Scratch& scratch, Index b,
                StageCounters& counters);

// Cells whose nodes moved: their boxes, and those of every cell sharing a node, are stale.
void invalidate_around(const Model& model, const BoxSet& boxes, Scratch& scratch, Index cell);

// Tested node k of box b at `level`: one of its 9 nodes, or (level 3) a surface node mapped
// from the lattice as it is now; how many a box has; and k's local coordinates in its cell.
Vec3 tested_node(const Model& model, const BoxLevel& level, const State& state, const Scratch& scratch, Index b, int k);
int tested_node_count(const BoxLevel& level);
const Vec3& tested_node_local(const Model& model, const BoxLevel& level, Index b, int k);

// Node-in-box detection (eq. 3-7, the face chosen by the way in: box_test.h), the one loop
// every response and every mover (a box's tested nodes, the probe's) runs: points k in
// [0, count), point_at(k), against box `container` as Scratch::box_nodes holds it, its
// planes grown by `skin` (m), at the points' velocity relative to the box,
// relative_velocity() (m/s). on_point(k, point, hit, planes) sees every point; it returns
// true where it answered at once and so moved the box or the points (having made the box
// valid again): the planes and the relative velocity are then taken again, and the scan ends
// should the box have become degenerate. False if the box is degenerate to begin with (it
// contains no point; nothing is called).
template <class PointAt, class RelativeVelocity, class OnPoint>
bool scan_points_in_box(const Scratch& scratch, Index container, double skin, double recent, int count,
                        const PointAt& point_at, const RelativeVelocity& relative_velocity, const OnPoint& on_point) {
  const auto planes_now = [&] {
    BoxPlanes planes = box_planes(scratch.box_nodes[container]);
    if (skin != 0.0)
      for (double& offset : planes.offset) offset += skin;
    return planes;
  };
  BoxPlanes planes = planes_now();
  if (planes.degenerate) return false;
  Vec3 relative = relative_velocity();
  for (int k = 0; k < count; ++k) {
    const Vec3 point = point_at(k);
    if (!on_point(k, point, node_in_box(planes, point, relative, recent), planes)) continue;
    planes = planes_now();
    if (planes.degenerate) break;
    relative = relative_velocity();
  }
  return true;
}

// Whether a tested node of box `mover` lies inside box `container` grown by `margin` (m;
// 0: inside the box itself). Read-only.
bool nodes_near(const Model& model, const BoxLevel& level, const State& state, const Scratch& scratch, Index mover,
                Index container, double margin);

// The narrow phase's detection, read-only and over the pool: Scratch::pair_hit[p] for each
// candidate pair, whether a tested node of one box lies inside the other grown by `margin`
// (the paper's response: 0; the solver's: its speculative distance), or both objects sleep
// (such a pair is looked at when its turn comes). Counts the node tests.
void find_pair_hits(const Model& model, const BoxLevel& level, const State& state, Scratch& scratch,
                    StageCounters& counters, double margin);

// Teschner et al. 2003: hash of integer grid coordinates (two's complement wrap for
// negative ones) into `table_size` buckets. It orders the narrow phase's pairs (broad_phase.cpp).
inline Index spatial_hash(std::int64_t gx, std::int64_t gy, std::int64_t gz, Index table_size) {
  const std::uint64_t h = (static_cast<std::uint64_t>(gx) * 73856093ull) ^
                          (static_cast<std::uint64_t>(gy) * 19349663ull) ^
                          (static_cast<std::uint64_t>(gz) * 83492791ull);
  return static_cast<Index>(h % table_size);
}

// Integer hash-grid coordinate of a world coordinate; saturates far outside +-2^52 cells
// and maps NaN to 0, so no input is undefined behaviour.
std::int64_t hash_grid_coordinate(double x, double inv_cell);

// Cells of a broad-phase grid at most (a coarser grid covers a larger region).
inline constexpr Index kBroadPhaseGridCells = 1 << 18;

// First and last box of `object` in `boxes` (boxes are stored in cell order).
inline Index first_box(const BoxSet& boxes, const ObjectModel& object) { return boxes.cell_box_begin[object.cell_begin]; }
inline Index end_box(const BoxSet& boxes, const ObjectModel& object) { return boxes.cell_box_begin[object.cell_end]; }

// The broad phase (broad_phase.cpp): first the boxes' AABBs (from the box update) grown by
// `margin` and the wake margins, and each object's bounds; then every pair of boxes the
// narrow phase wants (boxes of different objects, or of one object's cells that share no
// lattice node, as the effects ask; never two sleepers) whose AABBs overlap, once each,
// sorted, into scratch.pairs. Returns false when the buffers were too small (pairs are
// then missing this step; grow_scratch() makes room between steps).
void grow_box_bounds(const Model& model, const BoxSet& boxes, double margin, Scratch& scratch);
// What find_pairs looks for: pairs of boxes of different objects (inter), of one object's
// cells that share no lattice node (self), of one object's cells that do (neighbours: what
// a general broad phase reports too, for the race against FCL); objects asleep (per object,
// may be null) pair with nothing but awake objects' boxes.
struct PairQuery {
  bool inter = false, self = false, neighbours = false;
  const std::uint8_t* asleep = nullptr;
  bool ordered = true;  // in the order the narrow phase answers them (else as found)
};
bool find_pairs(const Model& model, const BoxSet& boxes, const PairQuery& query, Scratch& scratch,
                StageCounters& counters);
bool find_candidate_pairs(const Model& model, const BoxLevel& level, const State& state, Scratch& scratch,
                          StageCounters& counters);

// Algorithm 1 over the candidate pairs: the pairs with a node of one box inside the other are
// found first (read-only, in parallel); then in pair order each is tested again and answered
// at once, both boxes updated.
template <bool kFriction>
void collide_boxes(const Model& model, const BoxLevel& level, State& state, Scratch& scratch, StageCounters& counters,
                   double& max_depth);

// Level 5 over the same pairs: every surface vertex of one cell against the triangles of
// the other cell; a vertex behind the closest triangle (within Model::surface_contact_radius)
// gets the same response, with the triangle's normal and the vertex's distance as n and r.
template <bool kFriction>
void collide_surfaces(const Model& model, State& state, Scratch& scratch, StageCounters& counters, double& max_depth);

// Static planes: the deepest of a box's tested nodes (level 5: of its cell's surface
// vertices) below a plane moves the cell out, whole correction on the moving side.
template <bool kFriction>
void collide_planes(const Model& model, const BoxLevel& level, State& state, Scratch& scratch, StageCounters& counters,
                    double& max_depth);

}  // namespace ffd
