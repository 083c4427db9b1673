// Scene files -> SceneSpec: the shipped scenes load with the values they state, optional keys
// take their documented defaults, and every malformed scene is rejected with a message that
// names the exact file, line, column and field.
#include "ffd/scene_loader.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "ffd/mesh.h"
#include "ffd/mesh_import.h"
#include "ffd/model.h"

namespace {

using Catch::Matchers::Contains;
using Catch::Matchers::Equals;
using Catch::Matchers::StartsWith;

const std::string kFixtureDir = FFDSIM_TEST_DATA_DIR "/scenes";
const std::string kSceneDir = FFDSIM_SCENARIO_DIR "/scenes";

std::string fixture(const std::string& name) { return kFixtureDir + "/" + name; }

ffd::SceneSpec load_fixture(const std::string& name) { return ffd::load_scene_file(fixture(name)); }

// Scene text checked under the name "inline.toml"; mesh paths resolve against the fixtures.
ffd::SceneSpec parse(const std::string& text) { return ffd::parse_scene(text, "inline.toml", kFixtureDir); }

// A valid scene whose single object's body is `object_lines`: the [[object]] header is on
// line 3 and `object_lines` start on line 4.
std::string scene_with_object(const std::string& object_lines) {
  return "[simulation]\neffects = [\"gravity\"]\n[[object]]\n" + object_lines;
}
// A valid object body (lines 4..9) to append keys to: the next line is 10.
const std::string kBoxLines =
    "name = \"block\"\nshape = \"box\"\nsize = [0.1, 0.1, 0.1]\ncell_size = 0.02\n[object.mass_spring]\n"
    "iterations = 4\n";

// Parsing `text` must fail with exactly this message under the name "inline.toml".
void require_error(const std::string& text, const std::string& message) {
  REQUIRE_THROWS_AS(parse(text), ffd::SceneError);
  REQUIRE_THROWS_WITH(parse(text), Equals(message));
}

// Loading fixture `name` must fail with a message that starts with its full path followed by
// `position_and_field` (":LINE:COL: FIELD: PROBLEM...").
void require_fixture_error(const std::string& name, const std::string& position_and_field) {
  REQUIRE_THROWS_AS(load_fixture(name), ffd::SceneError);
  REQUIRE_THROWS_WITH(load_fixture(name), StartsWith(fixture(name) + position_and_field));
}

constexpr ffd::EffectSet kEveryEffect = ffd::Effect::Gravity | ffd::Effect::Planes |
                                        ffd::Effect::InterCollision | ffd::Effect::SelfCollision |
                                        ffd::Effect::Friction | ffd::Effect::Probe | ffd::Effect::Grab;

}  // namespace

TEST_CASE("the default scene is two teapots above a floor with every effect", "[scene_loader]") {
  REQUIRE(ffd::default_scene_path() == FFDSIM_SCENARIO_DIR "/scenes/two_teapots.toml");
  const ffd::SceneSpec scene = ffd::default_scene();

  CHECK(scene.name == "two_teapots");
  CHECK(scene.settings.effects == kEveryEffect);
  CHECK(scene.settings.dt == 0.001);
  CHECK(scene.settings.gravity == ffd::Vec3(0.0, -9.81, 0.0));
  CHECK(scene.settings.alpha == 1.0);
  CHECK(scene.settings.beta == 1.0);
  CHECK(scene.settings.seed == 1);

  REQUIRE(scene.planes.size() == 1);
  CHECK(scene.planes[0].name == "floor");
  CHECK(scene.planes[0].normal == ffd::Vec3::UnitY());
  CHECK(scene.planes[0].offset == 0.0);

  REQUIRE(scene.objects.size() == 2);
  const ffd::ObjectSpec& low = scene.objects[0];
  const ffd::ObjectSpec& high = scene.objects[1];
  CHECK(low.name == "teapot_low");
  CHECK(high.name == "teapot_high");
  for (const ffd::ObjectSpec* object : {&low, &high}) {
    CHECK(object->source == "../meshes/teapot.obj");
    // The raw file's vertices: clean-up happens in compile(), not in the loader.
    CHECK(object->mesh.vertices.size() == 3644);
    CHECK(object->mesh.triangles.size() == 6320);
    CHECK(object->cell_size == 0.016);
    CHECK(object->mass == 1.0);
    CHECK(object->dynamics == ffd::DynamicsKind::MassSpring);
    CHECK(object->mass_spring.stiffness == 5000.0);
    CHECK(object->mass_spring.damping == 0.5);
    CHECK(object->mass_spring.iterations == 4);
  }
  CHECK(low.position.y() == 0.002);
  CHECK(low.rotation_deg == ffd::Vec3::Zero());
  CHECK(high.rotation_deg.y() >= 30.0);
  CHECK(high.rotation_deg.y() <= 60.0);

  // The upper teapot's base starts about 5 cm above the lower one's lid.
  const auto [low_min, low_max] = ffd::mesh_bounds(low.mesh);
  const auto [high_min, high_max] = ffd::mesh_bounds(high.mesh);
  CHECK(low_min.y() + low.position.y() == Approx(0.002));
  const double gap = (high_min.y() + high.position.y()) - (low_max.y() + low.position.y());
  CHECK(gap == Approx(0.05).margin(0.01));
}

TEST_CASE("scale is applied to the mesh vertices", "[scene_loader]") {
  SECTION("uniform scale on a mesh file") {
    const ffd::SceneSpec scene = ffd::default_scene();
    const ffd::SurfaceMesh raw = ffd::import_mesh(FFDSIM_SCENARIO_DIR "/meshes/teapot.obj");
    const ffd::SurfaceMesh& scaled = scene.objects[0].mesh;
    REQUIRE(scaled.vertices.size() == raw.vertices.size());
    for (std::size_t i = 0; i < raw.vertices.size(); ++i) {
      REQUIRE(scaled.vertices[i] == raw.vertices[i] * 0.05);
    }
    CHECK(scaled.triangles == raw.triangles);
    const auto [lo, hi] = ffd::mesh_bounds(scaled);
    CHECK(hi.x() - lo.x() == Approx(0.05 * 6.434));
    CHECK(hi.y() - lo.y() == Approx(0.05 * 3.15));
    CHECK(hi.z() - lo.z() == Approx(0.05 * 4.0));
  }
  SECTION("per-axis scale on a built-in shape") {
    const ffd::SceneSpec scene = load_fixture("scaled_box.toml");
    REQUIRE(scene.objects.size() == 1);
    const auto [lo, hi] = ffd::mesh_bounds(scene.objects[0].mesh);
    CHECK(hi.x() - lo.x() == Approx(0.2));
    CHECK(hi.y() - lo.y() == Approx(0.2));
    CHECK(hi.z() - lo.z() == Approx(0.15));
    CHECK(scene.objects[0].source == "box");
  }
}

TEST_CASE("every stated value is read", "[scene_loader]") {
  const ffd::SceneSpec scene = load_fixture("scaled_box.toml");
  CHECK(scene.name == "scaled_box");
  CHECK(scene.settings.effects == (ffd::Effect::Gravity | ffd::Effect::Planes));
  REQUIRE(scene.planes.size() == 1);
  // A normal of any length is normalised; `point` becomes the offset along it.
  CHECK(scene.planes[0].normal == ffd::Vec3::UnitY());
  CHECK(scene.planes[0].offset == 0.25);
  const ffd::ObjectSpec& brick = scene.objects.at(0);
  CHECK(brick.name == "brick");
  CHECK(brick.position == ffd::Vec3(1, 2, 3));
  CHECK(brick.rotation_deg == ffd::Vec3(10, 20, 30));
  CHECK(brick.velocity == ffd::Vec3(0, -1, 0));
  CHECK(brick.cell_size == 0.04);
  CHECK(brick.mass == 2.0);  // an integer where a float is expected
  CHECK(brick.fill_interior);
  CHECK(brick.clean.weld_tolerance == 0.0);
  CHECK(brick.clean.min_component_fraction == 0.5);
  CHECK(brick.dynamics == ffd::DynamicsKind::ShapeMatching);
  CHECK(brick.shape_matching.stiffness == 1.0);
  CHECK(brick.shape_matching.region_half_width == 2);
  CHECK(brick.shape_matching.damping == 0.0);
}

TEST_CASE("missing optional keys take their documented defaults", "[scene_loader]") {
  const ffd::SceneSpec scene = load_fixture("minimal.toml");
  const ffd::SimulationSettings defaults;
  CHECK(scene.name == "minimal");
  CHECK(scene.settings.effects == 0);
  CHECK(scene.settings.dt == 0.001);
  CHECK(scene.settings.gravity == ffd::Vec3(0.0, -9.81, 0.0));
  CHECK(scene.settings.alpha == 0.5);
  CHECK(scene.settings.beta == 0.3);
  CHECK(scene.settings.seed == 1);
  CHECK(scene.settings.hash_cell_size == 0.0);
  CHECK(scene.settings.min_box_thickness == 0.1);
  CHECK(scene.settings.response == ffd::ContactResponse::Paper);
  CHECK(scene.planes.empty());

  REQUIRE(scene.objects.size() == 1);
  const ffd::ObjectSpec& ball = scene.objects[0];
  CHECK(ball.source == "sphere");
  CHECK(ball.position == ffd::Vec3::Zero());
  CHECK(ball.rotation_deg == ffd::Vec3::Zero());
  CHECK(ball.velocity == ffd::Vec3::Zero());
  CHECK(ball.cell_size == 0.05);
  CHECK(ball.mass == 1.0);
  CHECK_FALSE(ball.fill_interior);
  CHECK(ball.clean.weld_tolerance == 1e-9);
  CHECK(ball.clean.min_component_fraction == 0.01);
  CHECK(ball.dynamics == ffd::DynamicsKind::MassSpring);
  CHECK(ball.mass_spring.stiffness == 5000.0);
  CHECK(ball.mass_spring.damping == 0.5);
  CHECK(ball.mass_spring.iterations == 4);
  CHECK(ball.mass_spring.bulk_modulus == 0.0);  // springs only
  CHECK(ball.mass_spring.shape_stiffness == 0.0);
  // subdivisions defaults to 3 and scale to 1.
  const ffd::SurfaceMesh expected = ffd::make_sphere_mesh(0.1, 3);
  CHECK(ball.mesh.vertices == expected.vertices);
  CHECK(ball.mesh.triangles == expected.triangles);

  SECTION("shape matching and plane defaults") {
    const ffd::SceneSpec with_plane = parse(
        "[simulation]\neffects = [\"planes\"]\n[[plane]]\n[[object]]\nname = \"b\"\nshape = \"sphere\"\n"
        "radius = 0.1\nshape_matching = {}\n");
    REQUIRE(with_plane.planes.size() == 1);
    CHECK(with_plane.planes[0].name == "plane0");
    CHECK(with_plane.planes[0].normal == ffd::Vec3::UnitY());
    CHECK(with_plane.planes[0].offset == 0.0);
    const ffd::ObjectSpec& b = with_plane.objects.at(0);
    CHECK(b.dynamics == ffd::DynamicsKind::ShapeMatching);
    CHECK(b.shape_matching.stiffness == 0.5);
    CHECK(b.shape_matching.region_half_width == 1);
    CHECK(b.shape_matching.damping == 2.0);
  }
}

