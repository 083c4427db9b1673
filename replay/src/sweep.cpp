// Sweep files -> SweepPlan, the plan's folder, and the merge of its results (docs/sweeps.md).
// Strict like the scene and replay readers: errors name file:line:col and the field.
#include "ffd/sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "ffd/replay_runner.h"

namespace ffd {
namespace {

namespace fs = std::filesystem;

const std::vector<std::string_view> kRootKeys = {"format", "version", "description", "replay", "threads",
                                                 "parameters", "point"};
const std::vector<std::string_view> kRangeKeys = {"from", "to", "count"};

enum class ValueKind { Number, Integer, Flag, Name };

// A parameter a sweep may vary: a key of the scene's [simulation] table, or of every
// mass-spring object's [mass_spring] table ("stiffness"; "NAME.stiffness" for one object).
struct ParameterDef {
  std::string_view name;
  ValueKind kind;
  Bounds bounds;                     // numbers and integers
  std::vector<std::string_view> names;  // Name: the values allowed
  bool per_object;
  std::optional<CommandKind> command;   // the live command that also sets it, if any
  std::function<void(SimulationSettings&, const SweepValue&)> set_simulation;
  std::function<void(MassSpringParams&, const SweepValue&)> set_object;
};

double number_of(const SweepValue& v) {
  if (const auto* d = std::get_if<double>(&v)) return *d;
  if (const auto* i = std::get_if<std::int64_t>(&v)) return static_cast<double>(*i);
  return 0.0;
}

const std::vector<ParameterDef>& parameter_defs() {
  static const std::vector<ParameterDef> defs = [] {
    std::vector<ParameterDef> d;
    const auto sim = [&](std::string_view name, ValueKind kind, Bounds bounds,
                         std::function<void(SimulationSettings&, const SweepValue&)> set,
                         std::vector<std::string_view> names = {}) {
      d.push_back({name, kind, bounds, std::move(names), false, std::nullopt, std::move(set), {}});
    };
    const auto obj = [&](std::string_view name, ValueKind kind, Bounds bounds,
                         std::function<void(MassSpringParams&, const SweepValue&)> set) {
      d.push_back({name, kind, bounds, {}, true, std::nullopt, {}, std::move(set)});
    };
    sim("alpha", ValueKind::Number, kUnitInterval, [](SimulationSettings& s, const SweepValue& v) { s.alpha = number_of(v); });
    sim("beta", ValueKind::Number, kUnitInterval, [](SimulationSettings& s, const SweepValue& v) { s.beta = number_of(v); });
    sim("accuracy", ValueKind::Integer, Bounds{0, kAccuracyLevels - 1},
        [](SimulationSettings& s, const SweepValue& v) { s.accuracy = static_cast<Accuracy>(std::get<std::int64_t>(v)); });
    sim(
        "response", ValueKind::Name, kAnyValue,
        [](SimulationSettings& s, const SweepValue& v) { response_from_name(std::get<std::string>(v), s.response); },
        {"paper", "solver"});
    sim("rolling_resistance", ValueKind::Number, kNonNegative,
        [](SimulationSettings& s, const SweepValue& v) { s.rolling_resistance = number_of(v); });
    sim("seed", ValueKind::Integer, Bounds{0, 9.0e15},
        [](SimulationSettings& s, const SweepValue& v) { s.seed = static_cast<std::uint64_t>(std::get<std::int64_t>(v)); });
    sim("edge_contacts", ValueKind::Flag, kAnyValue,
        [](SimulationSettings& s, const SweepValue& v) { s.edge_contacts = std::get<bool>(v); });
    sim("box_overlap", ValueKind::Flag, kAnyValue,
        [](SimulationSettings& s, const SweepValue& v) { s.box_overlap = std::get<bool>(v); });
    sim("probe_stiffness", ValueKind::Number, kNonNegative,
        [](SimulationSettings& s, const SweepValue& v) { s.probe.coupling_stiffness = number_of(v); });
    obj("stiffness", ValueKind::Number, kPositive, [](MassSpringParams& p, const SweepValue& v) { p.stiffness = number_of(v); });
    obj("damping", ValueKind::Number, kNonNegative, [](MassSpringParams& p, const SweepValue& v) { p.damping = number_of(v); });
    obj("iterations", ValueKind::Integer, Bounds{1, 100},
        [](MassSpringParams& p, const SweepValue& v) { p.iterations = static_cast<int>(std::get<std::int64_t>(v)); });
    obj("shape_stiffness", ValueKind::Number, kNonNegative,
        [](MassSpringParams& p, const SweepValue& v) { p.shape_stiffness = number_of(v); });
    obj("bulk_modulus", ValueKind::Number, kNonNegative,
        [](MassSpringParams& p, const SweepValue& v) { p.bulk_modulus = number_of(v); });
    const std::pair<std::string_view, CommandKind> live[] = {
        {"alpha", CommandKind::SetAlpha},         {"beta", CommandKind::SetBeta},
        {"accuracy", CommandKind::SetAccuracy},   {"response", CommandKind::SetResponse},
        {"stiffness", CommandKind::SetStiffness}, {"probe_stiffness", CommandKind::SetProbeStiffness}};
    for (ParameterDef& def : d)
      for (const auto& [name, kind] : live)
        if (def.name == name) def.command = kind;
    return d;
  }();
  return defs;
}

// "stiffness" -> (stiffness, all objects); "teapot_low.stiffness" -> (stiffness, teapot_low).
struct ParameterName {
  const ParameterDef* def = nullptr;
  std::string object;  // empty: every mass-spring object
};

std::optional<ParameterName> find_parameter(std::string_view name) {
  std::string_view key = name, object;
  if (const std::size_t dot = name.rfind('.'); dot != std::string_view::npos) {
    object = name.substr(0, dot);
    key = name.substr(dot + 1);
  }
  for (const ParameterDef& def : parameter_defs())
    if (def.name == key && (object.empty() || def.per_object)) return ParameterName{&def, std::string(object)};
  return std::nullopt;
}

std::vector<std::string_view> parameter_keys() {
  std::vector<std::string_view> keys;
  for (const ParameterDef& def : parameter_defs()) keys.push_back(def.name);
  return keys;
}

// A table's parameters as (name, value node) in the file's order: "alpha = ...", and an
// object's own as "high.stiffness = ..." (TOML's dotted keys make that a table "high").
struct NamedNode {
  std::string name;
  const toml::node* node;
};

bool before(const toml::node* a, const toml::node* b) {
  const auto& sa = a->source().begin;
  const auto& sb = b->source().begin;
  return sa.line != sb.line ? sa.line < sb.line : sa.column < sb.column;
}

class SweepReader {
 public:
  SweepReader(const std::string& origin, const std::string& base_dir) : origin_(origin), base_dir_(base_dir) {}

