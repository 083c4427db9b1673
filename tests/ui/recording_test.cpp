// Recordings written as the run goes (`ffdsim run --headless --record`): what a killed run
// leaves, and how a replay treats a recording whose files changed.
#include <catch2/catch.hpp>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "support/run_ffdsim.h"

extern char** environ;

namespace {

namespace fs = std::filesystem;

using Result = test::ProgramResult;
using test::read_text;
using test::run_ffdsim;

// A scene folder of its own (scene + mesh), so that a test can edit or move it.
fs::path scene_folder(const std::string& name) {
  const fs::path dir = test::fresh_temp_dir(name);
  fs::create_directories(dir / "scenes");
  fs::create_directories(dir / "meshes");
  fs::create_directories(dir / "recordings");
  const fs::path shipped(FFDSIM_SCENARIO_DIR);
  fs::copy_file(shipped / "scenes" / "two_teapots.toml", dir / "scenes" / "two_teapots.toml");
  fs::copy_file(shipped / "meshes" / "teapot.obj", dir / "meshes" / "teapot.obj");
  return dir;
}

// The step of the last complete [[assert.hash]] block (one with its value line).
std::uint64_t last_hash_step(const std::string& recording) {
  const std::string head = "[[assert.hash]]\nstep = ";
  std::uint64_t last = 0;
  for (std::size_t at = recording.find(head); at != std::string::npos; at = recording.find(head, at + 1)) {
    const std::size_t digits = at + head.size(), end = recording.find('\n', digits);
    if (end == std::string::npos || recording.compare(end, 10, "\nvalue = \"") != 0) continue;
    last = std::max<std::uint64_t>(last, std::stoull(recording.substr(digits, end - digits)));
  }
  return last;
}

// The quoted value of `key = "..."` on a line of its own (empty if none).
std::string quoted_value(const std::string& text, const std::string& key) {
  const std::string head = "\n" + key + " = \"";
  const std::size_t at = text.find(head);
  if (at == std::string::npos) return "";
  const std::size_t begin = at + head.size(), end = text.find('"', begin);
  return end == std::string::npos ? "" : text.substr(begin, end - begin);
}

}  // namespace

TEST_CASE("a run killed with SIGKILL leaves a recording that replays every step it holds", "[cli][recording]") {
  const fs::path dir = scene_folder("killed");
  const fs::path recording = dir / "recordings" / "killed.toml", report = dir / "report.json";
  const std::string binary = FFDSIM_BINARY, scene = (dir / "scenes" / "two_teapots.toml").string();
  const std::string record_path = recording.string(), report_path = report.string();
  std::vector<const char*> argv = {binary.c_str(), "run", scene.c_str(), "--headless", "--seconds", "60", "--record",
                                   record_path.c_str(), "--report", report_path.c_str(), "-q", nullptr};
  pid_t child = 0;
  REQUIRE(posix_spawn(&child, binary.c_str(), nullptr, nullptr, const_cast<char* const*>(argv.data()), environ) == 0);
  // Kill it right after a report that says it ran at least 1.5 s of steps.
  std::uint64_t reported_steps = 0;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(40);
  while (reported_steps < 1500 && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    const std::string text = read_text(report);
    if (text.empty()) continue;
    const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (!j.is_discarded() && j.contains("steps")) reported_steps = j.at("steps").get<std::uint64_t>();
  }
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  REQUIRE(WIFSIGNALED(status));
  REQUIRE(reported_steps >= 1500);
  const nlohmann::json last_report = nlohmann::json::parse(read_text(report));
  CHECK(last_report.at("running") == true);

  // It holds all but the last few tens of milliseconds of what the report saw...
  const std::string text = read_text(recording);
  INFO(text.substr(0, 400));
  const std::uint64_t held = last_hash_step(text);
  CHECK(held + 100 >= reported_steps);
  // ...and every hash it holds replays equal.
  const Result replay = run_ffdsim("replay " + record_path + " --fast");
  INFO(replay.output);
  CHECK(replay.exit_code == 0);
  CHECK(replay.output.find("determinism.state_hash") != std::string::npos);

  // Cut off mid-block (as a kill during a write would): replayed up to the last whole block,
  // with a warning that names the line.
  const std::string cut = text.substr(0, text.size() - 9);
  std::ofstream(recording, std::ios::binary | std::ios::trunc) << cut;
  const Result truncated = run_ffdsim("replay " + record_path + " --fast");
  INFO(truncated.output);
  CHECK(truncated.exit_code == 0);
  CHECK(truncated.output.find("ends mid-write") != std::string::npos);
  CHECK(truncated.output.find(record_path + ":") != std::string::npos);
}

