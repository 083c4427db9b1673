// The response "solver" (runtime/src/contact_solver.h): contacts found by the paper's detection
// become constraints solved with the springs. The same states on any thread count, no
// allocation in a step, a resting box held on the floor, a live switch between the responses.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "step_memory.h"
#include "ffd/command.h"
#include "ffd/scene_loader.h"
#include "ffd/step.h"
#include "ffd/surface_intersections.h"
#include "ffd/worker_pool.h"
#include "support/allocation_counter.h"
#include "support/test_scenes.h"

using namespace ffd;

namespace {

Model probe_and_grab_scene(ContactResponse response, Accuracy accuracy = Accuracy::CentreOfMass,
                           bool edge_contacts = true, bool solver_substeps = false) {
  SceneSpec spec = load_scene_file(FFDSIM_TEST_DATA_DIR "/scenes/probe_and_grab.toml");
  spec.settings.response = response;
  spec.settings.accuracy = accuracy;
  spec.settings.edge_contacts = edge_contacts;
  spec.settings.solver_substeps = solver_substeps;
  return test::compile_quietly(spec);
}

// The probe pressed down onto the upper box from step 50, the lower box grabbed at step 150
// and dragged 5 cm sideways and up.
void apply_user(const Model& model, const State& initial, State& state, int i) {
  Command c;
  if (i >= 50) {
    c.kind = CommandKind::ProbePose;
    c.vector = Vec3(0.02, std::max(0.22, 0.4 - 0.001 * (i - 50)), 0.0);
    apply_command(model, initial, state, c);
  }
  if (i == 150) {
    c.kind = CommandKind::Grab;
    c.cell = model.objects[0].cell_begin;
    c.local = Vec3(0.5, 0.5, 0.5);
    apply_command(model, initial, state, c);
  }
  if (i > 150) {
    c.kind = CommandKind::Drag;
    c.vector = state.grab.target + Vec3(0.0002, 0.0002, 0.0);
    if (i < 400) apply_command(model, initial, state, c);
  }
}

struct Run {
  std::vector<std::uint64_t> hashes;
  std::uint64_t allocations = 0;
  std::uint32_t most_constraints = 0;
  Index most_edge_contacts = 0;  // edge crossings taken in one step (edge_contacts)
};

Run run(const Model& model, int threads, int steps) {
  Run r;
  State state = initial_state(model);
  const State initial = state;
  Scratch scratch = make_scratch(model);
  WorkerPool pool(threads, [] { test::count_allocations_on_this_thread(true); },
                  [] { test::count_allocations_on_this_thread(false); });
  if (threads > 1) attach_pool(model, scratch, pool);
  StepReport report;
  r.hashes.reserve(static_cast<std::size_t>(steps));
  test::reset_allocations();
  for (int i = 0; i < steps; ++i) {
    apply_user(model, initial, state, i);
    test::count_allocations_on_this_thread(true);
    step(model, state, scratch, report);
    test::count_allocations_on_this_thread(false);
    REQUIRE_FALSE(report.constraints_overflow);
    r.hashes.push_back(state_hash(state));
    r.most_constraints = std::max(r.most_constraints, report.constraints);
    r.most_edge_contacts = std::max(r.most_edge_contacts, scratch.memory().edge_crossing_count);
  }
  r.allocations = test::allocations();
  return r;
}

}  // namespace

