// `ffdsim accuracy`: every accuracy level of each scene from the same start, the collision
// time per step against the contact error on the exact surfaces; a table (Markdown, JSON)
// and a plot (PNG through gnuplot).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "bench/accuracy_table.h"
#include "commands.h"
#include "ffd/scene_loader.h"
#include "output_files.h"

namespace ffdsim {

void register_accuracy(CLI::App& app, AccuracyOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "accuracy", "What accuracy costs in time: each scene at every accuracy level (0 grid cells .. 5 exact "
                  "surfaces), collision time per step against gap and penetration on the exact surfaces");
  cmd->add_option("scenes", o.scenes, "Scene files (default: the two teapots and the five hard bunnies)");
  cmd->add_option("--steps", o.steps, "Steps per level (1 ms each); surfaces are sampled over the second half")
      ->check(CLI::Range(20, 1'000'000))
      ->capture_default_str();
  cmd->add_option("--levels", o.levels, "Levels to run (default: 0 1 2 3 4 5)")->check(CLI::Range(0, ffd::kAccuracyLevels - 1));
  cmd->add_option("--responses", o.responses, "Contact responses to run each level under (paper, solver)")
      ->check(CLI::IsMember({"paper", "solver"}))
      ->capture_default_str();
  cmd->add_option("--out", o.out_dir, "Folder for accuracy.md, accuracy.json, accuracy.gp and accuracy.png")
      ->capture_default_str();
  cmd->add_option("--update-docs", o.results_page,
                  "Also write the table as a results page stamped with this command, the commit, the machine and the "
                  "date, and the plot beside it as a PNG of the same name (docs/results/accuracy.md)");
  cmd->add_option("--plot", o.plot, "Also copy the plot to this PNG file");
  add_threads_option(*cmd, o.threads);
  cmd->add_flag("--quiet,-q", o.quiet, "No progress bars");
}

int run_accuracy_command(const AccuracyOptions& o) {
  try {
    if (!o.results_page.empty()) check_results_page(o.results_page);  // before minutes of running
    std::vector<std::string> scenes = o.scenes;
    if (scenes.empty())
      scenes = {ffd::scenario_dir() + "/scenes/two_teapots.toml",
                ffd::scenario_dir() + "/scenes/five_bunnies_hard.toml"};
    std::vector<int> levels = o.levels;
    if (levels.empty())
      for (int l = 0; l < ffd::kAccuracyLevels; ++l) levels.push_back(l);
    ensure_folder(o.out_dir);

    ProgressBar progress("ffdsim accuracy", o.quiet);
    std::vector<ffdbench::AccuracyRun> runs;
    bool finite = true;
    for (const std::string& file : scenes) {
      const ffd::SceneSpec spec = ffd::load_scene_file(file);
      std::vector<std::string> log;
      const ffd::Model model = ffd::compile_scene(spec, file, log);
      const std::string name = spec.name.empty() ? std::filesystem::path(file).stem().string() : spec.name;
      for (const std::string& response_text : o.responses) {
        ffd::ContactResponse response = ffd::ContactResponse::Paper;
        ffd::response_from_name(response_text, response);  // checked by the option
        for (int level : levels) {
          runs.push_back(ffdbench::run_accuracy(model, name, static_cast<ffd::Accuracy>(level), o.steps, 50,
                                                std::ref(progress), thread_count(o.threads), response));
          const ffdbench::AccuracyRun& r = runs.back();
          finite = finite && r.finite;
          char line[256];
          std::snprintf(line, sizeof line,
                        "%s level %d, %s: collision %.3f ms p50; gap max %.2f mm; penetration max %.2f mm%s", name.c_str(),
                        level, response_text.c_str(), r.collision_p50_ms, r.gap_max_mm, r.penetration_max_mm,
                        r.finite ? "" : "; NOT FINITE");
          progress.finish_line(line);
        }
      }
    }

    const std::string table = ffdbench::markdown_accuracy(runs, ffdbench::cpu_description(), o.steps);
    const std::filesystem::path out(o.out_dir);
    write_file(out / "accuracy.md", "## What accuracy costs\n\n" + table);
    write_file(out / "accuracy.json",
               nlohmann::json({{"machine", {{"cpu", ffdbench::cpu_description()}}}, {"date", today()}, {"steps", o.steps},
                               {"runs", ffdbench::to_json(runs)}})
                       .dump(2) +
                   "\n");
    const std::filesystem::path png = out / "accuracy.png";
    write_file(out / "accuracy.gp", ffdbench::gnuplot_script(runs, png.string()));
    const std::string plot_command = "gnuplot '" + (out / "accuracy.gp").string() + "'";
    if (std::system(plot_command.c_str()) != 0)
      throw std::runtime_error("gnuplot failed to draw " + png.string() + " (is gnuplot installed? setup.sh installs it)");
    if (!o.plot.empty()) std::filesystem::copy_file(png, o.plot, std::filesystem::copy_options::overwrite_existing);
    std::printf("%s", table.c_str());
    if (!o.results_page.empty()) {
      std::filesystem::path page_plot(o.results_page);
      page_plot.replace_extension(".png");
      std::filesystem::copy_file(png, page_plot, std::filesystem::copy_options::overwrite_existing);
      write_results_page(o.results_page, "What accuracy costs", ffdbench::cpu_description(),
                         "![Gap and penetration against collision time per step](" + page_plot.filename().string() +
                             ")\n\n" + table);
      std::fprintf(stderr, "ffdsim accuracy: wrote %s and %s\n", o.results_page.c_str(), page_plot.string().c_str());
    }
    std::fprintf(stderr, "ffdsim accuracy: wrote %s/accuracy.md, accuracy.json and accuracy.png\n", o.out_dir.c_str());
    return finite ? kExitOk : kExitRuntime;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }
}

}  // namespace ffdsim
