#include "collision.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <initializer_list>

#include "ffd/box_test.h"
#include "ffd/closest_point.h"
#include "ffd/trilinear.h"
#include "ffd/worker_pool.h"
#include "kernels/aabb_kernels.h"
#include "kernels/box_kernels.h"
#include "sleep.h"

namespace ffd {

namespace {

// Whether a static plane holds `cell` against a push along `push` (unit): a node of the cell
// lies within a twentieth of a cell of the plane, and the push heads into it (more than 17
// degrees off parallel). Where the planes answer before the objects (step.cpp), a cell
// pushed into the floor stays there until the next step's planes put it back, into what
// pushed it, and a thin plate under a letter buzzed. Held, the cell takes none of the push
// and the other side all of it, as a stack's lower bodies are treated as fixed for the ones
// above (Guendelman, Bridson and Fedkiw 2003, shock propagation). A tenth or a fifth of a
// cell did worse on the random piles (docs/notes/2026-11-28-code-findings.md#plane-hold).
bool plane_holds(const Model& model, const State& state, Index cell, const Vec3& push) {
  const double reach = 0.05 * model.objects[model.cell_object[cell]].cell_size;
  for (const PlaneModel& plane : model.planes) {
    if (!(plane.normal.dot(push) < -0.3)) continue;
    for (Index i : model.cell_nodes[cell])
      if (plane.normal.dot(state.x[i]) - plane.offset < reach) return true;
  }
  return false;
}

// Section 7 for a node of cell B found inside the box of cell A: n is A's outward normal of
// least penetration, r the depth (eq. 7). `may_rebound`: whether a fresh contact also
// rebounds (response.h) or gets eq. 8-9 alone. `planes_hold`: whether a cell that a plane
// holds against the push is static for it (plane_holds; one side held, not both).
template <bool kFriction>
void respond_pair(const Model& model, State& state, Index cell_a, Index cell_b, const Vec3& n, double r,
                  bool planes_hold, bool may_rebound = true) {
  bool held_a = false, held_b = false;
  if (planes_hold) {
    held_a = plane_holds(model, state, cell_a, -n);
    held_b = plane_holds(model, state, cell_b, n);
    if (held_a == held_b) held_a = held_b = false;
  }
  answer_at_once(model, state, ResponseSide::of_cell(cell_a, held_a), ResponseSide::of_cell(cell_b, held_b), n, r,
                 kFriction ? state.params.beta : 0.0, may_rebound);
}

}  // namespace

Vec3 tested_node(const Model& model, const BoxLevel& level, const State& state, const CollisionMemory& scratch, Index b, int k) {
  const int box_node_count = level.end_node - level.first_node;
  if (k < box_node_count) return scratch.box_nodes[b][level.first_node + k];
  const std::array<Index, 8>& corner = model.cell_nodes[level.boxes->box_cell[b]];
  return trilinear_map(model.box_samples[b][k - box_node_count], [&](int j) -> const Vec3& { return state.x[corner[j]]; });
}

int tested_node_count(const BoxLevel& level) {
  return level.end_node - level.first_node + (level.samples ? kBoxSampleCount : 0);
}

const Vec3& tested_node_local(const Model& model, const BoxLevel& level, Index b, int k) {
  const int box_node_count = level.end_node - level.first_node;
  if (k < box_node_count) return level.boxes->box_local[b][level.first_node + k];
  return model.box_samples[b][k - box_node_count];
}

namespace {

// Where the answers to box pairs go: the stage's counters and the step's contact list (one
// thread answering the pairs in order), or one thread's share of both (pairs answered in
// waves), each contact keyed by its pair and its place within the pair.
struct PairSink {
  StageCounters& counters;
  double& max_depth;
  Index& retested;
  CollisionMemory& scratch;
  NarrowMemory::NarrowWorkspace* workspace = nullptr;  // none: straight into the step's list
  std::uint64_t next_key = 0;

