// The worker pool (runtime/src/worker_pool.cpp): every chunk of every job runs exactly once,
// and the pool returns, however the jobs follow each other. A step runs a few dozen jobs back
// to back with different chunk counts; millions of them meet the races a simulation of hours
// meets.
#include <catch2/catch.hpp>

#include "ffd/worker_pool.h"

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>

using namespace ffd;

namespace {

// A watchdog for a test whose failure is a hang: aborts the process with `what` unless
// disarmed within `limit`.
class HangWatchdog {
 public:
  HangWatchdog(std::chrono::seconds limit, const char* what)
      : thread_([this, limit, what] {
          const auto until = std::chrono::steady_clock::now() + limit;
          while (!disarmed_.load()) {
            if (std::chrono::steady_clock::now() > until) {
              std::fprintf(stderr, "hang: %s\n", what);
              std::abort();
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
          }
        }) {}
  ~HangWatchdog() {
    disarmed_.store(true);
    thread_.join();
  }

 private:
  std::atomic<bool> disarmed_{false};
  std::thread thread_;
};

}  // namespace

TEST_CASE("back-to-back jobs of changing sizes run every chunk exactly once and return") {
  const int threads = GENERATE(2, 3);
  WorkerPool pool(threads);
  constexpr std::uint32_t kMaxChunks = 6;
  std::array<std::atomic<int>, kMaxChunks + 1> runs{};  // the last one counts chunks out of range
  std::atomic<int> wrong_thread{0};
  std::uint64_t jobs = 0, miscounted = 0;
  // A job that ends and the next one that starts with more chunks is where a worker that read
  // the finished job's cursor could claim a chunk past its end (the bug: one job in millions,
  // after which the step waited for ever). Long enough for millions of jobs in Release.
  const HangWatchdog watchdog(std::chrono::seconds(60), "a parallel_for never returned");
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(1500);
  pool.begin_step();
  while (std::chrono::steady_clock::now() < until) {
    for (int batch = 0; batch < 256; ++batch, ++jobs) {
      const std::uint32_t chunks = 2 + static_cast<std::uint32_t>(jobs % (kMaxChunks - 1));
      for (std::atomic<int>& r : runs) r.store(0, std::memory_order_relaxed);
      pool.parallel_for(chunks, [&](std::uint32_t chunk, std::uint32_t thread) {
        runs[std::min(chunk, kMaxChunks)].fetch_add(1, std::memory_order_relaxed);
        if (thread >= static_cast<std::uint32_t>(threads)) wrong_thread.fetch_add(1, std::memory_order_relaxed);
      });
      for (std::uint32_t c = 0; c <= kMaxChunks; ++c)
        if (runs[c].load(std::memory_order_relaxed) != (c < chunks ? 1 : 0)) ++miscounted;
    }
  }
  pool.end_step(0);
  INFO(jobs << " jobs on " << threads << " threads");
  CHECK(miscounted == 0);
  CHECK(wrong_thread.load() == 0);
  CHECK(jobs > 1000);
}
