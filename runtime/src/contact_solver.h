#pragma once
// The response "solver" (docs/step.md, "Two contact responses"): the contacts the paper's detection
// finds are answered as constraints inside the lattice's XPBD solve, not at once as eq. 7-9
// answer them. A step under it:
//   Dynamics      every awake object's prediction x* = x + dt v (begin_solver_step)
//   BoxUpdate, BroadPhase
//   NarrowPhase   node-in-box tests on x* (the paper's eq. 3-7, read-only): each node inside,
//                 or within kSpeculativeDistance outside, becomes a ContactConstraint
//                 (find_box_contacts); at level 5 with edge_contacts, of each half
//                 of a pair of cells the surface vertex deepest inside the other's surface
//                 or near it, likewise (find_vertex_constraints; without, they are answered
//                 at once, as the paper's response answers them)
//                 with edge contacts, each edge of one object's surface that crosses a
//                 triangle of another's, likewise (find_edge_contacts)
//   Planes        each tested node below a plane or within kSpeculativeDistance above it,
//                 likewise (find_plane_contacts)
//   Interaction   the probe's coupling predicted, its contacts found (find_probe_contacts)
//   ContactSolve  per iteration: one sweep of every object's springs and volumes, then every
//                 contact (non-penetration with Coulomb friction, mu = beta, held at its
//                 anchor if it stuck in the last step: State::anchors) and the grab;
//                 then v = (x - x_prev) / dt, and eq. 8 on the two cells of each contact
//                 that pushed: approach stopped, sliding kept (its friction was the
//                 solve's; none where the contact stuck), then a rebound of 1 - alpha of
//                 its approach, once per node and never adding kinetic energy
//                 (solve_contacts)
// The contact list (SolverMemory::constraints) is the boundary: detection writes it, the solve reads
// it. The box contacts' detection and the sweeps run over the pool, the first writing the
// list a single thread would write, the second as the dynamics does (dynamics.h); the rest
// runs in list order on one thread, so the result does not depend on the thread count.
#include <array>
#include <cstdint>
#include <vector>

#include "boxes.h"
#include "contact_record.h"
#include "ffd/box_test.h"
#include "ffd/model.h"
#include "ffd/state.h"
#include "ffd/step.h"

namespace ffd {

// A contact as the solver holds it: a ContactRecord's two sides (contact_record.h), side b's
// point kept on the outer side of side a's surface.
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
  double lambda = 0.0;           // normal correction so far this step (or substep), m (>= 0)
  double pushed = 0.0;           // the step's earlier substeps' normal corrections, m
  Vec3 friction = Vec3::Zero();  // tangential correction so far this step, m
  bool lodged = false;           // found deeper than a step's approach: pushed out without friction
};

// The response "solver"'s working memory: the step's contacts as constraints (the list the
// detection writes and the solve reads; capacity grown between steps), the objects this step
// solves (awake at its start), the probe's start of step and its device's velocity, and the
// force the grab has given so far this step (N).
struct SolverMemory {
  std::vector<ContactConstraint> constraints;
  Index constraint_count = 0;
  std::vector<ContactAnchor> next_anchors;  // the contacts that stuck this step (as constraints)
  std::vector<Index> friction_contacts;     // the resting contacts the friction passes revisit
  // The edge contacts' place in the list: constraints[edge_contact_begin .. edge_contact_end),
  // each one's points in edge_sources[i - edge_contact_begin] (the crossings' keys, sorted, in
  // crossing_keys: a held contact found crossed again is not added twice).
  Index edge_contact_begin = 0, edge_contact_end = 0;
  std::vector<EdgeHold> edge_sources, next_edge_holds;
  std::vector<std::uint64_t> crossing_keys;
  std::vector<Index> edge_order;            // drop_opposed_edge_contacts: the edge contacts by their cells
  std::vector<std::uint8_t> edge_dropped;   // and which of them let go
  Index friction_contact_count = 0;
  bool constraints_dropped = false;
  std::vector<std::uint8_t> object_solving;
  Vec3 probe_x_prev = Vec3::Zero(), probe_device_velocity = Vec3::Zero();
  Vec3 probe_x_sub = Vec3::Zero();  // the probe at the start of the substep
  Vec3 grab_force = Vec3::Zero();
  // Rolling resistance and support damping: per object, its rigid motion this step and what
  // its active contacts carry.
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
  // Marks the nodes a pass over the contacts has visited; each pass takes a new mark
  // (++node_stamp_epoch), so that a node shared by several contacts' cells is visited once,
  // whatever earlier passes left.
  std::vector<std::uint64_t> node_stamp;
  std::uint64_t node_stamp_epoch = 0;
  // The box contacts' detection over the pool (find_box_contacts): per candidate pair, where
  // its constraints and its logged contacts start (a running count, pairs + 1 entries), and
  // each thread's share of the counts.
  std::vector<std::array<Index, 2>> pair_contacts;
  // The planes of the candidate pairs' boxes (box_planes[b], for the boxes listed in
  // planned_boxes), taken once a step before the detection: it moves no box, and a box is
  // tested in many pairs, up to six times in each. box_planes_mark[b] == box_planes_epoch
  // marks a box taken.
  std::vector<BoxPlanes> box_planes;
  std::vector<std::uint64_t> box_planes_mark;
  std::uint64_t box_planes_epoch = 0;
  std::vector<Index> planned_boxes;
  struct ContactShare {
    std::uint32_t self_contacts = 0, inter_contacts = 0;
    double max_depth = 0.0;  // m
  };
  std::vector<ContactShare> contact_shares;
};


void begin_solver_step(const Model& model, State& state, StepMemory& memory);

void find_box_contacts(const Model& model, const BoxLevel& level, State& state, StepMemory& memory,
                       StageCounters& counters, double& max_depth);
void find_vertex_constraints(const Model& model, State& state, StepMemory& memory, StageCounters& counters,
                             double& max_depth);
void find_edge_contacts(const Model& model, const BoxLevel& level, State& state, StepMemory& memory,
                        StageCounters& counters, double& max_depth);
void find_plane_contacts(const Model& model, const BoxLevel& level, State& state, StepMemory& memory,
                         StageCounters& counters, double& max_depth);
void find_probe_contacts(const Model& model, const BoxSet& boxes, State& state, StepMemory& memory,
                         StageCounters& counters, double& max_depth);

void solve_contacts(const Model& model, State& state, StepMemory& memory);

}  // namespace ffd
