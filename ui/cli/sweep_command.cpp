// `ffdsim sweep plan|run-one|run|merge|status`: parameter sweeps over a replay script
// (docs/sweeps.md). Each job runs in a child process (`ffdsim sweep exec`), so that a job
// that crashes is written down as failed, with its exit code and the end of its stderr,
// and the other jobs go on.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "output_files.h"
#include "bench/paper_table.h"
#include "ffd/replay_runner.h"
#include "ffd/sweep.h"

extern char** environ;

namespace ffdsim {
namespace {

namespace fs = std::filesystem;

std::string self_program() {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  return error ? std::string("ffdsim") : self.string();
}

// The last `lines` lines of a file (of its last 4 KiB), for a failed job's record.
std::string tail_of_file(const std::string& path, int lines = 20) {
  std::ifstream in(path, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (text.size() > 4096) text.erase(0, text.size() - 4096);
  int seen = 0;  // line ends before the text's last character: each starts a line after it
  for (std::size_t i = text.size(); i-- > 1;)
    if (text[i - 1] == '\n' && ++seen == lines) return text.substr(i);
  return text;
}

// Runs `argv` with its stdout and stderr into `log`; its exit code, or 128 + the signal that
// ended it; -1 if it could not start.
int run_child(const std::vector<std::string>& args, const std::string& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return -1;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return -1;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

// One job in a child; its result written to results/ID.json whatever happens. True: done.
bool run_one(const ffd::SweepPlan& plan, const std::string& dir, const ffd::SweepJob& job) {
  const std::string result = ffd::sweep_result_path(dir, job.id);
  const std::string out = result + ".part";
  const std::string log = (fs::path(dir) / "logs" / (job.id + ".log")).string();
  std::error_code error;
  fs::create_directories(fs::path(dir) / "logs", error);
  fs::remove(out, error);
  const auto start = std::chrono::steady_clock::now();
  const int code = run_child({self_program(), "sweep", "exec", dir, job.id, "--out", out}, log);
  std::ifstream in(out, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  fs::remove(out, error);
  bool ran = (code == kExitOk || code == kExitAssertionFailed || code == kExitRuntime) && !text.empty();
  if (ran) {
    // The job's whole time, from starting its process to having its result: beside the
    // replay's own run_s, what running it as a job costs (ffdsim sweep status).
    nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    ran = j.is_object();
    if (ran) {
      j["job_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      text = j.dump(1) + "\n";
    }
  }
  if (!ran) {
    std::string why = code < 0 ? "could not start " + self_program()
                      : code > 128 ? "ended by signal " + std::to_string(code - 128) + " (" + strsignal(code - 128) + ")"
                                   : "exited with code " + std::to_string(code);
    why += "; the end of its output (" + log + "):\n" + tail_of_file(log);
    text = ffd::sweep_job_failure_json(plan, job, code, why);
  }
  ffd::write_file_atomically(result, text);
  return ran && code == kExitOk;
}

// DIR/plan.json, or none with the reason said.
std::optional<ffd::SweepPlan> read_plan(const std::string& dir) {
  try {
    return ffd::read_sweep_plan(dir);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return std::nullopt;
  }
}

int plan_command(const std::string& sweep_file, const std::string& dir, bool quiet) {
  const auto start = std::chrono::steady_clock::now();
  ffd::SweepPlan plan;
  try {
    plan = ffd::load_sweep_file(sweep_file);
    // The replay, and the first point on its scene, load before any job is written down.
    ffd::load_sweep_job(plan, plan.jobs.front());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }
  try {
    plan.plan_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ffd::write_sweep_plan(plan, dir, self_program());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }
  if (!quiet) {
    std::printf("%s: %zu jobs over %zu parameters, planned in %s (jobs.tsv)\n", sweep_file.c_str(), plan.jobs.size(),
                plan.parameters.size(), dir.c_str());
    std::printf("Run them with one of:\n"
                "  ffdsim sweep run %s --jobs 2      (this machine)\n"
                "  %s/parallel.sh --jobs 2           (GNU parallel; --sshloginfile for several hosts)\n"
                "  sbatch --wait %s/sweep.sbatch     (a Slurm job array)\n"
                "then: ffdsim sweep merge %s\n",
                dir.c_str(), dir.c_str(), dir.c_str(), dir.c_str());
  }
  return kExitOk;
}

// The child: one job in this process, its result to `out`.
int exec_command(const std::string& dir, const std::string& id, const std::string& out) {
  ffd::SweepPlan plan;
  const ffd::SweepJob* job = nullptr;
  ffd::LoadedReplay replay;
  const auto start = std::chrono::steady_clock::now();
  try {
    plan = ffd::read_sweep_plan(dir);
    job = ffd::find_sweep_job(plan, id);
    if (!job) throw ffd::InputError(dir + "/plan.json: no job " + id);
    replay = ffd::load_sweep_job(plan, *job);
  } catch (const std::exception& e) {  // run-one records the job as failed, with this message from its log
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }
  ffd::ReplayRunOptions run;
  run.pacing = ffd::Pacing::Fast;
  // A sweep's jobs share machines: their step times are metrics, not checks.
  run.check_latency = false;
  run.threads = plan.threads;
  const auto loaded = std::chrono::steady_clock::now();
  const ffd::ReplayResult result = ffd::run_replay(replay, run);
  const auto ran = std::chrono::steady_clock::now();
  std::fputs(ffd::format_replay_result(replay.script, result).c_str(), stdout);
  const auto seconds = [](auto from, auto to) { return std::chrono::duration<double>(to - from).count(); };
  ffd::write_file_atomically(
      out, ffd::sweep_job_result_json(plan, *job, replay, result, seconds(start, loaded), seconds(loaded, ran)));
  if (!result.finite) return kExitRuntime;
  return result.passed() ? kExitOk : kExitAssertionFailed;
}

int run_one_command(const std::string& dir, const std::string& id, bool force) {
  const std::optional<ffd::SweepPlan> read = read_plan(dir);
  if (!read) return kExitBadInput;
  const ffd::SweepPlan& plan = *read;
  const ffd::SweepJob* job = ffd::find_sweep_job(plan, id);
  if (!job) {
    std::fprintf(stderr, "ffdsim: error: %s/plan.json: no job %s (jobs %s to %s)\n", dir.c_str(), id.c_str(),
                 plan.jobs.front().id.c_str(), plan.jobs.back().id.c_str());
    return kExitBadInput;
  }
  const ffd::JobState state = ffd::sweep_job_state(plan, dir, *job);
  if (state == ffd::JobState::Done && !force) return kExitOk;  // a resumed sweep: done once
  try {
    return run_one(plan, dir, *job) ? kExitOk : kExitAssertionFailed;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }
}

int run_command(const std::string& dir, int jobs, bool retry_failed, bool quiet) {
  const std::optional<ffd::SweepPlan> read = read_plan(dir);
  if (!read) return kExitBadInput;
  const ffd::SweepPlan& plan = *read;
  std::vector<const ffd::SweepJob*> todo;
  std::size_t failed_before = 0;
  for (const ffd::SweepJob& job : plan.jobs) {
    const ffd::JobState state = ffd::sweep_job_state(plan, dir, job);
    if (state == ffd::JobState::Missing || (state == ffd::JobState::Failed && retry_failed)) todo.push_back(&job);
    else if (state == ffd::JobState::Failed) ++failed_before;
  }
  std::atomic<std::size_t> next{0}, finished{0}, failed{0};
  std::mutex print;
  std::string error;
  const bool tty = isatty(STDERR_FILENO) != 0;
  const auto progress = [&] {
    if (quiet) return;
    std::fprintf(stderr, "%ssweep: %zu of %zu jobs run (%zu failed)%s", tty ? "\r" : "", finished.load(), todo.size(),
                 failed.load(), tty ? "" : "\n");
    std::fflush(stderr);
  };
  const auto worker = [&] {
    for (std::size_t i; (i = next.fetch_add(1)) < todo.size();) {
      bool done = false;
      try {
        done = run_one(plan, dir, *todo[i]);
      } catch (const std::exception& e) {
        std::lock_guard lock(print);
        error = e.what();
      }
      std::lock_guard lock(print);
      failed += done ? 0 : 1;
      ++finished;
      progress();
    }
  };
  if (!quiet)
    std::printf("%s: %zu jobs to run, %zu already there, %d at a time\n", dir.c_str(), todo.size(),
                plan.jobs.size() - todo.size(), jobs);
  std::vector<std::thread> threads;
  for (int t = 0; t < std::max(1, jobs); ++t) threads.emplace_back(worker);
  for (std::thread& t : threads) t.join();
  if (!quiet && tty) std::fputc('\n', stderr);
  if (!error.empty()) {
    std::fprintf(stderr, "ffdsim: error: %s\n", error.c_str());
    return kExitBadInput;
  }
  const std::size_t failed_now = failed.load() + failed_before;
  if (failed_now > 0)
    std::fprintf(stderr, "ffdsim: %zu of %zu jobs failed (ffdsim sweep status %s lists them)\n", failed_now,
                 plan.jobs.size(), dir.c_str());
  return failed_now > 0 ? kExitAssertionFailed : kExitOk;
}

int status_command(const std::string& dir) {
  const std::optional<ffd::SweepPlan> read = read_plan(dir);
  if (!read) return kExitBadInput;
  const ffd::SweepPlan& plan = *read;
  std::size_t count[3] = {0, 0, 0};
  std::string failed, missing;
  for (const ffd::SweepJob& job : plan.jobs) {
    const ffd::JobState state = ffd::sweep_job_state(plan, dir, job);
    ++count[static_cast<int>(state)];
    if (state == ffd::JobState::Failed) failed += " " + job.id;
    if (state == ffd::JobState::Missing) missing += " " + job.id;
  }
  std::printf("%s: %zu jobs: %zu done, %zu failed, %zu missing\n", dir.c_str(), plan.jobs.size(), count[0], count[1],
              count[2]);
  const ffd::SweepTimes times = ffd::sweep_times(plan, dir);
  const double own = times.load_s + times.run_s;
  if (times.jobs > 0 && own > 0.0)
    std::printf("time: the %zu jobs took %.2f s of their own (loading %.2f s, running %.2f s); as a sweep's jobs they "
                "took %.2f s more (%.2f %%: processes, the plan, the results)\n",
                times.jobs, own, times.load_s, times.run_s, times.overhead_s, 100.0 * times.overhead_s / own);
  if (!failed.empty()) std::printf("failed:%s\n", failed.c_str());
  if (!missing.empty()) std::printf("missing:%s\n", missing.c_str());
  return count[0] == plan.jobs.size() ? kExitOk : kExitAssertionFailed;
}

// The results page of `merge --update-docs FILE`: the summary under the stamp, the heat maps
// copied into FILE's folder beside it (FILE's name without .md, then _METRIC.png), and the
// time the jobs took.
void write_sweep_page(const std::string& dir, const std::string& page, const ffd::SweepMerge& merge,
                      std::chrono::steady_clock::time_point merge_start) {
  const ffd::SweepPlan plan = ffd::read_sweep_plan(dir);
  std::string summary = read_file(merge.summary_path);
  const std::string title = summary.substr(2, summary.find('\n') - 2);
  std::string body = summary.substr(summary.find('\n') + 1);
  const fs::path out(page);
  for (const std::string& script : merge.heat_map_scripts) {
    const fs::path png = fs::path(script).replace_extension(".png");
    const std::string name = out.stem().string() + "_" + png.filename().string();
    fs::copy_file(png, out.parent_path() / name, fs::copy_options::overwrite_existing);
    body += "\n![" + png.stem().string() + "](" + name + ")\n";
  }
  const ffd::SweepTimes times = ffd::sweep_times(plan, dir);
  const double own = times.load_s + times.run_s;
  if (times.jobs > 0 && own > 0.0) {
    // What the sweep adds to its jobs' own time: the plan, each job's processes, plan reading
    // and result, and this merge (its heat maps included).
    const double merge_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - merge_start).count();
    const double added = plan.plan_s + times.overhead_s + merge_s;
    char line[512];
    std::snprintf(line, sizeof line,
                  "\nTime: the %zu jobs took %.1f s of their own, as `ffdsim replay` of each point would (loading "
                  "%.1f s, running %.1f s). The sweep added %.2f s (%.2f %%): the plan %.2f s, the jobs' processes and "
                  "results %.2f s, the merge %.2f s.\n",
                  times.jobs, own, times.load_s, times.run_s, added, 100.0 * added / own, plan.plan_s, times.overhead_s,
                  merge_s);
    body += line;
  }
  write_results_page(page, title, ffdbench::cpu_description(), body);
}

int merge_command(const std::string& dir, const std::vector<std::string>& axes, const std::string& page, bool quiet) {
  const auto start = std::chrono::steady_clock::now();
  try {
    if (!page.empty()) check_results_page(page);
    const ffd::SweepMerge merge = ffd::merge_sweep(dir, axes);
    for (const std::string& script : merge.heat_map_scripts) {
      const std::string command = "gnuplot '" + script + "' 2>&1";
      if (std::system(command.c_str()) != 0)
        throw std::runtime_error("gnuplot failed on " + script + " (is gnuplot installed? setup.sh installs it)");
    }
    if (!page.empty()) write_sweep_page(dir, page, merge, start);
    if (!quiet)
      std::printf("%s: %zu done, %zu failed, %zu missing; wrote %s and %s\n", dir.c_str(), merge.done, merge.failed,
                  merge.missing, merge.csv_path.c_str(), merge.summary_path.c_str());
    return kExitOk;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }
}

}  // namespace

void register_sweep(CLI::App& app, SweepOptions& o) {
  CLI::App* sweep = app.add_subcommand("sweep", "Parameter sweeps over a replay script: plan, run (here, GNU parallel or "
                                                "Slurm), merge (docs/sweeps.md)");
  sweep->require_subcommand(1);
  CLI::App* plan = sweep->add_subcommand("plan", "Plan a sweep file's jobs into a folder (jobs.tsv, sweep.sbatch, parallel.sh)");
  plan->add_option("sweep", o.sweep_file, "Sweep file (TOML)")->required();
  plan->add_option("--out", o.dir, "The sweep's folder")->required();
  CLI::App* run_one = sweep->add_subcommand("run-one", "Run one job of a planned sweep into DIR/results/ID.json");
  run_one->add_option("dir", o.dir, "The sweep's folder")->required();
  run_one->add_option("id", o.id, "The job's id (jobs.tsv)")->required();
  run_one->add_flag("--force", o.force, "Run it even if its result is there");
  CLI::App* run = sweep->add_subcommand("run", "Run every job of a planned sweep on this machine (skips those done)");
  run->add_option("dir", o.dir, "The sweep's folder")->required();
  run->add_option("--jobs,-j", o.jobs, "Jobs at once")->check(CLI::Range(1, 256));
  run->add_flag("--retry-failed", o.retry_failed, "Run the failed jobs again too");
  CLI::App* merge = sweep->add_subcommand("merge", "Merge the results into DIR/results.csv and DIR/summary.md");
  merge->add_option("dir", o.dir, "The sweep's folder")->required();
  merge->add_option("--axes", o.axes, "The two numeric parameters the heat maps are drawn over (default: the first two)")
      ->expected(2)
      ->delimiter(',');
  merge->add_option("--update-docs", o.results_page,
                    "Also write the summary, the heat maps and the jobs' time as a results page stamped with this "
                    "command, the commit, the machine and the date (docs/results/sweep_*.md)");
  CLI::App* status = sweep->add_subcommand("status", "Say which jobs are done, failed or missing");
  status->add_option("dir", o.dir, "The sweep's folder")->required();
  CLI::App* exec = sweep->add_subcommand("exec", "The child run-one starts");
  exec->group("");  // hidden: not for users
  exec->add_option("dir", o.dir)->required();
  exec->add_option("id", o.id)->required();
  exec->add_option("--out", o.out)->required();
  for (CLI::App* command : {plan, run, merge}) command->add_flag("--quiet,-q", o.quiet, "Print only errors");
}

int run_sweep_command(const CLI::App& app, const SweepOptions& o) {
  const CLI::App* sweep = app.get_subcommand("sweep");
  if (sweep->got_subcommand("plan")) return plan_command(o.sweep_file, o.dir, o.quiet);
  if (sweep->got_subcommand("exec")) return exec_command(o.dir, o.id, o.out);
  if (sweep->got_subcommand("run-one")) return run_one_command(o.dir, o.id, o.force);
  if (sweep->got_subcommand("run")) return run_command(o.dir, o.jobs, o.retry_failed, o.quiet);
  if (sweep->got_subcommand("status")) return status_command(o.dir);
  if (sweep->got_subcommand("merge")) return merge_command(o.dir, o.axes, o.results_page, o.quiet);
  return kExitUsage;
}

}  // namespace ffdsim
