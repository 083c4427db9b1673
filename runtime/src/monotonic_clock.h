#pragma once
// CLOCK_MONOTONIC in nanoseconds, and an absolute sleep on it: the physics loop's and the
// worker pool's clock (absolute deadlines, so errors never accumulate).
#include <time.h>

#include <cstdint>

namespace ffd {

inline std::int64_t monotonic_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Sleeps until `deadline_ns`; returns early only on a signal (the caller loops if it must).
inline void sleep_until_ns(std::int64_t deadline_ns) {
  const timespec ts{static_cast<time_t>(deadline_ns / 1'000'000'000), static_cast<long>(deadline_ns % 1'000'000'000)};
  clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
}

}  // namespace ffd