  SweepPlan read(const toml::table& root_table) {
    const TableReader root(origin_, root_table, "", kRootKeys);
    SweepPlan plan;
    plan.sweep_file = origin_.empty() ? origin_ : fs::absolute(origin_).lexically_normal().string();
    root.check_format("ffdsim-sweep", kSweepFormatVersion);
    plan.description = root.string("description").value_or("");
    const auto replay = root.string("replay");
    if (!replay) root.fail_missing("replay", " (the replay script every job runs)");
    plan.replay = (fs::path(base_dir_) / *replay).lexically_normal().string();
    plan.replay = fs::absolute(plan.replay).lexically_normal().string();
    plan.threads = static_cast<int>(root.integer("threads", 1, 1, 64));
    const bool grid = root.has("parameters"), points = root.has("point");
    if (grid == points)
      root.fail_here("parameters", grid ? "give either [parameters] (a grid) or [[point]] (a list), not both"
                                        : "missing: [parameters] (a grid of values) or [[point]] (a list of points)");
    if (grid) read_grid(root, plan);
    else read_points(root, plan);
    return plan;
  }

 private:
  // One value of parameter `name` from a TOML node, checked against its kind and range.
  SweepValue value(const TableReader& table, const ParameterName& p, const toml::node& node, const std::string& field) {
    const ParameterDef& def = *p.def;
    switch (def.kind) {
      case ValueKind::Number: return table.to_number(node, field, def.bounds);
      case ValueKind::Integer: {
        const auto* i = node.as_integer();
        if (!i) table.fail(node.source(), field, "expected an integer (got " + describe_type(node) + ")");
        if (!def.bounds.contains(static_cast<double>(i->get())))
          table.fail(node.source(), field, "must be " + def.bounds.describe() + " (got " + std::to_string(i->get()) + ")");
        return i->get();
      }
      case ValueKind::Flag: {
        const auto* b = node.as_boolean();
        if (!b) table.fail(node.source(), field, "expected true or false (got " + describe_type(node) + ")");
        return b->get();
      }
      case ValueKind::Name: {
        const auto* s = node.as_string();
        if (!s) table.fail(node.source(), field, "expected a string (got " + describe_type(node) + ")");
        if (std::find(def.names.begin(), def.names.end(), s->get()) == def.names.end())
          table.fail(node.source(), field, "must be one of " + join(def.names) + " (got " + in_quotes(s->get()) + ")");
        return s->get();
      }
    }
    return 0.0;
  }

  [[noreturn]] void not_a_parameter(const TableReader& table, const std::string& name, const toml::node& node) {
    std::string hint;
    const std::string_view key = std::string_view(name).substr(name.rfind('.') == std::string::npos ? 0 : name.rfind('.') + 1);
    if (const auto near = closest_match(key, parameter_keys())) hint = "; did you mean " + in_quotes(*near) + "?";
    table.fail(node.source(), table.field(name),
               "not a parameter a sweep can vary (" + join(parameter_keys()) + ", or OBJECT.key for one object's " +
                   "stiffness, damping, iterations, shape_stiffness or bulk_modulus)" + hint);
  }

  // The parameters of `table`, flattened and in the file's order.
  std::vector<NamedNode> parameters_of(const TableReader& reader) {
    std::vector<NamedNode> out;
    for (auto&& [key, node] : reader.table()) {
      const std::string name(key.str());
      if (find_parameter(name)) {
        out.push_back({name, &node});
        continue;
      }
      const auto* object = node.as_table();
      if (!object || object->empty()) not_a_parameter(reader, name, node);
      for (auto&& [sub, sub_node] : *object) {
        const std::string scoped = name + "." + std::string(sub.str());
        const auto p = find_parameter(scoped);
        if (!p) not_a_parameter(reader, scoped, sub_node);
        out.push_back({scoped, &sub_node});
      }
    }
    std::sort(out.begin(), out.end(), [](const NamedNode& a, const NamedNode& b) { return before(a.node, b.node); });
    return out;
  }

