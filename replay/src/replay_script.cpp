// Replay scripts -> ReplayScript: strict like the scene loader (unknown keys, wrong types,
// out-of-range values and events after the end are errors naming file:line:col and field).
#include "ffd/replay_script.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

#include "ffd/scene_loader.h"

namespace ffd {
namespace {

const std::vector<std::string_view> kRootKeys = {"format", "version", "description", "scene", "steps",
                                                 "duration_ms", "event", "probe_path", "drag_path",
                                                 "assert", "record", "recorded"};
const std::vector<std::string_view> kRecordedKeys = {"ffdsim", "scene", "scene_hash", "scene_text", "meshes"};
const std::vector<std::string_view> kRecordedFileKeys = {"path", "hash"};
const std::vector<std::string_view> kEventKeys = {"at_step", "at_ms", "probe", "grab", "drag", "release",
                                                  "alpha", "beta", "gravity", "stiffness", "probe_stiffness", "accuracy", "response", "auto_accuracy", "budget_us",
                                                  "pause_ms", "resume", "single_step", "reset"};
const std::vector<std::string_view> kGrabKeys = {"object", "point", "cell", "local", "target"};
const std::vector<std::string_view> kStiffnessKeys = {"object", "value"};
const std::vector<std::string_view> kPathKeys = {"interpolation", "keyframes"};
const std::vector<std::string_view> kKeyframeKeys = {"at_step", "at_ms", "position"};
const std::vector<std::string_view> kInterpolations = {"linear", "smooth", "step"};
const std::vector<std::string_view> kResponseAssertKeys = {"latency", "stability", "contact", "gap", "intersections",
                                                           "position", "rest", "motion", "creep", "force",
                                                           "force_window", "hash"};
const std::vector<std::string_view> kAssertKeys = {"latency", "stability", "contact", "gap", "intersections", "position",
                                                   "rest", "motion", "creep", "force", "force_window", "hash",
                                                   "paper", "solver"};
const std::vector<std::string_view> kIntersectionKeys = {"max_pairs", "from_step", "from_ms", "to_step",
                                                         "to_ms", "every_steps", "every_ms"};
const std::vector<std::string_view> kMotionKeys = {"rms_speed_max_m_s", "kinetic_energy_max_j", "speed_max_m_s",
                                                   "from_step", "from_ms"};
const std::vector<std::string_view> kCreepKeys = {"object", "max_m", "from_step", "from_ms", "to_step", "to_ms",
                                                  "every_steps", "every_ms"};
const std::vector<std::string_view> kForceWindowKeys = {"from_step", "from_ms", "to_step", "to_ms",
                                                        "relative_std_max", "mean_min_n", "mean_max_n", "above_previous"};
const std::vector<std::string_view> kLatencyKeys = {"compute_p50_us", "compute_p99_us", "compute_max_us",
                                                    "lateness_p50_us", "lateness_p99_us", "lateness_max_us",
                                                    "deadline_misses"};
const std::vector<std::string_view> kStabilityKeys = {"finite", "energy_max_j", "energy_gain_max_j", "speed_max_m_s",
                                                      "inverted_steps_max"};
const std::vector<std::string_view> kContactKeys = {"max_penetration_m", "min_contacts", "from_step", "from_ms"};
const std::vector<std::string_view> kGapKeys = {"objects", "max_gap_m", "max_penetration_m", "from_step",
                                                "from_ms", "to_step", "to_ms", "every_steps", "every_ms"};
const std::vector<std::string_view> kPositionKeys = {"object", "relative_to", "min", "max", "from_step", "from_ms",
                                                     "to_step", "to_ms", "every_steps", "every_ms"};
const std::vector<std::string_view> kRestKeys = {"speed_max_m_s", "from_step", "from_ms", "every_steps", "every_ms"};
const std::vector<std::string_view> kForceKeys = {"max_n", "peak_min_n"};
const std::vector<std::string_view> kHashKeys = {"step", "value"};
const std::vector<std::string_view> kRecordKeys = {"hash_every"};

constexpr Bounds kPositive{0.0, kInf, true, false};
constexpr Bounds kNonNegative{0.0, kInf, false, false};
constexpr Bounds kUnit{0.0, 1.0, false, false};
constexpr std::int64_t kMaxSteps = kMaxReplaySteps;

std::string location(const std::string& origin, const toml::source_region& where) {
  return origin + ":" + std::to_string(where.begin.line) + ":" + std::to_string(where.begin.column);
}

class ScriptReader {
 public:
  ScriptReader(const std::string& origin, const std::string& base_dir, const SceneLimits& limits,
               RecordedScene recorded_scene, std::optional<ContactResponse> response)
      : origin_(origin), base_dir_(base_dir), limits_(limits), recorded_scene_(recorded_scene), response_(response) {}

