// `ffdsim simulate` end to end: the report it writes, and how it fails on bad input.
#include <catch2/catch.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "support/run_ffdsim.h"

namespace {

using Result = test::ProgramResult;
using test::run_ffdsim;

std::filesystem::path temp_dir(const std::string& name) { return test::fresh_temp_dir(name); }

const std::string kScenes = std::string(FFDSIM_SCENARIO_DIR) + "/scenes/";

}  // namespace

TEST_CASE("simulate writes a report with the documented fields", "[cli]") {
  const std::filesystem::path dir = temp_dir("report");
  const std::string report = (dir / "nested" / "report.json").string();
  const Result r = run_ffdsim("simulate " + kScenes + "shape_matching_pair.toml --steps 200 --report " + report +
                              " --obj-every 100 --out " + (dir / "frames").string());
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  std::ifstream in(report);
  REQUIRE(in);
  const nlohmann::json j = nlohmann::json::parse(in);
  CHECK(j.at("steps") == 200);
  CHECK(j.at("finite") == true);
  CHECK(j.at("state_hash").get<std::string>().size() == 16);
  CHECK(j.at("max_penetration_m").is_number());
  CHECK(j.at("max_gap_m").is_number());
  for (const char* field : {"between_objects", "within_objects", "rest_crossings"})
    CHECK(j.at("surface_intersections").at(field).is_number_unsigned());
  CHECK(j.at("energy").at("total_j").is_number());
  CHECK(j.at("stages").contains("dynamics"));
  CHECK(j.at("stages").contains("narrow_phase"));
  CHECK_FALSE(j.at("stages").at("narrow_phase").at("counters").contains("self_pairs_tested"));  // no self_collision
  for (const auto& [name, stage] : j.at("stages").items()) {
    INFO(name);
    CHECK(stage.at("p50_us").get<double>() <= stage.at("p99_us").get<double>());
    CHECK(stage.at("p99_us").get<double>() <= stage.at("max_us").get<double>());
  }
  // Frames at steps 0, 100 and 200 for each of the two objects.
  int frames = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir / "frames")) frames += entry.path().extension() == ".obj";
  CHECK(frames == 6);
  // The same run again prints the same state hash.
  const Result again = run_ffdsim("simulate " + kScenes + "shape_matching_pair.toml --steps 200 --quiet --report " +
                                  (dir / "again.json").string());
  REQUIRE(again.exit_code == 0);
  std::ifstream in2(dir / "again.json");
  CHECK(nlohmann::json::parse(in2).at("state_hash") == j.at("state_hash"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("simulate fails clearly on bad input", "[cli]") {
  SECTION("a scene with an out-of-range value names file, line and field") {
    const std::filesystem::path dir = temp_dir("bad_scene");
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "bad.toml") << "[simulation]\neffects = []\n\n[[object]]\nname = \"b\"\nshape = \"box\"\n"
                                       "size = [0.1, 0.1, 0.1]\ncell_size = -0.02\n[object.mass_spring]\n";
    const Result r = run_ffdsim("simulate " + (dir / "bad.toml").string());
    CHECK(r.exit_code == 2);
    CHECK_THAT(r.output, Catch::Contains("bad.toml:8:") && Catch::Contains("cell_size") && Catch::Contains("-0.02"));
    std::filesystem::remove_all(dir);
  }
  SECTION("a missing scene file") {
    const Result r = run_ffdsim("simulate /nonexistent/scene.toml");
    CHECK(r.exit_code != 0);
    CHECK_THAT(r.output, Catch::Contains("/nonexistent/scene.toml"));
  }
  SECTION("a bad step count") {
    const Result r = run_ffdsim("simulate --steps 0");
    CHECK(r.exit_code != 0);
    CHECK_THAT(r.output, Catch::Contains("--steps"));
  }
  SECTION("--obj-every without --out (the older names of --surfaces-every and --surfaces)") {
    const Result r = run_ffdsim("simulate --obj-every 10");
    CHECK(r.exit_code == 1);
    CHECK_THAT(r.output, Catch::Contains("--surfaces-every requires --surfaces"));
  }
  SECTION("no subcommand") {
    CHECK(run_ffdsim("").exit_code != 0);
  }
}

TEST_CASE("--help works for the program and the command", "[cli]") {
  const Result top = run_ffdsim("--help");
  CHECK(top.exit_code == 0);
  CHECK_THAT(top.output, Catch::Contains("simulate"));
  const Result sub = run_ffdsim("simulate --help");
  CHECK(sub.exit_code == 0);
  CHECK_THAT(sub.output, Catch::Contains("--obj-every"));
}

TEST_CASE("replay exits 0 when every assertion holds, 4 when one fails, 2 on a bad script", "[cli]") {
  const std::filesystem::path dir = temp_dir("replay");
  std::filesystem::create_directories(dir);
  const std::string scene = std::string(FFDSIM_TEST_DATA_DIR) + "/scenes/probe_and_grab.toml";
  auto write = [&](const std::string& name, const std::string& body) {
    const std::string path = (dir / name).string();
    std::ofstream(path) << "version = 1\nscene = \"" << scene << "\"\nsteps = 100\n" << body;
    return path;
  };
  const std::string report = (dir / "out" / "replay.json").string();
  Result r = run_ffdsim("replay --fast " + write("ok.toml", "[assert.stability]\nfinite = true\nspeed_max_m_s = 100.0\n") +
                        " --report " + report);
  INFO(r.output);
  CHECK(r.exit_code == 0);
  CHECK(r.output.find("PASS stability.finite") != std::string::npos);
  std::ifstream in(report);
  const nlohmann::json j = nlohmann::json::parse(in);
  CHECK(j.at("passed") == true);
  CHECK(j.at("steps") == 100);

  r = run_ffdsim("replay --fast " + write("fail.toml", "[assert.stability]\nspeed_max_m_s = 0.000001\n"));
  CHECK(r.exit_code == 4);
  CHECK(r.output.find("FAIL stability.speed_max_m_s") != std::string::npos);

  const std::string bad = write("bad.toml", "[[event]]\nat_ms = 5\nalpha = 2.0\n");
  r = run_ffdsim("replay --fast " + bad);
  CHECK(r.exit_code == 2);
  CHECK(r.output.find(bad + ":6:9: event[0].alpha: must be in [0, 1] (got 2)") != std::string::npos);

  // --window insists on a window: without a display it fails and says why.
  r = run_ffdsim("run --window --seconds 1 " + scene, "env -u DISPLAY -u WAYLAND_DISPLAY ");
  CHECK(r.exit_code == 3);
  CHECK(r.output.find("no display") != std::string::npos);
}

TEST_CASE("simulate shows progress with rate and time left on a terminal, and nothing in a log or with -q", "[cli]") {
  const std::string scene = kScenes + "two_teapots.toml";
  // `script` gives the program a pseudo-terminal; CI would turn the bar off.
  auto on_terminal = [](const std::string& arguments) {
    return test::run_shell("env -u CI script -qfec '" FFDSIM_BINARY " " + arguments + "' /dev/null");
  };
  Result r = on_terminal("simulate " + scene + " --steps 1500");
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.output, Catch::Contains("\r\033[Ktwo_teapots"));
  CHECK_THAT(r.output, Catch::Contains("1500/1500  "));
  CHECK_THAT(r.output, Catch::Contains(" steps/s"));
  CHECK_THAT(r.output, Catch::Contains("state_hash"));
  r = on_terminal("simulate " + scene + " --steps 200 -q");
  CHECK(r.output.find("steps/s") == std::string::npos);
  r = run_ffdsim("simulate " + scene + " --steps 200");  // a pipe, as in a log
  CHECK(r.output.find("steps/s") == std::string::npos);
  CHECK(r.output.find('\r') == std::string::npos);
}

