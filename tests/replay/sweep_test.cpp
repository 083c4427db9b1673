// Sweep files (replay/src/sweep.cpp) and `ffdsim sweep` end to end on this machine.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <cstdlib>
#include <map>
#include <set>
#include <string>

#include "ffd/sweep.h"
#include "support/run_ffdsim.h"

namespace {

namespace fs = std::filesystem;
const std::string kSweeps = std::string(FFDSIM_TEST_DATA_DIR) + "/sweeps/";

// The error a sweep text gives, or "" if it reads.
std::string sweep_error(const std::string& text) {
  try {
    ffd::parse_sweep(text, "s.toml", kSweeps);
  } catch (const ffd::InputError& e) {
    return e.what();
  }
  return "";
}

const std::string kHead = "format = \"ffdsim-sweep\"\nversion = 1\nreplay = \"drop.toml\"\n";

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  REQUIRE(in);
  return nlohmann::json::parse(in);
}

// Each job's result without what depends on the machine or the run's folder.
std::map<std::string, nlohmann::json> simulation_results(const fs::path& dir) {
  std::map<std::string, nlohmann::json> out;
  for (const auto& entry : fs::directory_iterator(dir / "results")) {
    if (entry.path().extension() != ".json") continue;
    nlohmann::json j = read_json(entry.path());
    j["metrics"].erase("step_p50_us");
    j["metrics"].erase("step_p99_us");
    out[entry.path().stem().string()] = j;
  }
  return out;
}

}  // namespace

TEST_CASE("Sweep files: a grid is every combination, the last parameter fastest, in the file's order", "[sweep]") {
  const ffd::SweepPlan plan = ffd::load_sweep_file(kSweeps + "drop_alpha_beta.toml");
  REQUIRE(plan.parameters == std::vector<std::string>{"alpha", "beta"});
  REQUIRE(plan.jobs.size() == 9);
  CHECK(plan.jobs[0].id == "0001");
  CHECK(plan.jobs[8].id == "0009");
  CHECK(ffd::sweep_value_text(plan.jobs[0].values[0]) == "0.2");
  CHECK(ffd::sweep_value_text(plan.jobs[1].values[0]) == "0.2");
  CHECK(ffd::sweep_value_text(plan.jobs[1].values[1]) == "0.5");
  CHECK(ffd::sweep_value_text(plan.jobs[3].values[0]) == "0.6");
  CHECK(ffd::sweep_value_text(plan.jobs[8].values[0]) == "1");
  CHECK(fs::path(plan.replay).is_absolute());
  // A range's values as a user would type them.
  const ffd::SweepPlan ten = ffd::parse_sweep(kHead + "[parameters]\nalpha = { from = 0.1, to = 1.0, count = 10 }\n", "s.toml", kSweeps);
  REQUIRE(ten.jobs.size() == 10);
  CHECK(ffd::sweep_value_text(ten.jobs[2].values[0]) == "0.3");
  CHECK(ffd::sweep_value_text(ten.jobs[8].values[0]) == "0.9");
  // Order as written, not as sorted.
  const ffd::SweepPlan reversed = ffd::parse_sweep(kHead + "[parameters]\nbeta = [0.1]\nalpha = [0.3, 0.4]\n", "s.toml", kSweeps);
  CHECK(reversed.parameters == std::vector<std::string>{"beta", "alpha"});
}

TEST_CASE("Sweep files: a list of points, per-object keys, integers, flags and names", "[sweep]") {
  const ffd::SweepPlan plan = ffd::parse_sweep(kHead + "[[point]]\nalpha = 0.1\nhigh.stiffness = 2000.0\naccuracy = 3\n"
                                                       "response = \"solver\"\nedge_contacts = false\n"
                                                       "[[point]]\nalpha = 0.9\nhigh.stiffness = 8000\naccuracy = 5\n"
                                                       "response = \"paper\"\nedge_contacts = true\n",
                                               "s.toml", kSweeps);
  REQUIRE(plan.jobs.size() == 2);
  CHECK(ffd::sweep_value_text(plan.jobs[1].values[1]) == "8000");
  CHECK(ffd::sweep_value_text(plan.jobs[1].values[2]) == "5");
  CHECK(ffd::sweep_value_text(plan.jobs[0].values[3]) == "solver");
  CHECK(ffd::sweep_value_text(plan.jobs[0].values[4]) == "false");
  // Applied to the replay's scene: the compiled model has the point's values.
  const ffd::LoadedReplay replay = ffd::load_sweep_job(plan, plan.jobs[0]);
  CHECK(replay.model.settings.alpha == 0.1);
  CHECK(replay.model.settings.accuracy == ffd::Accuracy::SampleNodes);
  CHECK(replay.model.settings.response == ffd::ContactResponse::Solver);
  CHECK_FALSE(replay.model.settings.edge_contacts);
  CHECK(replay.script.scene.objects[1].mass_spring.stiffness == 2000.0);
  CHECK(replay.script.scene.objects[0].mass_spring.stiffness != 2000.0);
  CHECK(replay.script.hashes.empty());
}

