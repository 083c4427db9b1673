#pragma once
// Running the viewer on a platform: a GLFW window where there is a display, or headless on
// EGL writing PNG frames. Both return the same figures for the run report.
#include <atomic>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "app/viewer.h"
#include "ffd/ui_script.h"

namespace ffd::ui {

struct UiRunOptions {
  ViewerOptions viewer;
  std::optional<UiScript> script;  // drives the mouse and keys instead of a person
  double seconds = 0.0;            // wall-clock limit; 0: until the window closes or the script ends
                                   // (headless without a script needs one)
  std::string frames_dir;          // headless: write PNGs here (and frames.json)
  double fps = 10.0;               // frames per simulated second written
  int width = 1280, height = 720;  // px
  const std::atomic<bool>* interrupted = nullptr;  // set by a signal handler: end the run cleanly
  // Called on the UI thread at the first frame and then once a second of wall time (the run
  // report written as the run goes).
  std::function<void(const Session&)> every_second;
};

struct UiRunResult {
  std::string scene_path;
  std::string renderer;            // GL_RENDERER and version
  std::vector<std::int64_t> compute_ns, lateness_ns;  // every step's
  LoopCounters counters;
  std::array<std::uint64_t, kAccuracyLevels> steps_at_level{};
  bool finite = true;
  Recording log;                   // every applied command and hash
  // --record: written as the run went (by the first session); its figures where that session
  // is still the viewer's at the end, and the first write error.
  std::size_t recorded_commands = 0, recorded_hashes = 0;
  std::string recording_error;
  // The exports' summary line and first write error, when the session at the end has them.
  std::string exports_summary, exports_error;
  std::vector<std::string> model_object_names;
  std::size_t ui_frames = 0;
  double ui_frame_mean_ms = 0.0, ui_frame_max_ms = 0.0;  // wall time per UI frame
  std::size_t frames_written = 0;
  std::size_t script_events_done = 0, script_events = 0;
};

// Throws std::runtime_error when there is no usable display (the caller may fall back to
// the headless run) and ffd::InputError for bad scenes or scripts.
UiRunResult run_window(const UiRunOptions& options);
UiRunResult run_headless(const UiRunOptions& options);

// Where the figures shared by both come from.
void collect_result(Viewer& viewer, UiRunResult& result);

}  // namespace ffd::ui