TEST_CASE("torus, ring and bowl shapes are read with their sizes", "[scene_loader]") {
  const ffd::SceneSpec scene = parse(
      "[simulation]\neffects = [\"gravity\"]\n"
      "[[object]]\nname = \"t\"\nshape = \"torus\"\nradius = 0.05\nthickness = 0.02\ncell_size = 0.01\nmass_spring = {}\n"
      "[[object]]\nname = \"r\"\nshape = \"ring\"\nradius = 0.04\nthickness = 0.01\nheight = 0.02\nsegments = 32\n"
      "cell_size = 0.01\nmass_spring = {}\n"
      "[[object]]\nname = \"b\"\nshape = \"bowl\"\nradius = 0.05\nthickness = 0.008\ncell_size = 0.01\nmass_spring = {}\n");
  REQUIRE(scene.objects.size() == 3);
  const ffd::SurfaceMesh torus = ffd::make_torus_mesh(0.05, 0.02, 48);  // 48 segments by default
  const ffd::SurfaceMesh ring = ffd::make_ring_mesh(0.04, 0.01, 0.02, 32);
  const ffd::SurfaceMesh bowl = ffd::make_bowl_mesh(0.05, 0.008, 48);
  CHECK(scene.objects[0].source == "torus");
  CHECK(scene.objects[0].mesh.vertices == torus.vertices);
  CHECK(scene.objects[1].mesh.triangles == ring.triangles);
  CHECK(scene.objects[1].mesh.vertices == ring.vertices);
  CHECK(scene.objects[2].mesh.vertices == bowl.vertices);
  std::vector<std::string> log;
  const ffd::Model model = ffd::compile(scene, log);  // each a closed surface in its lattice
  CHECK(model.objects.size() == 3);
}

TEST_CASE("the shipped test scenes load", "[scene_loader]") {
  const ffd::SceneSpec pair = ffd::load_scene_file(kSceneDir + "/shape_matching_pair.toml");
  CHECK(pair.settings.effects ==
        (ffd::Effect::Gravity | ffd::Effect::Planes | ffd::Effect::InterCollision | ffd::Effect::Friction));
  REQUIRE(pair.objects.size() == 2);
  CHECK(pair.objects[0].source == "box");
  CHECK(pair.objects[1].source == "sphere");
  for (const ffd::ObjectSpec& object : pair.objects)
    CHECK(object.dynamics == ffd::DynamicsKind::ShapeMatching);
  CHECK(pair.planes.size() == 1);

  const ffd::SceneSpec falling = ffd::load_scene_file(kSceneDir + "/no_collision.toml");
  CHECK(falling.settings.effects == static_cast<ffd::EffectSet>(ffd::Effect::Gravity));
  CHECK(falling.planes.empty());
  REQUIRE(falling.objects.size() == 1);
  CHECK(falling.objects[0].source == "sphere");
}

TEST_CASE("the shipped scenes compile", "[scene_loader]") {
  for (const char* name : {"two_teapots.toml", "shape_matching_pair.toml", "no_collision.toml"}) {
    INFO(name);
    const ffd::SceneSpec spec = ffd::load_scene_file(kSceneDir + "/" + name);
    std::vector<std::string> log;
    const ffd::Model model = ffd::compile(spec, log);
    CHECK(model.objects.size() == spec.objects.size());
  }
  // The teapots' cell size is chosen for the paper's resolution: about 600 cells each.
  std::vector<std::string> log;
  const ffd::Model teapots = ffd::compile(ffd::default_scene(), log);
  CHECK(teapots.cell_count() / 2 >= 500);
  CHECK(teapots.cell_count() / 2 <= 800);
}

TEST_CASE("malformed scene files name the file, line, column and field", "[scene_loader]") {
  SECTION("TOML syntax error") { require_fixture_error("bad_syntax.toml", ":3:6: TOML syntax error: "); }
  SECTION("unknown key, with a suggestion") {
    require_fixture_error(
        "bad_unknown_key.toml",
        ":10:3: object[0].mass_spring.stifness: unknown key 'stifness'; did you mean 'stiffness'?");
  }
  SECTION("wrong type") {
    require_fixture_error("bad_wrong_type.toml", ":9:8: object[0].mass: expected a number (got a string)");
  }
  SECTION("wrong array length") {
    require_fixture_error("bad_array_length.toml",
                          ":9:12: object[0].position: expected 3 numbers [x, y, z] (got 2)");
  }
  SECTION("out of range") {
    require_fixture_error("bad_range.toml", ":16:13: object[1].cell_size: must be > 0 (got -0.02)");
  }
  SECTION("non-finite") {
    require_fixture_error("bad_non_finite.toml", ":3:17: simulation.gravity[1]: must be finite (got ");
  }
  SECTION("unknown effect") {
    require_fixture_error("bad_effect.toml",
                          ":3:23: simulation.effects[1]: unknown effect 'frction'; did you mean 'friction'? "
                          "(valid effects: gravity, planes, inter_collision, self_collision, friction, probe, grab, sleeping)");
  }
  SECTION("duplicate object name") {
    require_fixture_error("bad_duplicate_name.toml",
                          ":12:8: object[1].name: duplicate name 'block' (also object[0])");
  }
  SECTION("both mesh and shape") {
    require_fixture_error("bad_mesh_and_shape.toml", ":8:9: object[0].shape: give one of 'mesh', 'shape' and 'glyph', not several");
  }
  SECTION("both dynamics tables") {
    require_fixture_error("bad_two_dynamics.toml",
                          ":11:1: object[0].shape_matching: give exactly one of [object.mass_spring] and "
                          "[object.shape_matching]");
  }
  SECTION("missing mesh file") {
    require_fixture_error("bad_missing_mesh.toml", ":7:8: object[0].mesh: cannot find mesh file '" +
                                                       fixture("meshes/no_such_mesh.obj") + "'");
  }
  SECTION("mesh file assimp cannot read") {
    require_fixture_error("bad_unreadable_mesh.toml", ":7:8: object[0].mesh: ");
    REQUIRE_THROWS_WITH(load_fixture("bad_unreadable_mesh.toml"), Contains("unreadable.stl"));
  }
  SECTION("planes without the planes effect") {
    require_fixture_error(
        "bad_planes_without_effect.toml",
        ":5:1: plane[0]: planes are declared but the \"planes\" effect is off; add \"planes\" "
        "to simulation.effects");
  }
  SECTION("missing required key points at its table") {
    require_fixture_error("bad_missing_name.toml", ":5:1: object[0].name: missing required key");
  }
  SECTION("missing scene file") {
    const std::string path = fixture("no_such_scene.toml");
    REQUIRE_THROWS_WITH(ffd::load_scene_file(path), Equals(path + ": cannot open scene file"));
    REQUIRE_THROWS_WITH(ffd::load_scene_file(kFixtureDir), Equals(kFixtureDir + ": cannot open scene file"));
  }
}

TEST_CASE("scene structure errors", "[scene_loader]") {
  SECTION("missing [simulation]") {
    require_error("[[object]]\nname = \"a\"\n",
                  "inline.toml:1:1: simulation: missing required table [simulation]; it must list at least "
                  "'effects'");
  }
  SECTION("missing effects points at [simulation]") {
    require_error("\n[simulation]\ndt = 0.001\n",
                  "inline.toml:2:1: simulation.effects: missing required key (list the effects, e.g. "
                  "[\"gravity\", \"planes\"], or [])");
  }
  SECTION("no objects") {
    require_error("[simulation]\neffects = []\n",
                  "inline.toml:1:1: object: a scene needs at least one [[object]] or [[group]] table");
  }
  SECTION("[object] with single brackets") {
    require_error(
        "[simulation]\neffects = []\n[object]\nname = \"a\"\n",
        "inline.toml:3:1: object: expected an array of tables; write [[object]] with double brackets");
  }
  SECTION("misspelt top-level table") {
    require_error("[simulation]\neffects = []\n[[objects]]\nname = \"a\"\n",
                  "inline.toml:3:3: objects: unknown key 'objects'; did you mean 'object'?");
  }
  SECTION("simulation key at the top level") {
    require_error("dt = 0.001\n[simulation]\neffects = []\n",
                  "inline.toml:1:1: dt: unknown key 'dt'; it belongs in the [simulation] table");
  }
  SECTION("unknown key with no close match lists the valid keys") {
    require_error(
        "[simulation]\neffects = []\nwind = 3\n",
        "inline.toml:3:1: simulation.wind: unknown key 'wind' (valid keys: dt, gravity, alpha, beta, "
        "seed, effects, hash_table_size, hash_cell_size, min_box_thickness, accuracy, sub_box_split, sleep_radius, sleep_time, response, rolling_resistance, box_overlap, edge_contacts, solver_edge_contacts, solver_substeps)");
  }
  SECTION("the first unknown key in file order is reported") {
    require_error(
        "[simulation]\nwind = 1\neffects = []\nalpha_ = 1\n",
        "inline.toml:2:1: simulation.wind: unknown key 'wind' (valid keys: dt, gravity, alpha, beta, "
        "seed, effects, hash_table_size, hash_cell_size, min_box_thickness, accuracy, sub_box_split, sleep_radius, sleep_time, response, rolling_resistance, box_overlap, edge_contacts, solver_edge_contacts, solver_substeps)");
  }
  SECTION("a key that is the start of a valid one") {
    require_error(scene_with_object("name = \"a\"\nrotation = [0, 45, 0]\n"),
                  "inline.toml:5:1: object[0].rotation: unknown key 'rotation'; did you mean 'rotation_deg'?");
  }
  SECTION("dynamics key directly in the object") {
    require_error(scene_with_object(kBoxLines + "[[object]]\nname = \"b\"\nstiffness = 1\n"),
                  "inline.toml:12:1: object[1].stiffness: unknown key 'stiffness'; it belongs in "
                  "[object.mass_spring] or [object.shape_matching]");
  }
  SECTION("neither mesh nor shape") {
    require_error(scene_with_object("name = \"a\"\n[object.mass_spring]\n"),
                  "inline.toml:3:1: object[0]: needs a surface: 'mesh' (a file path), 'shape' (a built-in: box, "
                  "sphere, torus, ring, bowl) or 'glyph' (a letter of a font)");
  }
  SECTION("no dynamics table") {
    require_error(scene_with_object("name = \"a\"\nshape = \"sphere\"\nradius = 0.1\n"),
                  "inline.toml:3:1: object[0]: needs a dynamics table: [object.mass_spring] or "
                  "[object.shape_matching] (may be empty)");
  }
  SECTION("empty name") {
    require_error(scene_with_object("name = \"\"\n"), "inline.toml:4:8: object[0].name: must not be empty");
  }
}