  LoadedReplay read(const toml::table& root_table) {
    const TableReader root(origin_, root_table, "", kRootKeys);
    LoadedReplay out{ReplayScript{}, Model{}};
    ReplayScript& script = out.script;
    script.path = origin_;
    root.check_format("ffdsim-replay", kReplayFormatVersion);
    script.description = root.string("description").value_or("");

    read_recorded(root, script);
    if (script.recorded && recorded_scene_ == RecordedScene::FromRecording) {
      const std::filesystem::path scene_file = resolve(script.recorded->scene.path);
      script.scene_origin = origin_ + " [recorded].scene_text";
      try {
        script.scene = parse_scene(script.recorded->scene_text, script.scene_origin, scene_file.parent_path().string(), limits_);
      } catch (const InputError& e) {
        root.fail_at("recorded", std::string("the recorded scene text does not load: ") + e.what());
      }
    } else {
      read_scene(root, script);
    }
    if (script.recorded) check_recorded_files(root, script);
    if (response_) {
      if (script.recorded)
        throw ReplayError(origin_ + ": a recording replays the response it was recorded with (the run asked for " +
                          std::string(response_name(*response_)) + ")");
      script.scene.settings.response = *response_;
    }
    std::vector<std::string> log;
    try {
      out.model = compile(script.scene, log);
    } catch (const CompileError& e) {
      root.fail_at("scene", std::string("the scene does not compile: ") + e.what());
    }
    for (const std::string& line : log)  // e.g. objects that start inside each other
      if (line.rfind("warning: ", 0) == 0) script.warnings.push_back(script.scene_origin + ": " + line.substr(9));
    model_ = &out.model;
    dt_ms_ = out.model.settings.dt * 1000.0;

    if (root.has("steps") && root.has("duration_ms")) root.fail_at("duration_ms", "give either 'steps' or 'duration_ms', not both");
    if (root.has("steps")) script.steps = static_cast<std::uint64_t>(root.integer("steps", 0, 1, kMaxSteps));
    else if (root.has("duration_ms")) script.steps = ms_to_steps(root, "duration_ms", Bounds{0.0, kInf, true, false});
    else if (root.subtable("record")) script.steps = last_recorded_step(root);  // a recording written as it ran
    else root.fail_missing("steps", " (give 'steps' or 'duration_ms': how long the replay runs)");
    if (script.steps == 0) root.fail_at("duration_ms", "is shorter than one step");
    steps_ = script.steps;

    const auto events = array_of_tables(root, "event");
    for (std::size_t i = 0; i < events.size(); ++i) read_event(*events[i], "event[" + std::to_string(i) + "]", script);
    read_paths(root, "probe_path", CommandKind::ProbePose, script);
    read_paths(root, "drag_path", CommandKind::Drag, script);
    std::stable_sort(script.commands.begin(), script.commands.end(),
                     [](const Command& a, const Command& b) { return a.step < b.step; });

    if (const toml::table* record = root.subtable("record")) {
      const TableReader r(origin_, *record, "record", kRecordKeys);
      script.hash_every = static_cast<std::uint32_t>(r.integer("hash_every", 0, 1, 1'000'000));
    }
    if (const toml::table* assertions = root.subtable("assert")) read_assertions(*assertions, script);
    return out;
  }

 private:
  void read_scene(const TableReader& root, ReplayScript& script) {
    const toml::node* node = root.find("scene");
    if (!node) root.fail_missing("scene", " (a scene file path, or an inline [scene] table)");
    if (const toml::table* inline_scene = node->as_table()) {
      script.scene_origin = origin_;
      script.scene = read_scene_table(*inline_scene, origin_, base_dir_, limits_);
      script.scene.name = std::filesystem::path(origin_).stem().string();
      return;
    }
    const auto path = root.string("scene");
    if (!path) root.fail_at("scene", "expected a path or a table");
    std::filesystem::path resolved(*path);
    if (resolved.is_relative() && !base_dir_.empty()) resolved = std::filesystem::path(base_dir_) / resolved;
    resolved = resolved.lexically_normal();
    std::error_code error;
    if (!std::filesystem::is_regular_file(resolved, error))
      root.fail_at("scene", "cannot find scene file " + in_quotes(resolved.string()) +
                                " (scene paths are relative to the script's folder)");
    script.scene_origin = resolved.string();
    script.scene = load_scene_file(resolved.string(), limits_);
  }

  std::filesystem::path resolve(const std::string& path) const {
    std::filesystem::path resolved(path);
    if (resolved.is_relative() && !base_dir_.empty()) resolved = std::filesystem::path(base_dir_) / resolved;
    return resolved.lexically_normal();
  }

  // A recording's [recorded] table: the ffdsim that wrote it and its files' content hashes.
  void read_recorded(const TableReader& root, ReplayScript& script) {
    const toml::table* table = root.subtable("recorded");
    if (!table) return;
    const TableReader r(origin_, *table, "recorded", kRecordedKeys);
    RecordedOrigin o;
    auto required = [&](const TableReader& t, std::string_view key) {
      const auto value = t.string(key);
      if (!value) t.fail_missing(key);
      return *value;
    };
    o.ffdsim = required(r, "ffdsim");
    o.scene.path = required(r, "scene");
    o.scene.hash = required(r, "scene_hash");
    o.scene_text = required(r, "scene_text");
    const auto meshes = array_of_tables(r, "meshes");
    for (std::size_t i = 0; i < meshes.size(); ++i) {
      const TableReader m(origin_, *meshes[i], "recorded.meshes[" + std::to_string(i) + "]", kRecordedFileKeys);
      o.meshes.push_back({required(m, "path"), required(m, "hash")});
    }
    script.recorded = std::move(o);
  }

  // The scene and mesh files as they are now against their recorded content hashes.
  void check_recorded_files(const TableReader& root, ReplayScript& script) {
    const RecordedOrigin& o = *script.recorded;
    std::vector<RecordedFile> files;
    if (recorded_scene_ != RecordedScene::FromRecording) files.push_back(o.scene);
    files.insert(files.end(), o.meshes.begin(), o.meshes.end());
    for (const RecordedFile& f : files) {
      const std::string path = resolve(f.path).string();
      std::string now;
      try {
        now = content_hash_of_file(path);
      } catch (const InputError& e) {
        now = "unreadable";
      }
      if (now == f.hash) continue;
      const std::string what = path + " has changed since it was recorded (recorded " + f.hash + ", now " + now + ")";
      if (recorded_scene_ == RecordedScene::AllowChanged) {
        script.warnings.push_back(origin_ + ": " + what + "; replaying it as it is now (--allow-changed)");
        continue;
      }
      root.fail_at("recorded", what + ": replay the recorded scene with --scene-from-recording, or the files as they "
                                      "are now with --allow-changed");
    }
  }

