// The viewer without a window: EGL surfaceless context, offscreen framebuffer, PNG frames.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "app/scripted_input.h"
#include "app/ui_run.h"
#include "platform/headless_gl.h"

namespace ffd::ui {

namespace {
// A run owns the frames it writes: frame_NNNNN.png and frames.json. Those of an earlier run
// in the same folder go first, so that the folder and its index always agree; other files
// are left alone.
void remove_earlier_frames(const std::filesystem::path& dir) {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    const std::size_t digits_end = name.find_first_not_of("0123456789", 6);
    const bool frame = name.rfind("frame_", 0) == 0 && digits_end != std::string::npos && digits_end >= 11 &&
                       name.substr(digits_end) == ".png";
    if (frame || name == "frames.json") std::filesystem::remove(entry.path(), ec);
  }
}
}  // namespace

UiRunResult run_headless(const UiRunOptions& options) {
  using Clock = std::chrono::steady_clock;
  if (!options.script && options.seconds <= 0.0) throw std::invalid_argument("run_headless: a script or a time limit is needed");
  const int width = options.script ? options.script->width : options.width;
  const int height = options.script ? options.script->height : options.height;
  HeadlessGl gl(width, height);
  gl.bind();
  Viewer viewer(options.viewer);
  UiRunResult result;
  result.renderer = gl.renderer();
  std::optional<ScriptedInput> script;
  if (options.script) script.emplace(*options.script);
  const double dt = viewer.session().model().settings.dt;
  if (!options.frames_dir.empty()) remove_earlier_frames(options.frames_dir);
  const std::uint64_t capture_every =
      std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(1.0 / (options.fps * dt))));
  std::uint64_t next_capture = 0;
  nlohmann::json index = nlohmann::json::array();

  // A display's pace: at most 60 frames per second of wall time.
  constexpr auto kFramePeriod = std::chrono::microseconds(16'667);
  const auto start = Clock::now();
  auto previous = start;
  auto next_second = start;
  double frame_ms_sum = 0.0;
  for (;;) {
    const auto now = Clock::now();
    const std::uint64_t step = viewer.session().newest_step();
    if (options.interrupted && options.interrupted->load()) break;
    if (options.seconds > 0.0 && std::chrono::duration<double>(now - start).count() >= options.seconds) break;
    if (script && script->finished(step, dt)) break;
    if (viewer.quit_requested()) break;
    if (options.every_second && now >= next_second) {
      options.every_second(viewer.session());
      next_second += std::chrono::seconds(1);
    }
    const InputState input = script ? script->next(viewer, step, dt, width, height) : InputState{};
    gl.bind();
    viewer.frame(input, width, height, std::chrono::duration<float>(now - previous).count());
    previous = now;
    const std::uint64_t shown = viewer.session().newest_step();
    if (!options.frames_dir.empty() && shown >= next_capture && viewer.session().frame()) {
      char name[64];
      std::snprintf(name, sizeof name, "frame_%05zu.png", result.frames_written);
      write_png((std::filesystem::path(options.frames_dir) / name).string(), width, height, gl.read_pixels());
      index.push_back({{"file", name}, {"step", shown}});
      ++result.frames_written;
      next_capture = shown - shown % capture_every + capture_every;
    }
    ++result.ui_frames;
    const double frame_ms = std::chrono::duration<double, std::milli>(Clock::now() - now).count();
    frame_ms_sum += frame_ms;
    result.ui_frame_max_ms = std::max(result.ui_frame_max_ms, frame_ms);
    std::this_thread::sleep_until(now + kFramePeriod);
  }
  result.ui_frame_mean_ms = result.ui_frames ? frame_ms_sum / static_cast<double>(result.ui_frames) : 0.0;
  if (script) {
    result.script_events_done = script->events_done();
    result.script_events = script->script().events.size();
  }
  collect_result(viewer, result);
  if (!options.frames_dir.empty()) {
    const nlohmann::json j = {{"scene", result.scene_path}, {"width", width}, {"height", height},
                              {"renderer", result.renderer}, {"frames", index}};
    const std::string path = (std::filesystem::path(options.frames_dir) / "frames.json").string();
    std::ofstream out(path);
    out << j.dump(1) << '\n';
    if (!out) throw std::runtime_error(path + ": cannot write the frame index");
  }
  return result;
}

}  // namespace ffd::ui