  void record(const Vec3& point, const Vec3& normal, double depth, ContactKind kind) {
    if (!workspace) {
      scratch.record_contact(point, normal, depth, kind);
      return;
    }
    // Keep the contacts.size() smallest keys: the front of the max-heap is the largest held.
    NarrowMemory::NarrowWorkspace& w = *workspace;
    ++w.recorded;
    const NarrowMemory::KeyedContact contact{next_key++, {point, normal, depth, kind}};
    const auto begin = w.contacts.begin();
    const auto by_key = [](const NarrowMemory::KeyedContact& a, const NarrowMemory::KeyedContact& b) { return a.key < b.key; };
    if (w.held < w.contacts.size()) {
      w.contacts[w.held++] = contact;
      std::push_heap(begin, begin + w.held, by_key);
    } else if (w.held > 0 && contact.key < w.contacts.front().key) {
      std::pop_heap(begin, begin + w.held, by_key);
      w.contacts[w.held - 1] = contact;
      std::push_heap(begin, begin + w.held, by_key);
    }
  }
};

// Nodes of box `mover` against box `container` (one half of Algorithm 1's inner loop), each
// found inside answered at once.
template <bool kFriction>
void test_nodes(const Model& model, const BoxLevel& level, State& state, CollisionMemory& scratch, Index mover, Index container,
                bool self, PairSink& sink) {
  StageCounters& counters = sink.counters;
  const BoxSet& boxes = *level.boxes;
  const int node_count = tested_node_count(level);
  // Boxes of two objects hold each other's nodes a skin away from their faces (level 4,
  // "box_overlap").
  const double skin = self ? 0.0 : level.skin;
  const Index cell_a = boxes.box_cell[container], cell_b = boxes.box_cell[mover];
  const bool tested = scan_points_in_box(
      scratch, container, skin, kRecentEntrySteps * model.settings.dt, node_count,
      [&](int k) { return tested_node(model, level, state, scratch, mover, k); },
      [&] { return Vec3(mean_velocity(state, model.cell_nodes[cell_b]) - mean_velocity(state, model.cell_nodes[cell_a])); },
      [&](int, const Vec3& node, const NodeInBox& hit, const BoxPlanes& planes) {
        ++counters.node_tests;
        if (!hit.inside) return false;
        if (self) ++counters.self_contacts;
        else ++counters.inter_contacts;
        const double box_depth = std::max(0.0, hit.depth - skin);  // within the skin: touching
        sink.max_depth = std::max(sink.max_depth, box_depth);
        sink.record(node, planes.normal[hit.face], box_depth, self ? ContactKind::Self : ContactKind::Inter);
        respond_pair<kFriction>(model, state, cell_a, cell_b, planes.normal[hit.face], hit.depth, scratch.planes_hold);
        // Update both boxes at once so the remaining tests see the corrected state.
        invalidate_around(model, boxes, scratch, cell_a);
        invalidate_around(model, boxes, scratch, cell_b);
        ensure_box(model, boxes, state, scratch, container, counters);
        ensure_box(model, boxes, state, scratch, mover, counters);
        return true;
      });
  if (!tested) counters.node_tests += node_count;  // tested and found nothing: a degenerate box contains no node
}

// Surface vertex v (eq. 2) on the lattice nodes at `x`: the lattice now (State::x) or as the
// step found it (Scratch::x_start).
Vec3 surface_vertex(const Model& model, const std::vector<Vec3>& x, Index v) {
  const std::array<Index, 8>& corner = model.cell_nodes[model.surface_vertex_cell[v]];
  return trilinear_map(model.surface_vertex_local[v], [&](int j) -> const Vec3& { return x[corner[j]]; });
}

// The surface cache is stale: the lattice moved since the last surface tests.
void begin_surface_tests(CollisionMemory& scratch) {
  std::fill(scratch.surface_cell_fresh.begin(), scratch.surface_cell_fresh.end(), std::uint8_t{0});
  scratch.surface_step_epoch = ++scratch.surface_epoch;
}

// Maps the surface vertices of `cell` (and their AABB) into the level-5 cache.
void refresh_cell_vertices(const Model& model, const State& state, CollisionMemory& scratch, Index cell) {
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (Index i = model.cell_vertex_begin[cell]; i < model.cell_vertex_begin[cell + 1]; ++i) {
    const Index v = model.cell_vertices[i];
    const Vec3 p = surface_vertex(model, state.x, v);
    scratch.surface_x[v] = p;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // A non-finite vertex is in reach of everything, as the per-vertex test takes it.
  const bool finite = is_finite(lo) && is_finite(hi);
  scratch.cell_vertex_min[cell] = finite ? lo : Vec3::Constant(-INFINITY);
  scratch.cell_vertex_max[cell] = finite ? hi : Vec3::Constant(INFINITY);
  scratch.surface_cell_fresh[cell] = 1;
}

// Surface vertex v as the lattice is now: the same value surface_vertex() gives.
const Vec3& cached_vertex(const Model& model, const State& state, CollisionMemory& scratch, Index v) {
  const Index cell = model.surface_vertex_cell[v];
  if (!scratch.surface_cell_fresh[cell]) refresh_cell_vertices(model, state, scratch, cell);
  return scratch.surface_x[v];
}

// A response moved the nodes of `cell`: the vertices of every cell sharing one are stale.
void invalidate_surface_around(const Model& model, CollisionMemory& scratch, Index cell) {
  ++scratch.surface_epoch;
  for (Index i = model.cell_neighbour_begin[cell]; i < model.cell_neighbour_begin[cell + 1]; ++i) {
    scratch.surface_cell_fresh[model.cell_neighbours[i]] = 0;
    scratch.surface_changed[model.cell_neighbours[i]] = scratch.surface_epoch;
  }
}

bool triangle_bounds_valid(const Model& model, const CollisionMemory& scratch, Index cell) {
  const std::uint64_t stamp = scratch.cell_triangle_stamp[cell];
  if (stamp < scratch.surface_step_epoch) return false;
  for (Index i = model.cell_triangle_source_begin[cell]; i < model.cell_triangle_source_begin[cell + 1]; ++i)
    if (scratch.surface_changed[model.cell_triangle_sources[i]] > stamp) return false;
  return true;
}

// AABB of the corners of triangles[begin, end) as the lattice is now (empty: lo > hi).
void triangles_bounds(const Model& model, const State& state, CollisionMemory& scratch, const std::vector<Index>& triangles,
                      Index begin, Index end, Vec3& lo, Vec3& hi) {
  lo = Vec3::Constant(INFINITY);
  hi = Vec3::Constant(-INFINITY);
  for (Index t = begin; t < end; ++t)
    for (Index v : model.surface_triangles[triangles[t]]) {
      const Vec3& p = cached_vertex(model, state, scratch, v);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
}

// AABB of the corners of the triangles of `cell`, from the cache.
void cell_triangle_bounds(const Model& model, const State& state, CollisionMemory& scratch, Index cell, Vec3& lo, Vec3& hi) {
  if (!triangle_bounds_valid(model, scratch, cell)) {
    Vec3 l, h;
    triangles_bounds(model, state, scratch, model.cell_triangles, model.cell_triangle_begin[cell],
                     model.cell_triangle_begin[cell + 1], l, h);
    scratch.cell_triangle_min[cell] = l;
    scratch.cell_triangle_max[cell] = h;
    scratch.cell_triangle_stamp[cell] = scratch.surface_epoch;
  }
  lo = scratch.cell_triangle_min[cell];
  hi = scratch.cell_triangle_max[cell];
}

// (b - a) x (c - a): the normal of triangle abc (unnormalised, twice its area long), on the
// side from which a, b, c turn counter-clockwise. One expression for every use, so that a
// face computed once and kept (OwnedSurfaceCache::face) has the bits of one computed in place.
Vec3 triangle_face(const Vec3& a, const Vec3& b, const Vec3& c) { return (b - a).cross(c - a); }

// Triangle `tri`'s corners as the lattice is now into corner[0..3), and their AABB; false if
// some corner is not finite.
bool load_triangle(const Model& model, const State& state, CollisionMemory& scratch, const std::array<Index, 3>& tri,
                   Vec3* corner, Vec3& lo, Vec3& hi) {
  bool finite = true;
  for (int k = 0; k < 3; ++k) {
    corner[k] = cached_vertex(model, state, scratch, tri[k]);
    finite = finite && is_finite(corner[k]);
  }
  lo = corner[0].cwiseMin(corner[1]).cwiseMin(corner[2]);
  hi = corner[0].cwiseMax(corner[1]).cwiseMax(corner[2]);
  return finite;
}

// Box i of the columns (lo, hi) (BoxColumns' layout) set to [l, h].
void set_column_box(std::array<std::vector<double>, 3>& lo, std::array<std::vector<double>, 3>& hi, std::size_t i,
                    const Vec3& l, const Vec3& h) {
  for (int axis = 0; axis < 3; ++axis) {
    lo[axis][i] = l[axis];
    hi[axis][i] = h[axis];
  }
}

// Levels 0-3's edge tests: brings cell's entry of the owned-surface cache (NarrowMemory::
// owned_cache) up to the lattice as it is now, unless it was filled at this surface epoch.
// The same values, in the same order, as loading them for each pair.
void refresh_owned_surface(const Model& model, const State& state, CollisionMemory& scratch, Index cell) {
  OwnedSurfaceCache& cache = scratch.owned_cache;
  if (cache.stamp[cell] != 0 && cache.stamp[cell] == scratch.surface_epoch) return;
  Vec3 lo_all = Vec3::Constant(INFINITY), hi_all = Vec3::Constant(-INFINITY);
  bool finite = true;
  for (Index i = model.cell_owned_triangle_begin[cell]; i < model.cell_owned_triangle_begin[cell + 1]; ++i) {
    const std::array<Index, 3>& tri = model.surface_triangles[model.cell_owned_triangles[i]];
    Vec3* corner = cache.corners.data() + 3 * std::size_t{i};
    Vec3 lo, hi;
    finite = load_triangle(model, state, scratch, tri, corner, lo, hi) && finite;
    set_column_box(cache.triangle_lo, cache.triangle_hi, i, lo, hi);
    cache.face[i] = triangle_face(corner[0], corner[1], corner[2]);
    lo_all = lo_all.cwiseMin(lo);
    hi_all = hi_all.cwiseMax(hi);
  }
  cache.triangles_lo[cell] = lo_all;
  cache.triangles_hi[cell] = hi_all;
  cache.finite[cell] = finite ? 1 : 0;
  lo_all = Vec3::Constant(INFINITY);
  hi_all = Vec3::Constant(-INFINITY);
  for (Index e = model.cell_owned_edge_begin[cell]; e < model.cell_owned_edge_begin[cell + 1]; ++e) {
    const Vec3& p = cached_vertex(model, state, scratch, model.cell_owned_edges[e][0]);
    const Vec3& q = cached_vertex(model, state, scratch, model.cell_owned_edges[e][1]);
    lo_all = lo_all.cwiseMin(p).cwiseMin(q);
    hi_all = hi_all.cwiseMax(p).cwiseMax(q);
    set_column_box(cache.edge_lo, cache.edge_hi, e, p.cwiseMin(q), p.cwiseMax(q));
  }
  cache.edges_lo[cell] = lo_all;
  cache.edges_hi[cell] = hi_all;
  cache.stamp[cell] = scratch.surface_epoch;
}

// Within one object: vertex v lies within the contact radius of triangle `tri` in the rest
// shape. Such a pair is one piece of surface, not two that met: a vertex beside a coplanar
// triangle, or across a wall thinner than the radius, reads as a little behind it as the
// lattice bends, and pushing those cells apart made a resting letter jitter
// (docs/notes/2026-11-28-code-findings.md#rest-shape-filter).
bool near_at_rest(const Model& model, Index v, const std::array<Index, 3>& tri) {
  const std::vector<Vec3>& rest = model.surface_vertex_rest;
  const Vec3& p = rest[v];
  const ClosestPoint q = closest_point_on_triangle(p, rest[tri[0]], rest[tri[1]], rest[tri[2]]);
  return (p - q.point).squaredNorm() < model.surface_contact_radius * model.surface_contact_radius;
}

bool cells_share_node(const Model& model, Index cell_a, Index cell_b) {
  return (model.cell_coord[cell_a] - model.cell_coord[cell_b]).cwiseAbs().maxCoeff() <= 1;
}

// Behind the face of the closest triangle (normal: its unnormalised face normal). Near a
// concave edge an outside point is closest to a face, so the closest face tells. Where the
// closest point is a corner or an edge, p - q lies between the normals of the faces that
// share it, which at an acute corner (normals more than 90 degrees apart) may be behind one
// of them: there behind_every_face_at() tells.
bool behind(const Vec3& p, const Vec3& closest, const Vec3& normal) {
  return normal.squaredNorm() > 0.0 && (p - closest).dot(normal) < 0.0;
}

// Where the closest point of the surface is a corner or an edge of triangle `tri` (`feature`),
// p is behind the surface only if it is behind every triangle that shares that corner or edge:
// the inside of a convex corner is where the insides of all its faces meet. Behind one face's
// plane alone, a vertex beside a letter's acute corner and in front of the other wall read as
// inside, and was pushed into the floor every step
// (docs/notes/2026-11-28-code-findings.md#corner-judgement).
bool behind_every_face_at(const Model& model, const State& state, CollisionMemory& scratch, const Vec3& p, const Vec3& closest,
                          Index tri, Feature feature) {
  const std::array<Index, 3>& corners = model.surface_triangles[tri];
  Index u = 0, w = 0;  // the corner, or the edge's two ends (w == u for a corner)
  switch (feature) {
    case Feature::kFace: return true;
    case Feature::kVertexA: u = w = corners[0]; break;
    case Feature::kVertexB: u = w = corners[1]; break;
    case Feature::kVertexC: u = w = corners[2]; break;
    case Feature::kEdgeAB: u = corners[0], w = corners[1]; break;
    case Feature::kEdgeBC: u = corners[1], w = corners[2]; break;
    case Feature::kEdgeCA: u = corners[2], w = corners[0]; break;
  }
  // Every triangle with corner u is listed under the cell u is bound to.
  const Index cell = model.surface_vertex_cell[u];
  const auto has = [](const std::array<Index, 3>& t, Index v) { return t[0] == v || t[1] == v || t[2] == v; };
  for (Index k = model.cell_triangle_begin[cell]; k < model.cell_triangle_begin[cell + 1]; ++k) {
    const std::array<Index, 3>& t = model.surface_triangles[model.cell_triangles[k]];
    if (!has(t, u) || !has(t, w)) continue;
    const Vec3& a = cached_vertex(model, state, scratch, t[0]);
    const Vec3& b = cached_vertex(model, state, scratch, t[1]);
    const Vec3& c = cached_vertex(model, state, scratch, t[2]);
    const Vec3 normal = triangle_face(a, b, c);
    if (normal.squaredNorm() > 0.0 && !behind(p, closest, normal)) return false;
  }
  return true;
}


// Narrows (best_sq, best_point, best_normal, best_triangle, best_feature) to the closest
// triangle of the cells sharing a node with cell_a. For a pair of one object's cells, the
// cells that share a node with cell_b are p's own surface and are left out, as the pair test
// leaves them out. Returns false if the closest triangle lies in an inverted cell: then
// inside or outside is unknown.
bool closest_around(const Model& model, const State& state, CollisionMemory& scratch, Index cell_a, Index cell_b, bool self,
                    Index v, const Vec3& p, double& best_sq, Vec3& best_point, Vec3& best_normal, Index& best_triangle,
                    Feature& best_feature) {
  bool reliable = true;
  for (Index i = model.cell_neighbour_begin[cell_a]; i < model.cell_neighbour_begin[cell_a + 1]; ++i) {
    const Index cell = model.cell_neighbours[i];
    if (cell == cell_a || (self && cells_share_node(model, cell, cell_b))) continue;
    const bool inverted = cell_inverted(model, state, cell);
    for (Index t = model.cell_triangle_begin[cell]; t < model.cell_triangle_begin[cell + 1]; ++t) {
      const std::array<Index, 3>& tri = model.surface_triangles[model.cell_triangles[t]];
      if (self && near_at_rest(model, v, tri)) continue;
      const Vec3& a = cached_vertex(model, state, scratch, tri[0]);
      const Vec3& b = cached_vertex(model, state, scratch, tri[1]);
      const Vec3& c = cached_vertex(model, state, scratch, tri[2]);
      const Vec3 below = a.cwiseMin(b).cwiseMin(c) - p, above = p - a.cwiseMax(b).cwiseMax(c);
      if (!(below.cwiseMax(above).cwiseMax(0.0).squaredNorm() < best_sq)) continue;
      const ClosestPoint q = closest_point_on_triangle(p, a, b, c);
      const double d_sq = (p - q.point).squaredNorm();
      if (!(d_sq < best_sq)) continue;
      best_sq = d_sq;
      best_point = q.point;
      best_normal = triangle_face(a, b, c);
      best_triangle = model.cell_triangles[t];
      best_feature = q.feature;
      reliable = !inverted;
    }
  }
  return reliable;
}

// A cell's triangles and their edges as the edge tests take them: the edge contacts those it
// owns (Model::cell_owned_triangles), each tested once; level 5's answers at once (test_edges)
// those with a corner bound to it (Model::cell_triangles, "crossing" here).
struct CellSurface {
  const std::vector<Index>& triangle_begin;
  const std::vector<Index>& triangles;
  const std::vector<Index>& edge_begin;
  const std::vector<std::array<Index, 2>>& edges;
  bool crossing;  // the crossing triangles, whose bounds the scratch caches
};
CellSurface crossing_surface(const Model& model) {
  return {model.cell_triangle_begin, model.cell_triangles, model.cell_edge_begin, model.cell_edges, true};
}
CellSurface owned_surface(const Model& model) {
  return {model.cell_owned_triangle_begin, model.cell_owned_triangles, model.cell_owned_edge_begin,
          model.cell_owned_edges, false};
}

// The corners and AABBs (by axis too) of cell_a's triangles as the lattice is now, into the
// scratch arrays triangle_corners, triangle_min/max and triangle_lo/hi; false if some corner
// is not finite.
bool load_triangles(const Model& model, const State& state, CollisionMemory& scratch, Index cell_a,
                    const CellSurface& surface) {
  const Index tri_begin = surface.triangle_begin[cell_a], tri_count = surface.triangle_begin[cell_a + 1] - tri_begin;
  Vec3* corners = scratch.triangle_corners.data();
  bool finite = true;
  for (Index t = 0; t < tri_count; ++t) {
    const std::array<Index, 3>& tri = model.surface_triangles[surface.triangles[tri_begin + t]];
    Vec3 lo, hi;
    finite = load_triangle(model, state, scratch, tri, corners + 3 * t, lo, hi) && finite;
    scratch.triangle_min[t] = lo;
    scratch.triangle_max[t] = hi;
    set_column_box(scratch.triangle_lo, scratch.triangle_hi, t, lo, hi);
  }
  return finite;
}

// Level 5, one half of a cell pair: the surface vertices of cell_b against the triangles
// with a vertex in cell_a, as the lattice is now. A vertex is inside if it lies behind the
// closest triangle of cell_a and of the cells around it, none of them inverted; it is to go
// out along that triangle's normal to the skin in front (Model::surface_skin; none within one
// object, where it gained nothing on the random piles:
// docs/notes/2026-11-28-code-findings.md#self-skin). on_vertex(contact) for each vertex whose
// push there (VertexContact::depth: behind, its distance and the skin; in front, the skin
// less its distance) is above `floor` (m), which on_vertex may raise as it goes: the paper's
// response keeps only the deepest.
template <class OnVertex>
void judge_vertices(const Model& model, const State& state, CollisionMemory& scratch, Index cell_b, Index cell_a, bool self,
                    StageCounters& counters, const double& floor, const OnVertex& on_vertex) {
  const Index tri_begin = model.cell_triangle_begin[cell_a], tri_end = model.cell_triangle_begin[cell_a + 1];
  if (tri_begin == tri_end) return;
  const Index vertex_begin = model.cell_vertex_begin[cell_b], vertex_end = model.cell_vertex_begin[cell_b + 1];
  if (vertex_begin == vertex_end || cell_inverted(model, state, cell_a)) return;
  const double radius = model.surface_contact_radius, skin = self ? 0.0 : model.surface_skin;
  // The triangles' AABB widened by the radius: vertices outside it miss them all.
  Vec3 reach_lo, reach_hi;
  cell_triangle_bounds(model, state, scratch, cell_a, reach_lo, reach_hi);
  reach_lo -= Vec3::Constant(radius);
  reach_hi += Vec3::Constant(radius);
  // No vertex of cell_b in reach: nothing below would be tested.
  if (!scratch.surface_cell_fresh[cell_b]) refresh_cell_vertices(model, state, scratch, cell_b);
  if ((scratch.cell_vertex_max[cell_b].array() < reach_lo.array()).any() ||
      (scratch.cell_vertex_min[cell_b].array() > reach_hi.array()).any())
    return;
  const Index tri_count = tri_end - tri_begin;
  const Vec3* corners = scratch.triangle_corners.data();
  const bool corners_finite = load_triangles(model, state, scratch, cell_a, crossing_surface(model));
  // (cached_vertex may have refreshed cell_b above: with the same values.)
  Index* __restrict near = scratch.triangle_near.data();
  for (Index i = vertex_begin; i < vertex_end; ++i) {
    const Vec3 p = scratch.surface_x[model.cell_vertices[i]];
    if ((p.array() < reach_lo.array()).any() || (p.array() > reach_hi.array()).any()) continue;
    counters.node_tests += tri_count;
    // A triangle whose AABB is a radius or more away along an axis has an AABB distance of
    // at least the radius, so the test below would skip it: the same differences, in bulk.
    // With a NaN about, that distance may be NaN and skip nothing: test every triangle.
    Index candidates = 0;
    if (corners_finite && is_finite(p)) {
      const double px = p.x(), py = p.y(), pz = p.z();
      const double* __restrict lx = scratch.triangle_lo[0].data();
      const double* __restrict ly = scratch.triangle_lo[1].data();
      const double* __restrict lz = scratch.triangle_lo[2].data();
      const double* __restrict hx = scratch.triangle_hi[0].data();
      const double* __restrict hy = scratch.triangle_hi[1].data();
      const double* __restrict hz = scratch.triangle_hi[2].data();
      for (Index t = 0; t < tri_count; ++t) {
        near[candidates] = t;  // kept, in order, only if near
        candidates += static_cast<Index>((lx[t] - px < radius) & (px - hx[t] < radius) & (ly[t] - py < radius) &
                                         (py - hy[t] < radius) & (lz[t] - pz < radius) & (pz - hz[t] < radius));
      }
    } else {
      for (Index t = 0; t < tri_count; ++t) near[candidates++] = t;
    }
    double best_sq = radius * radius;
    Vec3 best_point = Vec3::Zero(), best_normal = Vec3::Zero();
    Index best_triangle = 0;
    Feature best_feature = Feature::kFace;
    for (Index c = 0; c < candidates; ++c) {
      const Index t = near[c];
      const Vec3* corner = corners + 3 * t;
      if (self && near_at_rest(model, model.cell_vertices[i], model.surface_triangles[model.cell_triangles[tri_begin + t]]))
        continue;
      // The distance to the triangle's AABB bounds the distance to the triangle from below.
      const Vec3 below = scratch.triangle_min[t] - p;
      const Vec3 above = p - scratch.triangle_max[t];
      if (below.cwiseMax(above).cwiseMax(0.0).squaredNorm() >= best_sq) continue;
      const ClosestPoint q = closest_point_on_triangle(p, corner[0], corner[1], corner[2]);
      const double d_sq = (p - q.point).squaredNorm();
      if (!(d_sq < best_sq)) continue;
      best_sq = d_sq;
      best_point = q.point;
      best_normal = triangle_face(corner[0], corner[1], corner[2]);
      best_triangle = model.cell_triangles[tri_begin + t];
      best_feature = q.feature;
    }
    const auto push = [&] { return behind(p, best_point, best_normal) ? skin + std::sqrt(best_sq) : skin - std::sqrt(best_sq); };
    if (best_normal.squaredNorm() == 0.0 || !(push() > floor)) continue;
    // Behind the closest triangle of cell_a's patch or within the skin before it; the
    // surface's closest point may lie just past the patch's border, though, with p in front
    // of it (a thin part of the object, a crease): look for it among the triangles of the
    // cells around cell_a.
    if (!closest_around(model, state, scratch, cell_a, cell_b, self, model.cell_vertices[i], p, best_sq, best_point, best_normal,
                        best_triangle, best_feature))
      continue;
    const double distance = std::sqrt(best_sq);
    const bool inside = behind(p, best_point, best_normal) &&
                        behind_every_face_at(model, state, scratch, p, best_point, best_triangle, best_feature);
    const double depth = inside ? skin + distance : skin - distance;
    if (!(depth > floor)) continue;
    const double normal_length = best_normal.norm();
    on_vertex(VertexContact{model.cell_vertices[i], best_triangle, p, best_point, best_normal / normal_length, depth, inside});
  }
}

// The paper's response at level 5: of one half of a cell pair (judge_vertices), the deepest
// vertex inside moves the cells apart, once per pair half as a plane moves a cell: a
// response per vertex would push the same two cells dozens of times in one step and store
// the pushes in the springs.
template <bool kFriction>
void test_vertices(const Model& model, State& state, CollisionMemory& scratch, Index cell_b, Index cell_a, bool self,
                   StageCounters& counters, double& max_depth) {
  const double skin = self ? 0.0 : model.surface_skin;
  double deepest = 0.0;
  Vec3 deepest_point = Vec3::Zero(), deepest_normal = Vec3::Zero();
  judge_vertices(model, state, scratch, cell_b, cell_a, self, counters, deepest, [&](const VertexContact& contact) {
    deepest = contact.depth;
    deepest_point = contact.point;
    deepest_normal = contact.normal;
  });
  if (!(deepest > 0.0)) return;
  if (self) ++counters.self_contacts;
  else ++counters.inter_contacts;
  max_depth = std::max(max_depth, deepest - skin);  // the penetration
  scratch.record_contact(deepest_point, deepest_normal, deepest, self ? ContactKind::Self : ContactKind::Inter);
  // No rebound here: the normal is one triangle's, and on a detailed surface that says little
  // about the direction the cells met in; reversing their approach along it crushes the
  // cells around (docs/notes/2026-11-28-code-findings.md#exact-rebound).
  respond_pair<kFriction>(model, state, cell_a, cell_b, deepest_normal, deepest, scratch.planes_hold, false);
  invalidate_surface_around(model, scratch, cell_a);
  invalidate_surface_around(model, scratch, cell_b);
}

// Six times the signed volume of the tetrahedron (a, b, c, d): > 0 when d lies on the side of
// the plane through a, b, c that (b - a) x (c - a) points to.
double orient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) { return triangle_face(a, b, c).dot(d - a); }

// The line through p and q passes through triangle abc (edges included).
bool line_through_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  const double u = orient(p, q, a, b), v = orient(p, q, b, c), w = orient(p, q, c, a);
  return (u >= 0.0 && v >= 0.0 && w >= 0.0) || (u <= 0.0 && v <= 0.0 && w <= 0.0);
}

// The open segment pq passes through triangle abc: its ends strictly on opposite sides of the
// plane (plane_height, which the edge tests' filter triangles_straddled computes likewise), and
// the line through them inside the triangle (edges included). A segment touching the plane, or
// lying in it, does not count.
bool segment_crosses_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 face = triangle_face(a, b, c);
  const double sp = plane_height(face, a, p), sq = plane_height(face, a, q);
  if (!((sp > 0.0 && sq < 0.0) || (sp < 0.0 && sq > 0.0))) return false;
  return line_through_triangle(p, q, a, b, c);
}

// How an edge pq that crosses triangle abc now, and did not at the start of the step (p0 q0,
// a0 b0 c0), is to go back: along `normal`, by `depth` (m). Through the face: the edge was
// wholly on one side of the triangle's plane, and goes back to that side, by the depth of
// its end furthest behind. Past one of the triangle's edges rs: the two lines passed through
// each other (the sign of orient(p, q, r, s) changed); the edge goes back along their common
// perpendicular to the side it was on. By at most `reach` (the depth level 5 sees a vertex
// at), as crossed_way_out: a long edge that turned through a face in one step reads deep at
// its far end, many times a vertex's depth; unbounded, a pile blew up, bounded it did not
// (docs/notes/2026-11-28-code-findings.md#bounded-edges). What is left goes next step.
// False if neither can be told.
bool edge_way_back(const Vec3 (&now)[5], const Vec3 (&start)[5], double reach, Vec3& normal, double& depth) {
  const Vec3 &p = now[0], &q = now[1];
  const Vec3 &p0 = start[0], &q0 = start[1];
  const double sp = orient(start[2], start[3], start[4], p0), sq = orient(start[2], start[3], start[4], q0);
  if ((sp > 0.0 && sq > 0.0) || (sp < 0.0 && sq < 0.0)) {
    const Vec3 face = triangle_face(now[2], now[3], now[4]);
    const double length = face.norm();
    if (!(length > 0.0)) return false;
    normal = (sp > 0.0 ? 1.0 : -1.0) / length * face;
    depth = std::min(reach, std::max(-normal.dot(p - now[2]), -normal.dot(q - now[2])));
    return depth > 0.0;
  }
  for (int k = 0; k < 3; ++k) {
    const int r = 2 + k, t = 2 + (k + 1) % 3;
    const double before = orient(p0, q0, start[r], start[t]), after = orient(p, q, now[r], now[t]);
    if (!((before > 0.0 && after < 0.0) || (before < 0.0 && after > 0.0))) continue;
    const Vec3 across = (q - p).cross(now[t] - now[r]);
    const double length = across.norm();
    if (!(length > 0.0)) return false;
    // orient(p, q, r, s) = ((q - p) x (s - r)) . (p - r): the normal points from rs's line to
    // pq's as it was at the start.
    normal = (before > 0.0 ? 1.0 : -1.0) / length * across;
    depth = std::min(reach, -normal.dot(p - now[r]));
    return depth > 0.0;
  }
  return false;
}

// The way out for an edge pq that crossed triangle abc (now[0..4]) before this step already,
// so that how it got in is not known: out of the face it crosses, to the face's front
// (outside the surface), by the depth of its end behind it, at most `reach` (the depth level
// 5 sees a vertex at: a long edge through a face far from its ends is not pushed out in one
// go). Not the nearest face, which for an edge past the middle of a thin part is the far one
// and would push it through.
bool crossed_way_out(const Vec3 (&now)[5], double reach, Vec3& normal, double& depth) {
  const Vec3 face = triangle_face(now[2], now[3], now[4]);
  const double length = face.norm();
  if (!(length > 0.0)) return false;
  normal = face / length;
  depth = std::min(reach, std::max(-normal.dot(now[0] - now[2]), -normal.dot(now[1] - now[2])));
  return depth > 0.0;
}

// The shortest way out for an edge pq that crossed triangle abc (now[0..4]) before this step
// already: to the face's front or back, by the depth of its end furthest behind, or past one
// of the triangle's edges rs towards the face's front, along the common perpendicular of the
// two lines by their distance, whichever is least (at most `reach`). The response "solver"'s:
// its constraints move the edge by the whole depth within the step, and a face's front taken
// blindly pushed the top face's diagonal of a box, crossed by a box resting on it, sideways
// out of the upper box's side by the reach instead of down by the fraction of a millimetre it
// was in.
bool least_way_out(const Vec3 (&now)[5], double reach, Vec3& normal, double& depth) {
  const Vec3 &p = now[0], &q = now[1];
  const Vec3 face = triangle_face(now[2], now[3], now[4]);
  const double length = face.norm();
  if (!(length > 0.0)) return false;
  const Vec3 front = face / length;
  const double hp = front.dot(p - now[2]), hq = front.dot(q - now[2]);
  depth = std::max(-hp, -hq);
  normal = front;
  if (std::max(hp, hq) < depth) {
    depth = std::max(hp, hq);
    normal = -front;
  }
  for (int k = 0; k < 3; ++k) {
    const Vec3 &r = now[2 + k], &t = now[2 + (k + 1) % 3];
    const Vec3 across = (q - p).cross(t - r);
    const double across_length = across.norm();
    if (!(across_length > 0.0)) continue;
    // The signed distance of pq's line from rs's along `across`: moved by it, pq's line
    // passes rs's on the other side, outside the triangle.
    const double distance = across.dot(p - r) / across_length;
    if (!(std::abs(distance) < depth)) continue;
    const Vec3 out = (distance > 0.0 ? -1.0 : 1.0) / across_length * across;
    // Past an edge to the face's back is into the body: pq's line passes a box's rim
    // outside already where it crosses the top face rising from inside, and moved past the
    // rim it crosses the side face instead (a letter leaning on a plate's rim stayed crossed).
    if (!(out.dot(front) > 0.0)) continue;
    depth = std::abs(distance);
    normal = out;
  }
  depth = std::min(depth, reach);
  return depth > 0.0;
}

// An edge whose angle to the plane of the triangle it crosses has a sine below this (about
// 11.5 degrees) is a face lying on a face rather than an edge through a surface: two faces
// divided into triangles about a cell across, resting on each other, cross wherever either
// bends by a fraction of a millimetre. The boxes' node contacts hold such faces apart; the
// paper's answer to such a crossing goes no deeper than the surface skin (a hundredth of a
// cell) a step. Answered in full, each bent the face into the next crossing and a slab
// landing on another threw nodes off (hard case many_contacts); not answered at all, a ring
// lying on a plate stayed crossed (random piles).
inline constexpr double kTangentEdgeSine = 0.2;

// Level 5's edge test, one half of a pair of cells of two objects: the deepest crossing of
// an edge of cell_b's triangles through one of cell_a's triangles (depth 0: none). Two
// surfaces can cross edge through edge with no vertex behind the other (thin parts, sharp
// edges), and a vertex that has gone past the middle of a thin part is nearest its far side
// and no longer behind (test_vertices). An edge that crosses a triangle now and did not at
// the start of the step came in during the step, and the start says from which side
// (edge_way_back); one that crossed already goes out of the face it crosses
// (crossed_way_out). Within one object edges are not tested: in parts thinner than a cell
// the pushes between a surface's own cells fed energy in.
// `least`: an edge crossed already takes the least way out (the solver's), not the way to
// the face's front (crossed_way_out, the paper's).
// `memory`: the edge tests' working memory (NarrowMemory::edge_tests, or a thread's own).
EdgeCrossing deepest_edge_crossing(const Model& model, const State& state, CollisionMemory& scratch, Index cell_b,
                                   Index cell_a, const CellSurface& surface, StageCounters& counters, bool least,
                                   NarrowMemory::EdgeTestMemory& memory) {
  EdgeCrossing deepest;
  const Index tri_begin = surface.triangle_begin[cell_a], tri_end = surface.triangle_begin[cell_a + 1];
  const Index edge_begin = surface.edge_begin[cell_b], edge_end = surface.edge_begin[cell_b + 1];
  if (tri_begin == tri_end || edge_begin == edge_end || cell_inverted(model, state, cell_a)) return deepest;
  const Index tri_count = tri_end - tri_begin;
  // The edges lie in the AABB of cell_b's triangles (of its edges' ends, for owned
  // triangles): only where it meets cell_a's can an edge cross a triangle.
  Vec3 reach_lo, reach_hi, edges_lo, edges_hi;
  bool corners_finite = true;
  // cell_a's triangles (corners, AABBs) and cell_b's edges' AABBs: the owned surfaces from
  // the per-cell cache, level 5's crossing triangles (test_edges) loaded for this pair.
  const Vec3* corners = scratch.triangle_corners.data();
  BoxColumns triangle_boxes{{scratch.triangle_lo[0].data(), scratch.triangle_lo[1].data(), scratch.triangle_lo[2].data()},
                            {scratch.triangle_hi[0].data(), scratch.triangle_hi[1].data(), scratch.triangle_hi[2].data()}};
  const Vec3* faces = nullptr;
  const Index edge_count = edge_end - edge_begin;
  BoxColumns edge_boxes{{memory.edge_lo[0].data(), memory.edge_lo[1].data(), memory.edge_lo[2].data()},
                        {memory.edge_hi[0].data(), memory.edge_hi[1].data(), memory.edge_hi[2].data()}};
  if (surface.crossing) {
    cell_triangle_bounds(model, state, scratch, cell_a, reach_lo, reach_hi);
    cell_triangle_bounds(model, state, scratch, cell_b, edges_lo, edges_hi);
  } else {
    const OwnedSurfaceCache& cache = scratch.owned_cache;
    refresh_owned_surface(model, state, scratch, cell_a);
    refresh_owned_surface(model, state, scratch, cell_b);
    corners_finite = cache.finite[cell_a] != 0;
    corners = cache.corners.data() + 3 * std::size_t{tri_begin};
    for (int axis = 0; axis < 3; ++axis) {
      triangle_boxes.lo[axis] = cache.triangle_lo[axis].data() + tri_begin;
      triangle_boxes.hi[axis] = cache.triangle_hi[axis].data() + tri_begin;
    }
    faces = cache.face.data() + tri_begin;
    for (int axis = 0; axis < 3; ++axis) {
      edge_boxes.lo[axis] = cache.edge_lo[axis].data() + edge_begin;
      edge_boxes.hi[axis] = cache.edge_hi[axis].data() + edge_begin;
    }
    reach_lo = cache.triangles_lo[cell_a];
    reach_hi = cache.triangles_hi[cell_a];
    edges_lo = cache.edges_lo[cell_b];
    edges_hi = cache.edges_hi[cell_b];
  }
  reach_lo = reach_lo.cwiseMax(edges_lo);
  reach_hi = reach_hi.cwiseMin(edges_hi);
  if ((reach_lo.array() > reach_hi.array()).any()) return deepest;
  // cell_a's triangles that reach into that region (all of them with a NaN about).
  if (surface.crossing) corners_finite = load_triangles(model, state, scratch, cell_a, surface);
  const bool finite = corners_finite && is_finite(reach_lo) && is_finite(reach_hi);
  Index* __restrict near = memory.candidates.data();
  Index candidates = tri_count;
  if (finite)
    candidates = boxes_meeting(triangle_boxes, tri_count, reach_lo, reach_hi, near);
  else
    for (Index t = 0; t < tri_count; ++t) near[t] = t;
  if (candidates == 0) return deepest;
  // Their AABBs, faces and first corners as columns: each edge's filter (triangles_straddled)
  // tests a vector of them at once, box and plane.
  for (Index c = 0; c < candidates; ++c) {
    const Index t = near[c];
    const Vec3* corner = corners + 3 * std::size_t{t};
    const Vec3 face = faces ? faces[t] : triangle_face(corner[0], corner[1], corner[2]);
    for (int axis = 0; axis < 3; ++axis) {
      memory.lo[axis][c] = triangle_boxes.lo[axis][t];
      memory.hi[axis][c] = triangle_boxes.hi[axis][t];
      memory.face[axis][c] = face[axis];
      memory.corner[axis][c] = corner[0][axis];
    }
  }
  const TriangleColumns candidate_triangles{
      {{memory.lo[0].data(), memory.lo[1].data(), memory.lo[2].data()},
       {memory.hi[0].data(), memory.hi[1].data(), memory.hi[2].data()}},
      {memory.face[0].data(), memory.face[1].data(), memory.face[2].data()},
      {memory.corner[0].data(), memory.corner[1].data(), memory.corner[2].data()}};
  // cell_b's edges whose AABB meets the region (levels 4 and 5: their bounds loaded here).
  if (surface.crossing)
    for (Index i = 0; i < edge_count; ++i) {
      const std::array<Index, 2>& edge = surface.edges[edge_begin + i];
      const Vec3& p = cached_vertex(model, state, scratch, edge[0]);
      const Vec3& q = cached_vertex(model, state, scratch, edge[1]);
      set_column_box(memory.edge_lo, memory.edge_hi, i, p.cwiseMin(q), p.cwiseMax(q));
    }
  // (A NaN compares false both ways: such an edge is tested, and crosses nothing.)
  Index* __restrict reaching = memory.edges.data();
  const Index reaching_count = boxes_meeting(edge_boxes, edge_count, reach_lo, reach_hi, reaching);
  Index* __restrict hits = memory.hits.data();
  for (Index k = 0; k < reaching_count; ++k) {
    const Index i = reaching[k];
    const std::array<Index, 2>& edge = surface.edges[edge_begin + i];
    const Vec3 lo(edge_boxes.lo[0][i], edge_boxes.lo[1][i], edge_boxes.lo[2][i]);
    const Vec3 hi(edge_boxes.hi[0][i], edge_boxes.hi[1][i], edge_boxes.hi[2][i]);
    const Vec3 p = cached_vertex(model, state, scratch, edge[0]);
    const Vec3 q = cached_vertex(model, state, scratch, edge[1]);
    counters.node_tests += candidates;
    // The triangles whose box meets the edge's and whose plane it passes through
    // (segment_crosses_triangle's first test).
    const Index hit_count = triangles_straddled(candidate_triangles, candidates, p, q, lo, hi, hits);
    for (Index h = 0; h < hit_count; ++h) {
      const Index t = near[hits[h]];
      const Index triangle = surface.triangles[tri_begin + t];
      const std::array<Index, 3>& tri = model.surface_triangles[triangle];
      const Vec3 now[5] = {p, q, corners[3 * t], corners[3 * t + 1], corners[3 * t + 2]};
      if (!line_through_triangle(p, q, now[2], now[3], now[4])) continue;
      // A face lying on a face (kTangentEdgeSine): the paper's answer is held to the skin.
      const Vec3 plane(memory.face[0][hits[h]], memory.face[1][hits[h]], memory.face[2][hits[h]]);
      const bool tangent = !least && std::abs(plane.dot(q - p)) < kTangentEdgeSine * plane.norm() * (q - p).norm();
      const std::vector<Vec3>& x0 = scratch.x_start;
      const Vec3 start[5] = {surface_vertex(model, x0, edge[0]), surface_vertex(model, x0, edge[1]),
                             surface_vertex(model, x0, tri[0]), surface_vertex(model, x0, tri[1]),
                             surface_vertex(model, x0, tri[2])};
      Vec3 normal;
      double depth = 0.0;
      const bool crossed_at_start = segment_crosses_triangle(start[0], start[1], start[2], start[3], start[4]);
      if (crossed_at_start) {
        if (!(least ? least_way_out(now, model.surface_contact_radius, normal, depth)
                    : crossed_way_out(now, model.surface_contact_radius, normal, depth)))
          continue;
      } else if (!edge_way_back(now, start, model.surface_contact_radius, normal, depth)) {
        continue;
      }
      if (tangent) depth = std::min(depth, model.surface_skin);
      if (!(depth > deepest.depth)) continue;
      deepest.depth = depth;
      deepest.normal = normal;
      deepest.fresh = !crossed_at_start;
      deepest.edge = edge;
      deepest.triangle = triangle;
      // Where the edge meets the triangle's plane: that far along it, and where in the
      // triangle (its barycentric coordinates; the crossing lies inside, edges included).
      const Vec3 face = triangle_face(now[2], now[3], now[4]);
      const double hp = face.dot(p - now[2]), hq = face.dot(q - now[2]);
      deepest.along = hp != hq ? hp / (hp - hq) : 0.5;
      deepest.point = p + deepest.along * (q - p);
      const double area_sq = face.squaredNorm();
      const double u = (now[4] - now[3]).cross(deepest.point - now[3]).dot(face) / area_sq;
      const double v = (now[2] - now[4]).cross(deepest.point - now[4]).dot(face) / area_sq;
      deepest.barycentric = Vec3(u, v, 1.0 - u - v);
      // The cells that carry the edge's end and the triangle's corner nearest to the
      // crossing (a long edge's ends, and so what moves it, may be cells away from the
      // pair's cells).
      const auto nearest = [&](std::initializer_list<Index> vertices, std::initializer_list<Vec3> at) {
        Index best = *vertices.begin();
        double best_sq = INFINITY;
        auto v = vertices.begin();
        for (const Vec3& x : at) {
          const double d_sq = (x - deepest.point).squaredNorm();
          if (d_sq < best_sq) {
            best_sq = d_sq;
            best = *v;
          }
          ++v;
        }
        return model.surface_vertex_cell[best];
      };
      deepest.carrier_b = nearest({edge[0], edge[1]}, {p, q});
      deepest.carrier_a = nearest({tri[0], tri[1], tri[2]}, {now[2], now[3], now[4]});
    }
  }
  return deepest;
}

// The paper's answer to an edge crossing (deepest_edge_crossing), at once: the cells that
// carry the edge's end and the triangle's corner nearest to it move apart, once per pair
// half, as a vertex contact moves its cells. Not under the response "solver", which takes the
// crossing as a constraint (contact_solver.cpp, find_edge_contacts): answered here, its
// springs and contacts, solved after, moved what this answered, and the edge contacts left
// more surfaces crossed than without them
// (docs/notes/2026-11-28-code-findings.md#edges-within-one-object-and-under-the-solver).
template <bool kFriction>
void test_edges(const Model& model, State& state, CollisionMemory& scratch, Index cell_b, Index cell_a,
                const CellSurface& surface, StageCounters& counters, double& max_depth) {
  const EdgeCrossing crossing = deepest_edge_crossing(model, state, scratch, cell_b, cell_a, surface, counters, false,
                                                       scratch.edge_tests);
  if (!(crossing.depth > 0.0)) return;
  ++counters.inter_contacts;
  max_depth = std::max(max_depth, crossing.depth);
  scratch.record_contact(crossing.point, crossing.normal, crossing.depth, ContactKind::Inter);
  // Past the face by the skin, as a vertex is put. A crossing made during this step is a
  // fresh contact and also rebounds (response.h; nothing at alpha = 1): moved out without
  // it, the edge kept (1 - alpha) of its approach and crossed again the next step, and at
  // level 4 the pushes fed energy in (docs/notes/2026-11-28-code-findings.md#edge-rebound).
  // One crossed already does not: its normal says little about how it got in.
  respond_pair<kFriction>(model, state, crossing.carrier_a, crossing.carrier_b, crossing.normal,
                          crossing.depth + model.surface_skin, scratch.planes_hold, crossing.fresh);
  invalidate_surface_around(model, scratch, crossing.carrier_a);
  invalidate_surface_around(model, scratch, crossing.carrier_b);
}

// The edge contacts' pairs of cells of two objects whose owned triangles' bounds meet, at
// every level: found by the broad phase over those bounds, one per cell (Model::boxes), in
// place of the step's boxes' (whose pairs, answered by now, are not needed again this step).
// A triangle spans cells, its corners moved by the cells they are bound to, and across a bent
// lattice it leaves the boxes: paired by boxes, an edge passed through another surface unseen,
// and found crossed steps later it was pushed out on the far side (the fast_impact hard case:
// a bullet through its plate); paired by level 4's sub-boxes, a letter's side, one triangle a
// few cells long, crossed a plate where no cell that carries its corners met the plate, and
// stayed crossed at rest. A cell that owns no triangle has no edge either, and nothing to
// test: it stands at a point, its first node.
void pair_cells_by_triangles(const Model& model, const BoxSet& step_boxes, const State& state, CollisionMemory& scratch,
                             StageCounters& counters) {
  const BoxSet& boxes = model.boxes;
  // Every cell's surface vertices, then every box's bounds, in chunks over the pool: a chunk
  // writes only its own cells' vertices and its own boxes' bounds, and the values are the ones
  // the lazy cache would give, so the state is the same bit for bit whatever the thread count.
  constexpr Index kPerChunk = 64;
  const auto cells = static_cast<Index>(model.cell_count());
  parallel_for(scratch.pool, (cells + kPerChunk - 1) / kPerChunk, [&](std::uint32_t chunk, std::uint32_t) {
    for (Index cell = chunk * kPerChunk; cell < std::min(cells, (chunk + 1) * kPerChunk); ++cell)
      if (!scratch.surface_cell_fresh[cell]) refresh_cell_vertices(model, state, scratch, cell);
  });
  const auto box_count = static_cast<Index>(boxes.size());
  parallel_for(scratch.pool, (box_count + kPerChunk - 1) / kPerChunk, [&](std::uint32_t chunk, std::uint32_t) {
    for (Index b = chunk * kPerChunk; b < std::min(box_count, (chunk + 1) * kPerChunk); ++b) {
      const Index cell = boxes.box_cell[b];
      Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
      for (Index t = model.cell_owned_triangle_begin[cell]; t < model.cell_owned_triangle_begin[cell + 1]; ++t)
        for (Index v : model.surface_triangles[model.cell_owned_triangles[t]]) {
          lo = lo.cwiseMin(scratch.surface_x[v]);  // fresh: every cell was mapped above
          hi = hi.cwiseMax(scratch.surface_x[v]);
        }
      const bool has_triangles = (lo.array() <= hi.array()).all();
      const Vec3& node = state.x[model.cell_nodes[cell][0]];
      for (int axis = 0; axis < 3; ++axis) {
        scratch.surface_lo[axis][b] = has_triangles ? lo[axis] : node[axis];
        scratch.surface_hi[axis][b] = has_triangles ? hi[axis] : node[axis];
      }
    }
  });
  std::swap(scratch.box_lo, scratch.surface_lo);
  std::swap(scratch.box_hi, scratch.surface_hi);
  // The sleepers' wake margins are kept per box: the cells' here, the step's again after.
  if (sleeping(model)) set_wake_margins(model, boxes, state, scratch);
  grow_box_bounds(model, boxes, 0.0, scratch, scratch);
  PairQuery query;
  query.inter = true;
  query.ordered = false;  // sorted by cells below
  find_pairs(model, boxes, query, scratch, scratch, scratch.pool, counters);
  if (sleeping(model)) set_wake_margins(model, step_boxes, state, scratch);
  std::swap(scratch.box_lo, scratch.surface_lo);
  std::swap(scratch.box_hi, scratch.surface_hi);
}

// The pairs of cells of two objects the edge tests take, each once and in cell order, both
// awake or one of them: the cells whose owned triangles' bounds meet (pair_cells_by_triangles).
// Into NarrowMemory::cell_pair_keys as (lower << 32 | higher); returns how many.
Index find_edge_cell_pairs(const Model& model, const BoxSet& step_boxes, const State& state, CollisionMemory& scratch,
                           StageCounters& counters) {
  begin_surface_tests(scratch);
  pair_cells_by_triangles(model, step_boxes, state, scratch, counters);
  const BoxSet& boxes = model.boxes;
  std::uint64_t* keys = scratch.cell_pair_keys.data();
  Index count = 0;
  for (Index p = 0; p < scratch.pair_count; ++p) {
    const Index c1 = boxes.box_cell[scratch.pairs[p].a], c2 = boxes.box_cell[scratch.pairs[p].b];
    if (model.cell_object[c1] == model.cell_object[c2]) continue;
    if (state.asleep[model.cell_object[c1]] && state.asleep[model.cell_object[c2]]) continue;
    keys[count++] = static_cast<std::uint64_t>(std::min(c1, c2)) << 32 | std::max(c1, c2);
  }
  std::sort(keys, keys + count);
  return static_cast<Index>(std::unique(keys, keys + count) - keys);
}

std::pair<Index, Index> edge_cell_pair(const CollisionMemory& scratch, Index k) {
  const std::uint64_t key = scratch.cell_pair_keys[k];
  return {static_cast<Index>(key >> 32), static_cast<Index>(key & 0xffffffffu)};
}

// on_pair(c1, c2) for each of find_edge_cell_pairs' pairs, in order.
template <class OnPair>
void for_each_edge_cell_pair(const Model& model, const BoxSet& boxes, const State& state, CollisionMemory& scratch,
                             StageCounters& counters, const OnPair& on_pair) {
  const Index count = find_edge_cell_pairs(model, boxes, state, scratch, counters);
  for (Index k = 0; k < count; ++k) {
    const auto [c1, c2] = edge_cell_pair(scratch, k);
    on_pair(c1, c2);
  }
}

// Under the paper's response, after the boxes' responses: level 5's edge contacts
// (test_edges) on every pair of cells of two objects whose owned triangles' bounds meet
// (for_each_edge_cell_pair). The boxes stop most of a thin part's way in, but two crossed
// like an X hold no node of each other, and a crossing once made stayed
// (docs/results/piles.md: the rows without edge contacts); the exact edges send a crossed
// edge back the way it came.
template <bool kFriction>
void answer_crossed_edges(const Model& model, const BoxSet& boxes, State& state, CollisionMemory& scratch,
                          StageCounters& counters, double& max_depth) {
  const CellSurface surface = owned_surface(model);
  for_each_edge_cell_pair(model, boxes, state, scratch, counters, [&](Index c1, Index c2) {
    test_edges<kFriction>(model, state, scratch, c1, c2, surface, counters, max_depth);
    test_edges<kFriction>(model, state, scratch, c2, c1, surface, counters, max_depth);
  });
}

}  // namespace