  // A recording written as the session ran has no 'steps' (its header went to disk first): it
  // runs to its last state hash or event, whichever is later.
  std::uint64_t last_recorded_step(const TableReader& root) const {
    std::uint64_t last = 0;
    for (const toml::table* event : array_of_tables(root, "event"))
      if (const auto step = (*event)["at_step"].value<std::int64_t>(); step && *step > 0)
        last = std::max(last, static_cast<std::uint64_t>(*step));
    if (const toml::table* assertions = root.subtable("assert"))
      if (const toml::array* hashes = (*assertions)["hash"].as_array())
        for (const toml::node& h : *hashes)
          if (const toml::table* t = h.as_table())
            if (const auto step = (*t)["step"].value<std::int64_t>(); step && *step > 0)
              last = std::max(last, static_cast<std::uint64_t>(*step));
    if (last == 0) root.fail_missing("steps", " (a recording with no state hash or event yet: nothing to replay)");
    return last;
  }

  // A time given as "<prefix>_step" or "<prefix>_ms" (exactly one), in steps.
  std::optional<std::uint64_t> time_of(const TableReader& t, const std::string& prefix, bool required) const {
    const std::string step_key = prefix + "_step", ms_key = prefix + "_ms";
    const bool has_step = t.has(step_key), has_ms = t.has(ms_key);
    if (has_step && has_ms) t.fail_at(ms_key, "give either '" + step_key + "' or '" + ms_key + "', not both");
    if (has_step) return static_cast<std::uint64_t>(t.integer(step_key, 0, 0, kMaxSteps));
    if (has_ms) return ms_to_steps(t, ms_key, kNonNegative);
    if (required) t.fail_missing(step_key, " (or '" + ms_key + "')");
    return std::nullopt;
  }

  // A sampling interval given as "every_steps" or "every_ms" (at most one), in steps.
  std::optional<std::uint64_t> interval_of(const TableReader& t) const {
    if (t.has("every_steps") && t.has("every_ms")) t.fail_at("every_ms", "give either 'every_steps' or 'every_ms', not both");
    if (t.has("every_steps")) return static_cast<std::uint64_t>(t.integer("every_steps", 0, 0, kMaxSteps));
    if (t.has("every_ms")) return ms_to_steps(t, "every_ms", kNonNegative);
    return std::nullopt;
  }

  // The sampling window of an assertion at `path`: from (default 0), to (default: the end of
  // the run) and every (default 10 steps), checked against each other and the run's length.
  void read_window(const TableReader& t, const std::string& path, std::uint64_t run_steps, std::uint64_t& from,
                   std::uint64_t& to, std::uint64_t& every) const {
    from = time_of(t, "from", false).value_or(0);
    to = time_of(t, "to", false).value_or(run_steps);
    if (to > run_steps) t.fail_here(path, "'to' is after the end of the run");
    if (from > to) t.fail_here(path, "'from' is after 'to'");
    every = interval_of(t).value_or(10);
    if (every == 0) t.fail_here(path, "'every' must be at least one step");
  }

  std::uint64_t ms_to_steps(const TableReader& t, const std::string& key, const Bounds& bounds) const {
    const double ms = t.number(key, 0.0, bounds);
    const double steps = std::round(ms / dt_ms_);
    if (steps > static_cast<double>(kMaxSteps))
      t.fail_at(key, "is " + format_number(steps) + " steps of " + format_number(dt_ms_) +
                         " ms, more than the limit of " + std::to_string(kMaxSteps) + " steps");
    return static_cast<std::uint64_t>(steps);
  }

  void require_effect(const TableReader& t, std::string_view key, Effect effect) const {
    if (!has(model_->settings.effects, effect))
      t.fail_at(key, std::string("the scene does not list the \"") + effect_name(effect) + "\" effect");
  }

  Index object_index(const TableReader& t, std::string_view key) const {
    const auto name = t.string(key);
    if (!name) t.fail_missing(key);
    return find_object(t, key, *name);
  }

