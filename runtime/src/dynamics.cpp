#include "dynamics.h"

#include "ffd/trilinear.h"
#include "ffd/worker_pool.h"
#include "kernels/spring_kernels.h"
#include "monotonic_clock.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <numeric>

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

// A position's three doubles, copied one by one: std::copy_n of 3 became a call to memmove
// per node, which cost more than the copy (the solver copies every node twice a sweep).
void copy_position(const double* from, double* to) {
  to[0] = from[0];
  to[1] = from[1];
  to[2] = from[2];
}

// A tetrahedron's volume V = d1 . (d2 x d3) / 6 with d_i = x_i - x0, and its gradient:
// (d2 x d3) / 6, (d3 x d1) / 6, (d1 x d2) / 6 for x1..x3 and minus their sum for x0.
struct VolumeGradient {
  double volume;         // m^3, signed: < 0 inside out
  std::array<Vec3, 4> g;  // m^2
  double denominator;    // sum of w_i |g_i|^2
};
VolumeGradient volume_gradient(const Model& model, const Tetrahedron& t, const State& state) {
  const Vec3& x0 = state.x[t.nodes[0]];
  const Vec3 d1 = state.x[t.nodes[1]] - x0, d2 = state.x[t.nodes[2]] - x0, d3 = state.x[t.nodes[3]] - x0;
  VolumeGradient v;
  v.g[1] = d2.cross(d3) / 6.0;
  v.g[2] = d3.cross(d1) / 6.0;
  v.g[3] = d1.cross(d2) / 6.0;
  v.g[0] = -(v.g[1] + v.g[2] + v.g[3]);
  v.volume = d1.dot(v.g[1]);
  v.denominator = 0.0;
  for (int i = 0; i < 4; ++i) v.denominator += model.node_inv_mass[t.nodes[i]] * v.g[i].squaredNorm();
  return v;
}

// Moves the tetrahedron's nodes by dlambda along the volume's gradient, each by its inverse mass.
void move_along_gradient(const Model& model, const Tetrahedron& t, const VolumeGradient& v, double dlambda, State& state) {
  for (int i = 0; i < 4; ++i) state.x[t.nodes[i]] += (model.node_inv_mass[t.nodes[i]] * dlambda) * v.g[i];
}

// One XPBD projection of a tetrahedron's volume constraint C = V - V0 with compliance
// V0 / K (so its energy is K (V - V0)^2 / 2 V0). C is signed, so an inverted tetrahedron
// (V < 0) is pushed back through flat to upright, where springs alone are as content with
// the mirror image.
void project_volume(const Model& model, const Tetrahedron& t, double inv_dt2, double& lambda, State& state) {
  const VolumeGradient v = volume_gradient(model, t, state);
  const double alpha_tilde = t.compliance * inv_dt2;  // > 0: defined even for a flat tetrahedron
  const double C = v.volume - t.rest_volume;
  const double dlambda = (-C - alpha_tilde * lambda) / (v.denominator + alpha_tilde);
  lambda += dlambda;
  move_along_gradient(model, t, v, dlambda, state);
}

// The rotation R (from q, updated in place) that maximises tr(R^T A): Newton steps on a
// rotation w of R, with the gradient sum_i r_i x a_i (r_i, a_i the columns of R and A) and
// the Hessian H = tr(B) I - (B + B^T) / 2, B = A R^T; where H is not positive definite (a
// cell folded far from R, or inside out) the step of extract_rotation instead. Near the fit
// a Newton step takes the error from e to O(e^2), where extract_rotation's takes it to e / 3
// for a cube, and the update (1, w / 2) needs no sine or cosine.
void fit_rotation(const Mat3& A, Quat& q, int max_iterations) {
  for (int it = 0; it < max_iterations; ++it) {
    const Mat3 R = q.matrix();
    const Vec3 torque = R.col(0).cross(A.col(0)) + R.col(1).cross(A.col(1)) + R.col(2).cross(A.col(2));
    const Mat3 B = A * R.transpose();
    const Mat3 H = B.trace() * Mat3::Identity() - 0.5 * (B + B.transpose());
    const Eigen::LLT<Mat3> newton(H);
    Vec3 w;
    if (newton.info() == Eigen::Success) w = newton.solve(torque);
    else w = torque / (std::fabs(B.trace()) + 1.0e-9);
    const double angle_sq = w.squaredNorm();
    if (!(angle_sq > 1.0e-20) || !std::isfinite(angle_sq)) break;  // within 1e-10 rad
    q = Quat(1.0, 0.5 * w.x(), 0.5 * w.y(), 0.5 * w.z()) * q;
    q.normalize();
  }
}

// The mass-weighted centre of a cell's 8 nodes now (m).
Vec3 cell_centre(const Model& model, const State& state, Index cell) {
  Vec3 centre = Vec3::Zero();
  for (Index n : model.cell_nodes[cell]) centre += model.node_mass[n] * state.x[n];
  return centre / model.cell_node_mass[cell];
}

