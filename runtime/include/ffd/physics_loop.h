#pragma once
// The physics thread: one deterministic step per period against absolute deadlines, fed by
// a lock-free command queue and publishing without ever waiting on a reader.
//
//   producers (UI, replay, device) --Command--> [moodycamel::ConcurrentQueue] --> loop
//   loop --Frame--> [newest-frame mailbox: 3 recycled buffers]              --> UI (lossy)
//   loop --Telemetry--> [moodycamel::ReaderWriterQueue, preallocated]       --> recorder/checks (lossless)
//   loop --applied Command--> [ReaderWriterQueue]                           --> recorder (lossless)
//   loop --Snapshot--> [ReaderWriterQueue + recycled pool]                  --> surface measurements
//
// Inside the loop nothing allocates, locks, logs or does I/O; every buffer is made by the
// constructor. The step index is the only clock the physics sees: a run is a pure function
// of (scene, command stream) whether the loop paces in real time or runs as fast as it can.
// Policies (overrun re-phasing, back-pressure in fast mode) are described in
// docs/realtime.md, "The physics loop".
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "ffd/accuracy_governor.h"
#include "ffd/command.h"
#include "ffd/model.h"
#include "ffd/state.h"
#include "ffd/step.h"

namespace ffd {

enum class Pacing : std::uint8_t {
  RealTime,  // one step per period against absolute deadlines; never waits on a consumer
  Fast,      // steps back to back; waits for the lossless consumers instead of dropping
};

// A live source of the probe's device position polled by the physics thread every step (a
// haptic device link, docs/realtime.md, "Haptic devices"). Both calls run on the physics thread and must
// neither allocate, lock, block nor do I/O: they exchange data with their own threads through
// lock-free queues. The position device_position() gives becomes a ProbePose command stamped
// with the step, applied and recorded like any other, so a recording replays the session
// without the source.
class ProbeSource {
 public:
  virtual ~ProbeSource() = default;
  // Before step `step` (released at `release_ns`, CLOCK_MONOTONIC): true and the device
  // position to apply (m), or false to leave the probe's device target where it is.
  // `current` is the probe's device target now (where a link that starts or resumes eases from).
  virtual bool device_position(std::uint64_t step, std::int64_t release_ns, const Vec3& current, Vec3& position) = 0;
  // After the step: the probe's coupling force (N) the step rendered, to send to the device.
  virtual void rendered_force(std::uint64_t step, std::int64_t release_ns, const Vec3& force) = 0;
};

struct LoopOptions {
  Pacing pacing = Pacing::RealTime;
  std::int64_t period_ns = 1'000'000;  // 1 kHz
  std::int64_t budget_ns = 1'000'000;  // a step must end within this of its release time
  std::int64_t spin_ns = 20'000;       // busy-wait this long before each release (sleep wake-up is coarse)
  bool realtime_priority = true;       // try SCHED_FIFO for the thread (quietly skipped if not permitted)
  bool lock_memory = true;             // try mlockall at start() (quietly skipped if not permitted)
  std::uint64_t stop_at_step = ~std::uint64_t{0};  // end the loop once State::step reaches this
  std::uint32_t hash_every = 100;      // state hash into the telemetry every N steps (0: never)
  std::uint32_t energy_every = 10;     // total energy into the telemetry every N steps (0: never)
  std::uint32_t frame_every = 1;       // fill a frame every N steps (0: no frames)
  bool frame_boxes = true;             // frames carry the FFD AABBs (0.3 MB a frame for the teapots)
  std::uint32_t snapshot_every = 0;    // lattice snapshot every N steps (0: none)
  std::size_t telemetry_capacity = 1 << 14;  // records: 16 s of stalled reader at 1 kHz
  std::size_t command_capacity = 1 << 12;    // commands held for future steps
  std::size_t snapshot_pool = 64;
  // Budget-aware accuracy (accuracy_governor.h) from the start; the AutoAccuracy command
  // turns it on and off while the loop runs. Its switches go out on the applied stream.
  bool auto_accuracy = false;
  AccuracyGovernorSettings governor;
  // Threads a step is spread over, the physics thread included (worker_pool.h). The workers
  // are created with the loop, before its first step; in real time they run at the physics
  // thread's priority and sleep until the same release time between steps. The results are
  // bit-identical whatever the count.
  int threads = 1;
  // Called on the physics thread just before the first tick and after the last one, and on
  // each worker thread as it starts and ends (for naming or pinning the threads, and for
  // tests that count what the loop does).
  std::function<void()> on_thread_start, on_thread_stop;
  // A device link driving the probe (nullptr: none). Not owned; it must outlive the loop.
  ProbeSource* probe_source = nullptr;
};

// One record per step, lossless: what the recorder and the replay assertions read.
struct Telemetry {
  std::uint64_t step = 0;         // State::step after this step (= steps taken so far)
  std::int64_t lateness_ns = 0;   // wake-up minus release time (0 in fast mode)
  std::int64_t compute_ns = 0;    // commands + step + publication
  bool deadline_met = true;       // lateness + compute <= budget (always true in fast mode)
  bool finite = true;
  bool has_hash = false;
  bool has_energy = false;
  std::uint64_t state_hash = 0;   // of the State after this step, when has_hash
  double energy_j = 0.0;          // kinetic + gravitational + elastic, when has_energy
  double max_speed_m_s = 0.0;     // fastest lattice node
  double rms_speed_m_s = 0.0;     // root mean square of the lattice nodes' speeds
  double kinetic_energy_j = 0.0;  // of the lattice nodes
  double max_penetration_m = 0.0; // deepest node-in-box / below-plane / probe depth found this step
  Vec3 probe_position = Vec3::Zero();  // m
  Vec3 probe_force_n = Vec3::Zero();   // force output on the device
  Vec3 grab_force_n = Vec3::Zero();
  std::uint32_t contacts = 0;          // inter + self + plane + probe contacts answered
  std::uint32_t commands_applied = 0;
  Accuracy accuracy = Accuracy::CentreOfMass;  // the level this step ran at
  std::array<std::int64_t, kStageCount> stage_ns{};
};

// The newest state for display: lossy, at most one step old when frame_every = 1.
struct Frame {
  std::uint64_t step = 0;
  std::vector<Vec3> nodes;                 // (N) lattice node positions, m
  std::vector<std::array<Vec3, 9>> boxes;  // (B) FFD AABB: 8 corners, then centre of mass, m (LoopOptions::frame_boxes)
  std::vector<std::uint8_t> asleep;        // (O) 1 for an object asleep (the "sleeping" effect)
  std::vector<Contact> contacts;           // [0, contact_count) hold this step's contacts
  std::uint32_t contact_count = 0;
  ProbeState probe;
  GrabState grab;
  double alpha = 0.0, beta = 0.0;
  Vec3 gravity = Vec3::Zero();
  Accuracy accuracy = Accuracy::CentreOfMass;
  ContactResponse response = ContactResponse::Paper;  // how this step answered its contacts
  bool auto_accuracy = false;  // the governor chooses the level
  StepReport report;
  bool paused = false;
};

// Lattice positions at a requested step, lossless, for measurements that need the surfaces
// (which the 1 kHz thread never touches).
struct Snapshot {
  std::uint64_t step = 0;
  std::vector<Vec3> x;
};

// Counters of the whole run, readable at any time.
struct LoopCounters {
  std::uint64_t steps = 0;
  std::uint64_t deadline_misses = 0;
  std::uint64_t overruns = 0;             // steps that ended after the next release: re-phased
  std::uint64_t telemetry_dropped = 0;    // real time only: the reader fell 16 s behind
  std::uint64_t snapshots_dropped = 0;    // real time only
  std::uint64_t commands_rejected = 0;    // malformed for this model (command_is_valid)
  std::uint64_t commands_late = 0;        // arrived after their step had run: applied at once
  std::uint64_t commands_unrecorded = 0;  // real time only: applied, but the recorder fell behind
  std::uint64_t frames_published = 0;
  std::uint64_t accuracy_switches = 0;    // made by the budget-aware governor
  bool realtime_priority = false;         // SCHED_FIFO was granted (to the workers too)
  int threads = 1;                        // the physics thread and its workers
  bool memory_locked = false;             // mlockall succeeded
};

class PhysicsLoop {
 public:
  PhysicsLoop(const Model& model, State initial, LoopOptions options);
  ~PhysicsLoop();  // stops and joins
  PhysicsLoop(const PhysicsLoop&) = delete;
  PhysicsLoop& operator=(const PhysicsLoop&) = delete;