TEST_CASE("a replay of a recording whose scene changed stops and names the scene and both hashes",
          "[cli][recording]") {
  const fs::path dir = scene_folder("changed");
  const fs::path scene = dir / "scenes" / "two_teapots.toml";
  const std::string recording = (dir / "recordings" / "session.toml").string();
  const Result recorded = run_ffdsim("run " + scene.string() + " --headless --seconds 1.5 --record " + recording + " -q");
  INFO(recorded.output);
  REQUIRE(recorded.exit_code == 0);
  const std::string text = read_text(recording);
  // Paths relative to the recording; the scene's text and content hashes in the header.
  CHECK(text.find("scene = \"../scenes/two_teapots.toml\"") != std::string::npos);
  CHECK(text.find("path = \"../meshes/teapot.obj\"") != std::string::npos);
  const std::string recorded_hash = quoted_value(text, "scene_hash");
  REQUIRE(recorded_hash.size() == 21);  // "xxh3:" and 16 hex digits
  REQUIRE(recorded_hash.rfind("xxh3:", 0) == 0);

  // The whole folder moved: the recording still replays.
  const fs::path moved = test::fresh_temp_dir("changed_moved");
  fs::rename(dir, moved);
  const std::string moved_recording = (moved / "recordings" / "session.toml").string();
  CHECK(run_ffdsim("replay " + moved_recording + " --fast -q").exit_code == 0);

  // One stiffness edited: an error before any step, naming the scene and both hashes.
  const fs::path moved_scene = moved / "scenes" / "two_teapots.toml";
  std::string scene_text = read_text(moved_scene);
  const std::size_t at = scene_text.find("stiffness = 5000.0");
  REQUIRE(at != std::string::npos);
  scene_text.replace(at, 18, "stiffness = 5001.0");
  std::ofstream(moved_scene, std::ios::binary | std::ios::trunc) << scene_text;
  const Result changed = run_ffdsim("replay " + moved_recording + " --fast");
  INFO(changed.output);
  CHECK(changed.exit_code == 2);
  CHECK(changed.output.find(moved_scene.lexically_normal().string()) != std::string::npos);
  CHECK(changed.output.find("recorded " + recorded_hash) != std::string::npos);
  CHECK(changed.output.find("now xxh3:") != std::string::npos);
  CHECK(changed.output.find("steps, fast") == std::string::npos);  // nothing was stepped

  // The embedded scene text: every hash equal.
  const Result embedded = run_ffdsim("replay " + moved_recording + " --fast --scene-from-recording");
  INFO(embedded.output);
  CHECK(embedded.exit_code == 0);
  // The edited files anyway: a warning, then the first diverging step.
  const Result anyway = run_ffdsim("replay " + moved_recording + " --fast --allow-changed");
  INFO(anyway.output);
  CHECK(anyway.exit_code == 4);
  CHECK(anyway.output.find("warning") != std::string::npos);
  CHECK(anyway.output.find("diverged: state hash at step") != std::string::npos);
}

TEST_CASE("the viewer's Record button writes the recording as the session runs, and it replays",
          "[cli][recording][viewer]") {  // [viewer]: draws with Mesa (tests/CMakeLists.txt)
  const fs::path dir = scene_folder("viewer");
  const fs::path script = dir / "record.toml";
  std::ofstream(script) << R"(format = "ffdsim-ui-script"
version = 1
scene = "scenes/two_teapots.toml"
duration_ms = 2400

[[input]]
at_ms = 100
widget = "record"

[[input]]
at_ms = 150
press = "left"

[[input]]
at_ms = 160
release = "left"

# In the recorded session (it restarts at step 0): a grab and a drag, then stop and save.
[[input]]
at_ms = 700
mouse_to = "teapot_high"

[[input]]
at_ms = 750
press = "left"

[[input]]
at_ms = 800
offset = [30, -20]
glide_ms = 300

[[input]]
at_ms = 1200
release = "left"

[[input]]
at_ms = 1500
widget = "record"

[[input]]
at_ms = 1550
press = "left"

[[input]]
at_ms = 1560
release = "left"
)";
  const Result r = run_ffdsim("run --headless --input " + script.string() + " --frames " + (dir / "frames").string() +
                              " -q");
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  // The viewer writes to out/recordings/ under the working directory: find this run's file.
  fs::path recording;
  for (const fs::directory_entry& e : fs::directory_iterator("out/recordings"))
    if (e.path().filename().string().rfind("session_", 0) == 0 &&
        (recording.empty() || fs::last_write_time(e.path()) > fs::last_write_time(recording)))
      recording = e.path();
  REQUIRE(!recording.empty());
  const std::string text = read_text(recording);
  INFO(recording.string());
  CHECK(text.rfind("# ffdsim recording, written as the session runs", 0) == 0);
  CHECK(text.find("grab = {") != std::string::npos);
  CHECK(last_hash_step(text) >= 1000);
  const Result replay = run_ffdsim("replay " + recording.string() + " --fast");
  INFO(replay.output);
  CHECK(replay.exit_code == 0);
  fs::remove(recording);
}
