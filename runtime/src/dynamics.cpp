#include "dynamics.h"

#include <cmath>

namespace ffd {

void extract_rotation(const Mat3& A, Quat& q, int max_iterations) {
  for (int it = 0; it < max_iterations; ++it) {
    const Mat3 R = q.matrix();
    const Vec3 torque = R.col(0).cross(A.col(0)) + R.col(1).cross(A.col(1)) + R.col(2).cross(A.col(2));
    const double scale = std::fabs(R.col(0).dot(A.col(0)) + R.col(1).dot(A.col(1)) + R.col(2).dot(A.col(2))) + 1.0e-9;
    const Vec3 omega = torque / scale;
    const double angle = omega.norm();
    if (!(angle > 1.0e-9) || !std::isfinite(angle)) break;
    q = Quat(Eigen::AngleAxisd(angle, omega / angle)) * q;
    q.normalize();
  }
}

namespace {

// XPBD (Macklin et al. 2016) on distance constraints with compliance 1/k and Rayleigh-like
// constraint damping: implicit in effect, so stable for every stiffness at the fixed dt.
// The stiffness is the object's live value in State::params, so it can be tuned between steps.
void integrate_mass_spring(const Model& model, const ObjectModel& obj, double stiffness, State& state,
                           Scratch& scratch) {
  const double dt = model.settings.dt;
  const MassSpringParams& p = obj.mass_spring;
  for (Index n = obj.node_begin; n < obj.node_end; ++n) {
    scratch.x_prev[n] = state.x[n];
    state.x[n] += dt * state.v[n];  // prediction
  }
  const double compliance = 1.0 / stiffness;            // m/N
  const double alpha_tilde = compliance / (dt * dt);    // XPBD eq. (compliance scaled by dt^2)
  const double gamma = compliance * p.damping / dt;     // XPBD damping term
  const std::size_t object = &obj - model.objects.data();
  if (scratch.denominator_stiffness[object] != stiffness) {
    for (Index s = obj.spring_begin; s < obj.spring_end; ++s) {
      const Spring& spring = model.springs[s];
      const double w = model.node_inv_mass[spring.a] + model.node_inv_mass[spring.b];
      scratch.spring_inv_denominator[s] = 1.0 / ((1.0 + gamma) * w + alpha_tilde);
    }
    scratch.denominator_stiffness[object] = stiffness;
  }
  for (Index s = obj.spring_begin; s < obj.spring_end; ++s) scratch.lambda[s] = 0.0;
  for (int it = 0; it < p.iterations; ++it) {
    for (Index s = obj.spring_begin; s < obj.spring_end; ++s) {
      const Spring& spring = model.springs[s];
      Vec3& xa = state.x[spring.a];
      Vec3& xb = state.x[spring.b];
      const Vec3 d = xa - xb;
      const double len = d.norm();
      if (!(len > 1e-12)) continue;  // coincident nodes: no direction to push along
      const Vec3 grad = d * (1.0 / len);
      const double wa = model.node_inv_mass[spring.a], wb = model.node_inv_mass[spring.b];
      const double C = len - spring.rest_length;
      const double damping_term = gamma * grad.dot((xa - scratch.x_prev[spring.a]) - (xb - scratch.x_prev[spring.b]));
      const double dlambda = (-C - alpha_tilde * scratch.lambda[s] - damping_term) * scratch.spring_inv_denominator[s];
      scratch.lambda[s] += dlambda;
      xa += (wa * dlambda) * grad;
      xb -= (wb * dlambda) * grad;
    }
  }
  const double inv_dt = 1.0 / dt;
  for (Index n = obj.node_begin; n < obj.node_end; ++n) state.v[n] = (state.x[n] - scratch.x_prev[n]) * inv_dt;
  // The force each constraint applied this step, elastic and damping (XPBD: lambda / dt^2), N.
  for (Index s = obj.spring_begin; s < obj.spring_end; ++s) state.spring_force[s] = scratch.lambda[s] * inv_dt * inv_dt;
}

// Lattice shape matching (Rivers & James 2007, FastLSM, with Mueller et al. 2005
// integration): each region's best rigid fit of its rest shape gives goal positions; a node
// is pulled towards the mean of its regions' goals by a fraction `stiffness` per step.
void integrate_shape_matching(const Model& model, const ObjectModel& obj, double stiffness, State& state,
                              Scratch& scratch) {
  const double dt = model.settings.dt;
  const ShapeMatchingParams& p = obj.shape_matching;
  for (Index n = obj.node_begin; n < obj.node_end; ++n) scratch.goal_sum[n] = Vec3::Zero();
  for (Index r = obj.region_begin; r < obj.region_end; ++r) {
    const Region& region = model.regions[r];
    Vec3 c = Vec3::Zero();
    for (Index m = region.member_begin; m < region.member_end; ++m) {
      const Index n = model.region_members[m];
      c += model.node_mass[n] * state.x[n];
    }
    c /= region.mass;
    Mat3 A = Mat3::Zero();
    for (Index m = region.member_begin; m < region.member_end; ++m) {
      const Index n = model.region_members[m];
      A += model.node_mass[n] * (state.x[n] - c) * (model.node_rest[n] - region.rest_centroid).transpose();
    }
    extract_rotation(A, state.region_rotation[r], 4);
    const Mat3 R = state.region_rotation[r].matrix();
    for (Index m = region.member_begin; m < region.member_end; ++m) {
      const Index n = model.region_members[m];
      scratch.goal_sum[n] += R * (model.node_rest[n] - region.rest_centroid) + c;
    }
  }
  const double pull = stiffness / dt;
  const double keep = std::max(0.0, 1.0 - p.damping * dt);
  for (Index n = obj.node_begin; n < obj.node_end; ++n) {
    const Vec3 goal = scratch.goal_sum[n] / static_cast<double>(model.node_region_count[n]);
    state.v[n] = keep * (state.v[n] + pull * (goal - state.x[n]));
    state.x[n] += dt * state.v[n];
  }
}

}  // namespace

void integrate_dynamics(const Model& model, State& state, Scratch& scratch) {
  for (std::size_t i = 0; i < model.objects.size(); ++i) {
    const ObjectModel& obj = model.objects[i];
    const double stiffness = state.params.stiffness[i];
    if (obj.dynamics == DynamicsKind::MassSpring) integrate_mass_spring(model, obj, stiffness, state, scratch);
    else integrate_shape_matching(model, obj, stiffness, state, scratch);
  }
}

}  // namespace ffd
