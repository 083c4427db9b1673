#pragma once
// A scene running on the real-time physics loop, as the UI thread sees it: the newest frame,
// the latency history for the plots, and the log of every applied command (what a
// recording writes). The public interface is for the UI thread. A drain thread empties the
// loop's lossless queues every 10 ms (whatever the UI's frame rate) into a staging area
// that poll() takes over, and writes the recording as it goes; the physics thread is only
// reached through the loop's queues and never waits on either.
#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "ffd/physics_loop.h"
#include "ffd/recording.h"
#include "ffd/run_exports.h"

namespace ffd::ui {

struct SessionOptions {
  LoopOptions loop;  // real time, 1 kHz, by default
  // A state command leaves the UI stamped for the step `command_lead_steps` after the newest
  // frame, so that it lands on a known step (3 ms later: under one display frame). One that
  // arrives after its step has run is applied at once and counted late by the loop.
  std::uint64_t command_lead_steps = 3;
  // Record to this file as the session runs (recording.h): written from the session's drain
  // thread every 10 ms, so a killed run loses at most the last few tens of milliseconds.
  std::string record_path;
  // Surfaces every K steps and the per-step time series (run_exports.h), written from the
  // drain thread too.
  ExportOptions exports;
};

// The last steps' loop figures, for the latency panel.
struct LatencyHistory {
  static constexpr std::size_t kLength = 2000;  // steps (2 s at 1 kHz)
  std::array<float, kLength> compute_us{};      // ring buffers, oldest at `next`
  std::array<float, kLength> lateness_us{};
  std::size_t next = 0;
  std::uint64_t steps = 0;
  std::uint64_t misses = 0;
  std::array<std::uint64_t, kAccuracyLevels> steps_at_level{};  // since the start
  std::array<double, kStageCount> stage_us{};   // moving average over about 200 steps
  double compute_average_us = 0.0;
  std::uint32_t contacts = 0;                    // at the newest step
  double max_speed_m_s = 0.0;
  bool finite = true;
};

class Session {
 public:
  // Loads and compiles the scene (throws ffd::InputError / CompileError with the file and
  // place) and starts the physics thread.
  Session(const std::string& scene_path, const SessionOptions& options);
  ~Session();

  const std::string& scene_path() const { return scene_path_; }
  const Model& model() const { return *model_; }
  const State& initial() const { return initial_; }
  const std::vector<std::string>& compile_log() const { return compile_log_; }

  // Takes the newest frame and drains the lossless queues. Call once per UI frame.
  void poll();
  const Frame* frame() const { return frame_; }  // nullptr until the first step
  std::uint64_t newest_step() const { return frame_ ? frame_->step : 0; }

  // Pushes a command, stamped as SessionOptions describes (loop commands apply at the next
  // tick, and so do state commands while the loop is paused). Returns the step it is
  // stamped for (kNextStep for the next tick).
  std::uint64_t send(Command command);

  const LatencyHistory& history() const { return history_; }
  LoopCounters counters() const { return loop_->counters(); }
  // Every command applied since step 0 and the state hash every 100 steps: a replay script
  // of the session so far (docs/replays.md, "Replay scripts").
  const Recording& log() const { return log_; }
  // Every step's compute and wake-up lateness so far, ns (for the end-of-run report).
  const std::vector<std::int64_t>& compute_ns() const { return compute_ns_; }
  const std::vector<std::int64_t>& lateness_ns() const { return lateness_ns_; }

  void stop();  // ends the physics thread (also done by the destructor)
  // The recording written as the session runs (nullptr without SessionOptions::record_path),
  // and the first error writing it (empty: none). Read after stop().
  const RecordingStream* recording() const { return recording_.get(); }
  // Ends the recording while the session goes on (the viewer's "Stop and save"): what was
  // applied and hashed until now is written, nothing after. Its last hash is at most 50 ms
  // of simulated time old; a replay runs to it or to the last command, whichever is later.
  void close_recording();
  const std::string& recording_error() const { return recording_error_; }
  // The exports (nullptr without SessionOptions::exports); final after stop().
  const RunExports* exports() const { return exports_.get(); }

 private:
  std::string scene_path_;
  SessionOptions options_;
  std::unique_ptr<Model> model_;
  State initial_;
  std::vector<std::string> compile_log_;
  std::unique_ptr<PhysicsLoop> loop_;
  const Frame* frame_ = nullptr;
  LatencyHistory history_;
  Recording log_;
  std::vector<std::int64_t> compute_ns_, lateness_ns_;
  // Drain thread (see above): what it took from the queues since the last poll().
  void drain();
  std::mutex staging_mutex_;
  std::vector<Telemetry> staged_telemetry_, taken_telemetry_;
  std::vector<Command> staged_commands_, taken_commands_;
  std::unique_ptr<RecordingStream> recording_;
  std::unique_ptr<RunExports> exports_;
  std::string recording_error_;
  bool recording_closed_ = false;
  std::atomic<bool> drain_stop_{false};
  std::thread drain_thread_;
};

}  // namespace ffd::ui
