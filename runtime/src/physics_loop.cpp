// The physics thread. Everything the loop body touches is allocated by the constructor;
// the body only copies into it (see physics_loop.h for the data flow).
#include "ffd/physics_loop.h"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>

#include <algorithm>
#include <thread>

#include <concurrentqueue/concurrentqueue.h>
#include <readerwriterqueue/readerwriterqueue.h>

#include "step_memory.h"
#include "ffd/measure.h"
#include "ffd/trilinear.h"
#include "ffd/worker_pool.h"
#include "monotonic_clock.h"

namespace ffd {

namespace {

// Sleeps until `deadline_ns` on CLOCK_MONOTONIC (absolute, so errors never accumulate),
// waking `spin_ns` early and spinning the rest: a sleep's wake-up is tens of microseconds
// late on a virtual machine, a spin is not.
void wait_until(std::int64_t deadline_ns, std::int64_t spin_ns) {
  const std::int64_t sleep_until = deadline_ns - spin_ns;
  while (monotonic_ns() < sleep_until) sleep_until_ns(sleep_until);  // a signal: sleep again
  while (monotonic_ns() < deadline_ns) {
  }
}

// The lattice nodes' fastest and RMS speeds (m/s) and kinetic energy (J), in one pass.
void node_motion(const Model& model, const State& state, Telemetry& t) {
  double fastest = 0.0, sum_sq = 0.0, kinetic = 0.0;
  for (std::size_t n = 0; n < state.v.size(); ++n) {
    const double v_sq = state.v[n].squaredNorm();
    fastest = std::max(fastest, v_sq);
    sum_sq += v_sq;
    kinetic += model.node_mass[n] * v_sq;
  }
  t.max_speed_m_s = std::sqrt(fastest);
  t.rms_speed_m_s = state.v.empty() ? 0.0 : std::sqrt(sum_sq / static_cast<double>(state.v.size()));
  t.kinetic_energy_j = 0.5 * kinetic;
}

std::uint32_t total_contacts(const StepReport& report) {
  std::uint32_t n = 0;
  for (const StageCounters& c : report.counters)
    n += c.inter_contacts + c.self_contacts + c.plane_contacts + c.probe_contacts;
  return n;
}

Frame make_frame_prototype(const Model& model) {
  Frame frame;
  frame.nodes.resize(model.node_count());
  frame.boxes.resize(model.box_count());  // left as built when LoopOptions::frame_boxes is off
  frame.asleep.resize(model.objects.size());
  frame.contacts.resize(kContactCapacity);
  return frame;
}

}  // namespace

struct PhysicsLoop::Impl {
  Impl(const Model& m, State initial_state, LoopOptions o)
      : model(m),
        options(std::move(o)),
        initial(initial_state),
        state(std::move(initial_state)),
        scratch(make_scratch(m)),
        pool(std::max(1, options.threads), options.on_thread_start, options.on_thread_stop),
        pending(options.command_capacity),
        commands(options.command_capacity),
        telemetry(options.telemetry_capacity),
        applied(options.command_capacity * 4),
        snapshots_ready(options.snapshot_pool),
        snapshots_free(options.snapshot_pool),
        frames(make_frame_prototype(m)),
        governor(options.governor) {
    attach_pool(model, scratch, pool);
    budget_ns = options.budget_ns;
    auto_accuracy = options.auto_accuracy;
    governor.start(state.params.accuracy);
    snapshot_storage.resize(options.snapshot_pool);
    for (Snapshot& s : snapshot_storage) {
      s.x.resize(model.node_count());
      snapshots_free.enqueue(&s);
    }
  }

  void run();
  void take_commands();
  bool apply_due_commands(bool& step_now, std::uint32_t& applied_count);
  void take_step(std::int64_t release_ns, std::int64_t wake_ns);
  void publish_frame();
  void publish_snapshot();
  void govern_accuracy(std::int64_t compute_ns);
  void take_device_position(std::int64_t release_ns);
  template <class Queue, class T>
  bool push_lossless(Queue& queue, const T& item, std::atomic<std::uint64_t>& dropped);

  const Model& model;
  LoopOptions options;
  const State initial;
  State state;
  Scratch scratch;
  WorkerPool pool;
  StepReport report;
  std::int64_t budget_ns;
  bool paused = false;
  double pause_ticks_left = 0.0;  // 0 with paused: until Resume

  // Commands waiting for their step, in arrival order; [0, pending_count) used.
  std::vector<Command> pending;
  std::size_t pending_count = 0;

