// Every command against the table of exit codes (docs/command-line.md): 0 success, 1 usage (the command
// line), 2 input (a file given), 3 runtime (the run failed), 4 a check failed.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <string>

#include "support/run_ffdsim.h"

namespace {

const std::string kData = std::string(FFDSIM_TEST_DATA_DIR) + "/scenes/";
const std::string kMinimal = kData + "minimal.toml";
const std::string kDiverging = kData + "diverging.toml";

// The command line, its exit code and a piece of what it must say.
void check_exit(const std::string& arguments, int expected, const std::string& says, const std::string& prefix = "") {
  const test::ProgramResult r = test::run_ffdsim(arguments, prefix);
  INFO("ffdsim " << arguments << "\n" << r.output);
  CHECK(r.exit_code == expected);
  CHECK_THAT(r.output, Catch::Contains(says));
}

}  // namespace

TEST_CASE("Exit codes: the program without a known command is a usage error, --help succeeds", "[cli]") {
  check_exit("", 1, "a command is required (simulate, replay, run, bench, accuracy, piles, hard-cases, device-sim, sweep)");
  check_exit("frobnicate", 1, "unknown command 'frobnicate'");
  check_exit("--frobnicate", 1, "unknown option '--frobnicate'");
  check_exit("--help", 0, "simulate");
  for (const char* command : {"simulate", "replay", "run", "bench", "accuracy", "piles", "hard-cases", "device-sim"})
    check_exit(std::string(command) + " --help", 0, "Usage");
}

TEST_CASE("Exit codes: simulate", "[cli]") {
  check_exit("simulate " + kMinimal + " --steps 5 -q", 0, "");
  check_exit("simulate --steps 0", 1, "--steps: Value 0 not in range");
  check_exit("simulate " + kMinimal + " extra.toml", 1, "extra.toml");
  check_exit("simulate --obj-every 5", 1, "--surfaces-every requires --surfaces");
  check_exit("simulate missing.toml", 2, "missing.toml: cannot open scene file");
  check_exit("simulate " + kData + "bad_range.toml", 2, "bad_range.toml:");
  check_exit("simulate " + kDiverging + " --steps 5 -q", 3, "");
}

TEST_CASE("Exit codes: run", "[cli]") {
  check_exit("run --headless --seconds 0.2 -q " + kMinimal, 0, "");
  check_exit("run --seconds 0", 1, "--seconds: Value 0 not in range");
  check_exit("run --window --headless", 1, "--headless excludes --window");
  check_exit("run --headless " + kMinimal + " extra.toml", 1, "extra.toml");
  check_exit("run --headless --device tcp://x " + kMinimal, 1, "expected udp://HOST:PORT");
  check_exit("run --headless --seconds 0.2 missing.toml", 2, "missing.toml: cannot open scene file");
  check_exit("run --headless --seconds 0.2 --input missing_script.toml " + kMinimal, 2, "missing_script.toml");
  check_exit("run --window --seconds 0.2 " + kMinimal, 3, "no display", "env -u DISPLAY -u WAYLAND_DISPLAY ");
  check_exit("run --headless --seconds 0.2 " + kDiverging, 3, "");
}

TEST_CASE("Exit codes: replay", "[cli]") {
  const std::filesystem::path dir = test::fresh_temp_dir("exit_codes_replay");
  std::filesystem::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& scene, const std::string& body) {
    const std::string path = (dir / name).string();
    std::ofstream(path) << "version = 1\nscene = \"" << scene << "\"\nsteps = 20\n" << body;
    return path;
  };
  check_exit("replay --fast " + write("ok.toml", kMinimal, "[assert.stability]\nfinite = true\n"), 0, "PASS");
  check_exit("replay --fast --realtime " + write("ok2.toml", kMinimal, ""), 1, "excludes");
  check_exit("replay", 1, "script is required");
  check_exit("replay --fast missing_replay.toml", 2, "missing_replay.toml: cannot open replay script");
  check_exit("replay --fast " + write("diverging.toml", kDiverging, ""), 3, "non-finite value at step");
  check_exit("replay --fast " + write("fail.toml", kData + "probe_and_grab.toml", "[assert.stability]\nspeed_max_m_s = 1e-9\n"), 4,
             "FAIL stability.speed_max_m_s");
  // --response runs the script under the other response: two boxes resting on each other
  // tremble under the paper's (13-15 mm/s RMS) and come to rest under the solver's.
  const std::string rest = (dir / "rest.toml").string();
  std::ofstream(rest) << "version = 1\nscene = \"" << kData << "probe_and_grab.toml\"\nduration_ms = 1000\n"
                      << "[assert.motion]\nfrom_ms = 500\nrms_speed_max_m_s = 0.001\n";
  check_exit("replay --fast --response paper " + rest, 4, "FAIL motion.rms_speed_max_m_s");
  check_exit("replay --fast --response solver " + rest, 0, "under contact response solver");
  check_exit("replay --fast --response other " + rest, 1, "--response");
  std::filesystem::remove_all(dir);
}

