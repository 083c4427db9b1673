// `ffdsim bench`: the paper's Table 1 beside ours, and the broad-phase race against FCL on
// FFD AABBs recorded from the same runs. Progress bars on the terminal while it runs.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "bench/broad_phase_race.h"
#include "bench/paper_table.h"
#include "commands.h"
#include "ffd/scene_loader.h"
#include "output_files.h"

namespace ffdsim {

void register_bench(CLI::App& app, BenchOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "bench", "The paper's Table 1 beside ours (collision time per step of its four experiments) and the "
               "broad-phase race against FCL, as Markdown and JSON");
  cmd->add_flag("--quick", o.quick, "Short warm-up and measuring windows (a smoke run; figures indicative only)");
  cmd->add_option("--out", o.out_dir, "Folder for table.md and bench.json")->capture_default_str();
  cmd->add_option("--only", o.only, "Run only these scenarios (teapots, alphabets, happy_buddha, bunnies_soft, bunnies_hard)");
  cmd->add_option("--update-docs", o.results_page,
                  "Also write the tables as a results page stamped with this command, the commit, the machine and the "
                  "date (docs/results/bench.md)");
  cmd->add_option("--repetitions", o.repetitions, "Timed runs per broad phase and box set in the race")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  cmd->add_option("--threads", o.threads,
                  "Every scenario runs on 1 thread, then on this many (default: 2 on a machine with 2 cores or more)")
      ->check(CLI::Range(2, 64));
  cmd->add_option("--responses", o.responses,
                  "Contact responses to run every scenario under, a row each (paper, solver); the broad-phase race "
                  "uses the paper's")
      ->check(CLI::IsMember({"paper", "solver"}))
      ->capture_default_str();
  cmd->add_option("--compare", o.compare,
                  "A bench.json (docs/results/bench.json): exit 4 when a scene's whole-step p50 is more than 25 % above "
                  "it, naming the scene and the stage (compared only if measured on the same CPU model)")
      ->check(CLI::ExistingFile);
  cmd->add_flag("--quiet,-q", o.quiet, "No progress bars");
}

int run_bench(const BenchOptions& o) {
  const auto& all = ffdbench::paper_scenarios();
  for (const std::string& key : o.only)  // a misspelt key is a command-line error
    if (std::none_of(all.begin(), all.end(), [&](const ffdbench::Scenario& s) { return s.key == key; })) {
      std::fprintf(stderr, "ffdsim: error: --only: unknown scenario '%s' (teapots, alphabets, happy_buddha, "
                   "bunnies_soft, bunnies_hard)\n", key.c_str());
      return kExitUsage;
    }
  try {
    std::vector<ffdbench::Scenario> chosen;
    for (const ffdbench::Scenario& s : all)
      if (o.only.empty() || std::find(o.only.begin(), o.only.end(), s.key) != o.only.end()) chosen.push_back(s);
    if (!o.results_page.empty()) check_results_page(o.results_page);  // before minutes of benchmarking
    ensure_folder(o.out_dir);
    nlohmann::json reference;
    if (!o.compare.empty()) {  // read before minutes of benchmarking too
      std::ifstream in(o.compare);
      reference = nlohmann::json::parse(in, nullptr, false);
      if (reference.is_discarded()) throw std::runtime_error(o.compare + ": not valid JSON");
      ffdbench::compare_to_reference({}, reference, ffdbench::cpu_description(), o.compare);  // its shape
    }

    const std::string cpu = ffdbench::cpu_description();
    ProgressBar progress("ffdsim bench", o.quiet);
    std::vector<ffdbench::ScenarioResult> results;
    bool finite = true;
    for (const ffdbench::Scenario& scenario : chosen) {
      for (const std::string& response_text : o.responses) {
        ffd::ContactResponse response = ffd::ContactResponse::Paper;
        ffd::response_from_name(response_text, response);  // checked by the option
        results.push_back(ffdbench::bench_scenario(scenario, ffd::scenario_dir(), o.quick,
                                                   std::max(2, thread_count(o.threads)), std::ref(progress), response,
                                                   !o.compare.empty()));
        const ffdbench::ScenarioResult& r = results.back();
        finite = finite && r.finite;
        char line[256];
        std::snprintf(line, sizeof line,
                      "%-13s %-6s p99 1 / %d threads: collision %.3f / %.3f ms, step %.2f / %.2f ms; %.0f contacts/step%s",
                      r.scenario.key.c_str(), response_text.c_str(), r.parallel.threads, r.single.collision_p99_ms,
                      r.parallel.collision_p99_ms, r.single.step_p99_ms, r.parallel.step_p99_ms, r.contacts_mean,
                      r.finite ? "" : "; NOT FINITE");
        progress.finish_line(line);
      }
    }

    std::vector<ffdbench::RaceResult> race;
    std::size_t sets = 0, missing = 0;
    for (const ffdbench::ScenarioResult& r : results) sets += r.box_sets.size();
    const int repetitions = o.quick ? std::min(o.repetitions, 5) : o.repetitions;
    for (const ffdbench::ScenarioResult& r : results) {
      for (const ffdbench::BoxSet& set : r.box_sets) {
        progress("broad-phase race", race.size(), sets);
        race.push_back(ffdbench::race(set, repetitions));
        missing += race.back().missing_any;
      }
    }
    progress.finish_line("broad-phase race: " + std::to_string(race.size()) + " box sets, " +
                         (missing ? std::to_string(missing) + " FCL pairs missing from ours" : "every FCL pair among ours"));

    const std::string table = ffdbench::markdown_table(results, cpu, o.quick);
    const std::string race_table = ffdbench::markdown_table(race);
    write_file(std::filesystem::path(o.out_dir) / "table.md",
               "## The paper's Table 1 beside ours\n\n" + table + "\n## Broad-phase race\n\n" + race_table);
    nlohmann::json json = {{"machine", {{"cpu", cpu}}},
                           {"date", today()},
                           {"quick", o.quick},
                           {"scenarios", ffdbench::to_json(results)},
                           {"broad_phase_race", ffdbench::to_json(race)}};
    write_file(std::filesystem::path(o.out_dir) / "bench.json", json.dump(2) + "\n");
    std::printf("%s\n%s", table.c_str(), race_table.c_str());
    if (!o.results_page.empty()) {
      // The reference for --compare, beside the page: docs/results/bench.json.
      write_file(std::filesystem::path(o.results_page).replace_extension(".json"), json.dump(2) + "\n");
      write_results_page(o.results_page, "Speed: the paper's Table 1 beside ours", cpu,
                         "## Collision handling and the whole step\n\n" + table + "\n## Broad-phase race against FCL\n\n" +
                             race_table);
      std::fprintf(stderr, "ffdsim bench: wrote %s\n", o.results_page.c_str());
    }
    std::fprintf(stderr, "ffdsim bench: wrote %s/table.md and %s/bench.json\n", o.out_dir.c_str(), o.out_dir.c_str());
    if (!finite) return kExitRuntime;
    bool slower = false;
    if (!o.compare.empty()) {
      const ffdbench::Comparison c = ffdbench::compare_to_reference(results, reference, cpu, o.compare);
      if (!c.compared)
        std::fprintf(stderr, "ffdsim bench: --compare: nothing compared: %s was measured on %s, this is %s\n",
                     o.compare.c_str(), c.reference_cpu.c_str(), cpu.c_str());
      for (const std::string& line : c.lines) std::fprintf(stderr, "ffdsim bench: --compare: %s\n", line.c_str());
      slower = !c.failures.empty();
    }
    return missing || slower ? kExitAssertionFailed : kExitOk;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }
}

}  // namespace ffdsim
