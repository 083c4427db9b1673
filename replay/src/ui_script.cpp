#include "ffd/ui_script.h"

#include <filesystem>

#include "ffd/toml_reader.h"

namespace ffd {

namespace {

const std::vector<std::string_view> kRootKeys = {"format", "version", "description", "scene", "duration_ms", "size", "input"};
const std::vector<std::string_view> kInputKeys = {"at_ms", "mouse", "mouse_to", "widget", "fraction", "offset",
                                                  "glide_ms", "press", "release", "key", "wheel", "text"};
const std::vector<std::string_view> kButtons = {"left", "right", "middle"};
constexpr double kMaxMs = 1e9;

int button(const TableReader& t, std::string_view key) {
  const auto name = t.string(key);
  if (!name) t.fail_at(key, "expected a button name (valid: " + join(kButtons) + ")");
  for (std::size_t b = 0; b < kButtons.size(); ++b)
    if (*name == kButtons[b]) return static_cast<int>(b);
  t.fail_at(key, "unknown button " + in_quotes(*name) + " (valid: " + join(kButtons) + ")");
}

std::pair<float, float> pixel_pair(const TableReader& t, std::string_view key, const Bounds& bounds) {
  const toml::array* a = t.find(key)->as_array();
  if (!a || a->size() != 2) t.fail_at(key, "expected [x, y] in pixels");
  double v[2];
  for (std::size_t i = 0; i < 2; ++i) {
    const auto number = a->get(i)->value<double>();
    if (!number || !std::isfinite(*number) || !bounds.contains(*number))
      t.fail_at(key, "expected two finite numbers " + bounds.describe());
    v[i] = *number;
  }
  return {static_cast<float>(v[0]), static_cast<float>(v[1])};
}

std::string location(const std::string& origin, const toml::table& table, const std::string& field) {
  return origin + ":" + std::to_string(table.source().begin.line) + ":" + std::to_string(table.source().begin.column) +
         ": " + field;
}

}  // namespace

const std::vector<std::string>& ui_script_key_names() {
  static const std::vector<std::string> names = {"space", "p", "r", "s", "f", "h", "l", "b", "c", "escape", "enter"};
  return names;
}

UiScript parse_ui_script(const std::string& text, const std::string& origin, const std::string& base_dir) {
  const toml::table root_table = parse_toml(text, origin);
  const TableReader root(origin, root_table, "", kRootKeys);
  UiScript script;
  script.origin = origin;
  if (root.has("format") && root.string("format").value_or("") != "ffdsim-ui-script")
    root.fail_at("format", "expected \"ffdsim-ui-script\"");
  if (root.integer("version", 1, 1, 1) != 1) root.fail_at("version", "only version 1 exists");
  root.string("description");
  if (root.has("scene")) {
    const auto path = root.string("scene");
    if (!path) root.fail_at("scene", "expected a path to a scene file");
    std::filesystem::path resolved(*path);
    if (resolved.is_relative() && !base_dir.empty()) resolved = std::filesystem::path(base_dir) / resolved;
    std::error_code error;
    if (!std::filesystem::is_regular_file(resolved, error))
      root.fail_at("scene", "cannot find scene file " + in_quotes(resolved.string()) +
                                " (scene paths are relative to the script's folder)");
    script.scene_path = std::filesystem::absolute(resolved).lexically_normal().string();
  }
  script.duration_ms = root.required_number("duration_ms", {0.0, kMaxMs, true, false}, " (how long the run lasts, ms of simulated time)");
  if (root.has("size")) {
    const auto size = pixel_pair(root, "size", {64.0, 8192.0});
    script.width = static_cast<int>(size.first);
    script.height = static_cast<int>(size.second);
  }
  const auto inputs = array_of_tables(root, "input");
  double previous = 0.0;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const std::string path = "input[" + std::to_string(i) + "]";
    const TableReader t(origin, *inputs[i], path, kInputKeys);
    UiInputEvent e;
    e.where = location(origin, *inputs[i], path);
    if (!t.has("at_ms")) t.fail_missing("at_ms", " (ms of simulated time)");
    e.at_ms = t.number("at_ms", 0.0, {0.0, kMaxMs});
    if (e.at_ms < previous) t.fail_at("at_ms", "inputs must be in time order");
    if (e.at_ms >= script.duration_ms) t.fail_at("at_ms", "is at or after the end of the run (duration_ms)");
    previous = e.at_ms;
    const int targets = int(t.has("mouse")) + int(t.has("mouse_to")) + int(t.has("widget"));
    if (targets > 1) t.fail_here(path, "give at most one of 'mouse', 'mouse_to' and 'widget'");
    if (t.has("mouse")) e.mouse = pixel_pair(t, "mouse", {-1.0, 8192.0});
    if (t.has("mouse_to")) e.mouse_to_object = t.string("mouse_to").value_or("");
    if (t.has("mouse_to") && e.mouse_to_object.empty()) t.fail_at("mouse_to", "expected an object name");
    if (t.has("widget")) e.mouse_to_widget = t.string("widget").value_or("");
    if (t.has("widget") && e.mouse_to_widget.empty()) t.fail_at("widget", "expected a widget name");
    if (t.has("fraction") && !t.has("widget")) t.fail_at("fraction", "goes with 'widget'");
    e.widget_fraction = static_cast<float>(t.number("fraction", 0.5, kUnitInterval));
    // An offset alone moves the cursor relative to where it is.
    if (t.has("offset")) e.offset = pixel_pair(t, "offset", {-8192.0, 8192.0});
    e.relative = targets == 0 && t.has("offset");
    if (t.has("glide_ms") && targets == 0 && !t.has("offset"))
      t.fail_at("glide_ms", "goes with 'mouse', 'mouse_to', 'widget' or 'offset'");
    e.glide_ms = t.number("glide_ms", 0.0, {0.0, kMaxMs});
    if (t.has("press")) e.press = button(t, "press");
    if (t.has("release")) e.release = button(t, "release");
    if (t.has("key")) {
      e.key = t.string("key").value_or("");
      const auto& names = ui_script_key_names();
      if (std::find(names.begin(), names.end(), e.key) == names.end()) {
        std::vector<std::string_view> valid(names.begin(), names.end());
        t.fail_at("key", "unknown key " + in_quotes(e.key) + " (valid: " + join(valid) + ")");
      }
    }
    e.wheel = static_cast<float>(t.number("wheel", 0.0, {-100.0, 100.0}));
    // Typed into the text field that has the keyboard (a click on it first), before `key`.
    e.text = t.string("text").value_or("");
    if (e.text.size() > 4096) t.fail_at("text", "is longer than 4096 bytes");
    if (targets == 0 && !t.has("offset") && e.press < 0 && e.release < 0 && e.key.empty() && e.wheel == 0.0f &&
        e.text.empty())
      t.fail_here(path, "does nothing: give a cursor target, press, release, key, text or wheel");
    script.events.push_back(std::move(e));
  }
  return script;
}

UiScript load_ui_script_file(const std::string& path) {
  return parse_ui_script(read_text_file(path, "UI input script"), path, std::filesystem::path(path).parent_path().string());
}

}  // namespace ffd