bool nodes_near(const Model& model, const BoxLevel& level, const State& state, const CollisionMemory& scratch, Index mover,
                const BoxPlanes& planes, double margin) {
  if (planes.degenerate) return false;
  const int node_count = tested_node_count(level);
  for (int k = 0; k < node_count; ++k)
    if (near_face(planes, tested_node(model, level, state, scratch, mover, k), margin).face >= 0) return true;
  return false;
}

namespace {

// box_overlap() on boxes a and b as the scratch holds them, their planes given; a degenerate
// box overlaps nothing.
BoxOverlap boxes_overlap(const CollisionMemory& scratch, Index a, const BoxPlanes& planes_a, Index b,
                         const BoxPlanes& planes_b, double skin, const Vec3& relative_velocity = Vec3::Zero(),
                         double recent = 0.0) {
  if (planes_a.degenerate || planes_b.degenerate) return BoxOverlap{};
  return box_overlap(planes_a, scratch.box_nodes[a].data(), 8, planes_b, scratch.box_nodes[b].data(), 8, skin,
                     relative_velocity, recent);
}
// The same, the planes taken here.
BoxOverlap boxes_overlap(const CollisionMemory& scratch, Index a, Index b, double skin,
                         const Vec3& relative_velocity = Vec3::Zero(), double recent = 0.0) {
  return boxes_overlap(scratch, a, box_planes(scratch.box_nodes[a]), b, box_planes(scratch.box_nodes[b]), skin,
                       relative_velocity, recent);
}

// "box_overlap": boxes b1 and b2 of two objects, their nodes answered, that still overlap
// (or come within the skin) are moved apart as wholes, along the axis they came in along in
// the last two steps, else the shortest way out. Thin boxes crossing like an X hold no node
// of each other, or only a corner just inside.
template <bool kFriction>
void separate_boxes(const Model& model, const BoxSet& boxes, State& state, CollisionMemory& scratch, Index b1, Index b2,
                    PairSink& sink) {
  ensure_box(model, boxes, state, scratch, b1, sink.counters);
  ensure_box(model, boxes, state, scratch, b2, sink.counters);
  const Index cell_1 = boxes.box_cell[b1], cell_2 = boxes.box_cell[b2];
  const Vec3 relative_velocity =
      mean_velocity(state, model.cell_nodes[cell_2]) - mean_velocity(state, model.cell_nodes[cell_1]);
  const BoxOverlap overlap =
      boxes_overlap(scratch, b1, b2, model.box_skin, relative_velocity, kRecentEntrySteps * model.settings.dt);
  if (!overlap.overlapping) return;
  ++sink.counters.inter_contacts;
  const double box_depth = std::max(0.0, overlap.depth - model.box_skin);
  sink.max_depth = std::max(sink.max_depth, box_depth);
  sink.record(0.5 * (scratch.box_nodes[b1][8] + scratch.box_nodes[b2][8]), overlap.normal, box_depth, ContactKind::Inter);
  // Eq. 8-9 without a rebound: the push is geometric (the exact level answers the same way),
  // and a rebound kick from it sent fast bodies flying (the fast_impact hard case).
  respond_pair<kFriction>(model, state, cell_1, cell_2, overlap.normal, overlap.depth, scratch.planes_hold,
                          /*may_rebound=*/false);
  invalidate_around(model, boxes, scratch, cell_1);
  invalidate_around(model, boxes, scratch, cell_2);
}

// Pair p of the step's list, answered as Algorithm 1 does: a pair with a node of one box in
// the other, or whose boxes a response has moved since the detection, is tested again, and
// each node found inside gets its response at once.
template <bool kFriction>
void answer_pair(const Model& model, const BoxLevel& level, State& state, CollisionMemory& scratch, Index p, PairSink& sink) {
  const BoxSet& boxes = *level.boxes;
  const Index b1 = scratch.pairs[p].a, b2 = scratch.pairs[p].b;
  const Index object_1 = model.cell_object[boxes.box_cell[b1]], object_2 = model.cell_object[boxes.box_cell[b2]];
  if (state.asleep[object_1] && state.asleep[object_2]) return;  // two sleepers never meet
  if (sleeping(model)) meet(state, object_1, object_2);  // a moving object wakes a sleeper it meets
  const bool same_object = object_1 == object_2;
  if (same_object) ++sink.counters.self_pairs_tested;
  else ++sink.counters.inter_pairs_tested;
  if (!scratch.pair_hit[p] && !scratch.box_moved[b1] && !scratch.box_moved[b2]) return;
  ++sink.retested;
  ensure_box(model, boxes, state, scratch, b1, sink.counters);
  ensure_box(model, boxes, state, scratch, b2, sink.counters);
  test_nodes<kFriction>(model, level, state, scratch, b1, b2, same_object, sink);
  test_nodes<kFriction>(model, level, state, scratch, b2, b1, same_object, sink);
  if (!same_object && model.box_skin > 0.0) separate_boxes<kFriction>(model, boxes, state, scratch, b1, b2, sink);
}

// A pair's answer reads and writes only its two objects: their nodes, their boxes' nodes and
// flags, their sleep state. So a pair only has to wait for the earlier pairs of its two
// objects, and pairs of other objects can be answered meanwhile on another thread. Each pair
// takes a turn among each of its objects' pairs (their order in the list) and waits until
// both objects have answered the turns before it; it then sees its objects exactly as the
// sequential loop would have left them, and the result is Algorithm 1's, bit for bit. The
// threads take the pairs in wave order (a pair's wave: one more than the last wave of a pair
// sharing an object with it), so that the pairs taken side by side seldom wait on each other.
// Worth it where the list holds many objects (the letters); a few objects (two teapots) make
// about as many waves as pairs, and one thread answers them in order.
template <bool kFriction>
bool answer_in_waves(const Model& model, const BoxLevel& level, State& state, CollisionMemory& scratch,
                     StageCounters& counters, double& max_depth, Index& retested) {
  constexpr Index kMinPairs = 64, kMinPairsPerWave = 2;  // below: waits and hand-offs cost more than they save
  constexpr Index kPairsPerChunk = 16;
  scratch.narrow_waves = 0;
  const Index pairs = scratch.pair_count;
  if (!scratch.pool || scratch.pool->threads() < 2 || pairs < kMinPairs || scratch.wave_pairs.size() < pairs)
    return false;
  const BoxSet& boxes = *level.boxes;
  std::fill(scratch.object_wave.begin(), scratch.object_wave.end(), std::uint32_t{0});
  std::fill(scratch.object_turn.begin(), scratch.object_turn.end(), std::uint32_t{0});
  std::uint32_t waves = 0;
  for (Index p = 0; p < pairs; ++p) {
    const Index o1 = model.cell_object[boxes.box_cell[scratch.pairs[p].a]];
    const Index o2 = model.cell_object[boxes.box_cell[scratch.pairs[p].b]];
    const std::uint32_t wave = std::max(scratch.object_wave[o1], scratch.object_wave[o2]);
    scratch.pair_wave[p] = wave;
    scratch.object_wave[o1] = scratch.object_wave[o2] = wave + 1;
    waves = std::max(waves, wave + 1);
    scratch.pair_turn[p][0] = scratch.object_turn[o1]++;
    scratch.pair_turn[p][1] = o2 == o1 ? scratch.pair_turn[p][0] : scratch.object_turn[o2]++;
  }
  if (static_cast<Index>(waves) * kMinPairsPerWave > pairs) return false;
  scratch.narrow_waves = waves;
  // The pairs by wave (a counting sort; list order within a wave).
  std::vector<Index>& begin = scratch.wave_begin;
  std::fill(begin.begin(), begin.begin() + waves + 1, Index{0});
  for (Index p = 0; p < pairs; ++p) ++begin[scratch.pair_wave[p] + 1];
  for (std::uint32_t w = 0; w < waves; ++w) begin[w + 1] += begin[w];
  for (Index p = 0; p < pairs; ++p) scratch.wave_pairs[begin[scratch.pair_wave[p]]++] = p;
  for (std::uint32_t w = waves; w > 0; --w) begin[w] = begin[w - 1];  // back to each wave's first pair
  begin[0] = 0;

  for (NarrowMemory::NarrowWorkspace& w : scratch.narrow_workspaces) {
    w.counters = StageCounters{};
    w.max_depth = 0.0;
    w.retested = 0;
    w.held = 0;
    w.recorded = 0;
  }
  std::fill(scratch.object_answered.begin(), scratch.object_answered.end(), std::uint32_t{0});
  // Chunks are claimed in increasing order, and a pair waits only for pairs of earlier waves,
  // which lie in earlier chunks (claimed, so being answered) or earlier in its own: the pair
  // furthest behind never waits, so the answering always progresses.
  const Index chunks = (pairs + kPairsPerChunk - 1) / kPairsPerChunk;
  scratch.pool->parallel_for(chunks, [&](std::uint32_t chunk, std::uint32_t thread) {
    NarrowMemory::NarrowWorkspace& w = scratch.narrow_workspaces[thread];
    PairSink sink{w.counters, w.max_depth, w.retested, scratch, &w};
    for (Index i = chunk * kPairsPerChunk; i < std::min(pairs, (chunk + 1) * kPairsPerChunk); ++i) {
      const Index p = scratch.wave_pairs[i];
      const Index o1 = model.cell_object[boxes.box_cell[scratch.pairs[p].a]];
      const Index o2 = model.cell_object[boxes.box_cell[scratch.pairs[p].b]];
      std::atomic_ref<std::uint32_t> answered_1(scratch.object_answered[o1]), answered_2(scratch.object_answered[o2]);
      const std::array<std::uint32_t, 2> turn = scratch.pair_turn[p];
      int spins = 0;
      while (answered_1.load(std::memory_order_acquire) != turn[0] ||
             answered_2.load(std::memory_order_acquire) != turn[1])
        spin_wait(spins);
      sink.next_key = static_cast<std::uint64_t>(p) << 20;  // a pair finds fewer than 2^20 contacts
      answer_pair<kFriction>(model, level, state, scratch, p, sink);
      answered_1.store(turn[0] + 1, std::memory_order_release);
      if (o2 != o1) answered_2.store(turn[1] + 1, std::memory_order_release);
    }
  });

  // The threads' shares, summed; their contacts merged in key order into the step's list.
  const auto by_key = [](const NarrowMemory::KeyedContact& a, const NarrowMemory::KeyedContact& b) { return a.key < b.key; };
  std::uint64_t found = 0;
  for (NarrowMemory::NarrowWorkspace& w : scratch.narrow_workspaces) {
    const StageCounters& c = w.counters;
    counters.boxes_updated += c.boxes_updated;
    counters.node_tests += c.node_tests;
    counters.inter_pairs_tested += c.inter_pairs_tested;
    counters.self_pairs_tested += c.self_pairs_tested;
    counters.inter_contacts += c.inter_contacts;
    counters.self_contacts += c.self_contacts;
    max_depth = std::max(max_depth, w.max_depth);
    retested += w.retested;
    found += w.recorded;
    std::sort_heap(w.contacts.begin(), w.contacts.begin() + w.held, by_key);
    w.merged = 0;
  }
  std::uint64_t kept = 0;
  while (scratch.contact_count < scratch.contacts.size()) {
    NarrowMemory::NarrowWorkspace* next = nullptr;
    for (NarrowMemory::NarrowWorkspace& w : scratch.narrow_workspaces)
      if (w.merged < w.held && (!next || w.contacts[w.merged].key < next->contacts[next->merged].key)) next = &w;
    if (!next) break;
    scratch.contacts[scratch.contact_count++] = next->contacts[next->merged++].contact;
    ++kept;
  }
  scratch.contacts_dropped += static_cast<std::uint32_t>(found - kept);
  return true;
}

}  // namespace

