// `ffdsim hard-cases`: every hard case (scenarios/replays/hard/) replayed fast under each
// contact response, one table row a run: what its assertions decided and the figures that
// say whether the run stayed numerically stable (depth, energy against what went in, speed).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "bench/paper_table.h"
#include "commands.h"
#include "ffd/replay_runner.h"
#include "ffd/replay_script.h"
#include "ffd/scene_loader.h"
#include "output_files.h"

namespace ffdsim {

void register_hard_cases(CLI::App& app, HardCasesOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "hard-cases", "Replay every hard case fast under each contact response and print one table: pass or fail, "
                    "deepest contact, energy against what went in, fastest node");
  cmd->add_option("scripts", o.scripts, "Replay scripts or folders of them (default: scenarios/replays/hard)");
  cmd->add_option("--responses", o.responses, "Contact responses to run every case under, a row each (paper, solver)")
      ->check(CLI::IsMember({"paper", "solver"}))
      ->capture_default_str();
  cmd->add_option("--update-docs", o.results_page,
                  "Also write the table as a results page stamped with this command, the commit, the machine and the "
                  "date (docs/results/hard_cases.md)");
  add_threads_option(*cmd, o.threads);
  cmd->add_flag("--quiet,-q", o.quiet, "Print only the table and failures");
}

namespace {

// The scripts named, folders expanded to their *.toml files in name order.
std::vector<std::string> script_files(const std::vector<std::string>& given) {
  std::vector<std::string> names = given;
  if (names.empty()) names.push_back(ffd::scenario_dir() + "/replays/hard");
  std::vector<std::string> files;
  for (const std::string& name : names) {
    if (!std::filesystem::is_directory(name)) {
      files.push_back(name);
      continue;
    }
    std::vector<std::string> in_folder;
    for (const auto& entry : std::filesystem::directory_iterator(name))
      if (entry.path().extension() == ".toml") in_folder.push_back(entry.path().string());
    std::sort(in_folder.begin(), in_folder.end());
    if (in_folder.empty()) throw std::runtime_error(name + ": no replay scripts (*.toml) in this folder");
    files.insert(files.end(), in_folder.begin(), in_folder.end());
  }
  return files;
}

std::string first_failure(const ffd::ReplayResult& r) {
  for (const ffd::AssertionResult& a : r.assertions)
    if (!a.skipped && !a.passed) return a.name + ": " + a.measured + " (limit " + a.limit + ")";
  return r.finite ? "" : "not finite";
}

}  // namespace

int run_hard_cases_command(const HardCasesOptions& o) {
  try {
    if (!o.results_page.empty()) check_results_page(o.results_page);  // before minutes of running
    const std::vector<std::string> files = script_files(o.scripts);
    std::ostringstream table;
    table << "Each hard case replayed back to back (`ffdsim replay --fast`) under each contact response, "
             "latency limits not checked. Depth: the deepest node-in-box contact of any step. Energy: the "
             "input (initial energy, potential energy counted from the origin, plus the probe's work) and the "
             "most the total energy rose above it. Time: the replay's wall-clock time on this machine.\n\n"
             "| case | response | result | assertions passed | depth mm | energy input J | most above input J | "
             "fastest node m/s | steps | time s | first failure |\n"
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|\n";
    std::size_t failed = 0, runs = 0;
    for (const std::string& file : files) {
      for (const std::string& response_text : o.responses) {
        ffd::ContactResponse response = ffd::ContactResponse::Paper;
        ffd::response_from_name(response_text, response);  // checked by the option
        ffd::LoadedReplay replay = ffd::load_replay_file(file, {}, ffd::RecordedScene::MustMatch, response);
        ffd::ReplayRunOptions run;
        run.pacing = ffd::Pacing::Fast;
        run.check_latency = false;
        run.threads = thread_count(o.threads);
        const auto start = std::chrono::steady_clock::now();
        const ffd::ReplayResult r = ffd::run_replay(replay, run);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::size_t checked = 0, passed = 0;
        for (const ffd::AssertionResult& a : r.assertions)
          if (!a.skipped) {
            ++checked;
            passed += a.passed;
          }
        const bool ok = r.finite && r.passed();
        failed += !ok;
        ++runs;
        const std::string name = std::filesystem::path(file).stem().string();
        char row[512];
        char gain[32] = "–";  // no energy assertion: the gain was not tracked
        if (r.max_energy_gain_j > -1e300) std::snprintf(gain, sizeof gain, "%.3g", r.max_energy_gain_j);
        std::snprintf(row, sizeof row, "| `%s` | %s | %s | %zu / %zu | %.2f | %.4g | %s | %.2f | %llu | %.1f | %s |\n",
                      name.c_str(), response_text.c_str(), ok ? "pass" : "**FAIL**", passed, checked,
                      r.max_penetration_m * 1e3, r.initial_energy_j + r.probe_work_j,
                      gain, r.max_speed_m_s,
                      static_cast<unsigned long long>(r.steps), seconds, first_failure(r).c_str());
        table << row;
        if (!o.quiet)
          std::fprintf(stderr, "%s (%s): %s in %.1f s\n", name.c_str(), response_text.c_str(), ok ? "pass" : "FAIL",
                       seconds);
      }
    }
    table << "\n" << (runs - failed) << " of " << runs << " runs passed.\n";
    std::printf("%s", table.str().c_str());
    if (!o.results_page.empty()) {
      write_results_page(o.results_page, "Hard cases", ffdbench::cpu_description(), table.str());
      std::fprintf(stderr, "ffdsim hard-cases: wrote %s\n", o.results_page.c_str());
    }
    return failed ? kExitAssertionFailed : kExitOk;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }
}

}  // namespace ffdsim
