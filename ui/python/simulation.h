#pragma once
// A scene stepped on the calling thread, as `ffdsim simulate` steps it, with the viewer's live
// commands applied at the start of the next step and recorded, so that a recording made
// here replays bit for bit with `ffdsim replay`. The Python module (ffdsim_module.cpp) wraps
// it; nothing in it knows about Python.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "ffd/command.h"
#include "ffd/model.h"
#include "ffd/spec.h"
#include "ffd/state.h"
#include "ffd/step.h"
#include "ffd/worker_pool.h"

namespace ffd::python {

// `threads` as the Python calls take it: 0 for the command line's default, else 1..64 (as
// --threads). Throws std::invalid_argument for anything else.
int thread_count(int threads);

class Simulation {
 public:
  // A scene file. Throws InputError ("file:line:column: field: problem") for a scene that does
  // not load or compile. `threads`: 0 for the CLI's default; the results do not depend on it.
  // `hash_every`: steps between the state hashes a recording holds.
  static std::unique_ptr<Simulation> from_file(const std::string& path, int threads, std::uint32_t hash_every);
  // Scene text; `origin` names it in errors, relative mesh paths are read from `base_dir`.
  static std::unique_ptr<Simulation> from_text(const std::string& text, const std::string& origin,
                                               const std::string& base_dir, int threads, std::uint32_t hash_every);
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // Takes `count` steps. Commands queued since the last step apply at the start of the first.
  void step(std::uint64_t count);
  // Queues a state command for the start of the next step. Throws std::invalid_argument when
  // it is not well formed for this scene (command_is_valid), naming what is wrong.
  void queue(Command command);

  const Model& model() const { return model_; }
  const State& state() const { return state_; }
  const StepReport& last_report() const { return report_; }
  std::span<const Contact> contacts() const { return scratch_.contacts(); }
  const std::string& scene_path() const { return scene_path_; }  // empty for scene text
  const std::string& name() const { return spec_.name; }
  int threads() const { return pool_->threads(); }
  // The object of that name; throws std::invalid_argument listing the names when none is.
  Index object_index(const std::string& name) const;

  // Writes the session so far (the commands as applied, a state hash every hash_every steps
  // and at the last step) as a replay script. A scene given as text is written beside it as
  // PATH's stem + ".scene.toml". Throws std::runtime_error naming the path when it cannot.
  void save_recording(const std::string& path) const;

 private:
  Simulation(SceneSpec spec, std::string scene_path, std::string scene_text, std::string base_dir, int threads,
             std::uint32_t hash_every);

  SceneSpec spec_;
  std::string scene_path_, scene_text_, base_dir_;
  Model model_;
  State initial_, state_;
  std::unique_ptr<WorkerPool> pool_;  // before scratch_, which uses it
  Scratch scratch_;
  StepReport report_;
  std::uint32_t hash_every_;
  std::vector<Command> queued_, applied_;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> hashes_;  // (step, state hash)
};

}  // namespace ffd::python
