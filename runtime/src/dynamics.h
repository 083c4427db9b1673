#pragma once
// Internal dynamics of the lattice nodes, per object: XPBD mass-spring or lattice shape
// matching. Both are unconditionally stable at any stiffness for the fixed step.
#include "ffd/model.h"
#include "ffd/step.h"

namespace ffd {

void integrate_dynamics(const Model& model, State& state, Scratch& scratch);

// Rotation part of A (Mueller et al. 2016, "A Robust Method to Extract the Rotational Part
// of Deformations"), iterated from `q`, which is updated in place. Never NaN: a degenerate A
// leaves q unchanged.
void extract_rotation(const Mat3& A, Quat& q, int max_iterations);

}  // namespace ffd
