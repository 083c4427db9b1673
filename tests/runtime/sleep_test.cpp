// The "sleeping" effect (runtime/src/sleep.h): objects at rest freeze, something moving wakes
// them, commands and the grab wake them, and a step with sleepers allocates nothing.
#include <catch2/catch.hpp>

#include "ffd/command.h"
#include "ffd/physics_loop.h"
#include "ffd/step.h"
#include "support/allocation_counter.h"
#include "support/test_scenes.h"

using namespace ffd;

namespace {

// A 10 cm box dropped from 1 cm onto the floor and, with `with_slider`, a second one on the
// floor 60 cm away sliding towards it at 1 m/s, without friction: it comes within the wake
// margin after 0.5 s, when the first has been asleep for 0.15 s.
SceneSpec resting_scene(bool with_slider) {
  SceneSpec spec;
  spec.settings.effects = Effect::Gravity | Effect::Planes | Effect::InterCollision | Effect::Sleeping | Effect::Grab;
  spec.settings.alpha = 0.9;
  spec.planes.push_back(test::floor_plane());
  spec.objects.push_back(test::box_object("resting", Vec3(0.1, 0.1, 0.1), 0.025, Vec3(0.0, 0.06, 0.0)));
  if (with_slider) {
    ObjectSpec slider = test::box_object("slider", Vec3(0.1, 0.1, 0.1), 0.025, Vec3(0.6, 0.051, 0.0));
    slider.velocity = Vec3(-1.0, 0.0, 0.0);
    spec.objects.push_back(slider);
  }
  return spec;
}

// Steps until `object` is asleep; returns the steps taken, or -1 after `limit`.
int steps_until_asleep(const Model& model, State& state, Scratch& scratch, Index object, int limit) {
  StepReport report;
  for (int i = 0; i < limit; ++i) {
    if (state.asleep[object]) return i;
    step(model, state, scratch, report);
  }
  return state.asleep[object] ? limit : -1;
}

}  // namespace

TEST_CASE("an object at rest falls asleep and stays frozen exactly where it settled", "[sleep]") {
  const Model model = test::compile_quietly(resting_scene(false));
  REQUIRE(model.pipeline.back() == Stage::Sleep);
  State state = initial_state(model);
  Scratch scratch = make_scratch(model);
  // It lands within about 50 ms, settles, then needs sleep_time (0.3 s) within 2 mm.
  const int steps = steps_until_asleep(model, state, scratch, 0, 2000);
  REQUIRE(steps > 300);
  CHECK(centre_of_mass(model, state.x, 0).y() == Approx(0.05).margin(0.005));  // resting on the floor
  const std::vector<Vec3> settled = state.x;
  for (const Vec3& v : state.v) CHECK(v == Vec3::Zero());
  // Asleep: 500 steps change nothing, bit for bit, and allocate nothing.
  StepReport report;
  test::reset_allocations();
  test::count_allocations_on_this_thread(true);
  for (int i = 0; i < 500; ++i) step(model, state, scratch, report);
  test::count_allocations_on_this_thread(false);
  CHECK(test::allocations() == 0);
  CHECK(state.x == settled);
  CHECK(state.asleep[0] == 1);
  CHECK(report.counters[static_cast<std::size_t>(Stage::Sleep)].objects_asleep == 1);
}

TEST_CASE("an object moving into a sleeper wakes it and pushes it, never through it", "[sleep]") {
  const Model model = test::compile_quietly(resting_scene(true));
  State state = initial_state(model);
  Scratch scratch = make_scratch(model);
  StepReport report;
  int asleep_at = -1, woken_at = -1;
  double closest = INFINITY, lowest = INFINITY;
  for (int i = 0; i < 1000; ++i) {
    step(model, state, scratch, report);
    if (asleep_at < 0 && state.asleep[0]) asleep_at = i;
    if (asleep_at >= 0 && woken_at < 0 && !state.asleep[0]) woken_at = i;
    closest = std::min(closest, centre_of_mass(model, state.x, 1).x() - centre_of_mass(model, state.x, 0).x());
    lowest = std::min(lowest, centre_of_mass(model, state.x, 0).y());
  }
  REQUIRE(asleep_at > 0);
  CHECK(asleep_at < 450);                   // asleep before the slider arrives (341)
  CHECK(woken_at > asleep_at);              // woken by it (496)
  CHECK(centre_of_mass(model, state.x, 0).x() < -0.05);  // and pushed along -x
  CHECK(closest > 0.08);                    // box widths 10 cm: never through each other
  CHECK(lowest > 0.045);                    // nor into the floor
}