TEST_CASE("scene value errors", "[scene_loader]") {
  SECTION("dt out of range") {
    require_error("[simulation]\ndt = 0.02\neffects = []\n",
                  "inline.toml:2:6: simulation.dt: must be in (0, 0.01] (got 0.02)");
  }
  SECTION("alpha out of range") {
    require_error("[simulation]\nalpha = 1.5\neffects = []\n",
                  "inline.toml:2:9: simulation.alpha: must be in [0, 1] (got 1.5)");
  }
  SECTION("negative seed") {
    require_error("[simulation]\nseed = -1\neffects = []\n",
                  "inline.toml:2:8: simulation.seed: must be >= 0 (got -1)");
  }
  SECTION("hash table size") {
    require_error("[simulation]\nhash_table_size = 4000\neffects = []\n",
                  "inline.toml:2:19: simulation.hash_table_size: hash_table_size is no longer used: the broad phase sizes "
                  "its grids to the objects (remove the key; hash_cell_size still sets the grid cell edge)");
  }
  SECTION("the solver's old edge switch") {
    require_error("[simulation]\nsolver_edge_contacts = true\neffects = []\n",
                  "inline.toml:2:24: simulation.solver_edge_contacts: solver_edge_contacts is no longer used: "
                  "edge_contacts gives both responses their edge contacts (remove the key; edge_contacts = false "
                  "turns them off)");
  }
  SECTION("effects is not an array") {
    require_error("[simulation]\neffects = \"gravity\"\n",
                  "inline.toml:2:11: simulation.effects: expected an array of effect names (got a string)");
  }
  SECTION("effect listed twice") {
    require_error("[simulation]\neffects = [\"gravity\", \"gravity\"]\n",
                  "inline.toml:2:23: simulation.effects[1]: effect 'gravity' is listed twice");
  }
  SECTION("float where an integer is expected") {
    require_error(scene_with_object(kBoxLines + "damping = 1\n[[object]]\nname = \"b\"\nshape = \"box\"\n"
                                                "size = [1, 1, 1]\n[object.mass_spring]\niterations = 4.0\n"),
                  "inline.toml:16:14: object[1].mass_spring.iterations: expected an integer (got a "
                  "floating-point number)");
  }
  SECTION("iterations out of range") {
    require_error(scene_with_object("name = \"a\"\nshape = \"box\"\nsize = [1, 1, 1]\n[object.mass_spring]\n"
                                    "iterations = 0\n"),
                  "inline.toml:8:14: object[0].mass_spring.iterations: must be in [1, 100] (got 0)");
  }
  SECTION("negative bulk modulus") {
    require_error(scene_with_object("name = \"a\"\nshape = \"box\"\nsize = [1, 1, 1]\n[object.mass_spring]\n"
                                    "bulk_modulus = -1e5\n"),
                  "inline.toml:8:16: object[0].mass_spring.bulk_modulus: must be >= 0 (got -1e+05)");
  }
  SECTION("negative shape stiffness") {
    require_error(scene_with_object("name = \"a\"\nshape = \"box\"\nsize = [1, 1, 1]\n[object.mass_spring]\n"
                                    "shape_stiffness = -5\n"),
                  "inline.toml:8:19: object[0].mass_spring.shape_stiffness: must be >= 0 (got -5)");
  }
  SECTION("shape matching stiffness") {
    require_error(
        scene_with_object("name = \"a\"\nshape = \"box\"\nsize = [1, 1, 1]\n[object.shape_matching]\n"
                          "stiffness = 0\n"),
        "inline.toml:8:13: object[0].shape_matching.stiffness: must be in (0, 1] (got 0)");
  }
  SECTION("region half width") {
    require_error(
        scene_with_object("name = \"a\"\nshape = \"box\"\nsize = [1, 1, 1]\n[object.shape_matching]\n"
                          "region_half_width = 5\n"),
        "inline.toml:8:21: object[0].shape_matching.region_half_width: must be in [1, 4] (got 5)");
  }
  SECTION("sphere subdivisions") {
    require_error(scene_with_object("name = \"a\"\nshape = \"sphere\"\nradius = 1\nsubdivisions = 7\n"
                                    "[object.mass_spring]\n"),
                  "inline.toml:7:16: object[0].subdivisions: must be in [0, 6] (got 7)");
  }
  SECTION("infinite cell size") {
    require_error(scene_with_object("name = \"a\"\ncell_size = inf\n"),
                  "inline.toml:5:13: object[0].cell_size: must be finite (got inf)");
  }
  SECTION("negative uniform scale") {
    require_error(scene_with_object("name = \"a\"\nscale = -1\n"),
                  "inline.toml:5:9: object[0].scale: must be > 0 (got -1)");
  }
  SECTION("zero per-axis scale") {
    require_error(scene_with_object("name = \"a\"\nscale = [1, 0, 1]\n"),
                  "inline.toml:5:13: object[0].scale[1]: must be > 0 (got 0)");
  }
  SECTION("scale of the wrong type") {
    require_error(
        scene_with_object("name = \"a\"\nscale = \"big\"\n"),
        "inline.toml:5:9: object[0].scale: expected a number or an array [sx, sy, sz] (got a string)");
  }
  SECTION("boolean of the wrong type") {
    require_error(scene_with_object("name = \"a\"\nfill_interior = 1\n"),
                  "inline.toml:5:17: object[0].fill_interior: expected true or false (got an integer)");
  }
  SECTION("array element of the wrong type") {
    require_error(scene_with_object("name = \"a\"\nvelocity = [0, \"up\", 0]\n"),
                  "inline.toml:5:16: object[0].velocity[1]: expected a number (got a string)");
  }
  SECTION("unknown shape") {
    require_error(scene_with_object("name = \"a\"\nshape = \"spher\"\n[object.mass_spring]\n"),
                  "inline.toml:5:9: object[0].shape: unknown shape 'spher'; did you mean 'sphere'? (valid "
                  "shapes: box, sphere, torus, ring, bowl)");
  }
  SECTION("box without a size") {
    require_error(
        scene_with_object("name = \"a\"\nshape = \"box\"\n[object.mass_spring]\n"),
        "inline.toml:3:1: object[0].size: missing required key (shape = \"box\" needs size = [x, y, "
        "z] in m)");
  }
  SECTION("sphere key on a box") {
    require_error(scene_with_object("name = \"a\"\nshape = \"box\"\nsize = [1, 1, 1]\nradius = 1\n"
                                    "[object.mass_spring]\n"),
                  "inline.toml:7:10: object[0].radius: not used with shape = \"box\" (only with sphere, torus, "
                  "ring, bowl)");
  }
  SECTION("ring without a height") {
    require_error(scene_with_object("name = \"a\"\nshape = \"ring\"\nradius = 0.04\nthickness = 0.01\n"
                                    "[object.mass_spring]\n"),
                  "inline.toml:3:1: object[0].height: missing required key (shape = \"ring\" needs height in m)");
  }
  SECTION("a bowl's wall as thick as the bowl") {
    require_error(scene_with_object("name = \"a\"\nshape = \"bowl\"\nradius = 0.04\nthickness = 0.04\n"
                                    "[object.mass_spring]\n"),
                  "inline.toml:7:13: object[0].thickness: must be < radius (0.04 m; got 0.04)");
  }
  SECTION("a torus's segments out of range") {
    require_error(scene_with_object("name = \"a\"\nshape = \"torus\"\nradius = 0.04\nthickness = 0.01\n"
                                    "segments = 4\n[object.mass_spring]\n"),
                  "inline.toml:8:12: object[0].segments: must be in [8, 1024] (got 4)");
  }
  SECTION("a ring far taller than it is wide") {
    require_error(scene_with_object("name = \"a\"\nshape = \"ring\"\nradius = 0.01\nthickness = 0.005\n"
                                    "height = 1000\n[object.mass_spring]\n"),
                  "inline.toml:8:10: object[0].height: make_ring_mesh: the shape is too long for its radius (its "
                  "profile would need more than 2048 points)");
  }
  SECTION("height on a torus") {
    require_error(scene_with_object("name = \"a\"\nshape = \"torus\"\nradius = 0.04\nthickness = 0.01\n"
                                    "height = 0.01\n[object.mass_spring]\n"),
                  "inline.toml:8:10: object[0].height: not used with shape = \"torus\" (only with ring)");
  }
  SECTION("shape key on a mesh") {
    require_error(
        scene_with_object("name = \"a\"\nmesh = \"unreadable.stl\"\nradius = 1\n[object.mass_spring]\n"),
        "inline.toml:6:10: object[0].radius: only used with 'shape', not with 'mesh'");
  }
  SECTION("zero plane normal") {
    require_error("[simulation]\neffects = [\"planes\"]\n[[plane]]\nnormal = [0, 0, 0]\n",
                  "inline.toml:4:10: plane[0].normal: must be non-zero");
  }
  SECTION("plane with both offset and point") {
    require_error("[simulation]\neffects = [\"planes\"]\n[[plane]]\noffset = 1\npoint = [0, 1, 0]\n",
                  "inline.toml:5:9: plane[0].point: give either 'offset' or 'point', not both");
  }
}

