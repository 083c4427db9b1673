// TOML scene files -> SceneSpec. The format is documented in scenarios/SCENE_FORMAT.md.
// The loader is strict: unknown keys, wrong types, wrong lengths and out-of-range values
// are all errors, each naming FILE:LINE:COL and the dotted field, so a typo in a scene
// never silently falls back to a default.
#include "ffd/scene_loader.h"

#include <toml++/toml.h>

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

namespace ffd {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string format_number(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

std::string in_quotes(std::string_view text) { return "'" + std::string(text) + "'"; }

std::string describe_type(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a floating-point number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::date: return "a date";
    case toml::node_type::time: return "a time";
    case toml::node_type::date_time: return "a date-time";
    default: return "nothing";
  }
}

// Optimal string alignment distance: a transposed pair ("nmae") counts as one edit,
// which is the commonest typo in key names.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[a.size()][b.size()];
}

// The closest candidate within a couple of edits, else one the word is a prefix of or
// extends ("rotation" for "rotation_deg"), else nothing: no candidate is a plausible intent.
std::optional<std::string_view> closest_match(std::string_view word,
                                              const std::vector<std::string_view>& candidates) {
  const std::size_t budget = word.size() >= 6 ? 2 : 1;
  std::optional<std::string_view> best;
  std::size_t best_distance = budget + 1;
  for (const std::string_view candidate : candidates) {
    const std::size_t distance = edit_distance(word, candidate);
    if (distance < best_distance) {
      best_distance = distance;
      best = candidate;
    }
  }
  if (best) return best;
  constexpr std::size_t kMinPrefix = 4;  // shorter prefixes match too much to be a hint
  for (const std::string_view candidate : candidates) {
    if (std::min(word.size(), candidate.size()) < kMinPrefix) continue;
    if (candidate.starts_with(word) || word.starts_with(candidate)) return candidate;
  }
  return std::nullopt;
}

std::string join(const std::vector<std::string_view>& words) {
  std::string out;
  for (const std::string_view word : words) {
    if (!out.empty()) out += ", ";
    out += word;
  }
  return out;
}

// An allowed interval for a number; "in (0, 0.01]", "> 0", ">= 0" in messages.
struct Bounds {
  double low = -kInf;
  double high = kInf;
  bool low_open = false;
  bool high_open = false;

  bool contains(double v) const {
    const bool above = low_open ? v > low : v >= low;
    const bool below = high_open ? v < high : v <= high;
    return above && below;
  }
  std::string describe() const {
    if (high == kInf) return std::string(low_open ? "> " : ">= ") + format_number(low);
    if (low == -kInf) return std::string(high_open ? "< " : "<= ") + format_number(high);
    return "in " + std::string(low_open ? "(" : "[") + format_number(low) + ", " + format_number(high) +
           (high_open ? ")" : "]");
  }
};
constexpr Bounds kAnyValue{};
constexpr Bounds kPositive{0.0, kInf, true, false};
constexpr Bounds kNonNegative{0.0, kInf, false, false};
constexpr Bounds kUnitInterval{0.0, 1.0, false, false};

// One TOML table being read: knows its dotted path for messages, rejects keys it does
// not know as soon as it is opened, and reads typed, range-checked values.
class TableReader {
 public:
  // `misplaced_hint` may say where an unknown key belongs instead ("... goes in [simulation]").
  TableReader(const std::string& origin, const toml::table& table, std::string path,
              std::vector<std::string_view> known_keys,
              const std::function<std::string(std::string_view)>& misplaced_hint = {})
      : origin_(origin), table_(table), path_(std::move(path)), known_keys_(std::move(known_keys)) {
    reject_unknown_keys(misplaced_hint);
  }

  const toml::table& table() const { return table_; }
  const std::string& path() const { return path_; }
  std::string field(std::string_view key) const {
    return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
  }
  const toml::node* find(std::string_view key) const { return table_.get(key); }
  bool has(std::string_view key) const { return find(key) != nullptr; }

