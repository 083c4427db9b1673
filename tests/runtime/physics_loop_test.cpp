// The physics thread: determinism across pacing modes, no allocation on the thread, a
// stalled reader, commands taking effect exactly at their step. Built under TSan too.
#include <catch2/catch.hpp>

#include <chrono>
#include <thread>

#include "ffd/command.h"
#include "ffd/physics_loop.h"
#include "support/allocation_counter.h"
#include "support/test_scenes.h"

using namespace ffd;

namespace {

// A box resting on the floor and a second one dropped on it, with probe and grab: every
// stage runs, and a step takes tens of microseconds, far inside the 1 ms budget.
SceneSpec loop_scene() {
  SceneSpec spec;
  spec.name = "loop";
  spec.settings.effects = Effect::Gravity | Effect::Planes | Effect::InterCollision | Effect::SelfCollision |
                          Effect::Friction | Effect::Probe | Effect::Grab;
  spec.settings.probe.start = Vec3(0.0, 0.4, 0.0);
  spec.objects.push_back(test::box_object("low", Vec3(0.2, 0.1, 0.2), 0.05, Vec3(0.0, 0.051, 0.0)));
  spec.objects.push_back(test::box_object("high", Vec3(0.1, 0.1, 0.1), 0.05, Vec3(0.02, 0.2, 0.0)));
  spec.planes.push_back(test::floor_plane());
  return spec;
}

Command at(std::uint64_t step, CommandKind kind) {
  Command c;
  c.step = step;
  c.kind = kind;
  return c;
}

// Probe pressed down onto the upper box, a grab and drag of the lower box, parameter
// changes, a pause and a reset: every command kind.
std::vector<Command> busy_commands(const Model& model) {
  std::vector<Command> commands;
  for (std::uint64_t s = 10; s < 400; ++s) {
    Command c = at(s, CommandKind::ProbePose);
    c.vector = Vec3(0.02, 0.4 - 0.0006 * static_cast<double>(s), 0.0);
    commands.push_back(c);
  }
  Command grab = at(50, CommandKind::Grab);
  grab.cell = model.objects[0].cell_begin;
  grab.local = Vec3(0.5, 0.5, 0.5);
  grab.vector = Vec3(-0.1, 0.1, 0.0);
  commands.push_back(grab);
  Command drag = at(120, CommandKind::Drag);
  drag.vector = Vec3(-0.15, 0.12, 0.0);
  commands.push_back(drag);
  commands.push_back(at(200, CommandKind::Release));
  Command alpha = at(150, CommandKind::SetAlpha);
  alpha.value = 0.3;
  commands.push_back(alpha);
  Command stiffness = at(160, CommandKind::SetStiffness);
  stiffness.object = 1;
  stiffness.value = 8000.0;
  commands.push_back(stiffness);
  Command pause = at(250, CommandKind::Pause);
  pause.value = 5;
  commands.push_back(pause);
  commands.push_back(at(420, CommandKind::Reset));
  std::stable_sort(commands.begin(), commands.end(),
                   [](const Command& a, const Command& b) { return a.step < b.step; });
  return commands;
}

// The same run without a thread: commands applied at their steps, then step().
std::vector<std::uint64_t> hashes_by_direct_stepping(const Model& model, const std::vector<Command>& commands,
                                                     std::uint64_t steps) {
  const State initial = initial_state(model);
  State state = initial;
  Scratch scratch = make_scratch(model);
  StepReport report;
  std::vector<std::uint64_t> hashes;
  std::size_t next = 0;
  while (state.step < steps) {
    while (next < commands.size() && commands[next].step == state.step) {
      if (is_state_command(commands[next].kind)) apply_command(model, initial, state, commands[next]);
      ++next;
    }
    step(model, state, scratch, report);
    hashes.push_back(state_hash(state));
  }
  return hashes;
}

struct LoopRun {
  std::vector<Telemetry> telemetry;
  std::vector<Command> applied;
  LoopCounters counters;
  std::uint64_t final_hash = 0;
};

LoopRun run_loop(const Model& model, const std::vector<Command>& commands, LoopOptions options,
                 std::chrono::milliseconds reader_stall = std::chrono::milliseconds(0)) {
  PhysicsLoop loop(model, initial_state(model), std::move(options));
  for (const Command& c : commands) REQUIRE(loop.push(c));
  loop.start();
  LoopRun run;
  if (reader_stall.count() > 0) std::this_thread::sleep_for(reader_stall);
  Telemetry t;
  Command c;
  while (!loop.finished()) {
    while (loop.pop_telemetry(t)) run.telemetry.push_back(t);
    while (loop.pop_applied_command(c)) run.applied.push_back(c);
    if (const Frame* frame = loop.latest_frame()) REQUIRE(frame->nodes.size() == model.node_count());
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  loop.join();
  while (loop.pop_telemetry(t)) run.telemetry.push_back(t);
  while (loop.pop_applied_command(c)) run.applied.push_back(c);
  run.counters = loop.counters();
  run.final_hash = state_hash(loop.state());
  return run;
}

LoopOptions options_for(Pacing pacing, std::uint64_t steps) {
  LoopOptions o;
  o.pacing = pacing;
  o.stop_at_step = steps;
  o.hash_every = 1;
  o.lock_memory = false;  // process-wide; not for a test runner under sanitizers
  return o;
}

}  // namespace

TEST_CASE("Physics loop: fast and real-time runs equal direct stepping bit for bit") {
  const Model model = test::compile_quietly(loop_scene());
  const std::vector<Command> commands = busy_commands(model);
  const std::uint64_t steps = 500;
  const std::vector<std::uint64_t> expected = hashes_by_direct_stepping(model, commands, steps);
  for (const int threads : {1, 2})
  for (const Pacing pacing : {Pacing::Fast, Pacing::RealTime}) {
    LoopOptions options = options_for(pacing, steps);
    options.threads = threads;
    const LoopRun run = run_loop(model, commands, options);
    REQUIRE(run.telemetry.size() == steps);
    CHECK(run.counters.threads == threads);
    for (std::size_t i = 0; i < steps; ++i) {
      INFO("pacing " << (pacing == Pacing::Fast ? "fast" : "real time") << ", " << threads << " threads, step " << i + 1);
      REQUIRE(run.telemetry[i].step == i + 1);
      REQUIRE(run.telemetry[i].has_hash);
      REQUIRE(run.telemetry[i].state_hash == expected[i]);
    }
    CHECK(run.counters.commands_rejected == 0);
    CHECK(run.counters.commands_late == 0);
    // Every command came back with the step it applied at, in order.
    REQUIRE(run.applied.size() == commands.size());
    for (std::size_t i = 0; i < commands.size(); ++i) {
      CHECK(run.applied[i].kind == commands[i].kind);
      CHECK(run.applied[i].step == commands[i].step);
    }
  }
}

TEST_CASE("Physics loop: the probe pushes back and the force output says so") {
  const Model model = test::compile_quietly(loop_scene());
  const LoopRun run = run_loop(model, busy_commands(model), options_for(Pacing::Fast, 400));
  double peak_force = 0.0;
  std::uint32_t contacts = 0;
  for (const Telemetry& t : run.telemetry) {
    peak_force = std::max(peak_force, t.probe_force_n.norm());
    contacts += t.contacts;
  }
  // The device goes 16 cm below where the upper box's top lies; the proxy is held back, so
  // the coupling spring (300 N/m) is stretched by centimetres: newtons, not millinewtons.
  CHECK(peak_force > 1.0);
  CHECK(contacts > 0);
}

TEST_CASE("Physics loop: nothing is allocated on the physics thread or its workers") {
  SceneSpec spec = loop_scene();
  spec.objects[1].mass_spring.shape_stiffness = 5000.0;  // corotated cells too (N/m)
  const Model model = test::compile_quietly(spec);
  for (const Pacing pacing : {Pacing::Fast, Pacing::RealTime}) {
    LoopOptions options = options_for(pacing, 450);
    options.threads = 2;  // on_thread_start runs on the worker too: its allocations count
    options.energy_every = 1;
    options.snapshot_every = 7;
    options.on_thread_start = [] { test::count_allocations_on_this_thread(true); };
    options.on_thread_stop = [] { test::count_allocations_on_this_thread(false); };
    test::reset_allocations();
    PhysicsLoop loop(model, initial_state(model), std::move(options));
    for (const Command& c : busy_commands(model)) loop.push(c);
    loop.start();
    Telemetry t;
    std::uint64_t records = 0;
    while (!loop.finished()) {
      while (loop.pop_telemetry(t)) ++records;
      while (Snapshot* s = loop.pop_snapshot()) loop.recycle(s);
      loop.latest_frame();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    loop.join();
    while (loop.pop_telemetry(t)) ++records;
    CHECK(records == 450);
    CHECK(test::allocations() == 0);
  }
}

// A loop that waited on its reader would block for the whole 2 s stall: one step would take
// seconds and the ~2,000 releases behind it would all be late. The virtual machines this
// runs on also stall a whole vCPU now and then (0.5-5 ms pauses, about one a second, seen by
// a bare SCHED_FIFO spin loop too), and ctest runs another test on the other core; no code
// can prevent that: in the Release build, with ctest's other test on the other core, 13 % of
// the steps have been seen late, 3.6 ms at most. So the bounds allow that noise (misses under a third of the
// steps, no step more than 250 ms late) and nothing near what waiting would cause (two
// thirds of the steps late, one by 2 s).
TEST_CASE("Physics loop: a reader stalled for 2 s costs no deadline and no telemetry") {
  const Model model = test::compile_quietly(loop_scene());
  // The period and budget this build can keep: 1 ms, or 4x the slowest of 200 fast steps in
  // a sanitizer build (whose steps are ~20x slower), so that only waiting could miss.
  const LoopRun probe_run = run_loop(model, {}, options_for(Pacing::Fast, 200));
  std::int64_t slowest_ns = 0;
  for (const Telemetry& t : probe_run.telemetry) slowest_ns = std::max(slowest_ns, t.compute_ns);
  const std::int64_t period_ns = std::max<std::int64_t>(1'000'000, 4 * slowest_ns);
  const std::uint64_t steps = static_cast<std::uint64_t>(3'000'000'000 / period_ns);  // 3 s
  LoopOptions options = options_for(Pacing::RealTime, steps);
  options.period_ns = options.budget_ns = period_ns;
  INFO("period and budget " << period_ns << " ns");
  const LoopRun run = run_loop(model, {}, options, std::chrono::milliseconds(2000));
  REQUIRE(run.telemetry.size() == steps);
  std::int64_t longest_compute_ns = 0;
  std::int64_t latest_ns = 0;
  for (std::size_t i = 0; i < run.telemetry.size(); ++i) {
    REQUIRE(run.telemetry[i].step == i + 1);
    longest_compute_ns = std::max(longest_compute_ns, run.telemetry[i].compute_ns);
    latest_ns = std::max(latest_ns, run.telemetry[i].lateness_ns);
    if (!run.telemetry[i].deadline_met)
      WARN("miss at step " << i + 1 << ": lateness " << run.telemetry[i].lateness_ns << " ns, compute "
                           << run.telemetry[i].compute_ns << " ns");
  }
  CHECK(run.counters.telemetry_dropped == 0);
  CHECK(longest_compute_ns < 50'000'000);
  CHECK(latest_ns < 250'000'000);
  CHECK(run.counters.deadline_misses * 3 < steps);
}

TEST_CASE("Physics loop: a change of alpha at step k changes nothing before k") {
  const Model model = test::compile_quietly(loop_scene());
  const std::uint64_t k = 150;
  Command alpha = at(k, CommandKind::SetAlpha);
  alpha.value = 0.0;
  const LoopRun plain = run_loop(model, {}, options_for(Pacing::Fast, 400));
  const LoopRun changed = run_loop(model, {alpha}, options_for(Pacing::Fast, 400));
  for (std::size_t i = 0; i < k; ++i) {
    INFO("state after step " << i + 1);
    REQUIRE(plain.telemetry[i].state_hash == changed.telemetry[i].state_hash);
  }
  // The boxes are in contact from the start, so alpha matters right away.
  CHECK(plain.final_hash != changed.final_hash);
}

TEST_CASE("Physics loop: malformed commands are dropped and counted") {
  const Model model = test::compile_quietly(loop_scene());
  Command bad_alpha = at(3, CommandKind::SetAlpha);
  bad_alpha.value = std::numeric_limits<double>::quiet_NaN();
  Command bad_grab = at(4, CommandKind::Grab);
  bad_grab.cell = static_cast<Index>(model.cell_count());
  Command bad_object = at(5, CommandKind::SetStiffness);
  bad_object.object = 7;
  bad_object.value = 100.0;
  const LoopRun run = run_loop(model, {bad_alpha, bad_grab, bad_object}, options_for(Pacing::Fast, 20));
  CHECK(run.counters.commands_rejected == 3);
  CHECK(run.applied.empty());
  CHECK(run.final_hash == hashes_by_direct_stepping(model, {}, 20).back());
}

TEST_CASE("Physics loop: budget-aware accuracy switches are recorded and replay bit for bit") {
  const Model model = test::compile_quietly(loop_scene());
  const std::uint64_t steps = 1200;
  LoopOptions options = options_for(Pacing::Fast, steps);
  // A budget of 1 s: every level fits, so the governor climbs one level per 250-step window
  // from the scene's level 2 once it is turned on at step 100, until it is turned off at 700.
  options.budget_ns = 1'000'000'000;
  Command on = at(100, CommandKind::AutoAccuracy);
  on.value = 1.0;
  Command off = at(700, CommandKind::AutoAccuracy);
  off.value = 0.0;
  const LoopRun run = run_loop(model, {on, off}, options);
  REQUIRE(run.telemetry.size() == steps);
  std::vector<Command> switches;
  for (const Command& c : run.applied) {
    CHECK(c.kind != CommandKind::AutoAccuracy);  // only its decisions are on the record
    if (c.kind == CommandKind::SetAccuracy) switches.push_back(c);
  }
  REQUIRE(switches.size() == 2);
  CHECK(switches[0].step == 350);
  CHECK(switches[0].value == 3.0);
  CHECK(switches[1].step == 600);
  CHECK(switches[1].value == 4.0);
  CHECK(run.counters.accuracy_switches == 2);
  CHECK(run.telemetry[349].accuracy == Accuracy::CentreOfMass);
  CHECK(run.telemetry[350].accuracy == Accuracy::SampleNodes);
  CHECK(run.telemetry.back().accuracy == Accuracy::SubBoxes);
  // The recorded commands alone, applied by plain stepping, give the same states.
  const std::vector<std::uint64_t> expected = hashes_by_direct_stepping(model, run.applied, steps);
  for (std::size_t i = 0; i < steps; ++i) {
    INFO("step " << i + 1);
    REQUIRE(run.telemetry[i].state_hash == expected[i]);
  }
}