TEST_CASE("Determinism: box, plane, probe, surface and grab contacts give the same states on 1, 2 and 8 threads "
          "under both responses, and no allocation",
          "[determinism]") {
  // Level 2: the boxes' nodes, and the exact edges with edge_contacts (on by default); level 4:
  // sub-boxes and the edges; level 5: the exact surfaces' vertices and their edges. Under the
  // solver the edges and level 5's vertex contacts are constraints, and its sweeps may be
  // substeps (solver_substeps).
  using Case = std::tuple<ContactResponse, Accuracy, bool, bool>;
  const auto [response, accuracy, edges, substeps] =
      GENERATE(Case{ContactResponse::Solver, Accuracy::CentreOfMass, false, false},
               Case{ContactResponse::Solver, Accuracy::CentreOfMass, true, false},
               Case{ContactResponse::Solver, Accuracy::CentreOfMass, false, true},
               Case{ContactResponse::Solver, Accuracy::SubBoxes, false, false},
               Case{ContactResponse::Solver, Accuracy::SubBoxes, true, false},
               Case{ContactResponse::Solver, Accuracy::SubBoxes, true, true},
               Case{ContactResponse::Solver, Accuracy::Exact, false, false},  // vertex contacts answered at once
               Case{ContactResponse::Solver, Accuracy::Exact, true, false},
               Case{ContactResponse::Solver, Accuracy::Exact, true, true},
               Case{ContactResponse::Paper, Accuracy::CentreOfMass, true, false},
               Case{ContactResponse::Paper, Accuracy::SubBoxes, true, false},
               Case{ContactResponse::Paper, Accuracy::Exact, true, false});
  CAPTURE(response_name(response), accuracy_name(accuracy), edges, substeps);
  const Model model = probe_and_grab_scene(response, accuracy, edges, substeps);
  const Run one = run(model, 1, 500);
  CHECK(one.allocations == 0);
  // The boxes' faces, resting and pressed on each other, cross at their triangles' edges
  // (at level 5 without substeps the vertex constraints alone keep them apart).
  if (response == ContactResponse::Solver && edges && (accuracy != Accuracy::Exact || substeps))
    CHECK(one.most_edge_contacts > 0);
  // The solver's list: the boxes on the floor and on each other, the probe (level 5's vertex
  // contacts without edge contacts are answered at once, not listed).
  if (response == ContactResponse::Solver && (accuracy != Accuracy::Exact || edges)) CHECK(one.most_constraints > 50);
  for (const int threads : {2, 8}) {
    const Run many = run(model, threads, 500);
    INFO(threads << " threads");
    CHECK(many.allocations == 0);
    for (std::size_t i = 0; i < one.hashes.size(); ++i) {
      INFO("step " << i + 1);
      REQUIRE(many.hashes[i] == one.hashes[i]);
    }
  }
}

TEST_CASE("Response solver with solver_substeps: a box dropped on another rests on it instead of bouncing",
          "[contact_solver]") {
  // Each substep's velocities are answered by the velocity pass; without it a correction
  // within a substep left as depth / h into the next one's prediction, and the upper box
  // bounced on the lower one for the whole second.
  const Model model = probe_and_grab_scene(ContactResponse::Solver, Accuracy::CentreOfMass, true, true);
  State state = initial_state(model);
  Scratch scratch = make_scratch(model);
  StepReport report;
  double fastest_rms = 0.0;  // m/s, from 0.4 s
  for (int i = 0; i < 1000; ++i) {
    step(model, state, scratch, report);
    if (i < 400) continue;
    double sum = 0.0;
    for (const Vec3& v : state.v) sum += v.squaredNorm();
    fastest_rms = std::max(fastest_rms, std::sqrt(sum / static_cast<double>(state.v.size())));
  }
  CHECK(report.constraints > 0);
  CHECK(fastest_rms < 0.01);
  CHECK(centre_of_mass(model, state.x, 1).y() == Approx(0.15).margin(0.01));  // on the lower box's top (0.1 m)
}

TEST_CASE("Response solver: a box dropped on the floor lands and rests on it", "[contact_solver]") {
  SceneSpec spec;
  spec.settings.effects = Effect::Gravity | Effect::Planes | Effect::Friction;
  spec.settings.response = ContactResponse::Solver;
  spec.planes.push_back(test::floor_plane());
  spec.objects.push_back(test::box_object("box", Vec3(0.1, 0.1, 0.1), 0.025, Vec3(0.0, 0.07, 0.0)));
  const Model model = test::compile_quietly(spec);
  State state = initial_state(model);
  Scratch scratch = make_scratch(model);
  StepReport report;
  double lowest = INFINITY;
  for (int i = 0; i < 1000; ++i) {
    step(model, state, scratch, report);
    // The box's surface: its FFD AABBs' nodes (the lattice reaches past the surface).
    update_all_boxes(model, state, scratch);
    for (Index b = 0; b < model.boxes.size(); ++b)
      for (const Vec3& x : scratch.box_nodes()[b]) lowest = std::min(lowest, x.y());
  }
  double fastest = 0.0;
  for (const Vec3& v : state.v) fastest = std::max(fastest, v.norm());
  CHECK(report.stage_ns[static_cast<std::size_t>(Stage::ContactSolve)] >= 0);  // the solver answered
  CHECK(report.constraints > 0);
  CHECK(lowest > -0.001);  // never more than 1 mm into the floor, from a 2 cm fall
  CHECK(centre_of_mass(model, state.x, 0).y() == Approx(0.05).margin(0.002));
  CHECK(fastest < 0.02);   // m/s, after 1 s
}

