#include "bench/paper_table.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "ffd/scene_loader.h"
#include "ffd/step.h"

namespace ffdbench {

const std::vector<Scenario>& paper_scenarios() {
  // Step counts: long enough for the paper's events (landing, piling, settling) to happen
  // inside the measured window; --quick cuts them for a smoke run.
  static const std::vector<Scenario> scenarios = {
      {"teapots", "scenes/two_teapots.toml", {"teapots", 12'640, 1'204, 1.7}, 0.15, 500, 2500, 200, 400},
      {"alphabets", "scenes/alphabets.toml", {"alphabets", 2'265'744, 11'661, 279}, 1.0, 500, 1500, 150, 150},
      {"happy_buddha", "scenes/happy_buddha.toml", {"happy Buddha", 293'000, 988, 0.3}, 0.10, 500, 1500, 200, 400},
      {"bunnies_soft", "scenes/five_bunnies_soft.toml", {"bunnies", 347'250, 6'900, 0.5}, 0.35, 500, 1500, 200, 300},
      {"bunnies_hard", "scenes/five_bunnies_hard.toml", {"bunnies", 347'250, 6'900, 0.5}, 0.35, 500, 1500, 200, 300},
  };
  return scenarios;
}

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string thousands(double value) {
  const long long v = std::llround(value);
  std::string digits = std::to_string(v < 0 ? -v : v);
  for (int i = static_cast<int>(digits.size()) - 3; i > 0; i -= 3) digits.insert(static_cast<std::size_t>(i), ",");
  return (v < 0 ? "-" : "") + digits;
}

}  // namespace

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  const std::size_t rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(values.size())));
  const std::size_t k = std::min(values.size() - 1, rank == 0 ? 0 : rank - 1);
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

double mean(const std::vector<double>& values) {
  double sum = 0.0;
  for (double v : values) sum += v;
  return values.empty() ? 0.0 : sum / static_cast<double>(values.size());
}

std::int64_t stage(const ffd::StepReport& r, ffd::Stage s) {
  return std::max<std::int64_t>(0, r.stage_ns[static_cast<std::size_t>(s)]);
}

std::string fixed(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  return buffer;
}

ScenarioResult bench_scenario(const Scenario& scenario, const std::string& scenarios_dir, bool quick,
                              const Progress& progress) {
  ScenarioResult result;
  result.scenario = scenario;
  result.warmup_steps = quick ? scenario.quick_warmup_steps : scenario.warmup_steps;
  result.measured_steps = quick ? scenario.quick_measured_steps : scenario.measured_steps;
  const std::uint64_t total = result.warmup_steps + result.measured_steps;

  progress(scenario.key + ": loading", 0, total);
  const auto load_start = std::chrono::steady_clock::now();
  const ffd::SceneSpec spec = ffd::load_scene_file(scenarios_dir + "/" + scenario.scene_file);
  std::vector<std::string> log;
  const ffd::Model model = ffd::compile(spec, log);
  result.load_s = seconds_since(load_start);
  result.objects = model.objects.size();
  for (const ffd::ObjectModel& o : model.objects) result.triangles += o.surface.triangles.size();
  result.cells = model.cell_count();
  result.boxes = model.box_count();
  result.nodes = model.node_count();

  ffd::State state = ffd::initial_state(model);
  ffd::Scratch scratch = ffd::make_scratch(model);
  ffd::Scratch record_scratch = ffd::make_scratch(model);  // boxes of the State, for the race
  ffd::StepReport report;
  const std::uint64_t record_at[3] = {total * 15 / 100, total * 55 / 100, total};
  const char* moment_names[3] = {"early", "mid-pile", "settled"};
  std::vector<double> collision_ms, step_ms, dynamics_ms, contacts;
  collision_ms.reserve(result.measured_steps);
  step_ms.reserve(result.measured_steps);
  dynamics_ms.reserve(result.measured_steps);
  contacts.reserve(result.measured_steps);
  const std::uint64_t report_every = std::max<std::uint64_t>(1, total / 200);
  for (std::uint64_t i = 1; i <= total; ++i) {
    ffd::step(model, state, scratch, report);
    ffd::grow_scratch(model, scratch, report);
    result.finite = result.finite && report.finite;
    if (i > result.warmup_steps) {
      const std::int64_t collision_ns = stage(report, ffd::Stage::BoxUpdate) + stage(report, ffd::Stage::BroadPhase) +
                                        stage(report, ffd::Stage::NarrowPhase) + stage(report, ffd::Stage::Planes);
      collision_ms.push_back(static_cast<double>(collision_ns) * 1e-6);
      step_ms.push_back(static_cast<double>(report.total_ns) * 1e-6);
      dynamics_ms.push_back(static_cast<double>(stage(report, ffd::Stage::Dynamics)) * 1e-6);
      const auto& narrow = report.counters[static_cast<std::size_t>(ffd::Stage::NarrowPhase)];
      const auto& planes = report.counters[static_cast<std::size_t>(ffd::Stage::Planes)];
      const std::uint32_t n = narrow.inter_contacts + narrow.self_contacts + planes.plane_contacts;
      contacts.push_back(n);
      result.contacts_max = std::max(result.contacts_max, n);
      result.max_penetration_m = std::max(result.max_penetration_m, report.max_box_penetration_m);
    }
    for (int m = 0; m < 3; ++m) {
      if (i != record_at[m] || model.hash_table_size == 0) continue;
      ffd::update_all_boxes(model, state, record_scratch);
      result.box_sets.push_back(record_boxes(model, record_scratch, scenario.key, moment_names[m], state.step));
    }
    if (i % report_every == 0 || i == total)
      progress(scenario.key + (i <= result.warmup_steps ? ": warm-up" : ": measuring"), i, total);
  }
  result.collision_mean_ms = mean(collision_ms);
  result.collision_p99_ms = percentile(collision_ms, 0.99);
  result.step_mean_ms = mean(step_ms);
  result.step_p99_ms = percentile(step_ms, 0.99);
  result.dynamics_mean_ms = mean(dynamics_ms);
  result.contacts_mean = mean(contacts);
  result.state_hash = ffd::hash_hex(ffd::state_hash(state));
  return result;
}

std::string cpu_description() {
  std::ifstream in("/proc/cpuinfo");
  std::string line, model = "unknown CPU";
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const std::size_t colon = line.find(':');
      if (colon != std::string::npos) model = line.substr(line.find_first_not_of(" \t", colon + 1));
      break;
    }
  }
  const unsigned cores = std::thread::hardware_concurrency();
  return model + " (" + std::to_string(cores) + (cores == 1 ? " core)" : " cores)");
}