// Each cell's rotation for the step's sweeps, fitted to the predicted positions: the sweeps
// move the nodes little beside the prediction, and fitting once a step instead of once a
// projection costs a fraction of the time (docs/notes/2026-11-28-code-findings.md#corotated-cells).
// Each cell's on its own: the cells may be fitted in any order, on any thread.
void fit_cell_rotation(const Model& model, Index cell, State& state, DynamicsMemory& memory) {
  const std::array<Index, 8>& node = model.cell_nodes[cell];
  const Vec3& rest_centre = model.cell_rest_centre[cell];
  const Vec3 centre = cell_centre(model, state, cell);
  Mat3 A = Mat3::Zero();
  for (Index n : node) A += model.node_mass[n] * (state.x[n] - centre) * (model.node_rest[n] - rest_centre).transpose();
  fit_rotation(A, state.cell_rotation[cell], 2);  // warm-started from the last step
  memory.cell_rotation_matrix[cell] = state.cell_rotation[cell].matrix();
}

bool has_cell_shapes(const ObjectModel& obj) {
  return obj.dynamics == DynamicsKind::MassSpring && obj.mass_spring.shape_stiffness > 0.0;
}

void fit_cell_rotations(const Model& model, const ObjectModel& obj, State& state, DynamicsMemory& memory) {
  for (Index cell = obj.cell_begin; cell < obj.cell_end; ++cell) fit_cell_rotation(model, cell, state, memory);
}

// The rotations of every stepping object's cells, in chunks over the pool (after the
// predictions: they fit the predicted positions).
void fit_cell_rotations_over_pool(const Model& model, State& state, DynamicsMemory& memory, WorkerPool* pool) {
  if (memory.cell_task_count == 0) return;
  constexpr Index kCellsPerChunk = 64;
  const Index cells = static_cast<Index>(model.cell_count());
  parallel_for(pool, (cells + kCellsPerChunk - 1) / kCellsPerChunk, [&](std::uint32_t chunk, std::uint32_t) {
    for (Index cell = chunk * kCellsPerChunk; cell < std::min(cells, (chunk + 1) * kCellsPerChunk); ++cell) {
      const Index object = model.cell_object[cell];
      if (memory.object_stepping[object] && has_cell_shapes(model.objects[object]))
        fit_cell_rotation(model, cell, state, memory);
    }
  });
}

// One XPBD projection of a cell's shape constraint: a corotated element, shape matching
// (Mueller et al. 2005) on the cell's 8 nodes. With c and c0 the mass-weighted centres of the
// nodes now and at rest, R the cell's rotation (fit_cell_rotations) and the goals
// g_j = R (r_j - c0) + c,
//   C = sqrt(sum_j m_j |x_j - g_j|^2 / M),  M = sum_j m_j,  energy k C^2 / 2.
// sum_j m_j (x_j - g_j) = 0 and, R being the best fit, the goals exert no torque, so the
// gradient is (m_j / M)(x_j - g_j) / C: the generalised inverse mass is 1 / M and every node
// moves the same share of the way to its goal, which keeps momentum, and angular momentum as
// far as R, fitted to the step's prediction, still fits the nodes in the later sweeps.
// R is a rotation whichever way the cell is folded, so an inverted cell's goal is upright.
void project_cell_shape(const Model& model, Index cell, const Mat3& R, double alpha_tilde, double& lambda,
                        State& state) {
  const std::array<Index, 8>& node = model.cell_nodes[cell];
  const double M = model.cell_node_mass[cell];
  const Vec3& rest_centre = model.cell_rest_centre[cell];
  const Vec3 centre = cell_centre(model, state, cell);
  Vec3 to_goal[8];
  double sum = 0.0;
  for (int j = 0; j < 8; ++j) {
    to_goal[j] = R * (model.node_rest[node[j]] - rest_centre) + centre - state.x[node[j]];
    sum += model.node_mass[node[j]] * to_goal[j].squaredNorm();
  }
  const double C = std::sqrt(sum / M);
  if (!(C > 1.0e-12)) return;  // at its goal shape: no direction to push in
  const double dlambda = (-C - alpha_tilde * lambda) / (1.0 / M + alpha_tilde);
  lambda += dlambda;
  const double share = -dlambda / (M * C);  // of each node's way to its goal
  for (int j = 0; j < 8; ++j) state.x[node[j]] += share * to_goal[j];
}

