#include "interaction.h"

#include <algorithm>
#include <cmath>

#include "collision.h"
#include "ffd/box_test.h"
#include "ffd/trilinear.h"
#include "sleep.h"

namespace ffd {

namespace {
std::array<Vec3, kProbeNodeCount> make_probe_node_offsets() {
  std::array<Vec3, kProbeNodeCount> offsets;
  offsets[0] = Vec3::Zero();
  // The 26 neighbours of a 3x3x3 grid (its centre skipped), normalised.
  for (int k = 1; k < kProbeNodeCount; ++k) {
    const int cell = k - 1 < 13 ? k - 1 : k;
    const Vec3 direction(cell % 3 - 1, (cell / 3) % 3 - 1, cell / 9 - 1);
    offsets[k] = direction / direction.norm();
  }
  return offsets;
}
}  // namespace

// Computed once at start-up, not in the step.
const std::array<Vec3, kProbeNodeCount> kProbeNodeOffsets = make_probe_node_offsets();

namespace {

// Section 7 between one lattice cell and the probe proxy: `n` separates them for the probe,
// which moves along +n, the cell along -n.
void respond_cell_probe(const Model& model, State& state, Index cell, const Vec3& n, double r, double beta) {
  wake(state, model.cell_object[cell]);
  answer_at_once(model, state, ResponseSide::of_cell(cell), ResponseSide::probe(), n, r, beta, true);
}

// The probe against box b both ways: its 27 nodes in the box (node-in-box, eq. 3-7), and
// the box's 9 nodes in the probe's sphere.
void probe_against_box(const Model& model, const BoxSet& boxes, State& state, CollisionMemory& scratch, Index b, double beta,
                       StageCounters& counters, double& max_depth) {
  const double radius = model.settings.probe.radius;
  const Index cell = boxes.box_cell[b];
  ProbeState& probe = state.probe;
  scan_points_in_box(
      scratch, b, 0.0, kRecentEntrySteps * model.settings.dt, kProbeNodeCount,
      [&](int k) { return Vec3(probe.x + radius * kProbeNodeOffsets[k]); },
      [&] { return Vec3(probe.v - mean_velocity(state, model.cell_nodes[cell])); },
      [&](int, const Vec3& node, const NodeInBox& hit, const BoxPlanes& planes) {
        ++counters.node_tests;
        if (!hit.inside) return false;
        ++counters.probe_contacts;
        max_depth = std::max(max_depth, hit.depth);
        scratch.record_contact(node, planes.normal[hit.face], hit.depth, ContactKind::Probe);
        respond_cell_probe(model, state, cell, planes.normal[hit.face], hit.depth, beta);
        invalidate_around(model, boxes, scratch, cell);
        ensure_box(model, boxes, state, scratch, b, counters);
        return true;
      });
  for (int k = 0; k < 9; ++k) {
    ++counters.node_tests;
    const Vec3 offset = scratch.box_nodes[b][k] - probe.x;
    const double distance = offset.norm();
    if (!(distance < radius) || !(distance > 1e-12)) continue;
    const Vec3 outward = offset / distance;  // the sphere's normal at the node
    const double depth = radius - distance;
    ++counters.probe_contacts;
    max_depth = std::max(max_depth, depth);
    scratch.record_contact(scratch.box_nodes[b][k], outward, depth, ContactKind::Probe);
    respond_cell_probe(model, state, cell, -outward, depth, beta);
    invalidate_around(model, boxes, scratch, cell);
    ensure_box(model, boxes, state, scratch, b, counters);
  }
}

}  // namespace

Vec3 step_probe_coupling(const Model& model, State& state) {
  const ProbeSettings& settings = model.settings.probe;
  ProbeState& probe = state.probe;
  const double dt = model.settings.dt, m = settings.mass;
  const double k = state.params.probe_stiffness, c = settings.coupling_damping;
  const Vec3 device_velocity = (probe.device - probe.device_previous) / dt;
  probe.device_previous = probe.device;
  // m (v' - v) = dt (k (device - x - dt v') + c (device_velocity - v'))
  probe.v = (m * probe.v + dt * (k * (probe.device - probe.x) + c * device_velocity)) / (m + dt * dt * k + dt * c);
  probe.x += dt * probe.v;
  return device_velocity;
}

Vec3 probe_force(const Model& model, const State& state, const Vec3& device_velocity) {
  const ProbeState& probe = state.probe;
  return state.params.probe_stiffness * (probe.x - probe.device) +
         model.settings.probe.coupling_damping * (probe.v - device_velocity);
}

Vec3 grab_velocity_change(const Model& model, double inv_mass, const Vec3& to_target, const Vec3& velocity,
                          const Vec3& force_so_far) {
  const double dt = model.settings.dt, k = model.settings.grab.stiffness, c = model.settings.grab.damping;
  return dt * inv_mass * (k * to_target - force_so_far - c * velocity) /
         (1.0 + dt * c * inv_mass + dt * dt * k * inv_mass);
}

namespace {

// Virtual coupling (Colgate et al. 1995) integrated by backward Euler, so any stiffness and
// damping are stable at the fixed step; then contacts; then the force the device renders.
void step_probe(const Model& model, const BoxSet& boxes, State& state, CollisionMemory& scratch, StageCounters& counters,
                double& max_depth) {
  const ProbeSettings& settings = model.settings.probe;
  ProbeState& probe = state.probe;
  const Vec3 device_velocity = step_probe_coupling(model, state);

  const double beta = has(model.settings.effects, Effect::Friction) ? state.params.beta : 0.0;
  const Vec3 lo = probe.x - Vec3::Constant(settings.radius), hi = probe.x + Vec3::Constant(settings.radius);
  for (Index b = 0; b < boxes.size(); ++b) {
    // The box's AABB (Scratch::box_lo/hi) is kept with its nodes: by the box update, by
    // ensure_box, and grown, never shrunk, by the broad phase's margins.
    ensure_box(model, boxes, state, scratch, b, counters);
    if (lo.x() > scratch.box_hi[0][b] || lo.y() > scratch.box_hi[1][b] || lo.z() > scratch.box_hi[2][b] ||
        hi.x() < scratch.box_lo[0][b] || hi.y() < scratch.box_lo[1][b] || hi.z() < scratch.box_lo[2][b])
      continue;
    probe_against_box(model, boxes, state, scratch, b, beta, counters, max_depth);
  }
  probe.force = probe_force(model, state, device_velocity);
}

// The grab under the paper's response: the spring's change of velocity, spread over the
// cell's 8 nodes so that the point's velocity changes by exactly that.
void step_grab(const Model& model, State& state) {
  GrabState& grab = state.grab;
  wake(state, model.cell_object[grab.cell]);
  const std::array<Index, 8>& nodes = model.cell_nodes[grab.cell];
  const std::array<double, 8> w = trilinear_weights(grab.local);
  Vec3 point = Vec3::Zero(), velocity = Vec3::Zero();
  double inv_mass = 0.0;
  for (int j = 0; j < 8; ++j) {
    point += w[j] * state.x[nodes[j]];
    velocity += w[j] * state.v[nodes[j]];
    inv_mass += w[j] * w[j] * model.node_inv_mass[nodes[j]];
  }
  const Vec3 dv = grab_velocity_change(model, inv_mass, grab.target - point, velocity, Vec3::Zero());
  for (int j = 0; j < 8; ++j) state.v[nodes[j]] += (w[j] * model.node_inv_mass[nodes[j]] / inv_mass) * dv;
  grab.force = dv / (inv_mass * model.settings.dt);
}

}  // namespace

void interact(const Model& model, const BoxSet& boxes, State& state, CollisionMemory& scratch, StageCounters& counters,
              double& max_depth) {
  if (has(model.settings.effects, Effect::Probe)) step_probe(model, boxes, state, scratch, counters, max_depth);
  if (has(model.settings.effects, Effect::Grab) && state.grab.active) step_grab(model, state);
}

}  // namespace ffd
