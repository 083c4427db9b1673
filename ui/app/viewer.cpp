#include "app/viewer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>

#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>
#include <imgui_freetype.h>

#include "app/picking.h"
#include "ffd/scene_loader.h"
#include "ffd/trilinear.h"

namespace ffd::ui {

namespace {

constexpr const char* kFontPath = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";  // Debian: fonts-dejavu-core
constexpr float kFontSize = 15.0f;                                                    // px
constexpr float kPanelWidth = 330.0f, kLatencyWidth = 380.0f, kMargin = 8.0f;         // px
constexpr float kProbeWheelStep = 0.01f;  // m the probe moves along the view per wheel click
constexpr double kProbeSpeed = 1.0;        // m/s of wall time the probe device may move at most

Vec3 to_double(const Vec3f& v) { return v.cast<double>(); }

std::vector<std::string> list_scenes(const std::string& folder) {
  std::vector<std::string> files;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(folder, error))
    if (entry.path().extension() == ".toml") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

constexpr std::size_t kRecentScenes = 8;

std::vector<std::string> read_recent(const std::string& file) {
  std::vector<std::string> paths;
  std::ifstream in(file);
  for (std::string line; std::getline(in, line) && paths.size() < kRecentScenes;)
    if (!line.empty()) paths.push_back(line);
  return paths;
}

std::string timestamp() {
  const std::time_t now = std::time(nullptr);
  std::tm local{};
  localtime_r(&now, &local);
  char text[32];
  std::strftime(text, sizeof text, "%Y%m%d_%H%M%S", &local);
  return text;
}

// Shortcut keys and ImGui's text-editing keys, mapped onto InputState::keys.
void map_imgui_keys(ImGuiIO& io) {
  const std::pair<ImGuiKey_, Key> map[] = {
      {ImGuiKey_Tab, Key::Tab},       {ImGuiKey_LeftArrow, Key::Left}, {ImGuiKey_RightArrow, Key::Right},
      {ImGuiKey_UpArrow, Key::Up},    {ImGuiKey_DownArrow, Key::Down}, {ImGuiKey_PageUp, Key::PageUp},
      {ImGuiKey_PageDown, Key::PageDown}, {ImGuiKey_Home, Key::Home},  {ImGuiKey_End, Key::End},
      {ImGuiKey_Insert, Key::Insert}, {ImGuiKey_Delete, Key::Delete},  {ImGuiKey_Backspace, Key::Backspace},
      {ImGuiKey_Space, Key::Space},   {ImGuiKey_Enter, Key::Enter},    {ImGuiKey_Escape, Key::Escape},
      {ImGuiKey_KeyPadEnter, Key::Enter}, {ImGuiKey_A, Key::A},        {ImGuiKey_C, Key::C},
      {ImGuiKey_V, Key::V},           {ImGuiKey_X, Key::X},            {ImGuiKey_Y, Key::Y},
      {ImGuiKey_Z, Key::Z}};
  for (const auto& [imgui_key, key] : map) io.KeyMap[imgui_key] = static_cast<int>(key);
}

// A ring buffer of per-step values as a line over the last kLength steps, oldest at the
// left; each pixel column shows the largest value that falls in it, so single spikes stay
// visible. `reference` (if >= 0) is drawn as a red line.
void plot_history(const char* label, const float* values, std::size_t count, std::size_t oldest, float scale_max,
                  float reference, float height) {
  const ImVec2 origin = ImGui::GetCursorScreenPos();
  const float width = ImGui::GetContentRegionAvail().x;
  ImGui::InvisibleButton(label, ImVec2(width, height));
  ImDrawList* draw = ImGui::GetWindowDrawList();
  draw->AddRectFilled(origin, ImVec2(origin.x + width, origin.y + height), IM_COL32(30, 33, 40, 255));
  auto y_of = [&](float v) { return origin.y + height - std::clamp(v / scale_max, 0.0f, 1.0f) * (height - 2.0f) - 1.0f; };
  const int columns = std::max(1, static_cast<int>(width));
  ImVec2 previous;
  for (int c = 0; c < columns; ++c) {
    const std::size_t begin = count * static_cast<std::size_t>(c) / static_cast<std::size_t>(columns);
    const std::size_t end = std::max(begin + 1, count * static_cast<std::size_t>(c + 1) / static_cast<std::size_t>(columns));
    float peak = 0.0f;
    for (std::size_t i = begin; i < end; ++i) peak = std::max(peak, values[(oldest + i) % count]);
    const ImVec2 point(origin.x + static_cast<float>(c), y_of(peak));
    if (c > 0) draw->AddLine(previous, point, IM_COL32(120, 200, 255, 255));
    previous = point;
  }
  if (reference >= 0.0f)
    draw->AddLine(ImVec2(origin.x, y_of(reference)), ImVec2(origin.x + width, y_of(reference)), IM_COL32(255, 80, 70, 255));
  draw->AddText(ImVec2(origin.x + 4.0f, origin.y + 2.0f), IM_COL32(220, 224, 232, 255), label);
}

}  // namespace

std::string default_recent_file() {
  const char* config = std::getenv("XDG_CONFIG_HOME");
  const char* home = std::getenv("HOME");
  if (config && *config) return std::string(config) + "/ffdsim/recent_scenes";
  if (home && *home) return std::string(home) + "/.config/ffdsim/recent_scenes";
  return "";
}

Viewer::Viewer(const ViewerOptions& options) : options_(options) {
  IMGUI_CHECKVERSION();
  imgui_ = ImGui::CreateContext();
  ImGui::SetCurrentContext(imgui_);
  ImGuiIO& io = ImGui::GetIO();
  io.IniFilename = nullptr;  // no imgui.ini left in the user's folder
  map_imgui_keys(io);
  ImGui::StyleColorsDark();
  ImGuiStyle& style = ImGui::GetStyle();
  style.WindowRounding = 4.0f;
  style.FrameRounding = 3.0f;
  style.WindowBorderSize = 0.0f;
  style.Colors[ImGuiCol_WindowBg].w = 0.88f;
  if (std::filesystem::exists(kFontPath)) {
    // Latin-1 (µ, ·), Greek (α, β), dashes and arrows.
    static const ImWchar ranges[] = {0x0020, 0x00FF, 0x0370, 0x03FF, 0x2010, 0x2027, 0x2190, 0x21FF, 0};
    io.Fonts->FontBuilderIO = ImGuiFreeType::GetBuilderForFreeType();
    io.Fonts->AddFontFromFileTTF(kFontPath, kFontSize, nullptr, ranges);
  }
  if (!ImGui_ImplOpenGL3_Init("#version 330 core")) throw std::runtime_error("ImGui: the OpenGL 3.3 renderer does not start");
  if (options_.scenes_folder.empty())
    options_.scenes_folder = std::filesystem::path(default_scene_path()).parent_path().string();
  scene_files_ = list_scenes(options_.scenes_folder);
  if (!options_.recent_file.empty()) recent_scenes_ = read_recent(options_.recent_file);
  // `--record`: the first session is recorded as it runs, as the Record button would.
  const std::string record_path = options_.session.record_path;
  open_scene(options_.scene_path.empty() ? default_scene_path() : options_.scene_path, record_path);
  if (!record_path.empty()) {
    recording_ = true;
    recording_path_ = record_path;
  }
  std::snprintf(recording_path_edit_, sizeof recording_path_edit_, "%s/session_%s.toml",
                options_.recordings_folder.c_str(), timestamp().c_str());
}

Viewer::~Viewer() {
  ImGui::SetCurrentContext(imgui_);
  session_.reset();
  renderer_.reset();
  ImGui_ImplOpenGL3_Shutdown();
  ImGui::DestroyContext(imgui_);
}

void Viewer::open_scene(const std::string& path, const std::string& record_path) {
  // Load first: a bad scene leaves the running one alone.
  SessionOptions options = options_.session;
  options.record_path = record_path;
  if (session_) options.exports = {};  // like --record, the exports are the first session's
  // Without a device, the mouse drives the probe through the physics thread's interpolation.
  auto pointer = options_.device ? nullptr : std::make_unique<PointerProbe>();
  if (pointer) options.loop.probe_source = pointer.get();
  auto session = std::make_unique<Session>(path, options);
  session_.reset();  // stops the old physics thread before its model goes away
  pointer_probe_ = std::move(pointer);
  renderer_.reset();
  session_ = std::move(session);
  std::error_code unknown_time;
  scene_written_ = std::filesystem::last_write_time(session_->scene_path(), unknown_time);
  remember_recent(session_->scene_path());
  renderer_ = std::make_unique<SceneRenderer>(session_->model());
  const State& initial = session_->initial();
  stiffness_.assign(initial.params.stiffness.begin(), initial.params.stiffness.end());
  probe_stiffness_ = static_cast<float>(initial.params.probe_stiffness);
  budget_us_ = static_cast<float>(options_.session.loop.budget_ns) * 1e-3f;
  grabbing_ = probing_ = false;
  recording_ = false;
  sent_.clear();
  // Frame the objects where the scene places them (node_rest is each object's own frame).
  Vec3 lo = initial.x.front(), hi = lo;
  for (const Vec3& p : initial.x) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  camera_.frame(lo.cast<float>(), hi.cast<float>());
  camera_.distance *= 1.15f;
}

void Viewer::open_scene_from_ui(const std::string& path) {
  try {
    open_scene(std::filesystem::absolute(path).lexically_normal().string());
    note("opened " + session_->scene_path());
  } catch (const std::exception& e) {
    note(e.what());  // the running scene goes on
  }
}

void Viewer::reload_if_changed() {
  const auto now = std::chrono::steady_clock::now();
  if (now < next_reload_check_) return;
  next_reload_check_ = now + std::chrono::milliseconds(500);
  std::error_code error;
  const auto written = std::filesystem::last_write_time(session_->scene_path(), error);
  if (error || written == scene_written_) return;
  scene_written_ = written;  // a scene that does not load is not retried until it changes again
  const std::string path = session_->scene_path();
  try {
    open_scene(path);
    note("reloaded " + path + ": it changed on disk");
  } catch (const std::exception& e) {
    note(std::string("not reloaded: ") + e.what());
  }
}

void Viewer::remember_recent(const std::string& path) {
  recent_scenes_.erase(std::remove(recent_scenes_.begin(), recent_scenes_.end(), path), recent_scenes_.end());
  recent_scenes_.insert(recent_scenes_.begin(), path);
  if (recent_scenes_.size() > kRecentScenes) recent_scenes_.resize(kRecentScenes);
  if (options_.recent_file.empty()) return;
  std::error_code error;
  std::filesystem::create_directories(std::filesystem::path(options_.recent_file).parent_path(), error);
  std::ofstream out(options_.recent_file, std::ios::trunc);
  for (const std::string& p : recent_scenes_) out << p << '\n';
  if (!out) {
    const std::string file = options_.recent_file;
    options_.recent_file.clear();  // said once; the list still works for this run
    note(file + ": cannot write the recent scenes");
  }
}

void Viewer::note(std::string message) {
  std::fprintf(stderr, "ffdsim: %s\n", message.c_str());
  messages_.push_back(std::move(message));
}

bool Viewer::widget_rect(const std::string& name, PixelRect& rect) const {
  const auto it = widgets_.find(name);
  if (it == widgets_.end()) return false;
  rect = it->second;
  return true;
}

bool Viewer::object_pixel(const std::string& object, int width, int height, float& x, float& y) const {
  const Frame* frame = session_->frame();
  if (!frame) return false;
  const Model& model = session_->model();
  for (Index o = 0; o < model.objects.size(); ++o) {
    if (model.objects[o].name != object) continue;
    Vec2f pixel;
    if (!camera_.project(object_centre(model, *frame, o).cast<float>(), width, height, pixel)) return false;
    x = pixel.x();
    y = pixel.y();
    return true;
  }
  return false;
}

void Viewer::remember(const char* name) {
  const ImVec2 lo = ImGui::GetItemRectMin(), hi = ImGui::GetItemRectMax();
  widgets_[name] = {lo.x, lo.y, hi.x, hi.y};
}

void Viewer::feed_imgui(const InputState& input, int width, int height, float dt_s) {
  ImGuiIO& io = ImGui::GetIO();
  io.DisplaySize = ImVec2(static_cast<float>(width), static_cast<float>(height));
  io.DeltaTime = std::max(dt_s, 1e-4f);
  io.MousePos = input.mouse_x >= 0.0f ? ImVec2(input.mouse_x, input.mouse_y) : ImVec2(-FLT_MAX, -FLT_MAX);
  for (int b = 0; b < 3; ++b) io.MouseDown[b] = input.buttons[static_cast<std::size_t>(b)];
  io.MouseWheel = input.wheel;
  for (std::size_t k = 0; k < kKeyCount; ++k) io.KeysDown[k] = input.keys[k];
  // A key pressed and released within one frame still counts as pressed for this frame.
  for (Key k : input.pressed) io.KeysDown[static_cast<std::size_t>(k)] = true;
  io.KeyShift = input.shift;
  io.KeyCtrl = input.ctrl;
  io.KeyAlt = input.alt;
  for (unsigned c : input.characters) io.AddInputCharacter(c);
}

void Viewer::frame(const InputState& input, int width, int height, float dt_s) {
  ImGui::SetCurrentContext(imgui_);
  reload_if_changed();
  session_->poll();
  feed_imgui(input, width, height, dt_s);
  ImGui_ImplOpenGL3_NewFrame();
  ImGui::NewFrame();
  widgets_.clear();
  panels(width, height);
  const ImGuiIO& io = ImGui::GetIO();
  if (!io.WantCaptureKeyboard) shortcuts(input);
  pointer(input, width, height, dt_s);
  ImGui::Render();

  // Before the first step the objects are drawn at rest.
  const Frame* frame = session_->frame();
  Frame rest;
  if (!frame) {
    rest.nodes = session_->model().node_rest;
    frame = &rest;
  }
  renderer_->draw(*frame, camera_, width, height, render_options_, &pick_);
  finish_pick();
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  previous_ = input;
}

void Viewer::shortcuts(const InputState& input) {
  const Frame* frame = session_->frame();
  for (Key k : input.pressed) {
    switch (k) {
      case Key::P:
        mode_ = mode_ == PointerMode::Grab ? PointerMode::Probe : PointerMode::Grab;
        if (mode_ == PointerMode::Probe && !has(session_->model().settings.effects, Effect::Probe)) {
          note("this scene has no \"probe\" effect");
          mode_ = PointerMode::Grab;
        } else if (mode_ == PointerMode::Probe && options_.device) {
          note("the haptic device drives the probe (--device)");
          mode_ = PointerMode::Grab;
        }
        break;
      case Key::Space: send({.kind = frame && frame->paused ? CommandKind::Resume : CommandKind::Pause}); break;
      case Key::S: send({.kind = CommandKind::SingleStep}); break;
      case Key::R: send({.kind = CommandKind::Reset}); break;
      case Key::L: render_options_.lattice = !render_options_.lattice; break;
      case Key::B: render_options_.boxes = !render_options_.boxes; break;
      case Key::C: render_options_.contacts = !render_options_.contacts; break;
      case Key::H: show_help_ = !show_help_; break;
      case Key::F: {
        Vec3 lo = frame ? frame->nodes.front() : session_->model().node_rest.front(), hi = lo;
        for (const Vec3& p : frame ? frame->nodes : session_->model().node_rest) {
          lo = lo.cwiseMin(p);
          hi = hi.cwiseMax(p);
        }
        camera_.frame(lo.cast<float>(), hi.cast<float>());
        camera_.distance *= 1.15f;
        break;
      }
      case Key::Escape: quit_ = true; break;
      default: break;
    }
  }
}

void Viewer::pointer(const InputState& input, int width, int height, float dt_s) {
  const ImGuiIO& io = ImGui::GetIO();
  const bool over_ui = io.WantCaptureMouse;
  const float dx = input.mouse_x - previous_.mouse_x, dy = input.mouse_y - previous_.mouse_y;
  const bool left_pressed = input.buttons[kLeftButton] && !previous_.buttons[kLeftButton];
  const bool left_released = !input.buttons[kLeftButton] && previous_.buttons[kLeftButton];
  const Ray ray = camera_.ray(input.mouse_x, input.mouse_y, width, height);
  const Vec3f view_normal = camera_.forward();
  pick_.requested = false;

  // Camera: right-drag orbits, middle-drag or shift + right-drag pans, the wheel zooms (or,
  // while the probe is held, pushes it into the scene).
  if (!over_ui || previous_.buttons[kRightButton] || previous_.buttons[kMiddleButton]) {
    if (input.buttons[kMiddleButton] && previous_.buttons[kMiddleButton]) camera_.pan(dx, dy, height);
    else if (input.buttons[kRightButton] && previous_.buttons[kRightButton]) {
      if (input.shift) camera_.pan(dx, dy, height);
      else camera_.orbit(dx, dy);
    }
  }
  if (!over_ui && input.wheel != 0.0f) {
    if (probing_) drag_plane_point_ += view_normal * (kProbeWheelStep * input.wheel);
    else camera_.zoom(input.wheel);
  }

  if (left_pressed && !over_ui) {
    // Both modes start from the surface point under the cursor, known once this frame's
    // surfaces are drawn: see finish_pick().
    pick_.requested = true;
    pick_.x_px = input.mouse_x;
    pick_.y_px = input.mouse_y;
    if (mode_ == PointerMode::Probe) {
      if (const Frame* frame = session_->frame()) {
        probing_ = true;
        drag_plane_point_ = frame->probe.device.cast<float>();
      }
    }
  }
  if (left_released) {
    if (grabbing_) send({.kind = CommandKind::Release});
    grabbing_ = probing_ = false;
  }
  if ((grabbing_ || probing_) && input.buttons[kLeftButton]) {
    Vec3f hit;
    if (intersect_plane(ray, drag_plane_point_, view_normal, hit)) {
      Vec3 target = to_double(hit);
      if (probing_ && session_->frame()) {
        // The device follows the cursor at a hand's pace (kProbeSpeed), so a jump of the
        // cursor never slams the probe into an object.
        const Vec3 device = session_->frame()->probe.device;
        const Vec3 move = target - device;
        const double reach = kProbeSpeed * std::clamp(static_cast<double>(dt_s), 0.002, 0.1);
        if (move.norm() > reach) target = device + move * (reach / move.norm());
      }
      if ((target - last_target_).norm() > 1e-5) {  // 0.01 mm: don't flood the queue while still
        Command c;
        c.kind = grabbing_ ? CommandKind::Drag : CommandKind::ProbePose;
        c.vector = target;
        if (grabbing_) send(c);
        else if (pointer_probe_) pointer_probe_->move(target);  // interpolated at each step's time
        last_target_ = target;
      }
    }
  }
}

void Viewer::finish_pick() {
  if (!pick_.requested) return;
  pick_.requested = false;
  const Frame* frame = session_->frame();
  if (!pick_.hit || !frame) return;
  if (probing_) {
    drag_plane_point_ = pick_.point;  // the probe moves in the view plane through the point
    return;
  }
  if (mode_ != PointerMode::Grab) return;
  if (!has(session_->model().settings.effects, Effect::Grab)) {
    note("this scene has no \"grab\" effect");
    return;
  }
  const CellPoint cp = cell_at(session_->model(), *frame, to_double(pick_.point));
  if (cp.cell == kNoIndex) return;
  Command grab;
  grab.kind = CommandKind::Grab;
  grab.cell = cp.cell;
  grab.local = cp.local;
  send(grab);
  grabbing_ = true;
  drag_plane_point_ = pick_.point;
  last_target_ = to_double(pick_.point);
}

void Viewer::panels(int width, int height) {
  ImGui::SetNextWindowPos(ImVec2(kMargin, kMargin), ImGuiCond_Always);
  ImGui::SetNextWindowSize(ImVec2(kPanelWidth, 0.0f), ImGuiCond_Always);
  ImGui::Begin("ffdsim", nullptr, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  scene_panel();
  if (ImGui::CollapsingHeader("Tuning", ImGuiTreeNodeFlags_DefaultOpen)) tuning_panel();
  if (ImGui::CollapsingHeader("Show", ImGuiTreeNodeFlags_DefaultOpen)) view_panel();
  if (ImGui::CollapsingHeader("Record", ImGuiTreeNodeFlags_DefaultOpen)) record_panel();
  ImGui::End();
  latency_panel(width);
  help_overlay(height);
}

void Viewer::scene_panel() {
  const Frame* frame = session_->frame();
  const std::string current = std::filesystem::path(session_->scene_path()).filename().string();
  ImGui::SetNextItemWidth(-1.0f);
  if (ImGui::BeginCombo("##scene", current.c_str())) {
    for (const std::string& file : scene_files_) {
      const std::string name = std::filesystem::path(file).filename().string();
      if (ImGui::Selectable(name.c_str(), name == current)) {
        try {
          open_scene(file);
        } catch (const std::exception& e) {
          note(e.what());
        }
      }
    }
    ImGui::EndCombo();
  }
  remember("scene");
  // Any scene by its path (Enter or Open), and the ones opened last.
  ImGui::SetNextItemWidth(-ImGui::CalcTextSize("Open").x - 3.0f * ImGui::GetStyle().FramePadding.x -
                          ImGui::GetStyle().ItemSpacing.x);
  const bool entered = ImGui::InputTextWithHint("##scene_path", "path/to/scene.toml", scene_path_edit_,
                                                sizeof scene_path_edit_, ImGuiInputTextFlags_EnterReturnsTrue);
  remember("scene_path");
  ImGui::SameLine();
  const bool clicked = ImGui::Button("Open");
  remember("open_scene");
  if (entered || clicked) open_scene_from_ui(scene_path_edit_);
  if (recent_scenes_.size() > 1) {
    ImGui::SetNextItemWidth(-1.0f);
    if (ImGui::BeginCombo("##recent", "recent scenes")) {
      std::string chosen;
      for (const std::string& path : recent_scenes_)
        if (ImGui::Selectable(path.c_str(), path == session_->scene_path())) chosen = path;
      ImGui::EndCombo();
      if (!chosen.empty()) open_scene_from_ui(chosen);
    }
    remember("recent");
  }
  frame = session_->frame();
  const double seconds = frame ? static_cast<double>(frame->step) * session_->model().settings.dt : 0.0;
  ImGui::Text("step %llu  ·  %.3f s%s", static_cast<unsigned long long>(frame ? frame->step : 0), seconds,
              frame && frame->paused ? "  ·  paused" : "");
  const bool paused = frame && frame->paused;
  if (ImGui::Button(paused ? "Play" : "Pause", ImVec2(70, 0))) send({.kind = paused ? CommandKind::Resume : CommandKind::Pause});
  remember("pause");
  ImGui::SameLine();
  if (ImGui::Button("Step", ImVec2(70, 0))) send({.kind = CommandKind::SingleStep});
  remember("step");
  ImGui::SameLine();
  if (ImGui::Button("Reset", ImVec2(70, 0))) {
    send({.kind = CommandKind::Reset});
    const State& initial = session_->initial();
    stiffness_.assign(initial.params.stiffness.begin(), initial.params.stiffness.end());
    probe_stiffness_ = static_cast<float>(initial.params.probe_stiffness);
  }
  remember("reset");
  int mode = mode_ == PointerMode::Grab ? 0 : 1;
  ImGui::TextUnformatted("Mouse:");
  ImGui::SameLine();
  if (ImGui::RadioButton("grab", &mode, 0)) mode_ = PointerMode::Grab;
  remember("mode_grab");
  ImGui::SameLine();
  // With a haptic device on the probe (--device) the mouse only grabs.
  ImGui::BeginDisabled(!has(session_->model().settings.effects, Effect::Probe) || options_.device);
  if (ImGui::RadioButton("probe (P)", &mode, 1)) mode_ = PointerMode::Probe;
  remember("mode_probe");
  ImGui::EndDisabled();
  if (!messages_.empty()) ImGui::TextColored(ImVec4(1.0f, 0.75f, 0.4f, 1.0f), "%s", messages_.back().c_str());
}

void Viewer::tuning_panel() {
  const Frame* frame = session_->frame();
  const Model& model = session_->model();
  ImGui::PushItemWidth(-130.0f);
  float alpha = static_cast<float>(frame ? frame->alpha : session_->initial().params.alpha);
  if (ImGui::SliderFloat("α damping", &alpha, 0.0f, 1.0f, "%.3f")) send({.kind = CommandKind::SetAlpha, .value = alpha});
  remember("alpha");
  float beta = static_cast<float>(frame ? frame->beta : session_->initial().params.beta);
  if (ImGui::SliderFloat("β friction", &beta, 0.0f, 1.0f, "%.3f")) send({.kind = CommandKind::SetBeta, .value = beta});
  remember("beta");
  Vec3 gravity = frame ? frame->gravity : session_->initial().params.gravity;
  float g = static_cast<float>(gravity.y());
  if (ImGui::SliderFloat("gravity y m/s²", &g, -20.0f, 20.0f, "%.2f")) {
    gravity.y() = g;
    send({.kind = CommandKind::SetGravity, .vector = gravity});
  }
  remember("gravity");
  for (Index o = 0; o < model.objects.size(); ++o) {
    const bool mass_spring = model.objects[o].dynamics == DynamicsKind::MassSpring;
    const std::string label = model.objects[o].name + (mass_spring ? " N/m" : " pull");
    float& k = stiffness_[o];
    const bool changed = mass_spring ? ImGui::SliderFloat(label.c_str(), &k, 10.0f, 1e6f, "%.0f", ImGuiSliderFlags_Logarithmic)
                                     : ImGui::SliderFloat(label.c_str(), &k, 0.01f, 1.0f, "%.3f");
    if (changed) send({.kind = CommandKind::SetStiffness, .object = o, .value = k});
    remember(("stiffness_" + model.objects[o].name).c_str());
  }
  if (has(model.settings.effects, Effect::Probe)) {
    if (ImGui::SliderFloat("probe N/m", &probe_stiffness_, 0.0f, 5000.0f, "%.0f", ImGuiSliderFlags_Logarithmic))
      send({.kind = CommandKind::SetProbeStiffness, .value = probe_stiffness_});
    remember("probe_stiffness");
  }
  // Accuracy: a level picked by hand turns the budget-aware choice off.
  const int level = static_cast<int>(frame ? frame->accuracy : session_->initial().params.accuracy);
  const bool automatic = frame && frame->auto_accuracy;
  char level_label[64];
  std::snprintf(level_label, sizeof level_label, "%d %s", level, accuracy_name(static_cast<Accuracy>(level)));
  // The longest level name ("2 FFD AABB + centre of mass") needs the panel's whole width.
  ImGui::TextUnformatted("accuracy");
  ImGui::SetNextItemWidth(-1.0f);
  if (ImGui::BeginCombo("##accuracy", level_label)) {
    for (int l = 0; l < kAccuracyLevels; ++l) {
      std::snprintf(level_label, sizeof level_label, "%d %s", l, accuracy_name(static_cast<Accuracy>(l)));
      if (ImGui::Selectable(level_label, l == level)) {
        if (automatic) send({.kind = CommandKind::AutoAccuracy, .value = 0.0});
        send({.kind = CommandKind::SetAccuracy, .value = static_cast<double>(l)});
      }
    }
    ImGui::EndCombo();
  }
  remember("accuracy");
  // The contact response (docs/step.md, "Two contact responses"): a recorded state command.
  const ContactResponse response = frame ? frame->response : session_->initial().params.response;
  if (ImGui::BeginCombo("response", response_name(response))) {
    for (ContactResponse r : {ContactResponse::Paper, ContactResponse::Solver})
      if (ImGui::Selectable(response_name(r), r == response))
        send({.kind = CommandKind::SetResponse, .value = static_cast<double>(r)});
    ImGui::EndCombo();
  }
  remember("response");
  bool auto_on = automatic;
  if (ImGui::Checkbox("fit accuracy to the budget", &auto_on))
    send({.kind = CommandKind::AutoAccuracy, .value = auto_on ? 1.0 : 0.0});
  remember("auto_accuracy");
  if (ImGui::SliderFloat("budget µs", &budget_us_, 100.0f, 5000.0f, "%.0f", ImGuiSliderFlags_Logarithmic))
    send({.kind = CommandKind::SetBudget, .value = budget_us_});
  remember("budget");
  ImGui::PopItemWidth();
}

void Viewer::view_panel() {
  ImGui::Checkbox("FFD lattice (L)", &render_options_.lattice);
  remember("show_lattice");
  ImGui::SameLine(170.0f);
  ImGui::Checkbox("FFD AABBs (B)", &render_options_.boxes);
  remember("show_boxes");
  ImGui::Checkbox("contacts (C)", &render_options_.contacts);
  remember("show_contacts");
  ImGui::SameLine(170.0f);
  ImGui::Checkbox("probe force", &render_options_.probe_force);
  remember("show_probe_force");
  ImGui::Checkbox("planes", &render_options_.planes);
}

void Viewer::record_panel() {
  ImGui::SetNextItemWidth(-1.0f);
  ImGui::InputText("##recording", recording_path_edit_, sizeof recording_path_edit_);
  remember("recording_path");
  if (!recording_) {
    if (ImGui::Button("Record (restarts the scene)")) start_recording();
  } else {
    if (ImGui::Button("Stop and save")) stop_recording();
    ImGui::SameLine();
    ImGui::TextColored(ImVec4(1.0f, 0.35f, 0.3f, 1.0f), "● %zu commands", session_->log().commands.size());
  }
  remember("record");
}

void Viewer::start_recording() {
  // A recording replays from the scene file, so it starts from step 0 of a fresh run.
  // Written as the session runs (recording.h), so a crash loses at most the last 60 ms.
  try {
    const std::filesystem::path parent = std::filesystem::path(recording_path_edit_).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent);
    open_scene(session_->scene_path(), recording_path_edit_);
    recording_ = true;
    recording_path_ = recording_path_edit_;
  } catch (const std::exception& e) {
    note(e.what());
  }
}

void Viewer::stop_recording() {
  recording_ = false;
  session_->close_recording();
  session_->poll();
  const LoopCounters counters = session_->counters();
  const RecordingStream* recording = session_->recording();
  if (!session_->recording_error().empty())
    note(session_->recording_error());
  else if (counters.commands_unrecorded > 0)
    note(recording_path_ + ": " + std::to_string(counters.commands_unrecorded) +
         " applied commands were lost; it will not replay this session");
  else if (recording)
    note("recorded " + std::to_string(recording->commands()) + " commands and " +
         std::to_string(recording->hashes()) + " state hashes to " + recording_path_);
  std::snprintf(recording_path_edit_, sizeof recording_path_edit_, "%s/session_%s.toml",
                options_.recordings_folder.c_str(), timestamp().c_str());
}

void Viewer::latency_panel(int width) {
  const LatencyHistory& h = session_->history();
  const LoopCounters counters = session_->counters();
  const Model& model = session_->model();
  ImGui::SetNextWindowPos(ImVec2(static_cast<float>(width) - kLatencyWidth - kMargin, kMargin), ImGuiCond_Always);
  ImGui::SetNextWindowSize(ImVec2(kLatencyWidth, 0.0f), ImGuiCond_Always);
  ImGui::Begin("Latency", nullptr, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  const float budget = budget_us_;
  char label[96];
  std::snprintf(label, sizeof label, "compute per step, µs (mean %.0f); red: budget %.0f", h.compute_average_us, budget);
  plot_history(label, h.compute_us.data(), h.compute_us.size(), h.next, 2.0f * budget, budget, 70.0f);
  remember("plot_compute");
  plot_history("wake-up lateness, µs (0 – 200)", h.lateness_us.data(), h.lateness_us.size(), h.next, 200.0f, -1.0f, 50.0f);
  const double miss_share = h.steps ? 100.0 * static_cast<double>(h.misses) / static_cast<double>(h.steps) : 0.0;
  ImGui::Text("steps %llu   misses %llu (%.2f%%)", static_cast<unsigned long long>(h.steps),
              static_cast<unsigned long long>(h.misses), miss_share);
  ImGui::Text("overruns %llu   late commands %llu   SCHED_FIFO %s", static_cast<unsigned long long>(counters.overruns),
              static_cast<unsigned long long>(counters.commands_late), counters.realtime_priority ? "yes" : "no");
  ImGui::Text("contacts %u   fastest node %.2f m/s%s", h.contacts, h.max_speed_m_s, h.finite ? "" : "   NON-FINITE");
  ImGui::Text("physics threads %d   SIMD %s", counters.threads, simd_target_name());
  if (ImGui::BeginTable("stages", 3, ImGuiTableFlags_SizingStretchProp)) {
    for (Stage stage : model.pipeline) {
      const double us = h.stage_us[static_cast<std::size_t>(stage)];
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(stage_name(stage));
      ImGui::TableNextColumn();
      ImGui::Text("%7.1f µs", us);
      ImGui::TableNextColumn();
      ImGui::ProgressBar(static_cast<float>(us / budget), ImVec2(-1.0f, 0.0f), "");
    }
    ImGui::EndTable();
  }
  if (const Frame* frame = session_->frame(); frame && has(model.settings.effects, Effect::Probe))
    ImGui::Text("probe force %.3f N", frame->probe.force.norm());
  if (const Frame* frame = session_->frame(); frame && has(model.settings.effects, Effect::Sleeping)) {
    const auto asleep = std::count(frame->asleep.begin(), frame->asleep.end(), std::uint8_t{1});
    ImGui::Text("asleep %lld of %zu objects (drawn grey)", static_cast<long long>(asleep), model.objects.size());
  }
  if (options_.device) device_panel(*options_.device);
  ImGui::End();
}

// The haptic device link: its state, rate and every counter a device user checks first.
void Viewer::device_panel(const device::DeviceLink& link) {
  const device::LinkCounters c = link.counters();
  ImGui::Separator();
  ImGui::TextUnformatted("device link");
  const ImVec4 colour = c.state == device::LinkState::Live ? ImVec4(0.4f, 0.9f, 0.4f, 1.0f) : ImVec4(1.0f, 0.5f, 0.3f, 1.0f);
  ImGui::TextColored(colour, "udp :%u  %s  %.0f Hz", static_cast<unsigned>(link.port()), device::link_state_name(c.state),
                     c.sample_rate_hz);
  ImGui::Text("samples %llu  forces sent %llu  force %.2f N", static_cast<unsigned long long>(c.samples),
              static_cast<unsigned long long>(c.forces_sent), c.force.norm());
  ImGui::Text("dropped: malformed %llu  duplicate %llu  late %llu  missing %llu",
              static_cast<unsigned long long>(c.malformed_total()), static_cast<unsigned long long>(c.duplicates),
              static_cast<unsigned long long>(c.out_of_order), static_cast<unsigned long long>(c.sequence_gaps));
  ImGui::Text("watchdog %llu  limited %llu  rate limited %llu", static_cast<unsigned long long>(c.watchdog_trips),
              static_cast<unsigned long long>(c.force_limited), static_cast<unsigned long long>(c.rate_limited));
}

void Viewer::help_overlay(int height) {
  const Frame* frame = session_->frame();
  ImDrawList* draw = ImGui::GetForegroundDrawList();
  // The force the device renders, as a number beside the probe.
  if (frame && has(session_->model().settings.effects, Effect::Probe) && render_options_.probe_force) {
    Vec2f pixel;
    const ImGuiIO& io = ImGui::GetIO();
    if (camera_.project(frame->probe.x.cast<float>(), static_cast<int>(io.DisplaySize.x), static_cast<int>(io.DisplaySize.y), pixel)) {
      char text[32];
      std::snprintf(text, sizeof text, "%.2f N", frame->probe.force.norm());
      draw->AddText(ImVec2(pixel.x() + 14.0f, pixel.y() - 8.0f), IM_COL32(255, 120, 100, 255), text);
    }
  }
  if (!show_help_) return;
  const char* mode = mode_ == PointerMode::Grab ? "grab" : "probe";
  char text[320];
  std::snprintf(text, sizeof text,
                "mode: %s   left-drag: %s   right-drag: orbit   middle / shift+right-drag: pan   wheel: zoom%s\n"
                "P: grab/probe   Space: pause   S: step   R: reset   F: frame   L/B/C: lattice/boxes/contacts   H: help   Esc: quit",
                mode, mode_ == PointerMode::Grab ? "grab and drag a point" : "move the probe",
                mode_ == PointerMode::Probe ? " (while held: push the probe)" : "");
  const ImVec2 size = ImGui::CalcTextSize(text);
  const ImVec2 at(kMargin, static_cast<float>(height) - size.y - kMargin);
  draw->AddRectFilled(ImVec2(at.x - 4, at.y - 4), ImVec2(at.x + size.x + 4, at.y + size.y + 4), IM_COL32(20, 22, 28, 200), 4.0f);
  draw->AddText(at, IM_COL32(220, 224, 232, 255), text);
}

}  // namespace ffd::ui
