// Two scene options for where node-in-box tests let thin boxes cross like an X: [simulation]
// box_overlap, boxes of two objects kept apart as wholes (box_test.h, box_overlap) with a
// skin; and [simulation] edge_contacts, the exact surfaces' crossed edges sent back as at
// levels 4 and 5 (collision.cpp, test_edges). (Their determinism over thread counts:
// determinism_test.cpp.)
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "ffd/command.h"
#include "ffd/measure.h"
#include "ffd/random_pile.h"
#include "ffd/scene_loader.h"
#include "ffd/state.h"
#include "ffd/step.h"
#include "ffd/surface_intersections.h"
#include "support/test_scenes.h"

using namespace ffd;

namespace {

// A random pile of two: a letter P dropped onto a 6 mm plate (seed 5), at level 2 under the
// paper's response unless another is named.
Model letter_on_plate(bool box_overlap, bool edge_contacts = false, ContactResponse response = ContactResponse::Paper) {
  PileOptions options;
  options.seed = 5;
  options.objects = 2;
  options.box_overlap = box_overlap;
  options.edge_contacts = edge_contacts;
  SceneSpec spec = parse_scene(random_pile_scene(options), "pile_5.toml", "");
  spec.settings.response = response;
  REQUIRE(spec.settings.box_overlap == box_overlap);
  REQUIRE(spec.settings.edge_contacts == edge_contacts);
  std::vector<std::string> log;
  return compile_scene(spec, "pile_5.toml", log);
}

State start(const Model& model) {
  State state = initial_state(model);
  Command c;
  c.kind = CommandKind::SetAccuracy;
  c.value = static_cast<double>(Accuracy::CentreOfMass);
  apply_command(model, initial_state(model), state, c);
  return state;
}

// A box of size `lower` lying on the floor and one of size `upper` with its centre at
// height `upper_y`, 1 cm cells, inelastic contacts, no option on.
SceneSpec box_on_box(const Vec3& lower, const Vec3& upper, double upper_y) {
  SceneSpec spec;
  spec.settings.effects = Effect::Gravity | Effect::Planes | Effect::InterCollision;
  spec.settings.alpha = 1.0;
  spec.planes.push_back(test::floor_plane());
  spec.objects.push_back(test::box_object("lower", lower, 0.01, Vec3(0.0, 0.5 * lower.y(), 0.0)));
  spec.objects.push_back(test::box_object("upper", upper, 0.01, Vec3(0.0, upper_y, 0.0)));
  return spec;
}

// The state after `steps` steps from start(), each finite.
State run(const Model& model, int steps) {
  State state = start(model);
  Scratch scratch = make_scratch(model);
  StepReport report;
  for (int i = 1; i <= steps; ++i) {
    step(model, state, scratch, report);
    REQUIRE(report.finite);
  }
  return state;
}

// The most intersecting triangle pairs in 2 s from step `from` on, counted every `every` steps.
std::size_t crossing_from(const Model& model, int from, int every) {
  State state = start(model);
  Scratch scratch = make_scratch(model);
  StepReport report;
  const SurfaceIntersections crossings(model);
  std::size_t most = 0;
  for (int i = 1; i <= 2000; ++i) {
    step(model, state, scratch, report);
    REQUIRE(report.finite);
    if (i >= from && i % every == 0) most = std::max(most, crossings.count(state).total());
  }
  return most;
}

// The most intersecting triangle pairs over the last 0.5 s of 2 s, counted every 0.1 s.
std::size_t crossing_at_the_end(const Model& model) { return crossing_from(model, 1500, 100); }

}  // namespace

TEST_CASE("Box overlap: a letter dropped on a thin plate at level 2 rests crossed through it without, apart with it",
          "[box_overlap]") {
  // Without: the P lands across the plate and stays through it (about 300 pairs), while the
  // node-in-box test finds a few nodes 0.1 mm deep.
  CHECK(crossing_at_the_end(letter_on_plate(false)) > 100);
  const Model model = letter_on_plate(true);
  CHECK(model.box_skin == Approx(1e-4));  // 1 % of the 1 cm cells
  CHECK(crossing_at_the_end(model) == 0);
}