  // [parameters]: each key a list of values or {from, to, count}; the grid of all of them,
  // the last parameter varying fastest.
  void read_grid(const TableReader& root, SweepPlan& plan) {
    const toml::table& table = *root.subtable("parameters");
    std::vector<std::string_view> keys;
    for (auto&& [key, node] : table) keys.push_back(key.str());
    const TableReader reader(origin_, table, "parameters", keys);
    const std::vector<NamedNode> named = parameters_of(reader);
    if (named.empty()) reader.fail_here("parameters", "names no parameter");
    std::vector<std::vector<SweepValue>> axes;
    for (const NamedNode& n : named) {
      const ParameterName p = *find_parameter(n.name);
      const toml::node& node = *n.node;
      const std::string field = reader.field(n.name);
      std::vector<SweepValue> values;
      if (const auto* array = node.as_array()) {
        for (std::size_t i = 0; i < array->size(); ++i)
          values.push_back(value(reader, p, *array->get(i), field + "[" + std::to_string(i) + "]"));
      } else if (const auto* range = node.as_table()) {
        if (p.def->kind != ValueKind::Number)
          reader.fail(node.source(), field, "a range {from, to, count} is for numbers; list the values instead");
        const TableReader r(origin_, *range, field, kRangeKeys);
        const double from = r.required_number("from", p.def->bounds), to = r.required_number("to", p.def->bounds);
        if (!r.has("count")) r.fail_missing("count");
        const std::int64_t count = r.integer("count", 0, 1, static_cast<std::int64_t>(kMaxSweepJobs));
        if (count == 1 && from != to) r.fail_at("count", "must be at least 2 for a range from " + format_number(from) +
                                                            " to " + format_number(to));
        for (std::int64_t i = 0; i < count; ++i) {
          const double v = count == 1 ? from
                                      : (from * static_cast<double>(count - 1 - i) + to * static_cast<double>(i)) /
                                            static_cast<double>(count - 1);  // the ends exact
          // To 12 significant digits: 0.3 as a user would type it, not 0.30000000000000004.
          char text[32];
          std::snprintf(text, sizeof text, "%.12g", v);
          values.push_back(std::strtod(text, nullptr));
        }
      } else {
        reader.fail(node.source(), field, "expected a list of values or a range {from, to, count} (got " + describe_type(node) + ")");
      }
      if (values.empty()) reader.fail(node.source(), field, "names no value");
      plan.parameters.push_back(n.name);
      axes.push_back(std::move(values));
    }
    double jobs = 1.0;
    for (const auto& axis : axes) jobs *= static_cast<double>(axis.size());
    if (jobs > static_cast<double>(kMaxSweepJobs))
      reader.fail_here("parameters", "a grid of " + format_number(jobs) + " jobs; at most " + std::to_string(kMaxSweepJobs));
    std::vector<std::size_t> at(axes.size(), 0);
    for (std::size_t j = 0; j < static_cast<std::size_t>(jobs); ++j) {
      SweepJob job;
      for (std::size_t a = 0; a < axes.size(); ++a) job.values.push_back(axes[a][at[a]]);
      plan.jobs.push_back(std::move(job));
      for (std::size_t a = axes.size(); a-- > 0;) {
        if (++at[a] < axes[a].size()) break;
        at[a] = 0;
      }
    }
    number_jobs(plan);
  }

  // [[point]]: each point the same parameters, a value each.
  void read_points(const TableReader& root, SweepPlan& plan) {
    const toml::node& node = *root.find("point");
    const auto* array = node.as_array();
    if (!array || !array->is_array_of_tables())
      root.fail_at("point", "expected [[point]] tables (got " + describe_type(node) + ")");
    if (array->size() > kMaxSweepJobs)
      root.fail_at("point", std::to_string(array->size()) + " points; at most " + std::to_string(kMaxSweepJobs));
    for (std::size_t i = 0; i < array->size(); ++i) {
      const toml::table& point = *array->get(i)->as_table();
      std::vector<std::string_view> keys;
      for (auto&& [key, v] : point) keys.push_back(key.str());
      const TableReader reader(origin_, point, "point[" + std::to_string(i) + "]", keys);
      const std::vector<NamedNode> named = parameters_of(reader);
      if (i == 0) {
        if (named.empty()) reader.fail_here(reader.path(), "names no parameter");
        for (const NamedNode& n : named) plan.parameters.push_back(n.name);
      }
      const std::string first = join(std::vector<std::string_view>(plan.parameters.begin(), plan.parameters.end()));
      SweepJob job;
      for (const std::string& name : plan.parameters) {
        const auto it = std::find_if(named.begin(), named.end(), [&](const NamedNode& n) { return n.name == name; });
        if (it == named.end())
          reader.fail_here(reader.field(name), "missing required key (every point gives the parameters of the first: " + first + ")");
        job.values.push_back(value(reader, *find_parameter(name), *it->node, reader.field(name)));
      }
      for (const NamedNode& n : named)
        if (std::find(plan.parameters.begin(), plan.parameters.end(), n.name) == plan.parameters.end())
          reader.fail(n.node->source(), reader.field(n.name), "not a parameter of the first point (" + first + ")");
      plan.jobs.push_back(std::move(job));
    }
    if (plan.jobs.empty()) root.fail_at("point", "names no point");
    number_jobs(plan);
  }

  static void number_jobs(SweepPlan& plan) {
    const std::size_t width = std::max<std::size_t>(4, std::to_string(plan.jobs.size()).size());
    for (std::size_t j = 0; j < plan.jobs.size(); ++j) {
      std::string id = std::to_string(j + 1);
      plan.jobs[j].id = std::string(width - id.size(), '0') + id;
    }
  }

