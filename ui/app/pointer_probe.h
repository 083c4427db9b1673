#pragma once
// The mouse on the probe. The viewer's cursor positions arrive at the UI's frame rate (15-50
// ms apart); sent as they come, each would jump the probe's device target by millimetres in
// one step and kick the coupling force. Instead they go, timed, through a lock-free queue to
// the physics thread, which interpolates them at each step's time less one frame interval,
// so the target moves smoothly between them (the device link does the same with a device's
// samples). The interpolated position becomes a recorded ProbePose command like the rest.
#include <algorithm>
#include <chrono>
#include <cmath>

#include <readerwriterqueue/readerwriterqueue.h>

#include "device/position_history.h"
#include "ffd/physics_loop.h"

namespace ffd::ui {

class PointerProbe final : public ProbeSource {
 public:
  // UI thread: the cursor's probe target now. Returns false if the queue is full (the physics
  // thread fell 256 moves behind; the next move carries on from where it is).
  bool move(const Vec3& target) {
    const std::int64_t now =
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
    return queue_.try_enqueue({now, now, target});
  }

  // Physics thread.
  bool device_position(std::uint64_t, std::int64_t release_ns, const Vec3&, Vec3& position) override {
    device::TimedPosition p;
    while (queue_.try_dequeue(p)) history_.add(p);
    if (history_.empty()) return false;
    // One frame interval behind (1-100 ms): the step's time then lies between two moves.
    const double delay = std::clamp(history_.mean_interval_ns(), 1e6, 1e8);
    position = history_.at(static_cast<double>(release_ns) - delay);
    if (position == last_) return false;  // still: no command
    last_ = position;
    return true;
  }
  void rendered_force(std::uint64_t, std::int64_t, const Vec3&) override {}

 private:
  moodycamel::ReaderWriterQueue<device::TimedPosition> queue_{256};
  device::PositionHistory history_;
  Vec3 last_ = Vec3::Constant(NAN);
};

}  // namespace ffd::ui
