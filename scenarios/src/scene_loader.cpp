// TOML scene files -> SceneSpec. The format is documented in scenarios/SCENE_FORMAT.md.
// The loader is strict: unknown keys, wrong types, wrong lengths and out-of-range values
// are all errors, each naming FILE:LINE:COL and the dotted field, so a typo in a scene
// never silently falls back to a default.
#include "ffd/scene_loader.h"


#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string_view>
#include <vector>

#include "ffd/mesh_import.h"
#include "ffd/toml_reader.h"

namespace ffd {
namespace {

const std::vector<std::string_view> kRootKeys = {"simulation", "plane", "object", "probe", "grab"};
const std::vector<std::string_view> kProbeKeys = {"radius", "mass", "coupling_stiffness", "coupling_damping",
                                                  "start"};
const std::vector<std::string_view> kGrabKeys = {"stiffness", "damping"};
const std::vector<std::string_view> kSimulationKeys = {
    "dt",      "gravity",         "alpha",          "beta", "seed",
    "effects", "hash_table_size", "hash_cell_size", "min_box_thickness"};
const std::vector<std::string_view> kPlaneKeys = {"name", "normal", "offset", "point"};
const std::vector<std::string_view> kObjectKeys = {
    "name",         "mesh",          "shape",         "size",           "radius",
    "subdivisions", "scale",         "position",      "rotation_deg",   "velocity",
    "cell_size",    "mass",          "fill_interior", "weld_tolerance", "min_component_fraction",
    "mass_spring",  "shape_matching"};
const std::vector<std::string_view> kMassSpringKeys = {"stiffness", "damping", "iterations"};
const std::vector<std::string_view> kShapeMatchingKeys = {"stiffness", "region_half_width", "damping"};
const std::vector<std::string_view> kShapeNames = {"box", "sphere"};

bool contains(const std::vector<std::string_view>& words, std::string_view word) {
  return std::find(words.begin(), words.end(), word) != words.end();
}

std::vector<std::string_view> all_effect_names() {
  std::vector<std::string_view> names;
  for (const Effect e : kAllEffects) names.emplace_back(effect_name(e));
  return names;
}

class SceneReader {
 public:
  SceneReader(const std::string& origin, const std::string& base_dir)
      : origin_(origin), base_dir_(base_dir) {}

  SceneSpec read(const toml::table& root_table) {
    const TableReader root(origin_, root_table, "", kRootKeys, [](std::string_view key) -> std::string {
      if (contains(kSimulationKeys, key)) return "it belongs in the [simulation] table";
      if (contains(kObjectKeys, key)) return "it belongs in an [[object]] table";
      return "";
    });
    SceneSpec scene;
    scene.name = std::filesystem::path(origin_).stem().string();

    const toml::table* simulation = root.subtable("simulation");
    if (!simulation)
      root.fail_here("simulation", "missing required table [simulation]; it must list at least 'effects'");
    scene.settings = read_simulation(*simulation);
    read_interaction(root, scene.settings);

    const auto planes = array_of_tables(root, "plane");
    if (!planes.empty() && !has(scene.settings.effects, Effect::Planes)) {
      root.fail(planes.front()->source(), "plane[0]",
                "planes are declared but the \"planes\" effect is off; add \"planes\" to simulation.effects "
                "(or remove the [[plane]] tables)");
    }
    for (std::size_t i = 0; i < planes.size(); ++i) scene.planes.push_back(read_plane(*planes[i], i));

    const auto objects = array_of_tables(root, "object");
    if (objects.empty()) root.fail_here("object", "a scene needs at least one [[object]] table");
    for (std::size_t i = 0; i < objects.size(); ++i) scene.objects.push_back(read_object(*objects[i], i));
    return scene;
  }

 private:
  SimulationSettings read_simulation(const toml::table& table) const {
    const TableReader sim(origin_, table, "simulation", kSimulationKeys);
    SimulationSettings settings;
    settings.dt = sim.number("dt", settings.dt, Bounds{0.0, 0.01, true, false});
    settings.gravity = sim.vec3("gravity", settings.gravity);
    settings.alpha = sim.number("alpha", settings.alpha, kUnitInterval);
    settings.beta = sim.number("beta", settings.beta, kUnitInterval);
    settings.seed = static_cast<std::uint64_t>(sim.integer("seed", static_cast<std::int64_t>(settings.seed),
                                                           0, std::numeric_limits<std::int64_t>::max()));
    settings.hash_table_size =
        static_cast<int>(sim.integer("hash_table_size", settings.hash_table_size, 1, 10'000'000));
    settings.hash_cell_size = sim.number("hash_cell_size", settings.hash_cell_size, kNonNegative);
    settings.min_box_thickness = sim.number("min_box_thickness", settings.min_box_thickness, kUnitInterval);
    settings.effects = read_effects(sim);
    return settings;
  }