// XPBD (Macklin et al. 2016) on distance constraints with compliance 1/k and Rayleigh-like
// constraint damping: implicit in effect, so stable for every stiffness at the fixed dt.
// The stiffness is the object's live value in State::params, so it can be tuned between steps.
// Gauss-Seidel colour by colour; a colour's springs share no node and go through the SIMD
// kernel several at a time, with the result of one after the other.
// A step is: the prediction (here), p.iterations sweeps (sweep_dynamics), then velocities
// from positions (finish_mass_spring). The "paper" response runs them back to back; the
// "solver" response puts the contacts' projections between the sweeps.
// The kernel's view of one object's springs at `stiffness`: XPBD's alpha~ = 1 / (k dt^2) and
// the damping term gamma = c / (k dt).
SpringSolve spring_solve(const Model& model, const ObjectModel& obj, double stiffness, DynamicsMemory& memory) {
  const double dt = model.settings.dt / memory.substeps;  // s: the step, or the substep
  const double compliance = 1.0 / stiffness;            // m/N
  const double alpha_tilde = compliance / (dt * dt);    // XPBD eq. (compliance scaled by dt^2)
  const double gamma = compliance * obj.mass_spring.damping / dt;  // XPBD damping term
  return SpringSolve{memory.node_record.get(),
                     memory.start_record.get(),
                     model.spring_node_a.data(),
                     model.spring_node_b.data(),
                     model.spring_rest_length.data(),
                     memory.lambda.data(),
                     memory.spring_inv_denominator.data(),
                     alpha_tilde,
                     gamma};
}

// Where a step fits its cells' rotations (fit_cell_rotations): in the object's own task, or
// afterwards for every object over the pool.
enum class CellFit { InTask, OverPool };

// x_prev = x, the prediction x += dt v, the multipliers reset, the denominators for the
// object's live stiffness.
SpringSolve predict_mass_spring(const Model& model, const ObjectModel& obj, double stiffness, State& state,
                                DynamicsMemory& memory, CellFit fit) {
  const double dt = model.settings.dt;
  for (Index n = obj.node_begin; n < obj.node_end; ++n) {
    memory.x_prev[n] = state.x[n];
    state.x[n] += dt * state.v[n];  // prediction
    copy_position(memory.x_prev[n].data(), memory.start_record.get() + kNodeRecord * n);
  }
  const SpringSolve solve = spring_solve(model, obj, stiffness, memory);
  const std::size_t object = &obj - model.objects.data();
  if (memory.denominator_stiffness[object] != stiffness || memory.denominator_substeps[object] != memory.substeps) {
    for (Index s = obj.spring_begin; s < obj.spring_end; ++s) {
      const Spring& spring = model.springs[s];
      const double w = model.node_inv_mass[spring.a] + model.node_inv_mass[spring.b];
      memory.spring_inv_denominator[s] = 1.0 / ((1.0 + solve.gamma) * w + solve.alpha_tilde);
    }
    memory.denominator_stiffness[object] = stiffness;
    memory.denominator_substeps[object] = memory.substeps;
  }
  for (Index s = obj.spring_begin; s < obj.spring_end; ++s) memory.lambda[s] = 0.0;
  for (Index t = obj.tetrahedron_begin; t < obj.tetrahedron_end; ++t) memory.tetrahedron_lambda[t] = 0.0;
  if (obj.mass_spring.shape_stiffness > 0.0) {
    for (Index c = obj.cell_begin; c < obj.cell_end; ++c) memory.cell_shape_lambda[c] = 0.0;
    if (fit == CellFit::InTask) fit_cell_rotations(model, obj, state, memory);
  }
  return solve;
}

// The object's positions into the kernel's node records (kNodeRecord), and back.
void nodes_to_records(const ObjectModel& obj, const State& state, DynamicsMemory& memory) {
  for (Index n = obj.node_begin; n < obj.node_end; ++n)
    copy_position(state.x[n].data(), memory.node_record.get() + kNodeRecord * n);
}
void records_to_nodes(const ObjectModel& obj, State& state, const DynamicsMemory& memory) {
  for (Index n = obj.node_begin; n < obj.node_end; ++n)
    copy_position(memory.node_record.get() + kNodeRecord * n, state.x[n].data());
}

bool has_cell_constraints(const ObjectModel& obj) {
  return obj.tetrahedron_end > obj.tetrahedron_begin || obj.mass_spring.shape_stiffness > 0.0;
}

// A sweep's second part, after the object's springs (sweep_springs): its volumes, then its
// cells' shapes, one after the other (they share nodes).
void project_cell_constraints(const Model& model, const ObjectModel& obj, State& state, DynamicsMemory& memory) {
  const double dt = model.settings.dt / memory.substeps;  // s: the step, or the substep
  for (Index t = obj.tetrahedron_begin; t < obj.tetrahedron_end; ++t)
    project_volume(model, model.tetrahedra[t], 1.0 / (dt * dt), memory.tetrahedron_lambda[t], state);
  if (obj.mass_spring.shape_stiffness > 0.0) {
    const double alpha_tilde = 1.0 / (obj.mass_spring.shape_stiffness * dt * dt);  // XPBD: compliance / dt^2
    for (Index c = obj.cell_begin; c < obj.cell_end; ++c)
      project_cell_shape(model, c, memory.cell_rotation_matrix[c], alpha_tilde, memory.cell_shape_lambda[c], state);
  }
}

// Node n's velocity at the end of a substep of h that began at start_record with velocity u:
// u plus what the constraints moved it from its prediction, over h. A node no constraint moved
// keeps u exactly (x - start over h would round it, and a free flight would gain energy).
Vec3 substep_velocity(const DynamicsMemory& memory, Index n, double h, const Vec3& x, const Vec3& u) {
  const Vec3 predicted = Eigen::Map<const Vec3>(memory.start_record.get() + kNodeRecord * n) + h * u;  // m
  return u + (x - predicted) / h;
}