TEST_CASE("Exit codes: bench and accuracy", "[cli]") {
  check_exit("bench --only nope", 1, "--only: unknown scenario 'nope'");
  check_exit("bench --repetitions 0", 1, "--repetitions");
  check_exit("bench --only happy_buddha --update-docs missing_folder/bench.md", 2, "missing_folder/bench.md: cannot write");
  check_exit("bench --only happy_buddha --compare missing_reference.json", 1, "--compare: File does not exist");
  {  // a reference that is not a bench.json: named, before any benchmarking
    const std::filesystem::path dir = test::fresh_temp_dir("exit_codes_bench");
    std::filesystem::create_directories(dir);
    const std::string not_json = (dir / "not_json.json").string(), not_bench = (dir / "not_bench.json").string();
    std::ofstream(not_json) << "{ scenarios";
    std::ofstream(not_bench) << "{\"scenarios\": []}";
    check_exit("bench --only happy_buddha --compare " + not_json, 2, "not_json.json: not valid JSON");
    check_exit("bench --only happy_buddha --compare " + not_bench, 2, "not_bench.json: not a bench.json");
  }
  check_exit("accuracy --levels 9", 1, "--levels: Value 9 not in range");
  check_exit("accuracy missing.toml", 2, "missing.toml: cannot open scene file");
  const std::filesystem::path dir = test::fresh_temp_dir("exit_codes_accuracy");
  check_exit("accuracy -q --steps 20 --levels 2 --responses paper --out " + dir.string() + " " + kDiverging, 3, "");
  std::filesystem::remove_all(dir);
}

TEST_CASE("Exit codes: piles", "[cli]") {
  check_exit("piles --steps 5", 1, "--steps: Value 5 not in range");
  check_exit("piles --levels 9", 1, "--levels: Value 9 not in range");
  check_exit("piles --responses exact", 1, "--responses");
  check_exit("piles --seeds 1 --levels 2 --update-docs missing_folder/piles.md", 2, "missing_folder/piles.md: cannot write");
  // --require-clean's failing path: one second of pile 1 at level 2 ends with its objects
  // still falling, so the check fails and the pile is listed with its reasons.
  const std::filesystem::path dir = test::fresh_temp_dir("exit_codes_piles");
  check_exit("piles -q --seeds 1 --levels 2 --responses paper --steps 1000 --require-clean --out " + dir.string(), 4,
             "check failed: 1 of 1 runs not clean");
  CHECK_THAT(test::read_text(dir / "piles.md"), Catch::Contains("- pile 1, paper level 2: not at rest at the end;"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("Exit codes: hard-cases", "[cli]") {
  check_exit("hard-cases --responses exact", 1, "--responses");
  check_exit("hard-cases missing.toml", 2, "missing.toml");
  check_exit("hard-cases --update-docs missing_folder/hard_cases.md", 2, "missing_folder/hard_cases.md: cannot write");
  const std::filesystem::path dir = test::fresh_temp_dir("exit_codes_hard_cases");
  std::filesystem::create_directories(dir);
  const std::string hard = std::string(FFDSIM_SCENARIO_DIR) + "/replays/hard/";
  // A case that passes, one row per response, into a results page.
  check_exit("hard-cases -q --responses paper solver --update-docs " + (dir / "hard.md").string() + " " + hard +
                 "alpha_zero_head_on.toml",
             0, "| `alpha_zero_head_on` | solver | pass |");
  CHECK_THAT(test::read_text(dir / "hard.md"), Catch::Contains("2 of 2 runs passed."));
  // A case whose assertion fails: exit 4, the row names the first failure.
  const std::string failing = (dir / "fails.toml").string();
  std::ofstream(failing) << "version = 1\nscene = \"" << kData << "probe_and_grab.toml\"\nduration_ms = 200\n"
                         << "[assert.stability]\nspeed_max_m_s = 1e-9\n";
  check_exit("hard-cases -q " + failing + " --responses paper", 4, "| `fails` | paper | **FAIL** |");
  // A recording keeps the response it was recorded with: refused, naming the file.
  const std::string recording = (dir / "session.toml").string();
  check_exit("run --headless --seconds 0.2 --threads 1 --record " + recording + " " + kMinimal, 0, "");
  check_exit("hard-cases -q " + recording, 2, "session.toml: a recording replays the response it was recorded with");
  std::filesystem::remove_all(dir);
}

TEST_CASE("Exit codes: device-sim", "[cli][device][realtime]") {
  const std::string script = std::string(FFDSIM_SCENARIO_DIR) + "/replays/device_press.toml";
  check_exit("device-sim " + script + " --to udp://127.0.0.1", 1, "expected udp://HOST:PORT");
  check_exit("device-sim " + script + " --to udp://127.0.0.1:9 --drop 2", 1, "--drop");
  check_exit("device-sim missing_path.toml --to udp://127.0.0.1:9", 2, "missing_path.toml");
  // Nobody listens on the discard port: no force comes back.
  check_exit("device-sim " + script + " --to udp://127.0.0.1:9 --wait-ms 50", 3, "no force came back within 50 ms");
}
