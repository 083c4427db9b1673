#pragma once
// The Interaction stage: the haptic probe (virtual coupling + contacts with the FFD AABBs)
// and the grab spring. Runs after the collision stages so that what a user does acts on the
// step's final positions, and the force output is that of the finished step.
#include "ffd/model.h"
#include "ffd/step.h"

namespace ffd {

// `boxes`: the box set of the accuracy level (the FFD AABBs at level 5).
void interact(const Model& model, const BoxSet& boxes, State& state, Scratch& scratch, StageCounters& counters,
              double& max_depth);

// The probe's virtual coupling (Colgate et al. 1995) by backward Euler, so any stiffness and
// damping are stable at the fixed step: the proxy's velocity and position before its
// contacts. Returns the device's velocity (m/s), which the force output needs.
Vec3 step_probe_coupling(const Model& model, State& state);

// The probe's sample nodes relative to its centre, for a unit radius: the centre, the 6 axis
// directions, 12 edge and 8 corner directions of a cube (27 in all).
inline constexpr int kProbeNodeCount = 27;
extern const std::array<Vec3, kProbeNodeCount> kProbeNodeOffsets;

}  // namespace ffd