TEST_CASE("probe and grab tables are read, and only with their effects", "[scene_loader]") {
  const ffd::SceneSpec scene = parse(
      "[simulation]\neffects = [\"probe\", \"grab\"]\n"
      "[probe]\nradius = 0.02\nmass = 0.1\ncoupling_stiffness = 500.0\ncoupling_damping = 3.0\nstart = [0.1, 0.2, 0.3]\n"
      "force_limit = 3.3\nforce_rate_limit = 0.5\nwatchdog_ms = 10.0\n"
      "[grab]\nstiffness = 50.0\ndamping = 1.5\n"
      "[[object]]\n" + kBoxLines);
  const ffd::ProbeSettings& p = scene.settings.probe;
  CHECK(p.radius == 0.02);
  CHECK(p.mass == 0.1);
  CHECK(p.coupling_stiffness == 500.0);
  CHECK(p.coupling_damping == 3.0);
  CHECK(p.start == ffd::Vec3(0.1, 0.2, 0.3));
  CHECK(p.force_limit == 3.3);
  CHECK(p.force_rate_limit == 0.5);
  CHECK(p.watchdog_ms == 10.0);
  CHECK(scene.settings.grab.stiffness == 50.0);
  CHECK(scene.settings.grab.damping == 1.5);
  require_error("[simulation]\neffects = [\"gravity\"]\n[probe]\nradius = 0.02\n[[object]]\n" + kBoxLines,
                "inline.toml:3:1: probe: [probe] is given but the \"probe\" effect is off; add \"probe\" to "
                "simulation.effects");
  require_error("[simulation]\neffects = [\"probe\"]\n[probe]\nradius = -1.0\n[[object]]\n" + kBoxLines,
                "inline.toml:4:10: probe.radius: must be > 0 (got -1)");
  require_error("[simulation]\neffects = [\"probe\"]\n[probe]\nwatchdog_ms = 0.0\n[[object]]\n" + kBoxLines,
                "inline.toml:4:15: probe.watchdog_ms: must be > 0 (got 0)");
  require_error("[simulation]\neffects = [\"grab\"]\n[grab]\nstifness = 1.0\n[[object]]\n" + kBoxLines,
                "inline.toml:4:1: grab.stifness: unknown key 'stifness'; did you mean 'stiffness'?");
}

TEST_CASE("sleep_radius and sleep_time are read, and only with the sleeping effect", "[scene_loader]") {
  const ffd::SceneSpec scene = parse(
      "[simulation]\neffects = [\"gravity\", \"sleeping\"]\nsleep_radius = 0.004\nsleep_time = 1.5\n[[object]]\n" +
      kBoxLines);
  CHECK(ffd::has(scene.settings.effects, ffd::Effect::Sleeping));
  CHECK(scene.settings.sleep_radius == 0.004);
  CHECK(scene.settings.sleep_time == 1.5);
  const ffd::SceneSpec defaults = parse("[simulation]\neffects = [\"sleeping\"]\n[[object]]\n" + kBoxLines);
  CHECK(defaults.settings.sleep_radius == 0.002);
  CHECK(defaults.settings.sleep_time == 0.3);
  require_error("[simulation]\neffects = [\"gravity\"]\nsleep_time = 1.0\n[[object]]\n" + kBoxLines,
                "inline.toml:3:14: simulation.sleep_time: sleep_time is given but the \"sleeping\" effect is off; "
                "add \"sleeping\" to simulation.effects");
  require_error("[simulation]\neffects = [\"sleeping\"]\nsleep_radius = 0.0\n[[object]]\n" + kBoxLines,
                "inline.toml:3:16: simulation.sleep_radius: must be in (0, 1] (got 0)");
}

// --- [[group]]: count copies on a grid with seeded random velocities, spins and rotations.

namespace {

// A scene whose [[group]] header is on line 4 and `group_lines` start on line 5.
std::string scene_with_group(const std::string& group_lines, int seed = 7) {
  return "[simulation]\neffects = []\nseed = " + std::to_string(seed) + "\n[[group]]\n" + group_lines;
}
// A box group body (lines 5..9) without `count` and `layout`; the next line is 10.
const std::string kBoxGroupLines =
    "name = \"g\"\nshape = \"box\"\nsize = [0.1, 0.1, 0.1]\ncell_size = 0.05\nmass_spring = {}\n";

std::string box_group(int count, const std::string& layout, const std::string& extra = "") {
  return kBoxGroupLines + "count = " + std::to_string(count) + "\nlayout = " + layout + "\n" + extra;
}

const std::string kFont = "/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf";

// glyph = { ... } with the given text and the other keys as in alphabets.toml (spacing
// coarser, so that the meshes are quick to make).
std::string glyph_line(const std::string& text, const std::string& font = kFont) {
  return "glyph = { text = \"" + text + "\", font = \"" + font +
         "\", em_size = 0.05, depth = 0.009, sample_spacing = 0.0005 }\n";
}

bool same_spec(const ffd::ObjectSpec& a, const ffd::ObjectSpec& b) {
  return a.name == b.name && a.source == b.source && a.position == b.position && a.rotation_deg == b.rotation_deg &&
         a.velocity == b.velocity && a.angular_velocity == b.angular_velocity && a.cell_size == b.cell_size &&
         a.mass == b.mass && a.subdivisions == b.subdivisions && a.mesh.vertices == b.mesh.vertices &&
         a.mesh.triangles == b.mesh.triangles;
}

}  // namespace

TEST_CASE("a group makes count objects named by an index zero-padded to the width of count - 1",
          "[scene_loader]") {
  const auto names = [](int count) {
    const ffd::SceneSpec scene = parse(scene_with_group(box_group(count, "{ grid = [200, 1, 1], spacing = [0.2, 0, 0] }")));
    std::vector<std::string> out;
    for (const ffd::ObjectSpec& object : scene.objects) out.push_back(object.name);
    REQUIRE(out.size() == static_cast<std::size_t>(count));
    return out;
  };
  CHECK(names(1) == std::vector<std::string>{"g_0"});
  CHECK(names(3) == std::vector<std::string>{"g_0", "g_1", "g_2"});
  const std::vector<std::string> ten = names(10);
  CHECK(ten.front() == "g_0");
  CHECK(ten.back() == "g_9");
  const std::vector<std::string> eleven = names(11);
  CHECK(eleven.front() == "g_00");
  CHECK(eleven[9] == "g_09");
  CHECK(eleven.back() == "g_10");
  const std::vector<std::string> hundred = names(100);
  CHECK(hundred.front() == "g_00");
  CHECK(hundred.back() == "g_99");
  const std::vector<std::string> hundred_one = names(101);
  CHECK(hundred_one.front() == "g_000");
  CHECK(hundred_one[42] == "g_042");
  CHECK(hundred_one.back() == "g_100");
}

TEST_CASE("every object of a group shares the group's description", "[scene_loader]") {
  const ffd::SceneSpec scene = parse(
      "[simulation]\neffects = []\n[[object]]\nname = \"solo\"\nshape = \"sphere\"\nradius = 0.1\n"
      "[object.mass_spring]\n[[group]]\nname = \"g\"\ncount = 3\nshape = \"box\"\nsize = [0.1, 0.2, 0.3]\n"
      "scale = 2\ncell_size = 0.04\nmass = 0.5\nfill_interior = true\nsubdivide = 1\nrotation_deg = [10, 20, 30]\n"
      "velocity = [1, 2, 3]\nangular_velocity = [4, 5, 6]\n"
      "layout = { grid = [3, 1, 1], spacing = [1, 0, 0] }\n[group.shape_matching]\nstiffness = 0.25\n");
  REQUIRE(scene.objects.size() == 4);
  CHECK(scene.objects[0].name == "solo");  // [[object]]s first, then the groups' objects
  // Scaled, in squares about a cell across (0.2 x 0.4 x 0.6 m in 4 cm cells).
  const ffd::SurfaceMesh box = ffd::make_box_mesh({0.2, 0.4, 0.6}, ffd::box_divisions({0.2, 0.4, 0.6}, 0.04));
  REQUIRE(box.triangles.size() == 4 * (5 * 10 + 10 * 15 + 15 * 5));
  for (std::size_t n = 1; n < 4; ++n) {
    const ffd::ObjectSpec& o = scene.objects[n];
    INFO(o.name);
    CHECK(o.name == "g_" + std::to_string(n - 1));
    CHECK(o.source == "box");
    CHECK(o.mesh.vertices == box.vertices);
    CHECK(o.mesh.triangles == box.triangles);
    CHECK(o.cell_size == 0.04);
    CHECK(o.mass == 0.5);
    CHECK(o.fill_interior);
    CHECK(o.subdivisions == 1);
    CHECK(o.dynamics == ffd::DynamicsKind::ShapeMatching);
    CHECK(o.shape_matching.stiffness == 0.25);
    // Without a [group.random] table nothing is drawn: the stated values, exactly.
    CHECK(o.rotation_deg == ffd::Vec3(10, 20, 30));
    CHECK(o.velocity == ffd::Vec3(1, 2, 3));
    CHECK(o.angular_velocity == ffd::Vec3(4, 5, 6));
  }
  // No centre: the grid is centred on the origin in x and z, the lowest layer at y = 0.
  CHECK(scene.objects[1].position == ffd::Vec3(-1, 0, 0));
  CHECK(scene.objects[2].position == ffd::Vec3(0, 0, 0));
  CHECK(scene.objects[3].position == ffd::Vec3(1, 0, 0));
}

