#include "ffd/accuracy_governor.h"

#include <algorithm>

namespace ffd {

void AccuracyGovernor::start(Accuracy level) {
  floor_ = level;
  clock_ = 0;
  hold_steps_.fill(0);
  retry_at_.fill(0);
  new_window(level);
}

void AccuracyGovernor::new_window(Accuracy level) {
  current_ = level;
  window_steps_ = window_overruns_ = window_spikes_ = 0;
}

Accuracy AccuracyGovernor::observe(Accuracy level, std::int64_t compute_ns, std::int64_t budget_ns) {
  ++clock_;
  if (level != current_) new_window(level);  // switched by a command or a Reset: judge it afresh
  const double budget = static_cast<double>(budget_ns);
  const double compute = static_cast<double>(compute_ns);
  ++window_steps_;
  window_overruns_ += compute > settings_.over_fraction * budget;
  window_spikes_ += compute > settings_.under_fraction * budget;

  const int l = static_cast<int>(level);
  if (window_overruns_ >= settings_.overruns_to_step_down && level > floor_) {
    // Too slow: one level down now, and this level waits before it is tried again.
    std::uint32_t& hold = hold_steps_[static_cast<std::size_t>(l)];
    hold = hold == 0 ? settings_.first_hold_steps : std::min(2 * hold, settings_.max_hold_steps);
    retry_at_[static_cast<std::size_t>(l)] = clock_ + hold;
    const auto lower = static_cast<Accuracy>(l - 1);
    new_window(lower);
    return lower;
  }
  if (window_steps_ < settings_.window_steps) return level;
  const bool room = window_spikes_ <= settings_.spikes_allowed;
  new_window(level);
  if (room && l + 1 < kAccuracyLevels && clock_ >= retry_at_[static_cast<std::size_t>(l + 1)]) {
    const auto higher = static_cast<Accuracy>(l + 1);
    new_window(higher);
    return higher;
  }
  return level;
}

}  // namespace ffd
