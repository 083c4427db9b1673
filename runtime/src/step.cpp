// One fixed step: the stages of the Model's pipeline, timed and counted. No allocation, no
// locking, no I/O, no logging in here: every buffer comes from Scratch.
#include "ffd/step.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "dynamics.h"
#include "collision.h"
#include "interaction.h"

namespace ffd {

namespace {

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

void apply_gravity(const Model& model, State& state) {
  const Vec3 dv = state.params.gravity * model.settings.dt;
  for (std::size_t n = 0; n < state.v.size(); ++n) state.v[n] += dv;
}

bool all_finite(const State& state) {
  for (std::size_t n = 0; n < state.x.size(); ++n)
    if (!is_finite(state.x[n]) || !is_finite(state.v[n])) return false;
  return true;
}

}  // namespace

Scratch make_scratch(const Model& model) {
  Scratch s;
  s.box_nodes.resize(model.box_count());
  s.box_valid.assign(model.box_count(), 0);
  s.box_min.resize(model.box_count());
  s.box_max.resize(model.box_count());
  if (model.hash_table_size > 0) {
    s.bucket_begin.assign(model.hash_table_size + 1, 0);
    // A box no larger than a hash cell touches at most 8 of them.
    const std::size_t capacity = 8 * model.box_count() + 64;
    s.entries.resize(capacity);
    s.entries_unsorted.resize(capacity);
    s.entry_bucket.resize(capacity);
  }
  s.x_prev.resize(model.node_count());
  s.lambda.resize(model.springs.size());
  s.spring_inv_denominator.resize(model.springs.size());
  s.denominator_stiffness.assign(model.objects.size(), 0.0);  // 0: not computed yet
  s.goal_sum.resize(model.regions.empty() ? 0 : model.node_count());
  s.contacts.resize(kContactCapacity);
  return s;
}

void grow_scratch(const Model& model, Scratch& scratch, const StepReport& last) {
  if (!last.hash_overflow || model.hash_table_size == 0) return;
  // Boxes stretched over hundreds of hash cells mean a blown-up scene, not a large one:
  // stop growing there and keep reporting the overflow.
  const std::size_t limit = 512 * (8 * model.box_count() + 64);
  if (scratch.entries.size() >= limit) return;
  const std::size_t capacity = std::min(limit, 2 * scratch.entries.size());
  scratch.entries.resize(capacity);
  scratch.entries_unsorted.resize(capacity);
  scratch.entry_bucket.resize(capacity);
}

void update_all_boxes(const Model& model, const State& state, Scratch& scratch) {
  for (Index b = 0; b < model.box_count(); ++b) update_box(model, state, scratch, b);
}

void step(const Model& model, State& state, Scratch& scratch, StepReport& report) {
  report = StepReport{};
  report.step = state.step;
  report.stage_ns.fill(-1);
  const std::int64_t start = now_ns();
  const bool friction = has(model.settings.effects, Effect::Friction);
  scratch.contact_count = 0;
  scratch.contacts_dropped = 0;
  for (Stage stage : model.pipeline) {
    const std::int64_t t0 = now_ns();
    StageCounters& counters = report.counters[static_cast<std::size_t>(stage)];
    switch (stage) {
      case Stage::Gravity: apply_gravity(model, state); break;
      case Stage::Dynamics: integrate_dynamics(model, state, scratch); break;
      case Stage::BoxUpdate:
        update_all_boxes(model, state, scratch);
        counters.boxes_updated = static_cast<std::uint32_t>(model.box_count());
        break;
      case Stage::BroadPhase: report.hash_overflow = !build_spatial_hash(model, scratch, counters); break;
      case Stage::NarrowPhase:
        if (friction) collide_boxes<true>(model, state, scratch, counters, report.max_box_penetration_m);
        else collide_boxes<false>(model, state, scratch, counters, report.max_box_penetration_m);
        break;
      case Stage::Planes:
        if (friction) collide_planes<true>(model, state, scratch, counters, report.max_box_penetration_m);
        else collide_planes<false>(model, state, scratch, counters, report.max_box_penetration_m);
        break;
      case Stage::Interaction: interact(model, state, scratch, counters, report.max_box_penetration_m); break;
      case Stage::Count: break;
    }
    report.stage_ns[static_cast<std::size_t>(stage)] = now_ns() - t0;
  }
  report.finite = all_finite(state) && is_finite(state.probe.x) && is_finite(state.probe.v);
  report.contacts_recorded = scratch.contact_count;
  report.contacts_dropped = scratch.contacts_dropped;
  ++state.step;
  report.total_ns = now_ns() - start;
}

}  // namespace ffd
