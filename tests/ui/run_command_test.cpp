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