TEST_CASE("a gravity command, a reset and the grab wake sleeping objects", "[sleep]") {
  const Model model = test::compile_quietly(resting_scene(false));
  const State initial = initial_state(model);
  State state = initial;
  Scratch scratch = make_scratch(model);
  REQUIRE(steps_until_asleep(model, state, scratch, 0, 2000) > 0);

  Command gravity;
  gravity.kind = CommandKind::SetGravity;
  gravity.vector = Vec3(0.0, -9.81, 0.0);
  apply_command(model, initial, state, gravity);
  CHECK(state.asleep[0] == 0);

  REQUIRE(steps_until_asleep(model, state, scratch, 0, 2000) > 0);
  Command reset;
  reset.kind = CommandKind::Reset;
  apply_command(model, initial, state, reset);
  CHECK(state.asleep[0] == 0);

  REQUIRE(steps_until_asleep(model, state, scratch, 0, 2000) > 0);
  Command grab;
  grab.kind = CommandKind::Grab;
  grab.cell = model.objects[0].cell_begin;
  grab.local = Vec3(0.5, 0.5, 0.5);
  apply_command(model, initial, state, grab);
  Command drag;
  drag.kind = CommandKind::Drag;
  drag.vector = state.grab.target + Vec3(0.0, 0.1, 0.0);  // lift it by 10 cm
  apply_command(model, initial, state, drag);
  StepReport report;
  const double before = centre_of_mass(model, state.x, 0).y();
  for (int i = 0; i < 300; ++i) step(model, state, scratch, report);
  CHECK(state.asleep[0] == 0);
  CHECK(centre_of_mass(model, state.x, 0).y() > before + 0.02);
}

TEST_CASE("an object drifting 2 mm in under sleep_time stays awake, a slower one sleeps", "[sleep]") {
  // No gravity, a slow drift of 1 cm/s (2 mm in 0.2 s, under sleep_time = 0.3 s): it never
  // stays within 2 mm for 0.3 s, so it never sleeps; at 1 mm/s it sleeps.
  for (const double speed : {0.01, 0.001}) {
    SceneSpec spec;
    spec.settings.effects = static_cast<EffectSet>(Effect::Sleeping);
    ObjectSpec o = test::box_object("drifting", Vec3(0.1, 0.1, 0.1), 0.025, Vec3::Zero());
    o.velocity = Vec3(speed, 0.0, 0.0);
    spec.objects.push_back(o);
    const Model model = test::compile_quietly(spec);
    State state = initial_state(model);
    Scratch scratch = make_scratch(model);
    const int steps = steps_until_asleep(model, state, scratch, 0, 1000);
    if (speed > 0.005) CHECK(steps == -1);
    else CHECK(steps == 301);  // the first step sets the anchor, then 300 still steps
  }
}

TEST_CASE("an object slower than the wake speed meets a sleeper as a static body, without waking it", "[sleep]") {
  // No gravity. The resting box falls asleep at step 301; the other drifts into it at 1 cm/s:
  // too fast to sleep (2 mm in 0.2 s), too slow to wake (2 sleep_radius / sleep_time =
  // 13 mm/s). It reaches the sleeper after about 0.5 s and is stopped there.
  SceneSpec spec;
  spec.settings.effects = Effect::InterCollision | Effect::Sleeping;
  spec.settings.alpha = 1.0;
  spec.objects.push_back(test::box_object("resting", Vec3(0.1, 0.1, 0.1), 0.025, Vec3::Zero()));
  ObjectSpec drifter = test::box_object("drifter", Vec3(0.1, 0.1, 0.1), 0.025, Vec3(0.105, 0.0, 0.0));
  drifter.velocity = Vec3(-0.01, 0.0, 0.0);
  spec.objects.push_back(drifter);
  const Model model = test::compile_quietly(spec);
  State state = initial_state(model);
  Scratch scratch = make_scratch(model);
  REQUIRE(steps_until_asleep(model, state, scratch, 0, 400) == 301);
  const std::vector<Vec3> settled = state.x;
  StepReport report;
  std::uint32_t contacts = 0;
  for (int i = 0; i < 1500; ++i) {
    step(model, state, scratch, report);
    contacts += report.counters[static_cast<std::size_t>(Stage::NarrowPhase)].inter_contacts;
  }
  CHECK(contacts > 0);        // they met
  CHECK(state.asleep[0] == 1);  // it never woke
  const ObjectModel& resting = model.objects[0];
  for (Index n = resting.node_begin; n < resting.node_end; ++n) CHECK(state.x[n] == settled[n]);
  // Stopped at the sleeper's face: centres one box width (10 cm) apart, less the boxes'
  // margins, and not pushed through.
  CHECK(centre_of_mass(model, state.x, 1).x() - centre_of_mass(model, state.x, 0).x() > 0.09);
}

TEST_CASE("frames from the physics loop carry which objects are asleep, for the viewer", "[sleep]") {
  const Model model = test::compile_quietly(resting_scene(true));
  LoopOptions options;
  options.pacing = Pacing::Fast;
  options.realtime_priority = false;
  options.lock_memory = false;
  options.stop_at_step = 400;  // the resting box is asleep (from about step 340), the slider not yet near
  PhysicsLoop loop(model, initial_state(model), options);
  loop.start();
  Telemetry t;
  while (!loop.finished())
    while (loop.pop_telemetry(t)) {
    }
  loop.join();
  while (loop.pop_telemetry(t)) {
  }
  const Frame* frame = loop.latest_frame();
  REQUIRE(frame != nullptr);
  REQUIRE(frame->asleep.size() == model.objects.size());
  CHECK(frame->asleep[0] == 1);
  CHECK(frame->asleep[1] == 0);
  CHECK(loop.state().asleep[0] == 1);
}
