// One fixed step: the stages of the Model's pipeline, timed and counted. No allocation, no
// locking, no I/O, no logging in here: every buffer comes from Scratch.
#include "ffd/step.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include "dynamics.h"
#include "ffd/worker_pool.h"
#include "collision.h"
#include "contact_solver.h"
#include "interaction.h"
#include "sleep.h"

namespace ffd {

namespace {

std::size_t largest_box_set(const Model& model) {
  return std::max({model.boxes.size(), model.grid_boxes.size(), model.sub_boxes.size()});
}

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

void make_workspace(const Model& model, Scratch::PairWorkspace& w) {
  const std::size_t boxes = largest_box_set(model);
  w.box_list_a.resize(boxes);
  w.box_list_b.resize(boxes);
  w.box_range.resize(boxes);
  w.grid_begin.resize(kBroadPhaseGridCells + 1);
  w.grid_cursor.resize(kBroadPhaseGridCells + 1);
  w.grid_entries.resize(8 * boxes + 64);
  for (std::vector<int>& c : w.cell_lattice) c.resize(boxes);
  w.cell_far.resize(boxes);
  w.pairs.resize(8 * boxes + 64);
}

// Room to answer every pair in waves (with a pool only: one thread answers them in order).
void size_waves(Scratch& scratch) {
  if (!scratch.pool || scratch.pool->threads() < 2) return;
  scratch.pair_wave.resize(scratch.pairs.size());
  scratch.pair_turn.resize(scratch.pairs.size());
  scratch.wave_pairs.resize(scratch.pairs.size());
  scratch.wave_begin.resize(scratch.pairs.size() + 1);
}

}  // namespace

Scratch make_scratch(const Model& model) {
  Scratch s;
  // Room for the largest box set of any accuracy level (level 4 has several boxes a cell).
  const std::size_t boxes = largest_box_set(model);
  s.box_nodes.resize(boxes);
  s.box_valid.assign(boxes, 0);
  s.box_moved.assign(boxes, 0);
  for (int axis = 0; axis < 3; ++axis) {
    s.box_lo[axis].resize(boxes);
    s.box_hi[axis].resize(boxes);
    s.surface_lo[axis].resize(boxes);
    s.surface_hi[axis].resize(boxes);
  }
  if (sleeping(model)) s.box_wake_margin.assign(boxes, 0.0);
  if (model.collides) {
    s.object_lo.resize(model.objects.size());
    s.object_hi.resize(model.objects.size());
    s.object_order.resize(model.objects.size());
    s.pair_tasks.resize(32 * model.objects.size() + 64);
    s.pair_workspaces.resize(1);
    make_workspace(model, s.pair_workspaces[0]);
    s.pairs.resize(8 * boxes + 64);
    s.pair_hit.resize(s.pairs.size());
    s.pair_keys.resize(s.pairs.size());
    s.pair_sorted_keys.resize(s.pairs.size());
    s.cell_pair_keys.resize(s.pairs.size());
    s.object_wave.resize(model.objects.size());
    s.object_turn.resize(model.objects.size());
    s.object_answered.resize(model.objects.size());
  }
  s.x_prev.resize(model.node_count());
  s.x_start.assign(model.node_count(), Vec3::Zero());  // (Eigen leaves a resized Vec3 unset)
  s.node_stamp.assign(model.node_count(), 0);
  s.lambda.resize(model.springs.size());
  s.tetrahedron_lambda.resize(model.tetrahedra.size());
  s.cell_shape_lambda.resize(model.cell_count());
  s.cell_rotation_matrix.resize(model.cell_count());
  s.spring_inv_denominator.resize(model.springs.size());
  s.denominator_stiffness.assign(model.objects.size(), 0.0);  // 0: not computed yet
  s.object_work.resize(model.objects.size());
  for (std::size_t i = 0; i < model.objects.size(); ++i) {
    const ObjectModel& o = model.objects[i];
    if (o.dynamics == DynamicsKind::MassSpring) {
      double projections = static_cast<double>(o.spring_end - o.spring_begin);
      // A cell's shape projection costs about 8 springs' (its rotation, its 8 nodes).
      if (o.mass_spring.shape_stiffness > 0.0) projections += 8.0 * (o.cell_end - o.cell_begin);
      s.object_work[i] = projections * o.mass_spring.iterations;
    } else {
      s.object_work[i] = o.region_begin == o.region_end ? 0.0
                                                        : static_cast<double>(model.regions[o.region_end - 1].member_end -
                                                                              model.regions[o.region_begin].member_begin);
    }
  }
  s.objects_by_work.resize(model.objects.size());
  std::iota(s.objects_by_work.begin(), s.objects_by_work.end(), Index{0});
  std::stable_sort(s.objects_by_work.begin(), s.objects_by_work.end(),
                   [&](Index a, Index b) { return s.object_work[a] > s.object_work[b]; });
  s.object_tasks.resize(model.objects.size());
  s.goal_sum.resize(model.regions.empty() ? 0 : model.node_count());
  s.contacts.resize(kContactCapacity);
  s.constraints.resize(std::max<std::size_t>(4096, 4 * boxes));
  s.next_anchors.resize(s.constraints.size());
  s.friction_contacts.resize(s.constraints.size());
  s.object_solving.assign(model.objects.size(), 0);
  s.object_motion.resize(model.objects.size());
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
  s.triangle_near.resize(most_triangles);
  s.surface_x.resize(model.surface_vertex_cell.size());
  s.surface_cell_fresh.assign(model.cell_count(), 0);
  s.cell_vertex_min.resize(model.cell_count());
  s.cell_vertex_max.resize(model.cell_count());
  s.cell_triangle_min.resize(model.cell_count());
  s.cell_triangle_max.resize(model.cell_count());
  s.cell_triangle_stamp.assign(model.cell_count(), 0);
  s.surface_changed.assign(model.cell_count(), 0);
  return s;
}

void attach_pool(const Model& model, Scratch& scratch, WorkerPool& pool) {
  scratch.pool = &pool;
  if (!model.collides) return;
  const std::size_t threads = static_cast<std::size_t>(pool.threads());
  while (scratch.pair_workspaces.size() < threads) {
    scratch.pair_workspaces.emplace_back();
    make_workspace(model, scratch.pair_workspaces.back());
    // As much room as the first workspace has grown to.
    scratch.pair_workspaces.back().grid_entries.resize(scratch.pair_workspaces[0].grid_entries.size());
    scratch.pair_workspaces.back().pairs.resize(scratch.pair_workspaces[0].pairs.size());
  }
  scratch.narrow_workspaces.resize(threads);
  for (Scratch::NarrowWorkspace& w : scratch.narrow_workspaces) w.contacts.resize(scratch.contacts.size());
  size_waves(scratch);
}

void grow_scratch(const Model& model, Scratch& scratch, const StepReport& last) {
  // Contact constraints: twice the room, up to 64 per box of the largest set.
  if (last.constraints_overflow && scratch.constraints.size() < 64 * largest_box_set(model) + 4096) {
    scratch.constraints.resize(2 * scratch.constraints.size());
    scratch.next_anchors.resize(scratch.constraints.size());
    scratch.friction_contacts.resize(scratch.constraints.size());
  }
  if (!last.hash_overflow || !model.collides) return;
  // Boxes stretched over hundreds of grid cells, or millions of pairs, mean a blown-up scene,
  // not a large one: stop growing there and keep reporting the overflow.
  const std::size_t boxes = largest_box_set(model);
  const std::size_t entry_limit = 512 * (8 * boxes + 64), pair_limit = 256 * (4 * boxes + 64);
  auto grow = [](auto& v, std::size_t limit) {
    if (v.size() < limit) v.resize(std::min(limit, 2 * v.size()));
  };
  for (Scratch::PairWorkspace& w : scratch.pair_workspaces) {
    grow(w.grid_entries, entry_limit);
    grow(w.pairs, pair_limit);
  }
  grow(scratch.pair_tasks, 256 * (32 * model.objects.size() + 64));
  grow(scratch.pairs, pair_limit);
  scratch.pair_hit.resize(scratch.pairs.size());
  scratch.pair_keys.resize(scratch.pairs.size());
  scratch.pair_sorted_keys.resize(scratch.pairs.size());
  scratch.cell_pair_keys.resize(scratch.pairs.size());
  size_waves(scratch);
}

void update_all_boxes(const Model& model, const State& state, Scratch& scratch) {
  update_boxes(model, *box_level(model, state.params.accuracy).boxes, state, scratch);
}

void step(const Model& model, State& state, Scratch& scratch, StepReport& report) {
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
  // The exact edge contacts (BoxLevel::edges; the paper's response only) read where the step
  // started.
  const bool exact_edges = level.edges && state.params.response == ContactResponse::Paper;
  if (exact_edges)
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
        else integrate_dynamics(model, state, scratch);
        break;
      case Stage::BoxUpdate:
        update_boxes(model, *level.boxes, state, scratch);
        counters.boxes_updated = static_cast<std::uint32_t>(level.boxes->size());
        break;
      case Stage::BroadPhase: {
        // The exact level pairs cells whose boxes come within its contact radius.
        // The paper's response: boxes of two objects come within the level's skin.
        const double margin = level.exact ? model.surface_contact_radius : solver ? kSpeculativeDistance : level.skin;
        if (sleeping(model)) set_wake_margins(model, *level.boxes, state, scratch);
        grow_box_bounds(model, *level.boxes, margin, scratch);
        report.hash_overflow = !find_candidate_pairs(model, level, state, scratch, counters);
        break;
      }
      case Stage::NarrowPhase: {
        double& depth = report.max_box_penetration_m;
        if (solver && !level.exact) {
          find_box_contacts(model, level, state, scratch, counters, depth);
        } else if (level.exact) {
          // The exact level answers its vertex contacts at once under either response (its
          // points lie on triangles of other cells: docs/limits.md).
          if (friction) collide_surfaces<true>(model, state, scratch, counters, depth);
          else collide_surfaces<false>(model, state, scratch, counters, depth);
        } else {
          if (friction) collide_boxes<true>(model, level, state, scratch, counters, depth);
          else collide_boxes<false>(model, level, state, scratch, counters, depth);
          // The edge contacts' own pairs (levels 0-3) may overflow too: grown between steps.
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

}  // namespace ffd
