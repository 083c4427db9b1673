// `ffdsim run`: the physics loop in real time. Headless, it runs for --seconds (or until
// Ctrl-C), reads frames as a 60 Hz display would, and prints the loop's latency figures.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "ffd/physics_loop.h"
#include "ffd/recording.h"
#include "ffd/replay_runner.h"
#include "ffd/scene_loader.h"
#include "json_report.h"

namespace ffdsim {

namespace {

std::atomic<bool> g_interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the signal handler needs a lock-free flag");
extern "C" void on_interrupt(int) { g_interrupted.store(true); }

void print_distribution(const char* name, const ffd::TimeSummary& d) {
  std::printf("%-9s us: p50 %8.1f  p99 %8.1f  p99.9 %8.1f  max %8.1f\n", name, d.p50_us, d.p99_us, d.p999_us, d.max_us);
}

}  // namespace

void register_run(CLI::App& app, RunOptions& o) {
  CLI::App* cmd = app.add_subcommand("run", "Run a scene on the real-time physics loop");
  cmd->add_option("scene", o.scene, "Scene file (TOML); default: two teapots dropped on a floor");
  cmd->add_flag("--headless", o.headless, "No window: run, then print the latency figures");
  cmd->add_option("--seconds", o.seconds, "Wall-clock seconds to run (Ctrl-C ends it earlier)")
      ->check(CLI::Range(0.001, 1e6));
  cmd->add_option("--record", o.record_path, "Record the command stream and state hashes to this replay file");
  cmd->add_option("--hash-every", o.hash_every, "State hash every N steps (recording, report)")
      ->check(CLI::Range(1LL, 1000000LL));
  cmd->add_option("--report", o.report_path, "Write the latency figures as JSON to this file");
  cmd->add_option("--period-us", o.period_us, "Loop period, microseconds (1000 = 1 kHz)")->check(CLI::Range(50.0, 1e6));
  cmd->add_option("--budget-us", o.budget_us, "Latency budget per step, microseconds")->check(CLI::Range(1.0, 1e7));
  cmd->add_option("--spin-us", o.spin_us, "Busy-wait before each release, microseconds")->check(CLI::Range(0.0, 1e6));
  cmd->add_flag("--quiet,-q", o.quiet, "Print only errors");
}

int run_run(const RunOptions& o) {
  if (!o.headless) {
    std::fprintf(stderr, "ffdsim: error: run: the interactive window is not part of this build; pass --headless\n");
    return kExitUsage;
  }
  ffd::Model model;
  std::string scene_path;
  try {
    scene_path = std::filesystem::absolute(o.scene.empty() ? ffd::default_scene_path() : o.scene).lexically_normal();
    const ffd::SceneSpec spec = ffd::load_scene_file(scene_path);
    std::vector<std::string> log;
    model = ffd::compile(spec, log);
    if (!o.report_path.empty()) ensure_parent_folder(o.report_path);
    if (!o.record_path.empty()) ensure_parent_folder(o.record_path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }

  ffd::LoopOptions options;
  options.pacing = ffd::Pacing::RealTime;
  options.period_ns = static_cast<std::int64_t>(o.period_us * 1000.0);
  options.budget_ns = static_cast<std::int64_t>(o.budget_us * 1000.0);
  options.spin_ns = static_cast<std::int64_t>(o.spin_us * 1000.0);
  options.hash_every = static_cast<std::uint32_t>(o.hash_every);
  ffd::PhysicsLoop loop(model, ffd::initial_state(model), options);

  const std::size_t expected_steps = static_cast<std::size_t>(o.seconds * 1e9 / static_cast<double>(options.period_ns)) + 16;
  std::vector<std::int64_t> compute_ns, lateness_ns;
  compute_ns.reserve(expected_steps);
  lateness_ns.reserve(expected_steps);
  ffd::Recording recording;
  recording.scene_path = scene_path;
  recording.hash_every = static_cast<std::uint32_t>(o.hash_every);
  bool finite = true;

  auto drain = [&] {
    ffd::Telemetry t;
    while (loop.pop_telemetry(t)) {
      compute_ns.push_back(t.compute_ns);
      lateness_ns.push_back(t.lateness_ns);
      finite = finite && t.finite;
      recording.steps = t.step;
      if (t.has_hash) recording.hashes.emplace_back(t.step, t.state_hash);
    }
    ffd::Command c;
    while (loop.pop_applied_command(c)) recording.commands.push_back(c);
  };

  g_interrupted.store(false);
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  const auto start = std::chrono::steady_clock::now();
  const auto end = start + std::chrono::duration<double>(o.seconds);
  loop.start();
  // A display's pace: take the newest frame, drain the lossless queues.
  while (std::chrono::steady_clock::now() < end && !g_interrupted.load() && !loop.finished()) {
    loop.latest_frame();
    drain();
    std::this_thread::sleep_for(std::chrono::milliseconds(16));
  }
  loop.request_stop();
  loop.join();
  drain();
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);

  const ffd::LoopCounters counters = loop.counters();
  const std::size_t steps = compute_ns.size();
  const ffd::TimeSummary compute = ffd::summarize_times(compute_ns);
  const ffd::TimeSummary lateness = ffd::summarize_times(lateness_ns);
  int status = finite ? kExitOk : kExitNonFinite;
  if (!o.quiet) {
    std::printf("%s: %zu steps in real time at %.0f Hz, budget %.0f us%s\n", scene_path.c_str(), steps,
                1e6 / o.period_us, o.budget_us, g_interrupted.load() ? " (interrupted)" : "");
    print_distribution("compute", compute);
    print_distribution("lateness", lateness);
    std::printf("deadline misses %llu (%.2f%%), overruns re-phased %llu; SCHED_FIFO %s, mlockall %s\n",
                static_cast<unsigned long long>(counters.deadline_misses),
                steps ? 100.0 * static_cast<double>(counters.deadline_misses) / static_cast<double>(steps) : 0.0,
                static_cast<unsigned long long>(counters.overruns), counters.realtime_priority ? "yes" : "no",
                counters.memory_locked ? "yes" : "no");
  }
  if (!o.report_path.empty()) {
    const nlohmann::json j = {{"scene", scene_path},
                              {"steps", steps},
                              {"period_us", o.period_us},
                              {"budget_us", o.budget_us},
                              {"interrupted", g_interrupted.load()},
                              {"finite", finite},
                              {"compute", time_summary_json(compute)},
                              {"lateness", time_summary_json(lateness)},
                              {"deadline_misses", counters.deadline_misses},
                              {"overruns", counters.overruns},
                              {"telemetry_dropped", counters.telemetry_dropped},
                              {"sched_fifo", counters.realtime_priority},
                              {"memory_locked", counters.memory_locked}};
    std::ofstream out(o.report_path);
    out << j.dump(2) << '\n';
    if (!out) {
      std::fprintf(stderr, "ffdsim: error: %s: cannot write the report\n", o.report_path.c_str());
      status = kExitBadInput;
    }
  }
  if (!o.record_path.empty()) {
    try {
      ffd::write_recording(o.record_path, model, recording);
      if (!o.quiet)
        std::printf("recorded %zu commands and %zu state hashes to %s\n", recording.commands.size(),
                    recording.hashes.size(), o.record_path.c_str());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
      status = kExitBadInput;
    }
    if (counters.commands_unrecorded > 0) {
      // Written anyway (it holds all that arrived), but it will not replay this session.
      std::fprintf(stderr, "ffdsim: error: %s: %llu applied commands were lost before the recorder read them\n",
                   o.record_path.c_str(), static_cast<unsigned long long>(counters.commands_unrecorded));
      status = kExitBadInput;
    }
  }
  return status;
}

}  // namespace ffdsim