bool pair_hit(const Model& model, const BoxLevel& level, const State& state, const CollisionMemory& scratch, Index p,
              double margin, const BoxPlanes* planes) {
  const BoxSet& boxes = *level.boxes;
  const BoxPair& pair = scratch.pairs[p];
  const Index o1 = model.cell_object[boxes.box_cell[pair.a]], o2 = model.cell_object[boxes.box_cell[pair.b]];
  const bool other = o1 != o2;
  const double skin = other ? level.skin : 0.0;
  // (A pair of two sleepers is not looked at; should one of them wake before its turn, it is
  // tested then.)
  if (state.asleep[o1] && state.asleep[o2]) return true;
  const auto near = [&](Index mover, Index container) {
    if (planes) return nodes_near(model, level, state, scratch, mover, planes[container], margin + skin);
    return nodes_near(model, level, state, scratch, mover, box_planes(scratch.box_nodes[container]), margin + skin);
  };
  if (near(pair.a, pair.b) || near(pair.b, pair.a)) return true;
  if (!other || !(model.box_skin > 0.0)) return false;
  return planes ? boxes_overlap(scratch, pair.a, planes[pair.a], pair.b, planes[pair.b], model.box_skin).overlapping
                : boxes_overlap(scratch, pair.a, pair.b, model.box_skin).overlapping;
}