TEST_CASE("simulate estimates memory and step time of a large scene before its first step, and says what makes it "
          "smaller", "[cli]") {
  const std::filesystem::path dir = temp_dir("large");
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "block.toml") << "[simulation]\neffects = [\"gravity\"]\n[[object]]\nname = \"block\"\nshape = "
                                       "\"box\"\nsize = [1.0, 1.0, 1.0]\ncell_size = 0.025\nfill_interior = true\n"
                                       "[object.mass_spring]\n";
  Result r = run_ffdsim("simulate " + (dir / "block.toml").string() + " --steps 2");
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.output, Catch::Contains("a large scene: 74088 lattice nodes, 68921 cells;"));
  CHECK_THAT(r.output, Catch::Contains("GB in memory now; a step takes about"));
  CHECK_THAT(r.output, Catch::Contains("a larger cell_size in each [[object]] makes it smaller"));
  CHECK(r.output.find("a large scene") < r.output.find("state_hash"));
  // The default scene is not large: no estimate.
  r = run_ffdsim("simulate " + kScenes + "two_teapots.toml --steps 2");
  CHECK(r.output.find("a large scene") == std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST_CASE("a mesh wound inside out is turned outward with a note in the log, and simulates as the outward one", "[cli]") {
  const std::filesystem::path dir = temp_dir("inside_out");
  std::filesystem::create_directories(dir);
  // A 10 cm cube, 8 vertices, 12 triangles, outward and inside out.
  const std::string vertices = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0.1 0.1 0\nv 0 0 0.1\nv 0.1 0 0.1\nv 0 0.1 0.1\nv 0.1 0.1 0.1\n";
  const std::string outward = "f 1 3 2\nf 2 3 4\nf 5 6 7\nf 6 8 7\nf 1 2 5\nf 2 6 5\nf 3 7 4\nf 4 7 8\nf 1 5 3\nf 3 5 7\n"
                              "f 2 4 6\nf 4 8 6\n";
  std::string inward;
  for (std::size_t at = 0; at < outward.size();) {  // "f a b c" -> "f a c b"
    const std::size_t end = outward.find('\n', at);
    const std::string line = outward.substr(at, end - at);
    const std::size_t b = line.find(' ', 2), c = line.find(' ', b + 1);
    inward += line.substr(0, b) + line.substr(c) + line.substr(b, c - b) + "\n";
    at = end + 1;
  }
  std::ofstream(dir / "outward.obj") << vertices << outward;
  std::ofstream(dir / "inward.obj") << vertices << inward;
  auto scene = [&](const std::string& mesh) {
    const std::string path = (dir / (mesh + ".toml")).string();
    std::ofstream(path) << "[simulation]\neffects = [\"gravity\", \"planes\"]\n[[object]]\nname = \"cube\"\nmesh = \"" << mesh
                        << ".obj\"\ncell_size = 0.025\nposition = [0.0, 0.1, 0.0]\n[object.mass_spring]\n";
    return path;
  };
  const Result out = run_ffdsim("simulate " + scene("outward") + " --steps 300");
  const Result in = run_ffdsim("simulate " + scene("inward") + " --steps 300");
  INFO(out.output << "\n" << in.output);
  REQUIRE(out.exit_code == 0);
  REQUIRE(in.exit_code == 0);
  CHECK_THAT(in.output, Catch::Contains("inward.obj): 8 vertices, 12 triangles; wound inside out (enclosed volume "
                                        "-0.001 m^3): turned outward"));
  CHECK(out.output.find("inside out") == std::string::npos);
  const auto hash = [](const std::string& text) { return text.substr(text.find("state_hash"), 27); };
  CHECK(hash(in.output) == hash(out.output));
}

TEST_CASE("objects that overlap at the start are named with the depth, by simulate, run and replay", "[cli]") {
  const std::filesystem::path dir = temp_dir("overlap");
  std::filesystem::create_directories(dir);
  // Two 10 cm balls 6 cm apart overlap by 4 cm; a third sits 5 mm into the floor.
  const std::string scene = (dir / "overlap.toml").string();
  std::ofstream(scene) << "[simulation]\neffects = [\"gravity\", \"planes\", \"inter_collision\"]\n"
                          "[[group]]\nname = \"ball\"\ncount = 2\nshape = \"sphere\"\nradius = 0.05\n"
                          "layout = { grid = [2, 1, 1], spacing = [0.06, 0.0, 0.0], centre = [0.0, 0.2, 0.0] }\n"
                          "[group.mass_spring]\n"
                          "[[object]]\nname = \"sunk\"\nshape = \"sphere\"\nradius = 0.05\nposition = [0.5, 0.045, 0.0]\n"
                          "[object.mass_spring]\n"
                          "[[plane]]\nname = \"floor\"\nnormal = [0.0, 1.0, 0.0]\noffset = 0.0\n";
  Result r = run_ffdsim("simulate " + scene + " --steps 1");
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.output, Catch::Contains("warning: objects 'ball_0' and 'ball_1' overlap at the start by "));
  CHECK_THAT(r.output, Catch::Contains("move them apart (a [[group]]'s spacing smaller than its objects does this)"));
  CHECK_THAT(r.output, Catch::Contains("warning: object 'sunk' starts "));
  CHECK_THAT(r.output, Catch::Contains(" mm below the plane 'floor'"));
  // The depth: 4 cm on the exact surfaces, up to their sampling (the search reaches one cell).
  const std::size_t at = r.output.find("overlap at the start by ") + 24;
  const double depth_mm = std::stod(r.output.substr(at));
  CHECK(depth_mm > 10.0);
  r = run_ffdsim("run --headless --seconds 0.1 " + scene);
  CHECK_THAT(r.output, Catch::Contains(scene + ": warning: objects 'ball_0' and 'ball_1' overlap at the start"));
  std::ofstream(dir / "replay.toml") << "version = 1\nscene = \"overlap.toml\"\nsteps = 5\n";
  r = run_ffdsim("replay --fast " + (dir / "replay.toml").string());
  CHECK_THAT(r.output, Catch::Contains("ffdsim: warning: " + scene + ": objects 'ball_0' and 'ball_1' overlap"));
  // A scene whose objects start apart says nothing of the kind.
  r = run_ffdsim("simulate " + kScenes + "two_teapots.toml --steps 1");
  CHECK(r.output.find("overlap at the start") == std::string::npos);
  CHECK(r.output.find("below the plane") == std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST_CASE("the README's own-mesh walkthrough scene and its replay run as it says, on a 100 mm cube in millimetres",
          "[cli][timed]") {
  std::ifstream readme(std::string(FFDSIM_SCENARIO_DIR) + "/../README.md");
  REQUIRE(readme);
  const std::string text((std::istreambuf_iterator<char>(readme)), std::istreambuf_iterator<char>());
  const std::size_t begin = text.find("<!-- walkthrough:begin -->\n```toml\n");
  const std::size_t end = text.find("```\n<!-- walkthrough:end -->");
  REQUIRE(begin != std::string::npos);
  REQUIRE(end != std::string::npos);
  const std::string scene = text.substr(begin + 35, end - begin - 35);
  const std::filesystem::path dir = temp_dir("walkthrough");
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "my_scene.toml") << scene;
  std::ofstream(dir / "my_part.obj") << "v 0 0 0\nv 100 0 0\nv 0 100 0\nv 100 100 0\nv 0 0 100\nv 100 0 100\n"
                                        "v 0 100 100\nv 100 100 100\nf 1 3 2\nf 2 3 4\nf 5 6 7\nf 6 8 7\nf 1 2 5\n"
                                        "f 2 6 5\nf 3 7 4\nf 4 7 8\nf 1 5 3\nf 3 5 7\nf 2 4 6\nf 4 8 6\n";
  const Result r = run_ffdsim("simulate " + (dir / "my_scene.toml").string() + " --steps 2000");
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.output, Catch::Contains("lattice 11x11x11 of 0.01 m cells"));  // as step 5 says
  CHECK_THAT(r.output, Catch::Contains("finite true"));
  CHECK(r.output.find("warning") == std::string::npos);
  // The README's replay of that scene: a live alpha / beta change and a latency assertion,
  // checked in fast mode (the sanitizer builds' steps are far slower: latency reported there).
  const std::size_t replay_begin = text.find("<!-- replay-walkthrough:begin -->\n```toml\n");
  const std::size_t replay_end = text.find("```\n<!-- replay-walkthrough:end -->");
  REQUIRE(replay_begin != std::string::npos);
  REQUIRE(replay_end != std::string::npos);
  const std::size_t body = replay_begin + std::string("<!-- replay-walkthrough:begin -->\n```toml\n").size();
  std::ofstream(dir / "my_replay.toml") << text.substr(body, replay_end - body);
#ifdef FFDSIM_SANITIZED
  const std::string latency = " --skip-latency";
#else
  const std::string latency;
#endif
  const Result replay = run_ffdsim("replay --fast " + (dir / "my_replay.toml").string() + latency);
  INFO(replay.output);
  CHECK(replay.exit_code == 0);
  CHECK_THAT(replay.output, Catch::Contains("latency.compute_p99_us"));
  CHECK_THAT(replay.output, Catch::Contains("PASS contact.max_penetration_m"));
  CHECK_THAT(replay.output, Catch::Contains("passed: all"));
  std::filesystem::remove_all(dir);
}
