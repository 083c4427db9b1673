// What each state command does to the State (the loop tests check when they apply).
#include <catch2/catch.hpp>

#include "ffd/command.h"
#include "ffd/measure.h"
#include "ffd/step.h"
#include "ffd/trilinear.h"
#include "support/test_scenes.h"

using namespace ffd;

namespace {

// One box resting on the floor, with probe and grab.
Model resting_box() {
  SceneSpec spec;
  spec.settings.effects =
      Effect::Gravity | Effect::Planes | Effect::Friction | Effect::Probe | Effect::Grab;
  spec.settings.probe.start = Vec3(0.0, 0.5, 0.0);
  spec.objects.push_back(test::box_object("box", Vec3(0.2, 0.1, 0.2), 0.05, Vec3(0.0, 0.051, 0.0)));
  spec.planes.push_back(test::floor_plane());
  return test::compile_quietly(spec);
}

Vec3 point_of(const Model& model, const State& state, Index cell, const Vec3& local) {
  const std::array<Index, 8>& corners = model.cell_nodes[cell];
  return trilinear_map(local, [&](int j) -> const Vec3& { return state.x[corners[j]]; });
}

void run(const Model& model, State& state, int steps) {
  Scratch scratch = make_scratch(model);
  StepReport report;
  for (int i = 0; i < steps; ++i) step(model, state, scratch, report);
}

Command command(CommandKind kind) {
  Command c;
  c.kind = kind;
  return c;
}

}  // namespace

TEST_CASE("Commands: a grab starts where the point is and a drag pulls it to the target") {
  const Model model = resting_box();
  const State initial = initial_state(model);
  State state = initial;
  run(model, state, 200);  // settled on the floor
  Command grab = command(CommandKind::Grab);
  grab.cell = model.objects[0].cell_begin;
  grab.local = Vec3(0.5, 0.5, 0.5);
  apply_command(model, initial, state, grab);
  const Vec3 start = point_of(model, state, grab.cell, grab.local);
  CHECK(state.grab.target == start);  // no jump
  Command drag = command(CommandKind::Drag);
  drag.vector = start + Vec3(0.0, 0.03, 0.0);
  apply_command(model, initial, state, drag);
  run(model, state, 500);
  const Vec3 end = point_of(model, state, grab.cell, grab.local);
  // The box weighs 9.8 N against a 200 N/m pull of at most 6 N at one bottom cell: the
  // point rises part of the way (without the grab it stays put on the floor).
  CHECK(end.y() > start.y() + 0.002);
  CHECK(end.y() < drag.vector.y());
  CHECK(state.grab.force.y() > 0.0);
  apply_command(model, initial, state, command(CommandKind::Release));
  CHECK_FALSE(state.grab.active);
  CHECK(state.grab.force == Vec3::Zero());
}

TEST_CASE("Commands: reset returns to the initial state but keeps the step count") {
  const Model model = resting_box();
  const State initial = initial_state(model);
  State state = initial;
  Command alpha = command(CommandKind::SetAlpha);
  alpha.value = 0.1;
  apply_command(model, initial, state, alpha);
  Command probe = command(CommandKind::ProbePose);
  probe.vector = Vec3(0.0, 0.2, 0.0);
  apply_command(model, initial, state, probe);
  run(model, state, 100);
  REQUIRE(state_hash(state) != state_hash(initial));
  apply_command(model, initial, state, command(CommandKind::Reset));
  CHECK(state.step == 100);
  CHECK(state_hash(state) == state_hash(initial));
  CHECK(state.params.alpha == initial.params.alpha);
  CHECK(state.probe.device == initial.probe.device);
}

TEST_CASE("Commands: stiffness changes the dynamics from the next step on") {
  const Model model = resting_box();
  const State initial = initial_state(model);
  State soft = initial, stiff = initial;
  Command c = command(CommandKind::SetStiffness);
  c.object = 0;
  c.value = 500.0;
  apply_command(model, initial, soft, c);
  CHECK(soft.params.stiffness[0] == 500.0);
  run(model, soft, 300);
  run(model, stiff, 300);
  // Under its own weight the soft box sags: more elastic energy stored.
  const double soft_sag = compute_energy(model, soft).elastic / 500.0;
  const double stiff_sag = compute_energy(model, stiff).elastic / initial.params.stiffness[0];
  CHECK(soft_sag > 4.0 * stiff_sag);
}

TEST_CASE("Commands: malformed ones are refused") {
  const Model model = resting_box();
  Command alpha = command(CommandKind::SetAlpha);
  alpha.value = 1.5;
  CHECK_FALSE(command_is_valid(model, alpha));
  alpha.value = 0.5;
  CHECK(command_is_valid(model, alpha));
  Command grab = command(CommandKind::Grab);
  grab.cell = static_cast<Index>(model.cell_count());
  CHECK_FALSE(command_is_valid(model, grab));
  grab.cell = 0;
  grab.local = Vec3(0.5, 1.5, 0.5);
  CHECK_FALSE(command_is_valid(model, grab));
  Command pose = command(CommandKind::ProbePose);
  pose.vector = Vec3(0.0, std::numeric_limits<double>::infinity(), 0.0);
  CHECK_FALSE(command_is_valid(model, pose));
  Command stiffness = command(CommandKind::SetStiffness);
  stiffness.object = 0;
  stiffness.value = 0.0;
  CHECK_FALSE(command_is_valid(model, stiffness));
}

TEST_CASE("Commands: the probe coupling stiffness is tuned live and reset") {
  const Model model = resting_box();
  const State initial = initial_state(model);
  CHECK(initial.params.probe_stiffness == model.settings.probe.coupling_stiffness);
  Command stiffer = command(CommandKind::SetProbeStiffness);
  stiffer.value = 3000.0;
  REQUIRE(command_is_valid(model, stiffer));
  Command negative = stiffer;
  negative.value = -1.0;
  CHECK_FALSE(command_is_valid(model, negative));

  // The device held 5 cm from the proxy, far above the box: the coupling force follows k.
  auto force_after_one_step = [&](const Command* c) {
    State state = initial;
    if (c) apply_command(model, initial, state, *c);
    state.probe.device = state.probe.device_previous = state.probe.x + Vec3(0.05, 0.0, 0.0);
    run(model, state, 1);
    return state.probe.force.norm();
  };
  const double default_force = force_after_one_step(nullptr), stiffer_force = force_after_one_step(&stiffer);
  INFO("force " << default_force << " N at 300 N/m, " << stiffer_force << " N at 3000 N/m");
  CHECK(stiffer_force > 5.0 * default_force);

  State state = initial;
  apply_command(model, initial, state, stiffer);
  CHECK(state.params.probe_stiffness == 3000.0);
  apply_command(model, initial, state, command(CommandKind::Reset));
  CHECK(state.params.probe_stiffness == initial.params.probe_stiffness);
}
