#include "ffd/worker_pool.h"

#include "monotonic_clock.h"

#include <pthread.h>
#include <sched.h>

namespace ffd {

namespace {

// A spin-wait hint to the core (x86 PAUSE): lets the sibling thread run and saves power.
inline void relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#endif
}

// Spins before a worker outside a step naps: fast-mode steps follow each other within
// microseconds, and a nap would make the next step start without it.
constexpr std::int64_t kIdleSpinNs = 2'000'000;
constexpr std::int64_t kNapNs = 100'000;
// Inside a step: how long a worker waits for the next parallel part before it naps, and the
// nap. Longer than any sequential part of a step that fits the 1 ms budget (a worker that naps
// misses the parts that start meanwhile, and the stepping thread does them alone), shorter
// than the sequential responses of a large pile (milliseconds), where a spinning worker
// would hold a core the viewer's renderer needs
// (docs/notes/2026-11-28-code-findings.md#worker-spin).
constexpr std::int64_t kStepSpinNs = 300'000;
constexpr std::int64_t kStepNapNs = 100'000;
// Inside a step a worker spins on PAUSE; after this many it also yields the core, so that
// more threads than cores (8 threads on 2 cores, the determinism tests) still make progress.
constexpr int kSpinsBeforeYield = 2048;
// The chunk index of a closed cursor: past any job's chunk count.
constexpr std::uint64_t kClosed = 0xffff'ffff;

}  // namespace

void spin_wait(int& spins) {
  relax();
  if (++spins == kSpinsBeforeYield) {
    spins = 0;
    std::this_thread::yield();
  }
}

int default_thread_count() { return std::thread::hardware_concurrency() >= 2 ? 2 : 1; }

WorkerPool::WorkerPool(int threads, std::function<void()> on_worker_start, std::function<void()> on_worker_stop)
    : on_worker_start_(std::move(on_worker_start)), on_worker_stop_(std::move(on_worker_stop)) {
  const int workers = threads > 1 ? threads - 1 : 0;
  workers_.reserve(static_cast<std::size_t>(workers));
  for (int i = 0; i < workers; ++i) workers_.emplace_back([this, i] { work(static_cast<std::uint32_t>(i + 1)); });
}

WorkerPool::~WorkerPool() {
  quit_.store(true, std::memory_order_release);
  for (std::thread& t : workers_) t.join();
}

void WorkerPool::begin_step() {
  wake_at_ns_.store(0, std::memory_order_relaxed);
  in_step_.store(true, std::memory_order_release);
}

void WorkerPool::end_step(std::int64_t next_wake_ns) {
  wake_at_ns_.store(next_wake_ns, std::memory_order_relaxed);
  in_step_.store(false, std::memory_order_release);
}

bool WorkerPool::set_realtime_priority(int priority) {
  bool all = true;
  sched_param param{};
  param.sched_priority = priority;
  for (std::thread& t : workers_) all = pthread_setschedparam(t.native_handle(), SCHED_FIFO, &param) == 0 && all;
  return all;
}

bool WorkerPool::claim_and_run(std::uint32_t job, std::uint32_t thread) {
  std::uint64_t cursor = cursor_.load(std::memory_order_acquire);
  for (;;) {
    if (static_cast<std::uint32_t>(cursor >> 32) != job) return false;
    const std::uint32_t chunk = static_cast<std::uint32_t>(cursor);
    // chunks_ may already be the next job's (run() writes it before it opens that job's
    // cursor); then the cursor was closed before it (acquire / release), and the claim below
    // fails. A claim that succeeds was made on an open cursor of `job`, whose fields are the
    // ones written before it was opened.
    if (chunk >= chunks_.load(std::memory_order_acquire)) return false;
    if (cursor_.compare_exchange_weak(cursor, cursor + 1, std::memory_order_acquire, std::memory_order_acquire)) {
      fn_.load(std::memory_order_relaxed)(context_.load(std::memory_order_relaxed), chunk, thread);
      done_.fetch_add(1, std::memory_order_release);
      return true;
    }
  }
}

void WorkerPool::run(std::uint32_t chunks, ChunkFn fn, void* context) {
  const std::uint32_t job = job_.load(std::memory_order_relaxed) + 1;
  // Close the last job's cursor before its fields change: a worker that read that cursor at
  // its end (every chunk claimed) and then reads the new, larger chunk count must fail its
  // claim, or it would run a chunk past the end and count it in the new job's done_ (which
  // then never equals `chunks`: the step hung).
  cursor_.store((static_cast<std::uint64_t>(job) << 32) | kClosed, std::memory_order_relaxed);
  fn_.store(fn, std::memory_order_relaxed);
  context_.store(context, std::memory_order_relaxed);
  done_.store(0, std::memory_order_relaxed);
  chunks_.store(chunks, std::memory_order_release);
  cursor_.store(static_cast<std::uint64_t>(job) << 32, std::memory_order_release);
  job_.store(job, std::memory_order_release);
  while (claim_and_run(job, 0)) {
  }
  int spins = 0;
  while (done_.load(std::memory_order_acquire) != chunks) spin_wait(spins);
}

void WorkerPool::work(std::uint32_t thread) {
  if (on_worker_start_) on_worker_start_();
  std::uint32_t seen = job_.load(std::memory_order_acquire);
  // Idle time is counted from the last job or from the last change between "in a step" and
  // "between steps", whichever is later: a worker that slept until the release time and
  // then spun must not count that wait against the step it starts.
  bool stepping = false;
  std::int64_t idle_since = monotonic_ns();
  int spins = 0;
  while (!quit_.load(std::memory_order_acquire)) {
    const std::uint32_t job = job_.load(std::memory_order_acquire);
    if (job != seen) {
      seen = job;
      while (claim_and_run(job, thread)) {
      }
      idle_since = monotonic_ns();
      continue;
    }
    const bool in_step = in_step_.load(std::memory_order_acquire);
    const std::int64_t now = monotonic_ns();
    if (in_step != stepping) {
      stepping = in_step;
      idle_since = now;
    }
    if (in_step) {
      // Between two parallel parts of a step (the narrow phase's responses run on the stepping
      // thread alone): spin, and nap only when the wait is long, so that a worker at the
      // physics thread's real-time priority does not hold a core the viewer's renderer needs.
      // A part that starts while it naps is taken by the stepping thread; no one wakes it.
      if (now - idle_since < kStepSpinNs) {
        spin_wait(spins);
        continue;
      }
      sleep_until_ns(now + kStepNapNs);
      continue;
    }
    // Between steps.
    const std::int64_t wake_at = wake_at_ns_.load(std::memory_order_relaxed);
    if (wake_at > now) {
      sleep_until_ns(wake_at);  // real time: up again just before the next release
      idle_since = monotonic_ns();
      continue;
    }
    if (now - idle_since < kIdleSpinNs) {
      spin_wait(spins);
      continue;
    }
    sleep_until_ns(now + kNapNs);
  }
  if (on_worker_stop_) on_worker_stop_();
}

}  // namespace ffd