TEST_CASE("Sweep files: bad ones name the file, line, column and field", "[sweep]") {
  CHECK_THAT(sweep_error(kHead + "[parameters]\nalpah = [0.1]\n"),
             Catch::Contains("s.toml:5:9: parameters.alpah: not a parameter") && Catch::Contains("did you mean 'alpha'"));
  CHECK_THAT(sweep_error(kHead + "[parameters]\nalpha = [0.1, 1.5]\n"),
             Catch::Contains("s.toml:5:15: parameters.alpha[1]: must be in [0, 1] (got 1.5)"));
  CHECK_THAT(sweep_error(kHead + "[parameters]\naccuracy = [2.5]\n"), Catch::Contains("expected an integer"));
  CHECK_THAT(sweep_error(kHead + "[parameters]\nresponse = [\"fast\"]\n"), Catch::Contains("must be one of paper, solver"));
  CHECK_THAT(sweep_error(kHead + "[parameters]\nalpha = { from = 0.1, to = 0.5 }\n"),
             Catch::Contains("parameters.alpha.count: missing required key"));
  CHECK_THAT(sweep_error(kHead + "[parameters]\nalpha = []\n"), Catch::Contains("names no value"));
  CHECK_THAT(sweep_error(kHead + "[parameters]\nalpha = { from = 0.0, to = 1.0, count = 400 }\n"
                                 "beta = { from = 0.0, to = 1.0, count = 400 }\n"),
             Catch::Contains("a grid of 160000 jobs; at most 100000"));
  CHECK_THAT(sweep_error(kHead), Catch::Contains("missing: [parameters]"));
  CHECK_THAT(sweep_error(kHead + "[parameters]\nalpha = [0.1]\n[[point]]\nalpha = 0.2\n"), Catch::Contains("not both"));
  CHECK_THAT(sweep_error(kHead + "[[point]]\nalpha = 0.2\n[[point]]\nbeta = 0.2\n"),
             Catch::Contains("point[1].alpha: missing required key"));
  CHECK_THAT(sweep_error("format = \"ffdsim-sweep\"\nversion = 1\n[parameters]\nalpha = [0.1]\n"),
             Catch::Contains("replay: missing required key"));
  CHECK_THAT(sweep_error("format = \"ffdsim-sweep\"\nversion = 2\nreplay = \"drop.toml\"\n[parameters]\nalpha = [0.1]\n"),
             Catch::Contains("s.toml:2:11: version: unsupported version 2; this program reads version 1"));
  CHECK_THAT(sweep_error("format = \"ffdsim-replay\"\nversion = 1\nreplay = \"drop.toml\"\n[parameters]\nalpha = [0.1]\n"),
             Catch::Contains("format: expected \"ffdsim-sweep\""));
  CHECK_THAT(sweep_error(kHead + "[parameters]\nalpha = [0.1\n"), Catch::Contains("s.toml:5:") && Catch::Contains("TOML syntax error"));
  // A parameter the replay sets itself would be overridden: refused when the job loads.
  const ffd::SweepPlan plan = ffd::parse_sweep(
      "format = \"ffdsim-sweep\"\nversion = 1\nreplay = \"" + std::string(FFDSIM_SCENARIO_DIR) +
          "/replays/sweep_alpha_beta.toml\"\n[parameters]\nalpha = [0.1]\n",
      "s.toml", kSweeps);
  CHECK_THROWS_WITH(ffd::load_sweep_job(plan, plan.jobs[0]),
                    Catch::Contains("alpha: the replay") && Catch::Contains("sets it itself"));
  // The same, for one object: only that object's own stiffness command counts.
  const std::string alpha_beta = std::string(FFDSIM_SCENARIO_DIR) + "/replays/sweep_alpha_beta.toml";
  const auto stiffness_of = [&](const std::string& object) {
    return ffd::parse_sweep("format = \"ffdsim-sweep\"\nversion = 1\nreplay = \"" + alpha_beta + "\"\n[parameters]\n" +
                                object + ".stiffness = [3000.0]\n",
                            "s.toml", kSweeps);
  };
  const ffd::SweepPlan low = stiffness_of("teapot_low"), high = stiffness_of("teapot_high");
  CHECK_NOTHROW(ffd::load_sweep_job(low, low.jobs[0]));
  CHECK_THROWS_WITH(ffd::load_sweep_job(high, high.jobs[0]), Catch::Contains("sets it itself"));
  // A [mass_spring] key where no object has one is an error, not a value left unused.
  const fs::path dir = test::fresh_temp_dir("sweep_shape_matching");
  fs::create_directories(dir);
  std::ofstream(dir / "r.toml") << "format = \"ffdsim-replay\"\nversion = 1\nscene = \"" << FFDSIM_SCENARIO_DIR
                                << "/scenes/shape_matching_pair.toml\"\nsteps = 10\n";
  const auto shape_sweep = [&](const std::string& key) {
    return ffd::parse_sweep("format = \"ffdsim-sweep\"\nversion = 1\nreplay = \"r.toml\"\n[parameters]\n" + key +
                                " = [1000.0]\n",
                            "s.toml", dir.string());
  };
  const ffd::SweepPlan all = shape_sweep("stiffness"), ball = shape_sweep("ball.stiffness");
  CHECK_THROWS_WITH(ffd::load_sweep_job(all, all.jobs[0]), Catch::Contains("the replay's scene has no mass-spring object"));
  CHECK_THROWS_WITH(ffd::load_sweep_job(ball, ball.jobs[0]), Catch::Contains("object 'ball' is not a mass-spring object"));
  const ffd::SweepPlan nobody = ffd::parse_sweep(kHead + "[parameters]\nmiddle.damping = [0.1]\n", "s.toml", kSweeps);
  CHECK_THROWS_WITH(ffd::load_sweep_job(nobody, nobody.jobs[0]), Catch::Contains("no object 'middle' (its objects: low, high)"));
}

