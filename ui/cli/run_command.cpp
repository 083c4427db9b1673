// `ffdsim run`: a scene on the real-time physics loop.
//   - with a display: the interactive window (GLFW);
//   - without one: the headless demo, which drives the same viewer from a UI input script on
//     EGL and writes PNG frames and the latency report;
//   - `--headless` alone: the physics loop only, read at a display's pace (no rendering);
//   - `--headless --frames DIR` / `--input FILE`: the headless viewer.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "app/session.h"
#include "app/ui_run.h"
#include "commands.h"
#include "device/device_link.h"
#include "ffd/physics_loop.h"
#include "ffd/recording.h"
#include "ffd/replay_runner.h"
#include "ffd/scene_loader.h"
#include "ffd/sweep.h"
#include "json_report.h"

namespace ffdsim {

namespace {

std::atomic<bool> g_interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the signal handler needs a lock-free flag");
extern "C" void on_interrupt(int) { g_interrupted.store(true); }

void print_distribution(const char* name, const ffd::TimeSummary& d) {
  std::printf("%-9s us: p50 %8.1f  p99 %8.1f  p99.9 %8.1f  max %8.1f\n", name, d.p50_us, d.p99_us, d.p999_us, d.max_us);
}

std::string demo_script_path() { return ffd::scenario_dir() + "/ui_scripts/ui_demo.toml"; }

bool display_present() {
  const char* x11 = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  return (x11 && *x11) || (wayland && *wayland);
}

// What every run reports, whichever way it ran.
struct RunFigures {
  std::string scene_path;
  std::string mode;  // "window", "headless viewer", "headless loop"
  std::vector<std::int64_t> compute_ns, lateness_ns;
  ffd::LoopCounters counters;
  std::array<std::uint64_t, ffd::kAccuracyLevels> steps_at_level{};
  bool finite = true;
  ffd::Recording log;
  // --record: the file was written as the run went; its figures and the first write error.
  std::size_t recorded_commands = 0, recorded_hashes = 0;
  std::string recording_error;
  std::string exports_summary, exports_error;  // --surfaces-every, --series
  nlohmann::json ui;  // UI figures, when a viewer ran
  const ffd::device::DeviceLink* device = nullptr;  // --device
};

nlohmann::json device_json(const ffd::device::DeviceLink& link) {
  const ffd::device::LinkCounters c = link.counters();
  nlohmann::json malformed = nlohmann::json::object();
  for (std::size_t i = 1; i < c.malformed.size(); ++i)
    malformed[ffd::device::decode_error_name(static_cast<ffd::device::DecodeError>(i))] = c.malformed[i];
  const ffd::device::LinkSettings& s = link.settings();
  return {{"url", "udp://" + s.address + ":" + std::to_string(link.port())},
          {"state", ffd::device::link_state_name(c.state)},
          {"datagrams", c.datagrams},
          {"samples", c.samples},
          {"malformed", malformed},
          {"malformed_total", c.malformed_total()},
          {"duplicates", c.duplicates},
          {"out_of_order", c.out_of_order},
          {"sequence_gaps", c.sequence_gaps},
          {"queue_full", c.queue_full},
          {"forces_sent", c.forces_sent},
          {"forces_unsent", c.forces_unsent},
          {"watchdog_trips", c.watchdog_trips},
          {"reengagements", c.reengagements},
          {"force_limited_steps", c.force_limited},
          {"rate_limited_steps", c.rate_limited},
          {"sample_rate_hz", c.sample_rate_hz},
          {"force_limit_n", s.force_limit_n},
          {"force_rate_limit_n_per_ms", s.force_rate_limit_n_per_ms},
          {"watchdog_ms", s.watchdog_ms}};
}

// The run report (--report) as JSON.
nlohmann::json report_json(const RunOptions& o, const RunFigures& f, bool interrupted, bool running) {
  const std::size_t steps = f.compute_ns.size();
  const ffd::TimeSummary compute = ffd::summarize_times(f.compute_ns);
  const ffd::TimeSummary lateness = ffd::summarize_times(f.lateness_ns);
  nlohmann::json j = {{"scene", f.scene_path},
                      {"mode", f.mode},
                      {"steps", steps},
                      {"period_us", o.period_us},
                      {"budget_us", o.budget_us},
                      {"interrupted", interrupted},
                      {"finite", f.finite},
                      {"compute", time_summary_json(compute)},
                      {"lateness", time_summary_json(lateness)},
                      {"deadline_misses", f.counters.deadline_misses},
                      {"overruns", f.counters.overruns},
                      {"commands_applied", f.log.commands.size()},
                      {"commands_late", f.counters.commands_late},
                      {"telemetry_dropped", f.counters.telemetry_dropped},
                      {"accuracy_switches", f.counters.accuracy_switches},
                      {"steps_at_accuracy_level", f.steps_at_level},
                      {"sched_fifo", f.counters.realtime_priority},
                      {"memory_locked", f.counters.memory_locked}};
  if (!f.ui.is_null()) j["ui"] = f.ui;
  if (f.device) j["device"] = device_json(*f.device);
  j["running"] = running;  // true: written while the run went on (it was cut off if it stays so)
  return j;
}

// Through a temporary file renamed over the report: a run killed at any moment leaves the
// last complete report. False if it cannot be written.
bool write_report_file(const std::string& path, const nlohmann::json& j) {
  const std::string temporary = path + ".partial";
  {
    std::ofstream out(temporary, std::ios::trunc);
    out << j.dump(2) << '\n';
    if (!out) return false;
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  return !error;
}

int report(const RunOptions& o, const RunFigures& f) {
  const std::size_t steps = f.compute_ns.size();
  const ffd::TimeSummary compute = ffd::summarize_times(f.compute_ns);
  const ffd::TimeSummary lateness = ffd::summarize_times(f.lateness_ns);
  int status = f.finite ? kExitOk : kExitRuntime;
  const bool interrupted = g_interrupted.load();
  if (!o.quiet) {
    std::printf("%s (%s): %zu steps in real time at %.0f Hz, budget %.0f us%s\n", f.scene_path.c_str(), f.mode.c_str(),
                steps, 1e6 / o.period_us, o.budget_us, interrupted ? " (interrupted)" : "");
    print_distribution("compute", compute);
    print_distribution("lateness", lateness);
    std::printf("deadline misses %llu (%.2f%%), overruns re-phased %llu, late commands %llu; %d thread%s, SIMD %s; "
                "SCHED_FIFO %s, mlockall %s\n",
                static_cast<unsigned long long>(f.counters.deadline_misses),
                steps ? 100.0 * static_cast<double>(f.counters.deadline_misses) / static_cast<double>(steps) : 0.0,
                static_cast<unsigned long long>(f.counters.overruns), static_cast<unsigned long long>(f.counters.commands_late),
                f.counters.threads, f.counters.threads == 1 ? "" : "s", ffd::simd_target_name(),
                f.counters.realtime_priority ? "yes" : "no", f.counters.memory_locked ? "yes" : "no");
    if (f.counters.accuracy_switches > 0 || o.auto_accuracy) {
      std::printf("accuracy: %llu switches; steps per level", static_cast<unsigned long long>(f.counters.accuracy_switches));
      for (int l = 0; l < ffd::kAccuracyLevels; ++l)
        std::printf(" %d: %llu", l, static_cast<unsigned long long>(f.steps_at_level[static_cast<std::size_t>(l)]));
      std::printf("\n");
    }
    if (!f.ui.is_null())
      std::printf("ui: %s, %zu frames, %.1f ms per frame (max %.1f), %zu commands applied\n",
                  f.ui.value("renderer", "").c_str(), f.ui.value("frames", std::size_t{0}), f.ui.value("frame_mean_ms", 0.0),
                  f.ui.value("frame_max_ms", 0.0), f.log.commands.size());
    if (f.device) {
      const ffd::device::LinkCounters c = f.device->counters();
      std::printf("device: %s, %llu samples (%.0f Hz), %llu malformed, %llu duplicates, %llu out of order, %llu "
                  "missing; %llu forces sent; watchdog %llu, force limited %llu steps, rate limited %llu\n",
                  ffd::device::link_state_name(c.state), static_cast<unsigned long long>(c.samples), c.sample_rate_hz,
                  static_cast<unsigned long long>(c.malformed_total()), static_cast<unsigned long long>(c.duplicates),
                  static_cast<unsigned long long>(c.out_of_order), static_cast<unsigned long long>(c.sequence_gaps),
                  static_cast<unsigned long long>(c.forces_sent), static_cast<unsigned long long>(c.watchdog_trips),
                  static_cast<unsigned long long>(c.force_limited), static_cast<unsigned long long>(c.rate_limited));
    }
  }
  if (!o.report_path.empty() && !write_report_file(o.report_path, report_json(o, f, interrupted, false))) {
    std::fprintf(stderr, "ffdsim: error: %s: cannot write the report\n", o.report_path.c_str());
    status = kExitBadInput;
  }
  if (!f.exports_error.empty()) {
    std::fprintf(stderr, "ffdsim: error: %s\n", f.exports_error.c_str());
    status = kExitBadInput;
  } else if (!f.exports_summary.empty() && !o.quiet) {
    std::printf("%s\n", f.exports_summary.c_str());
  }
  if (f.counters.snapshots_dropped > 0)  // the writer fell behind the real-time loop
    std::fprintf(stderr, "ffdsim: warning: the surfaces of %llu steps were dropped (written too slowly for real "
                 "time: a larger --surfaces-every, or replay --fast with the recording, writes them all)\n",
                 static_cast<unsigned long long>(f.counters.snapshots_dropped));
  if (!o.record_path.empty()) {  // written as the run went (Session, recording.h)
    if (!f.recording_error.empty()) {
      std::fprintf(stderr, "ffdsim: error: %s\n", f.recording_error.c_str());
      status = kExitBadInput;
    } else if (!o.quiet) {
      std::printf("recorded %zu commands and %zu state hashes to %s (written as the run went)\n", f.recorded_commands,
                  f.recorded_hashes, o.record_path.c_str());
    }
    if (f.counters.commands_unrecorded > 0) {
      // It holds all that arrived, but it will not replay this session.
      std::fprintf(stderr, "ffdsim: error: %s: %llu applied commands were lost before the recorder read them\n",
                   o.record_path.c_str(), static_cast<unsigned long long>(f.counters.commands_unrecorded));
      status = kExitBadInput;
    }
  }
  return status;
}

ffd::LoopOptions loop_options(const RunOptions& o, ffd::device::DeviceLink* device) {
  ffd::LoopOptions options;
  options.pacing = ffd::Pacing::RealTime;
  options.period_ns = static_cast<std::int64_t>(o.period_us * 1000.0);
  options.budget_ns = static_cast<std::int64_t>(o.budget_us * 1000.0);
  options.spin_ns = static_cast<std::int64_t>(o.spin_us * 1000.0);
  options.hash_every = static_cast<std::uint32_t>(o.hash_every);
  options.auto_accuracy = o.auto_accuracy;
  options.threads = thread_count(o.threads);
  options.probe_source = device;
  return options;
}

// The physics loop alone (a Session without a viewer), its queues read at a 60 Hz display's pace.
RunFigures figures_of(const ffd::ui::Session& session, const std::string& mode) {
  RunFigures f;
  f.scene_path = session.scene_path();
  f.mode = mode;
  f.compute_ns = session.compute_ns();
  f.lateness_ns = session.lateness_ns();
  f.counters = session.counters();
  f.finite = session.history().finite;
  f.steps_at_level = session.history().steps_at_level;
  f.log = session.log();
  return f;
}

RunFigures run_loop_only(const RunOptions& o, const std::string& scene_path, ffd::device::DeviceLink* device) {
  ffd::ui::SessionOptions options;
  options.loop = loop_options(o, device);
  options.loop.frame_boxes = false;  // nobody draws them
  options.record_path = o.record_path;
  options.exports = o.exports.options();
  ffd::ui::Session session(scene_path, options);
  const auto start = std::chrono::steady_clock::now();
  const auto end = start + std::chrono::duration<double>(o.seconds > 0.0 ? o.seconds : 10.0);
  // The report at the start and then every second, so that a killed run leaves one.
  auto next_report = start;
  while (std::chrono::steady_clock::now() < end && !g_interrupted.load()) {
    session.poll();
    if (!o.report_path.empty() && std::chrono::steady_clock::now() >= next_report) {
      RunFigures now = figures_of(session, "headless loop");
      now.device = device;
      write_report_file(o.report_path, report_json(o, now, false, true));
      next_report += std::chrono::seconds(1);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(16));
  }
  session.stop();
  RunFigures f = figures_of(session, "headless loop");
  f.scene_path = scene_path;
  f.device = device;
  if (const ffd::RunExports* e = session.exports()) {
    f.exports_summary = e->summary();
    f.exports_error = e->error();
  }
  if (const ffd::RecordingStream* r = session.recording()) {
    f.recorded_commands = r->commands();
    f.recorded_hashes = r->hashes();
    f.recording_error = session.recording_error();
  }
  return f;
}

// With a script and no --seconds, a wall-clock guard far beyond the script's own length.
double script_guard_seconds(const ffd::UiScript& script) { return script.duration_ms * 1e-3 * 20.0 + 30.0; }

}  // namespace

void register_run(CLI::App& app, RunOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "run", "Run a scene on the real-time physics loop: a window where there is a display, else the headless demo");
  cmd->add_option("scene", o.scene, "Scene file (TOML); default: two teapots dropped on a floor");
  cmd->add_flag("--headless", o.headless, "No window. Alone: the physics loop only; with --frames or --input: the viewer on EGL");
  cmd->add_flag("--window", o.window, "Insist on a window (fail without a display)")->excludes("--headless");
  cmd->add_option("--seconds", o.seconds, "Wall-clock seconds to run (default: 10 headless, until closed in a window)")
      ->check(CLI::Range(0.001, 1e6));
  cmd->add_option("--frames", o.frames_dir, "Headless: write what the window would show as PNGs (and frames.json) here");
  cmd->add_option("--fps", o.fps, "PNG frames per simulated second")->check(CLI::Range(0.1, 1000.0));
  cmd->add_option("--input", o.input_script, "UI input script: mouse and keys drive the viewer (docs/realtime.md, \"UI input scripts\")");
  cmd->add_option("--width", o.width, "Framebuffer width, px")->check(CLI::Range(64, 8192));
  cmd->add_option("--height", o.height, "Framebuffer height, px")->check(CLI::Range(64, 8192));
  cmd->add_option("--record", o.record_path, "Record the command stream and state hashes to this replay file");
  cmd->add_option("--hash-every", o.hash_every, "State hash every N steps (recording, report)")
      ->check(CLI::Range(1LL, 1000000LL));
  cmd->add_option("--report", o.report_path, "Write the latency figures as JSON to this file");
  cmd->add_option("--period-us", o.period_us, "Loop period, microseconds (1000 = 1 kHz)")->check(CLI::Range(50.0, 1e6));
  cmd->add_option("--budget-us", o.budget_us, "Latency budget per step, microseconds")->check(CLI::Range(1.0, 1e7));
  cmd->add_flag("--auto-accuracy", o.auto_accuracy,
                "Budget-aware accuracy: run the most accurate collision level whose steps fit the budget (from the "
                "scene's level up); each switch is recorded");
  cmd->add_option("--spin-us", o.spin_us, "Busy-wait before each release, microseconds")->check(CLI::Range(0.0, 1e6));
  add_export_options(*cmd, o.exports);
  add_threads_option(*cmd, o.threads);
  cmd->add_option("--device", o.device_url,
                  "A haptic device bridge drives the probe over UDP at this address, udp://127.0.0.1:PORT (docs/realtime.md, "
                  "\"Haptic devices\")");
  cmd->add_flag("--device-allow-remote", o.device_allow_remote,
                "Let --device bind an address other than loopback (the probe is then reachable from the network)");
  cmd->add_option("--force-limit", o.force_limit_n, "Device: largest force sent, N (default: the scene's [probe] force_limit)")
      ->check(CLI::Range(1e-6, 1e6));
  cmd->add_option("--force-rate-limit", o.force_rate_limit,
                  "Device: largest change of the force sent, N/ms (default: the scene's [probe] force_rate_limit)")
      ->check(CLI::Range(1e-6, 1e6));
  cmd->add_option("--watchdog-ms", o.watchdog_ms,
                  "Device: no sample for this long sets the force to zero and holds the probe (default: the scene's "
                  "[probe] watchdog_ms)")
      ->check(CLI::Range(0.1, 1e6));
  CLI::Option* sweep = cmd->add_option("--sweep", o.sweep_dir, "A planned sweep's folder: open one of its points (--point)");
  CLI::Option* point = cmd->add_option("--point", o.sweep_point, "The sweep's job id whose scene to open (jobs.tsv)");
  sweep->needs(point);
  point->needs(sweep);
  cmd->add_flag("--quiet,-q", o.quiet, "Print only errors");
}

int run_run(const RunOptions& given) {
  RunOptions o = given;
  if (!o.sweep_dir.empty()) {
    // The point's scene written beside the sweep's results, then run as any scene.
    if (!o.scene.empty()) {
      std::fprintf(stderr, "ffdsim: error: run takes a scene or --sweep DIR --point ID, not both\n");
      return kExitUsage;
    }
    try {
      const ffd::SweepPlan plan = ffd::read_sweep_plan(o.sweep_dir);
      const ffd::SweepJob* job = ffd::find_sweep_job(plan, o.sweep_point);
      if (!job) throw ffd::InputError(o.sweep_dir + "/plan.json: no job " + o.sweep_point);
      const std::filesystem::path scene = std::filesystem::path(o.sweep_dir) / "points" / (job->id + ".toml");
      std::filesystem::create_directories(scene.parent_path());
      ffd::write_file_atomically(scene.string(), ffd::sweep_point_scene(plan, *job));
      o.scene = scene.string();
      if (!o.quiet) std::printf("sweep point %s: %s\n", job->id.c_str(), o.scene.c_str());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
      return kExitBadInput;
    }
  }
  // No display and no --headless: the headless demo, with its outputs where the README says.
  const bool demo = !o.headless && !o.window && !display_present();
  if (demo) {
    if (o.frames_dir.empty()) o.frames_dir = "out/frames";
    if (o.report_path.empty()) o.report_path = "out/report.json";
    if (o.input_script.empty() && o.seconds == 0.0) o.input_script = demo_script_path();
    if (!o.quiet) std::printf("no display (DISPLAY is not set): running the headless demo\n");
  }
  const bool viewer = !o.headless || !o.frames_dir.empty() || !o.input_script.empty();
  ffd::Model model;
  std::string scene_path;
  std::optional<ffd::UiScript> script;
  std::unique_ptr<ffd::device::DeviceLink> device;
  ffd::device::LinkSettings link;  // --device: where it listens, then its limits from the scene
  if (!o.device_url.empty()) {
    try {
      ffd::device::parse_device_url(o.device_url, link);
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "ffdsim: error: --device %s\n", e.what());
      return kExitUsage;
    }
  }
  try {
    if (!o.input_script.empty()) {
      script = ffd::load_ui_script_file(o.input_script);
      if (!script->scene_path.empty() && !o.scene.empty() && !demo)
        throw ffd::InputError(o.input_script + ": names a scene and the command line names another; give one");
    }
    const std::string scene = !o.scene.empty() ? o.scene : script && !script->scene_path.empty() ? script->scene_path : ffd::default_scene_path();
    scene_path = std::filesystem::absolute(scene).lexically_normal().string();
    std::vector<std::string> log;
    model = ffd::compile_scene(ffd::load_scene_file(scene_path), scene_path, log);
    for (const std::string& line : log)  // e.g. objects that start inside each other
      if (line.rfind("warning: ", 0) == 0 && !o.quiet) std::fprintf(stderr, "ffdsim: %s: %s\n", scene_path.c_str(), line.c_str());
    if (!o.report_path.empty()) ensure_parent_folder(o.report_path);
    if (!o.record_path.empty()) ensure_parent_folder(o.record_path);
    if (!o.frames_dir.empty()) ensure_folder(o.frames_dir);
    if (!o.frames_dir.empty() && !o.headless && !demo)
      throw ffd::InputError("--frames writes the headless viewer's frames: add --headless");
    if (!o.device_url.empty()) {
      if (!ffd::has(model.settings.effects, ffd::Effect::Probe))
        throw ffd::InputError(scene_path + ": --device drives the probe, and the scene has no \"probe\" effect");
      link.allow_remote = o.device_allow_remote;
      const ffd::ProbeSettings& probe = model.settings.probe;
      link.force_limit_n = o.force_limit_n > 0.0 ? o.force_limit_n : probe.force_limit;
      link.force_rate_limit_n_per_ms = o.force_rate_limit > 0.0 ? o.force_rate_limit : probe.force_rate_limit;
      link.watchdog_ms = o.watchdog_ms > 0.0 ? o.watchdog_ms : probe.watchdog_ms;
      link.step_ms = model.settings.dt * 1000.0;
      device = std::make_unique<ffd::device::DeviceLink>(link);
      if (!o.quiet)
        std::printf("device link: listening on udp://%s:%u\n", link.address.c_str(), static_cast<unsigned>(device->port()));
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }

  g_interrupted.store(false);
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  RunFigures figures;
  int status = kExitOk;
  if (!viewer) {
    try {
      figures = run_loop_only(o, scene_path, device.get());
    } catch (const std::exception& e) {  // the recording cannot be created
      std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
      return kExitBadInput;
    }
  } else {
    ffd::ui::UiRunOptions u;
    u.viewer.scene_path = scene_path;
    u.viewer.session.loop = loop_options(o, device.get());
    u.viewer.device = device.get();
    u.viewer.session.record_path = o.record_path;
    u.viewer.session.exports = o.exports.options();
    u.script = script;
    const bool window = !o.headless && !demo;
    u.seconds = o.seconds > 0.0 ? o.seconds : script ? script_guard_seconds(*script) : window ? 0.0 : 10.0;
    u.frames_dir = o.frames_dir;
    u.fps = o.fps;
    u.width = o.width;
    u.height = o.height;
    u.interrupted = &g_interrupted;
    // The report at the first frame and every second (the fallback below may set its path).
    u.every_second = [&o, &device, window](const ffd::ui::Session& session) {
      if (o.report_path.empty()) return;
      RunFigures now = figures_of(session, window ? "window" : "headless viewer");
      now.device = device.get();
      write_report_file(o.report_path, report_json(o, now, false, true));
    };
    ffd::ui::UiRunResult r;
    try {
      try {
        r = window ? ffd::ui::run_window(u) : ffd::ui::run_headless(u);
        figures.mode = window ? "window" : "headless viewer";
      } catch (const ffd::InputError&) {
        throw;
      } catch (const std::exception& e) {
        if (!window || o.window) throw;
        // A display that cannot give a window: fall back to the headless demo.
        std::fprintf(stderr, "ffdsim: %s; running the headless demo instead\n", e.what());
        if (u.frames_dir.empty()) u.frames_dir = o.frames_dir = "out/frames";
        if (o.report_path.empty()) o.report_path = "out/report.json";
        ensure_folder(u.frames_dir);
        ensure_parent_folder(o.report_path);
        if (!u.script && o.seconds == 0.0) {  // as without a display: --seconds S is S seconds of frames
          u.script = ffd::load_ui_script_file(demo_script_path());
          u.seconds = script_guard_seconds(*u.script);
        }
        r = ffd::ui::run_headless(u);
        figures.mode = "headless viewer";
      }
    } catch (const ffd::InputError& e) {
      std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
      return kExitBadInput;
    } catch (const std::exception& e) {  // no window, no OpenGL context
      std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
      return kExitRuntime;
    }
    figures.scene_path = r.scene_path;
    figures.device = device.get();
    figures.compute_ns = std::move(r.compute_ns);
    figures.lateness_ns = std::move(r.lateness_ns);
    figures.counters = r.counters;
    figures.finite = r.finite;
    figures.steps_at_level = r.steps_at_level;
    figures.log = std::move(r.log);
    figures.recorded_commands = r.recorded_commands;
    figures.recorded_hashes = r.recorded_hashes;
    figures.recording_error = r.recording_error;
    figures.exports_summary = r.exports_summary;
    figures.exports_error = r.exports_error;
    figures.ui = {{"renderer", r.renderer},         {"frames", r.ui_frames},
                  {"frame_mean_ms", r.ui_frame_mean_ms}, {"frame_max_ms", r.ui_frame_max_ms},
                  {"png_frames", r.frames_written}, {"script_events", r.script_events},
                  {"script_events_done", r.script_events_done}};
    if (script && r.script_events_done < r.script_events && !g_interrupted.load()) {
      std::fprintf(stderr, "ffdsim: error: %s: the run ended after %zu of %zu inputs\n", o.input_script.c_str(),
                   r.script_events_done, r.script_events);
      status = kExitAssertionFailed;
    }
    if (!o.frames_dir.empty() && !o.quiet)
      std::printf("frames: %zu PNGs in %s/ (index: %s/frames.json)\n", r.frames_written, o.frames_dir.c_str(),
                  o.frames_dir.c_str());
  }
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  const int report_status = report(o, figures);
  if (!o.report_path.empty() && !o.quiet) std::printf("report: %s\n", o.report_path.c_str());
  return status != kExitOk ? status : report_status;
}

}  // namespace ffdsim