void finish_mass_spring(const Model& model, const ObjectModel& obj, State& state, DynamicsMemory& memory) {
  const double inv_dt = memory.substeps / model.settings.dt;  // 1/s: of the step, or the last substep
  if (memory.substeps == 1) {
    for (Index n = obj.node_begin; n < obj.node_end; ++n) state.v[n] = (state.x[n] - memory.x_prev[n]) * inv_dt;
  } else {
    const double h = model.settings.dt / memory.substeps;  // s
    for (Index n = obj.node_begin; n < obj.node_end; ++n) state.v[n] = substep_velocity(memory, n, h, state.x[n], state.v[n]);
  }
  // The force each constraint applied this step, elastic and damping (XPBD: lambda / dt^2), N.
  for (Index s = obj.spring_begin; s < obj.spring_end; ++s) state.spring_force[s] = memory.lambda[s] * inv_dt * inv_dt;
  for (Index t = obj.tetrahedron_begin; t < obj.tetrahedron_end; ++t)
    state.volume_pressure[t] = memory.tetrahedron_lambda[t] * inv_dt * inv_dt;
  if (obj.mass_spring.shape_stiffness > 0.0)
    for (Index c = obj.cell_begin; c < obj.cell_end; ++c)
      state.cell_shape_force[c] = memory.cell_shape_lambda[c] * inv_dt * inv_dt;
}

// Lattice shape matching (Rivers & James 2007, FastLSM, with Mueller et al. 2005
// integration): each region's best rigid fit of its rest shape gives goal positions; a node
// is pulled towards the mean of its regions' goals by a fraction `stiffness` per step.
void integrate_shape_matching(const Model& model, const ObjectModel& obj, double stiffness, State& state,
                              DynamicsMemory& memory) {
  const double dt = model.settings.dt;
  const ShapeMatchingParams& p = obj.shape_matching;
  for (Index n = obj.node_begin; n < obj.node_end; ++n) memory.goal_sum[n] = Vec3::Zero();
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
      memory.goal_sum[n] += R * (model.node_rest[n] - region.rest_centroid) + c;
    }
  }
  const double pull = stiffness / dt;
  const double keep = std::max(0.0, 1.0 - p.damping * dt);
  for (Index n = obj.node_begin; n < obj.node_end; ++n) {
    const Vec3 goal = memory.goal_sum[n] / static_cast<double>(model.node_region_count[n]);
    state.v[n] = keep * (state.v[n] + pull * (goal - state.x[n]));
    state.x[n] += dt * state.v[n];
  }
}

// One sweep of one object: its springs colour by colour on the node records, then, on the
// positions, its volumes and shapes. The records hold the positions before and after.
void sweep_object(const Model& model, const ObjectModel& obj, const SpringSolve& solve, State& state,
                  DynamicsMemory& memory) {
  for (Index c = obj.colour_begin; c < obj.colour_end; ++c) {
    const SpringColour& colour = model.spring_colours[c];
    project_springs(solve, colour.begin, colour.end, colour.independent);
  }
  if (!has_cell_constraints(obj)) return;
  records_to_nodes(obj, state, memory);
  project_cell_constraints(model, obj, state, memory);
  nodes_to_records(obj, state, memory);
}

// Which way a shape-matching object's velocity is finished: under the solver its step (taken
// at the prediction) is followed by the contacts' corrections, so it is taken from x_prev;
// under the paper's response its step already set it.
enum class ShapeMatchingVelocity { Kept, FromPositions };

void finish_object(const Model& model, Index i, State& state, DynamicsMemory& memory,
                   ShapeMatchingVelocity shape_matching) {
  const ObjectModel& obj = model.objects[i];
  if (obj.dynamics == DynamicsKind::MassSpring) {
    // Under the paper's response the sweeps ran back to back on the records; under the
    // solver each sweep brought the positions back for the contacts.
    if (shape_matching == ShapeMatchingVelocity::Kept) records_to_nodes(obj, state, memory);
    finish_mass_spring(model, obj, state, memory);
    return;
  }
  if (shape_matching == ShapeMatchingVelocity::Kept) return;
  const double inv_dt = 1.0 / model.settings.dt;
  for (Index n = obj.node_begin; n < obj.node_end; ++n) state.v[n] = (state.x[n] - memory.x_prev[n]) * inv_dt;
}

void predict_object(const Model& model, Index i, State& state, DynamicsMemory& memory, CellFit fit) {
  const ObjectModel& obj = model.objects[i];
  if (obj.dynamics == DynamicsKind::MassSpring) {
    memory.object_solve[i] = predict_mass_spring(model, obj, state.params.stiffness[i], state, memory, fit);
    nodes_to_records(obj, state, memory);
    return;
  }
  for (Index n = obj.node_begin; n < obj.node_end; ++n) memory.x_prev[n] = state.x[n];
  integrate_shape_matching(model, obj, state.params.stiffness[i], state, memory);
}

