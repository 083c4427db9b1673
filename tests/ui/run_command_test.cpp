// `ffdsim run` end to end where a new user meets it: the fallback when the display cannot
// give a window, and the frames folder a run writes into.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "support/run_ffdsim.h"

namespace {

const std::string kMinimal = std::string(FFDSIM_TEST_DATA_DIR) + "/scenes/minimal.toml";

nlohmann::json read_json(const std::filesystem::path& path) {
  std::ifstream in(path);
  REQUIRE(in);
  return nlohmann::json::parse(in);
}

std::size_t png_count(const std::filesystem::path& dir) {
  std::size_t n = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) n += entry.path().extension() == ".png";
  return n;
}

}  // namespace

TEST_CASE("run: a display that cannot give a window falls back to the headless demo for --seconds", "[viewer]") {
  const std::filesystem::path dir = test::fresh_temp_dir("run_fallback");
  std::filesystem::create_directories(dir);
  // DISPLAY names a display nobody serves: the window fails, the fallback writes to out/.
  const test::ProgramResult r =
      test::run_shell("cd " + dir.string() + " && env -u WAYLAND_DISPLAY DISPLAY=:987 " FFDSIM_BINARY " run --seconds 1 " +
                      kMinimal);
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.output, Catch::Contains("running the headless demo instead"));
  const nlohmann::json report = read_json(dir / "out" / "report.json");
  CHECK(report.at("mode") == "headless viewer");
  // One second of wall time at 1 kHz: well under the demo script's 20 s, with room for a slow
  // machine's start (steps are counted from the physics thread's start).
  const std::uint64_t steps = report.at("steps").get<std::uint64_t>();
  CHECK(steps >= 200);
  CHECK(steps <= 2000);
  CHECK(report.at("ui").at("script_events").get<std::size_t>() == 0);  // --seconds: no demo script
  std::filesystem::remove_all(dir);
}

TEST_CASE("run: a shorter run into the same frames folder leaves only its own frames beside their index", "[viewer]") {
  const std::filesystem::path dir = test::fresh_temp_dir("run_frames");
  const std::filesystem::path frames = dir / "frames";
  std::filesystem::create_directories(frames);
  std::ofstream(frames / "notes.txt") << "the user's own file\n";
  std::ofstream(frames / "frame_99999.png") << "an earlier run's frame\n";
  auto run = [&](const std::string& seconds, int fps) {
    const test::ProgramResult r = test::run_ffdsim("run --headless -q --seconds " + seconds + " --fps " +
                                                   std::to_string(fps) + " --frames " + frames.string() + " " + kMinimal);
    INFO(r.output);
    REQUIRE(r.exit_code == 0);
  };
  run("1.5", 20);
  const std::size_t first = read_json(frames / "frames.json").at("frames").size();
  CHECK(png_count(frames) == first);
  run("0.3", 10);
  const nlohmann::json index = read_json(frames / "frames.json");
  const std::size_t second = index.at("frames").size();
  CHECK(second < first);
  CHECK(png_count(frames) == second);  // no frame of the first run is left behind
  for (const nlohmann::json& frame : index.at("frames"))
    CHECK(std::filesystem::exists(frames / frame.at("file").get<std::string>()));
  CHECK(std::filesystem::exists(frames / "notes.txt"));  // what the run does not own stays
  std::filesystem::remove_all(dir);
}

namespace {
// A UI script that clicks the scene path field, types `path` and presses Enter.
std::string open_by_path_script(const std::string& path, int duration_ms) {
  return "format = \"ffdsim-ui-script\"\nversion = 1\nduration_ms = " + std::to_string(duration_ms) +
         "\nsize = [1280, 720]\n"
         "[[input]]\nat_ms = 200\nwidget = \"scene_path\"\n"
         "[[input]]\nat_ms = 250\npress = \"left\"\n"
         "[[input]]\nat_ms = 300\nrelease = \"left\"\n"
         "[[input]]\nat_ms = 350\ntext = \"" + path + "\"\n"
         "[[input]]\nat_ms = 400\nkey = \"enter\"\n";
}
}  // namespace

TEST_CASE("Viewer in a window under Xvfb: a scene outside the scene folder opens by its path and joins the recent "
          "scenes", "[viewer]") {
  const std::filesystem::path dir = test::fresh_temp_dir("open_by_path");
  std::filesystem::create_directories(dir / "elsewhere");
  const std::filesystem::path scene = dir / "elsewhere" / "my_scene.toml";
  std::filesystem::copy_file(std::string(FFDSIM_TEST_DATA_DIR) + "/scenes/probe_and_grab.toml", scene);
  std::ofstream(dir / "open.toml") << open_by_path_script(scene.string(), 1200);
  const std::string report = (dir / "report.json").string();
  const test::ProgramResult r = test::run_shell(
      "env XDG_CONFIG_HOME=" + (dir / "config").string() + " xvfb-run -a -s '-screen 0 1280x720x24' " FFDSIM_BINARY
      " run --window --input " + (dir / "open.toml").string() + " --report " + report + " " + kMinimal);
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.output, Catch::Contains("opened " + scene.string()));
  const nlohmann::json j = read_json(report);
  CHECK(j.at("mode") == "window");
  CHECK(j.at("scene") == scene.string());  // the session at the end is the scene opened by path
  // The recent scenes, newest first, kept for the next run.
  std::ifstream recent(dir / "config" / "ffdsim" / "recent_scenes");
  std::string first, second;
  std::getline(recent, first);
  std::getline(recent, second);
  CHECK(first == scene.string());
  CHECK(second == std::filesystem::path(kMinimal).lexically_normal().string());
  std::filesystem::remove_all(dir);
}

TEST_CASE("Viewer: the scene reloads when its file changes on disk, a change that does not load leaves it running",
          "[viewer]") {
  const std::filesystem::path dir = test::fresh_temp_dir("reload");
  std::filesystem::create_directories(dir);
  const std::filesystem::path scene = dir / "scene.toml";
  std::filesystem::copy_file(kMinimal, scene);
  // Each edit waits for the viewer to have answered the one before (no fixed timings: a loaded
  // machine may take seconds for a frame); SIGINT ends the run as Ctrl-C would.
  const std::string log = (dir / "viewer.log").string();
  const std::string report = (dir / "report.json").string();
  const test::ProgramResult r = test::run_shell(
      "wait_for() { i=0; until grep -q \"$1\" \"$2\" 2>/dev/null; do i=$((i+1)); [ $i -gt 1200 ] && return 1; sleep 0.1; done; }; "
      "env XDG_CONFIG_HOME=" + (dir / "config").string() + " " FFDSIM_BINARY " run --headless --seconds 300 --frames " +
      (dir / "frames").string() + " --report " + report + " " + scene.string() + " > " + log + " 2>&1 & pid=$!; "
      "wait_for '\"mode\"' " + report + " && echo '# edited' >> " + scene.string() + " && "
      "wait_for 'changed on disk' " + log + " && echo 'broken = ' >> " + scene.string() + " && "
      "wait_for 'not reloaded' " + log + "; kill -INT $pid; wait $pid; status=$?; cat " + log + "; exit $status");
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.output, Catch::Contains("reloaded " + scene.string() + ": it changed on disk"));
  CHECK_THAT(r.output, Catch::Contains("not reloaded: " + scene.string() + ":"));
  std::filesystem::remove_all(dir);
}