void find_pair_hits(const Model& model, const BoxLevel& level, const State& state, CollisionMemory& scratch,
                    StageCounters& counters, double margin) {
  const Index pairs = scratch.pair_count;
  constexpr Index kPairsPerChunk = 32;
  auto detect = [&](std::uint32_t chunk, std::uint32_t) {
    for (Index p = chunk * kPairsPerChunk; p < std::min(pairs, (chunk + 1) * kPairsPerChunk); ++p)
      scratch.pair_hit[p] = pair_hit(model, level, state, scratch, p, margin);
  };
  const Index chunks = (pairs + kPairsPerChunk - 1) / kPairsPerChunk;
  parallel_for(scratch.pool, chunks, detect);
  counters.node_tests += 2 * tested_node_count(level) * pairs;
}

template <bool kFriction>
void collide_boxes(const Model& model, const BoxLevel& level, State& state, CollisionMemory& scratch, StageCounters& counters,
                   double& max_depth) {
  const BoxSet& boxes = *level.boxes;
  const Index pairs = scratch.pair_count;
  // The detection costs what testing every pair costs, spread over the threads; it pays where
  // few pairs need testing again after it: with T threads, fewer than 1 - 1/T of them (the
  // share of the last step). Either way the result is the same: without it, every pair is
  // tested in the response loop below, as Algorithm 1 does.
  const int threads = scratch.pool ? scratch.pool->threads() : 1;
  const bool detecting = threads > 1 && scratch.narrow_retested_share < 1.0 - 1.0 / threads;
  if (detecting) {
    find_pair_hits(model, level, state, scratch, counters, 0.0);
  } else {
    std::fill(scratch.pair_hit.begin(), scratch.pair_hit.begin() + pairs, std::uint8_t{1});
  }
  // Response, in pair order: Algorithm 1, each pair tested as the earlier responses left it
  // (a response moves nodes, and with them the boxes around). A pair whose boxes no response
  // has moved since the detection is as the detection found it: without a hit there, it has
  // none now either, and is passed over. So the result is Algorithm 1's in this order.
  // A box left stale before the detection counts as moved: the detection read it as it was
  // (where the planes answer first, they move cells and leave their neighbours' boxes to be
  // updated when next needed), and its pairs are tested again. Taken as found, a pair the
  // detection missed that way was passed over on two threads and answered on one (a random
  // pile with box_overlap and edge contacts, switched from level 5 to level 0).
  for (Index b = 0; b < static_cast<Index>(boxes.size()); ++b) scratch.box_moved[b] = scratch.box_valid[b] ? 0 : 1;
  Index retested = 0;
  if (!answer_in_waves<kFriction>(model, level, state, scratch, counters, max_depth, retested)) {
    PairSink sink{counters, max_depth, retested, scratch};
    for (Index p = 0; p < pairs; ++p) answer_pair<kFriction>(model, level, state, scratch, p, sink);
  }
  if (detecting || pairs == 0) scratch.narrow_retested_share = pairs ? static_cast<double>(retested) / pairs : 0.0;
  else scratch.narrow_retested_share *= 0.9;  // try the detection again now and then
  if (level.edges) answer_crossed_edges<kFriction>(model, boxes, state, scratch, counters, max_depth);
}