TEST_CASE("Response solver with solver_substeps: five hard bunnies fall onto each other, no surface crossing "
          "between or within them",
          "[contact_solver][scenarios]") {
  // Four sweeps as iterations of one step leave a stiff lattice giving way around the nodes a
  // contact pushes, and the bunnies fold into themselves and each other (docs/limits.md);
  // as substeps each sweep starts from its own prediction.
  SceneSpec spec = load_scene_file(std::string(FFDSIM_SCENARIO_DIR) + "/scenes/five_bunnies_hard.toml");
  spec.settings.response = ContactResponse::Solver;
  spec.settings.solver_substeps = true;
  const Model model = test::compile_quietly(spec);
  State state = initial_state(model);
  Scratch scratch = make_scratch(model);
  StepReport report;
  const SurfaceIntersections measure(model);
  for (int i = 1; i <= 3000; ++i) {
    step(model, state, scratch, report);
    if (i % 500 != 0) continue;
    INFO("step " << i);
    const IntersectionCount count = measure.count(state);
    CHECK(count.within == 0);
    CHECK(count.between == 0);
  }
  for (const Vec3& x : state.x) REQUIRE(x.allFinite());
}

TEST_CASE("Response: a live switch is a state command, paper stays bit for bit what it was", "[contact_solver]") {
  const Model paper = probe_and_grab_scene(ContactResponse::Paper);
  const Model solver = probe_and_grab_scene(ContactResponse::Solver);
  State a = initial_state(paper), b = initial_state(solver);
  const State initial_a = a;
  CHECK(b.params.response == ContactResponse::Solver);
  // Switched at step 100 on the paper scene, the solver takes over from the same state.
  Scratch sa = make_scratch(paper);
  StepReport report;
  for (int i = 0; i < 100; ++i) step(paper, a, sa, report);
  CHECK(report.stage_ns[static_cast<std::size_t>(Stage::ContactSolve)] == -1);  // not run under "paper"
  Command c;
  c.kind = CommandKind::SetResponse;
  c.value = 1.0;
  REQUIRE(command_is_valid(paper, c));
  apply_command(paper, initial_a, a, c);
  CHECK(a.params.response == ContactResponse::Solver);
  step(paper, a, sa, report);
  CHECK(report.stage_ns[static_cast<std::size_t>(Stage::ContactSolve)] >= 0);
  c.value = 2.0;
  CHECK_FALSE(command_is_valid(paper, c));
  // Reset returns to the scene's response.
  c.kind = CommandKind::Reset;
  apply_command(paper, initial_a, a, c);
  CHECK(a.params.response == ContactResponse::Paper);
}

TEST_CASE("Response solver: after a reset the same commands give the same states as from the start",
          "[contact_solver]") {
  // The friction anchors are state: a reset that kept the last run's would hold the new run's
  // contacts where the old ones stuck.
  const Model model = probe_and_grab_scene(ContactResponse::Solver);
  const State initial = initial_state(model);
  auto run_from = [&](State& state, std::vector<std::uint64_t>& hashes) {
    Scratch scratch = make_scratch(model);
    StepReport report;
    for (int i = 0; i < 600; ++i) {
      apply_user(model, initial, state, i);
      step(model, state, scratch, report);
      hashes.push_back(state_hash(state));
    }
  };
  State fresh = initial;
  std::vector<std::uint64_t> first, again;
  run_from(fresh, first);
  REQUIRE(fresh.anchor_count > 0);  // the boxes rest on each other and on the floor
  Command reset;
  reset.kind = CommandKind::Reset;
  apply_command(model, initial, fresh, reset);
  CHECK(fresh.anchor_count == 0);
  fresh.step = 0;
  run_from(fresh, again);
  CHECK(again == first);
}

