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

class WorkerPool;

// Work counters of one stage in one step. A counter a stage has no use for stays zero.
// A candidate pair of the broad phase: boxes a < b of the accuracy level's box set.
struct BoxPair {
  Index a, b;
};

struct StageCounters {
  std::uint32_t boxes_updated = 0;      // FFD AABBs recomputed from the lattice (eq. 2)
  std::uint32_t hash_entries = 0;       // (box, grid cell) entries the broad phase's grids held
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

// The response "solver" (contact_solver.h): a contact is a constraint between two points, each
// carried by lattice nodes through trilinear weights (eq. 2): the point that must stay out
// (side b: a box node, a surface node, the probe) and a point of the surface it must stay
// out of (side a: the mean of a box face's four corners, the probe's centre, nothing for a
// static plane). A node index kProbeNode stands for the probe proxy.
inline constexpr Index kProbeNode = kNoIndex - 1;
struct ContactSide {
  std::array<Index, 8> node;
  std::array<double, 8> weight;
  std::array<double, 8> share{};  // 1/kg: weight / mass of each node in this step's solve (0: static)
  std::uint8_t count = 0;         // node[0 .. count) carry the point
  Index cell = kNoIndex;          // the lattice cell whose 8 nodes these are (none: the probe, a plane)
};
struct ContactConstraint {
  ContactSide a, b;
  Vec3 normal = Vec3::Zero();    // unit, from side a's surface towards the outside
  double rest = 0.0;             // C = normal . (p_b - p_a) - rest >= 0 (m)
  std::uint64_t key = 0;         // which contact, from step to step (0: none, never anchored)
  Vec3 hold = Vec3::Zero();      // m: friction holds p_b - p_a here, tangentially: its anchor,
                                 // or where the step began
  Index face_box = kNoIndex;     // side a's box and face, whose frame where the step began its
  std::uint8_t face = 0;         // anchor is kept in (kNoIndex: a plane's, the world's)
  double approach = 0.0;         // normal . (v_b - v_a) when found, m/s (< 0: approaching)
  double inv_mass = 0.0;         // sum of w^2 / m over both sides' free nodes, 1/kg
  double lambda = 0.0;           // normal correction so far this step, m (>= 0)
  Vec3 friction = Vec3::Zero();  // tangential correction so far this step, m
  bool lodged = false;           // found deeper than a step's approach: pushed out without friction
};

struct StepReport {
  std::uint64_t step = 0;                          // index of the step this report describes
  std::array<std::int64_t, kStageCount> stage_ns{};  // wall time per stage, ns (-1: not run)
  std::array<StageCounters, kStageCount> counters{};
  std::int64_t total_ns = 0;
  double max_box_penetration_m = 0.0;  // deepest node-in-box or node-below-plane depth r
  bool finite = true;                  // every x and v finite after the step
  bool hash_overflow = false;          // broad phase ran out of room for grid entries or pairs; grow_scratch() fixes it
  std::uint32_t contacts_recorded = 0; // Scratch::contacts[0 .. contacts_recorded) hold this step's
  std::uint32_t contacts_dropped = 0;  // contacts beyond Scratch::contacts' capacity (not recorded)
  std::uint32_t constraints = 0;       // response "solver": contact constraints solved this step
  bool constraints_overflow = false;   // some were dropped for want of room; grow_scratch() fixes it
};

// Working memory of step(): derived per step, never part of the State.
struct Scratch {
  // World positions of the 9 nodes of every box of the accuracy level's box set (8 corners,
  // then the centre node), and whether they match the current lattice (a response moves
  // lattice nodes and makes the boxes of the neighbouring cells stale).
  std::vector<std::array<Vec3, 9>> box_nodes;
  std::vector<std::uint8_t> box_valid;
  std::vector<std::uint8_t> box_moved;  // a response moved the box's nodes since the narrow phase's detection
  double narrow_retested_share = 0.0;   // of the last narrow phase's pairs, those tested again
  // Per axis, the world AABB of each box's nodes (from the box update; the broad phase grows
  // it by its margins), m.
  std::array<std::vector<double>, 3> box_lo, box_hi;
  // Levels 0-3 with edge contacts: per box, the bounds of the triangles its cell owns
  // (Model::cell_owned_triangles), swapped in for box_lo and box_hi while the edge tests'
  // pairs are found (collision.cpp, pair_cells_by_triangles).
  std::array<std::vector<double>, 3> surface_lo, surface_hi;
  // Sleeping only (else empty): how far (m) each box reaches beyond its nodes in the broad
  // phase, so that an object moving wakes a sleeper before it touches it (sleep.h).
  std::vector<double> box_wake_margin;
  // Broad phase (broad_phase.cpp): each object's bounds, the objects in sweep order, and its
  // tasks (an object's own pairs: a == b; a pair of objects whose bounds meet: a < b), run
  // over the pool, each thread in its own workspace (attach_pool()).
  std::vector<std::array<double, 3>> object_lo, object_hi;
  std::vector<Index> object_order;
  struct PairTask {
    Index a, b;
  };
  std::vector<PairTask> pair_tasks;  // capacity grown between steps
  // A thread's room for one task: boxes picked from one object or a pair, the grid over them
  // (counting-sorted: cell c holds grid_entries[grid_begin[c] .. grid_begin[c + 1])), and the
  // pairs it found.
  struct PairWorkspace {
    std::vector<Index> box_list_a, box_list_b;
    std::vector<std::array<int, 6>> box_range;     // grid cells a listed box covers: x0, x1, y0, y1, z0, z1
    std::vector<Index> grid_begin, grid_cursor;
    std::vector<Index> grid_entries;               // capacity grown between steps
    std::array<std::vector<int>, 3> cell_lattice;  // lattice coordinates of one grid cell's boxes
    std::vector<Index> cell_far;                   // of them, those two or more lattice steps from one
    std::vector<BoxPair> pairs;                    // capacity grown between steps
    Index pair_count = 0;
    bool dropped = false;
    std::uint32_t entries = 0;                     // grid entries made (the hash_entries counter)
  };
  std::vector<PairWorkspace> pair_workspaces;
  // The candidate pairs of this step, sorted, and whether the narrow phase's detection found a
  // node of one box inside the other.
  std::vector<BoxPair> pairs;       // [0, pair_count) used; capacity grown between steps
  std::vector<std::uint8_t> pair_hit;
  // Answering the pairs over the pool (collision.cpp): each pair's wave (one more than the
  // last wave of a pair sharing an object with it) and its turn among each of its two
  // objects' pairs, the pairs by wave (wave_pairs[wave_begin[w] .. wave_begin[w + 1])), and
  // per object the next wave, the next turn to hand out, and the turns answered so far.
  std::vector<std::uint32_t> pair_wave;
  std::vector<std::array<std::uint32_t, 2>> pair_turn;
  std::vector<Index> wave_pairs;
  std::vector<Index> wave_begin;
  std::vector<std::uint32_t> object_wave, object_turn, object_answered;
  std::uint32_t narrow_waves = 0;  // waves of the last narrow phase (0: one thread answered the pairs)
  // Sorting the pairs into the order they are answered in (broad_phase.cpp).
  struct PairKey {
    std::uint64_t key;
    BoxPair pair;
  };
  std::vector<PairKey> pair_keys, pair_sorted_keys;
  std::array<Index, 257> radix_count{};
  Index pair_count = 0;
  bool pairs_dropped = false;       // a buffer was too small this step
  // The worker threads the step spreads its work over (worker_pool.h); none: this thread
  // alone. Owned by the caller (the physics loop, a tool), never by the Scratch.
  WorkerPool* pool = nullptr;
  // Dynamics.
  std::vector<Vec3> x_prev;        // positions at the start of the step
  // Levels 4 and 5 under the paper's response only: the lattice as the step found it, before
  // dynamics and responses; which side of a triangle an edge came from (collision.cpp,
  // test_edges).
  std::vector<Vec3> x_start;
  // Levels 0-3 with edge contacts, where the planes answer first: a cell resting on a plane
  // takes none of a push into it (collision.cpp, plane_holds), set by step() each step.
  bool planes_hold = false;
  // Level 4 under the paper's response: the pairs of cells of two objects among the candidate
  // pairs of sub-boxes, (lower << 32 | higher), sorted so that each pair is answered once.
  std::vector<std::uint64_t> cell_pair_keys;  // capacity: that of pairs
  std::vector<double> lambda;      // XPBD Lagrange multipliers, one per spring
  std::vector<double> tetrahedron_lambda;  // XPBD Lagrange multipliers, one per tetrahedron
  std::vector<double> cell_shape_lambda;   // XPBD Lagrange multipliers, one per cell (shape)
  std::vector<Mat3> cell_rotation_matrix;  // State::cell_rotation as a matrix, for the sweeps
  // XPBD 1 / ((1 + gamma)(w_a + w_b) + alpha~) per spring, for the stiffness in
  // `denominator_stiffness` (per object): recomputed only when a command changes it.
  std::vector<double> spring_inv_denominator;
  std::vector<double> denominator_stiffness;
  // Scheduling the objects over the pool: each object's work (projections per step), the
  // objects by decreasing work, and the tasks of this step.
  std::vector<double> object_work;
  std::vector<Index> objects_by_work;
  std::vector<Index> object_tasks;
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
  // A thread's share of the narrow phase's answers while pairs are answered in waves: its
  // counters, and the contacts it found with the smallest keys (pair index, then order within
  // the pair), at most contacts.size() of them in a max-heap on the key. The step's list is
  // merged from them in key order: the same list, whichever thread answered which pair.
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
  };
  std::vector<NarrowWorkspace> narrow_workspaces;  // one per thread (attach_pool())
  // The response "solver" (contact_solver.h): the step's contacts as constraints (the list
  // the detection writes and the solve reads; capacity grown between steps), the objects this
  // step solves (awake at its start), the probe's start of step and its device's velocity,
  // and the force the grab has given so far this step (N).
  std::vector<ContactConstraint> constraints;
  Index constraint_count = 0;
  std::vector<ContactAnchor> next_anchors;  // the contacts that stuck this step (as constraints)
  std::vector<Index> friction_contacts;     // the resting contacts the friction passes revisit
  Index friction_contact_count = 0;
  bool constraints_dropped = false;
  std::vector<std::uint8_t> object_solving;
  Index object_task_count = 0;
  Vec3 probe_x_prev = Vec3::Zero(), probe_device_velocity = Vec3::Zero();
  Vec3 grab_force = Vec3::Zero();
  // Rolling resistance and support damping (contact_solver.cpp): per object, its rigid motion
  // this step and what its active contacts carry.
  struct ObjectMotion {
    Vec3 centre = Vec3::Zero();       // m
    Vec3 omega = Vec3::Zero();        // rad/s, the best rigid spin of its nodes
    Mat3 inertia = Mat3::Zero();      // kg m^2 about the centre
    double mass = 0.0;                // kg
    double load = 0.0;                // sum of its active contacts' normal corrections (kg m)
    Vec3 support_spin = Vec3::Zero(); // their partners' spins weighted by load
    Vec3 pivot = Vec3::Zero();        // their points weighted by load
    Vec3 velocity = Vec3::Zero();     // m/s, of the centre
    Vec3 up = Vec3::Zero();           // resting contacts' normals towards it, weighted by load
    Vec3 support_velocity = Vec3::Zero();  // their partners' centre velocities weighted by load
    double resting_load = 0.0;        // the share of load from resting contacts (kg m)
    bool touched = false;
  };
  std::vector<ObjectMotion> object_motion;
  // Response "solver": marks the nodes a pass over the contacts has visited (contact_solver.cpp);
  // each pass takes a new mark (++node_stamp_epoch), so that a node shared by several
  // contacts' cells is visited once, whatever earlier passes left.
  std::vector<std::uint64_t> node_stamp;
  std::uint64_t node_stamp_epoch = 0;
};

inline constexpr std::size_t kContactCapacity = 4096;

Scratch make_scratch(const Model& model);
// The step spreads its work over `pool` (which must outlive the Scratch's use), with room
// for each of its threads. Call before stepping, not inside a step.
void attach_pool(const Model& model, Scratch& scratch, WorkerPool& pool);
// Makes room for what the last step reported it lacked (call between steps).
void grow_scratch(const Model& model, Scratch& scratch, const StepReport& last);

// Advances `state` by one step of model.settings.dt and fills `report`.
void step(const Model& model, State& state, Scratch& scratch, StepReport& report);

// The SIMD target the step's kernels run on ("AVX3", "AVX2", "SSE4", "SCALAR", ...): the best
// this CPU has, chosen at run time. Every target gives the same bits.
const char* simd_target_name();

// Recomputes the nodes of every box of the State's accuracy level from the lattice (eq. 2),
// for tools that need the boxes of a State (frames, tests).
void update_all_boxes(const Model& model, const State& state, Scratch& scratch);

}  // namespace ffd