TEST_CASE("ffdsim sweep: a 3 x 3 grid planned, run and merged, a re-run skipping what is done, a stopped sweep resumed",
          "[sweep][cli]") {
  const fs::path dir = test::fresh_temp_dir("sweep_grid");
  const std::string out = (dir / "sweep").string();
  test::ProgramResult r = test::run_ffdsim("sweep plan " + kSweeps + "drop_alpha_beta.toml --out " + out);
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  for (const char* file : {"plan.json", "jobs.tsv", "sweep.sbatch", "parallel.sh"}) CHECK(fs::exists(fs::path(out) / file));
  CHECK_THAT(r.output, Catch::Contains("9 jobs over 2 parameters") && Catch::Contains("sbatch --wait"));
  r = test::run_ffdsim("sweep status " + out);
  CHECK(r.exit_code == 4);
  CHECK_THAT(r.output, Catch::Contains("0 done, 0 failed, 9 missing"));

  // A sweep stopped after three jobs (run-one by hand, as an engine would), then resumed.
  for (const char* id : {"0001", "0005", "0009"}) REQUIRE(test::run_ffdsim("sweep run-one " + out + " " + id).exit_code == 0);
  const auto first = fs::last_write_time(fs::path(out) / "results" / "0005.json");
  r = test::run_ffdsim("sweep run " + out + " --jobs 2 -q");
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK(fs::last_write_time(fs::path(out) / "results" / "0005.json") == first);  // done once
  r = test::run_ffdsim("sweep status " + out);
  CHECK(r.exit_code == 0);
  CHECK_THAT(r.output, Catch::Contains("9 done, 0 failed, 0 missing"));

  const nlohmann::json job = read_json(fs::path(out) / "results" / "0004.json");
  CHECK(job.at("state") == "done");
  CHECK(job.at("parameters").at("alpha") == 0.6);
  CHECK(job.at("parameters").at("beta") == 0.0);
  CHECK(job.at("metrics").at("final_state_hash").get<std::string>().size() == 16);
  CHECK(job.at("scene_hash").get<std::string>().rfind("xxh3:", 0) == 0);
  CHECK(job.at("assertions").size() >= 3);
  // Different points, different states.
  std::set<std::string> hashes;
  for (const auto& [id, j] : simulation_results(out)) hashes.insert(j["metrics"]["final_state_hash"].get<std::string>());
  CHECK(hashes.size() == 9);

  r = test::run_ffdsim("sweep merge " + out);
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  std::ifstream csv(fs::path(out) / "results.csv");
  std::string header, line;
  std::getline(csv, header);
  CHECK(header.rfind("id,alpha,beta,state,exit_code,", 0) == 0);
  int rows = 0;
  while (std::getline(csv, line)) rows += line.empty() ? 0 : 1;
  CHECK(rows == 9);
  std::ifstream summary(fs::path(out) / "summary.md");
  const std::string md((std::istreambuf_iterator<char>(summary)), std::istreambuf_iterator<char>());
  CHECK_THAT(md, Catch::Contains("| max_penetration_m |") && Catch::Contains("9 done, 0 failed, 0 missing") &&
                    Catch::Contains("Heat maps over alpha and beta"));
  CHECK(fs::file_size(fs::path(out) / "heatmaps" / "max_penetration_m.png") > 1000);
  // Under the paper's response the blocks' nodes tremble at rest (docs/limits.md): never at rest.
  CHECK(job.at("metrics").at("time_to_rest_s").is_null());
  CHECK(job.at("metrics").at("force_ripple").is_null());  // the replay holds no probe
  CHECK(job.at("run_s").get<double>() > 0.0);
  CHECK(job.at("job_s").get<double>() >= job.at("load_s").get<double>() + job.at("run_s").get<double>());
  r = test::run_ffdsim("sweep status " + out);
  CHECK_THAT(r.output, Catch::Contains("time: the 9 jobs took") && Catch::Contains("as a sweep's jobs they took"));

  // Heat maps over other axes; a name that is no numeric parameter is refused.
  r = test::run_ffdsim("sweep merge " + out + " -q --axes beta,alpha");
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(test::read_text(fs::path(out) / "summary.md"), Catch::Contains("Heat maps over beta and alpha"));
  r = test::run_ffdsim("sweep merge " + out + " -q --axes beta,gamma");
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.output, Catch::Contains("--axes gamma: not a numeric parameter of the sweep (alpha, beta)"));

  // The results page: the summary under the stamp, the heat maps beside it, the jobs' time.
  const fs::path page = dir / "results" / "sweep_drop.md";
  fs::create_directories(page.parent_path());
  r = test::run_ffdsim("sweep merge " + out + " -q --update-docs " + page.string());
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  const std::string text = test::read_text(page);
  CHECK_THAT(text, Catch::Contains("# Sweep: alpha and beta over two dropped blocks") && Catch::Contains("- Command: `") &&
                       Catch::Contains("- Machine: ") && Catch::Contains("](sweep_drop_max_penetration_m.png)") &&
                       Catch::Contains("Time: the 9 jobs took"));
  CHECK(fs::exists(dir / "results" / "sweep_drop_max_penetration_m.png"));

  // A point opened as a scene: the same state after the same steps as its job.
  r = test::run_ffdsim("run --sweep " + out + " --point 0004 --headless --seconds 0.05 -q");
  INFO(r.output);
  CHECK(r.exit_code == 0);
  const fs::path point = fs::path(out) / "points" / "0004.toml";
  REQUIRE(fs::exists(point));
  CHECK_THAT(test::read_text(point), Catch::Contains("alpha = 0.6") && Catch::Contains("beta = 0.0"));
  const std::string report = (dir / "point.json").string();
  REQUIRE(test::run_ffdsim("simulate " + point.string() + " --steps 800 -q --report " + report).exit_code == 0);
  CHECK(read_json(report).at("state_hash") == job.at("metrics").at("final_state_hash"));
  CHECK(test::run_ffdsim("run --sweep " + out + " --point 0042 --headless --seconds 0.05 -q").exit_code == 2);

  // The same plan run again from nothing gives the same simulation results.
  const std::string again = (dir / "again").string();
  REQUIRE(test::run_ffdsim("sweep plan " + kSweeps + "drop_alpha_beta.toml --out " + again + " -q").exit_code == 0);
  REQUIRE(test::run_ffdsim("sweep run " + again + " --jobs 1 -q").exit_code == 0);
  const auto a = simulation_results(out), b = simulation_results(again);
  REQUIRE(a.size() == 9);
  for (const auto& [id, j] : a) CHECK(j.at("metrics") == b.at(id).at("metrics"));
}

