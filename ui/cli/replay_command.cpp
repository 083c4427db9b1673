// `ffdsim replay FILE`: runs a replay script headless and checks its assertions.
#include <cstdio>
#include <optional>
#include <filesystem>
#include <fstream>

#include "commands.h"
#include "ffd/replay_runner.h"
#include "ffd/replay_script.h"

namespace ffdsim {

void register_replay(CLI::App& app, ReplayOptions& o) {
  CLI::App* cmd = app.add_subcommand("replay", "Run a replay script (or a recording) headless and check its assertions");
  cmd->add_option("script", o.script, "Replay script (TOML)")->required();
  CLI::Option* fast = cmd->add_flag("--fast", o.fast, "Step as fast as possible (latency limits on lateness are skipped)");
  CLI::Option* realtime = cmd->add_flag("--realtime", o.realtime, "Pace one step per period against deadlines (default)");
  fast->excludes(realtime);
  cmd->add_option("--report", o.report_path, "Write the results as JSON to this file");
  cmd->add_option("--period-us", o.period_us, "Loop period in real time, microseconds")->check(CLI::Range(50.0, 1e6));
  cmd->add_option("--budget-us", o.budget_us, "Latency budget per step, microseconds")->check(CLI::Range(1.0, 1e7));
  cmd->add_flag("--skip-latency", o.skip_latency,
                "Report latency limits as SKIP (for sanitizer and debug builds, whose steps are far slower)");
  CLI::Option* from_recording = cmd->add_flag(
      "--scene-from-recording", o.scene_from_recording,
      "A recording: replay the scene text it holds, not the scene file as it is now (meshes still from their files)");
  cmd->add_flag("--allow-changed", o.allow_changed,
                "A recording: replay the scene and mesh files as they are now even where their content changed since "
                "(the replay reports the first diverging step)")
      ->excludes(from_recording);
  cmd->add_option("--response", o.response,
                  "Run under this contact response instead of the scene's (paper, solver); not for a recording, "
                  "which replays the response it was recorded with")
      ->check(CLI::IsMember({"paper", "solver"}));
  add_threads_option(*cmd, o.threads);
  add_export_options(*cmd, o.exports);
  cmd->add_flag("--quiet,-q", o.quiet, "Print only failures and errors");
}

int run_replay_command(const ReplayOptions& o) {
  ffd::LoadedReplay replay;
  std::optional<ffd::RunExports> exports;
  try {
    const ffd::RecordedScene recorded = o.scene_from_recording ? ffd::RecordedScene::FromRecording
                                        : o.allow_changed      ? ffd::RecordedScene::AllowChanged
                                                               : ffd::RecordedScene::MustMatch;
    std::optional<ffd::ContactResponse> response;
    if (!o.response.empty()) ffd::response_from_name(o.response, response.emplace());  // checked by the option
    replay = ffd::load_replay_file(o.script, {}, recorded, response);
    if (!o.report_path.empty()) ensure_parent_folder(o.report_path);
    if (o.exports.options().any()) {
      std::vector<std::string> sources;
      for (const ffd::ObjectSpec& object : replay.script.scene.objects) sources.push_back(object.source);
      exports.emplace(replay.model, ffd::initial_state(replay.model), std::move(sources), o.exports.options());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }
  for (const std::string& warning : replay.script.warnings) std::fprintf(stderr, "ffdsim: warning: %s\n", warning.c_str());
  if (!o.response.empty() && !o.quiet)
    std::printf("%s: under contact response %s (--response)\n", o.script.c_str(), o.response.c_str());
  ffd::ReplayRunOptions run;
  run.pacing = o.fast ? ffd::Pacing::Fast : ffd::Pacing::RealTime;
  run.period_ns = static_cast<std::int64_t>(o.period_us * 1000.0);
  run.budget_ns = static_cast<std::int64_t>(o.budget_us * 1000.0);
  run.check_latency = !o.skip_latency;
  run.threads = thread_count(o.threads);
  run.exports = exports ? &*exports : nullptr;
  const ffd::ReplayResult result = ffd::run_replay(replay, run);
  const std::string text = ffd::format_replay_result(replay.script, result);
  if (!o.quiet || !result.passed()) std::fputs(text.c_str(), result.passed() ? stdout : stderr);
  if (!result.passed() && replay.script.recorded && replay.script.recorded->ffdsim != ffd::ffdsim_version())
    std::fprintf(stderr, "ffdsim: %s: recorded with ffdsim %s; this is ffdsim %s, whose state hashes may differ\n",
                 o.script.c_str(), replay.script.recorded->ffdsim.c_str(), ffd::ffdsim_version().c_str());
  if (!o.report_path.empty()) {
    std::ofstream out(o.report_path);
    out << ffd::replay_result_json(replay.script, result);
    if (!out) {
      std::fprintf(stderr, "ffdsim: error: %s: cannot write the report\n", o.report_path.c_str());
      return kExitBadInput;
    }
  }
  // After the results and the report: a file the exports could not write loses neither.
  if (exports) {
    exports->finish();
    if (!exports->error().empty()) {
      std::fprintf(stderr, "ffdsim: error: %s\n", exports->error().c_str());
      return kExitBadInput;
    }
    if (!o.quiet) std::printf("%s\n", exports->summary().c_str());
  }
  if (!result.finite) {  // the run failed, whatever the assertions say
    std::fprintf(stderr, "ffdsim: error: %s: the simulation produced a non-finite value at step %llu\n", o.script.c_str(),
                 static_cast<unsigned long long>(result.first_non_finite_step.value_or(result.steps)));
    return kExitRuntime;
  }
  return result.passed() ? kExitOk : kExitAssertionFailed;
}

}  // namespace ffdsim