  [[noreturn]] void fail(const toml::source_region& where, const std::string& field,
                         const std::string& problem) const {
    std::ostringstream message;
    message << origin_ << ':' << where.begin.line << ':' << where.begin.column << ": " << field << ": "
            << problem;
    throw SceneError(message.str());
  }
  // At the value of `key` (which must be present).
  [[noreturn]] void fail_at(std::string_view key, const std::string& problem) const {
    fail(find(key)->source(), field(key), problem);
  }
  // At the table itself: for what is missing from it.
  [[noreturn]] void fail_here(const std::string& field_name, const std::string& problem) const {
    fail(table_.source(), field_name, problem);
  }
  [[noreturn]] void fail_missing(std::string_view key, const std::string& why = "") const {
    fail_here(field(key), "missing required key" + why);
  }

  double number(std::string_view key, double fallback, const Bounds& bounds) const {
    const toml::node* node = find(key);
    return node ? to_number(*node, field(key), bounds) : fallback;
  }
  double required_number(std::string_view key, const Bounds& bounds, const std::string& why = "") const {
    if (!has(key)) fail_missing(key, why);
    return number(key, 0.0, bounds);
  }

  std::int64_t integer(std::string_view key, std::int64_t fallback, std::int64_t low,
                       std::int64_t high) const {
    const toml::node* node = find(key);
    if (!node) return fallback;
    const auto* value = node->as_integer();
    if (!value) fail_at(key, "expected an integer (got " + describe_type(*node) + ")");
    const std::int64_t v = value->get();
    if (v < low || v > high) {
      const std::string range = high == std::numeric_limits<std::int64_t>::max()
                                    ? ">= " + std::to_string(low)
                                    : "in [" + std::to_string(low) + ", " + std::to_string(high) + "]";
      fail_at(key, "must be " + range + " (got " + std::to_string(v) + ")");
    }
    return v;
  }

  bool boolean(std::string_view key, bool fallback) const {
    const toml::node* node = find(key);
    if (!node) return fallback;
    const auto* value = node->as_boolean();
    if (!value) fail_at(key, "expected true or false (got " + describe_type(*node) + ")");
    return value->get();
  }

  std::optional<std::string> string(std::string_view key) const {
    const toml::node* node = find(key);
    if (!node) return std::nullopt;
    const auto* value = node->as_string();
    if (!value) fail_at(key, "expected a string (got " + describe_type(*node) + ")");
    if (value->get().empty()) fail_at(key, "must not be empty");
    return value->get();
  }

  Vec3 vec3(std::string_view key, const Vec3& fallback, const Bounds& bounds = kAnyValue) const {
    const toml::node* node = find(key);
    return node ? to_vec3(*node, field(key), bounds) : fallback;
  }

  const toml::table* subtable(std::string_view key) const {
    const toml::node* node = find(key);
    if (!node) return nullptr;
    const auto* table = node->as_table();
    if (!table) fail_at(key, "expected a table (got " + describe_type(*node) + ")");
    return table;
  }

  double to_number(const toml::node& node, const std::string& field_name, const Bounds& bounds) const {
    double v = 0.0;
    if (const auto* integer = node.as_integer()) {
      v = static_cast<double>(integer->get());
    } else if (const auto* floating = node.as_floating_point()) {
      v = floating->get();
    } else {
      fail(node.source(), field_name, "expected a number (got " + describe_type(node) + ")");
    }
    // Checked before any comparison: comparing a NaN raises FE_INVALID.
    if (!std::isfinite(v)) fail(node.source(), field_name, "must be finite (got " + format_number(v) + ")");
    if (!bounds.contains(v)) {
      fail(node.source(), field_name, "must be " + bounds.describe() + " (got " + format_number(v) + ")");
    }
    return v;
  }

