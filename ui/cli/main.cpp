// ffdsim: one program, subcommands. `ffdsim --help` lists them.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <string>

#include "commands.h"
#include "ffd/toml_reader.h"
#include "ffd/worker_pool.h"
#include "output_files.h"

namespace ffdsim {
int thread_count(int option) { return option > 0 ? option : ffd::default_thread_count(); }

void add_threads_option(CLI::App& command, int& threads) {
  command
      .add_option("--threads", threads,
                  "Threads a step is spread over, this one included (default: 2 on a machine with 2 cores or "
                  "more); the results are bit-identical whatever the count")
      ->check(CLI::Range(1, 64));
}

void add_export_options(CLI::App& command, ExportArguments& a, bool series, bool older_names) {
  // simulate's --obj-every and --out came first and still work.
  CLI::Option* every = command
                           .add_option(older_names ? "--surfaces-every,--obj-every" : "--surfaces-every", a.surfaces_every,
                                       "Write the deformed surfaces every K steps (step 0 included)")
                           ->check(CLI::Range(1LL, 1000000000LL));
  CLI::Option* dir = command.add_option(older_names ? "--surfaces,--out" : "--surfaces", a.surfaces_dir, "Folder for the surfaces: DIR/<object>_<step>.obj");
  every->needs(dir);
  dir->needs(every);
  command.add_option("--surface-format", a.surface_format, "Surface files as obj (text) or ply (binary)")
      ->check(CLI::IsMember({"obj", "ply"}))
      ->capture_default_str();
  if (series)
    command.add_option("--series", a.series_path,
                       "Write a per-step time series (energy, contacts, penetration, stage times) to FILE.csv or "
                       "FILE.json");
}

ffd::ExportOptions ExportArguments::options() const {
  ffd::ExportOptions o;
  o.surfaces_every = static_cast<std::uint64_t>(surfaces_every);
  o.surfaces_dir = surfaces_dir;
  o.surface_format = ffd::parse_surface_format(surface_format);
  o.series_path = series_path;
  return o;
}

void ensure_folder(const std::string& dir) {
  if (dir.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw ffd::InputError(dir + ": cannot create folder: " + ec.message());
}

void ensure_parent_folder(const std::string& file_path) {
  ensure_folder(std::filesystem::path(file_path).parent_path().string());
}
}  // namespace ffdsim

namespace {
std::string command_list(const CLI::App& app) {
  std::string names;
  for (const CLI::App* command : app.get_subcommands([](const CLI::App*) { return true; }))
    names += (names.empty() ? "" : ", ") + command->get_name();
  return names;
}

bool has_command(const CLI::App& app, const std::string& name) {
  return !app.get_subcommands([&name](const CLI::App* command) { return command->get_name() == name; }).empty();
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ffdsim: deformable objects embedded in FFD lattices, with FFD AABB collision handling.\n"
      "Run `ffdsim <command> --help` for the options of a command."};
  app.require_subcommand(1);
  ffdsim::SimulateOptions simulate;
  ffdsim::register_simulate(app, simulate);
  ffdsim::ReplayOptions replay;
  ffdsim::register_replay(app, replay);
  ffdsim::RunOptions run;
  ffdsim::register_run(app, run);
  ffdsim::BenchOptions bench;
  ffdsim::register_bench(app, bench);
  ffdsim::AccuracyOptions accuracy;
  ffdsim::register_accuracy(app, accuracy);
  ffdsim::PilesOptions piles;
  ffdsim::register_piles(app, piles);
  ffdsim::HardCasesOptions hard_cases;
  ffdsim::register_hard_cases(app, hard_cases);
  ffdsim::DeviceSimOptions device_sim;
  ffdsim::register_device_sim(app, device_sim);
  ffdsim::SweepOptions sweep;
  ffdsim::register_sweep(app, sweep);
  // A first word that is no option must name a command: say which word, not only that a
  // command is missing.
  if (argc < 2) {
    std::fprintf(stderr, "ffdsim: error: a command is required (%s); `ffdsim --help` lists them\n", command_list(app).c_str());
    return ffdsim::kExitUsage;
  }
  const std::string first = argv[1];
  if (first[0] == '-' && first != "-h" && first != "--help") {
    std::fprintf(stderr, "ffdsim: error: unknown option '%s'; a command comes first (%s)\n", argv[1],
                 command_list(app).c_str());
    return ffdsim::kExitUsage;
  }
  if (first[0] != '-' && !has_command(app, first)) {
    std::fprintf(stderr, "ffdsim: error: unknown command '%s' (commands: %s)\n", argv[1], command_list(app).c_str());
    return ffdsim::kExitUsage;
  }
  ffdsim::set_command_line(argc, argv);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // CLI11 prints the reason; its own codes (105, 106, ...) all mean "usage" to a user.
    return app.exit(e) == 0 ? ffdsim::kExitOk : ffdsim::kExitUsage;
  }
  if (app.got_subcommand("simulate")) return ffdsim::run_simulate(simulate);
  if (app.got_subcommand("replay")) return ffdsim::run_replay_command(replay);
  if (app.got_subcommand("run")) return ffdsim::run_run(run);
  if (app.got_subcommand("bench")) return ffdsim::run_bench(bench);
  if (app.got_subcommand("device-sim")) return ffdsim::run_device_sim(device_sim);
  if (app.got_subcommand("accuracy")) return ffdsim::run_accuracy_command(accuracy);
  if (app.got_subcommand("piles")) return ffdsim::run_piles_command(piles);
  if (app.got_subcommand("hard-cases")) return ffdsim::run_hard_cases_command(hard_cases);
  if (app.got_subcommand("sweep")) return ffdsim::run_sweep_command(app, sweep);
  return ffdsim::kExitUsage;
}