TEST_CASE("a group fills its grid x first then z then up the layers in y", "[scene_loader]") {
  // 11 objects on a 2 x 3 x 2 grid (12 places). Spacings are binary fractions, so the
  // positions are exact: x = 1 -/+ 0.25, y = 2 + 0.25 j, z = 3 -/+ 0.375.
  const ffd::SceneSpec scene = parse(scene_with_group(
      box_group(11, "{ grid = [2, 3, 2], spacing = [0.5, 0.25, 0.75], centre = [1.0, 2.0, 3.0] }")));
  const std::vector<ffd::Vec3> expected = {
      {0.75, 2.0, 2.625},  {1.25, 2.0, 2.625},  {0.75, 2.0, 3.375},  {1.25, 2.0, 3.375},
      {0.75, 2.25, 2.625}, {1.25, 2.25, 2.625}, {0.75, 2.25, 3.375}, {1.25, 2.25, 3.375},
      {0.75, 2.5, 2.625},  {1.25, 2.5, 2.625},  {0.75, 2.5, 3.375}};
  REQUIRE(scene.objects.size() == expected.size());
  for (std::size_t n = 0; n < expected.size(); ++n) {
    INFO("object " << n);
    CHECK(scene.objects[n].position == expected[n]);
  }

  SECTION("odd rows are centred on their middle object") {
    const ffd::SceneSpec odd = parse(scene_with_group(
        box_group(9, "{ grid = [3, 1, 3], spacing = [0.5, 1.0, 0.25], centre = [0.0, 1.0, 0.0] }")));
    REQUIRE(odd.objects.size() == 9);
    CHECK(odd.objects[0].position == ffd::Vec3(-0.5, 1.0, -0.25));
    CHECK(odd.objects[1].position == ffd::Vec3(0.0, 1.0, -0.25));
    CHECK(odd.objects[4].position == ffd::Vec3(0.0, 1.0, 0.0));
    CHECK(odd.objects[8].position == ffd::Vec3(0.5, 1.0, 0.25));
  }
}

TEST_CASE("a group's random values come from the seed and stay within their bounds", "[scene_loader]") {
  const std::string random_group = box_group(
      40, "{ grid = [4, 5, 2], spacing = [0.2, 0.2, 0.2] }",
      "velocity = [1.0, -2.0, 0.5]\nangular_velocity = [0.1, 0.2, 0.3]\nrotation_deg = [10, 0, 0]\n"
      "random = { velocity = [0.5, 0.0, 0.25], angular_velocity = [0.0, 3.0, 0.0], rotation = true }\n");
  const ffd::SceneSpec first = parse(scene_with_group(random_group, 7));
  REQUIRE(first.objects.size() == 40);

  SECTION("the same seed gives identical objects") {
    const ffd::SceneSpec again = parse(scene_with_group(random_group, 7));
    REQUIRE(again.objects.size() == first.objects.size());
    for (std::size_t n = 0; n < first.objects.size(); ++n) CHECK(same_spec(first.objects[n], again.objects[n]));
  }
  SECTION("another seed gives other values") {
    const ffd::SceneSpec other = parse(scene_with_group(random_group, 8));
    REQUIRE(other.objects.size() == first.objects.size());
    std::size_t different = 0;
    for (std::size_t n = 0; n < first.objects.size(); ++n) {
      CHECK(other.objects[n].name == first.objects[n].name);
      CHECK(other.objects[n].position == first.objects[n].position);
      if (other.objects[n].velocity.x() != first.objects[n].velocity.x() &&
          other.objects[n].angular_velocity.y() != first.objects[n].angular_velocity.y() &&
          other.objects[n].rotation_deg != first.objects[n].rotation_deg)
        ++different;
    }
    CHECK(different == first.objects.size());
  }
  SECTION("each value lies within its bound of the stated value and zero bounds keep it exactly") {
    double widest_vx = 0.0, widest_vz = 0.0, widest_wy = 0.0, widest_rotation = 0.0;
    for (const ffd::ObjectSpec& o : first.objects) {
      INFO(o.name);
      REQUIRE(std::isfinite(o.velocity.sum()));
      REQUIRE(std::isfinite(o.angular_velocity.sum()));
      REQUIRE(std::isfinite(o.rotation_deg.sum()));
      CHECK(std::abs(o.velocity.x() - 1.0) <= 0.5);
      CHECK(o.velocity.y() == -2.0);
      CHECK(std::abs(o.velocity.z() - 0.5) <= 0.25);
      CHECK(o.angular_velocity.x() == 0.1);
      CHECK(std::abs(o.angular_velocity.y() - 0.2) <= 3.0);
      CHECK(o.angular_velocity.z() == 0.3);
      CHECK(std::abs(o.rotation_deg.x() - 10.0) <= 180.0);
      CHECK(std::abs(o.rotation_deg.y()) <= 180.0);
      CHECK(std::abs(o.rotation_deg.z()) <= 180.0);
      widest_vx = std::max(widest_vx, std::abs(o.velocity.x() - 1.0));
      widest_vz = std::max(widest_vz, std::abs(o.velocity.z() - 0.5));
      widest_wy = std::max(widest_wy, std::abs(o.angular_velocity.y() - 0.2));
      widest_rotation = std::max(widest_rotation, o.rotation_deg.cwiseAbs().maxCoeff());
    }
    // 40 draws spread over their ranges, not squeezed into a corner of them.
    CHECK(widest_vx > 0.25);
    CHECK(widest_vz > 0.125);
    CHECK(widest_wy > 1.5);
    CHECK(widest_rotation > 90.0);
    CHECK(first.objects[0].velocity != first.objects[1].velocity);
  }
  SECTION("zero bounds and rotation = false give exactly the stated values") {
    const ffd::SceneSpec fixed = parse(scene_with_group(box_group(
        6, "{ grid = [6, 1, 1], spacing = [0.2, 0.2, 0.2] }",
        "velocity = [1.0, -2.0, 0.5]\nangular_velocity = [0.1, 0.2, 0.3]\nrotation_deg = [10, 0, 0]\n"
        "random = { velocity = [0.0, 0.0, 0.0], angular_velocity = [0.0, 0.0, 0.0], rotation = false }\n")));
    for (const ffd::ObjectSpec& o : fixed.objects) {
      CHECK(o.velocity == ffd::Vec3(1.0, -2.0, 0.5));
      CHECK(o.angular_velocity == ffd::Vec3(0.1, 0.2, 0.3));
      CHECK(o.rotation_deg == ffd::Vec3(10, 0, 0));
    }
  }
  SECTION("two groups of one scene draw different values") {
    const ffd::SceneSpec two = parse(scene_with_group(random_group) + "[[group]]\n" +
                                     box_group(1, "{ grid = [1, 1, 1], spacing = [0, 0, 0] }",
                                               "random = { velocity = [0.5, 0.0, 0.25] }\n"));
    REQUIRE(two.objects.size() == 41);
    CHECK(two.objects[40].velocity.x() != first.objects[0].velocity.x());
  }
}

TEST_CASE("group errors name the file and line and column and field", "[scene_loader]") {
  const std::string layout = "{ grid = [2, 2, 2], spacing = [0.2, 0.2, 0.2] }";
  SECTION("missing count") {
    require_error(scene_with_group(kBoxGroupLines + "layout = " + layout + "\n"),
                  "inline.toml:4:1: group[0].count: missing required key (how many objects the group makes)");
  }
  SECTION("count out of range") {
    require_error(scene_with_group(box_group(0, layout)),
                  "inline.toml:10:9: group[0].count: must be in [1, 10000] (got 0)");
  }
  SECTION("missing layout") {
    require_error(scene_with_group(kBoxGroupLines + "count = 2\n"),
                  "inline.toml:4:1: group[0].layout: missing required key ([group[0].layout] with grid, "
                  "spacing and centre)");
  }
  SECTION("layout without a grid") {
    require_error(scene_with_group(box_group(2, "{ spacing = [0.2, 0.2, 0.2] }")),
                  "inline.toml:11:10: group[0].layout.grid: missing required key ([nx, ny, nz]: objects per "
                  "row, layers, rows)");
  }
  SECTION("layout without a spacing") {
    require_error(scene_with_group(box_group(2, "{ grid = [2, 1, 1] }")),
                  "inline.toml:11:10: group[0].layout.spacing: missing required key ([dx, dy, dz] in m)");
  }
  SECTION("a grid too small for the count") {
    require_error(scene_with_group(box_group(9, layout)),
                  "inline.toml:11:19: group[0].layout.grid: holds 8 places for 9 objects");
  }
  SECTION("a grid of fractions") {
    require_error(scene_with_group(box_group(2, "{ grid = [2.5, 1, 1], spacing = [0.2, 0.2, 0.2] }")),
                  "inline.toml:11:19: group[0].layout.grid: expected whole numbers");
  }
  SECTION("a grid with zero places along an axis") {
    require_error(scene_with_group(box_group(2, "{ grid = [2, 0, 1], spacing = [0.2, 0.2, 0.2] }")),
                  "inline.toml:11:23: group[0].layout.grid[1]: must be in [1, 10000] (got 0)");
  }
  SECTION("a negative spacing") {
    require_error(scene_with_group(box_group(2, "{ grid = [2, 1, 1], spacing = [0.2, -0.1, 0.2] }")),
                  "inline.toml:11:46: group[0].layout.spacing[1]: must be >= 0 (got -0.1)");
  }
  SECTION("an unknown key in the layout") {
    require_error(scene_with_group(box_group(2, "{ grid = [2, 1, 1], spacing = [0.2, 0.2, 0.2], center = [0, 0, 0] }")),
                  "inline.toml:11:57: group[0].layout.center: unknown key 'center'; did you mean 'centre'?");
  }
  SECTION("an unknown key in the random table") {
    require_error(scene_with_group(box_group(2, layout, "random = { spin = [1, 1, 1] }\n")),
                  "inline.toml:12:12: group[0].random.spin: unknown key 'spin' (valid keys: velocity, "
                  "angular_velocity, rotation)");
  }
  SECTION("a negative random bound") {
    require_error(scene_with_group(box_group(2, layout, "random = { velocity = [0.1, -0.1, 0.1] }\n")),
                  "inline.toml:12:29: group[0].random.velocity[1]: must be >= 0 (got -0.1)");
  }
  SECTION("a position in a group: positions come from the layout") {
    REQUIRE_THROWS_WITH(parse(scene_with_group(box_group(2, layout, "position = [0, 0, 0]\n"))),
                        StartsWith("inline.toml:12:1: group[0].position: unknown key 'position'"));
  }
}

