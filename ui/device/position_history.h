#pragma once
// The newest timed positions of what drives the probe (a haptic device, the mouse), and the
// position at any time between them. The physics thread reads it at its own step times, so
// that samples arriving at their own pace (a device at 1 kHz with jitter, the mouse at the
// UI's 15-50 ms) move the probe smoothly instead of in jumps. Fixed size, no allocation.
#include <array>
#include <cstdint>

#include "ffd/types.h"

namespace ffd::device {

struct TimedPosition {
  std::int64_t time_ns = 0;      // when the source took it, on the source's own clock
  std::int64_t received_ns = 0;  // when it arrived, on this machine's CLOCK_MONOTONIC
  Vec3 position = Vec3::Zero();  // m
};

class PositionHistory {
 public:
  static constexpr int kCapacity = 16;

  // Adds a sample newer than the others; the oldest leaves when full.
  void add(const TimedPosition& p) {
    if (count_ == kCapacity) {
      for (int i = 1; i < kCapacity; ++i) samples_[static_cast<std::size_t>(i - 1)] = samples_[static_cast<std::size_t>(i)];
      --count_;
    }
    samples_[static_cast<std::size_t>(count_++)] = p;
  }
  bool empty() const { return count_ == 0; }
  const TimedPosition& newest() const { return samples_[static_cast<std::size_t>(count_ - 1)]; }

  // The source's clock onto this one: received minus taken is the offset plus the sample's
  // delivery delay, never less, so the quickest sample gives it best.
  std::int64_t clock_offset_ns() const {
    std::int64_t offset = INT64_MAX;
    for (int i = 0; i < count_; ++i) offset = std::min(offset, at_index(i).received_ns - at_index(i).time_ns);
    return offset;
  }

  // Mean spacing of the samples, ns (0 with fewer than two).
  double mean_interval_ns() const {
    if (count_ < 2) return 0.0;
    return static_cast<double>(newest().time_ns - at_index(0).time_ns) / static_cast<double>(count_ - 1);
  }

  // The position at `time_ns` on the source's clock: linear between the two samples around
  // it, the nearest end outside them (never extrapolated). Needs a sample.
  Vec3 at(double time_ns) const {
    if (time_ns >= static_cast<double>(newest().time_ns)) return newest().position;
    for (int i = count_ - 1; i > 0; --i) {
      const double t0 = static_cast<double>(at_index(i - 1).time_ns), t1 = static_cast<double>(at_index(i).time_ns);
      if (time_ns >= t0 && t1 > t0) {
        const double u = (time_ns - t0) / (t1 - t0);
        return (1.0 - u) * at_index(i - 1).position + u * at_index(i).position;
      }
    }
    return at_index(0).position;
  }

 private:
  const TimedPosition& at_index(int i) const { return samples_[static_cast<std::size_t>(i)]; }
  std::array<TimedPosition, kCapacity> samples_{};
  int count_ = 0;
};

}  // namespace ffd::device