std::string markdown_table(const std::vector<ScenarioResult>& results, const std::string& cpu, bool quick) {
  std::ostringstream s;
  s << "Machine: " << cpu << ". Paper: Pentium D 3.0 GHz, 2 GB RAM (Table 1, as printed).";
  if (quick) s << " **Quick run** (`--quick`: short windows, figures indicative only).";
  s << "\n\n";
  s << "| scenario | triangles (paper / ours) | FFD cells (paper / ours) | collision ms/step: paper | ours mean | ours p99 "
       "| target p99 | whole step ms: mean / p99 | contacts/step: mean / max |\n";
  s << "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const ScenarioResult& r : results) {
    s << "| " << r.scenario.key << " | " << thousands(r.scenario.paper.triangles) << " / " << thousands(r.triangles)
      << " | " << thousands(r.scenario.paper.cells) << " / " << thousands(r.cells) << " | "
      << fixed(r.scenario.paper.collision_ms, r.scenario.paper.collision_ms < 10 ? 1 : 0) << " | "
      << fixed(r.collision_mean_ms, 3) << " | " << fixed(r.collision_p99_ms, 3) << " | "
      << fixed(r.scenario.target_p99_ms, 2) << " | " << fixed(r.step_mean_ms, 2) << " / " << fixed(r.step_p99_ms, 2)
      << " | " << fixed(r.contacts_mean, 0) << " / " << r.contacts_max << " |\n";
  }
  s << "\nCollision handling = FFD AABB update + broad phase + narrow phase with its responses + planes, per step, "
       "over the measured steps after the warm-up (";
  for (std::size_t i = 0; i < results.size(); ++i) {
    const ScenarioResult& r = results[i];
    s << (i ? "; " : "") << r.scenario.key << " " << thousands(static_cast<double>(r.warmup_steps)) << " + "
      << thousands(static_cast<double>(r.measured_steps));
  }
  s << " steps of 1 ms). The whole step adds the lattice dynamics (mass-spring, XPBD). Single thread. "
       "The paper's bunny row (five bunnies) stands beside both spring variants.\n";
  return s.str();
}

nlohmann::json to_json(const std::vector<ScenarioResult>& results) {
  nlohmann::json rows = nlohmann::json::array();
  for (const ScenarioResult& r : results) {
    rows.push_back({{"scenario", r.scenario.key},
                    {"scene_file", r.scenario.scene_file},
                    {"paper", {{"name", r.scenario.paper.name},
                               {"triangles", r.scenario.paper.triangles},
                               {"ffd_cells", r.scenario.paper.cells},
                               {"collision_ms", r.scenario.paper.collision_ms},
                               {"machine", "Pentium D 3.0 GHz, 2 GB RAM"}}},
                    {"target_collision_p99_ms", r.scenario.target_p99_ms},
                    {"objects", r.objects},
                    {"triangles", r.triangles},
                    {"ffd_cells", r.cells},
                    {"ffd_aabbs", r.boxes},
                    {"lattice_nodes", r.nodes},
                    {"load_s", r.load_s},
                    {"warmup_steps", r.warmup_steps},
                    {"measured_steps", r.measured_steps},
                    {"collision_mean_ms", r.collision_mean_ms},
                    {"collision_p99_ms", r.collision_p99_ms},
                    {"step_mean_ms", r.step_mean_ms},
                    {"step_p99_ms", r.step_p99_ms},
                    {"dynamics_mean_ms", r.dynamics_mean_ms},
                    {"contacts_mean", r.contacts_mean},
                    {"contacts_max", r.contacts_max},
                    {"max_box_penetration_m", r.max_penetration_m},
                    {"finite", r.finite},
                    {"state_hash", r.state_hash}});
  }
  return rows;
}

}  // namespace ffdbench