TEST_CASE("Response solver: a box resting on another comes to rest and stays", "[contact_solver]") {
  // The probe-and-grab boxes, left alone: the upper one lands on the lower by 0.4 s. Under the
  // paper's response the pair keeps trembling at 13-15 mm/s RMS (docs/limits.md).
  const Model model = probe_and_grab_scene(ContactResponse::Solver);
  State state = initial_state(model);
  Scratch scratch = make_scratch(model);
  StepReport report;
  for (int i = 0; i < 500; ++i) step(model, state, scratch, report);
  const Vec3 high = centre_of_mass(model, state.x, 1), low = centre_of_mass(model, state.x, 0);
  CHECK(high.y() == Approx(0.15).margin(0.002));  // on the lower box's top (y = 0.1), 5 cm half-height
  double fastest_rms = 0.0;
  for (int i = 500; i < 1500; ++i) {
    step(model, state, scratch, report);
    double sum_sq = 0.0;
    for (const Vec3& v : state.v) sum_sq += v.squaredNorm();
    fastest_rms = std::max(fastest_rms, std::sqrt(sum_sq / static_cast<double>(state.v.size())));
  }
  CHECK(fastest_rms < 1.0e-4);  // m/s, every step from 0.5 s to 1.5 s
  CHECK((centre_of_mass(model, state.x, 1) - high).norm() < 1.0e-5);  // no creep
  CHECK((centre_of_mass(model, state.x, 0) - low).norm() < 1.0e-5);
}

namespace {

// A ball of lattice cells rolled along the floor: 0.3 m/s forward with the spin that rolls it.
SceneSpec rolling_ball(double rolling_resistance) {
  SceneSpec spec;
  spec.settings.effects = Effect::Gravity | Effect::Planes | Effect::Friction;
  spec.settings.response = ContactResponse::Solver;
  spec.settings.alpha = 1.0;
  spec.settings.beta = 1.0;
  spec.settings.rolling_resistance = rolling_resistance;
  spec.planes.push_back(test::floor_plane());
  ObjectSpec ball = test::sphere_object("ball", 0.05, 0.02, Vec3(0.0, 0.0505, 0.0));
  ball.velocity = Vec3(0.3, 0.0, 0.0);
  ball.angular_velocity = Vec3(0.0, 0.0, -0.3 / 0.05);
  spec.objects.push_back(ball);
  return spec;
}

// The lattice's momentum over its mass: the centre of mass's velocity (m/s).
Vec3 centre_velocity(const Model& model, const State& state) {
  Vec3 momentum = Vec3::Zero();
  double mass = 0.0;
  for (Index n = 0; n < model.node_count(); ++n) {
    momentum += model.node_mass[n] * state.v[n];
    mass += model.node_mass[n];
  }
  return momentum / mass;
}

// The centre's fastest speed (m/s) in each of the step windows [from, to], one run.
std::vector<double> fastest_in(const Model& model, const std::vector<std::pair<int, int>>& windows) {
  State state = initial_state(model);
  Scratch scratch = make_scratch(model);
  StepReport report;
  std::vector<double> fastest(windows.size(), 0.0);
  for (int i = 1; i <= windows.back().second; ++i) {
    step(model, state, scratch, report);
    for (std::size_t w = 0; w < windows.size(); ++w)
      if (i >= windows[w].first && i <= windows[w].second)
        fastest[w] = std::max(fastest[w], centre_velocity(model, state).norm());
  }
  return fastest;
}

}  // namespace