  std::string origin_, base_dir_;
};

nlohmann::json value_json(const SweepValue& v) {
  return std::visit([](const auto& x) { return nlohmann::json(x); }, v);
}

SweepValue value_from_json(const nlohmann::json& j, const std::string& where) {
  if (j.is_boolean()) return j.get<bool>();
  if (j.is_number_integer()) return j.get<std::int64_t>();
  if (j.is_number_float()) return j.get<double>();
  if (j.is_string()) return j.get<std::string>();
  throw InputError(where + ": a parameter value is neither a number, a flag nor a name");
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out.flush()) throw std::runtime_error(path.string() + ": cannot write");
}

std::string shell_quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace

std::string sweep_value_text(const SweepValue& value) {
  if (const auto* d = std::get_if<double>(&value)) return format_number(*d);
  if (const auto* i = std::get_if<std::int64_t>(&value)) return std::to_string(*i);
  if (const auto* b = std::get_if<bool>(&value)) return *b ? "true" : "false";
  return std::get<std::string>(value);
}

SweepPlan parse_sweep(const std::string& text, const std::string& origin, const std::string& base_dir) {
  return SweepReader(origin, base_dir).read(parse_toml(text, origin));
}

SweepPlan load_sweep_file(const std::string& path) {
  return parse_sweep(read_text_file(path, "sweep file"), path, fs::path(path).parent_path().string());
}

LoadedReplay load_sweep_job(const SweepPlan& plan, const SweepJob& job) {
  std::optional<ContactResponse> response;
  for (std::size_t i = 0; i < plan.parameters.size(); ++i)
    if (plan.parameters[i] == "response") response_from_name(std::get<std::string>(job.values[i]), response.emplace());
  LoadedReplay replay = load_replay_file(plan.replay, {}, RecordedScene::MustMatch, response);
  SceneSpec& scene = replay.script.scene;
  for (std::size_t i = 0; i < plan.parameters.size(); ++i) {
    const std::string& name = plan.parameters[i];
    const auto p = find_parameter(name);
    if (!p) throw InputError(plan.sweep_file + ": " + name + ": not a parameter a sweep can vary");
    if (!p->def->per_object) {
      p->def->set_simulation(scene.settings, job.values[i]);
      continue;
    }
    bool named = false, applied = false;
    for (ObjectSpec& object : scene.objects) {
      if (!p->object.empty() && object.name != p->object) continue;
      named = true;
      if (object.dynamics != DynamicsKind::MassSpring) continue;
      p->def->set_object(object.mass_spring, job.values[i]);
      applied = true;
    }
    if (!named) {
      std::vector<std::string_view> names;
      for (const ObjectSpec& object : scene.objects) names.push_back(object.name);
      throw InputError(plan.sweep_file + ": " + name + ": the replay's scene has no object " + in_quotes(p->object) +
                       " (its objects: " + join(names) + ")");
    }
    if (!applied)
      throw InputError(plan.sweep_file + ": " + name + ": " +
                       (p->object.empty() ? std::string("the replay's scene has no mass-spring object")
                                          : "object " + in_quotes(p->object) + " is not a mass-spring object") +
                       " (it is a [mass_spring] key)");
  }
  // A parameter the replay's own commands set would hold only until the first of them: refused.
  for (std::size_t i = 0; i < plan.parameters.size(); ++i) {
    const auto p = find_parameter(plan.parameters[i]);
    if (!p->def->command) continue;
    for (const Command& c : replay.script.commands)
      if (c.kind == *p->def->command &&
          (p->object.empty() || c.object == kNoIndex || replay.model.objects[c.object].name == p->object)) {
        throw InputError(plan.sweep_file + ": " + plan.parameters[i] + ": the replay " + plan.replay +
                         " sets it itself (a " + command_name(c.kind) + " command at step " + std::to_string(c.step) +
                         "), which would override the sweep's value: sweep another parameter or a replay without it");
      }
  }
  std::vector<std::string> log;
  replay.model = compile(scene, log);
  replay.script.hashes.clear();  // the point's state is its own: reported, not checked
  return replay;
}

namespace {
// A value as TOML: what the scene loader reads for the parameter.
void set_toml(toml::table& table, std::string_view key, const SweepValue& value, ValueKind kind) {
  switch (kind) {
    case ValueKind::Number: table.insert_or_assign(key, number_of(value)); break;
    case ValueKind::Integer: table.insert_or_assign(key, std::get<std::int64_t>(value)); break;
    case ValueKind::Flag: table.insert_or_assign(key, std::get<bool>(value)); break;
    case ValueKind::Name: table.insert_or_assign(key, std::get<std::string>(value)); break;
  }
}

toml::table& subtable(toml::table& table, std::string_view key) {
  if (!table[key].is_table()) table.insert_or_assign(key, toml::table{});
  return *table[key].as_table();
}

// Where a parameter lives in a scene file: [simulation] key, [probe] key, or an object's
// [mass_spring] key.
std::pair<std::string_view, std::string_view> scene_key(const ParameterDef& def) {
  if (def.per_object) return {"mass_spring", def.name};
  if (def.name == "probe_stiffness") return {"probe", "coupling_stiffness"};
  return {"simulation", def.name};
}
}  // namespace

std::string sweep_point_scene(const SweepPlan& plan, const SweepJob& job) {
  const std::string replay_text = read_text_file(plan.replay, "replay script");
  const toml::table replay = parse_toml(replay_text, plan.replay);
  // The scene: the file the replay names (its paths relative to it), or its inline [scene].
  toml::table scene;
  fs::path base = fs::path(plan.replay).parent_path();
  if (const auto* name = replay["scene"].as_string()) {
    const fs::path path = (base / name->get()).lexically_normal();
    scene = parse_toml(read_text_file(path.string(), "scene file"), path.string());
    base = path.parent_path();
  } else if (const auto* inline_scene = replay["scene"].as_table()) {
    scene = *inline_scene;
  } else {
    throw InputError(plan.replay + ": names no scene");
  }
  const auto absolute = [&](toml::table& table, std::string_view key) {
    if (const auto* path = table[key].as_string(); path && fs::path(path->get()).is_relative())
      table.insert_or_assign(key, (base / path->get()).lexically_normal().string());
  };
  for (std::string_view list : {"object", "group"})
    if (auto* tables = scene[list].as_array())
      for (toml::node& node : *tables)
        if (auto* t = node.as_table()) {
          absolute(*t, "mesh");
          if (auto* glyph = (*t)["glyph"].as_table()) absolute(*glyph, "font");
        }
  // The values: the replay's step-0 settings first, then the job's.
  const LoadedReplay loaded = load_sweep_job(plan, job);  // checks the point as a job would
  std::vector<std::pair<std::string, SweepValue>> values;
  for (const Command& c : loaded.script.commands) {
    if (c.step != 0) continue;
    for (const ParameterDef& def : parameter_defs()) {
      if (!def.command || *def.command != c.kind) continue;
      SweepValue v = c.value;
      if (def.kind == ValueKind::Integer) v = static_cast<std::int64_t>(c.value);
      if (def.kind == ValueKind::Name) v = std::string(response_name(static_cast<ContactResponse>(static_cast<int>(c.value))));
      std::string name(def.name);
      if (def.per_object) name = loaded.model.objects[c.object].name + "." + name;
      values.emplace_back(name, v);
    }
  }
  for (std::size_t i = 0; i < plan.parameters.size(); ++i) values.emplace_back(plan.parameters[i], job.values[i]);
  for (const auto& [name, value] : values) {
    const ParameterName p = *find_parameter(name);
    const auto [table_name, key] = scene_key(*p.def);
    if (!p.def->per_object) {
      set_toml(subtable(scene, table_name), key, value, p.def->kind);
      continue;
    }
    bool found = false;
    if (auto* objects = scene["object"].as_array())
      for (toml::node& node : *objects)
        if (auto* t = node.as_table();
            t && (p.object.empty() || (t->get_as<std::string>("name") && t->get_as<std::string>("name")->get() == p.object))) {
          found = true;
          if (t->contains("mass_spring")) set_toml(subtable(*t, "mass_spring"), key, value, p.def->kind);
        }
    if (auto* groups = scene["group"].as_array())
      for (toml::node& node : *groups)
        if (auto* t = node.as_table(); t && p.object.empty() && t->contains("mass_spring")) {
          found = true;
          set_toml(subtable(*t, "mass_spring"), key, value, p.def->kind);
        }
    if (!found)
      throw InputError(plan.sweep_file + ": " + name + ": the object is made by a [[group]] of the scene, whose " +
                       "objects share their keys: its own value cannot be written into a scene file");
  }
  std::ostringstream text;
  text << "# The point " << job.id << " of the sweep " << plan.sweep_file << ":";
  for (std::size_t i = 0; i < plan.parameters.size(); ++i)
    text << ' ' << plan.parameters[i] << " = " << sweep_value_text(job.values[i]);
  text << "\n# (ffdsim sweep wrote it from the replay " << plan.replay << ")\n" << scene << "\n";
  return text.str();
}

std::string sweep_result_path(const std::string& dir, const std::string& id) {
  return (fs::path(dir) / "results" / (id + ".json")).string();
}

void write_file_atomically(const std::string& path, const std::string& text) {
  const fs::path target(path);
  const fs::path temporary = target.parent_path() / ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()));
  write_text(temporary, text);
  std::error_code error;
  fs::rename(temporary, target, error);
  if (error) {
    fs::remove(temporary, error);
    throw std::runtime_error(path + ": cannot write (" + error.message() + ")");
  }
}