  void start();
  void request_stop();                       // any thread; the loop ends at its next tick
  void join();
  bool finished() const;                     // the loop has ended (stop_at_step or request_stop)

  // Producers (any thread). Returns false if the queue could not take it (out of memory).
  bool push(const Command& command);

  // Lossless consumers: one reader each.
  bool pop_telemetry(Telemetry& out);
  bool pop_applied_command(Command& out);    // state and loop commands, with the step they applied at
  Snapshot* pop_snapshot();                  // nullptr when none; give it back with recycle()
  void recycle(Snapshot* snapshot);

  // Lossy consumer (one reader): the newest frame published so far (nullptr before the
  // first). It stays valid and unchanged until the next call.
  const Frame* latest_frame();

  LoopCounters counters() const;
  // The State after the loop ended (valid after join()).
  const State& state() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Latest-value mailbox over three buffers (a triple buffer): the writer never waits and the
// reader always gets the newest complete buffer. Lock-free: one atomic exchange per side.
template <class T>
class NewestMailbox {
 public:
  explicit NewestMailbox(const T& prototype) : buffers_{prototype, prototype, prototype} {}
  T& back() { return buffers_[back_]; }  // writer: fill this, then publish()
  void publish() { back_ = middle_.exchange(back_ | kFresh, std::memory_order_acq_rel) & kIndex; }
  // Reader: the newest published buffer, or nullptr if nothing new since the last call.
  const T* take() {
    if (!(middle_.load(std::memory_order_relaxed) & kFresh)) return nullptr;
    front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndex;
    return &buffers_[front_];
  }
  const T& front() const { return buffers_[front_]; }

 private:
  static constexpr unsigned kFresh = 4, kIndex = 3;
  std::array<T, 3> buffers_;
  unsigned back_ = 0, front_ = 1;
  std::atomic<unsigned> middle_{2};
};

}  // namespace ffd