TEST_CASE("Response solver: rolling resistance stops a rolling ball, without it the ball rolls on", "[contact_solver]") {
  // A bounded torque: about mu_r g / R_gyration ~ 0.05 x 9.81 / 0.04 ~ 12 rad/s^2 of spin
  // lost, so the 6 rad/s roll stops within half a second, as a ball on a soft floor. With
  // solver_substeps the cap is a substep's worth (damp_on_supports): a quarter of it at 4
  // sweeps, stopped within 2 s. The lattice ball is a polyhedron of 2 cm cells: free, it tips
  // from face to face, its speed rising and falling, so each figure is the fastest over a
  // window, not one instant's.
  for (const bool substeps : {false, true}) {
    INFO("solver_substeps " << substeps);
    SceneSpec resisted_spec = rolling_ball(0.05), free_spec = rolling_ball(0.0);
    resisted_spec.settings.solver_substeps = free_spec.settings.solver_substeps = substeps;
    const int stopped = substeps ? 2000 : 500;  // step by which the model stops the roll
    const std::vector<std::pair<int, int>> windows = {{100, 400}, {stopped, stopped + 100}};  // steps
    const std::vector<double> resisted = fastest_in(test::compile_quietly(resisted_spec), windows);
    const std::vector<double> free = fastest_in(test::compile_quietly(free_spec), windows);
    CAPTURE(resisted, free);
    CHECK(resisted[1] < 0.001);  // at rest
    CHECK(free[0] > 0.03);       // free, it rolls on
    // and still moves when the resisted ball has stopped (with substeps, by 2 s, so has the
    // free one: its tips lose to the contacts' damping what the roll has left)
    if (!substeps) CHECK(free[1] > 10.0 * resisted[1]);
  }
}

namespace {

// A 10 cm box (1 kg) held against a wall (the plane x = 0) by a sideways gravity `push`
// (m/s^2) with the usual 9.81 m/s^2 down, friction beta = mu = 0.5, stepped `steps` times.
// Returns its centre's velocity (m/s) and sets `centre` to its centre of mass (m).
Vec3 slide_on_wall(double push, int steps, Vec3& centre) {
  SceneSpec spec;
  spec.settings.effects = Effect::Gravity | Effect::Planes | Effect::Friction;
  spec.settings.response = ContactResponse::Solver;
  spec.settings.gravity = Vec3(-push, -9.81, 0.0);
  spec.settings.beta = 0.5;
  PlaneSpec wall;
  wall.name = "wall";
  wall.normal = Vec3::UnitX();
  wall.offset = 0.0;
  spec.planes.push_back(wall);
  spec.objects.push_back(test::box_object("box", Vec3(0.1, 0.1, 0.1), 0.025, Vec3(0.0505, 1.0, 0.0)));
  const Model model = test::compile_quietly(spec);
  State state = initial_state(model);
  Scratch scratch = make_scratch(model);
  StepReport report;
  for (int i = 0; i < steps; ++i) step(model, state, scratch, report);
  centre = centre_of_mass(model, state.x, 0);
  return centre_velocity(model, state);
}

}  // namespace

TEST_CASE("Response solver: a box pressed on a wall by less than friction needs slides down at Coulomb's rate",
          "[contact_solver]") {
  // Pressed by half its weight, mu = 0.5: kinetic friction takes 0.5 x 4.905 of the 9.81
  // m/s^2, so the box slides down at 7.36 m/s^2 (measured: 0.741 m/s after 0.1 s, 2.21 m/s
  // after 0.3 s). A velocity pass that also took 1 - beta of the sliding speed each step
  // held it to a 5 cm/s crawl, as a drag in proportion to the speed.
  Vec3 centre;
  const Vec3 v = slide_on_wall(4.905, 300, centre);
  CHECK(-v.y() == Approx((9.81 - 0.5 * 4.905) * 0.3).epsilon(0.05));
  CHECK(centre.x() == Approx(0.05).margin(0.001));  // against the wall, not into it or off it
  // Pressed by three times its weight, static friction (up to 15 N) holds it (9.81 N).
  const Vec3 held = slide_on_wall(30.0, 300, centre);
  CHECK(held.norm() < 0.001);
  CHECK(centre.y() == Approx(1.0).margin(0.001));
}

