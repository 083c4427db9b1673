#pragma once
// The BoxUpdate stage (section 4): the FFD AABBs of the accuracy level, each box's 8 boundary
// nodes and centre of mass moved with the lattice by trilinear FFD (eq. 2), and their world
// AABBs; a box a response made stale is recomputed when next needed.
#include <array>
#include <cstdint>
#include <vector>

#include "ffd/model.h"
#include "ffd/state.h"
#include "ffd/step.h"

namespace ffd {

class WorkerPool;

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
  // Under the response "solver": the same edges as constraints (contact_solver.h), and at
  // level 5 the vertex contacts too (without, answered at once before the solve). Levels 0-5
  // with edge_contacts in a scene with inter-collision.
  bool solver_edges;
  // Under the response "solver": level 5's vertex contacts are answered at once in the narrow
  // phase, before the solve, where they are not constraints (without solver_edges).
  bool vertex_contacts_at_once() const { return exact && !solver_edges; }
  // m, the gap a box keeps the tested nodes of another object's boxes from its faces:
  // Model::box_skin ("box_overlap"; 0 when off), at level 4 the larger of it and
  // Model::sub_box_skin.
  double skin;
};
BoxLevel box_level(const Model& model, Accuracy accuracy);

// The boxes' working memory, with room for the largest box set of any accuracy level.
struct BoxMemory {
  // World positions of the 9 nodes of every box of the accuracy level's box set (8 corners,
  // then the centre node), and whether they match the current lattice (a response moves
  // lattice nodes and makes the boxes of the neighbouring cells stale).
  std::vector<std::array<Vec3, 9>> box_nodes;
  std::vector<std::uint8_t> box_valid;
  std::vector<std::uint8_t> box_moved;  // a response moved the box's nodes since the narrow phase's detection
  // Per axis, the world AABB of each box's nodes (from the box update; the broad phase grows
  // it by its margins), m.
  std::array<std::vector<double>, 3> box_lo, box_hi;
  // Sleeping only (else empty): how far (m) each box reaches beyond its nodes in the broad
  // phase, so that an object moving wakes a sleeper before it touches it (sleep.h).
  std::vector<double> box_wake_margin;
};
std::size_t largest_box_set(const Model& model);
void size_box_memory(const Model& model, BoxMemory& memory);

// Eq. 2 for the 9 nodes of box b of `boxes` from its cell's 8 lattice nodes; marks it valid.
void update_box(const Model& model, const BoxSet& boxes, const State& state, BoxMemory& memory, Index b);
void update_boxes(const Model& model, const BoxSet& boxes, const State& state, BoxMemory& memory, WorkerPool* pool);

// Box b recomputed if a response made it stale (counted in `counters`).
void ensure_box(const Model& model, const BoxSet& boxes, const State& state, BoxMemory& memory, Index b,
                StageCounters& counters);

// Cells whose nodes moved: their boxes, and those of every cell sharing a node, are stale.
void invalidate_around(const Model& model, const BoxSet& boxes, BoxMemory& memory, Index cell);

}  // namespace ffd
