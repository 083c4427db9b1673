// Output files of the long-running commands: `--update-docs FILE` writes a results page stamped
// with the command that made it, the commit, the machine and the date; a wrong path fails
// before the run; a file is written through a temporary renamed over it, and a failed rename
// is reported as such.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <string>

#include "support/run_ffdsim.h"

TEST_CASE("Results page: piles --update-docs writes its table under a stamp of command, commit, machine and date", "[cli]") {
  const std::filesystem::path dir = test::fresh_temp_dir("results_page");
  std::filesystem::create_directories(dir);
  const std::filesystem::path page = dir / "piles.md";
  std::ofstream(page) << "the old page\n";
  const test::ProgramResult r =
      test::run_ffdsim("piles --seeds 1 --objects 2 --levels 2 --responses paper --steps 1000 --quiet --out " +
                       (dir / "out").string() + " --update-docs " + page.string());
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  const std::string text = test::read_text(page);
  INFO(text);
  CHECK_THAT(text, Catch::StartsWith("# Random piles\n"));
  CHECK_THAT(text, Catch::Contains("- Command: `ffdsim piles --seeds 1 --objects 2 --levels 2 --responses paper "
                                   "--steps 1000 --quiet --out "));
  CHECK_THAT(text, Catch::Contains("\n- Commit: "));  // a temporary folder: "unknown (not a git checkout)"
  CHECK_THAT(text, Catch::Contains("\n- Machine: "));
  CHECK_THAT(text, Catch::Contains("\n- Date: 20"));
  CHECK_THAT(text, Catch::Contains("| Response | Level | Clean piles"));
  CHECK_THAT(text, !Catch::Contains("the old page"));
  CHECK_FALSE(std::filesystem::exists(dir / "piles.md.partial"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("Output files: a file that cannot be replaced is an error naming it and the reason, and no temporary is left", "[cli]") {
  const std::filesystem::path dir = test::fresh_temp_dir("output_blocked");
  std::filesystem::create_directories(dir / "out" / "piles.md");  // a folder where the table goes
  const test::ProgramResult r = test::run_ffdsim("piles --seeds 1 --objects 2 --levels 2 --responses paper --steps 1000 "
                                                 "--quiet --out " + (dir / "out").string());
  INFO(r.output);
  CHECK(r.exit_code != 0);
  CHECK_THAT(r.output, Catch::Contains("piles.md: cannot write (Is a directory)"));
  CHECK_FALSE(std::filesystem::exists(dir / "out" / "piles.md.partial"));
  std::filesystem::remove_all(dir);
}