TEST_CASE("ffdsim sweep: the time to rest is when the nodes' RMS speed stays below 5 mm/s, or none", "[sweep][cli]") {
  const fs::path dir = test::fresh_temp_dir("sweep_rest");
  fs::create_directories(dir);
  std::ofstream(dir / "s.toml") << "format = \"ffdsim-sweep\"\nversion = 1\nreplay = \"" << kSweeps << "drop.toml\"\n"
                                << "[parameters]\nresponse = [\"paper\", \"solver\"]\n";
  const std::string out = (dir / "sweep").string();
  REQUIRE(test::run_ffdsim("sweep plan " + (dir / "s.toml").string() + " --out " + out + " -q").exit_code == 0);
  REQUIRE(test::run_ffdsim("sweep run " + out + " -q").exit_code == 0);
  const nlohmann::json paper = read_json(fs::path(out) / "results" / "0001.json");
  const nlohmann::json solver = read_json(fs::path(out) / "results" / "0002.json");
  CHECK(paper.at("parameters").at("response") == "paper");
  CHECK(paper.at("metrics").at("time_to_rest_s").is_null());  // the paper's response trembles
  REQUIRE(solver.at("metrics").at("time_to_rest_s").is_number());
  const double rest = solver.at("metrics").at("time_to_rest_s").get<double>();
  CHECK(rest > 0.05);  // the blocks fall first
  CHECK(rest < 0.8);
  REQUIRE(test::run_ffdsim("sweep merge " + out + " -q").exit_code == 0);
  CHECK_THAT(test::read_text(fs::path(out) / "summary.md"), Catch::Contains("| time_to_rest_s |") && Catch::Contains("| 0002 | solver |"));
  CHECK_FALSE(fs::exists(fs::path(out) / "heatmaps"));  // one parameter, and not a number
}

