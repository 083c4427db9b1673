#pragma once
// The Interaction stage: the haptic probe (virtual coupling + contacts with the FFD AABBs)
// and the grab spring. Runs after the collision stages so that what a user does acts on the
// step's final positions, and the force output is that of the finished step.
#include "ffd/model.h"
#include "collision.h"

namespace ffd {

// `boxes`: the box set of the accuracy level (the FFD AABBs at level 5).
void interact(const Model& model, const BoxSet& boxes, State& state, CollisionMemory& scratch, StageCounters& counters,
              double& max_depth);

// The probe's virtual coupling (Colgate et al. 1995) by backward Euler, so any stiffness and
// damping are stable at the fixed step: the proxy's velocity and position before its
// contacts. Returns the device's velocity (m/s), which the force output needs.
Vec3 step_probe_coupling(const Model& model, State& state);

// The force the device renders (N): the coupling's spring and damper, from the proxy to the
// device, after the step's contacts.
Vec3 probe_force(const Model& model, const State& state, const Vec3& device_velocity);

// The grab (Effect::Grab, both responses): a spring-damper (GrabSettings: stiffness k N/m,
// damping c N s/m) from a point carried by a cell (eq. 2) to its target, integrated by
// backward Euler on the point's effective inverse mass w = sum_j w_j^2 / m_j (1/kg), so any
// stiffness is stable at the fixed step. Given the point's offset to the target (m), its
// velocity (m/s) and the force the spring has already given it this step (N: the solver
// applies it over its iterations, which makes this XPBD's soft constraint with compliance
// 1 / k), the change of the point's velocity this step (m/s).
Vec3 grab_velocity_change(const Model& model, double inv_mass, const Vec3& to_target, const Vec3& velocity,
                          const Vec3& force_so_far);

// The probe's sample nodes relative to its centre, for a unit radius: the centre, the 6 axis
// directions, 12 edge and 8 corner directions of a cube (27 in all).
inline constexpr int kProbeNodeCount = 27;
extern const std::array<Vec3, kProbeNodeCount> kProbeNodeOffsets;

}  // namespace ffd
