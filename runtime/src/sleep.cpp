#include "sleep.h"

namespace ffd {

void wake(State& state, Index object) {
  if (!state.asleep[object]) return;
  state.asleep[object] = 0;
  state.still_steps[object] = 1;
}

void wake_all(State& state) {
  for (Index o = 0; o < state.asleep.size(); ++o) wake(state, o);
}

void meet(State& state, Index object_a, Index object_b) {
  if (state.asleep[object_a] && state.moving[object_b]) wake(state, object_a);
  if (state.asleep[object_b] && state.moving[object_a]) wake(state, object_b);
}

void set_wake_margins(const Model& model, const BoxSet& boxes, const State& state, BoxMemory& memory) {
  const double reach = 2.0 * model.settings.sleep_radius;
  for (Index b = 0; b < boxes.size(); ++b) {
    const Index o = model.cell_object[boxes.box_cell[b]];
    memory.box_wake_margin[b] = state.moving[o] ? reach : 0.0;
  }
}

std::uint32_t update_sleep(const Model& model, State& state) {
  const std::uint32_t sleep_steps = model.sleep_steps;
  std::uint32_t asleep = 0;
  for (Index o = 0; o < model.objects.size(); ++o) {
    if (state.asleep[o]) {
      ++asleep;
      continue;
    }
    const ObjectModel& object = model.objects[o];
    const Vec3 centre = centre_of_mass(model, state.x, o);
    if (!((centre - state.rest_anchor[o]).norm() <= model.settings.sleep_radius)) {
      // Fast enough to wake others: it left the anchor within half of sleep_time, faster than
      // 2 sleep_radius / sleep_time (about 13 mm/s at the defaults). Slower drift in a trembling pile
      // would otherwise wake the neighbours, and theirs, and keep a pile from ever sleeping.
      state.moving[o] = state.still_steps[o] < sleep_steps / 2;
      state.rest_anchor[o] = centre;
      state.still_steps[o] = 0;
      continue;
    }
    state.moving[o] = 0;
    if (++state.still_steps[o] < sleep_steps) continue;
    state.asleep[o] = 1;
    ++asleep;
    for (Index n = object.node_begin; n < object.node_end; ++n) state.v[n] = Vec3::Zero();
  }
  return asleep;
}

}  // namespace ffd
