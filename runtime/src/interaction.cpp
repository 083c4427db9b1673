#include "interaction.h"

#include <algorithm>
#include <cmath>

#include "collision.h"
#include "ffd/box_test.h"
#include "ffd/response.h"
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

// Section 7 between one lattice cell and the probe proxy. `n` is the direction that
// separates them for the probe: the probe moves along +n, the cell along -n, the pair's
// velocities along n are damped by alpha (eq. 8) relative to their mass-weighted mean, and
// the depth r is split by inverse mass (eq. 9).
void respond_cell_probe(const Model& model, State& state, Index cell, const Vec3& n, double r, double beta) {
  wake(state, model.cell_object[cell]);
  const std::array<Index, 8>& nodes = model.cell_nodes[cell];
  ProbeState& probe = state.probe;
  const double inv_cell = model.cell_inv_mass[cell], inv_probe = 1.0 / model.settings.probe.mass;
  const Vec3 v_cell = mean_velocity(state, nodes);
  const double u = (probe.v - v_cell).dot(n);
  const PositionShares share = position_shares(inv_cell, inv_probe);
  if (u < 0.0) {  // approaching
    const double m_cell = 1.0 / inv_cell, m_probe = model.settings.probe.mass;
    const Vec3 v_ref = (m_cell * v_cell + m_probe * probe.v) / (m_cell + m_probe);
    const double alpha = state.params.alpha;
    const double bounce = rebound(u, r, alpha, kRecentEntrySteps * model.settings.dt);
    for (Index i : nodes) state.v[i] = respond_velocity(state.v[i], v_ref, n, alpha, beta) - share.a * bounce * n;
    probe.v = respond_velocity(probe.v, v_ref, n, alpha, beta) + share.b * bounce * n;
  }
  for (Index i : nodes) state.x[i] -= share.a * r * n;
  probe.x += share.b * r * n;
}

// The probe against box b both ways: its 27 nodes in the box (node-in-box, eq. 3-7), and
// the box's 9 nodes in the probe's sphere.
void probe_against_box(const Model& model, const BoxSet& boxes, State& state, Scratch& scratch, Index b, double beta,
                       StageCounters& counters, double& max_depth) {
  const double radius = model.settings.probe.radius;
  const Index cell = boxes.box_cell[b];
  ProbeState& probe = state.probe;
  BoxPlanes planes = box_planes(scratch.box_nodes[b]);
  for (int k = 0; k < kProbeNodeCount && !planes.degenerate; ++k) {
    ++counters.node_tests;
    const Vec3 node = probe.x + radius * kProbeNodeOffsets[k];
    const Vec3 relative_velocity = probe.v - mean_velocity(state, model.cell_nodes[cell]);
    const NodeInBox hit = node_in_box(planes, node, relative_velocity, kRecentEntrySteps * model.settings.dt);
    if (!hit.inside) continue;
    ++counters.probe_contacts;
    max_depth = std::max(max_depth, hit.depth);
    scratch.record_contact(node, planes.normal[hit.face], hit.depth, ContactKind::Probe);
    respond_cell_probe(model, state, cell, planes.normal[hit.face], hit.depth, beta);
    invalidate_around(model, boxes, scratch, cell);
    ensure_box(model, boxes, state, scratch, b, counters);
    planes = box_planes(scratch.box_nodes[b]);
  }
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

namespace {

// Virtual coupling (Colgate et al. 1995) integrated by backward Euler, so any stiffness and
// damping are stable at the fixed step; then contacts; then the force the device renders.
void step_probe(const Model& model, const BoxSet& boxes, State& state, Scratch& scratch, StageCounters& counters,
                double& max_depth) {
  const ProbeSettings& settings = model.settings.probe;
  ProbeState& probe = state.probe;
  const double k = state.params.probe_stiffness, c = settings.coupling_damping;
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
  probe.force = k * (probe.x - probe.device) + c * (probe.v - device_velocity);
}

// A spring-damper from the grabbed point to its target, integrated by backward Euler on the
// point's effective mass 1 / sum_j(w_j^2 / m_j), and spread over the cell's 8 nodes so that
// the point's velocity changes by exactly the solved amount.
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
  const double dt = model.settings.dt, k = model.settings.grab.stiffness, c = model.settings.grab.damping;
  const Vec3 dv = dt * inv_mass * (k * (grab.target - point) - c * velocity) / (1.0 + dt * c * inv_mass + dt * dt * k * inv_mass);
  for (int j = 0; j < 8; ++j) state.v[nodes[j]] += (w[j] * model.node_inv_mass[nodes[j]] / inv_mass) * dv;
  grab.force = dv / (inv_mass * dt);
}

}  // namespace

void interact(const Model& model, const BoxSet& boxes, State& state, Scratch& scratch, StageCounters& counters,
              double& max_depth) {
  if (has(model.settings.effects, Effect::Probe)) step_probe(model, boxes, state, scratch, counters, max_depth);
  if (has(model.settings.effects, Effect::Grab) && state.grab.active) step_grab(model, state);
}

}  // namespace ffd
