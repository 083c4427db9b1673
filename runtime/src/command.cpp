#include "ffd/command.h"

#include <cmath>

#include "ffd/trilinear.h"
#include "sleep.h"

namespace ffd {

const char* command_name(CommandKind kind) {
  switch (kind) {
    case CommandKind::ProbePose: return "probe";
    case CommandKind::Grab: return "grab";
    case CommandKind::Drag: return "drag";
    case CommandKind::Release: return "release";
    case CommandKind::SetAlpha: return "alpha";
    case CommandKind::SetBeta: return "beta";
    case CommandKind::SetGravity: return "gravity";
    case CommandKind::SetStiffness: return "stiffness";
    case CommandKind::SetProbeStiffness: return "probe_stiffness";
    case CommandKind::SetAccuracy: return "accuracy";
    case CommandKind::SetResponse: return "response";
    case CommandKind::Reset: return "reset";
    case CommandKind::SetBudget: return "budget";
    case CommandKind::AutoAccuracy: return "auto_accuracy";
    case CommandKind::Pause: return "pause";
    case CommandKind::Resume: return "resume";
    case CommandKind::SingleStep: return "single_step";
  }
  return "?";
}

namespace {
// isfinite first: an ordered comparison with NaN raises FE_INVALID.
bool in_unit_interval(double v) { return std::isfinite(v) && v >= 0.0 && v <= 1.0; }
}  // namespace

bool command_is_valid(const Model& model, const Command& c) {
  switch (c.kind) {
    case CommandKind::ProbePose: return has(model.settings.effects, Effect::Probe) && is_finite(c.vector);
    case CommandKind::Grab:
      return has(model.settings.effects, Effect::Grab) && c.cell < model.cell_count() &&
             in_unit_interval(c.local.x()) && in_unit_interval(c.local.y()) && in_unit_interval(c.local.z());
    case CommandKind::Drag: return has(model.settings.effects, Effect::Grab) && is_finite(c.vector);
    case CommandKind::Release: return has(model.settings.effects, Effect::Grab);
    case CommandKind::SetAlpha:
    case CommandKind::SetBeta: return in_unit_interval(c.value);
    case CommandKind::SetGravity: return is_finite(c.vector);
    case CommandKind::SetStiffness: {
      if (c.object >= model.objects.size() || !std::isfinite(c.value) || !(c.value > 0.0)) return false;
      return model.objects[c.object].dynamics == DynamicsKind::MassSpring || c.value <= 1.0;
    }
    case CommandKind::SetProbeStiffness:
      return has(model.settings.effects, Effect::Probe) && std::isfinite(c.value) && c.value >= 0.0;
    case CommandKind::SetAccuracy:
      return std::isfinite(c.value) && c.value >= 0.0 && c.value < kAccuracyLevels && c.value == std::floor(c.value);
    case CommandKind::SetResponse: return c.value == 0.0 || c.value == 1.0;
    case CommandKind::SetBudget: return std::isfinite(c.value) && c.value > 0.0;
    case CommandKind::Pause: return std::isfinite(c.value) && c.value >= 0.0;
    case CommandKind::AutoAccuracy: return c.value == 0.0 || c.value == 1.0;
    case CommandKind::Reset:
    case CommandKind::Resume:
    case CommandKind::SingleStep: return true;
  }
  return false;
}

void apply_command(const Model& model, const State& initial, State& state, const Command& c) {
  switch (c.kind) {
    case CommandKind::ProbePose: state.probe.device = c.vector; break;
    case CommandKind::Grab: {
      // The target starts at the point itself, so grabbing never yanks; Drag moves it.
      state.grab.active = true;
      state.grab.cell = c.cell;
      state.grab.local = c.local;
      const std::array<Index, 8>& corners = model.cell_nodes[c.cell];
      state.grab.target = trilinear_map(c.local, [&](int j) -> const Vec3& { return state.x[corners[j]]; });
      break;
    }
    case CommandKind::Drag: state.grab.target = c.vector; break;
    case CommandKind::Release:
      state.grab.active = false;
      state.grab.force = Vec3::Zero();
      break;
    case CommandKind::SetAlpha: state.params.alpha = c.value; break;
    case CommandKind::SetBeta: state.params.beta = c.value; break;
    // Changing the physics of an object asleep wakes it (sleep.h).
    case CommandKind::SetGravity:
      state.params.gravity = c.vector;
      wake_all(state);
      break;
    case CommandKind::SetStiffness:
      state.params.stiffness[c.object] = c.value;
      wake(state, c.object);
      break;
    case CommandKind::SetProbeStiffness: state.params.probe_stiffness = c.value; break;
    case CommandKind::SetAccuracy: state.params.accuracy = static_cast<Accuracy>(static_cast<int>(c.value)); break;
    case CommandKind::SetResponse:
      state.params.response = static_cast<ContactResponse>(static_cast<int>(c.value));
      wake_all(state);  // contacts that held a sleeper are answered another way now
      break;
    case CommandKind::Reset: {
      // Element-wise copies into vectors of the same size: no allocation.
      const std::uint64_t step = state.step;
      state.params.gravity = initial.params.gravity;
      state.params.alpha = initial.params.alpha;
      state.params.beta = initial.params.beta;
      state.params.probe_stiffness = initial.params.probe_stiffness;
      state.params.accuracy = initial.params.accuracy;
      state.params.response = initial.params.response;
      std::copy(initial.params.stiffness.begin(), initial.params.stiffness.end(), state.params.stiffness.begin());
      std::copy(initial.x.begin(), initial.x.end(), state.x.begin());
      std::copy(initial.v.begin(), initial.v.end(), state.v.begin());
      std::copy(initial.region_rotation.begin(), initial.region_rotation.end(), state.region_rotation.begin());
      std::copy(initial.cell_rotation.begin(), initial.cell_rotation.end(), state.cell_rotation.begin());
      std::copy(initial.cell_shape_force.begin(), initial.cell_shape_force.end(), state.cell_shape_force.begin());
      std::copy(initial.spring_force.begin(), initial.spring_force.end(), state.spring_force.begin());
      std::copy(initial.volume_pressure.begin(), initial.volume_pressure.end(), state.volume_pressure.begin());
      std::copy(initial.asleep.begin(), initial.asleep.end(), state.asleep.begin());
      std::copy(initial.still_steps.begin(), initial.still_steps.end(), state.still_steps.begin());
      std::copy(initial.moving.begin(), initial.moving.end(), state.moving.begin());
      std::copy(initial.rest_anchor.begin(), initial.rest_anchor.end(), state.rest_anchor.begin());
      std::copy(initial.anchors.begin(), initial.anchors.begin() + static_cast<std::ptrdiff_t>(initial.anchor_count),
                state.anchors.begin());
      state.anchor_count = initial.anchor_count;
      std::copy(initial.edge_holds.begin(),
                initial.edge_holds.begin() + static_cast<std::ptrdiff_t>(initial.edge_hold_count), state.edge_holds.begin());
      state.edge_hold_count = initial.edge_hold_count;
      state.probe = initial.probe;
      state.grab = initial.grab;
      state.step = step;
      break;
    }
    default: break;  // loop commands: handled by the physics loop
  }
}

}  // namespace ffd
