#include "app/session.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include "ffd/scene_loader.h"

namespace ffd::ui {

Session::Session(const std::string& scene_path, const SessionOptions& options)
    : scene_path_(std::filesystem::absolute(scene_path).lexically_normal().string()), options_(options) {
  const SceneSpec spec = load_scene_file(scene_path_);
  model_ = std::make_unique<Model>(compile_scene(spec, scene_path_, compile_log_));
  initial_ = initial_state(*model_);
  if (options_.loop.hash_every == 0) options_.loop.hash_every = 100;
  log_.scene_path = scene_path_;
  // A hash at least every 50 ms of simulated time, whatever --hash-every says: a recording
  // (written as it goes or at the end) always compares, and one cut off at any moment does so
  // up to within about 60 ms of where the run was (hashes, drain, flush).
  const auto most = static_cast<std::uint32_t>(std::max(1.0, std::round(0.05 / model_->settings.dt)));
  options_.loop.hash_every = std::min(options_.loop.hash_every, most);
  if (!options_.record_path.empty()) {
    recording_ = std::make_unique<RecordingStream>(options_.record_path, *model_, scene_path_, spec, options_.loop.hash_every);
  }
  log_.hash_every = options_.loop.hash_every;
  if (options_.exports.any()) {
    std::vector<std::string> sources;
    for (const ObjectSpec& o : spec.objects) sources.push_back(o.source);
    exports_ = std::make_unique<RunExports>(*model_, initial_, std::move(sources), options_.exports);
    options_.loop.snapshot_every = static_cast<std::uint32_t>(options_.exports.surfaces_every);
    if (!options_.exports.series_path.empty()) options_.loop.energy_every = 1;  // a value in every row
  }
  loop_ = std::make_unique<PhysicsLoop>(*model_, initial_, options_.loop);
  compute_ns_.reserve(1 << 20);
  lateness_ns_.reserve(1 << 20);
  loop_->start();
  drain_thread_ = std::thread([this] {
    while (!drain_stop_.load(std::memory_order_acquire)) {
      drain();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  });
}

Session::~Session() { stop(); }

void Session::stop() {
  if (!loop_ || !drain_thread_.joinable()) return;
  loop_->request_stop();
  loop_->join();
  drain_stop_.store(true, std::memory_order_release);
  drain_thread_.join();
  drain();
  if (exports_) exports_->finish();
  // The last step's hash, whatever the interval: a replay then compares up to the end.
  const State& last = loop_->state();
  const std::uint64_t last_hash = state_hash(last);
  if (recording_ && !recording_closed_ && recording_error_.empty()) {
    try {
      if (last.step > 0) recording_->hash(last.step, last_hash);
      recording_->flush();
    } catch (const std::exception& e) {
      recording_error_ = e.what();
    }
  }
  poll();
  if (last.step > 0 && (log_.hashes.empty() || log_.hashes.back().first != last.step))
    log_.hashes.emplace_back(last.step, last_hash);
}

void Session::close_recording() {
  drain();
  std::lock_guard<std::mutex> lock(staging_mutex_);
  recording_closed_ = true;
}

void Session::drain() {
  std::lock_guard<std::mutex> lock(staging_mutex_);
  const std::size_t first_telemetry = staged_telemetry_.size(), first_command = staged_commands_.size();
  // Telemetry first: a command is queued before the telemetry of the step it was applied at,
  // so every command up to the newest hash drained here is drained below too.
  Telemetry t;
  while (loop_->pop_telemetry(t)) staged_telemetry_.push_back(t);
  Command c;
  while (loop_->pop_applied_command(c)) staged_commands_.push_back(c);
  if (exports_) {
    for (std::size_t i = first_telemetry; i < staged_telemetry_.size(); ++i) exports_->telemetry(staged_telemetry_[i]);
    while (Snapshot* snapshot = loop_->pop_snapshot()) {
      exports_->snapshot(snapshot->step, snapshot->x);
      loop_->recycle(snapshot);
    }
  }
  if (!recording_ || recording_closed_ || !recording_error_.empty()) return;
  try {
    for (std::size_t i = first_command; i < staged_commands_.size(); ++i) recording_->command(staged_commands_[i]);
    for (std::size_t i = first_telemetry; i < staged_telemetry_.size(); ++i)
      if (staged_telemetry_[i].has_hash) recording_->hash(staged_telemetry_[i].step, staged_telemetry_[i].state_hash);
    recording_->flush();
  } catch (const std::exception& e) {
    recording_error_ = e.what();  // reported at the end; the session goes on
  }
}

void Session::poll() {
  if (const Frame* f = loop_->latest_frame()) frame_ = f;
  {
    std::lock_guard<std::mutex> lock(staging_mutex_);
    taken_telemetry_.swap(staged_telemetry_);
    taken_commands_.swap(staged_commands_);
  }
  constexpr double kAverageWeight = 1.0 / 200.0;  // moving average over about 200 steps
  for (const Telemetry& t : taken_telemetry_) {
    history_.compute_us[history_.next] = static_cast<float>(t.compute_ns) * 1e-3f;
    history_.lateness_us[history_.next] = static_cast<float>(t.lateness_ns) * 1e-3f;
    history_.next = (history_.next + 1) % LatencyHistory::kLength;
    ++history_.steps;
    if (!t.deadline_met) ++history_.misses;
    ++history_.steps_at_level[static_cast<std::size_t>(t.accuracy)];
    for (std::size_t s = 0; s < kStageCount; ++s) {
      const double us = t.stage_ns[s] < 0 ? 0.0 : static_cast<double>(t.stage_ns[s]) * 1e-3;
      history_.stage_us[s] += (us - history_.stage_us[s]) * kAverageWeight;
    }
    history_.compute_average_us += (static_cast<double>(t.compute_ns) * 1e-3 - history_.compute_average_us) * kAverageWeight;
    history_.contacts = t.contacts;
    history_.max_speed_m_s = t.max_speed_m_s;
    history_.finite = history_.finite && t.finite;
    compute_ns_.push_back(t.compute_ns);
    lateness_ns_.push_back(t.lateness_ns);
    log_.steps = t.step;
    if (t.has_hash) log_.hashes.emplace_back(t.step, t.state_hash);
  }
  log_.commands.insert(log_.commands.end(), taken_commands_.begin(), taken_commands_.end());
  taken_telemetry_.clear();
  taken_commands_.clear();
}

std::uint64_t Session::send(Command command) {
  const bool paused = frame_ && frame_->paused;
  command.step = is_state_command(command.kind) && !paused ? newest_step() + options_.command_lead_steps : kNextStep;
  loop_->push(command);
  return command.step;
}

}  // namespace ffd::ui
