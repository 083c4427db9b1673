// TOML scene files -> SceneSpec. The format is documented in docs/scene-format.md, "Scene format".
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
#include <tuple>
#include <cstdio>
#include <cctype>
#include <vector>

#include "ffd/glyph_mesh.h"
#include "ffd/mesh_import.h"
#include "ffd/toml_reader.h"

namespace ffd {
namespace {

const std::vector<std::string_view> kRootKeys = {"simulation", "plane", "object", "group", "probe", "grab"};
const std::vector<std::string_view> kProbeKeys = {"radius",      "mass",        "coupling_stiffness",
                                                  "coupling_damping", "start", "force_limit",
                                                  "force_rate_limit", "watchdog_ms"};
const std::vector<std::string_view> kGrabKeys = {"stiffness", "damping"};
const std::vector<std::string_view> kSimulationKeys = {
    "dt",      "gravity",         "alpha",          "beta", "seed",
    "effects", "hash_table_size", "hash_cell_size", "min_box_thickness", "accuracy", "sub_box_split",
    "sleep_radius", "sleep_time", "response", "rolling_resistance", "box_overlap", "edge_contacts", "solver_edge_contacts", "solver_substeps"};
const std::vector<std::string_view> kPlaneKeys = {"name", "normal", "offset", "point"};
const std::vector<std::string_view> kObjectKeys = {
    "name",         "mesh",          "shape",          "glyph",          "size",
    "radius",       "subdivisions",  "thickness",      "height",         "segments",
    "subdivide",    "scale",         "position",
    "rotation_deg", "velocity",      "angular_velocity", "cell_size",    "mass",
    "fill_interior", "weld_tolerance", "min_component_fraction", "mass_spring", "shape_matching"};
// A group: `count` copies of one object description, placed on a grid, with random
// velocities, spins and orientations drawn from simulation.seed.
const std::vector<std::string_view> kGroupOnlyKeys = {"count", "layout", "random"};
const std::vector<std::string_view> kLayoutKeys = {"grid", "spacing", "centre"};
const std::vector<std::string_view> kRandomKeys = {"velocity", "angular_velocity", "rotation"};
const std::vector<std::string_view> kGlyphKeys = {"text", "font", "em_size", "depth", "sample_spacing"};
const std::vector<std::string_view> kMassSpringKeys = {"stiffness", "damping", "iterations", "bulk_modulus",
                                                       "shape_stiffness"};
const std::vector<std::string_view> kShapeMatchingKeys = {"stiffness", "region_half_width", "damping"};
const std::vector<std::string_view> kShapeNames = {"box", "sphere", "torus", "ring", "bowl"};
// The keys each built-in shape reads (besides `shape`); any other of kShapeKeys is an error.
const std::vector<std::string_view> kShapeKeys = {"size", "radius", "subdivisions", "thickness", "height", "segments"};
std::vector<std::string_view> keys_of_shape(std::string_view shape) {
  if (shape == "box") return {"size"};
  if (shape == "sphere") return {"radius", "subdivisions"};
  if (shape == "ring") return {"radius", "thickness", "height", "segments"};
  return {"radius", "thickness", "segments"};  // torus, bowl
}

bool contains(const std::vector<std::string_view>& words, std::string_view word) {
  return std::find(words.begin(), words.end(), word) != words.end();
}

}  // namespace

std::vector<std::pair<std::string, std::vector<std::string>>> scene_keys() {
  const auto strings = [](const std::vector<std::string_view>& keys) {
    return std::vector<std::string>(keys.begin(), keys.end());
  };
  return {{"simulation", strings(kSimulationKeys)}, {"probe", strings(kProbeKeys)},
          {"grab", strings(kGrabKeys)},             {"plane", strings(kPlaneKeys)},
          {"object", strings(kObjectKeys)},         {"object.glyph", strings(kGlyphKeys)},
          {"object.mass_spring", strings(kMassSpringKeys)},
          {"object.shape_matching", strings(kShapeMatchingKeys)},
          {"group", strings(kGroupOnlyKeys)},       {"group.layout", strings(kLayoutKeys)},
          {"group.random", strings(kRandomKeys)}};
}

namespace {

std::vector<std::string_view> all_effect_names() {
  std::vector<std::string_view> names;
  for (const Effect e : kAllEffects) names.emplace_back(effect_name(e));
  return names;
}

class SceneReader {
 public:
  SceneReader(const std::string& origin, const std::string& base_dir, const SceneLimits& limits)
      : origin_(origin), base_dir_(base_dir), limits_(limits) {}

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
    const auto groups = array_of_tables(root, "group");
    if (objects.empty() && groups.empty())
      root.fail_here("object", "a scene needs at least one [[object]] or [[group]] table");
    if (objects.size() > limits_.objects) {
      root.fail(objects[limits_.objects]->source(), "object[" + std::to_string(limits_.objects) + "]",
                "the scene has more than " + std::to_string(limits_.objects) + " objects (the limit)");
    }
    for (std::size_t i = 0; i < objects.size(); ++i) scene.objects.push_back(read_object(*objects[i], i));
    for (std::size_t i = 0; i < groups.size(); ++i) read_group(*groups[i], i, scene);
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
    // The paper's single hash table of T buckets is gone: the broad phase sizes its grids to
    // the objects (docs/step.md, "How a step works"), so a table size would change nothing.
    if (sim.has("hash_table_size"))
      sim.fail_at("hash_table_size", "hash_table_size is no longer used: the broad phase sizes its grids to the objects "
                                     "(remove the key; hash_cell_size still sets the grid cell edge)");
    settings.hash_cell_size = sim.number("hash_cell_size", settings.hash_cell_size, kNonNegative);
    settings.min_box_thickness = sim.number("min_box_thickness", settings.min_box_thickness, kUnitInterval);
    settings.accuracy = static_cast<Accuracy>(
        sim.integer("accuracy", static_cast<int>(settings.accuracy), 0, kAccuracyLevels - 1));
    settings.sub_box_split = static_cast<int>(sim.integer("sub_box_split", settings.sub_box_split, 2, 4));
    settings.rolling_resistance = sim.number("rolling_resistance", settings.rolling_resistance, kNonNegative);
    settings.box_overlap = sim.boolean("box_overlap", settings.box_overlap);
    settings.edge_contacts = sim.boolean("edge_contacts", settings.edge_contacts);
    // The solver's own switch for the edge contacts is gone: edge_contacts means the same under
    // both responses.
    if (sim.has("solver_edge_contacts"))
      sim.fail_at("solver_edge_contacts", "solver_edge_contacts is no longer used: edge_contacts gives both responses "
                                          "their edge contacts (remove the key; edge_contacts = false turns them off)");
    settings.solver_substeps = sim.boolean("solver_substeps", settings.solver_substeps);
    if (const std::optional<std::string> response = sim.string("response"))
      if (!response_from_name(*response, settings.response))
        sim.fail_at("response", "unknown response " + in_quotes(*response) + " (valid: \"paper\", \"solver\")");
    settings.effects = read_effects(sim);
    // The sleeping effect's settings, only with it on: a value that would change nothing is a mistake.
    for (const char* key : {"sleep_radius", "sleep_time"})
      if (sim.has(key) && !has(settings.effects, Effect::Sleeping))
        sim.fail_at(key, std::string(key) + " is given but the \"sleeping\" effect is off; add \"sleeping\" to simulation.effects");
    settings.sleep_radius = sim.number("sleep_radius", settings.sleep_radius, Bounds{0.0, 1.0, true, false});
    settings.sleep_time = sim.number("sleep_time", settings.sleep_time, Bounds{0.0, 60.0, true, false});
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
      p.force_limit = probe.number("force_limit", p.force_limit, kPositive);
      p.force_rate_limit = probe.number("force_rate_limit", p.force_rate_limit, kPositive);
      p.watchdog_ms = probe.number("watchdog_ms", p.watchdog_ms, kPositive);
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
    check_unique(plane, spec.name, plane_names_);
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