// Level 5's candidate pairs, in order: on_pair(c1, c2, same_object) for each with an object
// awake, after a moving object wakes a sleeper it meets; counts the pairs tested.
template <class OnPair>
void for_each_surface_pair(const Model& model, State& state, CollisionMemory& scratch, StageCounters& counters,
                           const OnPair& on_pair) {
  const BoxSet& boxes = model.boxes;
  begin_surface_tests(scratch);
  for (Index p = 0; p < scratch.pair_count; ++p) {
    const Index c1 = boxes.box_cell[scratch.pairs[p].a], c2 = boxes.box_cell[scratch.pairs[p].b];
    if (state.asleep[model.cell_object[c1]] && state.asleep[model.cell_object[c2]]) continue;
    if (sleeping(model)) meet(state, model.cell_object[c1], model.cell_object[c2]);
    const bool same_object = model.cell_object[c1] == model.cell_object[c2];
    if (same_object) ++counters.self_pairs_tested;
    else ++counters.inter_pairs_tested;
    on_pair(c1, c2, same_object);
  }
}

template <bool kFriction>
void collide_surfaces(const Model& model, State& state, CollisionMemory& scratch, StageCounters& counters, double& max_depth) {
  for_each_surface_pair(model, state, scratch, counters, [&](Index c1, Index c2, bool same_object) {
    test_vertices<kFriction>(model, state, scratch, c1, c2, same_object, counters, max_depth);
    test_vertices<kFriction>(model, state, scratch, c2, c1, same_object, counters, max_depth);
    if (!same_object && state.params.response == ContactResponse::Paper) {  // test_edges says why
      test_edges<kFriction>(model, state, scratch, c1, c2, crossing_surface(model), counters, max_depth);
      test_edges<kFriction>(model, state, scratch, c2, c1, crossing_surface(model), counters, max_depth);
    }
  });
}

