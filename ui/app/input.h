#pragma once
// What a platform (the GLFW window, or a script driving the headless renderer) hands the
// viewer each frame: the same structure from both, so both drive the UI the same way.
#include <array>
#include <cstddef>
#include <vector>

namespace ffd::ui {

enum class Key : int {
  None,
  // Shortcuts (docs/realtime.md, "The interactive viewer").
  Space, P, R, S, F, H, L, B, C, Escape,
  // Text editing in ImGui fields.
  Tab, Left, Right, Up, Down, PageUp, PageDown, Home, End, Insert, Delete, Backspace, Enter, A, V, X, Y, Z,
  Count
};
inline constexpr std::size_t kKeyCount = static_cast<std::size_t>(Key::Count);

enum MouseButton : int { kLeftButton = 0, kRightButton = 1, kMiddleButton = 2 };

struct InputState {
  float mouse_x = -1.0f, mouse_y = -1.0f;  // px from the framebuffer's top-left; < 0: outside
  std::array<bool, 3> buttons{};           // held now: left, right, middle
  float wheel = 0.0f;                      // clicks since the last frame (positive: away from the user)
  std::array<bool, kKeyCount> keys{};      // held now
  std::vector<Key> pressed;                // pressed since the last frame, in order
  std::vector<unsigned> characters;        // typed since the last frame (Unicode)
  bool shift = false, ctrl = false, alt = false;
};

}  // namespace ffd::ui