TEST_CASE("a group's object names must not collide with other objects' names", "[scene_loader]") {
  // The error points at the group's name (its objects' names are made from it).
  const std::string group = box_group(2, "{ grid = [2, 1, 1], spacing = [1, 0, 0] }");
  const std::string object = "[[object]]\nname = \"g_1\"\nshape = \"box\"\nsize = [0.1, 0.1, 0.1]\nmass_spring = {}\n";
  const auto require_duplicate = [](const std::string& text, const std::string& position_and_name) {
    REQUIRE_THROWS_AS(parse(text), ffd::SceneError);
    REQUIRE_THROWS_WITH(parse(text), StartsWith("inline.toml:" + position_and_name + " (also ") &&
                                         Contains("); names must be unique"));
  };
  SECTION("with an object table after the group in the file") {
    require_duplicate(scene_with_group(group) + object, "5:8: group[0].name: duplicate name 'g_1'");
  }
  SECTION("with an object table before the group in the file") {
    require_duplicate("[simulation]\neffects = []\n" + object + "[[group]]\n" + group,
                      "9:8: group[0].name: duplicate name 'g_1'");
  }
  SECTION("with an earlier group's objects") {
    const std::string second = "[[group]]\n" + box_group(1, "{ grid = [1, 1, 1], spacing = [0, 0, 0] }");
    require_error(scene_with_group(group) + second,
                  "inline.toml:13:8: group[1].name: duplicate name 'g_0' (also group[0]); names must be unique");
  }
}

// --- glyph surfaces: extruded letters of a font.

TEST_CASE("an object with a one-letter glyph is an extruded letter of the given depth", "[scene_loader]") {
  const ffd::SceneSpec scene = parse(scene_with_object("name = \"a\"\n" + glyph_line("A") + "[object.mass_spring]\n"));
  REQUIRE(scene.objects.size() == 1);
  const ffd::ObjectSpec& a = scene.objects[0];
  CHECK(a.name == "a");  // no _A: that suffix is for groups
  CHECK(a.source == kFont + " U+0041");
  REQUIRE_FALSE(a.mesh.vertices.empty());
  REQUIRE_FALSE(a.mesh.triangles.empty());
  const auto [lo, hi] = ffd::mesh_bounds(a.mesh);
  CHECK(hi.z() - lo.z() == Approx(0.009).epsilon(1e-12));
  CHECK(hi.x() - lo.x() > 0.01);  // a capital of a 5 cm font: a few cm wide and high
  CHECK(hi.x() - lo.x() < 0.05);
  CHECK(hi.y() - lo.y() > 0.01);
  CHECK(hi.y() - lo.y() < 0.05);

  SECTION("a scaled copy of a glyph leaves the other objects' copies alone") {
    // The loader makes each glyph mesh once; scaling one object must not scale the others.
    const ffd::SceneSpec two = parse(
        "[simulation]\neffects = []\n[[object]]\nname = \"big\"\nscale = 2\n" + glyph_line("A") +
        "mass_spring = {}\n[[object]]\nname = \"plain\"\n" + glyph_line("A") + "mass_spring = {}\n");
    REQUIRE(two.objects.size() == 2);
    REQUIRE(two.objects[0].mesh.vertices.size() == a.mesh.vertices.size());
    CHECK(two.objects[1].mesh.vertices == a.mesh.vertices);
    for (std::size_t v = 0; v < a.mesh.vertices.size(); ++v)
      REQUIRE(two.objects[0].mesh.vertices[v] == 2.0 * a.mesh.vertices[v]);
  }
  SECTION("and it compiles") {
    const ffd::SceneSpec small = parse(
        scene_with_object("name = \"a\"\ncell_size = 0.012\n" + glyph_line("A") + "[object.mass_spring]\n"));
    std::vector<std::string> log;
    const ffd::Model model = ffd::compile(small, log);
    REQUIRE(model.objects.size() == 1);
    CHECK(model.cell_count() > 0);
  }
}

TEST_CASE("a glyph group cycles through the letters of its text", "[scene_loader]") {
  const ffd::SceneSpec scene = parse(scene_with_group(
      "name = \"g\"\ncount = 5\n" + glyph_line("IOL") + "mass_spring = {}\n"
      "layout = { grid = [5, 1, 1], spacing = [0.06, 0, 0] }\n"));
  REQUIRE(scene.objects.size() == 5);
  const std::vector<std::string> names = {"g_0_I", "g_1_O", "g_2_L", "g_3_I", "g_4_O"};
  const std::vector<std::string> codes = {"0049", "004F", "004C", "0049", "004F"};
  for (std::size_t n = 0; n < 5; ++n) {
    CHECK(scene.objects[n].name == names[n]);
    CHECK(scene.objects[n].source == kFont + " U+" + codes[n]);
    const auto [lo, hi] = ffd::mesh_bounds(scene.objects[n].mesh);
    CHECK(hi.z() - lo.z() == Approx(0.009).epsilon(1e-12));
  }
  // Object i gets letter i mod 3: objects 0 and 3 are the same I, and I, O, L differ.
  CHECK(scene.objects[0].mesh.vertices.size() == scene.objects[3].mesh.vertices.size());
  CHECK(scene.objects[0].mesh.vertices == scene.objects[3].mesh.vertices);
  CHECK(scene.objects[0].mesh.triangles == scene.objects[3].mesh.triangles);
  CHECK(scene.objects[1].mesh.vertices == scene.objects[4].mesh.vertices);
  CHECK(scene.objects[0].mesh.vertices.size() != scene.objects[1].mesh.vertices.size());
  CHECK(scene.objects[1].mesh.vertices.size() != scene.objects[2].mesh.vertices.size());
  CHECK(scene.objects[0].mesh.vertices.size() != scene.objects[2].mesh.vertices.size());

  SECTION("a letter that is no ASCII letter or digit adds no suffix") {
    const ffd::SceneSpec accented = parse(scene_with_group(
        "name = \"g\"\ncount = 2\n" + glyph_line("A\u00C9") + "mass_spring = {}\n"
        "layout = { grid = [2, 1, 1], spacing = [0.06, 0, 0] }\n"));
    REQUIRE(accented.objects.size() == 2);
    CHECK(accented.objects[0].name == "g_0_A");
    CHECK(accented.objects[1].name == "g_1");
    CHECK(accented.objects[1].source == kFont + " U+00C9");
  }
}

TEST_CASE("glyph errors name the file and line and column and field", "[scene_loader]") {
  SECTION("several letters in an object table") {
    require_error(scene_with_object("name = \"a\"\n" + glyph_line("AB") + "[object.mass_spring]\n"),
                  "inline.toml:5:9: object[0].glyph: an [[object]]'s glyph.text is one character (a [[group]] "
                  "cycles through several)");
  }
  SECTION("a missing font file") {
    require_error(scene_with_object("name = \"a\"\n" + glyph_line("A", "/no/such/font.ttf") + "[object.mass_spring]\n"),
                  "inline.toml:5:30: object[0].glyph.font: cannot find font file '/no/such/font.ttf' (Debian's "
                  "fonts-dejavu-core installs /usr/share/fonts/truetype/dejavu/)");
  }
  SECTION("a missing font file in a group") {
    REQUIRE_THROWS_WITH(
        parse(scene_with_group("name = \"g\"\ncount = 2\n" + glyph_line("AB", "/no/such/font.ttf") +
                               "mass_spring = {}\nlayout = { grid = [2, 1, 1], spacing = [0.06, 0, 0] }\n")),
        StartsWith("inline.toml:7:31: group[0].glyph.font: cannot find font file '/no/such/font.ttf'"));
  }
  SECTION("missing sizes") {
    const std::string head = "name = \"a\"\nglyph = { text = \"A\", font = \"" + kFont + "\"";
    require_error(scene_with_object(head + ", depth = 0.009, sample_spacing = 0.0005 }\n[object.mass_spring]\n"),
                  "inline.toml:5:9: object[0].glyph.em_size: missing required key (m: the font size)");
    require_error(scene_with_object(head + ", em_size = 0.05, sample_spacing = 0.0005 }\n[object.mass_spring]\n"),
                  "inline.toml:5:9: object[0].glyph.depth: missing required key (m: the extrusion)");
    require_error(scene_with_object(head + ", em_size = 0.05, depth = 0.009 }\n[object.mass_spring]\n"),
                  "inline.toml:5:9: object[0].glyph.sample_spacing: missing required key (m between outline "
                  "samples)");
  }
  SECTION("missing text") {
    require_error(scene_with_object("name = \"a\"\nglyph = { font = \"" + kFont +
                                    "\", em_size = 0.05, depth = 0.009, sample_spacing = 0.0005 }\n[object.mass_spring]\n"),
                  "inline.toml:5:9: object[0].glyph.text: missing required key (the character(s) to extrude)");
  }
  SECTION("an unknown key in the glyph table") {
    REQUIRE_THROWS_WITH(parse(scene_with_object("name = \"a\"\nglyph = { text = \"A\", size = 0.05 }\n[object.mass_spring]\n")),
                        StartsWith("inline.toml:5:23: object[0].glyph.size: unknown key 'size'"));
  }
  SECTION("a character the font does not have") {
    require_error(scene_with_object("name = \"a\"\n" + glyph_line("\\uE000") + "[object.mass_spring]\n"),
                  "inline.toml:5:18: object[0].glyph.text: " + kFont + ": no glyph for U+E000");
  }
  SECTION("a mesh and a glyph") {
    require_error(scene_with_object("name = \"a\"\nmesh = \"unreadable.stl\"\n" + glyph_line("A") + "[object.mass_spring]\n"),
                  "inline.toml:6:9: object[0].glyph: give one of 'mesh', 'shape' and 'glyph', not several");
    require_error(scene_with_object("name = \"a\"\n" + glyph_line("A") + "shape = \"box\"\n[object.mass_spring]\n"),
                  "inline.toml:6:9: object[0].shape: give one of 'mesh', 'shape' and 'glyph', not several");
  }
  SECTION("a shape key with a glyph") {
    require_error(scene_with_object("name = \"a\"\n" + glyph_line("A") + "size = [1, 1, 1]\n[object.mass_spring]\n"),
                  "inline.toml:6:8: object[0].size: only used with 'shape', not with 'glyph'");
  }
  SECTION("invalid UTF-8 in the text") {
    // The TOML parser already refuses invalid UTF-8 in a file...
    REQUIRE_THROWS_WITH(parse(scene_with_object("name = \"a\"\n" + glyph_line("\xC3(") + "[object.mass_spring]\n")),
                        StartsWith("inline.toml:5:"));
    // ... and the scene reader checks the text itself for tables built otherwise.
    const std::string bad_sequences[] = {"\xC3(", "\xFF", "A\xE2\x82", "\x80"};
    for (const std::string& bad : bad_sequences) {
      toml::table root = ffd::parse_toml(scene_with_object("name = \"a\"\n" + glyph_line("A") + "[object.mass_spring]\n"),
                                         "inline.toml");
      toml::table* glyph = root["object"][0]["glyph"].as_table();
      REQUIRE(glyph != nullptr);
      glyph->insert_or_assign("text", bad);
      REQUIRE_THROWS_AS(ffd::read_scene_table(root, "inline.toml", kFixtureDir), ffd::SceneError);
      REQUIRE_THROWS_WITH(ffd::read_scene_table(root, "inline.toml", kFixtureDir),
                          Catch::Matchers::EndsWith("object[0].glyph.text: is not valid UTF-8"));
    }
  }
}