  void read_event(const toml::table& table, const std::string& path, ReplayScript& script) {
    const TableReader e(origin_, table, path, kEventKeys);
    const std::uint64_t step = *time_of(e, "at", true);
    check_within_run(e, e.has("at_step") ? "at_step" : "at_ms", step);
    // Actions in the order they are written.
    std::vector<std::pair<toml::source_position, std::string_view>> actions;
    for (auto&& [key, value] : table) {
      (void)value;
      if (key.str() != "at_step" && key.str() != "at_ms") actions.emplace_back(key.source().begin, key.str());
    }
    if (actions.empty()) e.fail_here(path, "an event needs an action (e.g. alpha = 0.5, probe = [x, y, z], grab = {...})");
    std::sort(actions.begin(), actions.end(), [](const auto& a, const auto& b) {
      return a.first.line != b.first.line ? a.first.line < b.first.line : a.first.column < b.first.column;
    });
    for (const auto& [where, key] : actions) {
      (void)where;
      Command c;
      c.step = step;
      if (key == "probe") {
        require_effect(e, key, Effect::Probe);
        c.kind = CommandKind::ProbePose;
        c.vector = e.vec3(key, Vec3::Zero());
      } else if (key == "grab") {
        require_effect(e, key, Effect::Grab);
        c = read_grab(e, step);
        if (const toml::table* g = e.subtable("grab"); g && g->contains("target")) {
          // The grab starts at the point; a target is a drag in the same step.
          script.commands.push_back(c);
          c.kind = CommandKind::Drag;
          c.vector = TableReader(origin_, *g, e.field("grab"), kGrabKeys).vec3("target", Vec3::Zero());
        }
      } else if (key == "drag") {
        require_effect(e, key, Effect::Grab);
        c.kind = CommandKind::Drag;
        c.vector = e.vec3(key, Vec3::Zero());
      } else if (key == "alpha" || key == "beta") {
        c.kind = key == "alpha" ? CommandKind::SetAlpha : CommandKind::SetBeta;
        c.value = e.number(key, 0.0, kUnit);
      } else if (key == "gravity") {
        c.kind = CommandKind::SetGravity;
        c.vector = e.vec3(key, Vec3::Zero());
      } else if (key == "stiffness") {
        c = read_stiffness(e, step);
      } else if (key == "probe_stiffness") {
        require_effect(e, key, Effect::Probe);
        c.kind = CommandKind::SetProbeStiffness;
        c.value = e.number(key, 0.0, kNonNegative);
      } else if (key == "accuracy") {
        c.kind = CommandKind::SetAccuracy;
        c.value = static_cast<double>(e.integer(key, 0, 0, kAccuracyLevels - 1));
      } else if (key == "response") {
        c.kind = CommandKind::SetResponse;
        const std::optional<std::string> name = e.string(key);
        ContactResponse response = ContactResponse::Paper;
        if (!response_from_name(*name, response))
          e.fail_at(key, "unknown response " + in_quotes(*name) + " (valid: \"paper\", \"solver\")");
        c.value = static_cast<double>(response);
      } else if (key == "auto_accuracy") {
        c.kind = CommandKind::AutoAccuracy;
        c.value = e.boolean(key, false) ? 1.0 : 0.0;
      } else if (key == "budget_us") {
        c.kind = CommandKind::SetBudget;
        c.value = e.number(key, 0.0, kPositive);
      } else if (key == "pause_ms") {
        c.kind = CommandKind::Pause;
        c.value = std::round(e.number(key, 0.0, kPositive) / dt_ms_);  // ticks of the loop
        if (c.value < 1.0) e.fail_at(key, "is shorter than one tick of the loop");
      } else {  // release, resume, single_step, reset: flags
        if (!e.boolean(key, false)) e.fail_at(key, "write " + std::string(key) + " = true, or leave it out");
        c.kind = key == "release" ? CommandKind::Release
                 : key == "resume" ? CommandKind::Resume
                 : key == "single_step" ? CommandKind::SingleStep
                                        : CommandKind::Reset;
        if (c.kind == CommandKind::Release) require_effect(e, key, Effect::Grab);
      }
      script.commands.push_back(c);
    }
  }

  // An inline table such as grab = { ... }, read strictly.
  TableReader inline_table(const TableReader& e, std::string_view key, const std::vector<std::string_view>& keys,
                           const std::string& shape) const {
    const toml::table* table = e.subtable(key);
    if (!table) e.fail_at(key, "expected a table " + shape);
    return TableReader(origin_, *table, e.field(key), keys);
  }

  Command read_grab(const TableReader& e, std::uint64_t step) const {
    const TableReader g = inline_table(e, "grab", kGrabKeys, "{ object = \"name\", point = [x, y, z] }");
    Command c;
    c.step = step;
    c.kind = CommandKind::Grab;
    const Index object = object_index(g, "object");
    const ObjectModel& o = model_->objects[object];
    if (g.has("point") == (g.has("cell") || g.has("local")))
      g.fail_here(g.path(), "give either 'point' (a position in m) or 'cell' and 'local', not both and not neither");
    if (g.has("point")) {
      // The surface vertex nearest to the point, given in the object's own frame (as its
      // mesh is, scaled), so that it names the same spot whenever the grab happens.
      const Vec3 point = g.vec3("point", Vec3::Zero());
      double best = kInf;
      for (std::size_t v = 0; v < o.surface.vertices.size(); ++v) {
        const double d = (o.surface.vertices[v] - point).squaredNorm();
        if (d < best) {
          best = d;
          c.cell = o.vertex_cell[v];
          c.local = o.vertex_local[v];
        }
      }
    } else {
      if (!g.has("cell") || !g.has("local")) g.fail_here(g.path(), "'cell' and 'local' go together");
      const std::int64_t cells = static_cast<std::int64_t>(o.cell_end - o.cell_begin);
      c.cell = o.cell_begin + static_cast<Index>(g.integer("cell", 0, 0, cells - 1));
      c.local = g.vec3("local", Vec3::Zero(), kUnit);
    }
    if (g.has("target")) g.vec3("target", Vec3::Zero());  // checked here, used as a Drag
    return c;
  }

  Command read_stiffness(const TableReader& e, std::uint64_t step) const {
    const TableReader s = inline_table(e, "stiffness", kStiffnessKeys, "{ object = \"name\", value = ... }");
    Command c;
    c.step = step;
    c.kind = CommandKind::SetStiffness;
    c.object = object_index(s, "object");
    const bool mass_spring = model_->objects[c.object].dynamics == DynamicsKind::MassSpring;
    if (!s.has("value")) s.fail_missing("value", mass_spring ? " (N/m per spring)" : " (pull fraction in (0, 1])");
    c.value = s.number("value", 0.0, mass_spring ? kPositive : Bounds{0.0, 1.0, true, false});
    return c;
  }

