#pragma once
// The response "solver" (docs/step.md, "Two contact responses"): the contacts the paper's detection
// finds are answered as constraints inside the lattice's XPBD solve, not at once as eq. 7-9
// answer them. A step under it:
//   Dynamics      every awake object's prediction x* = x + dt v (begin_solver_step)
//   BoxUpdate, BroadPhase
//   NarrowPhase   node-in-box tests on x* (the paper's eq. 3-7, read-only): each node inside,
//                 or within kSpeculativeDistance outside, becomes a ContactConstraint
//                 (find_box_contacts)
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
// The contact list (Scratch::constraints) is the boundary: detection writes it, the solve reads
// it. Everything runs in list order on one thread but the sweeps (objects over the pool), so
// the result does not depend on the thread count.
#include "collision.h"

namespace ffd {

// How far outside a box face (m) a node still gets a contact: a speculative one, inactive
// unless the solve would move the node in. The broad phase grows the boxes by as much.
extern const double kSpeculativeDistance;

void begin_solver_step(const Model& model, State& state, Scratch& scratch);

void find_box_contacts(const Model& model, const BoxLevel& level, State& state, Scratch& scratch,
                       StageCounters& counters, double& max_depth);
void find_plane_contacts(const Model& model, const BoxLevel& level, State& state, Scratch& scratch,
                         StageCounters& counters, double& max_depth);
void find_probe_contacts(const Model& model, const BoxSet& boxes, State& state, Scratch& scratch,
                         StageCounters& counters, double& max_depth);

void solve_contacts(const Model& model, State& state, Scratch& scratch);

}  // namespace ffd
