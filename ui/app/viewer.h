#pragma once
// The interactive viewer: a scene on the physics loop, drawn with the SceneRenderer and
// steered with ImGui panels and the mouse. Platform-free: the GLFW window and the headless
// EGL runner both create a GL context, feed an InputState per frame and call frame().
#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "app/input.h"
#include "app/pointer_probe.h"
#include "app/session.h"
#include "device/device_link.h"
#include "render/camera.h"
#include "render/scene_renderer.h"

struct ImGuiContext;

namespace ffd::ui {

std::string default_recent_file();

struct ViewerOptions {
  std::string scene_path;       // the scene to open
  std::string scenes_folder;    // the scene picker lists the *.toml files here
  std::string recordings_folder = "out/recordings";
  // The scenes opened last, newest first, kept between runs (empty: not kept). Default:
  // $XDG_CONFIG_HOME/ffdsim/recent_scenes, else ~/.config/ffdsim/recent_scenes.
  std::string recent_file = default_recent_file();
  SessionOptions session;
  const device::DeviceLink* device = nullptr;  // a haptic device on the probe: its panel shows the link
};

struct PixelRect {
  float x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // px from the top-left
};

enum class PointerMode { Grab, Probe };

class Viewer {
 public:
  // Needs a current OpenGL 3.3 core context. Throws what Session throws for a bad scene.
  explicit Viewer(const ViewerOptions& options);
  ~Viewer();
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  // One UI frame: reads the newest physics frame, runs the panels and the pointer (which send
  // commands), and draws everything, ImGui included, into the bound framebuffer.
  void frame(const InputState& input, int width, int height, float dt_s);

  bool quit_requested() const { return quit_; }
  Session& session() { return *session_; }
  const OrbitCamera& camera() const { return camera_; }
  RenderOptions& render_options() { return render_options_; }
  PointerMode mode() const { return mode_; }
  // Where a named widget was drawn in the last frame ("alpha", "beta", "pause", ...), for
  // scripted input; false if it was not drawn.
  bool widget_rect(const std::string& name, PixelRect& rect) const;
  // Pixel of an object's lattice centre in the last frame; false if unknown or behind.
  bool object_pixel(const std::string& object, int width, int height, float& x, float& y) const;
  // Every command the UI sent, with the step it was stamped for (kNextStep: the next tick).
  const std::vector<Command>& sent_commands() const { return sent_; }
  // Messages for the user (errors, saved recordings), newest last.
  const std::vector<std::string>& messages() const { return messages_; }

 private:
  // `record_path`: record the new session to this file as it runs (empty: no recording).
  void open_scene(const std::string& path, const std::string& record_path = "");
  // The scene opened by the path field, Enter or the Open button, or the recent list.
  void open_scene_from_ui(const std::string& path);
  // Reopens the scene when its file changed on disk (checked twice a second).
  void reload_if_changed();
  void remember_recent(const std::string& path);
  void feed_imgui(const InputState& input, int width, int height, float dt_s);
  void panels(int width, int height);
  void scene_panel();
  void tuning_panel();
  void view_panel();
  void record_panel();
  void latency_panel(int width);
  void device_panel(const device::DeviceLink& link);
  void help_overlay(int height);
  void shortcuts(const InputState& input);
  void pointer(const InputState& input, int width, int height, float dt_s);
  void finish_pick();
  void remember(const char* name);
  void note(std::string message);
  void send(Command command) {
    command.step = session_->send(command);
    sent_.push_back(command);
  }
  void start_recording();
  void stop_recording();

  ViewerOptions options_;
  std::unique_ptr<Session> session_;
  std::unique_ptr<PointerProbe> pointer_probe_;  // the mouse on the probe (none with a device)
  std::unique_ptr<SceneRenderer> renderer_;
  OrbitCamera camera_;
  RenderOptions render_options_;
  PointerMode mode_ = PointerMode::Grab;
  bool quit_ = false, show_help_ = true;
  std::vector<std::string> scene_files_;
  char scene_path_edit_[1024] = {};
  std::vector<std::string> recent_scenes_;  // newest first, at most kRecentScenes
  std::filesystem::file_time_type scene_written_{};  // the scene file's time when it was opened
  std::chrono::steady_clock::time_point next_reload_check_{};
  std::map<std::string, PixelRect> widgets_;
  std::vector<std::string> messages_;
  std::vector<Command> sent_;
  // Values of the tunables the frame does not carry, as last sent.
  std::vector<float> stiffness_;
  float probe_stiffness_ = 0.0f, budget_us_ = 1000.0f;
  // Pointer state.
  InputState previous_;
  SurfacePick pick_;
  bool grabbing_ = false, probing_ = false;
  Vec3f drag_plane_point_ = Vec3f::Zero();  // the drag / probe moves in the view plane through this point
  Vec3 last_target_ = Vec3::Zero();
  // Recording.
  bool recording_ = false;
  std::string recording_path_;
  char recording_path_edit_[512] = {};
  ImGuiContext* imgui_ = nullptr;
};

}  // namespace ffd::ui