  void check_within_run(const TableReader& t, std::string_view key, std::uint64_t step) const {
    if (step >= steps_)
      t.fail_at(key, "is at step " + std::to_string(step) + ", after the end of the run (" + std::to_string(steps_) +
                         " steps)");
  }

  // Keyframed probe or drag paths: one command per step from the first keyframe to the last.
  void read_paths(const TableReader& root, std::string_view key, CommandKind kind, ReplayScript& script) {
    const auto paths = array_of_tables(root, key);
    std::vector<std::pair<std::uint64_t, std::uint64_t>> spans;
    for (std::size_t p = 0; p < paths.size(); ++p) {
      const std::string path = std::string(key) + "[" + std::to_string(p) + "]";
      const TableReader t(origin_, *paths[p], path, kPathKeys);
      require_effect(root, key, kind == CommandKind::ProbePose ? Effect::Probe : Effect::Grab);
      const std::string interpolation = t.string("interpolation").value_or("linear");
      if (std::find(kInterpolations.begin(), kInterpolations.end(), interpolation) == kInterpolations.end())
        t.fail_at("interpolation", "unknown interpolation " + in_quotes(interpolation) + " (valid: " + join(kInterpolations) + ")");
      const toml::node* frames = t.find("keyframes");
      if (!frames) t.fail_missing("keyframes", " (an array of { at_ms = ..., position = [x, y, z] })");
      const toml::array* array = frames->as_array();
      if (!array || array->empty()) t.fail_at("keyframes", "expected a non-empty array of tables");
      std::vector<std::pair<std::uint64_t, Vec3>> keys;
      for (std::size_t i = 0; i < array->size(); ++i) {
        const toml::table* frame = array->get(i)->as_table();
        const std::string field = t.field("keyframes") + "[" + std::to_string(i) + "]";
        if (!frame) t.fail(array->get(i)->source(), field, "expected a table { at_ms = ..., position = [x, y, z] }");
        const TableReader k(origin_, *frame, field, kKeyframeKeys);
        const std::uint64_t step = *time_of(k, "at", true);
        check_within_run(k, k.has("at_step") ? "at_step" : "at_ms", step);
        if (!k.has("position")) k.fail_missing("position");
        if (!keys.empty() && step <= keys.back().first)
          k.fail_here(field, "keyframes must be in increasing time (step " + std::to_string(step) +
                                 " is not after step " + std::to_string(keys.back().first) + ")");
        keys.emplace_back(step, k.vec3("position", Vec3::Zero()));
      }
      const std::pair<std::uint64_t, std::uint64_t> span{keys.front().first, keys.back().first};
      for (std::size_t q = 0; q < spans.size(); ++q)
        if (span.first <= spans[q].second && spans[q].first <= span.second)
          t.fail_here(path, "overlaps " + std::string(key) + "[" + std::to_string(q) + "] (steps " +
                                std::to_string(spans[q].first) + " to " + std::to_string(spans[q].second) + ")");
      spans.push_back(span);
      path_commands_ += span.second - span.first + 1;
      if (path_commands_ > kMaxPathCommands)
        t.fail_here(path, "the paths so far span " + std::to_string(path_commands_) +
                              " steps, more than the limit of " + std::to_string(kMaxPathCommands) +
                              " (one command per step) in a script");
      std::size_t segment = 0;
      for (std::uint64_t s = span.first; s <= span.second; ++s) {
        while (segment + 1 < keys.size() && keys[segment + 1].first <= s) ++segment;
        Vec3 position = keys[segment].second;
        if (segment + 1 < keys.size() && interpolation != "step") {
          const double u = static_cast<double>(s - keys[segment].first) /
                           static_cast<double>(keys[segment + 1].first - keys[segment].first);
          const double w = interpolation == "smooth" ? u * u * (3.0 - 2.0 * u) : u;  // smoothstep
          position = (1.0 - w) * keys[segment].second + w * keys[segment + 1].second;
        }
        Command c;
        c.step = s;
        c.kind = kind;
        c.vector = position;
        script.commands.push_back(c);
      }
    }
  }

  // [assert] and the per-response tables under it: [assert.paper] and [assert.solver] add
  // their assertions to [assert]'s when the run is under that response, for figures that
  // describe what one response does rather than stability (docs/replays.md). The other
  // response's table is read too, so that its mistakes are reported whatever the run.
  void read_assertions(const toml::table& table, ReplayScript& script) const {
    read_assertion_tables(table, "assert", kAssertKeys, script);
    const TableReader a(origin_, table, "assert", kAssertKeys);
    for (const ContactResponse response : {ContactResponse::Paper, ContactResponse::Solver}) {
      const std::string name = response_name(response);
      const toml::table* section = a.subtable(name);
      if (!section) continue;
      const std::string prefix = "assert." + name;
      for (const Command& c : script.commands)
        if (c.kind == CommandKind::SetResponse)
          a.fail_at(name, "per-response assertions need one response for the whole run, and the script switches "
                          "the response at step " + std::to_string(c.step));
      for (const std::string_view single : {"latency", "stability", "contact", "rest", "motion", "force"})
        if (table.contains(single) && section->contains(single))
          a.fail_at(name, "[" + prefix + "." + std::string(single) + "] is given in [assert] too; a table under [" +
                              prefix + "] adds to [assert]'s, so give each single table in one place");
      if (response == model_->settings.response) {
        read_assertion_tables(*section, prefix, kResponseAssertKeys, script);
      } else {
        ReplayScript unused;
        unused.steps = script.steps;
        unused.commands = script.commands;
        unused.force_windows = script.force_windows;  // what above_previous compares with
        read_assertion_tables(*section, prefix, kResponseAssertKeys, unused);
      }
    }
    std::stable_sort(script.hashes.begin(), script.hashes.end(),
                     [](const HashCheck& x, const HashCheck& y) { return x.step < y.step; });
  }