TEST_CASE("Response solver: a box held on a wall just within friction's reach stays where it stuck",
          "[contact_solver]") {
  // Pressed by 1.02 times what mu = 0.5 needs to hold its weight: static friction holds it, and
  // its contacts' anchors hold it where it stuck. Measured: 2.5e-15 m from 0.5 s to 3 s. With
  // each step's friction holding its points only where the step began, what the solve left
  // unconverged added up: 41 um in the same 2.5 s, as a slow slide down the wall.
  const double push = 1.02 * 9.81 / 0.5;
  Vec3 stuck, later;
  slide_on_wall(push, 500, stuck);
  const Vec3 v = slide_on_wall(push, 3000, later);
  CHECK((later - stuck).norm() < 1.0e-6);
  CHECK(v.norm() < 1.0e-4);
  CHECK(later.x() == Approx(0.05).margin(0.001));  // against the wall
}

TEST_CASE("Response solver: a probe driven through a box on the floor never pushes it through the floor",
          "[contact_solver]") {
  // The probe_force hard case in small: a 10^7 N/m coupling, the device going from above a
  // box to 10 cm below the floor at 6 m/s. The planes have the last word in the solve; when
  // the probe's contacts came last, they pushed the box's nodes through the floor (the hard
  // case's box ended with its centre 0.9 cm below it, a contact 0.65 m deep).
  SceneSpec spec;
  spec.settings.effects = Effect::Gravity | Effect::Planes | Effect::Friction | Effect::Probe;
  spec.settings.response = ContactResponse::Solver;
  spec.settings.probe.start = Vec3(0.0, 0.15, 0.0);
  spec.planes.push_back(test::floor_plane());
  spec.objects.push_back(test::box_object("box", Vec3(0.1, 0.1, 0.1), 0.025, Vec3(0.0, 0.05, 0.0)));
  const Model model = test::compile_quietly(spec);
  State state = initial_state(model);
  const State initial = state;
  state.params.probe_stiffness = 1.0e7;  // N/m
  Scratch scratch = make_scratch(model);
  StepReport report;
  double lowest = INFINITY, deepest_probe = INFINITY;
  for (int i = 0; i < 200; ++i) {
    Command c;
    c.kind = CommandKind::ProbePose;
    c.vector = Vec3(0.0, std::max(-0.1, 0.15 - 0.006 * i), 0.0);
    apply_command(model, initial, state, c);
    step(model, state, scratch, report);
    REQUIRE(report.finite);
    update_all_boxes(model, state, scratch);
    for (Index b = 0; b < model.boxes.size(); ++b)
      for (const Vec3& x : scratch.box_nodes()[b]) lowest = std::min(lowest, x.y());
    deepest_probe = std::min(deepest_probe, state.probe.x.y());
  }
  CHECK(deepest_probe < 0.0);   // the proxy went through: the box was driven hard
  // m: the box's nodes stay at the floor (measured: 4.2 mm below it at worst; 11 cm below
  // without the planes' last pass).
  CHECK(lowest > -0.01);
  CHECK(centre_of_mass(model, state.x, 0).y() > 0.0);
}

TEST_CASE("Response solver: a node lodged deep in a box is pushed out without friction", "[contact_solver]") {
  // The two stacked boxes; the upper one is put 3 mm into the lower one's top and given a
  // sideways velocity. Its bottom nodes are lodged (deeper than two steps' approach makes):
  // their contacts push out without friction, while the contacts of the boxes' touching
  // edges keep theirs.
  const Model model = probe_and_grab_scene(ContactResponse::Solver);
  State state = initial_state(model);
  const Vec3 drop = centre_of_mass(model, state.x, 1) - Vec3(0.02, 0.147, 0.0);
  const ObjectModel& high = model.objects[1];
  for (Index n = high.node_begin; n < high.node_end; ++n) {
    state.x[n] -= drop;
    state.v[n] = Vec3(0.2, 0.0, 0.0);
  }
  Scratch scratch = make_scratch(model);
  StepReport report;
  step(model, state, scratch, report);
  int lodged = 0, gripping = 0;
  for (Index i = 0; i < scratch.memory().constraint_count; ++i) {
    const ContactConstraint& c = scratch.memory().constraints[i];
    if (c.lodged) {
      ++lodged;
      CHECK(c.friction == Vec3::Zero());
    } else if (c.lambda > 0.0 && c.friction != Vec3::Zero()) {
      ++gripping;
    }
  }
  CHECK(lodged > 0);
  CHECK(gripping > 0);  // the floor's contacts and the shallow ones keep their friction
}

