// Output files of the long-running commands: `--update-readme` replaces its section of the file
// as it is when the run finishes, so that what was written into it meanwhile is kept; a file
// is written through a temporary renamed over it, and a failed rename is reported as such.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <string>

#include "support/run_ffdsim.h"

TEST_CASE("Update README: piles replaces its section and keeps what was written into the file meanwhile", "[cli]") {
  const std::filesystem::path dir = test::fresh_temp_dir("readme_update");
  std::filesystem::create_directories(dir);
  const std::filesystem::path readme = dir / "README.md";
  std::ofstream(readme) << "# Notes\n<!-- piles:table:begin -->\nthe old table\n<!-- piles:table:end -->\nafter the table\n";
  // The run goes on in the background (a second or more: 2 objects, 1000 steps) while a line is
  // added to the file; `wait` gives its exit code.
  const std::string command = std::string(FFDSIM_BINARY) + " piles --seeds 1 --objects 2 --levels 2 --responses paper " +
                              "--steps 1000 --quiet --out " + (dir / "out").string() + " --update-readme " +
                              readme.string() + " & sleep 0.2; echo 'written during the run' >> " + readme.string() +
                              "; wait $!";
  const test::ProgramResult r = test::run_shell(command);
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  const std::string text = test::read_text(readme);
  INFO(text);
  CHECK_THAT(text, Catch::StartsWith("# Notes\n<!-- piles:table:begin -->\n"));
  CHECK_THAT(text, Catch::Contains("| Response | Level | Clean piles"));
  CHECK_THAT(text, !Catch::Contains("the old table"));
  CHECK_THAT(text, Catch::Contains("<!-- piles:table:end -->\nafter the table\n"));
  CHECK_THAT(text, Catch::Contains("written during the run"));
  CHECK_FALSE(std::filesystem::exists(dir / "README.md.partial"));
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