  // One [assert] table's assertions (or one [assert.<response>] table's), added to `script`.
  void read_assertion_tables(const toml::table& table, const std::string& prefix,
                             const std::vector<std::string_view>& keys, ReplayScript& script) const {
    const TableReader a(origin_, table, prefix, keys);
    auto optional_number = [](const TableReader& t, std::string_view key, const Bounds& bounds) -> std::optional<double> {
      if (!t.has(key)) return std::nullopt;
      return t.number(key, 0.0, bounds);
    };
    if (const toml::table* latency = a.subtable("latency")) {
      const TableReader l(origin_, *latency, prefix + ".latency", kLatencyKeys);
      LatencyLimits& lim = script.latency;
      lim.compute_p50_us = optional_number(l, "compute_p50_us", kPositive);
      lim.compute_p99_us = optional_number(l, "compute_p99_us", kPositive);
      lim.compute_max_us = optional_number(l, "compute_max_us", kPositive);
      lim.lateness_p50_us = optional_number(l, "lateness_p50_us", kNonNegative);
      lim.lateness_p99_us = optional_number(l, "lateness_p99_us", kNonNegative);
      lim.lateness_max_us = optional_number(l, "lateness_max_us", kNonNegative);
      if (l.has("deadline_misses"))
        lim.deadline_misses = static_cast<std::uint64_t>(l.integer("deadline_misses", 0, 0, kMaxSteps));
    }
    if (const toml::table* stability = a.subtable("stability")) {
      const TableReader s(origin_, *stability, prefix + ".stability", kStabilityKeys);
      script.stability.finite = s.boolean("finite", false);
      script.stability.energy_max_j = optional_number(s, "energy_max_j", kAnyValue);
      script.stability.energy_gain_max_j = optional_number(s, "energy_gain_max_j", kAnyValue);
      if (script.stability.energy_gain_max_j) {
        // The gain counts the probe's work as the one input; these commands change the
        // energy in ways it does not count.
        for (const Command& c : script.commands) {
          if (c.kind != CommandKind::Grab && c.kind != CommandKind::Drag && c.kind != CommandKind::SetGravity &&
              c.kind != CommandKind::SetStiffness)
            continue;
          s.fail_at("energy_gain_max_j", std::string("counts the probe's work only, and the script has a '") +
                                             command_name(c.kind) + "' command at step " + std::to_string(c.step) +
                                             " (grab, drag, gravity and stiffness commands add energy it does not count)");
        }
      }
      script.stability.speed_max_m_s = optional_number(s, "speed_max_m_s", kPositive);
      if (s.has("inverted_steps_max"))
        script.stability.inverted_steps_max =
            static_cast<std::uint64_t>(s.integer("inverted_steps_max", 0, 0, kMaxSteps));
    }
    if (const toml::table* contact = a.subtable("contact")) {
      const TableReader c(origin_, *contact, prefix + ".contact", kContactKeys);
      script.contact.max_penetration_m = optional_number(c, "max_penetration_m", kNonNegative);
      if (c.has("min_contacts")) {
        script.contact.min_contacts = static_cast<std::uint64_t>(c.integer("min_contacts", 0, 0, 1'000'000'000));
        script.contact.contacts_from_step = time_of(c, "from", false).value_or(0);
        if (script.contact.contacts_from_step >= script.steps)
          c.fail_at(c.has("from_ms") ? "from_ms" : "from_step", "starts after the run's last step");
      } else if (c.has("from_ms") || c.has("from_step")) {
        c.fail_at(c.has("from_ms") ? "from_ms" : "from_step", "only used with 'min_contacts'");
      }
    }
    if (const toml::table* force = a.subtable("force")) {
      const TableReader f(origin_, *force, prefix + ".force", kForceKeys);
      if (!has(model_->settings.effects, Effect::Probe))
        a.fail_at("force", "force assertions need the \"probe\" effect in the scene");
      script.force.max_n = optional_number(f, "max_n", kPositive);
      script.force.peak_min_n = optional_number(f, "peak_min_n", kNonNegative);
    }
    const auto gaps = array_of_tables(a, "gap");
    for (std::size_t i = 0; i < gaps.size(); ++i) {
      const std::string path = prefix + ".gap[" + std::to_string(i) + "]";
      const TableReader g(origin_, *gaps[i], path, kGapKeys);
      GapLimit gap;
      gap.where = location(origin_, gaps[i]->source());
      const toml::node* objects = g.find("objects");
      if (!objects) g.fail_missing("objects", " (two object names)");
      const toml::array* names = objects->as_array();
      if (!names || names->size() != 2 || !names->get(0)->is_string() || !names->get(1)->is_string())
        g.fail_at("objects", "expected two object names [\"a\", \"b\"]");
      gap.a = names->get(0)->as_string()->get();
      gap.b = names->get(1)->as_string()->get();
      gap.object_a = find_object(g, "objects", gap.a);
      gap.object_b = find_object(g, "objects", gap.b);
      if (gap.object_a == gap.object_b) g.fail_at("objects", "names the same object twice");
      gap.max_gap_m = optional_number(g, "max_gap_m", kNonNegative);
      gap.max_penetration_m = optional_number(g, "max_penetration_m", kNonNegative);
      if (!gap.max_gap_m && !gap.max_penetration_m) g.fail_here(path, "give 'max_gap_m' and/or 'max_penetration_m'");
      read_window(g, path, script.steps, gap.from_step, gap.to_step, gap.every_steps);
      script.gaps.push_back(gap);
    }
    const auto intersections = array_of_tables(a, "intersections");
    for (std::size_t i = 0; i < intersections.size(); ++i) {
      const std::string path = prefix + ".intersections[" + std::to_string(i) + "]";
      const TableReader t(origin_, *intersections[i], path, kIntersectionKeys);
      IntersectionLimit limit;
      limit.where = location(origin_, intersections[i]->source());
      if (!t.has("max_pairs")) t.fail_missing("max_pairs", " (intersecting triangle pairs at most)");
      limit.max_pairs = static_cast<std::uint64_t>(t.integer("max_pairs", 0, 0, 1'000'000'000));
      read_window(t, path, script.steps, limit.from_step, limit.to_step, limit.every_steps);
      script.intersections.push_back(limit);
    }
    const auto positions = array_of_tables(a, "position");
    for (std::size_t i = 0; i < positions.size(); ++i) {
      const std::string path = prefix + ".position[" + std::to_string(i) + "]";
      const TableReader p(origin_, *positions[i], path, kPositionKeys);
      PositionLimit limit;
      limit.where = location(origin_, positions[i]->source());
      limit.pattern = object_pattern(p, limit.objects);
      if (const auto relative = p.string("relative_to")) {
        limit.relative_to_name = *relative;
        limit.relative_to = find_object(p, "relative_to", *relative);
      }
      if (!p.has("min") && !p.has("max")) p.fail_here(path, "give 'min' and/or 'max' ([x, y, z], m)");
      limit.min = p.vec3("min", limit.min);
      limit.max = p.vec3("max", limit.max);
      for (int axis = 0; axis < 3; ++axis)
        if (limit.min[axis] > limit.max[axis]) p.fail_at("max", "is below 'min' on axis " + std::to_string(axis));
      read_window(p, path, script.steps, limit.from_step, limit.to_step, limit.every_steps);
      script.positions.push_back(limit);
    }
    if (const toml::table* rest = a.subtable("rest")) {
      const TableReader r(origin_, *rest, prefix + ".rest", kRestKeys);
      if (!r.has("speed_max_m_s")) r.fail_missing("speed_max_m_s", " (m/s: the fastest an object's centre of mass may move)");
      script.rest.speed_max_m_s = r.number("speed_max_m_s", 0.0, kPositive);
      script.rest.from_step = time_of(r, "from", false).value_or(0);
      script.rest.every_steps = interval_of(r).value_or(10);
      if (script.rest.every_steps == 0) r.fail_here(prefix + ".rest", "'every' must be at least one step");
      if (script.rest.from_step + script.rest.every_steps > script.steps)
        r.fail_here(prefix + ".rest", "the window from 'from' leaves no whole 'every' interval before the end of the run");
    }
    if (const toml::table* motion = a.subtable("motion")) {
      const TableReader m(origin_, *motion, prefix + ".motion", kMotionKeys);
      script.motion.rms_speed_max_m_s = optional_number(m, "rms_speed_max_m_s", kPositive);
      script.motion.kinetic_energy_max_j = optional_number(m, "kinetic_energy_max_j", kPositive);
      script.motion.speed_max_m_s = optional_number(m, "speed_max_m_s", kPositive);
      if (!script.motion.rms_speed_max_m_s && !script.motion.kinetic_energy_max_j && !script.motion.speed_max_m_s)
        m.fail_here(prefix + ".motion", "give 'rms_speed_max_m_s', 'kinetic_energy_max_j' and/or 'speed_max_m_s'");
      script.motion.from_step = time_of(m, "from", false).value_or(0);
      if (script.motion.from_step >= script.steps)
        m.fail_at(m.has("from_ms") ? "from_ms" : "from_step", "starts after the run's last step");
    }
    const auto creeps = array_of_tables(a, "creep");
    for (std::size_t i = 0; i < creeps.size(); ++i) {
      const std::string path = prefix + ".creep[" + std::to_string(i) + "]";
      const TableReader c(origin_, *creeps[i], path, kCreepKeys);
      CreepLimit creep;
      creep.where = location(origin_, creeps[i]->source());
      creep.pattern = object_pattern(c, creep.objects);
      creep.max_m = c.required_number("max_m", kNonNegative, " (m: how far a centre of mass may move)");
      read_window(c, path, script.steps, creep.from_step, creep.to_step, creep.every_steps);
      if (creep.from_step % creep.every_steps != 0)
        c.fail_here(path, "'from' must be a whole number of 'every' intervals (the first sample is taken there)");
      script.creeps.push_back(creep);
    }
    const auto windows = array_of_tables(a, "force_window");
    for (std::size_t i = 0; i < windows.size(); ++i) {
      const std::string path = prefix + ".force_window[" + std::to_string(i) + "]";
      const TableReader w(origin_, *windows[i], path, kForceWindowKeys);
      if (!has(model_->settings.effects, Effect::Probe))
        w.fail_here(path, "force assertions need the \"probe\" effect in the scene");
      ForceWindow window;
      window.where = location(origin_, windows[i]->source());
      std::uint64_t every = 0;
      read_window(w, path, script.steps, window.from_step, window.to_step, every);
      if (window.from_step >= window.to_step) w.fail_here(path, "the window holds no step ('from' must be before 'to')");
      window.relative_std_max = optional_number(w, "relative_std_max", kPositive);
      window.mean_min_n = optional_number(w, "mean_min_n", kNonNegative);
      window.mean_max_n = optional_number(w, "mean_max_n", kNonNegative);
      window.above_previous = w.boolean("above_previous", false);
      if (window.above_previous && script.force_windows.empty())
        w.fail_at("above_previous", "the first force window has none before it");
      if (!window.relative_std_max && !window.mean_min_n && !window.mean_max_n && !window.above_previous)
        w.fail_here(path, "give 'relative_std_max', 'mean_min_n', 'mean_max_n' and/or 'above_previous'");
      script.force_windows.push_back(window);
    }
    const auto hashes = array_of_tables(a, "hash");
    for (std::size_t i = 0; i < hashes.size(); ++i) {
      const TableReader h(origin_, *hashes[i], prefix + ".hash[" + std::to_string(i) + "]", kHashKeys);
      HashCheck check;
      check.where = location(origin_, hashes[i]->source());
      if (!h.has("step")) h.fail_missing("step");
      check.step = static_cast<std::uint64_t>(h.integer("step", 0, 1, kMaxSteps));
      if (check.step > script.steps) h.fail_at("step", "is after the end of the run (" + std::to_string(script.steps) + " steps)");
      const auto value = h.string("value");
      if (!value) h.fail_missing("value", " (16 hexadecimal digits, as printed by ffdsim)");
      if (value->size() != 16 || value->find_first_not_of("0123456789abcdefABCDEF") != std::string::npos)
        h.fail_at("value", "expected 16 hexadecimal digits (got " + in_quotes(*value) + ")");
      check.value = std::stoull(*value, nullptr, 16);
      script.hashes.push_back(check);
    }
  }

  // The required key `object` of an assertion: its text, and the objects it names.
  std::string object_pattern(const TableReader& t, std::vector<Index>& objects) const {
    const auto pattern = t.string("object");
    if (!pattern) t.fail_missing("object", " (an object name, or a name prefix ending in '*')");
    objects = objects_matching(t, "object", *pattern);
    return *pattern;
  }

  // An exact name, or every object whose name starts with the text before a final '*'.
  std::vector<Index> objects_matching(const TableReader& t, std::string_view key, const std::string& pattern) const {
    if (pattern.back() != '*') return {find_object(t, key, pattern)};
    const std::string prefix = pattern.substr(0, pattern.size() - 1);
    std::vector<Index> found;
    for (std::size_t i = 0; i < model_->objects.size(); ++i)
      if (model_->objects[i].name.starts_with(prefix)) found.push_back(static_cast<Index>(i));
    if (found.empty()) t.fail_at(key, "no object name starts with " + in_quotes(prefix));
    return found;
  }

  Index find_object(const TableReader& t, std::string_view key, const std::string& name) const {
    std::vector<std::string_view> names;
    for (std::size_t i = 0; i < model_->objects.size(); ++i) {
      if (model_->objects[i].name == name) return static_cast<Index>(i);
      names.emplace_back(model_->objects[i].name);
    }
    std::string problem = "no object named " + in_quotes(name) + " in the scene";
    if (const auto suggestion = closest_match(name, names)) problem += "; did you mean " + in_quotes(*suggestion) + "?";
    t.fail_at(key, problem + " (objects: " + join(names) + ")");
  }

  const std::string& origin_;
  const std::string& base_dir_;
  const SceneLimits& limits_;
  RecordedScene recorded_scene_;
  std::optional<ContactResponse> response_;  // the run's response, when the caller chose it
  const Model* model_ = nullptr;
  std::uint64_t path_commands_ = 0;  // commands from the keyframed paths so far
  double dt_ms_ = 1.0;
  std::uint64_t steps_ = 0;
};

}  // namespace

LoadedReplay parse_replay(const std::string& text, const std::string& origin, const std::string& base_dir,
                          const SceneLimits& limits, RecordedScene recorded_scene,
                          std::optional<ContactResponse> response) {
  // A recording written as the session ran ends each block with a blank line; a run killed
  // mid-write leaves a last block cut short, which is left out with a note.
  if (text.rfind(kStreamedRecordingMarker, 0) == 0 && !text.ends_with("\n\n")) {
    const std::size_t end = text.rfind("\n\n");
    const std::string kept = end == std::string::npos ? std::string() : text.substr(0, end + 2);
    const auto line_of = [&](std::size_t offset) { return std::count(text.begin(), text.begin() + offset, '\n') + 1; };
    if (kept.find("\n[record]\n") == std::string::npos)
      throw ReplayError(origin + ":" + std::to_string(line_of(text.size())) +
                        ": the recording ends mid-write within its header (the run was cut off as it started): "
                        "nothing to replay");
    LoadedReplay out = ScriptReader(origin, base_dir, limits, recorded_scene, response).read(parse_toml(kept, origin));
    out.script.warnings.push_back(origin + ":" + std::to_string(line_of(kept.size())) +
                                  ": the recording ends mid-write here (the run was cut off); replaying its " +
                                  std::to_string(out.script.steps) + " steps up to line " +
                                  std::to_string(line_of(kept.size()) - 1));
    return out;
  }
  return ScriptReader(origin, base_dir, limits, recorded_scene, response).read(parse_toml(text, origin));
}

LoadedReplay load_replay_file(const std::string& path, const SceneLimits& limits, RecordedScene recorded_scene,
                              std::optional<ContactResponse> response) {
  return parse_replay(read_text_file(path, "replay script"), path, std::filesystem::path(path).parent_path().string(),
                      limits, recorded_scene, response);
}

}  // namespace ffd