// The step's tasks: the awake objects, largest first; and which way the sweeps go for the
// pool's thread count: one task per object when the objects, dealt largest first to the
// least loaded thread, keep every thread within kBalanced of an even share, else stages.
constexpr double kBalanced = 1.1;
// Unbalanced scenes: a trial of kTrialSteps steps each way every kTrialPeriod steps.
constexpr int kTrialSteps = 16, kTrialPeriod = 2048;

void plan_step(const State& state, DynamicsMemory& memory, WorkerPool* pool) {
  Index tasks = 0, cell_tasks = 0;
  for (Index i : memory.objects_by_work) {
    memory.object_stepping[i] = !state.asleep[i];  // an object asleep is frozen (sleep.h)
    if (memory.object_stepping[i]) memory.object_tasks[tasks++] = i;
  }
  for (Index i : memory.objects_with_cells)
    if (memory.object_stepping[i]) memory.cell_tasks[cell_tasks++] = i;
  memory.object_task_count = tasks;
  memory.cell_task_count = cell_tasks;
  const int threads = pool ? std::min(pool->threads(), 64) : 1;
  if (threads != memory.stages_for_threads) {
    memory.stages_for_threads = threads;
    double load[64] = {};
    double total = 0.0;
    for (Index i : memory.objects_by_work) {
      *std::min_element(load, load + threads) += memory.object_work[i];
      total += memory.object_work[i];
    }
    memory.unbalanced = threads > 1 && *std::max_element(load, load + threads) > kBalanced * total / threads;
    memory.trial_step = 0;
  }
  if (!memory.unbalanced) {
    memory.use_stages = false;
    return;
  }
  memory.timing = memory.trial_step < 2 * kTrialSteps;
  memory.use_stages = memory.timing ? memory.trial_step >= kTrialSteps : memory.stages_faster;
  if (memory.timing) memory.step_start_ns = monotonic_ns();
}

// The end of a step's dynamics: a trial step's time, and the verdict after the last one.
void end_trial_step(DynamicsMemory& memory) {
  if (!memory.unbalanced) return;
  if (memory.timing) memory.trial_ns[memory.use_stages ? 1 : 0] += monotonic_ns() - memory.step_start_ns;
  if (++memory.trial_step == 2 * kTrialSteps) {
    memory.stages_faster = memory.trial_ns[1] < memory.trial_ns[0];
    memory.trial_ns[0] = memory.trial_ns[1] = 0;
  }
  if (memory.trial_step == kTrialPeriod) memory.trial_step = 0;
}

// Cuts every stage's segments into chunks of about this many springs: a chunk of a large
// object's colour is about a microsecond of work, a few times a stage's wait.
constexpr Index kChunkSprings = 128;  // a multiple of the kernel's 4 lanes

void schedule_springs(const Model& model, DynamicsMemory& memory) {
  memory.spring_segments.clear();
  memory.chunk_first_segment.clear();
  memory.stage_first_chunk.clear();
  Index stages = 0;
  for (const ObjectModel& obj : model.objects)
    if (obj.dynamics == DynamicsKind::MassSpring) stages = std::max(stages, obj.colour_end - obj.colour_begin);
  for (Index stage = 0; stage < stages; ++stage) {
    memory.stage_first_chunk.push_back(static_cast<Index>(memory.chunk_first_segment.size()));
    Index in_chunk = 0;  // springs in the open chunk
    const auto add = [&](Index object, Index begin, Index end, bool independent) {
      if (memory.chunk_first_segment.size() == memory.stage_first_chunk.back() || in_chunk + (end - begin) > kChunkSprings) {
        memory.chunk_first_segment.push_back(static_cast<Index>(memory.spring_segments.size()));
        in_chunk = 0;
      }
      memory.spring_segments.push_back(DynamicsMemory::SpringSegment{object, begin, end, independent});
      in_chunk += end - begin;
    };
    for (Index o = 0; o < model.objects.size(); ++o) {
      const ObjectModel& obj = model.objects[o];
      if (obj.dynamics != DynamicsKind::MassSpring || stage >= obj.colour_end - obj.colour_begin) continue;
      const SpringColour& colour = model.spring_colours[obj.colour_begin + stage];
      if (!colour.independent) {  // its springs one after the other: one segment
        add(o, colour.begin, colour.end, false);
        continue;
      }
      for (Index begin = colour.begin; begin < colour.end; begin += kChunkSprings)
        add(o, begin, std::min(colour.end, begin + kChunkSprings), true);
    }
  }
  memory.stage_first_chunk.push_back(static_cast<Index>(memory.chunk_first_segment.size()));
  memory.chunk_first_segment.push_back(static_cast<Index>(memory.spring_segments.size()));
  const std::size_t chunks = memory.chunk_first_segment.size() - 1;
  memory.chunk_claim = std::make_unique<std::atomic<std::uint64_t>[]>(chunks);
  for (std::size_t c = 0; c < chunks; ++c) memory.chunk_claim[c].store(0, std::memory_order_relaxed);
  memory.stage_done = std::make_unique<DynamicsMemory::StageDone[]>(static_cast<std::size_t>(dynamics_iterations(model)) * stages);
  memory.pass = 0;
}

