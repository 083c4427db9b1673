// Scene files -> SceneSpec: the shipped scenes load with the values they state, optional keys
// take their documented defaults, and every malformed scene is rejected with a message that
// names the exact file, line, column and field.
#include "ffd/scene_loader.h"

#include <catch2/catch.hpp>
#include <string>
#include <vector>

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
  CHECK(scene.settings.hash_table_size == 4000);
  CHECK(scene.settings.hash_cell_size == 0.0);
  CHECK(scene.settings.min_box_thickness == 0.1);
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
                          "(valid effects: gravity, planes, inter_collision, self_collision, friction, probe, grab)");
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
        "seed, effects, hash_table_size, hash_cell_size, min_box_thickness)");
  }
  SECTION("the first unknown key in file order is reported") {
    require_error(
        "[simulation]\nwind = 1\neffects = []\nalpha_ = 1\n",
        "inline.toml:2:1: simulation.wind: unknown key 'wind' (valid keys: dt, gravity, alpha, beta, "
        "seed, effects, hash_table_size, hash_cell_size, min_box_thickness)");
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
                  "inline.toml:3:1: object[0]: needs a surface: 'mesh' (a file path), 'shape' (\"box\" or "
                  "\"sphere\") or 'glyph' (a letter of a font)");
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
    require_error("[simulation]\nhash_table_size = 0\neffects = []\n",
                  "inline.toml:2:19: simulation.hash_table_size: must be in [1, 10000000] (got 0)");
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
                  "shapes: box, sphere)");
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
                  "inline.toml:7:10: object[0].radius: only used with shape = \"sphere\"");
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
      "[grab]\nstiffness = 50.0\ndamping = 1.5\n"
      "[[object]]\n" + kBoxLines);
  const ffd::ProbeSettings& p = scene.settings.probe;
  CHECK(p.radius == 0.02);
  CHECK(p.mass == 0.1);
  CHECK(p.coupling_stiffness == 500.0);
  CHECK(p.coupling_damping == 3.0);
  CHECK(p.start == ffd::Vec3(0.1, 0.2, 0.3));
  CHECK(scene.settings.grab.stiffness == 50.0);
  CHECK(scene.settings.grab.damping == 1.5);
  require_error("[simulation]\neffects = [\"gravity\"]\n[probe]\nradius = 0.02\n[[object]]\n" + kBoxLines,
                "inline.toml:3:1: probe: [probe] is given but the \"probe\" effect is off; add \"probe\" to "
                "simulation.effects");
  require_error("[simulation]\neffects = [\"probe\"]\n[probe]\nradius = -1.0\n[[object]]\n" + kBoxLines,
                "inline.toml:4:10: probe.radius: must be > 0 (got -1)");
  require_error("[simulation]\neffects = [\"grab\"]\n[grab]\nstifness = 1.0\n[[object]]\n" + kBoxLines,
                "inline.toml:4:1: grab.stifness: unknown key 'stifness'; did you mean 'stiffness'?");
}