void find_vertex_contacts(const Model& model, State& state, CollisionMemory& scratch, StageCounters& counters, double margin,
                          VertexContactSink& sink) {
  // Hands a contact to the sink with where on its triangle the closest point lies, as the
  // corners are now; a sliver has no such point and is left out.
  const auto emit = [&](VertexContact contact, bool same_object) {
    const std::array<Index, 3>& tri = model.surface_triangles[contact.triangle];
    const Vec3& a = cached_vertex(model, state, scratch, tri[0]);
    const Vec3 ab = cached_vertex(model, state, scratch, tri[1]) - a;
    const Vec3 ac = cached_vertex(model, state, scratch, tri[2]) - a;
    const Vec3 aq = contact.closest - a;
    const double d00 = ab.dot(ab), d01 = ab.dot(ac), d11 = ac.dot(ac), d20 = aq.dot(ab), d21 = aq.dot(ac);
    const double denominator = d00 * d11 - d01 * d01;
    if (!(denominator > 0.0)) return;
    const double v = std::clamp((d11 * d20 - d01 * d21) / denominator, 0.0, 1.0);
    const double w = std::clamp((d00 * d21 - d01 * d20) / denominator, 0.0, 1.0 - v);
    contact.barycentric = Vec3(1.0 - v - w, v, w);
    sink.add(contact, same_object);
  };
  // Of one half of a cell pair, every vertex behind the other's surface is a constraint: the
  // deepest alone leaves the others crossed while it is pushed out, and the solver shares
  // the push between them. Where none is behind, the nearest within the margin is one, so
  // that a pair about to meet is held before it crosses (a constraint per vertex in front
  // would stack dozens on two cells and set piles shaking).
  const double floor = -margin;
  for_each_surface_pair(model, state, scratch, counters, [&](Index c1, Index c2, bool same_object) {
    for (const auto& [cell_b, cell_a] : {std::pair{c1, c2}, std::pair{c2, c1}}) {
      bool any_inside = false;
      double nearest = floor;
      VertexContact nearest_contact;
      judge_vertices(model, state, scratch, cell_b, cell_a, same_object, counters, floor, [&](const VertexContact& c) {
        if (c.inside) {
          any_inside = true;
          emit(c, same_object);
        } else if (c.depth > nearest) {
          nearest = c.depth;
          nearest_contact = c;
        }
      });
      if (!any_inside && nearest > floor) emit(nearest_contact, same_object);
    }
  });
}

