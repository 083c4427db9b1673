#pragma once
// A fixed pool of worker threads for the step (Jolt's JobSystemThreadPool and Box2D's task
// callbacks are the models). The threads are created with the pool, before the first step,
// and never inside one. Inside a step the workers spin; between steps they sleep until the
// next release time the physics loop announces (no system call ever wakes them: a futex wake
// costs tens of microseconds on a virtual machine), or nap in short slices when none is announced.
//
// Determinism: parallel_for(chunks, fn) runs fn(chunk) once for every chunk index, on
// whichever thread claims it first. The caller cuts the work into chunks that do not depend
// on the thread count and whose results do not depend on which thread runs them or in which
// order (chunks write disjoint data, or only commutative integer counters), so a step gives
// bit-identical results with 1, 2 or 8 threads. A thread that is asleep or late simply claims
// nothing: the calling thread can do every chunk itself.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <thread>
#include <type_traits>
#include <vector>

namespace ffd {

class WorkerPool {
 public:
  // `threads`: the calling thread included, so 1 means no worker at all. `on_worker_start` /
  // `on_worker_stop` run on each worker thread as it starts and ends (tests count allocations).
  explicit WorkerPool(int threads, std::function<void()> on_worker_start = {},
                      std::function<void()> on_worker_stop = {});
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  int threads() const { return static_cast<int>(workers_.size()) + 1; }

  // fn(chunk, thread) for every chunk in [0, chunks), spread over the calling thread (thread 0)
  // and the workers (1 ..); returns when every chunk is done. `thread` only picks per-thread
  // scratch space; results must not depend on it. Not re-entrant: fn must not call it.
  template <class Fn>
  void parallel_for(std::uint32_t chunks, Fn&& fn) {
    if (chunks == 0) return;
    if (workers_.empty() || chunks == 1) {
      for (std::uint32_t c = 0; c < chunks; ++c) fn(c, 0u);
      return;
    }
    auto call = [](void* context, std::uint32_t chunk, std::uint32_t thread) {
      (*static_cast<std::remove_reference_t<Fn>*>(context))(chunk, thread);
    };
    run(chunks, call, const_cast<void*>(static_cast<const void*>(&fn)));
  }

  // The step brackets: inside a step the workers spin between jobs; after end_step they sleep
  // until `next_wake_ns` (CLOCK_MONOTONIC, absolute: the next release minus the loop's spin
  // time), or, with 0 (fast mode, tools), keep spinning for a while and then nap in 100 us
  // slices until the next job.
  void begin_step();
  void end_step(std::int64_t next_wake_ns);

  // SCHED_FIFO at `priority` for every worker (the physics thread's, in real-time mode).
  // Returns false where that is not permitted (the workers keep their policy).
  bool set_realtime_priority(int priority);

 private:
  using ChunkFn = void (*)(void*, std::uint32_t, std::uint32_t);
  void run(std::uint32_t chunks, ChunkFn fn, void* context);
  void work(std::uint32_t thread);
  bool claim_and_run(std::uint32_t job, std::uint32_t thread);

  // The job being run. A claim is a compare-and-swap on `cursor_` (job id in the high 32
  // bits, next chunk in the low 32): a worker that wakes after its job is over fails the
  // claim and never touches the next job's chunks. run() closes the cursor before it writes
  // the next job's fields and opens it after.
  std::atomic<std::uint32_t> job_{0};
  std::atomic<std::uint64_t> cursor_{0};
  std::atomic<std::uint32_t> done_{0};
  std::atomic<ChunkFn> fn_{nullptr};
  std::atomic<void*> context_{nullptr};
  std::atomic<std::uint32_t> chunks_{0};

  std::atomic<bool> quit_{false};
  std::atomic<bool> in_step_{false};
  std::atomic<std::int64_t> wake_at_ns_{0};
  std::function<void()> on_worker_start_, on_worker_stop_;
  std::vector<std::thread> workers_;
};

// pool->parallel_for(chunks, fn), or every chunk on this thread where there is no pool (a
// Scratch without attach_pool()).
template <class Fn>
void parallel_for(WorkerPool* pool, std::uint32_t chunks, Fn&& fn) {
  if (pool) {
    pool->parallel_for(chunks, fn);
    return;
  }
  for (std::uint32_t c = 0; c < chunks; ++c) fn(c, 0u);
}

// One step of a spin-wait inside a step: a PAUSE, and after every few thousand a yield of
// the core, so that more threads than cores (8 threads on 2 cores, the tests) still progress.
void spin_wait(int& spins);

// Threads a tool uses when the user does not say: two where the machine has two cores or
// more (the product's target is a 2-core machine), else one.
int default_thread_count();

}  // namespace ffd