// --- angular_velocity: the initial spin about each object's centre of mass.

TEST_CASE("angular_velocity spins each object about its lattice's centre of mass", "[scene_loader]") {
  const ffd::SceneSpec spec = parse(
      "[simulation]\neffects = []\n"
      "[[object]]\nname = \"spinning\"\nshape = \"box\"\nsize = [0.1, 0.1, 0.1]\ncell_size = 0.025\nmass = 2.0\n"
      "position = [1.0, 2.0, -0.5]\nrotation_deg = [30, 40, 50]\nvelocity = [0.5, -1.0, 0.25]\n"
      "angular_velocity = [3.0, -2.0, 5.0]\n[object.mass_spring]\n"
      "[[object]]\nname = \"still\"\nshape = \"sphere\"\nradius = 0.05\nsubdivisions = 2\ncell_size = 0.025\n"
      "position = [-1.0, 0.5, 0.0]\nvelocity = [0.1, 0.2, 0.3]\n[object.mass_spring]\n"
      "[[object]]\nname = \"zero\"\nshape = \"box\"\nsize = [0.1, 0.1, 0.1]\ncell_size = 0.025\n"
      "position = [0.0, 0.0, 3.0]\nrotation_deg = [0, 0, 20]\nvelocity = [-0.5, 0.0, 0.5]\n"
      "angular_velocity = [0.0, 0.0, 0.0]\n[object.mass_spring]\n");
  REQUIRE(spec.objects.size() == 3);
  CHECK(spec.objects[0].angular_velocity == ffd::Vec3(3.0, -2.0, 5.0));
  CHECK(spec.objects[1].angular_velocity == ffd::Vec3::Zero());  // the default
  std::vector<std::string> log;
  const ffd::Model model = ffd::compile(spec, log);
  const ffd::State state = ffd::initial_state(model);
  REQUIRE(model.objects.size() == 3);
  REQUIRE(state.v.size() == model.node_count());

  const ffd::ObjectModel& box = model.objects[0];
  const ffd::Vec3 v0(0.5, -1.0, 0.25), w(3.0, -2.0, 5.0);
  double mass = 0.0;
  ffd::Vec3 centre = ffd::Vec3::Zero();
  for (ffd::Index n = box.node_begin; n < box.node_end; ++n) {
    mass += model.node_mass[n];
    centre += model.node_mass[n] * state.x[n];
  }
  centre /= mass;
  CHECK(mass == Approx(2.0).epsilon(1e-12));
  CHECK((centre - ffd::Vec3(1.0, 2.0, -0.5)).norm() < 1e-12);  // a symmetric lattice: its centre is the box's

  ffd::Vec3 momentum = ffd::Vec3::Zero(), angular_momentum = ffd::Vec3::Zero();
  double largest_spin_speed = 0.0;
  for (ffd::Index n = box.node_begin; n < box.node_end; ++n) {
    const ffd::Vec3 r = state.x[n] - centre;
    const ffd::Vec3 expected = v0 + w.cross(r);
    REQUIRE(std::isfinite(state.v[n].sum()));
    CHECK((state.v[n] - expected).norm() <= 1e-12 * expected.norm());
    momentum += model.node_mass[n] * state.v[n];
    angular_momentum += model.node_mass[n] * r.cross(state.v[n]);
    largest_spin_speed = std::max(largest_spin_speed, (state.v[n] - v0).norm());
  }
  CHECK(largest_spin_speed > 0.1);  // |w| * half the box diagonal is about 0.5 m/s
  // The spin adds no linear momentum...
  CHECK((momentum - mass * v0).norm() <= 1e-12 * (mass * v0).norm());
  // ... and for a cube-symmetric body L = I w with I a multiple of the identity: along w.
  REQUIRE(angular_momentum.norm() > 0.0);
  CHECK(angular_momentum.normalized().dot(w.normalized()) == Approx(1.0).epsilon(1e-9));
  CHECK(angular_momentum.cross(w).norm() <= 1e-9 * angular_momentum.norm() * w.norm());

  // Without a spin (absent or zero) every node has exactly the object's velocity.
  for (std::size_t i : {std::size_t{1}, std::size_t{2}}) {
    const ffd::ObjectModel& o = model.objects[i];
    REQUIRE(o.node_end > o.node_begin);
    for (ffd::Index n = o.node_begin; n < o.node_end; ++n) REQUIRE(state.v[n] == spec.objects[i].velocity);
  }
}

// --- subdivide: 1-to-4 midpoint subdivision of the cleaned mesh, 0..3 times.

TEST_CASE("subdivide refines the compiled surface 4x per level", "[scene_loader]") {
  auto compiled_triangles = [](const std::string& extra) {
    const ffd::SceneSpec spec = parse(scene_with_object(
        "name = \"a\"\nshape = \"sphere\"\nradius = 0.1\nsubdivisions = 1\ncell_size = 0.05\n" + extra +
        "[object.mass_spring]\n"));
    std::vector<std::string> log;
    const ffd::Model model = ffd::compile(spec, log);
    REQUIRE(model.objects.size() == 1);
    return std::make_pair(spec.objects[0].subdivisions, model.objects[0].surface.triangles.size());
  };
  CHECK(compiled_triangles("") == std::make_pair(0, std::size_t{80}));  // the default: none
  CHECK(compiled_triangles("subdivide = 0\n") == std::make_pair(0, std::size_t{80}));
  CHECK(compiled_triangles("subdivide = 1\n") == std::make_pair(1, std::size_t{320}));
  CHECK(compiled_triangles("subdivide = 2\n") == std::make_pair(2, std::size_t{1280}));
  CHECK(compiled_triangles("subdivide = 3\n") == std::make_pair(3, std::size_t{5120}));

  SECTION("of the cleaned mesh and not the raw one") {
    // A box with a duplicated triangle: clean-up drops it, then the 12 left become 48.
    // A box in one cell, so that its faces are single squares.
    ffd::SceneSpec spec = parse(scene_with_object(
        "name = \"block\"\nshape = \"box\"\nsize = [0.1, 0.1, 0.1]\ncell_size = 0.1\n[object.mass_spring]\n"));
    REQUIRE(spec.objects[0].mesh.triangles.size() == 12);
    spec.objects[0].mesh.triangles.push_back(spec.objects[0].mesh.triangles.front());
    spec.objects[0].subdivisions = 1;
    std::vector<std::string> log;
    const ffd::Model model = ffd::compile(spec, log);
    CHECK(model.objects[0].surface.triangles.size() == 48);
    CHECK(model.objects[0].surface.vertices.size() == 26);
  }
  SECTION("compile rejects an out-of-range level in a spec built in code") {
    ffd::SceneSpec spec = parse(scene_with_object(kBoxLines));
    spec.objects[0].subdivisions = 4;
    std::vector<std::string> log;
    REQUIRE_THROWS_AS(ffd::compile(spec, log), ffd::CompileError);
    REQUIRE_THROWS_WITH(ffd::compile(spec, log), Equals("object 'block'.subdivide: must be in 0..3"));
  }
}

TEST_CASE("a box's faces are grids of squares about a cell across, counted against the limits first", "[scene_loader]") {
  const auto box = [](const std::string& lines) {
    return scene_with_object("name = \"a\"\nshape = \"box\"\n" + lines + "\n[object.mass_spring]\n");
  };
  // 10 x 5 x 20 cm in 2.5 cm cells: 4 x 2 x 8 squares, two triangles each; the grid points
  // on the surface are shared by the faces that meet there.
  const ffd::SceneSpec plain = parse(box("size = [0.1, 0.05, 0.2]\ncell_size = 0.025"));
  CHECK(plain.objects[0].mesh.triangles.size() == 4 * (4 * 2 + 2 * 8 + 8 * 4));
  CHECK(plain.objects[0].mesh.vertices.size() == 5 * 3 * 9 - 3 * 1 * 7);
  CHECK(ffd::is_closed_and_consistent(plain.objects[0].mesh));
  // Scaled first: twice the size, twice the squares an edge.
  const ffd::SceneSpec scaled = parse(box("size = [0.1, 0.05, 0.2]\nscale = 2\ncell_size = 0.025"));
  CHECK(scaled.objects[0].mesh.triangles.size() == 4 * (8 * 4 + 4 * 16 + 16 * 8));
  // A thin box is one square thick; a cell larger than the box leaves faces of one square.
  CHECK(parse(box("size = [0.1, 0.001, 0.1]\ncell_size = 0.025")).objects[0].mesh.triangles.size() ==
        4 * (4 * 1 + 1 * 4 + 4 * 4));
  CHECK(parse(box("size = [0.1, 0.1, 0.1]\ncell_size = 1.0")).objects[0].mesh.triangles.size() == 12);
  // Too many squares is refused by the key that asks for them, before any is built.
  REQUIRE_THROWS_WITH(parse(box("size = [0.1, 0.1, 0.1]\ncell_size = 0.00001")),
                      Contains("inline.toml:") && Contains("object[0].cell_size: a box of 0.1 x 0.1 x 0.1 m") &&
                          Contains("more than 4096 squares an edge"));
  REQUIRE_THROWS_WITH(parse(box("size = [1, 1, 1]\ncell_size = 0.0005")),
                      Contains("object[0].cell_size: a box of 1 x 1 x 1 m") &&
                          Contains("triangles (at most 4096 squares an edge and 5000000 triangles per object)"));
}

TEST_CASE("subdivide out of range names the file and line and column and field", "[scene_loader]") {
  const auto with = [](const std::string& line) {
    return scene_with_object("name = \"a\"\nshape = \"box\"\nsize = [0.1, 0.1, 0.1]\n" + line + "\n[object.mass_spring]\n");
  };
  require_error(with("subdivide = 4"), "inline.toml:7:13: object[0].subdivide: must be in [0, 3] (got 4)");
  require_error(with("subdivide = -1"), "inline.toml:7:13: object[0].subdivide: must be in [0, 3] (got -1)");
  require_error(with("subdivide = 1.0"),
                "inline.toml:7:13: object[0].subdivide: expected an integer (got a floating-point number)");
  require_error(with("subdivide = true"), "inline.toml:7:13: object[0].subdivide: expected an integer (got a boolean)");
  // In a group too.
  require_error(scene_with_group(box_group(2, "{ grid = [2, 1, 1], spacing = [1, 0, 0] }", "subdivide = 4\n")),
                "inline.toml:12:13: group[0].subdivide: must be in [0, 3] (got 4)");
}

