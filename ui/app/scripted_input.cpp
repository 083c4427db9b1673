#include "app/scripted_input.h"

#include <algorithm>
#include <cmath>

#include "ffd/toml_reader.h"

namespace ffd::ui {

namespace {
std::uint64_t to_steps(double ms, double dt_s) { return static_cast<std::uint64_t>(std::llround(ms / (dt_s * 1000.0))); }
}  // namespace

Key key_from_name(const std::string& name) {
  if (name == "space") return Key::Space;
  if (name == "p") return Key::P;
  if (name == "r") return Key::R;
  if (name == "s") return Key::S;
  if (name == "f") return Key::F;
  if (name == "h") return Key::H;
  if (name == "l") return Key::L;
  if (name == "b") return Key::B;
  if (name == "c") return Key::C;
  if (name == "escape") return Key::Escape;
  if (name == "enter") return Key::Enter;
  return Key::None;
}

bool ScriptedInput::finished(std::uint64_t newest_step, double dt_s) const {
  return newest_step >= to_steps(script_.duration_ms, dt_s) && next_event_ >= script_.events.size() && !gliding_;
}

InputState ScriptedInput::next(const Viewer& viewer, std::uint64_t newest_step, double dt_s, int width, int height) {
  state_.pressed.clear();
  state_.characters.clear();
  state_.wheel = 0.0f;
  state_.keys.fill(false);
  if (gliding_) {
    const double span = static_cast<double>(glide_end_ - glide_begin_);
    const float f = static_cast<float>(std::clamp(static_cast<double>(newest_step - glide_begin_) / span, 0.0, 1.0));
    state_.mouse_x = glide_from_x_ + f * (glide_to_x_ - glide_from_x_);
    state_.mouse_y = glide_from_y_ + f * (glide_to_y_ - glide_from_y_);
    if (f >= 1.0f) gliding_ = false;
    return state_;  // nothing else happens while the cursor glides
  }
  if (next_event_ >= script_.events.size()) return state_;
  const UiInputEvent& e = script_.events[next_event_];
  const std::uint64_t at = to_steps(e.at_ms, dt_s);
  if (newest_step < at) return state_;
  ++next_event_;

  const bool moves = e.mouse || !e.mouse_to_object.empty() || !e.mouse_to_widget.empty() || e.relative;
  if (moves) {
    float x = 0, y = 0;
    if (e.relative) {
      x = std::max(state_.mouse_x, 0.0f);
      y = std::max(state_.mouse_y, 0.0f);
    } else if (e.mouse) {
      x = e.mouse->first;
      y = e.mouse->second;
    } else if (!e.mouse_to_object.empty()) {
      if (!viewer.object_pixel(e.mouse_to_object, width, height, x, y))
        throw InputError(e.where + ".mouse_to: no object " + in_quotes(e.mouse_to_object) + " on screen in this scene");
    } else {
      PixelRect r;
      if (!viewer.widget_rect(e.mouse_to_widget, r))
        throw InputError(e.where + ".widget: no widget " + in_quotes(e.mouse_to_widget) +
                         " is shown (docs/realtime.md, \"UI input scripts\", lists them)");
      x = r.x0 + e.widget_fraction * (r.x1 - r.x0);
      y = 0.5f * (r.y0 + r.y1);
    }
    x += e.offset.first;
    y += e.offset.second;
    if (e.glide_ms > 0.0) {
      gliding_ = true;
      glide_from_x_ = state_.mouse_x < 0 ? x : state_.mouse_x;
      glide_from_y_ = state_.mouse_y < 0 ? y : state_.mouse_y;
      glide_to_x_ = x;
      glide_to_y_ = y;
      glide_begin_ = newest_step;
      glide_end_ = newest_step + std::max<std::uint64_t>(1, to_steps(e.glide_ms, dt_s));
    } else {
      state_.mouse_x = x;
      state_.mouse_y = y;
    }
  }
  if (e.press >= 0) state_.buttons[static_cast<std::size_t>(e.press)] = true;
  if (e.release >= 0) state_.buttons[static_cast<std::size_t>(e.release)] = false;
  // UTF-8 to code points (the parser checked the text is valid TOML, so valid UTF-8).
  for (std::size_t i = 0; i < e.text.size();) {
    const auto byte = static_cast<unsigned char>(e.text[i]);
    const int length = byte < 0x80 ? 1 : byte < 0xE0 ? 2 : byte < 0xF0 ? 3 : 4;
    unsigned code = length == 1 ? byte : byte & (0x3Fu >> (length - 1));
    for (int k = 1; k < length && i + static_cast<std::size_t>(k) < e.text.size(); ++k)
      code = code << 6 | (static_cast<unsigned char>(e.text[i + static_cast<std::size_t>(k)]) & 0x3Fu);
    state_.characters.push_back(code);
    i += static_cast<std::size_t>(length);
  }
  if (!e.key.empty()) {
    const Key k = key_from_name(e.key);
    state_.pressed.push_back(k);
    state_.keys[static_cast<std::size_t>(k)] = true;
  }
  state_.wheel = e.wheel;
  return state_;
}

}  // namespace ffd::ui
