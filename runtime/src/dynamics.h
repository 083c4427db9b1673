#pragma once
// Internal dynamics of the lattice nodes, per object: XPBD mass-spring or lattice shape
// matching. Both are unconditionally stable at any stiffness for the fixed step.
#include "ffd/model.h"
#include "ffd/step.h"

namespace ffd {

// The whole step of every awake object: prediction, XPBD sweeps, velocities (response "paper").
void integrate_dynamics(const Model& model, State& state, Scratch& scratch);

// The same in three parts, for the response "solver" (contact_solver.h), which projects the
// contacts between the sweeps: every awake object's prediction (x_prev = x, x += dt v; a
// shape-matching object's whole step), one sweep `iteration` of every mass-spring object
// that has that many, and v = (x - x_prev) / dt with the constraint forces.
void predict_dynamics(const Model& model, State& state, Scratch& scratch);
int dynamics_iterations(const Model& model);  // the most sweeps an object asks for
void sweep_dynamics(const Model& model, int iteration, State& state, Scratch& scratch);
void finish_dynamics(const Model& model, State& state, Scratch& scratch);

// Rotation part of A (Mueller et al. 2016, "A Robust Method to Extract the Rotational Part
// of Deformations"), iterated from `q`, which is updated in place. Never NaN: a degenerate A
// leaves q unchanged.
void extract_rotation(const Mat3& A, Quat& q, int max_iterations);

}  // namespace ffd