  static std::string misplaced_object_key(std::string_view key) {
    if (contains(kMassSpringKeys, key) || contains(kShapeMatchingKeys, key)) {
      return "it belongs in [object.mass_spring] or [object.shape_matching]";
    }
    return "";
  }

  ObjectSpec read_object(const toml::table& table, std::size_t index) {
    const std::string path = "object[" + std::to_string(index) + "]";
    const TableReader object(origin_, table, path, kObjectKeys, misplaced_object_key);
    ObjectSpec spec;

    const auto name = object.string("name");
    if (!name) object.fail_missing("name");
    spec.name = *name;
    check_unique(object, spec.name, object_names_);

    const Vec3 scale = read_scale(object);
    spec.position = object.vec3("position", spec.position);
    read_object_settings(object, spec);
    // Last, because importing a mesh is the slow part: every cheap mistake is reported first.
    if (object.has("glyph") && glyph_text(object).size() != 1)
      object.fail_at("glyph", "an [[object]]'s glyph.text is one character (a [[group]] cycles through several)");
    spec.mesh = read_surface(object, spec.source, 0, scale, spec.cell_size);
    scale_mesh(scale, spec.mesh);
    charge(object, spec, 1);
    return spec;
  }

  // [[group]]: `count` objects named NAME_0000, NAME_0001, ... (plus _C for a glyph C),
  // one description, placed on layout.grid (x fastest, then z, then up the layers in y)
  // around layout.centre, each with a random velocity, spin and orientation on top of the
  // given ones. Glyph groups cycle through glyph.text.
  void read_group(const toml::table& table, std::size_t index, SceneSpec& scene) {
    const std::string path = "group[" + std::to_string(index) + "]";
    std::vector<std::string_view> keys = kGroupOnlyKeys;
    for (std::string_view key : kObjectKeys)
      if (key != "position") keys.push_back(key);
    const TableReader group(origin_, table, path, keys, misplaced_object_key);
    const auto name = group.string("name");
    if (!name) group.fail_missing("name");
    const std::size_t count = static_cast<std::size_t>(group.integer("count", 0, 1, static_cast<std::int64_t>(limits_.objects)));
    if (!group.has("count")) group.fail_missing("count", " (how many objects the group makes)");
    if (count > limits_.objects - std::min(limits_.objects, scene.objects.size())) {
      group.fail_at("count", std::to_string(count) + " objects would make " +
                                 std::to_string(scene.objects.size() + count) + " in the scene; the limit is " +
                                 std::to_string(limits_.objects) + " per scene");
    }

    const toml::table* layout_table = group.subtable("layout");
    if (!layout_table) group.fail_missing("layout", " ([" + path + ".layout] with grid, spacing and centre)");
    const TableReader layout(origin_, *layout_table, group.field("layout"), kLayoutKeys);
    if (!layout.has("grid")) layout.fail_missing("grid", " ([nx, ny, nz]: objects per row, layers, rows)");
    const Vec3 grid_numbers = layout.vec3("grid", Vec3::Ones(), Bounds{1.0, 10'000.0, false, false});
    Vec3i grid;
    for (int a = 0; a < 3; ++a) {
      if (grid_numbers[a] != std::floor(grid_numbers[a])) layout.fail_at("grid", "expected whole numbers");
      grid[a] = static_cast<int>(grid_numbers[a]);
    }
    // 64-bit: up to 10^12 places.
    const std::int64_t places = std::int64_t{grid.x()} * grid.y() * grid.z();
    if (places < static_cast<std::int64_t>(count)) {
      layout.fail_at("grid", "holds " + std::to_string(places) + " places for " + std::to_string(count) + " objects");
    }
    const Vec3 spacing = layout.vec3("spacing", Vec3::Zero(), kNonNegative);
    if (!layout.has("spacing")) layout.fail_missing("spacing", " ([dx, dy, dz] in m)");
    const Vec3 centre = layout.vec3("centre", Vec3::Zero());

    Vec3 random_velocity = Vec3::Zero(), random_spin = Vec3::Zero();
    bool random_rotation = false;
    if (const toml::table* random_table = group.subtable("random")) {
      const TableReader random(origin_, *random_table, group.field("random"), kRandomKeys);
      random_velocity = random.vec3("velocity", random_velocity, kNonNegative);
      random_spin = random.vec3("angular_velocity", random_spin, kNonNegative);
      random_rotation = random.boolean("rotation", random_rotation);
    }

    const Vec3 scale = read_scale(group);
    ObjectSpec base;
    read_object_settings(group, base);
    const std::u32string text = group.has("glyph") ? glyph_text(group) : std::u32string(1, U' ');
    std::vector<SurfaceMesh> surfaces;
    std::vector<std::string> sources(text.size());
    for (std::size_t i = 0; i < text.size(); ++i) {
      surfaces.push_back(read_surface(group, sources[i], i, scale, base.cell_size));
      scale_mesh(scale, surfaces.back());
      // Character i is used by objects i, i + len(text), ... below `count`.
      const std::size_t copies = i < count ? (count - i + text.size() - 1) / text.size() : 0;
      ObjectSpec sized = base;
      sized.mesh = std::move(surfaces.back());
      charge(group, sized, copies);
      surfaces.back() = std::move(sized.mesh);
    }

    // splitmix64 from the scene seed and the group index: the same numbers on every platform.
    std::uint64_t random_state = scene.settings.seed * 0x9E3779B97F4A7C15ull + index + 1;
    auto uniform = [&]() {  // in [-1, 1)
      std::uint64_t z = (random_state += 0x9E3779B97F4A7C15ull);
      z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
      z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
      z ^= z >> 31;
      return static_cast<double>(z >> 11) * 0x1.0p-52 - 1.0;
    };
    const int width = std::max<int>(1, static_cast<int>(std::log10(static_cast<double>(count - 1 + (count == 1)))) + 1);
    for (std::size_t n = 0; n < count; ++n) {
      ObjectSpec spec = base;
      const std::size_t variant = n % text.size();
      std::string number = std::to_string(n);
      number.insert(0, static_cast<std::size_t>(std::max(0, width - static_cast<int>(number.size()))), '0');
      spec.name = *name + "_" + number;
      if (group.has("glyph") && text[variant] < 128 && std::isalnum(static_cast<int>(text[variant])))
        spec.name += "_" + std::string(1, static_cast<char>(text[variant]));
      check_unique(group, spec.name, object_names_);
      const std::size_t i = n % static_cast<std::size_t>(grid.x());
      const std::size_t k = (n / static_cast<std::size_t>(grid.x())) % static_cast<std::size_t>(grid.z());
      const std::size_t j = n / (static_cast<std::size_t>(grid.x()) * static_cast<std::size_t>(grid.z()));
      spec.position = centre + Vec3((static_cast<double>(i) - 0.5 * (grid.x() - 1)) * spacing.x(),
                                    static_cast<double>(j) * spacing.y(),
                                    (static_cast<double>(k) - 0.5 * (grid.z() - 1)) * spacing.z());
      for (int a = 0; a < 3; ++a) spec.velocity[a] += random_velocity[a] * uniform();
      for (int a = 0; a < 3; ++a) spec.angular_velocity[a] += random_spin[a] * uniform();
      if (random_rotation)
        for (int a = 0; a < 3; ++a) spec.rotation_deg[a] += 180.0 * uniform();
      spec.mesh = surfaces[variant];
      spec.source = sources[variant];
      scene.objects.push_back(std::move(spec));
    }
  }

  // Everything of an object but its name, position and surface (shared with [[group]]).
  void read_object_settings(const TableReader& object, ObjectSpec& spec) const {
    spec.rotation_deg = object.vec3("rotation_deg", spec.rotation_deg);
    spec.velocity = object.vec3("velocity", spec.velocity);
    spec.angular_velocity = object.vec3("angular_velocity", spec.angular_velocity);
    spec.subdivisions = static_cast<int>(object.integer("subdivide", 0, 0, 3));
    spec.cell_size = object.number("cell_size", spec.cell_size, kPositive);
    spec.mass = object.number("mass", spec.mass, kPositive);
    spec.fill_interior = object.boolean("fill_interior", spec.fill_interior);
    spec.clean.weld_tolerance =
        object.number("weld_tolerance", spec.clean.weld_tolerance, Bounds{0.0, 1.0, false, true});
    spec.clean.min_component_fraction =
        object.number("min_component_fraction", spec.clean.min_component_fraction, kUnitInterval);
    read_dynamics(object, spec);
  }

  static void scale_mesh(const Vec3& scale, SurfaceMesh& mesh) {
    for (Vec3& vertex : mesh.vertices) vertex = vertex.cwiseProduct(scale);
  }

  // glyph.text as code points (UTF-8 in the file).
  std::u32string glyph_text(const TableReader& object) const {
    const toml::table* table = object.subtable("glyph");
    if (!table) object.fail_at("glyph", "expected a table { text = \"A\", font = \"...ttf\", ... }");
    const TableReader glyph(origin_, *table, object.field("glyph"), kGlyphKeys);
    const auto text = glyph.string("text");
    if (!text) glyph.fail_missing("text", " (the character(s) to extrude)");
    std::u32string out;
    const std::string& s = *text;
    for (std::size_t i = 0; i < s.size();) {
      const unsigned char c = static_cast<unsigned char>(s[i]);
      const int length = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xE ? 3 : (c >> 3) == 0x1E ? 4 : 0;
      if (length == 0 || i + static_cast<std::size_t>(length) > s.size()) glyph.fail_at("text", "is not valid UTF-8");
      char32_t code = length == 1 ? c : c & (0x7F >> length);
      for (int k = 1; k < length; ++k) {
        const unsigned char next = static_cast<unsigned char>(s[i + static_cast<std::size_t>(k)]);
        if ((next >> 6) != 0x2) glyph.fail_at("text", "is not valid UTF-8");
        code = (code << 6) | (next & 0x3F);
      }
      const char32_t shortest[5] = {0, 0, 0x80, 0x800, 0x10000};  // smallest code of each length
      if (code < shortest[length] || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF))
        glyph.fail_at("text", "is not valid UTF-8");
      out.push_back(code);
      i += static_cast<std::size_t>(length);
    }
    // A group makes one mesh per character, up front.
    if (out.size() > limits_.glyph_text) {
      glyph.fail_at("text", "has " + std::to_string(out.size()) + " characters, more than the limit of " +
                                std::to_string(limits_.glyph_text));
    }
    return out;
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
  // `variant` picks the character of a glyph group.
  // `scale` and `cell_size` are the object's: a box's faces are divided into squares about a
  // cell across once scaled.
  SurfaceMesh read_surface(const TableReader& object, std::string& source, std::size_t variant, const Vec3& scale,
                           double cell_size) {
    std::vector<std::string_view> given;
    for (std::string_view key : {"mesh", "shape", "glyph"})
      if (object.has(key)) given.push_back(key);
    if (given.size() > 1) {
      std::sort(given.begin(), given.end(), [&](std::string_view a, std::string_view b) {
        return object.find(a)->source().begin.line < object.find(b)->source().begin.line;
      });
      object.fail_at(given.back(), "give one of 'mesh', 'shape' and 'glyph', not several");
    }
    if (given.empty()) {
      object.fail_here(object.path(),
                       "needs a surface: 'mesh' (a file path), 'shape' (a built-in: " + join(kShapeNames) + ") or 'glyph' "
                       "(a letter of a font)");
    }
    if (given.front() != "shape") {
      for (const std::string_view shape_key : kShapeKeys) {
        if (object.has(shape_key))
          object.fail_at(shape_key, "only used with 'shape', not with '" + std::string(given.front()) + "'");
      }
    }
    if (given.front() == "mesh") return read_mesh_file(object, source);
    if (given.front() == "glyph") return read_glyph(object, source, variant);

    source = *object.string("shape");
    if (!contains(kShapeNames, source)) {
      std::string problem = "unknown shape " + in_quotes(source);
      if (const auto suggestion = closest_match(source, kShapeNames)) {
        problem += "; did you mean " + in_quotes(*suggestion) + "?";
      }
      object.fail_at("shape", problem + " (valid shapes: " + join(kShapeNames) + ")");
    }
    const std::vector<std::string_view> used = keys_of_shape(source);
    for (const std::string_view key : kShapeKeys) {
      if (object.has(key) && !contains(used, key)) {
        std::vector<std::string_view> shapes;  // the shapes that do use it
        for (const std::string_view shape : kShapeNames)
          if (contains(keys_of_shape(shape), key)) shapes.push_back(shape);
        object.fail_at(key, "not used with shape = \"" + source + "\" (only with " + join(shapes) + ")");
      }
    }
    const std::string needs = " (shape = \"" + source + "\" needs ";
    if (source == "box") {
      if (!object.has("size")) object.fail_missing("size", needs + "size = [x, y, z] in m)");
      return read_box(object, object.vec3("size", Vec3::Zero(), kPositive), scale, cell_size);
    }
    const double radius = object.required_number("radius", kPositive, needs + "radius in m)");
    if (source == "sphere") return make_sphere_mesh(radius, static_cast<int>(object.integer("subdivisions", 3, 0, 6)));
    // Surfaces of revolution (mesh.h): the wall must leave a hole.
    const double thickness = object.required_number("thickness", kPositive, needs + "thickness in m)");
    const double thickest = source == "torus" ? 2.0 * radius : radius;
    if (!(thickness < thickest)) {
      object.fail_at("thickness", "must be < " + std::string(source == "torus" ? "2 x radius" : "radius") + " (" +
                                      format_number(thickest) + " m; got " + format_number(thickness) + ")");
    }
    const int segments = static_cast<int>(object.integer("segments", 48, 8, 1024));
    if (source == "torus") return make_torus_mesh(radius, thickness, segments);
    if (source == "bowl") return make_bowl_mesh(radius, thickness, segments);
    const double height = object.required_number("height", kPositive, needs + "height in m)");
    try {
      return make_ring_mesh(radius, thickness, height, segments);
    } catch (const std::invalid_argument& e) {  // a profile too long for its radius
      object.fail_at("height", e.what());
    }
  }

  // A box whose faces are grids of squares about a cell across (box_divisions): a face bends
  // with the lattice only through its vertices, and an edge contact moves the cells of the
  // corners nearest to it, so a face of two triangles answered for the whole face at its
  // corners. The squares are counted against the limits before any is built.
  SurfaceMesh read_box(const TableReader& object, const Vec3& size, const Vec3& scale, double cell_size) const {
    const Vec3 scaled = size.cwiseProduct(scale);
    const std::string_view key = object.has("cell_size") ? "cell_size" : object.has("scale") ? "scale" : "size";
    const auto refuse = [&](const std::string& count) {
      object.fail_at(key, "a box of " + format_number(scaled.x()) + " x " + format_number(scaled.y()) + " x " +
                              format_number(scaled.z()) + " m in squares of cell_size " + format_number(cell_size) +
                              " m has " + count + " (at most " + std::to_string(kMaxBoxDivisions) +
                              " squares an edge and " + std::to_string(limits_.object_triangles) +
                              " triangles per object); use a larger cell_size");
    };
    Vec3 squares;  // per axis; the first test keeps the division below from overflowing
    for (int a = 0; a < 3; ++a) {
      if (!(scaled[a] / kMaxBoxDivisions <= cell_size))
        refuse("more than " + std::to_string(kMaxBoxDivisions) + " squares an edge");
      squares[a] = std::max(1.0, std::ceil(scaled[a] / cell_size));
    }
    const double triangles = 4.0 * (squares.x() * squares.y() + squares.y() * squares.z() + squares.z() * squares.x());
    if (triangles > static_cast<double>(limits_.object_triangles)) refuse(format_number(triangles) + " triangles");
    return make_box_mesh(size, box_divisions(scaled, cell_size));  // scaled with the others by scale_mesh
  }

  // An extruded letter of a font (glyph_mesh.h); meshes are made once per character.
  SurfaceMesh read_glyph(const TableReader& object, std::string& source, std::size_t variant) {
    const std::u32string text = glyph_text(object);
    const TableReader glyph(origin_, *object.subtable("glyph"), object.field("glyph"), kGlyphKeys);
    GlyphMeshOptions options;
    const auto font = glyph.string("font");
    if (!font) glyph.fail_missing("font", " (a TrueType file, e.g. /usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf)");
    std::filesystem::path resolved(*font);
    if (resolved.is_relative() && !base_dir_.empty()) resolved = std::filesystem::path(base_dir_) / resolved;
    options.font_path = resolved.lexically_normal().string();
    std::error_code error;
    if (!std::filesystem::is_regular_file(options.font_path, error))
      glyph.fail_at("font", "cannot find font file " + in_quotes(options.font_path) +
                                " (Debian's fonts-dejavu-core installs /usr/share/fonts/truetype/dejavu/)");
    options.character = text[variant % text.size()];
    options.em_size = glyph.required_number("em_size", kPositive, " (m: the font size)");
    options.depth = glyph.required_number("depth", kPositive, " (m: the extrusion)");
    options.sample_spacing = glyph.required_number("sample_spacing", kPositive, " (m between outline samples)");
    // The outline's samples (and so the time to mesh it) grow with em_size / sample_spacing.
    const double samples_per_em = options.em_size / options.sample_spacing;
    if (samples_per_em > limits_.glyph_samples_per_em) {
      glyph.fail_at("sample_spacing", "em_size / sample_spacing is " + format_number(samples_per_em) +
                                          ", more than the limit of " + format_number(limits_.glyph_samples_per_em) +
                                          "; use a larger sample_spacing");
    }
    const auto key = std::make_tuple(options.font_path, options.character, options.em_size, options.depth,
                                     options.sample_spacing);
    source = options.font_path + " U+" + hex_code(options.character);
    if (const auto cached = glyphs_.find(key); cached != glyphs_.end()) return cached->second;
    try {
      return glyphs_.emplace(key, make_glyph_mesh(options)).first->second;
    } catch (const std::invalid_argument& e) {
      glyph.fail_at("text", e.what());
    }
  }

  static std::string hex_code(char32_t c) {
    char buffer[16];
    std::snprintf(buffer, sizeof buffer, "%04X", static_cast<unsigned>(c));
    return buffer;
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
      spec.mass_spring.bulk_modulus = table.number("bulk_modulus", spec.mass_spring.bulk_modulus, kNonNegative);
      spec.mass_spring.shape_stiffness = table.number("shape_stiffness", spec.mass_spring.shape_stiffness, kNonNegative);
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

  // Counts `copies` objects of `spec`'s (scaled) surface against the limits before compile()
  // builds them, with the numbers compile() will meet: triangles after subdivision, cells of
  // the regular lattice grid over the bounds of the vertices the triangles use (compile()
  // drops stray pieces first, so it may use fewer), the triangle-cell pairs the lattice
  // builder clips (each triangle against every cell of its bounding box, 4^subdivide times
  // for the finer triangles inside it), and shape-matching region members.
  void charge(const TableReader& object, const ObjectSpec& spec, std::size_t copies) {
    const std::string_view surface_key = object.has("mesh") ? "mesh" : object.has("glyph") ? "glyph" : "shape";
    const std::string_view cell_key = object.has("cell_size") ? "cell_size" : surface_key;
    const double refinement = std::pow(4.0, spec.subdivisions);
    const double triangles = static_cast<double>(spec.mesh.triangles.size()) * refinement;
    if (triangles > static_cast<double>(limits_.object_triangles)) {
      const bool subdivided = spec.subdivisions > 0;
      object.fail_at(subdivided ? "subdivide" : surface_key,
                     "the surface has " + format_number(triangles) + " triangles" +
                         (subdivided ? " after subdivision (" + std::to_string(spec.mesh.triangles.size()) +
                                           " before)"
                                     : "") +
                         ", more than the limit of " + std::to_string(limits_.object_triangles) + " per object");
    }
    // Bad indices and non-finite vertices are left to clean_mesh(), which reports them.
    const auto usable = [&](const std::array<Index, 3>& triangle) {
      for (const Index v : triangle)
        if (v >= spec.mesh.vertices.size() || !is_finite(spec.mesh.vertices[v])) return false;
      return true;
    };
    Vec3 lo = Vec3::Constant(kInf), hi = Vec3::Constant(-kInf);
    bool any = false;
    for (const auto& triangle : spec.mesh.triangles) {
      if (!usable(triangle)) continue;
      for (const Index v : triangle) {
        lo = lo.cwiseMin(spec.mesh.vertices[v]);
        hi = hi.cwiseMax(spec.mesh.vertices[v]);
      }
      any = true;
    }
    if (!any) return;  // compile() reports a surface without triangles
    // Computed so that no value overflows, even for extreme coordinates and cell sizes (the
    // tests trap floating-point overflow): half extents, and an axis past the limit is +inf.
    const double h = spec.cell_size;
    const double cap = static_cast<double>(limits_.object_lattice_cells);
    const double largest = std::numeric_limits<double>::max();
    Vec3 half, dims;
    for (int a = 0; a < 3; ++a) {
      half[a] = 0.5 * hi[a] - 0.5 * lo[a];
      dims[a] = h <= largest / cap && half[a] > 0.5 * cap * h ? kInf : std::floor(2.0 * (half[a] / h)) + 1.0;
    }
    const double cells = dims.prod();
    if (!(cells <= cap)) {
      const auto extent = [&](int a) { return half[a] <= 0.5 * largest ? format_number(2.0 * half[a]) : "inf"; };
      object.fail_at(object.has("cell_size") ? "cell_size" : object.has("scale") ? "scale" : surface_key,
                     "cell_size " + format_number(h) + " m over a surface of " + extent(0) + " x " + extent(1) +
                         " x " + extent(2) + " m makes a lattice of " +
                         (cells < kInf ? "up to " + format_number(cells) + " cells, more than" : "more cells than") +
                         " the limit of " + std::to_string(limits_.object_lattice_cells) +
                         " per object; use a larger cell_size");
    }
    // The grid as build_lattice() places it: centred on the bounds.
    const Vec3 origin = 0.5 * lo + 0.5 * hi - (0.5 * h) * dims;
    double pairs = 0.0;
    for (const auto& triangle : spec.mesh.triangles) {
      if (!usable(triangle)) continue;
      double span = 1.0;
      for (int a = 0; a < 3; ++a) {
        double first = kInf, last = -kInf;
        for (const Index v : triangle) {
          const double g = std::floor((spec.mesh.vertices[v][a] - origin[a]) / h);
          first = std::min(first, g);
          last = std::max(last, g);
        }
        span *= std::clamp(last, 0.0, dims[a] - 1.0) - std::clamp(first, 0.0, dims[a] - 1.0) + 1.0;
      }
      pairs += span;
    }
    pairs *= refinement;
    const double nodes = (dims + Vec3::Ones()).prod();
    const double region_width = 2.0 * spec.shape_matching.region_half_width + 1.0;
    const double members =
        spec.dynamics == DynamicsKind::ShapeMatching ? nodes * region_width * region_width * region_width : 0.0;

    const double n = static_cast<double>(copies);
    triangles_ += triangles * n;
    lattice_cells_ += cells * n;
    triangle_cells_ += pairs * n;
    region_members_ += members * n;
    if (triangles_ > static_cast<double>(limits_.scene_triangles)) {
      object.fail_at(surface_key, "the scene's objects have " + format_number(triangles_) +
                                      " triangles so far, more than the limit of " +
                                      std::to_string(limits_.scene_triangles) + " per scene");
    }
    if (lattice_cells_ > static_cast<double>(limits_.scene_lattice_cells)) {
      object.fail_at(cell_key, "the scene's objects have lattices of up to " + format_number(lattice_cells_) +
                                   " cells so far, more than the limit of " +
                                   std::to_string(limits_.scene_lattice_cells) + " per scene; use a larger cell_size");
    }
    if (triangle_cells_ > static_cast<double>(limits_.scene_triangle_cells)) {
      object.fail_at(cell_key, "building the lattices means clipping " + format_number(triangle_cells_) +
                                   " triangle-cell pairs so far (each triangle against every cell of its bounding "
                                   "box), more than the limit of " + std::to_string(limits_.scene_triangle_cells) +
                                   " per scene; use a larger cell_size");
    }
    if (region_members_ > static_cast<double>(limits_.scene_region_members)) {
      object.fail_at("shape_matching", "shape-matching regions of up to " + format_number(region_members_) +
                                           " lattice nodes in all so far (each node's region spans (2w+1)^3), more "
                                           "than the limit of " + std::to_string(limits_.scene_region_members) +
                                           " per scene; use a smaller region_half_width or a larger cell_size");
    }
  }

  // `seen` maps each name to the table that declared it ("object[2]", "group[0]").
  void check_unique(const TableReader& table, const std::string& name,
                    std::map<std::string, std::string>& seen) const {
    const auto [it, inserted] = seen.emplace(name, table.path());
    if (inserted) return;
    const std::string problem =
        "duplicate name " + in_quotes(name) + " (also " + it->second + "); names must be unique";
    if (table.has("name")) table.fail_at("name", problem);
    table.fail_here(table.field("name"), problem);
  }

  const std::string& origin_;
  const std::string& base_dir_;
  const SceneLimits& limits_;
  // Charged so far (see charge()).
  double triangles_ = 0.0, lattice_cells_ = 0.0, triangle_cells_ = 0.0, region_members_ = 0.0;
  std::map<std::string, std::string> object_names_;
  std::map<std::string, std::string> plane_names_;
  std::map<std::tuple<std::string, char32_t, double, double, double>, SurfaceMesh> glyphs_;
};

}  // namespace

SceneSpec parse_scene(const std::string& text, const std::string& origin, const std::string& base_dir,
                      const SceneLimits& limits) {
  return read_scene_table(parse_toml(text, origin), origin, base_dir, limits);
}

SceneSpec read_scene_table(const toml::table& table, const std::string& origin, const std::string& base_dir,
                           const SceneLimits& limits) {
  return SceneReader(origin, base_dir, limits).read(table);
}

SceneSpec load_scene_file(const std::string& path, const SceneLimits& limits) {
  return parse_scene(read_text_file(path, "scene file"), path, std::filesystem::path(path).parent_path().string(),
                     limits);
}

Model compile_scene(const SceneSpec& spec, const std::string& path, std::vector<std::string>& log) {
  try {
    return compile(spec, log);
  } catch (const CompileError& e) {
    throw InputError(path + ": " + e.what());
  }
}

std::string scenario_dir() {
  // Installed (cmake --install): <prefix>/bin/ffdsim beside <prefix>/share/ffdsim/scenes. In
  // the build tree the program finds its scenes in the source tree it was built from.
  static const std::string dir = [] {
    std::error_code error;
    const std::filesystem::path program = std::filesystem::read_symlink("/proc/self/exe", error);
    if (!error) {
      const std::filesystem::path installed = program.parent_path().parent_path() / "share" / "ffdsim";
      if (std::filesystem::is_directory(installed / "scenes", error)) return installed.string();
    }
    return std::string(FFDSIM_SCENARIO_DIR);
  }();
  return dir;
}

std::string default_scene_path() { return scenario_dir() + "/scenes/two_teapots.toml"; }

SceneSpec default_scene() { return load_scene_file(default_scene_path()); }

}  // namespace ffd