namespace {

Model solver_scene(const std::string& text) {
  SceneSpec spec = parse_scene(text, "inline.toml", ".");
  spec.settings.response = ContactResponse::Solver;
  return test::compile_quietly(spec);
}

}  // namespace

TEST_CASE("Response solver: a node just above a plane gets a contact, inactive until the solve moves it in",
          "[contact_solver]") {
  // No gravity: nothing moves. 0.5 mm above the floor the box's bottom nodes are within the
  // speculative distance (1 mm) and get contacts with no push; 5 mm above they get none.
  // Without these contacts a node held against a plane by its springs was pushed out in one
  // step and pulled back through in the next (a letter's node on the deep stack's bin wall).
  auto scene = [](double bottom) {
    return "[simulation]\neffects = [\"planes\"]\n[[plane]]\nname = \"floor\"\nnormal = [0.0, 1.0, 0.0]\n"
           "[[object]]\nname = \"box\"\nshape = \"box\"\nsize = [0.1, 0.1, 0.1]\nposition = [0.0, " +
           std::to_string(bottom + 0.05) + ", 0.0]\ncell_size = 0.05\n  [object.mass_spring]\n";
  };
  for (const double bottom : {0.0005, 0.005}) {
    const Model model = solver_scene(scene(bottom));
    State state = initial_state(model);
    Scratch scratch = make_scratch(model);
    StepReport report;
    step(model, state, scratch, report);
    const State start = state;
    step(model, state, scratch, report);
    INFO("box bottom " << bottom << " m above the floor");
    CHECK((bottom < kSpeculativeDistance ? report.constraints > 0 : report.constraints == 0));
    for (Index i = 0; i < scratch.memory().constraint_count; ++i) CHECK(scratch.memory().constraints[i].lambda == 0.0);
    double moved = 0.0;  // m, the farthest any node went in the step: nothing pushed
    for (std::size_t n = 0; n < state.x.size(); ++n) moved = std::max(moved, (state.x[n] - start.x[n]).norm());
    CHECK(moved < 1e-9);
  }
}

TEST_CASE("Response solver: a Scratch that has stepped other states steps a state as a fresh one does",
          "[contact_solver]") {
  // Two spheres meeting head on at alpha = 0 (the hard case alpha_zero_head_on): their cells'
  // nodes take a rebound once per step, found by marks kept in the Scratch. Stepped again
  // from the state of step 49 with the same Scratch, the marks the first run left must not
  // count: the same states as with a fresh Scratch, and as the first run.
  const Model model = solver_scene(
      "[simulation]\nalpha = 0.0\nbeta = 0.0\neffects = [\"inter_collision\", \"friction\"]\n"
      "[[object]]\nname = \"left\"\nshape = \"sphere\"\nradius = 0.05\nposition = [-0.1, 0.0, 0.0]\n"
      "velocity = [1.0, 0.0, 0.0]\ncell_size = 0.02\n  [object.mass_spring]\n"
      "[[object]]\nname = \"right\"\nshape = \"sphere\"\nradius = 0.05\nposition = [0.1, 0.01, 0.0]\n"
      "velocity = [-1.0, 0.0, 0.0]\ncell_size = 0.02\n  [object.mass_spring]\n");
  State state = initial_state(model);
  Scratch used = make_scratch(model);
  StepReport report;
  State at_49 = state;
  std::uint32_t contact_steps = 0;
  for (int i = 0; i < 80; ++i) {
    if (state.step == 49) at_49 = state;
    step(model, state, used, report);
    contact_steps += report.constraints > 0;
  }
  REQUIRE(contact_steps > 5);  // the spheres met within the run
  State again = at_49, fresh = at_49;
  Scratch fresh_scratch = make_scratch(model);
  for (int i = 0; i < 31; ++i) {
    step(model, again, used, report);
    step(model, fresh, fresh_scratch, report);
  }
  CHECK(again.step == state.step);
  CHECK(state_hash(again) == state_hash(fresh));
  CHECK(state_hash(again) == state_hash(state));
}