  Vec3 to_vec3(const toml::node& node, const std::string& field_name, const Bounds& bounds) const {
    const auto* array = node.as_array();
    if (!array)
      fail(node.source(), field_name, "expected an array [x, y, z] (got " + describe_type(node) + ")");
    if (array->size() != 3) {
      fail(node.source(), field_name,
           "expected 3 numbers [x, y, z] (got " + std::to_string(array->size()) + ")");
    }
    Vec3 v;
    for (int i = 0; i < 3; ++i) {
      v[i] = to_number(*array->get(static_cast<std::size_t>(i)), field_name + "[" + std::to_string(i) + "]",
                       bounds);
    }
    return v;
  }

 private:
  void reject_unknown_keys(const std::function<std::string(std::string_view)>& misplaced_hint) const {
    // The earliest unknown key in the file, not the first in the table's sorted order.
    const toml::key* first_unknown = nullptr;
    for (auto&& [key, value] : table_) {
      (void)value;
      if (std::find(known_keys_.begin(), known_keys_.end(), key.str()) != known_keys_.end()) continue;
      const auto& here = key.source().begin;
      if (!first_unknown || here.line < first_unknown->source().begin.line ||
          (here.line == first_unknown->source().begin.line &&
           here.column < first_unknown->source().begin.column)) {
        first_unknown = &key;
      }
    }
    if (!first_unknown) return;
    const std::string_view name = first_unknown->str();
    std::string problem = "unknown key " + in_quotes(name);
    if (const auto suggestion = closest_match(name, known_keys_)) {
      problem += "; did you mean " + in_quotes(*suggestion) + "?";
    } else if (std::string hint = misplaced_hint ? misplaced_hint(name) : ""; !hint.empty()) {
      problem += "; " + hint;
    } else {
      problem += " (valid keys: " + join(known_keys_) + ")";
    }
    fail(first_unknown->source(), field(name), problem);
  }

  const std::string& origin_;
  const toml::table& table_;
  std::string path_;
  std::vector<std::string_view> known_keys_;
};

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
  // `[[plane]]` / `[[object]]`: an array whose every element is a table.
  std::vector<const toml::table*> array_of_tables(const TableReader& root, std::string_view key) const {
    std::vector<const toml::table*> tables;
    const toml::node* node = root.find(key);
    if (!node) return tables;
    const auto* array = node->as_array();
    if (!array) {
      root.fail_at(key,
                   "expected an array of tables; write [[" + std::string(key) + "]] with double brackets");
    }
    for (std::size_t i = 0; i < array->size(); ++i) {
      const toml::node& element = *array->get(i);
      const auto* table = element.as_table();
      if (!table) {
        root.fail(element.source(), std::string(key) + "[" + std::to_string(i) + "]",
                  "expected a table (got " + describe_type(element) + ")");
      }
      tables.push_back(table);
    }
    return tables;
  }

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
  toml::table root;
  try {
    root = toml::parse(text, std::string_view(origin));
  } catch (const toml::parse_error& e) {
    std::ostringstream message;
    message << origin << ':' << e.source().begin.line << ':' << e.source().begin.column
            << ": TOML syntax error: " << e.description();
    throw SceneError(message.str());
  }
  return SceneReader(origin, base_dir).read(root);
}

SceneSpec load_scene_file(const std::string& path) {
  std::error_code error;
  std::ifstream file(path, std::ios::binary);
  // A folder opens as a stream on Linux but cannot be read.
  if (!file || std::filesystem::is_directory(path, error))
    throw SceneError(path + ": cannot open scene file");
  std::ostringstream text;
  text << file.rdbuf();
  if (file.bad()) throw SceneError(path + ": cannot read scene file");
  return parse_scene(text.str(), path, std::filesystem::path(path).parent_path().string());
}

std::string default_scene_path() { return FFDSIM_SCENARIO_DIR "/scenes/two_teapots.toml"; }

SceneSpec default_scene() { return load_scene_file(default_scene_path()); }

}  // namespace ffd
