// `cmake --install`: the program and what it reads, under a prefix, found from there.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "support/run_ffdsim.h"

TEST_CASE("cmake --install puts ffdsim and its scenes under a prefix, and the installed ffdsim runs from there", "[cli]") {
  const std::filesystem::path prefix = test::fresh_temp_dir("install");
  test::ProgramResult r = test::run_shell("cmake --install " FFDSIM_BUILD_DIR " --prefix " + prefix.string());
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  const std::filesystem::path program = prefix / "bin" / "ffdsim";
  REQUIRE(std::filesystem::exists(program));
  for (const char* file : {"scenes/two_teapots.toml", "meshes/teapot.obj", "replays/poke_teapot.toml",
                           "ui_scripts/ui_demo.toml", "bridges/ffdsim_device.py"})
    CHECK(std::filesystem::exists(prefix / "share" / "ffdsim" / file));
  CHECK(std::filesystem::exists(prefix / "share" / "doc" / "ffdsim" / "README.md"));
  // From another folder: the default scene is the installed one, its mesh found beside it.
  const std::string report = (prefix / "report.json").string();
  r = test::run_shell("cd / && " + program.string() + " run --headless --seconds 0.2 -q --report " + report);
  REQUIRE(r.exit_code == 0);
  std::ifstream in(report);
  CHECK(nlohmann::json::parse(in).at("scene") == (prefix / "share" / "ffdsim" / "scenes" / "two_teapots.toml").string());
  r = test::run_shell("cd / && " + program.string() + " simulate -q --steps 5 " +
                      (prefix / "share" / "ffdsim" / "scenes" / "happy_buddha.toml").string());
  CHECK(r.exit_code == 0);
  std::filesystem::remove_all(prefix);
}
