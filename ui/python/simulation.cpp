#include "simulation.h"

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "ffd/recording.h"
#include "ffd/scene_loader.h"

namespace ffd::python {

namespace {

std::filesystem::path absolute_normal(const std::string& path) {
  return std::filesystem::absolute(path).lexically_normal();
}

}  // namespace

int thread_count(int threads) {
  if (threads < 0 || threads > 64)
    throw std::invalid_argument("threads must be 0 (the default) or 1 to 64 (got " + std::to_string(threads) + ")");
  return threads > 0 ? threads : default_thread_count();
}

std::unique_ptr<Simulation> Simulation::from_file(const std::string& path, int threads, std::uint32_t hash_every) {
  const std::filesystem::path absolute = absolute_normal(path);
  thread_count(threads);  // a bad count before a scene's load, however long that takes
  SceneSpec spec = load_scene_file(absolute.string());
  return std::unique_ptr<Simulation>(
      new Simulation(std::move(spec), absolute.string(), "", absolute.parent_path().string(), threads, hash_every));
}

std::unique_ptr<Simulation> Simulation::from_text(const std::string& text, const std::string& origin,
                                                  const std::string& base_dir, int threads, std::uint32_t hash_every) {
  const std::string base = absolute_normal(base_dir).string();
  thread_count(threads);
  SceneSpec spec = parse_scene(text, origin, base);
  return std::unique_ptr<Simulation>(new Simulation(std::move(spec), "", text, base, threads, hash_every));
}

Simulation::Simulation(SceneSpec spec, std::string scene_path, std::string scene_text, std::string base_dir, int threads,
                       std::uint32_t hash_every)
    : spec_(std::move(spec)),
      scene_path_(std::move(scene_path)),
      scene_text_(std::move(scene_text)),
      base_dir_(std::move(base_dir)),
      hash_every_(hash_every) {
  if (hash_every_ == 0) throw std::invalid_argument("hash_every must be at least 1 step");
  std::vector<std::string> log;
  // compile_scene names the file first in its errors, as the loader does.
  model_ = compile_scene(spec_, scene_path_.empty() ? spec_.name : scene_path_, log);
  initial_ = initial_state(model_);
  state_ = initial_;
  pool_ = std::make_unique<WorkerPool>(thread_count(threads));
  scratch_ = make_scratch(model_);
  attach_pool(model_, scratch_, *pool_);
}

void Simulation::queue(Command command) {
  if (!is_state_command(command.kind))
    throw std::invalid_argument(std::string(command_name(command.kind)) + " steers the real-time loop, not a simulation");
  if (!command_is_valid(model_, command))
    throw std::invalid_argument(std::string(command_name(command.kind)) + ": not valid for this scene (" +
                                (scene_path_.empty() ? spec_.name : scene_path_) +
                                "): a value outside its range, a non-finite number, or an effect the scene does not have");
  queued_.push_back(command);
}

void Simulation::step(std::uint64_t count) {
  for (std::uint64_t i = 0; i < count; ++i) {
    // As the physics loop does: due commands in arrival order, stamped with the step they
    // took effect at, then the step.
    for (Command& c : queued_) {
      c.step = state_.step;
      apply_command(model_, initial_, state_, c);
      applied_.push_back(c);
    }
    queued_.clear();
    ffd::step(model_, state_, scratch_, report_);
    grow_scratch(model_, scratch_, report_);
    if (state_.step % hash_every_ == 0) hashes_.emplace_back(state_.step, state_hash(state_));
  }
}

Index Simulation::object_index(const std::string& name) const {
  std::string names;
  for (Index o = 0; o < model_.objects.size(); ++o) {
    if (model_.objects[o].name == name) return o;
    names += (names.empty() ? "" : ", ") + model_.objects[o].name;
  }
  throw std::invalid_argument("no object named '" + name + "' in this scene (its objects: " + names + ")");
}

void Simulation::save_recording(const std::string& path) const {
  namespace fs = std::filesystem;
  if (state_.step == 0) throw std::runtime_error(path + ": nothing to record yet: take a step first");
  Recording recording;
  recording.scene_path = scene_path_;
  if (scene_path_.empty()) {
    // Scene text: written beside the recording, where its relative mesh paths must still lead.
    const fs::path folder = absolute_normal(path).parent_path();
    for (const ObjectSpec& object : spec_.objects) {
      std::error_code error;
      if (fs::path(object.source).is_relative() && fs::is_regular_file(fs::path(base_dir_) / object.source, error) &&
          folder != fs::path(base_dir_))
        throw std::runtime_error(path + ": cannot record: object '" + object.name + "' reads the mesh " + object.source +
                                 " relative to " + base_dir_ +
                                 "; save the recording in that folder, or load the scene from a file");
    }
    const fs::path scene_file = folder / (fs::path(path).stem().string() + ".scene.toml");
    std::ofstream out(scene_file);
    out << scene_text_;
    if (!out) throw std::runtime_error(scene_file.string() + ": cannot write the recording's scene");
    recording.scene_path = scene_file.string();
  }
  recording.steps = state_.step;
  recording.hash_every = hash_every_;
  recording.commands = applied_;
  recording.hashes = hashes_;
  if (recording.hashes.empty() || recording.hashes.back().first != state_.step)
    recording.hashes.emplace_back(state_.step, state_hash(state_));
  write_recording(path, model_, recording);
}

}  // namespace ffd::python