void write_sweep_plan(const SweepPlan& plan, const std::string& dir, const std::string& program) {
  const fs::path folder = fs::absolute(dir).lexically_normal();
  fs::create_directories(folder / "results");
  fs::create_directories(folder / "logs");
  nlohmann::json j;
  j["format"] = "ffdsim-sweep-plan";
  j["version"] = kSweepFormatVersion;
  j["sweep_file"] = plan.sweep_file;
  j["replay"] = plan.replay;
  j["description"] = plan.description;
  j["threads"] = plan.threads;
  j["plan_s"] = plan.plan_s;
  j["parameters"] = plan.parameters;
  j["jobs"] = nlohmann::json::array();
  for (const SweepJob& job : plan.jobs) {
    nlohmann::json values = nlohmann::json::array();
    for (const SweepValue& v : job.values) values.push_back(value_json(v));
    j["jobs"].push_back({{"id", job.id}, {"values", values}});
  }
  write_file_atomically((folder / "plan.json").string(), j.dump(1) + "\n");
  std::ostringstream tsv;
  tsv << "id";
  for (const std::string& name : plan.parameters) tsv << '\t' << name;
  tsv << '\n';
  for (const SweepJob& job : plan.jobs) {
    tsv << job.id;
    for (const SweepValue& v : job.values) tsv << '\t' << sweep_value_text(v);
    tsv << '\n';
  }
  write_file_atomically((folder / "jobs.tsv").string(), tsv.str());
  const std::string quoted_dir = shell_quoted(folder.string()), quoted_program = shell_quoted(program);
  std::ostringstream sbatch;
  sbatch << "#!/bin/bash\n"
         << "# A Slurm job array: one array task per job of jobs.tsv (ffdsim sweep plan wrote it).\n"
         << "#SBATCH --job-name=ffdsim-sweep\n"
         << "#SBATCH --array=1-" << plan.jobs.size() << "\n"
         << "#SBATCH --cpus-per-task=" << plan.threads << "\n"
         << "#SBATCH --output=" << (folder / "logs" / "slurm-%A_%a.out").string() << "\n"
         << "id=$(sed -n \"$((SLURM_ARRAY_TASK_ID + 1))p\" " << quoted_dir << "/jobs.tsv | cut -f1)\n"
         << "exec " << quoted_program << " sweep run-one " << quoted_dir << " \"$id\"\n";
  write_file_atomically((folder / "sweep.sbatch").string(), sbatch.str());
  std::ostringstream parallel;
  parallel << "#!/bin/sh\n"
           << "# GNU parallel: every job of jobs.tsv, as many at once as parallel runs (--jobs N to say).\n"
           << "tail -n +2 " << quoted_dir << "/jobs.tsv | cut -f1 | parallel \"$@\" " << quoted_program << " sweep run-one "
           << quoted_dir << " {}\n";
  write_file_atomically((folder / "parallel.sh").string(), parallel.str());
  fs::permissions(folder / "parallel.sh", fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec,
                  fs::perm_options::add);
}

