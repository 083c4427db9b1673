#pragma once
// One fixed step of the simulation: the Model's pipeline of stages run over the State, each
// timed and counted into a StepReport. step() never allocates: every buffer it needs lives
// in a Scratch sized by make_scratch(); overflow is reported as a flag, and grow_scratch()
// (between steps) makes room.
#include <array>
#include <cstdint>
#include <vector>

#include "ffd/model.h"
#include "ffd/state.h"

namespace ffd {

// Work counters of one stage in one step. A counter a stage has no use for stays zero.
struct StageCounters {
  std::uint32_t boxes_updated = 0;      // FFD AABBs recomputed from the lattice (eq. 2)
  std::uint32_t hash_entries = 0;       // (box, hash cell) entries inserted
  std::uint32_t inter_pairs_tested = 0; // box pairs of different objects given node tests
  std::uint32_t self_pairs_tested = 0;  // box pairs of one object given node tests
  std::uint32_t node_tests = 0;         // node-in-box or node-below-plane tests
  std::uint32_t inter_contacts = 0;     // nodes found inside a box of another object
  std::uint32_t self_contacts = 0;      // nodes found inside a non-adjacent box of the same object
  std::uint32_t plane_contacts = 0;     // boxes found below a static plane
  std::uint32_t probe_contacts = 0;     // probe nodes in a box, or box nodes in the probe sphere
  std::uint32_t objects_asleep = 0;     // objects asleep after the Sleep stage ("sleeping")
};

enum class ContactKind : std::uint8_t { Inter, Self, Plane, Probe };

// One contact found and answered this step, for display: where, along which normal, how deep.
struct Contact {
  Vec3 point = Vec3::Zero();   // m, the node found inside
  Vec3 normal = Vec3::Zero();  // unit, direction the node was pushed out along
  double depth = 0.0;          // m, r of eq. 7
  ContactKind kind = ContactKind::Inter;
};

inline constexpr std::size_t kStageCount = static_cast<std::size_t>(Stage::Count);

struct StepReport {
  std::uint64_t step = 0;                          // index of the step this report describes
  std::array<std::int64_t, kStageCount> stage_ns{};  // wall time per stage, ns (-1: not run)
  std::array<StageCounters, kStageCount> counters{};
  std::int64_t total_ns = 0;
  double max_box_penetration_m = 0.0;  // deepest node-in-box or node-below-plane depth r
  bool finite = true;                  // every x and v finite after the step
  bool hash_overflow = false;          // broad phase ran out of entry room; grow_scratch() fixes it
  std::uint32_t contacts_recorded = 0; // Scratch::contacts[0 .. contacts_recorded) hold this step's
  std::uint32_t contacts_dropped = 0;  // contacts beyond Scratch::contacts' capacity (not recorded)
};

// Working memory of step(): derived per step, never part of the State.
struct Scratch {
  // World positions of the 9 nodes of every box of the accuracy level's box set (8 corners,
  // then the centre node), and whether they match the current lattice (a response moves
  // lattice nodes and makes the boxes of the neighbouring cells stale).
  std::vector<std::array<Vec3, 9>> box_nodes;
  std::vector<std::uint8_t> box_valid;
  std::vector<Vec3> box_min, box_max;  // world AABB of each box's nodes at hash time
  // Sleeping only (else empty): how far (m) each box reaches beyond its nodes in the hash,
  // so that an object moving wakes a sleeper before it touches it (sleep.h).
  std::vector<double> box_wake_margin;
  // Spatial hash as counting-sorted arrays: bucket b holds entries[bucket_begin[b] ..
  // bucket_begin[b + 1]).
  struct HashEntry {
    Index box;
    std::int64_t gx, gy, gz;  // integer hash-grid coordinates
  };
  std::vector<Index> bucket_begin;      // (T + 1) for the largest table of any level
  Index hash_table_size = 0;            // T of the table built last
  std::vector<HashEntry> entries;       // capacity grown between steps
  std::vector<HashEntry> entries_unsorted;
  std::vector<Index> entry_bucket;
  // Dynamics.
  std::vector<Vec3> x_prev;        // positions at the start of the step
  std::vector<double> lambda;      // XPBD Lagrange multipliers, one per spring
  std::vector<double> tetrahedron_lambda;  // XPBD Lagrange multipliers, one per tetrahedron
  // XPBD 1 / ((1 + gamma)(w_a + w_b) + alpha~) per spring, for the stiffness in
  // `denominator_stiffness` (per object): recomputed only when a command changes it.
  std::vector<double> spring_inv_denominator;
  std::vector<double> denominator_stiffness;
  std::vector<Vec3> goal_sum;      // shape matching: summed goal positions per node
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
  // Contacts of the step, for frames; fixed capacity, the excess is counted not stored.
  std::vector<Contact> contacts;
  std::uint32_t contact_count = 0;
  std::uint32_t contacts_dropped = 0;
  void record_contact(const Vec3& point, const Vec3& normal, double depth, ContactKind kind) {
    if (contact_count < contacts.size()) contacts[contact_count++] = {point, normal, depth, kind};
    else ++contacts_dropped;
  }
};

inline constexpr std::size_t kContactCapacity = 4096;

Scratch make_scratch(const Model& model);
// Makes room for what the last step reported it lacked (call between steps).
void grow_scratch(const Model& model, Scratch& scratch, const StepReport& last);

// Advances `state` by one step of model.settings.dt and fills `report`.
void step(const Model& model, State& state, Scratch& scratch, StepReport& report);

// Recomputes the nodes of every box of the State's accuracy level from the lattice (eq. 2),
// for tools that need the boxes of a State (frames, tests).
void update_all_boxes(const Model& model, const State& state, Scratch& scratch);

}  // namespace ffd
