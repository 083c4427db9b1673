#pragma once
// The Interaction stage: the haptic probe (virtual coupling + contacts with the FFD AABBs)
// and the grab spring. Runs after the collision stages so that what a user does acts on the
// step's final positions, and the force output is that of the finished step.
#include <algorithm>

#include "collision.h"
#include "ffd/model.h"

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
                          const Vec3& force_so_far, double step);

// The probe's sample nodes relative to its centre, for a unit radius: the centre, the 6 axis
// directions, 12 edge and 8 corner directions of a cube (27 in all).
inline constexpr int kProbeNodeCount = 27;
extern const std::array<Vec3, kProbeNodeCount> kProbeNodeOffsets;

// A contact between the probe and box b's cell: a probe node inside the box (`face`: the
// box face, eq. 7; `normal` out of the face), or the box's node `node` inside the probe's
// sphere (face -1; `normal` out of the sphere); `depth` m, `point` where.
struct ProbeContact {
  Index box, cell;
  int face, node;
  Vec3 normal, point;
  double depth;
};

// The probe's contacts with the boxes, for both responses: each box whose AABB meets the
// probe's (made valid first), on_box(b) before its tests; then its 27 nodes in the box
// (node-in-box, eq. 3-7) and the box's 9 nodes in the probe's sphere, each contact counted,
// shown (the step's contact log) and handed to on_contact(const ProbeContact&), which
// returns true where it answered at once and so moved the box (having made it valid again).
template <class OnBox, class OnContact>
void find_probe_box_contacts(const Model& model, const BoxSet& boxes, State& state, CollisionMemory& scratch,
                             StageCounters& counters, double& max_depth, const OnBox& on_box,
                             const OnContact& on_contact) {
  const ProbeState& probe = state.probe;
  const double radius = model.settings.probe.radius, recent = kRecentEntrySteps * model.settings.dt;
  const Vec3 lo = probe.x - Vec3::Constant(radius), hi = probe.x + Vec3::Constant(radius);
  for (Index b = 0; b < boxes.size(); ++b) {
    // The box's AABB (BoxMemory::box_lo/hi) is kept with its nodes: by the box update, by
    // ensure_box, and grown, never shrunk, by the broad phase's margins.
    ensure_box(model, boxes, state, scratch, b, counters);
    if (lo.x() > scratch.box_hi[0][b] || lo.y() > scratch.box_hi[1][b] || lo.z() > scratch.box_hi[2][b] ||
        hi.x() < scratch.box_lo[0][b] || hi.y() < scratch.box_lo[1][b] || hi.z() < scratch.box_lo[2][b])
      continue;
    const Index cell = boxes.box_cell[b];
    on_box(b);
    const auto found = [&](const ProbeContact& c) {
      ++counters.probe_contacts;
      max_depth = std::max(max_depth, c.depth);
      scratch.record_contact(c.point, c.normal, c.depth, ContactKind::Probe);
      return on_contact(c);
    };
    scan_points_in_box(
        scratch, b, 0.0, recent, kProbeNodeCount,
        [&](int k) { return Vec3(probe.x + radius * kProbeNodeOffsets[k]); },
        [&] { return Vec3(probe.v - mean_velocity(state, model.cell_nodes[cell])); },
        [&](int, const Vec3& node, const NodeInBox& hit, const BoxPlanes& planes) {
          ++counters.node_tests;
          if (!hit.inside) return false;
          return found({b, cell, hit.face, -1, planes.normal[hit.face], node, hit.depth});
        });
    for (int k = 0; k < 9; ++k) {
      ++counters.node_tests;
      const Vec3 offset = scratch.box_nodes[b][k] - probe.x;
      const double distance = offset.norm();
      if (!(distance < radius) || !(distance > 1e-12)) continue;
      found({b, cell, -1, k, Vec3(offset / distance), scratch.box_nodes[b][k], radius - distance});
    }
  }
}

}  // namespace ffd
