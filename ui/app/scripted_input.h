#pragma once
// Turns a UI input script (replay/ui_script.h) into the per-frame InputState a person would
// produce: the cursor glides, buttons go down and up, keys are pressed, the wheel turns.
// Events are applied when the newest physics frame reaches their time, one button or key
// change per UI frame so that ImGui sees every transition.
#include <cstdint>

#include "app/input.h"
#include "app/viewer.h"
#include "ffd/ui_script.h"

namespace ffd::ui {

class ScriptedInput {
 public:
  explicit ScriptedInput(UiScript script) : script_(std::move(script)) {}
  // Input for the next frame. Throws ffd::InputError naming the script line when an event
  // names an object or widget the viewer does not have.
  InputState next(const Viewer& viewer, std::uint64_t newest_step, double dt_s, int width, int height);
  // The run has reached the script's duration and every input has been given. (On a slow
  // machine the UI may reach an input after its time: it is then given late, not skipped.)
  bool finished(std::uint64_t newest_step, double dt_s) const;
  std::size_t events_done() const { return next_event_; }
  const UiScript& script() const { return script_; }

 private:
  UiScript script_;
  std::size_t next_event_ = 0;
  InputState state_;
  bool gliding_ = false;
  float glide_from_x_ = 0, glide_from_y_ = 0, glide_to_x_ = 0, glide_to_y_ = 0;
  std::uint64_t glide_begin_ = 0, glide_end_ = 0;
};

Key key_from_name(const std::string& name);

}  // namespace ffd::ui