// The volumes and shapes of sweep `iteration`, one task per object that has them.
void sweep_cells(const Model& model, int iteration, State& state, DynamicsMemory& memory, WorkerPool* pool) {
  parallel_for(pool, memory.cell_task_count, [&](std::uint32_t task, std::uint32_t) {
    const ObjectModel& obj = model.objects[memory.cell_tasks[task]];
    if (iteration >= obj.mass_spring.iterations) return;
    records_to_nodes(obj, state, memory);
    project_cell_constraints(model, obj, state, memory);
    nodes_to_records(obj, state, memory);
  });
}

}  // namespace

void restore_inverted_cells(const Model& model, State& state, const DynamicsMemory& memory, WorkerPool* pool) {
  const double h = model.settings.dt / memory.substeps;  // s: the step, or the substep
  parallel_for(pool, static_cast<std::uint32_t>(model.objects.size()), [&](std::uint32_t i, std::uint32_t) {
    const ObjectModel& obj = model.objects[i];
    if (obj.dynamics != DynamicsKind::MassSpring || has_cell_constraints(obj) || !memory.object_stepping[i]) return;
    // The springs' live stiffness as a bulk modulus, K = k / cell size (Pa): a soft lattice
    // is not thrown upright harder than its springs would pull it.
    const double modulus = state.params.stiffness[i] / obj.cell_size;
    for (Index c = obj.cell_begin; c < obj.cell_end; ++c) {
      if (!cell_inverted(model, state, c)) continue;
      for (int pass = 0; pass < kUprightPasses; ++pass)
        for (int k = 0; k < 6; ++k) {
          const Tetrahedron t = kuhn_tetrahedron(model, c, k);
          const VolumeGradient v = volume_gradient(model, t, state);
          const double C = v.volume - t.rest_volume;
          const double alpha_tilde = t.rest_volume / modulus / (h * h);  // XPBD: compliance / h^2
          if (C < 0.0) move_along_gradient(model, t, v, -C / (v.denominator + alpha_tilde), state);
        }
    }
  });
}

void sweep_springs(const Model& model, int first, int last, DynamicsMemory& memory, WorkerPool* pool) {
  const Index stages = static_cast<Index>(memory.stage_first_chunk.size()) - 1;
  if (stages <= 0 || last <= first) return;
  const auto project_chunk = [&](int iteration, Index chunk) {
    for (Index g = memory.chunk_first_segment[chunk]; g < memory.chunk_first_segment[chunk + 1]; ++g) {
      const DynamicsMemory::SpringSegment& segment = memory.spring_segments[g];
      if (memory.object_stepping[segment.object] && iteration < model.objects[segment.object].mass_spring.iterations)
        project_springs(memory.object_solve[segment.object], segment.begin, segment.end, segment.independent);
    }
  };
  DynamicsMemory::StageDone* done = memory.stage_done.get();
  const std::size_t passes = static_cast<std::size_t>(last - first) * stages;
  for (std::size_t k = 0; k < passes; ++k) done[k].chunks.store(0, std::memory_order_relaxed);  // published by the job
  const std::uint64_t first_pass = memory.pass + 1;
  memory.pass += passes;
  const std::uint32_t threads = pool ? static_cast<std::uint32_t>(pool->threads()) : 1u;
  const auto take_part = [&](std::uint32_t part, std::uint32_t) {
    int spins = 0;
    for (std::size_t k = 0; k < passes; ++k) {
      const int iteration = first + static_cast<int>(k / stages);
      const Index stage = static_cast<Index>(k % stages);
      const Index chunk_begin = memory.stage_first_chunk[stage];
      const std::uint32_t chunks = memory.stage_first_chunk[stage + 1] - chunk_begin;
      const std::uint64_t pass = first_pass + k;
      std::uint32_t claimed = 0;
      const auto claim = [&](std::uint32_t c) {
        std::atomic<std::uint64_t>& flag = memory.chunk_claim[chunk_begin + c];
        std::uint64_t last_pass = flag.load(std::memory_order_relaxed);
        // A thread left behind in an earlier pass (every chunk done without it) finds the
        // chunks claimed in that pass or a later one and claims none.
        if (last_pass >= pass || !flag.compare_exchange_strong(last_pass, pass, std::memory_order_relaxed)) return;
        project_chunk(iteration, chunk_begin + c);
        ++claimed;
      };
      const std::uint32_t start = static_cast<std::uint32_t>(std::uint64_t{part} * chunks / threads);
      for (std::uint32_t c = start; c < chunks; ++c) claim(c);
      for (std::uint32_t c = start; c-- > 0;) claim(c);
      // release / acquire on the count hands the stage's nodes on to the next stage
      if (claimed > 0) done[k].chunks.fetch_add(claimed, std::memory_order_acq_rel);
      while (done[k].chunks.load(std::memory_order_acquire) < chunks) spin_wait(spins);
    }
  };
  parallel_for(pool, threads, take_part);
}