SweepPlan read_sweep_plan(const std::string& dir) {
  const std::string path = (fs::path(dir) / "plan.json").string();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_text_file(path, "sweep plan"));
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path + ": not a sweep plan (" + e.what() + ")");
  }
  try {
    if (j.value("format", "") != "ffdsim-sweep-plan") throw InputError(path + ": not a sweep plan (format)");
    SweepPlan plan;
    plan.sweep_file = j.at("sweep_file").get<std::string>();
    plan.replay = j.at("replay").get<std::string>();
    plan.description = j.value("description", "");
    plan.threads = j.value("threads", 1);
    plan.plan_s = j.value("plan_s", 0.0);
    plan.parameters = j.at("parameters").get<std::vector<std::string>>();
    std::vector<ValueKind> kinds;
    for (const std::string& name : plan.parameters) {
      const auto p = find_parameter(name);
      if (!p) throw InputError(path + ": " + name + ": not a parameter a sweep can vary");
      kinds.push_back(p->def->kind);
    }
    for (const nlohmann::json& job : j.at("jobs")) {
      SweepJob out;
      out.id = job.at("id").get<std::string>();
      for (const nlohmann::json& v : job.at("values")) out.values.push_back(value_from_json(v, path));
      if (out.values.size() != plan.parameters.size()) throw InputError(path + ": job " + out.id + ": wrong number of values");
      for (std::size_t i = 0; i < kinds.size(); ++i) {
        const SweepValue& v = out.values[i];
        const bool fits = kinds[i] == ValueKind::Number   ? std::holds_alternative<double>(v) || std::holds_alternative<std::int64_t>(v)
                          : kinds[i] == ValueKind::Integer ? std::holds_alternative<std::int64_t>(v)
                          : kinds[i] == ValueKind::Flag    ? std::holds_alternative<bool>(v)
                                                           : std::holds_alternative<std::string>(v);
        if (!fits) throw InputError(path + ": job " + out.id + ": " + plan.parameters[i] + ": a value of the wrong type");
        if (kinds[i] == ValueKind::Number) out.values[i] = number_of(v);  // 2 as 2.0, as the sweep file reads it
      }
      plan.jobs.push_back(std::move(out));
    }
    if (plan.jobs.empty()) throw InputError(path + ": the plan holds no job");
    return plan;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path + ": not a sweep plan (" + e.what() + ")");
  }
}

const SweepJob* find_sweep_job(const SweepPlan& plan, const std::string& id) {
  for (const SweepJob& job : plan.jobs)
    if (job.id == id) return &job;
  return nullptr;
}

namespace {
// A result's parameters as the plan would write them: what "matches the plan" compares.
nlohmann::json job_values_json(const SweepPlan& plan, const SweepJob& job) {
  nlohmann::json values = nlohmann::json::object();
  for (std::size_t i = 0; i < plan.parameters.size(); ++i) values[plan.parameters[i]] = value_json(job.values[i]);
  return values;
}

// A job's result, if the file holds one as sweep_job_result_json / sweep_job_failure_json
// write it (anything else, edited or foreign, counts as missing: the job runs again).
std::optional<nlohmann::json> read_result(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  const auto has = [&](const char* key, auto is) { return j.contains(key) && (j[key].*is)(); };
  if (!j.is_object() || !has("replay", &nlohmann::json::is_string) || !has("state", &nlohmann::json::is_string) ||
      !has("exit_code", &nlohmann::json::is_number_integer) || !has("parameters", &nlohmann::json::is_object))
    return std::nullopt;
  if (j.contains("metrics") && !j["metrics"].is_object()) return std::nullopt;
  for (const char* time : {"load_s", "run_s", "job_s"})
    if (j.contains(time) && !j[time].is_number()) return std::nullopt;
  return j;
}

// The value of a ranked metric of a job done, if it has one.
std::optional<double> done_metric(const std::optional<nlohmann::json>& r, const std::string& name) {
  if (!r || r->at("state") != "done" || !r->contains("metrics") || !r->at("metrics").contains(name) ||
      !r->at("metrics").at(name).is_number())
    return std::nullopt;
  return r->at("metrics").at(name).get<double>();
}
}  // namespace

JobState sweep_job_state(const SweepPlan& plan, const std::string& dir, const SweepJob& job) {
  const auto result = read_result(sweep_result_path(dir, job.id));
  if (!result || result->at("replay") != plan.replay || result->at("parameters") != job_values_json(plan, job))
    return JobState::Missing;
  return result->at("state") == "done" ? JobState::Done : JobState::Failed;
}

