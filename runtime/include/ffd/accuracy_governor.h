#pragma once
// Budget-aware accuracy: the most accurate collision level (spec.h, Accuracy) whose steps
// fit the physics loop's latency budget, chosen from each step's measured compute time.
//
// Hysteresis keeps it from flapping: it steps down one level at once when a window sees a
// few steps over `over_fraction` of the budget, steps up one level only after a whole
// window with (nearly) every step under `under_fraction`, and a level that proved too slow
// is not tried again for a hold time that doubles each time it fails again.
//
// The governor is a pure function of the timings it is shown; the loop turns each decision
// into a SetAccuracy command on the command stream, so a recording replays the switches at
// the same steps without the governor, bit for bit.
#include <array>
#include <cstdint>

#include "ffd/spec.h"

namespace ffd {

struct AccuracyGovernorSettings {
  std::uint32_t window_steps = 250;   // steps per decision window
  double over_fraction = 0.8;         // a step over this fraction of the budget is an overrun
  std::uint32_t overruns_to_step_down = 3;  // overruns within one window
  double under_fraction = 0.4;        // a window may step up when its steps stay under this fraction
  std::uint32_t spikes_allowed = 2;   // steps of a window allowed above under_fraction (preemption)
  std::uint32_t first_hold_steps = 2'000;  // a level that was too slow waits this long to be tried again,
  std::uint32_t max_hold_steps = 64'000;   // doubling each time it fails again, up to this
};

class AccuracyGovernor {
 public:
  explicit AccuracyGovernor(AccuracyGovernorSettings settings = {}) : settings_(settings) {}

  // Starts (or restarts) governing from `level`, which is also the lowest level it will
  // choose; forgets every hold.
  void start(Accuracy level);

  // One step ran at `level` (whatever chose it) and took `compute_ns` against a budget of
  // `budget_ns`. Returns the level the next step should run at: `level` when nothing changes.
  Accuracy observe(Accuracy level, std::int64_t compute_ns, std::int64_t budget_ns);

 private:
  void new_window(Accuracy level);

  AccuracyGovernorSettings settings_;
  Accuracy floor_ = Accuracy::CentreOfMass;
  Accuracy current_ = Accuracy::CentreOfMass;
  std::uint64_t clock_ = 0;  // steps observed since start()
  std::uint32_t window_steps_ = 0, window_overruns_ = 0, window_spikes_ = 0;
  std::array<std::uint32_t, kAccuracyLevels> hold_steps_{};  // 0: never failed
  std::array<std::uint64_t, kAccuracyLevels> retry_at_{};    // clock_ from which the level may be tried
};

}  // namespace ffd