TEST_CASE("a cell so large that no triangle has an area in it is refused, naming the file", "[scene_loader]") {
  // Areas are measured in cells: a 1.2 m box in 3.3e30 m cells leaves no cell with surface,
  // and so no cell to bind the vertices to (a fuzzer's find).
  const ffd::SceneSpec spec = parse(scene_with_object(
      "name = \"box\"\nshape = \"box\"\nsize = [1.2, 0.1, 0.1]\ncell_size = 3.3e30\n[object.mass_spring]\n"));
  std::vector<std::string> log;
  REQUIRE_THROWS_AS(ffd::compile(spec, log), ffd::CompileError);
  REQUIRE_THROWS_WITH(ffd::compile_scene(spec, "inline.toml", log),
                      Equals("inline.toml: object 'box'.cell_size: no triangle has an area at cell size 3.3e+30 m for "
                             "a mesh of extent 1.2 m; use a cell_size nearer the mesh's size"));
  REQUIRE_THROWS_AS(ffd::compile_scene(spec, "inline.toml", log), ffd::SceneError);
}

TEST_CASE("scene limits turn oversized scenes into errors naming the limit", "[scene_loader]") {
  const auto box_object = [](const std::string& size, const std::string& cell_size, const std::string& extra = "") {
    return scene_with_object("name = \"b\"\nshape = \"box\"\nsize = " + size + "\ncell_size = " + cell_size + "\n" +
                             extra + "[object.mass_spring]\n");
  };
  const auto sphere_group = [](int count, int subdivide) {
    return scene_with_group("name = \"s\"\nshape = \"sphere\"\nradius = 0.1\nsubdivisions = 6\nsubdivide = " +
                            std::to_string(subdivide) + "\ncount = " + std::to_string(count) +
                            "\nlayout = { grid = [10, 1, 1], spacing = [0.3, 0, 0] }\nmass_spring = {}\n");
  };
  SECTION("a lattice over the per-object limit") {
    // 2^-7 m cells over 1 m: 129^3 = 2,146,689 cells.
    require_error(box_object("[1.0, 1.0, 1.0]", "0.0078125"),
                  "inline.toml:7:13: object[0].cell_size: cell_size 0.0078125 m over a surface of 1 x 1 x 1 m "
                  "makes a lattice of up to 2146689 cells, more than the limit of 1000000 per object; use a larger "
                  "cell_size");
    // A sphere: a box that fine is refused for its squares first.
    REQUIRE_THROWS_WITH(parse(scene_with_object("name = \"s\"\nshape = \"sphere\"\nradius = 0.5\ncell_size = 1e-300\n"
                                                "[object.mass_spring]\n")),
                        Contains("object[0].cell_size: cell_size 1e-300 m over a surface of ") &&
                            Contains("makes a lattice of more cells than the limit of 1000000 per object"));
  }
  SECTION("lattices over the per-scene limit") {
    // 2^-6 m cells over 1 m boxes: 65^3 = 274,625 cells each, 8 of them.
    const std::string group = "name = \"g\"\nshape = \"box\"\nsize = [1, 1, 1]\ncell_size = 0.015625\ncount = 8\n"
                              "layout = { grid = [8, 1, 1], spacing = [2, 0, 0] }\nmass_spring = {}\n";
    require_error(scene_with_group(group),
                  "inline.toml:8:13: group[0].cell_size: the scene's objects have lattices of up to 2197000 cells "
                  "so far, more than the limit of 2000000 per scene; use a larger cell_size");
  }
  SECTION("triangles over the per-object limit after subdivision") {
    // An icosphere of 6 subdivisions has 81,920 triangles; 3 more 1-to-4 rounds give 5,242,880.
    require_error(sphere_group(1, 3),
                  "inline.toml:9:13: group[0].subdivide: the surface has 5242880 triangles after subdivision (81920 "
                  "before), more than the limit of 5000000 per object");
  }
  SECTION("triangles over the per-scene limit") {
    // 8 objects of 1,310,720 triangles.
    require_error(sphere_group(8, 2),
                  "inline.toml:6:9: group[0].shape: the scene's objects have 10485760 triangles so far, more than "
                  "the limit of 10000000 per scene");
  }
  SECTION("triangle-cell pairs over the per-scene limit") {
    // 2^-3 m cells over a 1 m box: a 9^3 grid; each face is 8 x 8 squares of a cell, and each of
    // their 768 triangles' bounding boxes spans 2 x 2 cells of the grid.
    ffd::SceneLimits limits;
    limits.scene_triangle_cells = 900;
    REQUIRE_THROWS_WITH(ffd::parse_scene(box_object("[1.0, 1.0, 1.0]", "0.125"), "inline.toml", kFixtureDir, limits),
                        Equals("inline.toml:7:13: object[0].cell_size: building the lattices means clipping 3072 "
                               "triangle-cell pairs so far (each triangle against every cell of its bounding box), "
                               "more than the limit of 900 per scene; use a larger cell_size"));
  }
  SECTION("shape-matching region members over the per-scene limit") {
    // A 9^3 grid has 10^3 nodes, each with a region of 3^3 nodes.
    ffd::SceneLimits limits;
    limits.scene_region_members = 20'000;
    const std::string text = scene_with_object("name = \"b\"\nshape = \"box\"\nsize = [1, 1, 1]\ncell_size = 0.125\n"
                                               "[object.shape_matching]\nregion_half_width = 1\n");
    REQUIRE_THROWS_WITH(ffd::parse_scene(text, "inline.toml", kFixtureDir, limits),
                        Equals("inline.toml:8:1: object[0].shape_matching: shape-matching regions of up to 27000 "
                               "lattice nodes in all so far (each node's region spans (2w+1)^3), more than the limit "
                               "of 20000 per scene; use a smaller region_half_width or a larger cell_size"));
  }
  SECTION("more objects than the limit") {
    require_error(scene_with_group(box_group(10001, "{ grid = [10001, 1, 1], spacing = [0.2, 0, 0] }")),
                  "inline.toml:10:9: group[0].count: must be in [1, 10000] (got 10001)");
    require_error(scene_with_object(kBoxLines) + "[[group]]\n" +
                      box_group(10000, "{ grid = [10000, 1, 1], spacing = [0.2, 0, 0] }"),
                  "inline.toml:16:9: group[0].count: 10000 objects would make 10001 in the scene; the limit is "
                  "10000 per scene");
    ffd::SceneLimits three;
    three.objects = 3;
    std::string four = scene_with_object(kBoxLines);
    for (const char* name : {"c", "d", "e"}) four += "[[object]]\n" + std::string(kBoxLines).replace(8, 5, name);
    REQUIRE_THROWS_WITH(ffd::parse_scene(four, "inline.toml", kFixtureDir, three),
                        Equals("inline.toml:24:1: object[3]: the scene has more than 3 objects (the limit)"));
  }
  SECTION("a glyph text over the limit") {
    require_error(scene_with_group("name = \"g\"\ncount = 2\n" + glyph_line(std::string(257, 'A')) +
                                   "mass_spring = {}\nlayout = { grid = [2, 1, 1], spacing = [0.06, 0, 0] }\n"),
                  "inline.toml:7:18: group[0].glyph.text: has 257 characters, more than the limit of 256");
  }
  SECTION("glyph samples per em over the limit") {
    // 2^-4 m over 2^-16 m: 4,096 samples per em.
    const std::string glyph = "glyph = { text = \"A\", font = \"" + kFont +
                              "\", em_size = 0.0625, depth = 0.009, sample_spacing = 0.0000152587890625 }\n";
    require_error(scene_with_object("name = \"a\"\n" + glyph + "[object.mass_spring]\n"),
                  "inline.toml:5:" + std::to_string(glyph.find("0.0000152") + 1) +
                      ": object[0].glyph.sample_spacing: em_size / sample_spacing is 4096, more than the limit of "
                      "2000; use a larger sample_spacing");
  }
}

TEST_CASE("simulation.response picks the contact response, and an unknown one names the file and field",
          "[scene_loader]") {
  const std::string head = "[simulation]\neffects = [\"planes\"]\nresponse = ";
  const std::string tail = "\n[[plane]]\n[[object]]\nname = \"b\"\nshape = \"sphere\"\nradius = 0.1\nshape_matching = {}\n";
  CHECK(parse(head + "\"solver\"" + tail).settings.response == ffd::ContactResponse::Solver);
  CHECK(parse(head + "\"paper\"" + tail).settings.response == ffd::ContactResponse::Paper);
  CHECK_THROWS_WITH(parse(head + "\"springs\"" + tail),
                    "inline.toml:3:12: simulation.response: unknown response 'springs' (valid: \"paper\", \"solver\")");
  CHECK_THROWS_WITH(parse(head + "1" + tail), Catch::Matchers::Contains("simulation.response: expected a string"));
  // rolling_resistance (the solver's): read, default 0.2, never negative.
  const std::string rolling = "[simulation]\neffects = [\"planes\"]\nrolling_resistance = ";
  CHECK(parse(rolling + "0.35" + tail).settings.rolling_resistance == 0.35);
  CHECK(parse(head + "\"solver\"" + tail).settings.rolling_resistance == 0.2);
  CHECK_THROWS_WITH(parse(rolling + "-0.1" + tail),
                    "inline.toml:3:22: simulation.rolling_resistance: must be >= 0 (got -0.1)");
  // box_overlap: off unless asked for; a boolean.
  const std::string overlap = "[simulation]\neffects = [\"planes\"]\nbox_overlap = ";
  CHECK_FALSE(parse(head + "\"paper\"" + tail).settings.box_overlap);
  CHECK(parse(overlap + "true" + tail).settings.box_overlap);
  CHECK_FALSE(parse(overlap + "false" + tail).settings.box_overlap);
  CHECK_THROWS_WITH(parse(overlap + "1" + tail), "inline.toml:3:15: simulation.box_overlap: expected true or false (got an integer)");
}
