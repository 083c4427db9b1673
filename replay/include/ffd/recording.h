#pragma once
// Recordings: the command stream of a session, written as a replay script (docs/replays.md,
// "Recordings") with the state hash every N steps as determinism assertions, so that
// `ffdsim replay FILE` reproduces the session and reports the first step it diverged at.
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "ffd/command.h"
#include "ffd/model.h"
#include "ffd/spec.h"

namespace ffd {

struct Recording {
  std::string scene_path;  // absolute, so the recording replays from anywhere
  std::uint64_t steps = 0;
  std::uint32_t hash_every = 0;
  std::vector<Command> commands;  // as applied, with their steps
  std::vector<std::pair<std::uint64_t, std::uint64_t>> hashes;  // (step, state hash)
};

// The recording as replay-script text. Numbers are written with 17 significant digits so
// that they read back as the same doubles.
std::string recording_text(const Model& model, const Recording& recording);

// A recording written while the session runs (docs/replays.md, "Recordings"): the header goes to disk
// when it is made, commands and state hashes follow in blocks each time flush() is called
// (by a thread that is not the physics thread, every few milliseconds). Every block ends with
// a blank line, so a run killed mid-write leaves a file that replays up to its last complete
// block. Throws std::runtime_error naming the path when the file cannot be written.
class RecordingStream {
 public:
  // `scene_path` is written relative to the recording's folder, so that a folder of scene,
  // meshes and recordings can be moved. `hash_every`: the steps between state hashes.
  // The header names this ffdsim's version and holds the scene file's text and the content
  // hashes of it and of every mesh file `spec` was read from (a replay checks them).
  RecordingStream(const std::string& path, const Model& model, const std::string& scene_path, const SceneSpec& spec,
                  std::uint32_t hash_every);
  ~RecordingStream();
  RecordingStream(const RecordingStream&) = delete;
  RecordingStream& operator=(const RecordingStream&) = delete;

  void command(const Command& command);
  void hash(std::uint64_t step, std::uint64_t value);
  void flush();
  const std::string& path() const { return path_; }
  std::size_t commands() const { return commands_; }
  std::size_t hashes() const { return hashes_; }
  std::uint64_t last_hash_step() const { return last_hash_step_; }

 private:
  std::string path_;
  const Model& model_;
  std::FILE* file_ = nullptr;
  std::string pending_commands_, pending_hashes_;  // blocks not yet written
  std::size_t commands_ = 0, hashes_ = 0;
  std::uint64_t last_hash_step_ = 0;
};

// Writes it to `path` (through a temporary file, renamed when complete, so a crash never
// leaves half a recording). Throws std::runtime_error naming the path on failure.
void write_recording(const std::string& path, const Model& model, const Recording& recording);

}  // namespace ffd