  moodycamel::ConcurrentQueue<Command> commands;
  moodycamel::ReaderWriterQueue<Telemetry> telemetry;
  moodycamel::ReaderWriterQueue<Command> applied;
  moodycamel::ReaderWriterQueue<Snapshot*> snapshots_ready, snapshots_free;
  std::vector<Snapshot> snapshot_storage;
  NewestMailbox<Frame> frames;
  bool reader_has_frame = false;
  AccuracyGovernor governor;
  bool auto_accuracy = false;

  std::thread thread;
  std::atomic<bool> stop{false};
  std::atomic<bool> done{false};
  std::atomic<std::uint64_t> steps{0}, misses{0}, overruns{0}, telemetry_dropped{0}, snapshots_dropped{0},
      rejected{0}, late{0}, frames_published{0}, applied_dropped{0}, accuracy_switches{0};
  std::atomic<bool> fifo{false}, locked{false};
};

void PhysicsLoop::Impl::take_commands() {
  while (pending_count < pending.size() && commands.try_dequeue(pending[pending_count])) ++pending_count;
}

// Applies, in arrival order, every pending command whose step has come. Returns whether the
// loop should take a step this tick; `step_now` is set by SingleStep.
bool PhysicsLoop::Impl::apply_due_commands(bool& step_now, std::uint32_t& applied_count) {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < pending_count; ++i) {
    Command& c = pending[i];
    if (c.step != kNextStep && c.step > state.step) {
      pending[kept++] = c;
      continue;
    }
    if (c.step != kNextStep && c.step < state.step) late.fetch_add(1, std::memory_order_relaxed);
    if (!command_is_valid(model, c)) {
      rejected.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    c.step = state.step;  // what a recording replays
    switch (c.kind) {
      case CommandKind::SetBudget: budget_ns = static_cast<std::int64_t>(c.value * 1000.0); break;
      case CommandKind::Pause:
        paused = true;
        pause_ticks_left = c.value;
        break;
      case CommandKind::Resume: paused = false; break;
      case CommandKind::SingleStep: step_now = true; break;
      case CommandKind::AutoAccuracy:
        auto_accuracy = c.value != 0.0;
        if (auto_accuracy) governor.start(state.params.accuracy);
        ++applied_count;
        continue;  // not recorded: the SetAccuracy commands it makes are
      default: apply_command(model, initial, state, c); break;
    }
    ++applied_count;
    push_lossless(applied, c, applied_dropped);
  }
  pending_count = kept;
  return !paused || step_now;
}

template <class Queue, class T>
bool PhysicsLoop::Impl::push_lossless(Queue& queue, const T& item, std::atomic<std::uint64_t>& dropped) {
  if (queue.try_enqueue(item)) return true;
  if (options.pacing == Pacing::RealTime) {
    dropped.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  // Fast mode has no deadline to keep: wait for the reader (back-pressure).
  while (!queue.try_enqueue(item)) {
    if (stop.load(std::memory_order_relaxed)) return false;
    std::this_thread::yield();
  }
  return true;
}

void PhysicsLoop::Impl::publish_frame() {
  Frame& f = frames.back();
  f.step = state.step;
  std::copy(state.x.begin(), state.x.end(), f.nodes.begin());
  // Frames show the FFD AABBs whatever the accuracy level. Boxes a response left stale are
  // refreshed so the frame shows the step's final lattice.
  if (!options.frame_boxes) {
  } else if (box_level(model, state.params.accuracy).boxes == &model.boxes) {
    BoxMemory& boxes = scratch.memory();
    for (Index b = 0; b < model.box_count(); ++b)
      if (!boxes.box_valid[b]) update_box(model, model.boxes, state, boxes, b);
    std::copy(boxes.box_nodes.begin(), boxes.box_nodes.begin() + model.box_count(), f.boxes.begin());
  } else {
    for (Index b = 0; b < model.box_count(); ++b) {
      const std::array<Index, 8>& corner = model.cell_nodes[model.boxes.box_cell[b]];
      for (int k = 0; k < 9; ++k)
        f.boxes[b][k] = trilinear_map(model.boxes.box_local[b][k], [&](int j) -> const Vec3& { return state.x[corner[j]]; });
    }
  }
  std::copy(state.asleep.begin(), state.asleep.end(), f.asleep.begin());
  const std::span<const Contact> contacts = scratch.contacts();
  f.contact_count = static_cast<std::uint32_t>(contacts.size());
  std::copy(contacts.begin(), contacts.end(), f.contacts.begin());
  f.probe = state.probe;
  f.grab = state.grab;
  f.alpha = state.params.alpha;
  f.beta = state.params.beta;
  f.gravity = state.params.gravity;
  f.accuracy = state.params.accuracy;
  f.response = state.params.response;
  f.auto_accuracy = auto_accuracy;
  f.report = report;
  f.paused = paused;
  frames.publish();
  frames_published.fetch_add(1, std::memory_order_relaxed);
}

void PhysicsLoop::Impl::publish_snapshot() {
  Snapshot* s = nullptr;
  if (!snapshots_free.try_dequeue(s)) {
    if (options.pacing == Pacing::RealTime) {
      snapshots_dropped.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    while (!snapshots_free.try_dequeue(s)) {
      if (stop.load(std::memory_order_relaxed)) return;
      std::this_thread::yield();
    }
  }
  s->step = state.step;
  std::copy(state.x.begin(), state.x.end(), s->x.begin());
  snapshots_ready.enqueue(s);  // never grows: the pool has as many slots as the queue
}

// The governor's decision becomes a SetAccuracy command for the next step, queued behind
// whatever is pending, so it is applied, counted and recorded like any other command.
void PhysicsLoop::Impl::govern_accuracy(std::int64_t compute_ns) {
  const Accuracy level = state.params.accuracy;
  const Accuracy next = governor.observe(level, compute_ns, budget_ns);
  if (next == level || pending_count == pending.size()) return;  // full: the governor sees the level unchanged
  Command& c = pending[pending_count++];
  c = Command{};
  c.step = state.step;
  c.kind = CommandKind::SetAccuracy;
  c.value = static_cast<double>(next);
  accuracy_switches.fetch_add(1, std::memory_order_relaxed);
}

// The device link's position for this step becomes a ProbePose command for this step, queued
// behind whatever is pending: applied, counted and recorded like the UI's (a replay of the
// recording needs no device).
void PhysicsLoop::Impl::take_device_position(std::int64_t release_ns) {
  Vec3 position;
  if (!options.probe_source->device_position(state.step, release_ns, state.probe.device, position)) return;
  if (pending_count == pending.size()) return;  // full: this step keeps the last position
  Command& c = pending[pending_count++];
  c = Command{};
  c.step = state.step;
  c.kind = CommandKind::ProbePose;
  c.vector = position;
}

void PhysicsLoop::Impl::take_step(std::int64_t release_ns, std::int64_t wake_ns) {
  std::uint32_t applied_count = 0;
  bool single = false;
  if (options.probe_source) take_device_position(release_ns);
  if (!apply_due_commands(single, applied_count)) return;  // paused
  step(model, state, scratch, report);
  if (options.probe_source) options.probe_source->rendered_force(state.step, release_ns, state.probe.force);
  Telemetry t;
  t.step = state.step;
  t.finite = report.finite;
  node_motion(model, state, t);
  t.max_penetration_m = report.max_box_penetration_m;
  t.probe_position = state.probe.x;
  t.probe_force_n = state.probe.force;
  t.grab_force_n = state.grab.active ? state.grab.force : Vec3::Zero();
  t.contacts = total_contacts(report);
  t.commands_applied = applied_count;
  t.accuracy = state.params.accuracy;
  t.stage_ns = report.stage_ns;
  if (options.hash_every && state.step % options.hash_every == 0) {
    t.has_hash = true;
    t.state_hash = state_hash(state);
  }
  if (options.energy_every && state.step % options.energy_every == 0) {
    t.has_energy = true;
    t.energy_j = compute_energy(model, state).total();
  }
  if (options.frame_every && state.step % options.frame_every == 0) publish_frame();
  if (options.snapshot_every && state.step % options.snapshot_every == 0) publish_snapshot();
  const std::int64_t end_ns = monotonic_ns();
  if (options.pacing == Pacing::RealTime) {
    t.lateness_ns = wake_ns - release_ns;
    t.deadline_met = end_ns - release_ns <= budget_ns;
  }
  t.compute_ns = end_ns - wake_ns;
  if (!t.deadline_met) misses.fetch_add(1, std::memory_order_relaxed);
  if (auto_accuracy) govern_accuracy(t.compute_ns);
  push_lossless(telemetry, t, telemetry_dropped);
  steps.fetch_add(1, std::memory_order_relaxed);
}

void PhysicsLoop::Impl::run() {
  if (options.realtime_priority && options.pacing == Pacing::RealTime) {
    sched_param param{};
    param.sched_priority = sched_get_priority_max(SCHED_FIFO) - 9;
    fifo.store(pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0 &&
               pool.set_realtime_priority(param.sched_priority));
  }
  if (options.on_thread_start) options.on_thread_start();
  std::int64_t release = monotonic_ns();
  while (!stop.load(std::memory_order_relaxed) && state.step < options.stop_at_step) {
    std::int64_t wake = release;
    if (options.pacing == Pacing::RealTime) {
      wait_until(release, options.spin_ns);
      wake = monotonic_ns();
    } else {
      wake = monotonic_ns();
      release = wake;
    }
    take_commands();
    if (paused && pause_ticks_left > 0.0 && (pause_ticks_left -= 1.0) <= 0.0) paused = false;
    take_step(release, wake);
    if (!report.finite) {
      // Nothing sensible follows a non-finite state (the telemetry says so). In real time
      // hold it until a Reset and Resume; a fast run (a replay) ends here.
      if (options.pacing == Pacing::Fast) break;
      paused = true;
      pause_ticks_left = 0.0;
      report.finite = true;
    }
    // A fast run paused until a Resume that nobody will send can never go on.
    if (options.pacing == Pacing::Fast && paused && pause_ticks_left <= 0.0 && pending_count == 0 &&
        commands.size_approx() == 0)
      break;
    if (report.hash_overflow) {
      // Growing is an allocation: the one case the loop allows it, and only between steps,
      // because dropping boxes from the broad phase would silently lose contacts.
      grow_scratch(model, scratch, report);
      report.hash_overflow = false;
    }
    release += options.period_ns;
    if (options.pacing == Pacing::RealTime) {
      const std::int64_t now = monotonic_ns();
      // The workers sleep until the next release too (no system call wakes them).
      pool.end_step(now > release ? 0 : release - options.spin_ns);
      if (now > release) {
        // Overrun: skip the ticks already gone and wait for the next one (docs/realtime.md,
        // "Pacing"): no burst of back-to-back steps, the tick phase a device samples at is
        // kept, and the thread still sleeps a part of every period, so a SCHED_FIFO loop that
        // cannot keep up neither starves the other threads nor trips the kernel's real-time
        // throttling (sched_rt_runtime_us: by default 50 ms of every second stopped).
        overruns.fetch_add(1, std::memory_order_relaxed);
        release += ((now - release) / options.period_ns + 1) * options.period_ns;
      }
    }
  }
  if (options.on_thread_stop) options.on_thread_stop();
  done.store(true, std::memory_order_release);
}

PhysicsLoop::PhysicsLoop(const Model& model, State initial, LoopOptions options)
    : impl_(std::make_unique<Impl>(model, std::move(initial), std::move(options))) {}

PhysicsLoop::~PhysicsLoop() {
  request_stop();
  join();
}

void PhysicsLoop::start() {
  if (impl_->options.lock_memory && impl_->options.pacing == Pacing::RealTime)
    impl_->locked.store(mlockall(MCL_CURRENT) == 0);
  impl_->thread = std::thread([this] { impl_->run(); });
}

void PhysicsLoop::request_stop() { impl_->stop.store(true, std::memory_order_relaxed); }

void PhysicsLoop::join() {
  if (impl_->thread.joinable()) impl_->thread.join();
}

bool PhysicsLoop::finished() const { return impl_->done.load(std::memory_order_acquire); }

bool PhysicsLoop::push(const Command& command) { return impl_->commands.enqueue(command); }

bool PhysicsLoop::pop_telemetry(Telemetry& out) { return impl_->telemetry.try_dequeue(out); }

bool PhysicsLoop::pop_applied_command(Command& out) { return impl_->applied.try_dequeue(out); }

Snapshot* PhysicsLoop::pop_snapshot() {
  Snapshot* s = nullptr;
  return impl_->snapshots_ready.try_dequeue(s) ? s : nullptr;
}

void PhysicsLoop::recycle(Snapshot* snapshot) { impl_->snapshots_free.enqueue(snapshot); }

const Frame* PhysicsLoop::latest_frame() {
  if (const Frame* fresh = impl_->frames.take()) {
    impl_->reader_has_frame = true;
    return fresh;
  }
  return impl_->reader_has_frame ? &impl_->frames.front() : nullptr;
}

LoopCounters PhysicsLoop::counters() const {
  const Impl& i = *impl_;
  LoopCounters c;
  c.steps = i.steps.load();
  c.deadline_misses = i.misses.load();
  c.overruns = i.overruns.load();
  c.telemetry_dropped = i.telemetry_dropped.load();
  c.snapshots_dropped = i.snapshots_dropped.load();
  c.commands_rejected = i.rejected.load();
  c.commands_late = i.late.load();
  c.commands_unrecorded = i.applied_dropped.load();
  c.frames_published = i.frames_published.load();
  c.accuracy_switches = i.accuracy_switches.load();
  c.realtime_priority = i.fifo.load();
  c.memory_locked = i.locked.load();
  c.threads = i.pool.threads();
  return c;
}

const State& PhysicsLoop::state() const { return impl_->state; }

}  // namespace ffd
