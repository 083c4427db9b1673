#pragma once
// Internal dynamics of the lattice nodes, per object: XPBD mass-spring or lattice shape
// matching. Both are unconditionally stable at any stiffness for the fixed step.
#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "ffd/model.h"
#include "ffd/state.h"
#include <hwy/aligned_allocator.h>

#include "kernels/spring_kernels.h"

namespace ffd {

class WorkerPool;

// The Dynamics stage's working memory.
struct DynamicsMemory {
  std::vector<Vec3> x_prev;                // positions at the start of the step
  // The spring kernel's copy of the positions (kNodeRecord: x, y, z, 1/m) during the sweeps,
  // and of x_prev (x, y, z, unused), 32-byte aligned.
  hwy::AlignedFreeUniquePtr<double[]> node_record, start_record;
  std::vector<double> lambda;              // XPBD Lagrange multipliers, one per spring
  std::vector<double> tetrahedron_lambda;  // XPBD Lagrange multipliers, one per tetrahedron
  std::vector<double> cell_shape_lambda;   // XPBD Lagrange multipliers, one per cell (shape)
  std::vector<Mat3> cell_rotation_matrix;  // State::cell_rotation as a matrix, for the sweeps
  // XPBD 1 / ((1 + gamma)(w_a + w_b) + alpha~) per spring, for the stiffness in
  // `denominator_stiffness` (per object): recomputed only when a command changes it.
  std::vector<double> spring_inv_denominator;
  std::vector<double> denominator_stiffness;
  std::vector<int> denominator_substeps;  // per object: the substeps they were computed for
  // The step in substeps of dt / substeps (solver_substeps: one per sweep), or 1: one step of
  // dt, the sweeps iterations of it. Set before the prediction.
  int substeps = 1;
  Vec3 substep_gravity = Vec3::Zero();  // m/s^2: gravity spread over the substeps (0: none, or no substeps)
  // Scheduling the objects over the pool: each object's work (projections per step), the
  // objects by decreasing work, and the tasks of this step.
  std::vector<double> object_work;
  std::vector<Index> objects_by_work;
  std::vector<Index> object_tasks;
  Index object_task_count = 0;
  // How the objects share the pool. When they balance over its threads (two teapots on two,
  // a thousand letters) each object is one task, its whole step in it. When they do not (one
  // Buddha, five bunnies on two threads) the sweeps' springs go stage by stage, as Box2D v3
  // solves its constraint colours: stage c holds colour c of every mass-spring object, cut
  // into chunks of about kChunkSprings springs. A colour's springs share no node and two
  // objects share none, so a stage's chunks give the same bits on any thread in any order,
  // and both ways give the same bits. A segment is one object's springs [begin, end) of one
  // colour.
  struct SpringSegment {
    Index object, begin, end;
    bool independent;  // SpringColour::independent
  };
  std::vector<SpringSegment> spring_segments;
  std::vector<Index> chunk_first_segment;  // per chunk, then one past the last
  std::vector<Index> stage_first_chunk;    // per stage, then one past the last
  // Claiming the chunks (Box2D v3's b2ExecuteMainStage): each thread of the job starts at its
  // share of a stage's chunks and goes forward, then back, claiming each chunk not yet claimed
  // in this pass, so a thread keeps to the same part of the lattice from stage to stage (its
  // nodes stay in its cache) and takes over the rest when another is slow; then it waits
  // until the stage's chunks are all done. A thread that never comes (asleep, late) is not
  // waited for. `chunk_claim` holds the pass a chunk was last claimed in (passes are counted
  // in `pass` and never repeat); `stage_done`, per stage of a job, the chunks done.
  struct alignas(64) StageDone {
    std::atomic<std::uint32_t> chunks{0};
  };
  std::unique_ptr<std::atomic<std::uint64_t>[]> chunk_claim;
  std::unique_ptr<StageDone[]> stage_done;
  std::uint64_t pass = 0;
  std::vector<SpringSolve> object_solve;      // per object: its springs' view, set by the prediction
  std::vector<std::uint8_t> object_stepping;  // per object: awake at the prediction (1)
  // The mass-spring objects with volumes or shape constraints, projected object by object
  // after the springs in the stages (their constraints share nodes); the stepping ones.
  std::vector<Index> objects_with_cells;
  std::vector<Index> cell_tasks;
  Index cell_task_count = 0;
  // Where the objects do not balance, which way is faster is measured, not assumed: a stage's
  // wait costs several times more when the host puts the two threads far apart (a run may
  // move between the two), and both ways give the same bits. Every kTrialPeriod steps, a few
  // steps go each way, timed from the prediction to the velocities; the faster way runs
  // until the next trial.
  int stages_for_threads = 0;  // the thread count `unbalanced` was decided for (0: none yet)
  bool unbalanced = false;     // the objects do not balance over the threads
  bool use_stages = false;     // this step's way
  bool stages_faster = true;   // the last trial's verdict
  bool timing = false;         // this step is a trial step
  int trial_step = 0;          // steps since the last trial began
  std::int64_t step_start_ns = 0;
  std::int64_t trial_ns[2] = {0, 0};  // per way (one task per object, stages): the trial's time
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
// Substep k of memory.substeps (h = dt / substeps) of every stepping mass-spring object: the
// substep's start x_sub (start_record) and its prediction x = x_sub + h u, with u kept in v
// until the substep ends: the substep before's velocity (end_substep's) plus g h (at k = 0:
// the step's v, with g h of its g dt); the multipliers reset (XPBD with small steps, Macklin
// et al. 2019).
void begin_substep(const Model& model, int k, State& state, DynamicsMemory& memory, WorkerPool* pool);
// The velocities at the end of a substep but the last (finish_dynamics takes the last's), from
// where its constraints left the nodes: u plus their move from the prediction over h.
void end_substep(const Model& model, State& state, DynamicsMemory& memory, WorkerPool* pool);
void finish_dynamics(const Model& model, State& state, DynamicsMemory& memory, WorkerPool* pool);
// A cell turned inside out (cell_inverted) of every stepping mass-spring object whose
// springs alone hold its cells, pushed back upright: each tetrahedron of its Kuhn split
// below its rest volume grown towards it (C = V - V0 >= 0, XPBD with compliance V0 / K,
// K = the springs' live stiffness over the cell size), in kUprightPasses Gauss-Seidel passes over
// the six (they share nodes: one pass leaves some of them short). Springs are as content
// with a cell's mirror image as with the cell, so a cell that a contact pushed a node of
// through its opposite face stays inside out without this, and the surface it carries stays
// folded through itself. Volumes or shapes (bulk_modulus, shape_stiffness) bring such a
// cell back themselves. Every cell is looked at: the springs carry a contact's push to
// cells around the ones that carry its points, and those too turn inside out.
inline constexpr int kUprightPasses = 3;
void restore_inverted_cells(const Model& model, State& state, const DynamicsMemory& memory, WorkerPool* pool);
// Sweeps [first, last) of every object's springs alone, stage by stage (sweep_dynamics adds
// the volumes and shapes).
void sweep_springs(const Model& model, int first, int last, DynamicsMemory& memory, WorkerPool* pool);

// Rotation part of A (Mueller et al. 2016, "A Robust Method to Extract the Rotational Part
// of Deformations"), iterated from `q`, which is updated in place. Never NaN: a degenerate A
// leaves q unchanged.
void extract_rotation(const Mat3& A, Quat& q, int max_iterations);

}  // namespace ffd