  // [probe] and [grab]: settings of the interaction effects, only with those effects on.
  void read_interaction(const TableReader& root, SimulationSettings& settings) const {
    if (const toml::table* table = root.subtable("probe")) {
      if (!has(settings.effects, Effect::Probe))
        root.fail_at("probe", "[probe] is given but the \"probe\" effect is off; add \"probe\" to simulation.effects");
      const TableReader probe(origin_, *table, "probe", kProbeKeys);
      ProbeSettings& p = settings.probe;
      p.radius = probe.number("radius", p.radius, kPositive);
      p.mass = probe.number("mass", p.mass, kPositive);
      p.coupling_stiffness = probe.number("coupling_stiffness", p.coupling_stiffness, kNonNegative);
      p.coupling_damping = probe.number("coupling_damping", p.coupling_damping, kNonNegative);
      p.start = probe.vec3("start", p.start);
    }
    if (const toml::table* table = root.subtable("grab")) {
      if (!has(settings.effects, Effect::Grab))
        root.fail_at("grab", "[grab] is given but the \"grab\" effect is off; add \"grab\" to simulation.effects");
      const TableReader grab(origin_, *table, "grab", kGrabKeys);
      settings.grab.stiffness = grab.number("stiffness", settings.grab.stiffness, kNonNegative);
      settings.grab.damping = grab.number("damping", settings.grab.damping, kNonNegative);
    }
  }

  EffectSet read_effects(const TableReader& sim) const {
    // Required so that a scene states what it simulates rather than inheriting a default.
    if (!sim.has("effects"))
      sim.fail_missing("effects", " (list the effects, e.g. [\"gravity\", \"planes\"], or [])");
    const toml::node& node = *sim.find("effects");
    const auto* array = node.as_array();
    if (!array) sim.fail_at("effects", "expected an array of effect names (got " + describe_type(node) + ")");
    const std::vector<std::string_view> valid = all_effect_names();
    EffectSet effects = 0;
    for (std::size_t i = 0; i < array->size(); ++i) {
      const toml::node& element = *array->get(i);
      const std::string field = sim.field("effects") + "[" + std::to_string(i) + "]";
      const auto* name = element.as_string();
      if (!name)
        sim.fail(element.source(), field, "expected an effect name (got " + describe_type(element) + ")");
      Effect effect{};
      if (!effect_from_name(name->get(), effect)) {
        std::string problem = "unknown effect " + in_quotes(name->get());
        if (const auto suggestion = closest_match(name->get(), valid)) {
          problem += "; did you mean " + in_quotes(*suggestion) + "?";
        }
        sim.fail(element.source(), field, problem + " (valid effects: " + join(valid) + ")");
      }
      if (has(effects, effect))
        sim.fail(element.source(), field, "effect " + in_quotes(name->get()) + " is listed twice");
      effects = effects | effect;
    }
    return effects;
  }

  PlaneSpec read_plane(const toml::table& table, std::size_t index) {
    const TableReader plane(origin_, table, "plane[" + std::to_string(index) + "]", kPlaneKeys);
    PlaneSpec spec;
    spec.name = plane.string("name").value_or("plane" + std::to_string(index));
    check_unique(plane, spec.name, plane_names_, index);
    const Vec3 normal = plane.vec3("normal", spec.normal);
    if (normal == Vec3::Zero()) plane.fail_at("normal", "must be non-zero");
    // Normalised here so that `offset` means a distance along the unit normal, whatever
    // length the file's normal has. stableNormalized cannot overflow on huge components.
    spec.normal = normal.stableNormalized();
    if (plane.has("offset") && plane.has("point")) {
      plane.fail_at("point", "give either 'offset' or 'point', not both");
    }
    if (plane.has("point")) {
      spec.offset = spec.normal.dot(plane.vec3("point", Vec3::Zero()));
    } else {
      spec.offset = plane.number("offset", spec.offset, kAnyValue);
    }
    return spec;
  }