namespace {
nlohmann::json job_record(const SweepPlan& plan, const SweepJob& job) {
  nlohmann::json j;
  j["id"] = job.id;
  j["replay"] = plan.replay;
  j["parameters"] = job_values_json(plan, job);
  j["ffdsim"] = ffdsim_version();
  return j;
}
}  // namespace

std::string sweep_job_result_json(const SweepPlan& plan, const SweepJob& job, const LoadedReplay& replay,
                                  const ReplayResult& result, double load_s, double run_s) {
  nlohmann::json j = job_record(plan, job);
  j["load_s"] = load_s;
  j["run_s"] = run_s;
  const bool passed = result.passed() && result.finite;
  j["state"] = passed ? "done" : "failed";
  j["exit_code"] = passed ? 0 : !result.finite ? kSweepExitDiverged : kSweepExitAssertionFailed;
  if (!result.finite)
    j["error"] = "the simulation produced a non-finite value at step " +
                 std::to_string(result.first_non_finite_step.value_or(result.steps));
  const std::string& scene = replay.script.scene_origin;
  j["scene"] = scene;
  std::error_code error;
  j["scene_hash"] = fs::is_regular_file(scene, error) ? content_hash_of_file(scene) : content_hash_of_file(plan.replay);
  std::size_t failed = 0;
  nlohmann::json assertions = nlohmann::json::array();
  for (const AssertionResult& a : result.assertions) {
    failed += !a.skipped && !a.passed ? 1 : 0;
    assertions.push_back({{"name", a.name}, {"where", a.where}, {"passed", a.passed}, {"skipped", a.skipped},
                          {"measured", a.measured}, {"limit", a.limit}});
  }
  j["assertions"] = assertions;
  char hash[17];
  std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(result.final_hash));
  j["metrics"] = {{"assertions_failed", failed},
                  {"finite", result.finite ? 1 : 0},
                  {"max_penetration_m", result.max_penetration_m},
                  {"mean_contacts", result.mean_contacts},
                  {"peak_force_n", result.peak_force_n},
                  {"max_speed_m_s", result.max_speed_m_s},
                  {"energy_gain_j", result.max_energy_gain_j},
                  {"step_p50_us", result.latency.compute.p50_us},
                  {"step_p99_us", result.latency.compute.p99_us},
                  {"final_state_hash", std::string(hash)}};
  // Measured only where they mean something: null otherwise (an empty cell in results.csv).
  j["metrics"]["time_to_rest_s"] = result.time_to_rest_s ? nlohmann::json(*result.time_to_rest_s) : nlohmann::json();
  j["metrics"]["force_ripple"] = result.force_ripple ? nlohmann::json(*result.force_ripple) : nlohmann::json();
  return j.dump(1) + "\n";
}

std::string sweep_job_failure_json(const SweepPlan& plan, const SweepJob& job, int exit_code, const std::string& why) {
  nlohmann::json j = job_record(plan, job);
  j["state"] = "failed";
  j["exit_code"] = exit_code;
  j["error"] = why;
  return j.dump(1) + "\n";
}

SweepTimes sweep_times(const SweepPlan& plan, const std::string& dir) {
  SweepTimes times;
  for (const SweepJob& job : plan.jobs) {
    if (sweep_job_state(plan, dir, job) == JobState::Missing) continue;
    const std::optional<nlohmann::json> r = read_result(sweep_result_path(dir, job.id));  // its times numbers
    if (!r || !r->contains("load_s") || !r->contains("run_s") || !r->contains("job_s")) continue;
    const double load = r->at("load_s").get<double>(), run = r->at("run_s").get<double>();
    ++times.jobs;
    times.load_s += load;
    times.run_s += run;
    times.overhead_s += std::max(0.0, r->at("job_s").get<double>() - load - run);
  }
  return times;
}