void size_dynamics_memory(const Model& model, DynamicsMemory& memory) {
  memory.x_prev.resize(model.node_count());
  memory.node_record = hwy::AllocateAligned<double>(kNodeRecord * std::max<std::size_t>(1, model.node_count()));
  memory.start_record = hwy::AllocateAligned<double>(kNodeRecord * std::max<std::size_t>(1, model.node_count()));
  for (Index n = 0; n < model.node_count(); ++n) {
    double* record = memory.node_record.get() + kNodeRecord * n;
    std::fill_n(record, kNodeRecord, 0.0);
    record[3] = model.node_inv_mass[n];  // never written by the sweeps
    std::fill_n(memory.start_record.get() + kNodeRecord * n, kNodeRecord, 0.0);
  }
  memory.lambda.resize(model.springs.size());
  memory.tetrahedron_lambda.resize(model.tetrahedra.size());
  memory.cell_shape_lambda.resize(model.cell_count());
  memory.cell_rotation_matrix.resize(model.cell_count());
  memory.spring_inv_denominator.resize(model.springs.size());
  memory.denominator_stiffness.assign(model.objects.size(), 0.0);  // 0: not computed yet
  memory.denominator_substeps.assign(model.objects.size(), 0);
  memory.object_work.resize(model.objects.size());
  for (std::size_t i = 0; i < model.objects.size(); ++i) {
    const ObjectModel& o = model.objects[i];
    if (o.dynamics == DynamicsKind::MassSpring) {
      double projections = static_cast<double>(o.spring_end - o.spring_begin);
      // A cell's shape projection costs about 8 springs' (its rotation, its 8 nodes).
      if (o.mass_spring.shape_stiffness > 0.0) projections += 8.0 * (o.cell_end - o.cell_begin);
      memory.object_work[i] = projections * o.mass_spring.iterations;
    } else {
      memory.object_work[i] = o.region_begin == o.region_end ? 0.0
                                                        : static_cast<double>(model.regions[o.region_end - 1].member_end -
                                                                              model.regions[o.region_begin].member_begin);
    }
  }
  memory.objects_by_work.resize(model.objects.size());
  std::iota(memory.objects_by_work.begin(), memory.objects_by_work.end(), Index{0});
  std::stable_sort(memory.objects_by_work.begin(), memory.objects_by_work.end(),
                   [&](Index a, Index b) { return memory.object_work[a] > memory.object_work[b]; });
  memory.object_tasks.resize(model.objects.size());
  memory.goal_sum.resize(model.regions.empty() ? 0 : model.node_count());
  schedule_springs(model, memory);
  memory.object_solve.resize(model.objects.size());
  memory.object_stepping.assign(model.objects.size(), 0);
  memory.objects_with_cells.clear();
  for (Index i : memory.objects_by_work)
    if (model.objects[i].dynamics == DynamicsKind::MassSpring && has_cell_constraints(model.objects[i]))
      memory.objects_with_cells.push_back(i);
  memory.cell_tasks.resize(memory.objects_with_cells.size());
  memory.stages_for_threads = 0;
}

void integrate_dynamics(const Model& model, State& state, DynamicsMemory& memory, WorkerPool* pool) {
  memory.substeps = 1;  // the paper's response: the sweeps are iterations of one step
  plan_step(state, memory, pool);
  if (!memory.use_stages) {  // one task per object, its whole step in it
    parallel_for(pool, memory.object_task_count, [&](std::uint32_t task, std::uint32_t) {
      const Index i = memory.object_tasks[task];
      const ObjectModel& obj = model.objects[i];
      predict_object(model, i, state, memory, CellFit::InTask);
      if (obj.dynamics == DynamicsKind::MassSpring)
        for (int it = 0; it < obj.mass_spring.iterations; ++it) sweep_object(model, obj, memory.object_solve[i], state, memory);
      finish_object(model, i, state, memory, ShapeMatchingVelocity::Kept);
    });
    end_trial_step(memory);
    return;
  }
  parallel_for(pool, memory.object_task_count, [&](std::uint32_t task, std::uint32_t) {
    predict_object(model, memory.object_tasks[task], state, memory, CellFit::OverPool);
  });
  fit_cell_rotations_over_pool(model, state, memory, pool);
  const int iterations = dynamics_iterations(model);
  if (memory.cell_task_count == 0) {
    sweep_springs(model, 0, iterations, memory, pool);  // every sweep in one job
  } else {
    for (int it = 0; it < iterations; ++it) {
      sweep_springs(model, it, it + 1, memory, pool);
      sweep_cells(model, it, state, memory, pool);
    }
  }
  parallel_for(pool, memory.object_task_count, [&](std::uint32_t task, std::uint32_t) {
    finish_object(model, memory.object_tasks[task], state, memory, ShapeMatchingVelocity::Kept);
  });
  end_trial_step(memory);
}

