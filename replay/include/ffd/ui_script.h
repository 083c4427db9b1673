#pragma once
// UI input scripts: mouse and key input for the interactive viewer, timed in simulated
// milliseconds, so that a headless run (or a window under test) is driven the way a person
// drives the window. Format in docs/realtime.md, "UI input scripts".
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace ffd {

struct UiInputEvent {
  double at_ms = 0.0;             // simulated time: applied once the newest frame has reached it
  std::string where;              // "file:line:col: input[3]" for errors found while running
  // Where the cursor goes (at most one of these):
  std::optional<std::pair<float, float>> mouse;  // px from the top-left
  std::string mouse_to_object;    // the object's lattice centre on screen
  std::string mouse_to_widget;    // a named viewer widget (docs/realtime.md lists them)
  float widget_fraction = 0.5f;   // across the widget, 0 = left edge, 1 = right edge
  std::pair<float, float> offset{0.0f, 0.0f};  // px added to the target; alone: a move from the cursor
  bool relative = false;          // offset alone
  double glide_ms = 0.0;          // move there over this much simulated time (0: jump)
  // Then, in this order:
  int press = -1, release = -1;   // mouse button: 0 left, 1 right, 2 middle
  std::string text;               // UTF-8 typed into the focused text field (before `key`)
  std::string key;                // a key name: "p", "space", "r", "enter", ...
  float wheel = 0.0f;             // clicks
};

struct UiScript {
  std::string origin;
  std::string scene_path;         // absolute; empty: the command line's or the default scene
  double duration_ms = 0.0;       // simulated time the run lasts
  int width = 1280, height = 720; // px, the framebuffer the coordinates refer to
  std::vector<UiInputEvent> events;  // in time order
};

// Throws ffd::InputError "file:line:col: field: problem".
UiScript parse_ui_script(const std::string& text, const std::string& origin, const std::string& base_dir);
UiScript load_ui_script_file(const std::string& path);

// Key names a script may use.
const std::vector<std::string>& ui_script_key_names();

}  // namespace ffd