TEST_CASE("ffdsim sweep: a failing job is written as failed with its exit code, the others run, the exit code says so",
          "[sweep][cli]") {
  const fs::path dir = test::fresh_temp_dir("sweep_fail");
  fs::create_directories(dir);
  // The dropped blocks, the upper one asserted to rest on the lower (its centre 5-7 cm up,
  // 6 cm at rest): at 5,000 N/m it does; springs of 1 N/m cannot hold 0.2 kg up (they would
  // stretch 2 m under its weight), and it ends flattened, its centre about 2 cm up.
  {
    std::ofstream(dir / "drop.toml") << test::read_text(kSweeps + "drop.toml")
                                     << "\n[[assert.position]]\nobject = \"high\"\nmin = [-0.05, 0.05, -0.05]\n"
                                     << "max = [0.05, 0.07, 0.05]\nfrom_ms = 400\n";
    std::ofstream sweep(dir / "s.toml");
    sweep << "format = \"ffdsim-sweep\"\nversion = 1\nreplay = \"drop.toml\"\n"
          << "[[point]]\nstiffness = 5000.0\n[[point]]\nstiffness = 1.0\n";
  }
  const std::string out = (dir / "sweep").string();
  REQUIRE(test::run_ffdsim("sweep plan " + (dir / "s.toml").string() + " --out " + out + " -q").exit_code == 0);
  test::ProgramResult r = test::run_ffdsim("sweep run " + out + " -q");
  INFO(r.output);
  CHECK(r.exit_code == 4);
  CHECK_THAT(r.output, Catch::Contains("1 of 2 jobs failed"));
  const nlohmann::json good = read_json(fs::path(out) / "results" / "0001.json");
  const nlohmann::json bad = read_json(fs::path(out) / "results" / "0002.json");
  CHECK(good.at("state") == "done");
  CHECK(bad.at("state") == "failed");
  CHECK(bad.at("exit_code").get<int>() != 0);
  r = test::run_ffdsim("sweep status " + out);
  CHECK(r.exit_code == 4);
  CHECK_THAT(r.output, Catch::Contains("failed: 0002"));
  // A job that cannot start (its plan names a replay gone missing) is recorded too.
  fs::copy_file(kSweeps + "drop.toml", dir / "gone.toml");
  {
    std::ofstream sweep(dir / "t.toml");
    sweep << "format = \"ffdsim-sweep\"\nversion = 1\nreplay = \"gone.toml\"\n[parameters]\nbeta = [0.5]\n";
  }
  const std::string out2 = (dir / "sweep2").string();
  REQUIRE(test::run_ffdsim("sweep plan " + (dir / "t.toml").string() + " --out " + out2 + " -q").exit_code == 0);
  fs::remove(dir / "gone.toml");
  r = test::run_ffdsim("sweep run-one " + out2 + " 0001");
  CHECK(r.exit_code == 4);
  const nlohmann::json gone = read_json(fs::path(out2) / "results" / "0001.json");
  CHECK(gone.at("state") == "failed");
  CHECK(gone.at("exit_code") == 2);
  CHECK_THAT(gone.at("error").get<std::string>(), Catch::Contains("gone.toml"));
  // An edited plan or result: a clear error, or the job counted as not run; never a crash.
  {
    std::string plan = test::read_text(fs::path(out2) / "plan.json");
    plan.replace(plan.find("0.5"), 3, "\"x\"");
    std::ofstream(fs::path(out2) / "plan.json") << plan;
  }
  r = test::run_ffdsim("sweep status " + out2);
  CHECK(r.exit_code == 2);
  CHECK_THAT(r.output, Catch::Contains("plan.json: job 0001: beta: a value of the wrong type"));
  std::ofstream(fs::path(out) / "results" / "0001.json") << "{\"replay\": 5, \"state\": [], \"exit_code\": \"0\"}";
  r = test::run_ffdsim("sweep status " + out);
  CHECK(r.exit_code == 4);
  CHECK_THAT(r.output, Catch::Contains("missing: 0001"));
  CHECK(test::run_ffdsim("sweep merge " + out + " -q").exit_code == 0);

  // Bad command lines and folders.
  CHECK(test::run_ffdsim("sweep run-one " + out2 + " 0099").exit_code == 2);
  CHECK(test::run_ffdsim("sweep status " + (dir / "nowhere").string()).exit_code == 2);
  CHECK(test::run_ffdsim("sweep plan " + (dir / "missing.toml").string() + " --out " + out2).exit_code == 2);
}

