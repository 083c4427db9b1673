#pragma once
// The NarrowPhase and Planes stages: node-in-box tests (section 6.2) with the paper's
// immediate response (section 7, Algorithm 1), the exact level's surface tests, and static
// planes, at the accuracy level the State asks for (spec.h, Accuracy), over the broad
// phase's pairs (broad_phase.h) of the boxes (boxes.h).
#include <array>
#include <cstdint>
#include <vector>

#include "boxes.h"
#include "broad_phase.h"
#include "ffd/box_test.h"
#include "ffd/model.h"
#include "ffd/step.h"
#include "paper_response.h"

namespace ffd {

// An edge of one object's surface through a triangle of another's (level 5's edge test,
// collision.cpp): the edge is to go back along `normal` by `depth` (m), out of the way it came
// in if it came in during the step (`fresh`), else out of the face it crosses (the paper's
// response) or the least way out (the solver's).
struct EdgeCrossing {
  double depth = 0.0;                  // m (0: no crossing)
  Vec3 normal = Vec3::Zero();          // unit, out of the triangle's side towards where the edge goes
  Vec3 point = Vec3::Zero();           // m, where the edge meets the triangle's plane, now
  bool fresh = false;                  // crossed during this step (not at its start)
  std::array<Index, 2> edge{};         // surface vertices; point = (1 - along) edge[0] + along edge[1]
  double along = 0.0;
  Index triangle = 0;                  // Model::surface_triangles; point = barycentric . its corners
  Vec3 barycentric = Vec3::Zero();
  Index carrier_a = 0, carrier_b = 0;  // the cells of the triangle's corner and the edge's end nearest to point
};

// Levels 0-3's edge tests: per cell, its owned triangles' corners and AABBs and its owned
// edges' AABBs (Model::cell_owned_triangles and cell_owned_edges order), with the AABBs of
// all of them, as the lattice was at surface epoch `stamp` (every response advances it). A
// cell meets many others in a step, and reloading its surface for every pair was most of
// the edge tests' work.
struct OwnedSurfaceCache {
  std::vector<Vec3> corners;                                    // 3 per owned triangle
  std::array<std::vector<double>, 3> triangle_lo, triangle_hi;  // per owned triangle, as BoxColumns
  std::vector<Vec3> face;                               // per owned triangle: (b - a) x (c - a) of its corners
  std::array<std::vector<double>, 3> edge_lo, edge_hi;  // per owned edge, as BoxColumns
  std::vector<Vec3> triangles_lo, triangles_hi;         // (C)
  std::vector<Vec3> edges_lo, edges_hi;                 // (C)
  std::vector<std::uint8_t> finite;                     // (C) every corner finite
  std::vector<std::uint64_t> stamp;                     // (C) 0: never filled
};

// The narrow phase's working memory (collision.cpp).
struct NarrowMemory {
  // Whether the narrow phase's detection found a node of one box inside the other, per
  // candidate pair (capacity: that of BroadPhaseMemory::pairs).
  std::vector<std::uint8_t> pair_hit;
  double narrow_retested_share = 0.0;  // of the last narrow phase's pairs, those tested again
  // Answering the pairs over the pool: each pair's wave (one more than the last wave of a
  // pair sharing an object with it) and its turn among each of its two objects' pairs, the
  // pairs by wave (wave_pairs[wave_begin[w] .. wave_begin[w + 1])), and per object the next
  // wave, the next turn to hand out, and the turns answered so far.
  std::vector<std::uint32_t> pair_wave;
  std::vector<std::array<std::uint32_t, 2>> pair_turn;
  std::vector<Index> wave_pairs;
  std::vector<Index> wave_begin;
  std::vector<std::uint32_t> object_wave, object_turn, object_answered;
  std::uint32_t narrow_waves = 0;  // waves of the last narrow phase (0: one thread answered the pairs)
  // Level 4 under the paper's response: the pairs of cells of two objects among the candidate
  // pairs of sub-boxes, (lower << 32 | higher), sorted so that each pair is answered once.
  std::vector<std::uint64_t> cell_pair_keys;  // capacity: that of the pairs
  // The response "solver" with edge contacts: the step's deepest edge crossing per half of a
  // pair of cells (find_crossed_edges; capacity: twice the pairs', one per half of each pair
  // of cells, which are at most as many as the pairs).
  std::vector<EdgeCrossing> edge_crossings;
  Index edge_crossing_count = 0;
  // (C) find_crossed_edges over the pool: the cells of its pairs, whose owned-surface cache it
  // fills before the pairs are tested (cleared as it goes).
  std::vector<std::uint8_t> edge_cell_in_pair;
  // Wherever edges are tested (levels 4 and 5 under the paper's response, 0-3 with edge
  // contacts, 0-4 with the solver's): the lattice as the step found it, before dynamics and responses; which side of a triangle an edge came
  // from (test_edges).
  std::vector<Vec3> x_start;
  // Levels 0-3 with edge contacts, where the planes answer first: a cell resting on a plane
  // takes none of a push into it (plane_holds), set by step() each step.
  bool planes_hold = false;
  // Levels 0-3 with edge contacts: per box, the bounds of the triangles its cell owns
  // (Model::cell_owned_triangles), swapped in for BoxMemory::box_lo and box_hi while the edge
  // tests' pairs are found (pair_cells_by_triangles).
  std::array<std::vector<double>, 3> surface_lo, surface_hi;
  // Accuracy level 5. Each surface vertex as the lattice is now, mapped a cell at a time
  // when a step first needs it (a response clears the flags of the cells it moved), and the
  // AABB of each cell's vertices.
  std::vector<Vec3> surface_x;                      // (V)
  std::vector<std::uint8_t> surface_cell_fresh;     // (C)
  std::vector<Vec3> cell_vertex_min, cell_vertex_max;  // (C)
  // The AABB of the corners of each cell's triangles, computed at epoch `stamp`; valid while
  // no cell its corners are bound to has changed since (surface_changed, the epoch of the
  // last response that moved a cell's vertices). The epoch advances at every step and response.
  std::vector<Vec3> cell_triangle_min, cell_triangle_max;  // (C)
  std::vector<std::uint64_t> cell_triangle_stamp;          // (C)
  std::vector<std::uint64_t> surface_changed;              // (C)
  std::uint64_t surface_epoch = 0, surface_step_epoch = 0;
  // Corners of the triangles of one cell, 3 per triangle, and each triangle's AABB by axis.
  std::vector<Vec3> triangle_corners;
  std::vector<Vec3> triangle_min, triangle_max;
  std::array<std::vector<double>, 3> triangle_lo, triangle_hi;
  std::vector<Index> triangle_near;  // the triangles one vertex may lie within the contact radius of
  // One thread's working memory of the edge tests (deepest_edge_crossing), sized for the most
  // triangles and edges a cell has: a cell's candidate triangles, their AABBs, faces and
  // corners as columns for the triangle filter's SIMD kernel, and those an edge passes the
  // filter of (indices into the candidates); the cell's edges in reach of the other, and at
  // levels 4 and 5 their AABBs as columns.
  struct EdgeTestMemory {
    std::vector<Index> candidates, hits;                      // triangles
    std::array<std::vector<double>, 3> lo, hi, face, corner;  // TriangleColumns
    std::vector<Index> edges;                                 // those in reach
    std::array<std::vector<double>, 3> edge_lo, edge_hi;      // BoxColumns (levels 4 and 5)
    void resize(std::size_t most_triangles, std::size_t most_edges) {
      candidates.resize(most_triangles);
      hits.resize(most_triangles);
      edges.resize(most_edges);
      for (int axis = 0; axis < 3; ++axis) {
        lo[axis].resize(most_triangles);
        hi[axis].resize(most_triangles);
        face[axis].resize(most_triangles);
        corner[axis].resize(most_triangles);
        edge_lo[axis].resize(most_edges);
        edge_hi[axis].resize(most_edges);
      }
    }
  };
  EdgeTestMemory edge_tests;
  OwnedSurfaceCache owned_cache;
  // A thread's share of the narrow phase's answers while pairs are answered in waves: its
  // counters, and the contacts it found with the smallest keys (pair index, then order within
  // the pair), at most ContactLog::contacts.size() of them in a max-heap on the key. The
  // step's list is merged from them in key order: the same list, whichever thread answered
  // which pair.
  struct KeyedContact {
    std::uint64_t key;
    Contact contact;
  };
  struct NarrowWorkspace {
    StageCounters counters;
    double max_depth = 0.0;
    Index retested = 0;
    std::vector<KeyedContact> contacts;
    std::uint32_t held = 0;      // contacts[0 .. held) used
    std::uint32_t recorded = 0;  // contacts found, held or not
    std::uint32_t merged = 0;    // contacts[0 .. merged) are in the step's list
    EdgeTestMemory edge_tests;  // the solver's edge tests over the pool (find_crossed_edges)
  };
  std::vector<NarrowWorkspace> narrow_workspaces;  // one per thread (attach_pool())
};

// The contacts of the step, for frames (Scratch::contacts()): every stage that finds one
// records it; fixed capacity, the excess is counted not stored.
struct ContactLog {
  std::vector<Contact> contacts;
  std::uint32_t contact_count = 0;
  std::uint32_t contacts_dropped = 0;
  void record_contact(const Vec3& point, const Vec3& normal, double depth, ContactKind kind) {
    if (contact_count < contacts.size()) contacts[contact_count++] = {point, normal, depth, kind};
    else ++contacts_dropped;
  }
};

// What the collision stages (boxes, broad phase, narrow phase, planes) and the interaction
// work in, and the worker threads they spread over (worker_pool.h; none: this thread alone,
// owned by the caller, never by the memory).
struct CollisionMemory : BoxMemory, BroadPhaseMemory, NarrowMemory, ContactLog {
  WorkerPool* pool = nullptr;
};

// Tested node k of box b at `level`: one of its 9 nodes, or (level 3) a surface node mapped
// from the lattice as it is now; how many a box has; and k's local coordinates in its cell.
Vec3 tested_node(const Model& model, const BoxLevel& level, const State& state, const CollisionMemory& scratch, Index b, int k);
int tested_node_count(const BoxLevel& level);
const Vec3& tested_node_local(const Model& model, const BoxLevel& level, Index b, int k);

// Node-in-box detection (eq. 3-7, the face chosen by the way in: box_test.h), the one loop
// every response and every mover (a box's tested nodes, the probe's) runs: points k in
// [0, count), point_at(k), against box `container` as BoxMemory::box_nodes holds it, its
// planes grown by `skin` (m), at the points' velocity relative to the box,
// relative_velocity() (m/s). on_point(k, point, hit, planes) sees every point; it returns
// true where it answered at once and so moved the box or the points (having made the box
// valid again): the planes and the relative velocity are then taken again, and the scan ends
// should the box have become degenerate. False if the box is degenerate to begin with (it
// contains no point; nothing is called).
template <class PointAt, class RelativeVelocity, class OnPoint>
bool scan_points_in_box(const CollisionMemory& scratch, Index container, double skin, double recent, int count,
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

// The same scan where nothing is answered at once (a detection that only reads), against the
// container's planes taken already.
template <class PointAt, class RelativeVelocity, class OnPoint>
void scan_points_in_planes(const BoxPlanes& planes, double recent, int count, const PointAt& point_at,
                           const RelativeVelocity& relative_velocity, const OnPoint& on_point) {
  if (planes.degenerate) return;
  const Vec3 relative = relative_velocity();
  for (int k = 0; k < count; ++k) {
    const Vec3 point = point_at(k);
    on_point(k, point, node_in_box(planes, point, relative, recent), planes);
  }
}

// Whether a tested node of box `mover` lies inside the box whose planes are `planes`, grown by
// `margin` (m; 0: inside the box itself). Read-only.
bool nodes_near(const Model& model, const BoxLevel& level, const State& state, const CollisionMemory& scratch, Index mover,
                const BoxPlanes& planes, double margin);

// Whether candidate pair p has a tested node of one box inside the other grown by `margin`
// (m), or its two objects sleep. Read-only. `planes`, where given, holds the planes of the
// pair's boxes by box (box_planes of BoxMemory::box_nodes), taken already.
bool pair_hit(const Model& model, const BoxLevel& level, const State& state, const CollisionMemory& scratch, Index p,
              double margin, const BoxPlanes* planes = nullptr);

// The narrow phase's detection, read-only and over the pool: NarrowMemory::pair_hit[p] for each
// candidate pair, whether a tested node of one box lies inside the other grown by `margin`
// (the paper's response: 0; the solver's: its speculative distance), or both objects sleep
// (such a pair is looked at when its turn comes). Counts the node tests.
void find_pair_hits(const Model& model, const BoxLevel& level, const State& state, CollisionMemory& scratch,
                    StageCounters& counters, double margin);

// Algorithm 1 over the candidate pairs: the pairs with a node of one box inside the other are
// found first (read-only, in parallel); then in pair order each is tested again and answered
// at once, both boxes updated.
template <bool kFriction>
void collide_boxes(const Model& model, const BoxLevel& level, State& state, CollisionMemory& scratch, StageCounters& counters,
                   double& max_depth);

// Level 5 over the same pairs: every surface vertex of one cell against the triangles of
// the other cell; a vertex behind the closest triangle (within Model::surface_contact_radius)
// gets the same response, with the triangle's normal and the vertex's distance as n and r.
template <bool kFriction>
void collide_surfaces(const Model& model, State& state, CollisionMemory& scratch, StageCounters& counters, double& max_depth);

// A surface vertex at level 5 near or behind another cell's surface (collision.cpp,
// judge_vertices): the vertex is side b, the closest point of the closest triangle side a.
struct VertexContact {
  Index vertex = 0, triangle = 0;
  Vec3 point = Vec3::Zero();    // m, the vertex as the lattice is now
  Vec3 closest = Vec3::Zero();  // m, the triangle's closest point
  Vec3 normal = Vec3::Zero();   // unit, the triangle's, out of its surface
  double depth = 0.0;           // m, the push along the normal that puts the vertex the skin in front
  bool inside = false;          // behind the surface (else within the skin or `margin` before it)
  Vec3 barycentric = Vec3::Zero();  // of `closest` on the triangle's corners
};
class VertexContactSink {
 public:
  virtual void add(const VertexContact& contact, bool self) = 0;

 protected:
  ~VertexContactSink() = default;
};

// Level 5's vertex contacts as the response "solver" takes them: over the candidate pairs, in
// pair order, both halves of each, every surface vertex of one cell inside the other's
// surface, or where none is, the one nearest to it within the skin and `margin` (m) in front,
// into sink.add. Reads the State but for the sleepers it wakes; refreshes the surface caches.
void find_vertex_contacts(const Model& model, State& state, CollisionMemory& scratch, StageCounters& counters, double margin,
                          VertexContactSink& sink);

// The edge contacts as the response "solver" takes them: the deepest edge crossing of each
// half of each pair of cells of two objects whose owned triangles' bounds meet, as the lattice
// is now, into NarrowMemory::edge_crossings, in cell-pair order. Replaces the broad phase's
// pairs. Reads the State; refreshes the surface caches.
void find_crossed_edges(const Model& model, const BoxSet& boxes, const State& state, CollisionMemory& scratch,
                        StageCounters& counters);

// Static planes: the deepest of a box's tested nodes (level 5: of its cell's surface
// vertices) below a plane moves the cell out, whole correction on the moving side.
template <bool kFriction>
void collide_planes(const Model& model, const BoxLevel& level, State& state, CollisionMemory& scratch, StageCounters& counters,
                    double& max_depth);

}  // namespace ffd
