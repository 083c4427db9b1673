// The viewer in a GLFW window (OpenGL 3.3 core): mouse, wheel and keys become an InputState.
#include <chrono>
#include <stdexcept>
#include <string>

#include <epoxy/gl.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include "app/scripted_input.h"
#include "app/ui_run.h"

namespace ffd::ui {

namespace {

std::string g_glfw_error;  // the last error GLFW reported (its callback has no user pointer)
void on_glfw_error(int, const char* description) { g_glfw_error = description; }

// What the callbacks collect between two frames.
struct WindowEvents {
  float wheel = 0.0f;
  std::vector<Key> pressed;
  std::vector<unsigned> characters;
  std::array<bool, kKeyCount> keys{};
};

Key key_from_glfw(int key) {
  switch (key) {
    case GLFW_KEY_SPACE: return Key::Space;
    case GLFW_KEY_P: return Key::P;
    case GLFW_KEY_R: return Key::R;
    case GLFW_KEY_S: return Key::S;
    case GLFW_KEY_F: return Key::F;
    case GLFW_KEY_H: return Key::H;
    case GLFW_KEY_L: return Key::L;
    case GLFW_KEY_B: return Key::B;
    case GLFW_KEY_C: return Key::C;
    case GLFW_KEY_ESCAPE: return Key::Escape;
    case GLFW_KEY_TAB: return Key::Tab;
    case GLFW_KEY_LEFT: return Key::Left;
    case GLFW_KEY_RIGHT: return Key::Right;
    case GLFW_KEY_UP: return Key::Up;
    case GLFW_KEY_DOWN: return Key::Down;
    case GLFW_KEY_PAGE_UP: return Key::PageUp;
    case GLFW_KEY_PAGE_DOWN: return Key::PageDown;
    case GLFW_KEY_HOME: return Key::Home;
    case GLFW_KEY_END: return Key::End;
    case GLFW_KEY_INSERT: return Key::Insert;
    case GLFW_KEY_DELETE: return Key::Delete;
    case GLFW_KEY_BACKSPACE: return Key::Backspace;
    case GLFW_KEY_ENTER: return Key::Enter;
    case GLFW_KEY_KP_ENTER: return Key::Enter;
    case GLFW_KEY_A: return Key::A;
    case GLFW_KEY_V: return Key::V;
    case GLFW_KEY_X: return Key::X;
    case GLFW_KEY_Y: return Key::Y;
    case GLFW_KEY_Z: return Key::Z;
    default: return Key::None;
  }
}

struct GlfwSession {
  GlfwSession() {
    glfwSetErrorCallback(on_glfw_error);
    if (!glfwInit()) throw std::runtime_error("no display for a window (" + g_glfw_error + ")");
  }
  ~GlfwSession() { glfwTerminate(); }
};

}  // namespace

UiRunResult run_window(const UiRunOptions& options) {
  GlfwSession glfw;
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  const int width = options.script ? options.script->width : options.width;
  const int height = options.script ? options.script->height : options.height;
  GLFWwindow* window = glfwCreateWindow(width, height, "ffdsim", nullptr, nullptr);
  if (!window) throw std::runtime_error("cannot open an OpenGL 3.3 window (" + g_glfw_error + ")");
  glfwMakeContextCurrent(window);
  glfwSwapInterval(1);
  WindowEvents events;
  glfwSetWindowUserPointer(window, &events);
  glfwSetScrollCallback(window, [](GLFWwindow* w, double, double dy) {
    static_cast<WindowEvents*>(glfwGetWindowUserPointer(w))->wheel += static_cast<float>(dy);
  });
  glfwSetCharCallback(window, [](GLFWwindow* w, unsigned c) {
    static_cast<WindowEvents*>(glfwGetWindowUserPointer(w))->characters.push_back(c);
  });
  glfwSetKeyCallback(window, [](GLFWwindow* w, int key, int, int action, int) {
    auto* e = static_cast<WindowEvents*>(glfwGetWindowUserPointer(w));
    const Key k = key_from_glfw(key);
    if (k == Key::None) return;
    e->keys[static_cast<std::size_t>(k)] = action != GLFW_RELEASE;
    if (action == GLFW_PRESS) e->pressed.push_back(k);
  });

  UiRunResult result;
  result.renderer = std::string(reinterpret_cast<const char*>(glGetString(GL_RENDERER))) + ", OpenGL " +
                    reinterpret_cast<const char*>(glGetString(GL_VERSION));
  {
    ViewerOptions viewer_options = options.viewer;
    Viewer viewer(viewer_options);
    std::string title = "ffdsim — " + viewer.session().scene_path();
    glfwSetWindowTitle(window, title.c_str());
    std::optional<ScriptedInput> script;
    if (options.script) script.emplace(*options.script);
    const double dt = viewer.session().model().settings.dt;
    using Clock = std::chrono::steady_clock;
    const auto start = Clock::now();
    auto previous = start;
    auto next_second = start;
    double frame_ms_sum = 0.0;
    while (!glfwWindowShouldClose(window) && !viewer.quit_requested()) {
      const auto now = Clock::now();
      if (options.interrupted && options.interrupted->load()) break;
      if (options.seconds > 0.0 && std::chrono::duration<double>(now - start).count() >= options.seconds) break;
      const std::uint64_t step = viewer.session().newest_step();
      if (script && script->finished(step, dt)) break;
      if (options.every_second && now >= next_second) {
        options.every_second(viewer.session());
        next_second += std::chrono::seconds(1);
      }
      events.pressed.clear();
      events.characters.clear();
      events.wheel = 0.0f;
      glfwPollEvents();
      int fb_width = 0, fb_height = 0, window_width = 0, window_height = 0;
      glfwGetFramebufferSize(window, &fb_width, &fb_height);
      glfwGetWindowSize(window, &window_width, &window_height);
      if (fb_width <= 0 || fb_height <= 0) continue;  // minimised
      InputState input;
      if (script) {
        input = script->next(viewer, step, dt, fb_width, fb_height);
      } else {
        double x = 0, y = 0;
        glfwGetCursorPos(window, &x, &y);
        // Cursor positions are in window units; the viewer works in framebuffer pixels.
        const double sx = window_width > 0 ? static_cast<double>(fb_width) / window_width : 1.0;
        const double sy = window_height > 0 ? static_cast<double>(fb_height) / window_height : 1.0;
        input.mouse_x = static_cast<float>(x * sx);
        input.mouse_y = static_cast<float>(y * sy);
        input.buttons = {glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS,
                         glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS,
                         glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS};
        input.wheel = events.wheel;
        input.keys = events.keys;
        input.pressed = events.pressed;
        input.characters = events.characters;
        input.shift = glfwGetKey(window, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS || glfwGetKey(window, GLFW_KEY_RIGHT_SHIFT) == GLFW_PRESS;
        input.ctrl = glfwGetKey(window, GLFW_KEY_LEFT_CONTROL) == GLFW_PRESS || glfwGetKey(window, GLFW_KEY_RIGHT_CONTROL) == GLFW_PRESS;
        input.alt = glfwGetKey(window, GLFW_KEY_LEFT_ALT) == GLFW_PRESS || glfwGetKey(window, GLFW_KEY_RIGHT_ALT) == GLFW_PRESS;
      }
      glBindFramebuffer(GL_FRAMEBUFFER, 0);
      viewer.frame(input, fb_width, fb_height, std::chrono::duration<float>(now - previous).count());
      previous = now;
      glfwSwapBuffers(window);
      ++result.ui_frames;
      const double frame_ms = std::chrono::duration<double, std::milli>(Clock::now() - now).count();
      frame_ms_sum += frame_ms;
      result.ui_frame_max_ms = std::max(result.ui_frame_max_ms, frame_ms);
    }
    result.ui_frame_mean_ms = result.ui_frames ? frame_ms_sum / static_cast<double>(result.ui_frames) : 0.0;
    if (script) {
      result.script_events_done = script->events_done();
      result.script_events = script->script().events.size();
    }
    collect_result(viewer, result);
  }
  glfwDestroyWindow(window);
  return result;
}

}  // namespace ffd::ui