TEST_CASE("ffdsim sweep: GNU parallel runs a plan's jobs to the same results as ffdsim sweep run", "[sweep][cli]") {
  const fs::path dir = test::fresh_temp_dir("sweep_parallel");
  const std::string local = (dir / "local").string(), parallel = (dir / "parallel").string();
  for (const std::string& out : {local, parallel})
    REQUIRE(test::run_ffdsim("sweep plan " + kSweeps + "drop_alpha_beta.toml --out " + out + " -q").exit_code == 0);
  REQUIRE(test::run_ffdsim("sweep run " + local + " --jobs 2 -q").exit_code == 0);
  // As the plan says to: its parallel.sh, through the real GNU parallel (Debian's `parallel`).
  const test::ProgramResult r = test::run_shell("HOME=" + dir.string() + " " + parallel + "/parallel.sh --jobs 2");
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  REQUIRE(test::run_ffdsim("sweep status " + parallel).exit_code == 0);
  const auto a = simulation_results(local), b = simulation_results(parallel);
  REQUIRE(a.size() == 9);
  REQUIRE(b.size() == 9);
  for (const auto& [id, j] : a) {
    CHECK(j.at("metrics") == b.at(id).at("metrics"));
    CHECK(j.at("parameters") == b.at(id).at("parameters"));
  }
  REQUIRE(test::run_ffdsim("sweep merge " + parallel + " -q").exit_code == 0);
  CHECK(fs::exists(fs::path(parallel) / "results.csv"));
}

