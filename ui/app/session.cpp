#include "app/session.h"

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
  log_.hash_every = options_.loop.hash_every;
  loop_ = std::make_unique<PhysicsLoop>(*model_, initial_, options_.loop);
  compute_ns_.reserve(1 << 20);
  lateness_ns_.reserve(1 << 20);
  loop_->start();
}

Session::~Session() { stop(); }

void Session::stop() {
  if (!loop_) return;
  loop_->request_stop();
  loop_->join();
  poll();
}

void Session::poll() {
  if (const Frame* f = loop_->latest_frame()) frame_ = f;
  Telemetry t;
  constexpr double kAverageWeight = 1.0 / 200.0;  // moving average over about 200 steps
  while (loop_->pop_telemetry(t)) {
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
  Command c;
  while (loop_->pop_applied_command(c)) log_.commands.push_back(c);
}

std::uint64_t Session::send(Command command) {
  const bool paused = frame_ && frame_->paused;
  command.step = is_state_command(command.kind) && !paused ? newest_step() + options_.command_lead_steps : kNextStep;
  loop_->push(command);
  return command.step;
}

}  // namespace ffd::ui
