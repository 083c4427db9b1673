#pragma once
// Replay scripts: a scene, timed commands and assertions, in TOML (format in docs/replays.md,
// "Replay scripts"). A recording written by `ffdsim run --record` is a replay script too.
// Every error names the file, the line, the column and the field:
//   "poke.toml:14:9: event[2].alpha: must be in [0, 1] (got 1.5)"
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ffd/command.h"
#include "ffd/model.h"
#include "ffd/scene_loader.h"
#include "ffd/toml_reader.h"

namespace ffd {

using ReplayError = InputError;

inline constexpr int kReplayFormatVersion = 1;

// Limits that keep a bad script from exhausting memory: the runner keeps a timing sample
// per step (100,000,000 steps: 28 hours at dt = 1 ms), and a keyframed path is one command
// per step it spans.
inline constexpr std::int64_t kMaxReplaySteps = 100'000'000;
inline constexpr std::uint64_t kMaxPathCommands = 1'000'000;  // all paths of a script together

// Assertions. An unset optional is not checked.
struct LatencyLimits {  // microseconds; lateness and misses only mean something in real time
  std::optional<double> compute_p50_us, compute_p99_us, compute_max_us;
  std::optional<double> lateness_p50_us, lateness_p99_us, lateness_max_us;
  std::optional<std::uint64_t> deadline_misses;
};

struct StabilityLimits {
  bool finite = false;                 // every step finite
  std::optional<double> energy_max_j;  // total energy (kinetic + gravity + elastic) never above
  // The total energy never more than this above what went in: the initial energy plus the
  // work the probe's device has done so far (sampled every step when given).
  std::optional<double> energy_gain_max_j;
  std::optional<double> speed_max_m_s; // no lattice node faster than this
  // No lattice cell inside out (ffd::cell_inside_out) for more than this many consecutive
  // steps; measured on a snapshot of every step (a real-time run that drops snapshots, its
  // reader falling behind, counts the snapshots it got).
  std::optional<std::uint64_t> inverted_steps_max;
};

struct ContactLimits {
  std::optional<double> max_penetration_m;  // deepest node-in-box depth r of any step
  // Sustained contact: every step from `contacts_from_step` on answers at least this many
  // contacts (inter + self + plane + probe), e.g. a pile that has formed and stays formed.
  std::optional<std::uint64_t> min_contacts;
  std::uint64_t contacts_from_step = 0;
};

// Measured on the embedded surfaces (outside the physics thread) every `every_steps` steps
// in [from_step, to_step].
struct GapLimit {
  std::string where;      // "file:line:col" of the assertion, for reports
  std::string a, b;       // object names
  Index object_a = 0, object_b = 0;
  std::optional<double> max_gap_m;          // the surfaces stay within this of each other
  std::optional<double> max_penetration_m;  // and sink no deeper into each other
  std::uint64_t from_step = 0, to_step = 0;
  std::uint64_t every_steps = 10;
};

// The surfaces' intersecting triangle pairs (surface_intersections.h: between objects and
// within one, rest-shape crossings left out) stay at most max_pairs every `every_steps` steps
// in [from_step, to_step].
struct IntersectionLimit {
  std::string where;
  std::uint64_t max_pairs = 0;
  std::uint64_t from_step = 0, to_step = 0;
  std::uint64_t every_steps = 10;
};

// The centre of mass of each named object (lattice nodes, mass-weighted), optionally minus
// that of another object, stays inside [min, max] every `every_steps` steps in
// [from_step, to_step]; an axis without a bound has -inf / +inf.
struct PositionLimit {
  std::string where;
  std::string pattern;             // as written: an object name, or "prefix*"
  std::vector<Index> objects;      // the objects it names
  std::optional<Index> relative_to;
  std::string relative_to_name;
  Vec3 min = Vec3::Constant(-std::numeric_limits<double>::infinity());
  Vec3 max = Vec3::Constant(std::numeric_limits<double>::infinity());
  std::uint64_t from_step = 0, to_step = 0;
  std::uint64_t every_steps = 10;
};

// The scene comes to rest: from `from_step` on, no object's centre of mass moves faster
// than `speed_max_m_s`, averaged over each `every_steps` interval.
struct RestLimit {
  std::optional<double> speed_max_m_s;
  std::uint64_t from_step = 0;
  std::uint64_t every_steps = 10;
};

// What a hand feels at rest: from `from_step` on, every step, the lattice nodes' RMS speed,
// their kinetic energy and the fastest node stay below these.
struct MotionLimits {
  std::optional<double> rms_speed_max_m_s;
  std::optional<double> kinetic_energy_max_j;
  std::optional<double> speed_max_m_s;
  std::uint64_t from_step = 0;
};

// Creep: from `from_step` to `to_step`, sampled every `every_steps`, no named object's centre
// of mass gets farther than `max_m` from where it was at `from_step`.
struct CreepLimit {
  std::string where;
  std::string pattern;
  std::vector<Index> objects;
  double max_m = 0.0;
  std::uint64_t from_step = 0, to_step = 0;
  std::uint64_t every_steps = 10;
};

// The probe's force output |F| over the steps (from_step, to_step]: steady (standard deviation
// at most `relative_std_max` of the mean), at least `mean_min_n` and at most `mean_max_n` on
// average, and, with
// `above_previous`, a larger mean than the force window before it in the script.
struct ForceWindow {
  std::string where;
  std::uint64_t from_step = 0, to_step = 0;
  std::optional<double> relative_std_max;
  std::optional<double> mean_min_n;
  std::optional<double> mean_max_n;
  bool above_previous = false;
};

struct ForceLimits {  // the probe's force output, N
  std::optional<double> max_n;       // |F| never above
  std::optional<double> peak_min_n;  // |F| reached at least this once (the probe touched)
};

struct HashCheck {
  std::string where;
  std::uint64_t step = 0;   // the State after this many steps
  std::uint64_t value = 0;  // state_hash
};

// Where a recording came from (its [recorded] table, recording.h): the ffdsim that wrote it
// and the files it ran, by content hash ("xxh3:" and 16 hex digits), paths as stored
// (relative to the recording's folder).
struct RecordedFile {
  std::string path;
  std::string hash;
};
struct RecordedOrigin {
  std::string ffdsim;      // version
  RecordedFile scene;
  std::string scene_text;  // the scene file as it was
  std::vector<RecordedFile> meshes;
};

// How a recording is read against the files it names.
enum class RecordedScene {
  MustMatch,      // a scene or mesh file whose content changed is an error, before any step
  FromRecording,  // the scene text embedded in the recording (meshes still from their files)
  AllowChanged,   // the files as they are now, each difference a warning
};

// "xxh3:" and the 16 hex digits of XXH3-64 over the file's bytes. Throws InputError naming
// the file when it cannot be read.
std::string content_hash_of_file(const std::string& path);
// This build's version (the top-level CMakeLists.txt).
std::string ffdsim_version();

struct ReplayScript {
  std::string path;         // the script file
  std::string scene_origin; // the scene file, or "<script>[scene]" when inline
  std::string description;
  SceneSpec scene;
  std::uint64_t steps = 0;           // length of the run
  std::vector<Command> commands;     // resolved against the compiled scene, ordered by step
  std::uint32_t hash_every = 0;      // a recording's hash interval (0: derived from `hashes`)
  LatencyLimits latency;
  StabilityLimits stability;
  ContactLimits contact;
  std::vector<GapLimit> gaps;
  std::vector<IntersectionLimit> intersections;
  std::vector<PositionLimit> positions;
  RestLimit rest;
  MotionLimits motion;
  std::vector<CreepLimit> creeps;
  ForceLimits force;
  std::vector<ForceWindow> force_windows;
  std::vector<HashCheck> hashes;     // ordered by step
  std::optional<RecordedOrigin> recorded;  // a recording's origin (none: a hand-written script)
  // What the reader let pass with a note (a recording cut off mid-write), file:line: text.
  std::vector<std::string> warnings;
};

// The first line of a recording written as the session runs (recording.h): such a file may
// end mid-write, and is read up to its last complete block.
inline constexpr const char* kStreamedRecordingMarker = "# ffdsim recording, written as the session runs";

struct LoadedReplay {
  ReplayScript script;
  Model model;  // the scene, compiled
};

// Reads, validates and resolves a script (object names, grab points, times in ms -> steps).
// Throws ReplayError (file:line:col: field: problem) for anything wrong, including a scene
// that does not load or compile.
// `limits` applies to the script's scene. `response`, when given, is the contact response
// the run is under in place of the scene's (a recording refuses it): it decides which of
// the [assert.paper] / [assert.solver] tables apply.
LoadedReplay load_replay_file(const std::string& path, const SceneLimits& limits = {},
                              RecordedScene recorded_scene = RecordedScene::MustMatch,
                              std::optional<ContactResponse> response = std::nullopt);
LoadedReplay parse_replay(const std::string& text, const std::string& origin, const std::string& base_dir,
                          const SceneLimits& limits = {}, RecordedScene recorded_scene = RecordedScene::MustMatch,
                          std::optional<ContactResponse> response = std::nullopt);

}  // namespace ffd