SweepMerge merge_sweep(const std::string& dir, const std::vector<std::string>& axis_names) {
  const SweepPlan plan = read_sweep_plan(dir);
  const auto numeric = [&](std::size_t i) {
    return !plan.jobs.empty() && (std::holds_alternative<double>(plan.jobs[0].values[i]) ||
                                  std::holds_alternative<std::int64_t>(plan.jobs[0].values[i]));
  };
  std::vector<std::size_t> axes;
  for (const std::string& name : axis_names) {
    const auto it = std::find(plan.parameters.begin(), plan.parameters.end(), name);
    if (it == plan.parameters.end() || !numeric(static_cast<std::size_t>(it - plan.parameters.begin())))
      throw InputError(dir + "/plan.json: --axes " + name + ": not a numeric parameter of the sweep (" +
                       join(std::vector<std::string_view>(plan.parameters.begin(), plan.parameters.end())) + ")");
    axes.push_back(static_cast<std::size_t>(it - plan.parameters.begin()));
  }
  if (axis_names.empty())
    for (std::size_t i = 0; i < plan.parameters.size() && axes.size() < 2; ++i)
      if (numeric(i)) axes.push_back(i);
  SweepMerge merge;
  // The metrics, in the order the first result lists them.
  std::vector<std::string> metrics;
  std::vector<std::optional<nlohmann::json>> results;
  for (const SweepJob& job : plan.jobs) {
    const JobState state = sweep_job_state(plan, dir, job);
    results.push_back(state == JobState::Missing ? std::nullopt : read_result(sweep_result_path(dir, job.id)));
    ++(state == JobState::Done ? merge.done : state == JobState::Failed ? merge.failed : merge.missing);
    if (results.back() && results.back()->contains("metrics"))
      for (auto&& [name, value] : results.back()->at("metrics").items())
        if (std::find(metrics.begin(), metrics.end(), name) == metrics.end()) metrics.push_back(name);
  }
  const auto metric_text = [](const nlohmann::json& v) -> std::string {
    if (v.is_null()) return "";
    if (v.is_number_float()) return format_number(v.get<double>());
    if (v.is_string()) return v.get<std::string>();
    return v.dump();
  };
  std::ostringstream csv;
  csv << "id";
  for (const std::string& name : plan.parameters) csv << ',' << name;
  csv << ",state,exit_code";
  for (const std::string& name : metrics) csv << ',' << name;
  csv << '\n';
  for (std::size_t j = 0; j < plan.jobs.size(); ++j) {
    const SweepJob& job = plan.jobs[j];
    csv << job.id;
    for (const SweepValue& v : job.values) csv << ',' << sweep_value_text(v);
    const std::optional<nlohmann::json>& r = results[j];
    csv << ',' << (r ? r->at("state").get<std::string>() : "missing") << ','
        << (r ? std::to_string(r->at("exit_code").get<int>()) : "");
    for (const std::string& name : metrics) {
      csv << ',';
      if (r && r->contains("metrics") && r->at("metrics").contains(name)) csv << metric_text(r->at("metrics").at(name));
    }
    csv << '\n';
  }
  merge.csv_path = (fs::path(dir) / "results.csv").string();
  write_file_atomically(merge.csv_path, csv.str());

  // The best point per numeric metric, among the jobs done (all assertions held).
  std::ostringstream md;
  const auto shown = [](const std::string& path) { return fs::proximate(path).string(); };  // relative where it can be
  md << "# Sweep: " << (plan.description.empty() ? fs::path(plan.sweep_file).filename().string() : plan.description)
     << "\n\n- Sweep file: `" << shown(plan.sweep_file) << "`\n- Replay: `" << shown(plan.replay) << "`\n- Jobs: " << plan.jobs.size()
     << " (" << merge.done << " done, " << merge.failed << " failed, " << merge.missing << " missing)\n\n"
     << "The best point per metric among the jobs done (every assertion held): the lowest value.\n\n"
     << "| metric | best | job |";
  for (const std::string& name : plan.parameters) md << ' ' << name << " |";
  md << "\n|---|---:|---|";
  for (std::size_t i = 0; i < plan.parameters.size(); ++i) md << "---:|";
  md << '\n';
  // The metrics where lower is better (the others, such as the contacts per step, describe a
  // point without ranking it: they are in results.csv).
  const std::vector<std::string> ranked = {"time_to_rest_s", "force_ripple", "max_penetration_m", "max_speed_m_s",
                                           "step_p99_us"};
  for (const std::string& name : ranked) {
    std::optional<std::size_t> best;
    double best_value = 0.0;
    for (std::size_t j = 0; j < plan.jobs.size(); ++j)
      if (const std::optional<double> v = done_metric(results[j], name); v && (!best || *v < best_value))
        best = j, best_value = *v;
    if (!best) continue;
    char value[32];
    std::snprintf(value, sizeof value, "%.4g", best_value);
    md << "| " << name << " | " << value << " | " << plan.jobs[*best].id << " |";
    for (const SweepValue& v : plan.jobs[*best].values) md << ' ' << sweep_value_text(v) << " |";
    md << '\n';
  }
  // Heat maps: each ranked metric over the two axes; where the sweep has more parameters, a
  // cell shows the lowest value among the jobs done at its two values.
  if (axes.size() == 2) {
    const fs::path maps = fs::path(dir) / "heatmaps";
    fs::create_directories(maps);
    for (const std::string& name : ranked) {
      std::map<std::pair<double, double>, double> cells;
      for (std::size_t j = 0; j < plan.jobs.size(); ++j) {
        const std::optional<double> v = done_metric(results[j], name);
        if (!v) continue;
        const std::pair<double, double> at{number_of(plan.jobs[j].values[axes[0]]), number_of(plan.jobs[j].values[axes[1]])};
        const auto it = cells.find(at);
        if (it == cells.end() || *v < it->second) cells[at] = *v;
      }
      if (cells.empty()) continue;
      const std::string png = (maps / (name + ".png")).string();
      std::ostringstream gp;
      gp << "set terminal pngcairo size 720,560 font 'DejaVu Sans,10' noenhanced\n"
         << "set output '" << png << "'\n"
         << "set title '" << name << " (lower is better; blank: no job done there)'\n"
         << "set xlabel '" << plan.parameters[axes[0]] << "'\nset ylabel '" << plan.parameters[axes[1]] << "'\n"
         << "set palette rgb 33,13,10\nset offsets graph 0.08, graph 0.08, graph 0.08, graph 0.08\nset grid\n"
         << "plot '-' using 1:2:3 with points pointtype 5 pointsize 5 palette notitle, "
         << "'-' using 1:2:(sprintf('%.3g', $3)) with labels offset 0,-2 notitle\n";
      for (int copy = 0; copy < 2; ++copy) {
        for (const auto& [at, v] : cells) gp << format_number(at.first) << ' ' << format_number(at.second) << ' ' << format_number(v) << '\n';
        gp << "e\n";
      }
      const std::string script = (maps / (name + ".gp")).string();
      write_file_atomically(script, gp.str());
      merge.heat_map_scripts.push_back(script);
    }
    md << "\nHeat maps over " << plan.parameters[axes[0]] << " and " << plan.parameters[axes[1]]
       << " (the lowest value at each pair where the sweep has more parameters): heatmaps/METRIC.png in the sweep's folder.\n";
  }
  merge.summary_path = (fs::path(dir) / "summary.md").string();
  write_file_atomically(merge.summary_path, md.str());
  return merge;
}

}  // namespace ffd
