// One fixed step: the stages of the Model's pipeline, timed and counted. No allocation, no
// locking, no I/O, no logging in here: every buffer comes from the Scratch's StepMemory.
#include "ffd/step.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "ffd/worker_pool.h"
#include "interaction.h"
#include "sleep.h"
#include "step_memory.h"

namespace ffd {

namespace {

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

void apply_gravity(const Model& model, State& state) {
  const Vec3 dv = state.params.gravity * model.settings.dt;
  if (sleeping(model)) {
    for (std::size_t n = 0; n < state.v.size(); ++n)
      if (!state.asleep[model.node_object[n]]) state.v[n] += dv;
    return;
  }
  for (std::size_t n = 0; n < state.v.size(); ++n) state.v[n] += dv;
}

bool all_finite(const State& state) {
  for (std::size_t n = 0; n < state.x.size(); ++n)
    if (!is_finite(state.x[n]) || !is_finite(state.v[n])) return false;
  return true;
}

}  // namespace

namespace {

// Room to answer every pair in waves (with a pool only: one thread answers them in order),
// and to mark each pair's detection, for as many pairs as the broad phase holds.
void size_pair_answers(StepMemory& memory) {
  const std::size_t pairs = memory.pairs.size();
  memory.pair_hit.resize(pairs);
  memory.pair_contacts.resize(pairs + 1);
  memory.cell_pair_keys.resize(pairs);
  memory.edge_crossings.resize(2 * pairs);
  if (!memory.pool || memory.pool->threads() < 2) return;
  memory.pair_wave.resize(pairs);
  memory.pair_turn.resize(pairs);
  memory.wave_pairs.resize(pairs);
  memory.wave_begin.resize(pairs + 1);
}

void size_narrow_memory(const Model& model, NarrowMemory& s) {
  const std::size_t boxes = largest_box_set(model);
  for (int axis = 0; axis < 3; ++axis) {
    s.surface_lo[axis].resize(boxes);
    s.surface_hi[axis].resize(boxes);
  }
  if (model.collides) {
    s.object_wave.resize(model.objects.size());
    s.object_turn.resize(model.objects.size());
    s.object_answered.resize(model.objects.size());
  }
  s.x_start.assign(model.node_count(), Vec3::Zero());  // (Eigen leaves a resized Vec3 unset)
  std::size_t most_triangles = 0;
  for (Index c = 0; c + 1 < model.cell_triangle_begin.size(); ++c)
    most_triangles = std::max<std::size_t>(most_triangles, model.cell_triangle_begin[c + 1] - model.cell_triangle_begin[c]);
  for (Index c = 0; c + 1 < model.cell_owned_triangle_begin.size(); ++c)
    most_triangles = std::max<std::size_t>(most_triangles,
                                           model.cell_owned_triangle_begin[c + 1] - model.cell_owned_triangle_begin[c]);
  s.triangle_corners.resize(3 * most_triangles);
  s.triangle_min.resize(most_triangles);
  s.triangle_max.resize(most_triangles);
  for (int k = 0; k < 3; ++k) {
    s.triangle_lo[k].resize(most_triangles);
    s.triangle_hi[k].resize(most_triangles);
  }
  std::size_t most_edges = 0;
  for (Index c = 0; c + 1 < model.cell_edge_begin.size(); ++c)
    most_edges = std::max<std::size_t>(most_edges, model.cell_edge_begin[c + 1] - model.cell_edge_begin[c]);
  for (Index c = 0; c + 1 < model.cell_owned_edge_begin.size(); ++c)
    most_edges = std::max<std::size_t>(most_edges, model.cell_owned_edge_begin[c + 1] - model.cell_owned_edge_begin[c]);
  s.triangle_near.resize(most_triangles);
  s.edge_tests.resize(most_triangles, most_edges);
  s.edge_cell_in_pair.assign(model.cell_count(), 0);
  OwnedSurfaceCache& owned = s.owned_cache;
  owned.corners.resize(3 * model.cell_owned_triangles.size());
  owned.face.resize(model.cell_owned_triangles.size());
  for (int axis = 0; axis < 3; ++axis) {
    owned.triangle_lo[axis].resize(model.cell_owned_triangles.size());
    owned.triangle_hi[axis].resize(model.cell_owned_triangles.size());
    owned.edge_lo[axis].resize(model.cell_owned_edges.size());
    owned.edge_hi[axis].resize(model.cell_owned_edges.size());
  }
  for (std::vector<Vec3>* v : {&owned.triangles_lo, &owned.triangles_hi, &owned.edges_lo, &owned.edges_hi})
    v->resize(model.cell_count());
  owned.finite.assign(model.cell_count(), 0);
  owned.stamp.assign(model.cell_count(), 0);
  s.surface_x.resize(model.surface_vertex_cell.size());
  s.surface_cell_fresh.assign(model.cell_count(), 0);
  s.cell_vertex_min.resize(model.cell_count());
  s.cell_vertex_max.resize(model.cell_count());
  s.cell_triangle_min.resize(model.cell_count());
  s.cell_triangle_max.resize(model.cell_count());
  s.cell_triangle_stamp.assign(model.cell_count(), 0);
  s.surface_changed.assign(model.cell_count(), 0);
}

// The arrays with an entry per contact constraint, sized to the constraints' room.
void size_per_constraint(SolverMemory& s) {
  s.next_anchors.resize(s.constraints.size());
  s.friction_contacts.resize(s.constraints.size());
  s.edge_sources.resize(s.constraints.size());
  s.next_edge_holds.resize(s.constraints.size());
  s.crossing_keys.resize(s.constraints.size());
  s.edge_order.resize(s.constraints.size());
  s.edge_dropped.resize(s.constraints.size());
}

void size_solver_memory(const Model& model, SolverMemory& s) {
  s.constraints.resize(std::max<std::size_t>(4096, 4 * largest_box_set(model)));
  size_per_constraint(s);
  s.object_solving.assign(model.objects.size(), 0);
  s.object_motion.resize(model.objects.size());
  s.node_stamp.assign(model.node_count(), 0);
  s.contact_shares.resize(1);
  s.box_planes.resize(largest_box_set(model));
  s.box_planes_mark.assign(largest_box_set(model), 0);
  s.planned_boxes.resize(largest_box_set(model));
}

}  // namespace

Scratch::Scratch() = default;
Scratch::Scratch(std::unique_ptr<StepMemory> memory) : memory_(std::move(memory)) {}
Scratch::Scratch(Scratch&&) noexcept = default;
Scratch& Scratch::operator=(Scratch&&) noexcept = default;
Scratch::~Scratch() = default;

std::span<const Contact> Scratch::contacts() const {
  return {memory_->contacts.data(), memory_->contact_count};
}

std::span<const std::array<Vec3, 9>> Scratch::box_nodes() const { return memory_->box_nodes; }

Scratch make_scratch(const Model& model) {
  auto memory = std::make_unique<StepMemory>();
  // Room for the largest box set of any accuracy level (level 4 has several boxes a cell).
  size_box_memory(model, *memory);
  size_broad_phase_memory(model, *memory, 1);
  size_narrow_memory(model, *memory);
  size_pair_answers(*memory);
  memory->contacts.resize(kContactCapacity);
  size_dynamics_memory(model, *memory);
  size_solver_memory(model, *memory);
  return Scratch(std::move(memory));
}

void attach_pool(const Model& model, Scratch& scratch, WorkerPool& pool) {
  StepMemory& memory = scratch.memory();
  memory.pool = &pool;
  if (!model.collides) return;
  memory.contact_shares.resize(static_cast<std::size_t>(pool.threads()));
  const std::size_t threads = static_cast<std::size_t>(pool.threads());
  size_broad_phase_memory(model, memory, threads);
  memory.narrow_workspaces.resize(threads);
  for (NarrowMemory::NarrowWorkspace& w : memory.narrow_workspaces) {
    w.contacts.resize(memory.contacts.size());
    w.edge_tests.resize(memory.triangle_near.size(), memory.edge_tests.edges.size());
  }
  size_pair_answers(memory);
}

void grow_scratch(const Model& model, Scratch& scratch, const StepReport& last) {
  StepMemory& memory = scratch.memory();
  // Contact constraints: twice the room, up to 64 per box of the largest set.
  if (last.constraints_overflow && memory.constraints.size() < 64 * largest_box_set(model) + 4096) {
    memory.constraints.resize(2 * memory.constraints.size());
    size_per_constraint(memory);
  }
  if (!last.hash_overflow || !model.collides) return;
  grow_broad_phase_memory(model, memory);
  size_pair_answers(memory);
}

void update_all_boxes(const Model& model, const State& state, Scratch& scratch) {
  StepMemory& memory = scratch.memory();
  update_boxes(model, *box_level(model, state.params.accuracy).boxes, state, memory, memory.pool);
}

void step(const Model& model, State& state, Scratch& whole, StepReport& report) {
  StepMemory& scratch = whole.memory();
  report = StepReport{};
  report.step = state.step;
  report.stage_ns.fill(-1);
  const std::int64_t start = now_ns();
  const bool friction = has(model.settings.effects, Effect::Friction);
  const BoxLevel level = box_level(model, state.params.accuracy);
  scratch.contact_count = 0;
  scratch.contacts_dropped = 0;
  // The response "solver" needs its stage; a scene without contacts has nothing to answer.
  const bool solver = state.params.response == ContactResponse::Solver &&
                      std::find(model.pipeline.begin(), model.pipeline.end(), Stage::ContactSolve) != model.pipeline.end();
  // The exact edge contacts (BoxLevel::edges) read where the step started; under the solver
  // they are constraints (BoxLevel::solver_edges), and so are level 5's vertex contacts where
  // its edges are (without, they are answered at once, as under the paper's response:
  // BoxLevel::vertex_contacts_at_once).
  const bool exact_edges = level.edges && state.params.response == ContactResponse::Paper;
  const bool solver_edges = level.solver_edges && solver;
  if (exact_edges || solver_edges)
    std::copy(state.x.begin(), state.x.end(), scratch.x_start.begin());
  if (!solver) state.anchor_count = 0;  // the solver's friction anchors (contact_solver.cpp) lapse
  if (scratch.pool) scratch.pool->begin_step();
  // Where the exact edges answer (levels 4 and 5, and 0-3 with edge_contacts; the paper's
  // response) the planes answer before the surfaces, so that the last word of a step is the
  // contacts between objects: answered after them, a floor lifting a resting object pushed
  // it back into the one on top, which the narrow phase had just parted from it, and the two
  // stayed crossed edge through edge (docs/notes/2026-11-28-code-findings.md#planes-first).
  // What the objects' pushes leave below a plane, it answers next step.
  std::array<Stage, kStageCount> order{};
  std::size_t stage_count = 0;
  const bool planes_first = exact_edges && !solver;
  // Answered first, the planes would otherwise take back next step what the objects' pushes
  // put into them (collision.cpp, plane_holds). Levels 0-3 only: levels 4 and 5 rest clean
  // without it, and did worse with it (docs/notes/2026-11-28-code-findings.md#plane-hold).
  scratch.planes_hold = planes_first && !level.exact && level.boxes != &model.sub_boxes;
  for (Stage stage : model.pipeline) {
    if (planes_first && stage == Stage::Planes) continue;
    if (planes_first && stage == Stage::NarrowPhase &&
        std::find(model.pipeline.begin(), model.pipeline.end(), Stage::Planes) != model.pipeline.end())
      order[stage_count++] = Stage::Planes;
    order[stage_count++] = stage;
  }
  for (std::size_t i = 0; i < stage_count; ++i) {
    const Stage stage = order[i];
    if (stage == Stage::ContactSolve && !solver) continue;  // not run: its time stays -1
    const std::int64_t t0 = now_ns();
    StageCounters& counters = report.counters[static_cast<std::size_t>(stage)];
    switch (stage) {
      case Stage::Gravity: apply_gravity(model, state); break;
      case Stage::Dynamics:
        if (solver) begin_solver_step(model, state, scratch);  // the prediction; the solve comes last
        else integrate_dynamics(model, state, scratch, scratch.pool);
        break;
      case Stage::BoxUpdate:
        update_boxes(model, *level.boxes, state, scratch, scratch.pool);
        counters.boxes_updated = static_cast<std::uint32_t>(level.boxes->size());
        break;
      case Stage::BroadPhase: {
        // The exact level pairs cells whose boxes come within its contact radius.
        // The paper's response: boxes of two objects come within the level's skin.
        const double margin = level.exact ? model.surface_contact_radius : solver ? kSpeculativeDistance : level.skin;
        if (sleeping(model)) set_wake_margins(model, *level.boxes, state, scratch);
        grow_box_bounds(model, *level.boxes, margin, scratch, scratch);
        report.hash_overflow = !find_candidate_pairs(model, level, scratch, scratch, scratch.pool, counters);
        break;
      }
      case Stage::NarrowPhase: {
        double& depth = report.max_box_penetration_m;
        if (solver && !level.vertex_contacts_at_once()) {
          if (level.exact) find_vertex_constraints(model, state, scratch, counters, depth);
          else find_box_contacts(model, level, state, scratch, counters, depth);
          if (solver_edges) {
            find_edge_contacts(model, level, state, scratch, counters, depth);
            // Its own pairs may overflow: grown between steps.
            if (scratch.pairs_dropped) report.hash_overflow = true;
          }
        } else if (level.exact) {
          // Answered at once (without the solver's edge contacts also under the solver).
          if (friction) collide_surfaces<true>(model, state, scratch, counters, depth);
          else collide_surfaces<false>(model, state, scratch, counters, depth);
        } else {
          if (friction) collide_boxes<true>(model, level, state, scratch, counters, depth);
          else collide_boxes<false>(model, level, state, scratch, counters, depth);
          // The edge contacts' own pairs may overflow too: grown between steps.
          if (scratch.pairs_dropped) report.hash_overflow = true;
        }
        break;
      }
      case Stage::Planes:
        if (solver) find_plane_contacts(model, level, state, scratch, counters, report.max_box_penetration_m);
        else if (friction) collide_planes<true>(model, level, state, scratch, counters, report.max_box_penetration_m);
        else collide_planes<false>(model, level, state, scratch, counters, report.max_box_penetration_m);
        break;
      case Stage::Interaction:
        if (!solver) interact(model, *level.boxes, state, scratch, counters, report.max_box_penetration_m);
        else if (has(model.settings.effects, Effect::Probe))
          find_probe_contacts(model, *level.boxes, state, scratch, counters, report.max_box_penetration_m);
        break;  // the grab is solved with the contacts
      case Stage::ContactSolve:
        solve_contacts(model, state, scratch);
        report.constraints = static_cast<std::uint32_t>(scratch.constraint_count);
        report.constraints_overflow = scratch.constraints_dropped;
        break;
      case Stage::Sleep: counters.objects_asleep = update_sleep(model, state); break;
      case Stage::Count: break;
    }
    report.stage_ns[static_cast<std::size_t>(stage)] = now_ns() - t0;
  }
  if (scratch.pool) scratch.pool->end_step(0);
  report.finite = all_finite(state) && is_finite(state.probe.x) && is_finite(state.probe.v);
  report.contacts_recorded = scratch.contact_count;
  report.contacts_dropped = scratch.contacts_dropped;
  ++state.step;
  report.total_ns = now_ns() - start;
}

double time_spring_sweeps(const Model& model, const State& state, int sweeps) {
  State copy = state;
  DynamicsMemory memory;
  size_dynamics_memory(model, memory);
  predict_dynamics(model, copy, memory, nullptr);
  const auto start = std::chrono::steady_clock::now();
  for (int sweep = 0; sweep < sweeps; ++sweep) sweep_springs(model, 0, 1, memory, nullptr);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace ffd
