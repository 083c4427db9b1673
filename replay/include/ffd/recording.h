#pragma once
// Recordings: the command stream of a session, written as a replay script (README.md,
// "Replay scripts") with the state hash every N steps as determinism assertions, so that
// `ffdsim replay FILE` reproduces the session and reports the first step it diverged at.
#include <cstdint>
#include <string>
#include <vector>

#include "ffd/command.h"
#include "ffd/model.h"

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

// Writes it to `path` (through a temporary file, renamed when complete, so a crash never
// leaves half a recording). Throws std::runtime_error naming the path on failure.
void write_recording(const std::string& path, const Model& model, const Recording& recording);

}  // namespace ffd