  ObjectSpec read_object(const toml::table& table, std::size_t index) {
    const std::string path = "object[" + std::to_string(index) + "]";
    const TableReader object(origin_, table, path, kObjectKeys, [](std::string_view key) -> std::string {
      if (contains(kMassSpringKeys, key) || contains(kShapeMatchingKeys, key)) {
        return "it belongs in [object.mass_spring] or [object.shape_matching]";
      }
      return "";
    });
    ObjectSpec spec;

    const auto name = object.string("name");
    if (!name) object.fail_missing("name");
    spec.name = *name;
    check_unique(object, spec.name, object_names_, index);

    const Vec3 scale = read_scale(object);
    spec.position = object.vec3("position", spec.position);
    spec.rotation_deg = object.vec3("rotation_deg", spec.rotation_deg);
    spec.velocity = object.vec3("velocity", spec.velocity);
    spec.cell_size = object.number("cell_size", spec.cell_size, kPositive);
    spec.mass = object.number("mass", spec.mass, kPositive);
    spec.fill_interior = object.boolean("fill_interior", spec.fill_interior);
    spec.clean.weld_tolerance =
        object.number("weld_tolerance", spec.clean.weld_tolerance, Bounds{0.0, 1.0, false, true});
    spec.clean.min_component_fraction =
        object.number("min_component_fraction", spec.clean.min_component_fraction, kUnitInterval);
    read_dynamics(object, spec);

    // Last, because importing a mesh is the slow part: every cheap mistake is reported first.
    spec.mesh = read_surface(object, spec.source);
    for (Vec3& vertex : spec.mesh.vertices) vertex = vertex.cwiseProduct(scale);
    return spec;
  }

  Vec3 read_scale(const TableReader& object) const {
    const toml::node* node = object.find("scale");
    if (!node) return Vec3::Ones();
    // Positive only: a negative factor would mirror the mesh and turn its triangles inside out.
    if (node->is_array()) return object.to_vec3(*node, object.field("scale"), kPositive);
    if (!node->is_number()) {
      object.fail_at("scale",
                     "expected a number or an array [sx, sy, sz] (got " + describe_type(*node) + ")");
    }
    return Vec3::Constant(object.number("scale", 1.0, kPositive));
  }

  // The surface as written in the file (unscaled); `source` says where it came from.
  SurfaceMesh read_surface(const TableReader& object, std::string& source) const {
    const bool has_mesh = object.has("mesh");
    const bool has_shape = object.has("shape");
    if (has_mesh && has_shape) {
      const bool shape_is_later =
          object.find("shape")->source().begin.line >= object.find("mesh")->source().begin.line;
      object.fail_at(shape_is_later ? "shape" : "mesh", "give either 'mesh' or 'shape', not both");
    }
    if (!has_mesh && !has_shape) {
      object.fail_here(object.path(),
                       "needs a surface: 'mesh' (a file path) or 'shape' (\"box\" or \"sphere\")");
    }
    if (has_mesh) {
      for (const std::string_view shape_key : {"size", "radius", "subdivisions"}) {
        if (object.has(shape_key)) object.fail_at(shape_key, "only used with 'shape', not with 'mesh'");
      }
      return read_mesh_file(object, source);
    }

    source = *object.string("shape");
    if (!contains(kShapeNames, source)) {
      std::string problem = "unknown shape " + in_quotes(source);
      if (const auto suggestion = closest_match(source, kShapeNames)) {
        problem += "; did you mean " + in_quotes(*suggestion) + "?";
      }
      object.fail_at("shape", problem + " (valid shapes: " + join(kShapeNames) + ")");
    }
    if (source == "box") {
      for (const std::string_view sphere_key : {"radius", "subdivisions"}) {
        if (object.has(sphere_key)) object.fail_at(sphere_key, "only used with shape = \"sphere\"");
      }
      if (!object.has("size")) object.fail_missing("size", " (shape = \"box\" needs size = [x, y, z] in m)");
      return make_box_mesh(object.vec3("size", Vec3::Zero(), kPositive));
    }
    if (object.has("size")) object.fail_at("size", "only used with shape = \"box\"");
    const double radius =
        object.required_number("radius", kPositive, " (shape = \"sphere\" needs radius in m)");
    const int subdivisions = static_cast<int>(object.integer("subdivisions", 3, 0, 6));
    return make_sphere_mesh(radius, subdivisions);
  }

