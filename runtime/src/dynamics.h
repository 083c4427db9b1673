#pragma once
// Internal dynamics of the lattice nodes, per object: XPBD mass-spring or lattice shape
// matching. Both are unconditionally stable at any stiffness for the fixed step.
#include <vector>

#include "ffd/model.h"
#include "ffd/state.h"

namespace ffd {

class WorkerPool;

// The Dynamics stage's working memory.
struct DynamicsMemory {
  std::vector<Vec3> x_prev;                // positions at the start of the step
  std::vector<double> lambda;              // XPBD Lagrange multipliers, one per spring
  std::vector<double> tetrahedron_lambda;  // XPBD Lagrange multipliers, one per tetrahedron
  std::vector<double> cell_shape_lambda;   // XPBD Lagrange multipliers, one per cell (shape)
  std::vector<Mat3> cell_rotation_matrix;  // State::cell_rotation as a matrix, for the sweeps
  // XPBD 1 / ((1 + gamma)(w_a + w_b) + alpha~) per spring, for the stiffness in
  // `denominator_stiffness` (per object): recomputed only when a command changes it.
  std::vector<double> spring_inv_denominator;
  std::vector<double> denominator_stiffness;
  // Scheduling the objects over the pool: each object's work (projections per step), the
  // objects by decreasing work, and the tasks of this step.
  std::vector<double> object_work;
  std::vector<Index> objects_by_work;
  std::vector<Index> object_tasks;
  Index object_task_count = 0;
  std::vector<Vec3> goal_sum;  // shape matching: summed goal positions per node
};
void size_dynamics_memory(const Model& model, DynamicsMemory& memory);

// Each function spreads its objects over `pool` (none: this thread alone).

// The whole step of every awake object: prediction, XPBD sweeps, velocities (response "paper").
void integrate_dynamics(const Model& model, State& state, DynamicsMemory& memory, WorkerPool* pool);

// The same in three parts, for the response "solver" (contact_solver.h), which projects the
// contacts between the sweeps: every awake object's prediction (x_prev = x, x += dt v; a
// shape-matching object's whole step), one sweep `iteration` of every mass-spring object
// that has that many, and v = (x - x_prev) / dt with the constraint forces.
void predict_dynamics(const Model& model, State& state, DynamicsMemory& memory, WorkerPool* pool);
int dynamics_iterations(const Model& model);  // the most sweeps an object asks for
void sweep_dynamics(const Model& model, int iteration, State& state, DynamicsMemory& memory, WorkerPool* pool);
void finish_dynamics(const Model& model, State& state, DynamicsMemory& memory, WorkerPool* pool);

// Rotation part of A (Mueller et al. 2016, "A Robust Method to Extract the Rotational Part
// of Deformations"), iterated from `q`, which is updated in place. Never NaN: a degenerate A
// leaves q unchanged.
void extract_rotation(const Mat3& A, Quat& q, int max_iterations);

}  // namespace ffd
