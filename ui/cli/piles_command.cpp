// `ffdsim piles`: seeded random piles of rings, tori, plates, bowls and letters dropped at
// every accuracy level under each response; intersecting triangle pairs over time, the
// longest crossing and the step time (ui/bench/pile_table.h). A table (Markdown, JSON).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "bench/pile_table.h"
#include "commands.h"
#include "ffd/random_pile.h"
#include "ffd/scene_loader.h"
#include "output_files.h"

namespace ffdsim {

void register_piles(CLI::App& app, PilesOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "piles", "Random piles (rings, tori, thin plates, bowls, letters) dropped at every accuracy level: do the "
               "surfaces end apart, and how long does a crossing last?");
  cmd->add_option("--seeds", o.seeds, "Piles to run, by seed (default: 1 2 3; with --long 1 to 20)")
      ->check(CLI::Range(std::uint64_t{1}, std::uint64_t{1'000'000'000}));
  cmd->add_flag("--long", o.long_set, "The long set: seeds 1 to 20");
  cmd->add_option("--objects", o.objects, "Objects per pile")->check(CLI::Range(1, 64))->capture_default_str();
  cmd->add_option("--steps", o.steps, "Steps per run (1 ms each); the last 1000 must end crossing-free")
      ->check(CLI::Range(1000, 1'000'000))
      ->capture_default_str();
  cmd->add_option("--sample-every", o.sample_every, "Steps between intersection counts")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--levels", o.levels, "Levels to run (default: 0 1 2 3 4 5)")->check(CLI::Range(0, ffd::kAccuracyLevels - 1));
  cmd->add_option("--responses", o.responses, "Contact responses to run each level under (paper, solver)")
      ->check(CLI::IsMember({"paper", "solver"}))
      ->capture_default_str();
  cmd->add_option("--out", o.out_dir, "Folder for piles.md and piles.json")->capture_default_str();
  cmd->add_option("--scenes", o.scenes_dir, "Also write each pile's scene file (pile_SEED.toml) into this folder");
  cmd->add_option("--update-docs", o.results_page,
                  "Also write the table and the piles not clean as a results page stamped with this command, the "
                  "commit, the machine and the date (docs/results/piles.md)");
  cmd->add_flag("--box-overlap", o.box_overlap,
                "Every pile with [simulation] box_overlap = true (boxes of two objects kept apart as wholes)");
  cmd->add_flag("--edge-contacts,!--no-edge-contacts", o.edge_contacts,
                "Every pile with [simulation] edge_contacts = true, the default (levels 0-3: crossed surface edges sent "
                "back, as at levels 4 and 5; under either response), or false");
  cmd->add_flag("--solver-substeps", o.solver_substeps,
                "Every pile with [simulation] solver_substeps = true (the response solver's sweeps as substeps; at "
                "level 5 only with edge contacts)");
  cmd->add_option("--iterations", o.iterations,
                  "Every object's mass_spring.iterations: its lattice's sweeps a step (more: a stiffer lattice under "
                  "its contacts, and a slower step)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd->add_flag("--require-clean", o.require_clean,
                "Exit 4 (a check failed) unless every pile ends clean: at rest, no pair in the last second, no crossing "
                "longer than 50 ms");
  add_threads_option(*cmd, o.threads);
  cmd->add_flag("--quiet,-q", o.quiet, "No progress bars");
}

int run_piles_command(const PilesOptions& o) {
  try {
    if (!o.results_page.empty()) check_results_page(o.results_page);  // before minutes of running
    std::vector<std::uint64_t> seeds = o.seeds;
    if (seeds.empty())
      for (std::uint64_t s = 1; s <= (o.long_set ? 20u : 3u); ++s) seeds.push_back(s);
    std::vector<int> levels = o.levels;
    if (levels.empty())
      for (int l = 0; l < ffd::kAccuracyLevels; ++l) levels.push_back(l);
    ensure_folder(o.out_dir);
    if (!o.scenes_dir.empty()) ensure_folder(o.scenes_dir);

    ProgressBar progress("ffdsim piles", o.quiet);
    std::vector<ffdbench::PileRun> runs;
    bool finite = true;
    for (const std::uint64_t seed : seeds) {
      ffd::PileOptions pile;
      pile.seed = seed;
      pile.objects = o.objects;
      pile.box_overlap = o.box_overlap;
      pile.edge_contacts = o.edge_contacts;
      pile.solver_substeps = o.solver_substeps;
      pile.iterations = o.iterations;
      const std::string text = ffd::random_pile_scene(pile);
      const std::string origin = "pile_" + std::to_string(seed) + ".toml";
      if (!o.scenes_dir.empty()) write_file(std::filesystem::path(o.scenes_dir) / origin, text);
      const ffd::SceneSpec spec = ffd::parse_scene(text, origin, "");
      std::vector<std::string> log;
      const ffd::Model model = ffd::compile_scene(spec, origin, log);
      for (const std::string& response_text : o.responses) {
        ffd::ContactResponse response = ffd::ContactResponse::Paper;
        ffd::response_from_name(response_text, response);  // checked by the option
        for (const int level : levels) {
          runs.push_back(ffdbench::run_pile(model, seed, static_cast<ffd::Accuracy>(level), response, o.steps,
                                            o.sample_every, std::ref(progress), thread_count(o.threads)));
          const ffdbench::PileRun& r = runs.back();
          finite = finite && r.finite;
          char line[256];
          std::snprintf(line, sizeof line,
                        "pile %llu level %d, %s: %s; pairs max %zu, last second %zu; longest crossing %.0f ms; step "
                        "%.3f ms p50",
                        static_cast<unsigned long long>(seed), level, response_text.c_str(),
                        r.clean() ? "clean" : "NOT CLEAN", r.pairs_max, r.last_second_max, r.longest_crossing_ms,
                        r.step_p50_ms);
          progress.finish_line(line);
        }
      }
    }

    const std::string table = ffdbench::markdown_piles(runs, ffdbench::cpu_description(), o.objects);
    const std::filesystem::path out(o.out_dir);
    const std::string unclean = ffdbench::markdown_unclean_piles(runs);
    write_file(out / "piles.md", "## Random piles\n\n" + table + (unclean.empty() ? "" : "\n" + unclean));
    write_file(out / "piles.json",
               nlohmann::json({{"machine", {{"cpu", ffdbench::cpu_description()}}},
                               {"date", today()},
                               {"objects", o.objects},
                               {"runs", ffdbench::to_json(runs)}})
                       .dump(2) +
                   "\n");
    std::printf("%s%s", table.c_str(), unclean.empty() ? "" : ("\n" + unclean).c_str());
    if (!o.results_page.empty()) {
      write_results_page(o.results_page, "Random piles", ffdbench::cpu_description(),
                         table + (unclean.empty() ? "" : "\n" + unclean));
      std::fprintf(stderr, "ffdsim piles: wrote %s\n", o.results_page.c_str());
    }
    std::fprintf(stderr, "ffdsim piles: wrote %s/piles.md and piles.json\n", o.out_dir.c_str());
    if (!finite) return kExitRuntime;
    const auto unclean_runs = std::count_if(runs.begin(), runs.end(), [](const ffdbench::PileRun& r) { return !r.clean(); });
    if (o.require_clean && unclean_runs > 0) {
      std::fprintf(stderr, "ffdsim piles: check failed: %lld of %zu runs not clean (listed in %s/piles.md)\n",
                   static_cast<long long>(unclean_runs), runs.size(), o.out_dir.c_str());
      return kExitAssertionFailed;
    }
    return kExitOk;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }
}

}  // namespace ffdsim