  SurfaceMesh read_mesh_file(const TableReader& object, std::string& source) const {
    source = *object.string("mesh");
    std::filesystem::path resolved(source);
    if (resolved.is_relative() && !base_dir_.empty()) resolved = std::filesystem::path(base_dir_) / resolved;
    resolved = resolved.lexically_normal();
    std::error_code error;
    if (!std::filesystem::is_regular_file(resolved, error)) {
      object.fail_at("mesh", "cannot find mesh file " + in_quotes(resolved.string()) +
                                 " (mesh paths are relative to the scene file's folder)");
    }
    try {
      return import_mesh(resolved.string());
    } catch (const MeshImportError& e) {
      object.fail_at("mesh", e.what());
    }
  }

  void read_dynamics(const TableReader& object, ObjectSpec& spec) const {
    const toml::table* mass_spring = object.subtable("mass_spring");
    const toml::table* shape_matching = object.subtable("shape_matching");
    if (mass_spring && shape_matching) {
      const bool shape_matching_is_later = object.find("shape_matching")->source().begin.line >=
                                           object.find("mass_spring")->source().begin.line;
      object.fail_at(shape_matching_is_later ? "shape_matching" : "mass_spring",
                     "give exactly one of [object.mass_spring] and [object.shape_matching], not both");
    }
    if (mass_spring) {
      const TableReader table(origin_, *mass_spring, object.field("mass_spring"), kMassSpringKeys);
      spec.dynamics = DynamicsKind::MassSpring;
      spec.mass_spring.stiffness = table.number("stiffness", spec.mass_spring.stiffness, kPositive);
      spec.mass_spring.damping = table.number("damping", spec.mass_spring.damping, kNonNegative);
      spec.mass_spring.iterations =
          static_cast<int>(table.integer("iterations", spec.mass_spring.iterations, 1, 100));
    } else if (shape_matching) {
      const TableReader table(origin_, *shape_matching, object.field("shape_matching"), kShapeMatchingKeys);
      spec.dynamics = DynamicsKind::ShapeMatching;
      spec.shape_matching.stiffness =
          table.number("stiffness", spec.shape_matching.stiffness, Bounds{0.0, 1.0, true, false});
      spec.shape_matching.region_half_width =
          static_cast<int>(table.integer("region_half_width", spec.shape_matching.region_half_width, 1, 4));
      spec.shape_matching.damping = table.number("damping", spec.shape_matching.damping, kNonNegative);
    } else {
      object.fail_here(
          object.path(),
          "needs a dynamics table: [object.mass_spring] or [object.shape_matching] (may be empty)");
    }
  }

  void check_unique(const TableReader& table, const std::string& name,
                    std::map<std::string, std::size_t>& seen, std::size_t index) const {
    const auto [it, inserted] = seen.emplace(name, index);
    if (inserted) return;
    const std::string kind = table.path().substr(0, table.path().find('['));
    const std::string problem = "duplicate name " + in_quotes(name) + " (also " + kind + "[" +
                                std::to_string(it->second) + "]); names must be unique";
    if (table.has("name")) table.fail_at("name", problem);
    table.fail_here(table.field("name"), problem);
  }

  const std::string& origin_;
  const std::string& base_dir_;
  std::map<std::string, std::size_t> object_names_;
  std::map<std::string, std::size_t> plane_names_;
};

}  // namespace

SceneSpec parse_scene(const std::string& text, const std::string& origin, const std::string& base_dir) {
  return read_scene_table(parse_toml(text, origin), origin, base_dir);
}

SceneSpec read_scene_table(const toml::table& table, const std::string& origin, const std::string& base_dir) {
  return SceneReader(origin, base_dir).read(table);
}

SceneSpec load_scene_file(const std::string& path) {
  return parse_scene(read_text_file(path, "scene file"), path, std::filesystem::path(path).parent_path().string());
}

std::string default_scene_path() { return FFDSIM_SCENARIO_DIR "/scenes/two_teapots.toml"; }

SceneSpec default_scene() { return load_scene_file(default_scene_path()); }

}  // namespace ffd