template <bool kFriction>
void collide_planes(const Model& model, const BoxLevel& level, State& state, CollisionMemory& scratch, StageCounters& counters,
                    double& max_depth) {
  const double beta = kFriction ? state.params.beta : 0.0;
  const BoxSet& boxes = *level.boxes;
  const int node_count = tested_node_count(level);
  for (const PlaneModel& plane : model.planes) {
    for (Index b = 0; b < boxes.size(); ++b) {
      const Index cell = boxes.box_cell[b];
      if (state.asleep[model.cell_object[cell]]) continue;  // frozen where it rests
      ensure_box(model, boxes, state, scratch, b, counters);
      // The box's AABB bounds its nodes (and level 3's surface nodes): if its lowest corner
      // along the normal is above the plane, so is every node.
      double support = -plane.offset;
      for (int axis = 0; axis < 3; ++axis)
        support += plane.normal[axis] * (plane.normal[axis] > 0.0 ? scratch.box_lo[axis][b] : scratch.box_hi[axis][b]);
      if (!level.exact && support >= 0.0) continue;
      if (level.samples) {
        // The surface nodes lie in the box, and trilinear FFD (eq. 2) maps a point of the box
        // into the hull of its 8 mapped corners: a box with every corner above the plane has
        // no node below it. Same result, without mapping 26 nodes of every box every step.
        double lowest = INFINITY;
        for (int k = 0; k < 8; ++k) lowest = std::min(lowest, plane.normal.dot(scratch.box_nodes[b][k]) - plane.offset);
        counters.node_tests += 8;
        if (!(lowest < 0.0)) continue;
      }
      double deepest = 0.0;
      Vec3 deepest_point = Vec3::Zero();
      auto consider = [&](const Vec3& p) {
        const double height = plane.normal.dot(p) - plane.offset;
        if (height < deepest) {
          deepest = height;
          deepest_point = p;
        }
      };
      if (level.exact) {
        for (Index i = model.cell_vertex_begin[cell]; i < model.cell_vertex_begin[cell + 1]; ++i)
          consider(surface_vertex(model, state.x, model.cell_vertices[i]));
        counters.node_tests += model.cell_vertex_begin[cell + 1] - model.cell_vertex_begin[cell];
      } else {
        for (int k = 0; k < node_count; ++k) consider(tested_node(model, level, state, scratch, b, k));
        counters.node_tests += node_count;
      }
      if (!(deepest < 0.0)) continue;
      const double r = -deepest;
      ++counters.plane_contacts;
      max_depth = std::max(max_depth, r);
      scratch.record_contact(deepest_point, plane.normal, r, ContactKind::Plane);
      // The plane does not move: the whole correction is the cell's.
      answer_at_once(model, state, ResponseSide::plane(), ResponseSide::of_cell(cell), plane.normal, r, beta, true);
      invalidate_around(model, boxes, scratch, cell);
      ensure_box(model, boxes, state, scratch, b, counters);
    }
  }
}

// Detection only (nothing moves), so the pairs spread over the pool: every cell of a pair has
// its owned-surface cache filled first (each by one thread), a pair's two halves are written
// to its own two slots of edge_crossings, and the crossings found are then packed in pair
// order, the list one thread finds.
void find_crossed_edges(const Model& model, const BoxSet& boxes, const State& state, CollisionMemory& scratch,
                        StageCounters& counters) {
  const CellSurface surface = owned_surface(model);
  const Index pairs = find_edge_cell_pairs(model, boxes, state, scratch, counters);
  EdgeCrossing* crossings = scratch.edge_crossings.data();
  const auto test_halves = [&](Index k, StageCounters& thread_counters, NarrowMemory::EdgeTestMemory& edge_tests) {
    const auto [c1, c2] = edge_cell_pair(scratch, k);
    crossings[2 * k] = deepest_edge_crossing(model, state, scratch, c1, c2, surface, thread_counters, true, edge_tests);
    crossings[2 * k + 1] =
        deepest_edge_crossing(model, state, scratch, c2, c1, surface, thread_counters, true, edge_tests);
  };
  if (scratch.narrow_workspaces.size() < 2) {
    for (Index k = 0; k < pairs; ++k) test_halves(k, counters, scratch.edge_tests);
  } else {
    std::uint8_t* in_pair = scratch.edge_cell_in_pair.data();
    for (Index k = 0; k < pairs; ++k) {
      const auto [c1, c2] = edge_cell_pair(scratch, k);
      in_pair[c1] = in_pair[c2] = 1;
    }
    constexpr Index kCellsPerChunk = 64, kPairsPerChunk = 8;
    const auto cells = static_cast<Index>(model.cell_count());
    parallel_for(scratch.pool, (cells + kCellsPerChunk - 1) / kCellsPerChunk, [&](std::uint32_t chunk, std::uint32_t) {
      for (Index cell = chunk * kCellsPerChunk; cell < std::min(cells, (chunk + 1) * kCellsPerChunk); ++cell)
        if (in_pair[cell]) {
          refresh_owned_surface(model, state, scratch, cell);
          in_pair[cell] = 0;
        }
    });
    for (NarrowMemory::NarrowWorkspace& w : scratch.narrow_workspaces) w.counters = StageCounters{};
    const Index pair_chunks = (pairs + kPairsPerChunk - 1) / kPairsPerChunk;
    parallel_for(scratch.pool, pair_chunks, [&](std::uint32_t chunk, std::uint32_t thread) {
      NarrowMemory::NarrowWorkspace& w = scratch.narrow_workspaces[thread];
      for (Index k = chunk * kPairsPerChunk; k < std::min(pairs, (chunk + 1) * kPairsPerChunk); ++k)
        test_halves(k, w.counters, w.edge_tests);
    });
    // (node_tests is the one counter the edge tests keep.)
    for (const NarrowMemory::NarrowWorkspace& w : scratch.narrow_workspaces) counters.node_tests += w.counters.node_tests;
  }
  Index count = 0;
  for (Index i = 0; i < 2 * pairs; ++i)
    if (crossings[i].depth > 0.0) crossings[count++] = crossings[i];
  scratch.edge_crossing_count = count;
}

template void collide_boxes<true>(const Model&, const BoxLevel&, State&, CollisionMemory&, StageCounters&, double&);
template void collide_boxes<false>(const Model&, const BoxLevel&, State&, CollisionMemory&, StageCounters&, double&);
template void collide_surfaces<true>(const Model&, State&, CollisionMemory&, StageCounters&, double&);
template void collide_surfaces<false>(const Model&, State&, CollisionMemory&, StageCounters&, double&);
template void collide_planes<true>(const Model&, const BoxLevel&, State&, CollisionMemory&, StageCounters&, double&);
template void collide_planes<false>(const Model&, const BoxLevel&, State&, CollisionMemory&, StageCounters&, double&);

}  // namespace ffd