// Run by ctest beside a one-node Slurm cluster of the tests' own (tests/slurm/cluster.sh, a
// fixture), which SLURM_CONF names; hidden from a plain `ffd_tests` run.
TEST_CASE("ffdsim sweep: a Slurm job array runs a plan's jobs to the same results as ffdsim sweep run",
          "[sweep][cli][.slurm]") {
  const char* conf = std::getenv("SLURM_CONF");
  INFO("SLURM_CONF names the tests' cluster (ctest starts it: tests/slurm/cluster.sh)");
  REQUIRE(conf != nullptr);
  REQUIRE(fs::exists(conf));
  const fs::path dir = test::fresh_temp_dir("sweep_slurm");
  // The job array's tasks run as the cluster's user, on its node: the folder a path they can
  // reach (here the same machine).
  const std::string local = (dir / "local").string(), slurm = (dir / "slurm").string();
  for (const std::string& out : {local, slurm})
    REQUIRE(test::run_ffdsim("sweep plan " + kSweeps + "drop_alpha_beta.toml --out " + out + " -q").exit_code == 0);
  REQUIRE(test::run_ffdsim("sweep run " + local + " --jobs 2 -q").exit_code == 0);
  const test::ProgramResult r = test::run_shell("sbatch --wait " + slurm + "/sweep.sbatch");
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.output, Catch::Contains("Submitted batch job"));
  REQUIRE(test::run_ffdsim("sweep status " + slurm).exit_code == 0);
  const auto a = simulation_results(local), b = simulation_results(slurm);
  REQUIRE(b.size() == 9);
  for (const auto& [id, j] : a) {
    CHECK(j.at("metrics") == b.at(id).at("metrics"));
    CHECK(j.at("parameters") == b.at(id).at("parameters"));
  }
  // The array's own logs, one per task.
  int logs = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(slurm) / "logs"))
    logs += entry.path().filename().string().rfind("slurm-", 0) == 0 ? 1 : 0;
  CHECK(logs == 9);
}

TEST_CASE("ffdsim sweep: a sweep killed half-way resumes and ends with every job done once", "[sweep][cli]") {
  const fs::path dir = test::fresh_temp_dir("sweep_killed");
  const std::string out = (dir / "sweep").string();
  REQUIRE(test::run_ffdsim("sweep plan " + kSweeps + "drop_alpha_beta.toml --out " + out + " -q").exit_code == 0);
  // One job at a time, killed (SIGKILL: no clean-up) once a few results are there.
  const test::ProgramResult killed = test::run_shell(
      std::string(FFDSIM_BINARY) + " sweep run " + out + " --jobs 1 -q & pid=$!; "
      "for i in $(seq 6000); do n=$(ls " + out + "/results/*.json 2>/dev/null | wc -l); [ \"$n\" -ge 3 ] && break; sleep 0.01; done; "
      "kill -9 $pid; wait $pid; echo killed");
  INFO(killed.output);
  REQUIRE_THAT(killed.output, Catch::Contains("killed"));
  std::map<std::string, fs::file_time_type> before;
  for (const auto& entry : fs::directory_iterator(fs::path(out) / "results"))
    if (entry.path().extension() == ".json") before[entry.path().stem().string()] = fs::last_write_time(entry.path());
  CHECK(before.size() >= 3);
  CHECK(before.size() < 9);
  test::ProgramResult r = test::run_ffdsim("sweep status " + out);
  CHECK(r.exit_code == 4);
  CHECK_THAT(r.output, Catch::Contains("missing"));
  r = test::run_ffdsim("sweep run " + out + " -q");
  INFO(r.output);
  REQUIRE(r.exit_code == 0);
  CHECK(test::run_ffdsim("sweep status " + out).exit_code == 0);
  for (const auto& [id, time] : before) CHECK(fs::last_write_time(fs::path(out) / "results" / (id + ".json")) == time);
  // No job's temporary file is left as a result.
  for (const auto& entry : fs::directory_iterator(fs::path(out) / "results"))
    CHECK((entry.path().extension() == ".json" || entry.path().extension() == ".part"));
}