TEST_CASE("Edge contacts: a letter dropped on a thin plate at level 2 rests apart from it with them", "[box_overlap]") {
  // Without them it rests crossed through the plate (the test above).
  CHECK(crossing_at_the_end(letter_on_plate(false, true)) == 0);
}

TEST_CASE("Edge contacts: under the response solver too, the letter on the thin plate rests apart from it with them "
          "from 0.5 s on, crossed without",
          "[box_overlap]") {
  // The solver takes each crossing as a constraint between the edge's point and the
  // triangle's (contact_solver.cpp, find_edge_contacts). With them, counted every 10 ms from
  // 0.5 s (it lands at about 0.2 s): each solve's iterations end with the edge contacts'
  // non-penetration after the friction passes, else the box contacts' friction, holding
  // their points at their anchors, takes back the edges' pushes and the letter's edges cross
  // the plate again and again.
  const std::size_t without = crossing_at_the_end(letter_on_plate(false, false, ContactResponse::Solver));
  const std::size_t with = crossing_from(letter_on_plate(false, true, ContactResponse::Solver), 500, 10);
  CAPTURE(without, with);
  CHECK(without > 10);
  CHECK(with == 0);
}

TEST_CASE("Edge contacts: a thin plate on the floor under a letter is held by the floor, not pushed into it", "[box_overlap]") {
  // A 3 mm plate (1 cm cells) lying on the floor, an I of 160 g (nine times the plate's mass)
  // lying on it, level 2 with edge contacts. The letter's edges cross the plate's top by a
  // few hundredths of a millimetre every step; moved by the answer in proportion to its
  // inverse mass, the plate went into the floor, which put it back into the letter before the
  // next answer: RMS node speed 9.9 cm/s at 2.5 s. Held by the floor it stays still (0.04 cm/s).
  const std::string toml = R"(
[simulation]
alpha = 1.0
beta = 0.5
edge_contacts = true
effects = ["gravity", "planes", "inter_collision", "self_collision", "friction"]

[[plane]]
name = "floor"
normal = [0.0, 1.0, 0.0]
offset = 0.0

[[object]]
name = "plate"
shape = "box"
size = [0.04, 0.003, 0.037]
position = [0.0, 0.0016, 0.0]
cell_size = 0.01
mass = 0.0178
mass_spring = { stiffness = 5000.0, damping = 0.5, iterations = 4 }

[[object]]
name = "letter"
glyph = { text = "I", font = "/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf", em_size = 0.12, depth = 0.022, sample_spacing = 0.002 }
position = [0.0, 0.02, 0.0]
rotation_deg = [90.0, 0.0, 0.0]
cell_size = 0.01
mass = 0.16
mass_spring = { stiffness = 5000.0, damping = 0.5, iterations = 4 }
)";
  std::vector<std::string> log;
  const Model model = compile_scene(parse_scene(toml, "plate_under_letter.toml", ""), "plate_under_letter.toml", log);
  const State state = run(model, 2500);
  const ObjectModel& plate = model.objects[0];
  double kinetic = 0.0, mass = 0.0;  // 2 x J, kg
  for (Index n = plate.node_begin; n < plate.node_end; ++n) {
    kinetic += model.node_mass[n] * state.v[n].squaredNorm();
    mass += model.node_mass[n];
  }
  CHECK(std::sqrt(kinetic / mass) < 0.03);  // m/s
  CHECK(SurfaceIntersections(model).count(state).total() == 0);
  CHECK(centre_of_mass(model, state.x, 1).y() > 0.003);  // on the plate
}

TEST_CASE("Edge contacts: a scene without inter-collision runs no edge pass, and its objects pass through each other",
          "[box_overlap]") {
  // Without "inter_collision" a scene's objects do not collide with each other at all, so the
  // edge pass has nothing to answer and does not run: the narrow phase pairs no cells by their
  // triangles (its broad phase counts no grid entry), and the upper slab, dropped onto the
  // lower one, falls through it the same way, bit for bit, with edge_contacts on or off. The
  // pass once ran there every step (a self-collision-only scene paying for it in full).
  std::uint64_t hashes[2] = {0, 0};
  std::size_t crossings = 0;
  for (const bool edges : {false, true}) {
    SceneSpec spec = box_on_box(Vec3(0.1, 0.015, 0.1), Vec3(0.06, 0.015, 0.06), 0.04);
    spec.settings.effects = Effect::Gravity | Effect::Planes | Effect::SelfCollision;
    spec.settings.edge_contacts = edges;
    const Model model = test::compile_quietly(spec);
    State state = start(model);
    Scratch scratch = make_scratch(model);
    StepReport report;
    std::uint64_t narrow_grid_entries = 0;
    for (int i = 0; i < 150; ++i) {
      step(model, state, scratch, report);
      REQUIRE(report.finite);
      narrow_grid_entries += report.counters[static_cast<std::size_t>(Stage::NarrowPhase)].hash_entries;
    }
    CHECK(narrow_grid_entries == 0);
    hashes[edges] = state_hash(state);
    if (!edges) crossings = SurfaceIntersections(model).count(state).between;
  }
  CHECK(crossings > 0);  // the slabs did pass into each other
  CHECK(hashes[0] == hashes[1]);
}

