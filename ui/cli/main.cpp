// ffdsim: one program, subcommands. `ffdsim --help` lists them.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "commands.h"

int main(int argc, char** argv) {
  CLI::App app{
      "ffdsim: deformable objects embedded in FFD lattices, with FFD AABB collision handling.\n"
      "Run `ffdsim <command> --help` for the options of a command."};
  app.require_subcommand(1);
  ffdsim::SimulateOptions simulate;
  ffdsim::register_simulate(app, simulate);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (app.got_subcommand("simulate")) return ffdsim::run_simulate(simulate);
  return 1;
}
