#pragma once
// Commands: the only way anything outside the physics thread changes a running simulation.
// Each names the step at whose start it takes effect, so a run is a pure function of the
// scene and the command stream (see docs/realtime.md, "The physics loop").
#include <cstdint>

#include "ffd/model.h"
#include "ffd/state.h"

namespace ffd {

enum class CommandKind : std::uint8_t {
  // State commands: they change the State and are part of what a recording replays.
  ProbePose,     // vector: device position (m)
  Grab,          // cell + local: the picked point; its target starts where the point is now
  Drag,          // vector: new target of the grabbed point (m)
  Release,       // let go of the grabbed point
  SetAlpha,      // value: collision damping, eq. 8, [0, 1]
  SetBeta,       // value: friction, eq. 8, [0, 1]
  SetGravity,    // vector: m/s^2
  SetStiffness,  // object + value: N/m (mass_spring) or pull fraction in (0, 1] (shape_matching)
  SetProbeStiffness,  // value: virtual coupling stiffness of the probe, N/m (>= 0)
  SetAccuracy,   // value: collision accuracy level 0..5 (spec.h, Accuracy)
  SetResponse,   // value: contact response 0 = paper, 1 = solver (spec.h, ContactResponse)
  Reset,         // back to the scene's initial State (the step index keeps counting)
  // Loop commands: they steer the physics loop and leave the State alone.
  SetBudget,     // value: latency budget, microseconds (> 0)
  Pause,         // value: ticks to stay paused, 0 = until Resume
  Resume,
  SingleStep,    // while paused: take one step
  AutoAccuracy,  // value: 1 = budget-aware accuracy on (from the current level up), 0 = off.
                 // Not itself recorded: the SetAccuracy commands it makes are.
};
const char* command_name(CommandKind kind);

// Apply at the start of the next step the loop takes (interactive input).
inline constexpr std::uint64_t kNextStep = ~std::uint64_t{0};

struct Command {
  std::uint64_t step = kNextStep;  // takes effect when State::step == step
  CommandKind kind = CommandKind::Resume;
  Index object = kNoIndex;    // SetStiffness
  Index cell = kNoIndex;      // Grab: global cell index
  Vec3 vector = Vec3::Zero();
  Vec3 local = Vec3::Zero();  // Grab: (s, t, u) in [0, 1]^3
  double value = 0.0;
};

inline bool is_state_command(CommandKind kind) { return kind <= CommandKind::Reset; }

// Whether `command` is well formed for `model` (finite numbers, indices in range, values in
// their intervals). The loop drops and counts commands that are not: bad input never
// reaches the State.
bool command_is_valid(const Model& model, const Command& command);

// Applies a valid state command. `initial` is the State Reset returns to. No allocation.
void apply_command(const Model& model, const State& initial, State& state, const Command& command);

}  // namespace ffd