TEST_CASE("Edge contacts: each triangle has one owner cell, and two slabs of 2-triangle faces over 400 cells rest apart",
          "[box_overlap]") {
  // Two 20 x 1.5 x 20 cm slabs of 1 cm cells, the upper one resting on the lower: each face
  // of a box mesh is 2 triangles, which cross every cell under them. Tested by the cells they
  // cross, each pair of triangles was tested by some 160,000 pairs of cells a step; by the
  // cells that own them, by a few.
  SceneSpec spec = box_on_box(Vec3(0.2, 0.015, 0.2), Vec3(0.2, 0.015, 0.2), 0.0226);
  for (ObjectSpec& slab : spec.objects) slab.mesh = make_box_mesh(Vec3(0.2, 0.015, 0.2));  // undivided
  spec.settings.edge_contacts = true;
  const Model model = test::compile_quietly(spec);
  std::size_t owned = 0, owners = 0;
  for (Index c = 0; c < model.cell_count(); ++c) {
    const Index count = model.cell_owned_triangle_begin[c + 1] - model.cell_owned_triangle_begin[c];
    owned += count;
    owners += count > 0 ? 1 : 0;
  }
  CHECK(owned == model.surface_triangles.size());  // each triangle once
  CHECK(owners <= 16);                              // 24 triangles, their first corners at the 8 corners of each box
  const State state = run(model, 300);
  // The upper slab rests on the lower one, no surface through the other.
  CHECK(SurfaceIntersections(model).count(state).total() == 0);
  CHECK(centre_of_mass(model, state.x, 1).y() > 0.015 + 0.0075 - 0.001);  // on the lower slab, not in it
}

TEST_CASE("Box overlap: a flat box resting on another keeps the skin between their faces, which then never touch",
          "[box_overlap]") {
  // A 4 x 1 x 4 cm box on a 6 x 1 x 6 cm slab on the floor, 1 cm cells: the faces that meet
  // are their boxes' faces. Without the skin the upper one rests in them (each step's sinking
  // answered back to the face), and the surfaces touch or cross.
  auto rest = [](bool box_overlap, double& gap, std::size_t& crossing) {
    SceneSpec spec = box_on_box(Vec3(0.06, 0.01, 0.06), Vec3(0.04, 0.01, 0.04), 0.0155);
    spec.settings.box_overlap = box_overlap;
    const Model model = test::compile_quietly(spec);
    State state = initial_state(model);
    Scratch scratch = make_scratch(model);
    StepReport report;
    for (int i = 0; i < 1000; ++i) step(model, state, scratch, report);
    REQUIRE(report.finite);
    double top = -INFINITY, bottom = INFINITY;
    for (const Vec3& v : deformed_surface(model, state, 0).vertices) top = std::max(top, v.y());
    for (const Vec3& v : deformed_surface(model, state, 1).vertices) bottom = std::min(bottom, v.y());
    gap = bottom - top;
    crossing = SurfaceIntersections(model).count(state).between;
  };
  double gap = 0.0;
  std::size_t crossing = 0;
  rest(false, gap, crossing);
  INFO("without: gap " << gap << " m, " << crossing << " crossing pairs");
  CHECK((gap <= 0.0 || crossing > 0));
  rest(true, gap, crossing);
  CHECK(crossing == 0);
  CHECK(gap > 0.25e-4);  // 0.057 mm: the skin, 0.1 mm, less the slab's and the box's sinking
  CHECK(gap < 2e-4);
}
