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
                          const Vec3& force_so_far, double dt) {
  const double k = model.settings.grab.stiffness, c = model.settings.grab.damping;
  return dt * inv_mass * (k * to_target - force_so_far - c * velocity) /
         (1.0 + dt * c * inv_mass + dt * dt * k * inv_mass);
}

namespace {

// Virtual coupling (Colgate et al. 1995) integrated by backward Euler, so any stiffness and
// damping are stable at the fixed step; then contacts; then the force the device renders.
void step_probe(const Model& model, const BoxSet& boxes, State& state, CollisionMemory& scratch, StageCounters& counters,
                double& max_depth) {
  ProbeState& probe = state.probe;
  const Vec3 device_velocity = step_probe_coupling(model, state);

  const double beta = has(model.settings.effects, Effect::Friction) ? state.params.beta : 0.0;
  find_probe_box_contacts(
      model, boxes, state, scratch, counters, max_depth, [](Index) {},
      [&](const ProbeContact& c) {
        // `normal` separates the two for the probe: along it out of the box's face, or into
        // the sphere's for a box node.
        respond_cell_probe(model, state, c.cell, c.node >= 0 ? Vec3(-c.normal) : c.normal, c.depth, beta);
        invalidate_around(model, boxes, scratch, c.cell);
        ensure_box(model, boxes, state, scratch, c.box, counters);
        return true;
      });
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
  const Vec3 dv = grab_velocity_change(model, inv_mass, grab.target - point, velocity, Vec3::Zero(), model.settings.dt);
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