// Every awake object's prediction, one task each, the largest first; a shape-matching object
// takes its whole step here (it has no sweeps), its start kept in x_prev.
void predict_dynamics(const Model& model, State& state, DynamicsMemory& memory, WorkerPool* pool) {
  plan_step(state, memory, pool);
  parallel_for(pool, memory.object_task_count, [&](std::uint32_t task, std::uint32_t) {
    predict_object(model, memory.object_tasks[task], state, memory, CellFit::OverPool);
  });
  fit_cell_rotations_over_pool(model, state, memory, pool);
}

int dynamics_iterations(const Model& model) {
  int iterations = 1;
  for (const ObjectModel& obj : model.objects)
    if (obj.dynamics == DynamicsKind::MassSpring) iterations = std::max(iterations, obj.mass_spring.iterations);
  return iterations;
}

// Under the solver the contacts move the positions between the sweeps: each sweep takes
// them into the node records and gives them back.
void sweep_dynamics(const Model& model, int iteration, State& state, DynamicsMemory& memory, WorkerPool* pool) {
  const auto sweeping = [&](Index i) {
    const ObjectModel& obj = model.objects[i];
    return obj.dynamics == DynamicsKind::MassSpring && iteration < obj.mass_spring.iterations;
  };
  if (memory.use_stages) {
    parallel_for(pool, memory.object_task_count, [&](std::uint32_t task, std::uint32_t) {
      const Index i = memory.object_tasks[task];
      if (sweeping(i)) nodes_to_records(model.objects[i], state, memory);
    });
    sweep_springs(model, iteration, iteration + 1, memory, pool);
    parallel_for(pool, memory.object_task_count, [&](std::uint32_t task, std::uint32_t) {
      const Index i = memory.object_tasks[task];
      if (!sweeping(i)) return;
      records_to_nodes(model.objects[i], state, memory);
      project_cell_constraints(model, model.objects[i], state, memory);
    });
    return;
  }
  parallel_for(pool, memory.object_task_count, [&](std::uint32_t task, std::uint32_t) {
    const Index i = memory.object_tasks[task];
    if (!sweeping(i)) return;
    const ObjectModel& obj = model.objects[i];
    nodes_to_records(obj, state, memory);
    for (Index c = obj.colour_begin; c < obj.colour_end; ++c) {
      const SpringColour& colour = model.spring_colours[c];
      project_springs(memory.object_solve[i], colour.begin, colour.end, colour.independent);
    }
    records_to_nodes(obj, state, memory);
    project_cell_constraints(model, obj, state, memory);
  });
}

void begin_substep(const Model& model, int k, State& state, DynamicsMemory& memory, WorkerPool* pool) {
  const double dt = model.settings.dt, h = dt / memory.substeps;  // s
  parallel_for(pool, memory.object_task_count, [&](std::uint32_t task, std::uint32_t) {
    const ObjectModel& obj = model.objects[memory.object_tasks[task]];
    if (obj.dynamics != DynamicsKind::MassSpring) return;
    for (Index n = obj.node_begin; n < obj.node_end; ++n) {
      // The step's v holds all of g dt; substep 0 keeps g h of it, each later one adds g h.
      const Vec3 u = k == 0 ? Vec3(state.v[n] + memory.substep_gravity * (h - dt))
                            : Vec3(state.v[n] + memory.substep_gravity * h);  // m/s: end_substep's
      const Vec3 x_sub = k == 0 ? memory.x_prev[n] : state.x[n];
      copy_position(x_sub.data(), memory.start_record.get() + kNodeRecord * n);
      state.v[n] = u;
      state.x[n] = x_sub + h * u;
    }
    if (k == 0) return;  // the prediction reset them
    for (Index s = obj.spring_begin; s < obj.spring_end; ++s) memory.lambda[s] = 0.0;
    for (Index t = obj.tetrahedron_begin; t < obj.tetrahedron_end; ++t) memory.tetrahedron_lambda[t] = 0.0;
    if (obj.mass_spring.shape_stiffness > 0.0)
      for (Index c = obj.cell_begin; c < obj.cell_end; ++c) memory.cell_shape_lambda[c] = 0.0;
  });
}

void end_substep(const Model& model, State& state, DynamicsMemory& memory, WorkerPool* pool) {
  const double h = model.settings.dt / memory.substeps;  // s
  parallel_for(pool, memory.object_task_count, [&](std::uint32_t task, std::uint32_t) {
    const ObjectModel& obj = model.objects[memory.object_tasks[task]];
    if (obj.dynamics != DynamicsKind::MassSpring) return;
    for (Index n = obj.node_begin; n < obj.node_end; ++n) state.v[n] = substep_velocity(memory, n, h, state.x[n], state.v[n]);
  });
}

void finish_dynamics(const Model& model, State& state, DynamicsMemory& memory, WorkerPool* pool) {
  parallel_for(pool, memory.object_task_count, [&](std::uint32_t task, std::uint32_t) {
    finish_object(model, memory.object_tasks[task], state, memory, ShapeMatchingVelocity::FromPositions);
  });
  end_trial_step(memory);
}

}  // namespace ffd
