#include "bench/paper_table.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <utility>

#include "ffd/command.h"
#include "ffd/scene_loader.h"
#include "ffd/step.h"
#include "ffd/worker_pool.h"

namespace ffdbench {

const std::vector<Scenario>& paper_scenarios() {
  // Step counts: long enough for the paper's events (landing, piling, settling) to happen
  // inside the measured window; --quick cuts them for a smoke run.
  static const std::vector<Scenario> scenarios = {
      {"teapots", "scenes/two_teapots.toml", {"teapots", 12'640, 1'204, 1.7}, 0.15, 0.40, 500, 2500, 200, 400},
      {"alphabets", "scenes/alphabets.toml", {"alphabets", 2'265'744, 11'661, 279}, 4.0, 8.0, 500, 1500, 150, 150},
      {"happy_buddha", "scenes/happy_buddha.toml", {"happy Buddha", 293'000, 988, 0.3}, 0.10, 0.25, 500, 1500, 200, 400},
      {"bunnies_soft", "scenes/five_bunnies_soft.toml", {"bunnies", 347'250, 6'900, 0.5}, 0.5, 1.2, 500, 1500, 200, 300},
      {"bunnies_hard", "scenes/five_bunnies_hard.toml", {"bunnies", 347'250, 6'900, 0.5}, 0.35, 1.0, 500, 1500, 200, 300},
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

ffd::State initial_state_at(const ffd::Model& model, ffd::Accuracy level, ffd::ContactResponse response) {
  ffd::State state = ffd::initial_state(model);
  const ffd::State initial = state;
  ffd::Command command;
  command.kind = ffd::CommandKind::SetAccuracy;
  command.value = static_cast<double>(level);
  ffd::apply_command(model, initial, state, command);
  command.kind = ffd::CommandKind::SetResponse;
  command.value = static_cast<double>(response);
  ffd::apply_command(model, initial, state, command);
  return state;
}

double rms_speed(const ffd::Model& model, const ffd::State& state, const ffd::ObjectModel& object) {
  double kinetic = 0.0, mass = 0.0;  // 2 x J, kg
  for (ffd::Index n = object.node_begin; n < object.node_end; ++n) {
    kinetic += model.node_mass[n] * state.v[n].squaredNorm();
    mass += model.node_mass[n];
  }
  return std::sqrt(kinetic / mass);
}

namespace {

// One run of `model`: warm-up, measured window; box sets recorded when `record` is set.
ThreadRun run_scenario(const std::shared_ptr<const ffd::Model>& shared_model, ScenarioResult& result, int threads,
                       bool record, const Progress& progress, const std::string& label) {
  const ffd::Model& model = *shared_model;
  const std::uint64_t total = result.warmup_steps + result.measured_steps;
  ffd::State state = ffd::initial_state(model);
  {  // the response, switched as a user switches it: the live command
    const ffd::State initial = state;
    ffd::Command command;
    command.kind = ffd::CommandKind::SetResponse;
    command.value = static_cast<double>(result.response);
    ffd::apply_command(model, initial, state, command);
  }
  const bool record_boxes_now = record && result.response == ffd::ContactResponse::Paper;
  ffd::Scratch scratch = ffd::make_scratch(model);
  ffd::WorkerPool pool(threads);
  ffd::attach_pool(model, scratch, pool);
  ffd::Scratch record_scratch = ffd::make_scratch(model);  // boxes of the State, for the race
  ffd::StepReport report;
  const std::uint64_t record_at[3] = {total * 15 / 100, total * 55 / 100, total};
  const char* moment_names[3] = {"early", "mid-pile", "settled"};
  std::vector<double> collision_ms, step_ms, dynamics_ms, box_ms, contacts;
  for (std::vector<double>* v : {&collision_ms, &step_ms, &dynamics_ms, &box_ms, &contacts}) v->reserve(result.measured_steps);
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
      box_ms.push_back(static_cast<double>(stage(report, ffd::Stage::BoxUpdate)) * 1e-6);
      if (record) {
        const auto& narrow = report.counters[static_cast<std::size_t>(ffd::Stage::NarrowPhase)];
        const auto& planes = report.counters[static_cast<std::size_t>(ffd::Stage::Planes)];
        const std::uint32_t n = narrow.inter_contacts + narrow.self_contacts + planes.plane_contacts;
        contacts.push_back(n);
        result.contacts_max = std::max(result.contacts_max, n);
        result.max_penetration_m = std::max(result.max_penetration_m, report.max_box_penetration_m);
      }
    }
    for (int m = 0; m < 3 && record_boxes_now; ++m) {
      if (i != record_at[m] || !model.collides) continue;
      ffd::update_all_boxes(model, state, record_scratch);
      result.box_sets.push_back(record_boxes(shared_model, record_scratch, result.scenario.key, moment_names[m], state.step));
    }
    if (i % report_every == 0 || i == total)
      progress(result.scenario.key + " (" + ffd::response_name(result.response) + "): " + label +
                   (i <= result.warmup_steps ? ", warm-up" : ", measuring"),
               i, total);
  }
  ThreadRun run;
  run.threads = pool.threads();
  run.collision_mean_ms = mean(collision_ms);
  run.collision_p99_ms = percentile(collision_ms, 0.99);
  run.step_mean_ms = mean(step_ms);
  run.step_p50_ms = percentile(step_ms, 0.50);
  run.head.steps = std::min<std::uint64_t>(result.scenario.quick_measured_steps, step_ms.size());
  const auto head = [&](const std::vector<double>& v) {
    return std::vector<double>(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(run.head.steps));
  };
  run.head.step_p50_ms = percentile(head(step_ms), 0.50);
  run.head.step_mean_ms = mean(head(step_ms));
  run.head.collision_mean_ms = mean(head(collision_ms));
  run.head.dynamics_mean_ms = mean(head(dynamics_ms));
  run.head.box_update_mean_ms = mean(head(box_ms));
  run.step_p99_ms = percentile(step_ms, 0.99);
  run.dynamics_mean_ms = mean(dynamics_ms);
  run.box_update_mean_ms = mean(box_ms);
  run.state_hash = ffd::hash_hex(ffd::state_hash(state));
  if (record) result.contacts_mean = mean(contacts);
  return run;
}

}  // namespace

ScenarioResult bench_scenario(const Scenario& scenario, const std::string& scenarios_dir, bool quick, int threads,
                              const Progress& progress, ffd::ContactResponse response, bool compare_windows) {
  ScenarioResult result;
  result.scenario = scenario;
  result.response = response;
  result.warmup_steps = quick && !compare_windows ? scenario.quick_warmup_steps : scenario.warmup_steps;
  result.measured_steps = quick ? scenario.quick_measured_steps : scenario.measured_steps;

  progress(scenario.key + ": loading", 0, result.warmup_steps + result.measured_steps);
  const auto load_start = std::chrono::steady_clock::now();
  const ffd::SceneSpec spec = ffd::load_scene_file(scenarios_dir + "/" + scenario.scene_file);
  std::vector<std::string> log;
  const auto shared_model = std::make_shared<const ffd::Model>(ffd::compile(spec, log));
  const ffd::Model& model = *shared_model;
  result.load_s = seconds_since(load_start);
  result.objects = model.objects.size();
  for (const ffd::ObjectModel& o : model.objects) {
    result.triangles += o.surface.triangles.size();
    if (o.dynamics == ffd::DynamicsKind::MassSpring)
      result.spring_projections += static_cast<std::size_t>(o.spring_end - o.spring_begin) * o.mass_spring.iterations;
  }
  result.springs = model.springs.size();
  result.cells = model.cell_count();
  result.boxes = model.box_count();
  result.nodes = model.node_count();

  result.single = run_scenario(shared_model, result, 1, true, progress, "1 thread");
  result.parallel = run_scenario(shared_model, result, threads, false, progress, std::to_string(threads) + " threads");
  if (result.parallel.state_hash != result.single.state_hash)
    throw std::runtime_error(scenario.key + " (response " + ffd::response_name(response) + "): the state after " + std::to_string(result.warmup_steps + result.measured_steps) +
                             " steps differs between 1 and " + std::to_string(threads) + " threads (" +
                             result.single.state_hash + " and " + result.parallel.state_hash + ")");
  result.collision_mean_ms = result.single.collision_mean_ms;
  result.collision_p99_ms = result.single.collision_p99_ms;
  result.step_mean_ms = result.single.step_mean_ms;
  result.step_p99_ms = result.single.step_p99_ms;
  result.dynamics_mean_ms = result.single.dynamics_mean_ms;
  result.state_hash = result.single.state_hash;
  if (result.springs > 0) {
    // About 0.2 s of sweeps (20 at the least): long beside the clock, short beside the run.
    const int sweeps = std::max(20, static_cast<int>(4.0e7 / static_cast<double>(result.springs)));
    const double seconds = ffd::time_spring_sweeps(model, ffd::initial_state(model), sweeps);
    result.ns_per_spring_projection = seconds * 1e9 / (static_cast<double>(result.springs) * sweeps);
  }
  if (result.boxes > 0) result.ns_per_box_update = result.single.box_update_mean_ms * 1e6 / static_cast<double>(result.boxes);
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
  const int threads = results.empty() ? 2 : results.front().parallel.threads;
  s << "Machine: " << cpu << ". Paper: Pentium D 3.0 GHz, 2 GB RAM (Table 1, as printed).";
  if (quick) s << " **Quick run** (`--quick`: short windows, figures indicative only).";
  s << "\n\n";
  s << "| scenario | response | triangles (paper / ours) | FFD cells (paper / ours) | collision ms/step: paper | ours p99, 1 / "
    << threads << " threads | target p99 | whole step ms p99, 1 / " << threads
    << " threads | speed-up | target p99 | contacts/step: mean / max |\n";
  s << "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  const auto met = [](double value, double target) { return value <= target ? "" : " ✗"; };
  for (const ScenarioResult& r : results) {
    s << "| " << r.scenario.key << " | " << ffd::response_name(r.response) << " | " << thousands(r.scenario.paper.triangles)
      << " / " << thousands(r.triangles)
      << " | " << thousands(r.scenario.paper.cells) << " / " << thousands(r.cells) << " | "
      << fixed(r.scenario.paper.collision_ms, r.scenario.paper.collision_ms < 10 ? 1 : 0) << " | "
      << fixed(r.single.collision_p99_ms, 3) << " / " << fixed(r.parallel.collision_p99_ms, 3)
      << met(r.parallel.collision_p99_ms, r.scenario.target_p99_ms) << " | " << fixed(r.scenario.target_p99_ms, 2)
      << " | " << fixed(r.single.step_p99_ms, 2) << " / " << fixed(r.parallel.step_p99_ms, 2)
      << met(r.parallel.step_p99_ms, r.scenario.target_step_p99_ms) << " | "
      << fixed(r.parallel.step_p99_ms > 0 ? r.single.step_p99_ms / r.parallel.step_p99_ms : 0.0, 2) << "× | "
      << fixed(r.scenario.target_step_p99_ms, 2) << " | " << fixed(r.contacts_mean, 0) << " / " << r.contacts_max
      << " |\n";
  }
  s << "\nCollision handling = FFD AABB update + broad phase + narrow phase with its responses + planes, per step, "
       "over the measured steps after the warm-up (";
  std::string listed;
  for (const ScenarioResult& r : results) {
    if (listed.find(" " + r.scenario.key + " ") != std::string::npos) continue;  // once per scenario
    s << (listed.empty() ? "" : "; ") << r.scenario.key << " " << thousands(static_cast<double>(r.warmup_steps)) << " + "
      << thousands(static_cast<double>(r.measured_steps));
    listed += " " + r.scenario.key + " ";
  }
  s << " steps of 1 ms). The whole step adds the lattice dynamics (mass-spring, XPBD). Each scenario runs on 1 thread, "
       "then on "
    << threads
    << " (the same final state, checked); speed-up = whole-step p99 on 1 thread / on " << threads
    << ". ✗: above the target. The paper's bunny row (five bunnies) stands beside both spring variants. "
       "Response: how contacts are answered ([Two contact responses](../step.md#two-contact-responses) in docs/); collision handling "
       "is detection alone under `solver`, whose contacts are solved with the springs (in the whole step).\n\n";
  s << "Per element, 1 thread (mean over the measured steps; targets: a spring projection ≤ 1.5 ns, an FFD AABB "
       "update ≤ 15 ns):\n\n";
  s << "| scenario | springs | spring projections/step | ns per spring projection | FFD AABBs | ns per FFD AABB update "
       "|\n|---|---:|---:|---:|---:|---:|\n";
  for (const ScenarioResult& r : results) {
    if (r.response != ffd::ContactResponse::Paper) continue;
    s << "| " << r.scenario.key << " | " << thousands(static_cast<double>(r.springs)) << " | "
      << thousands(static_cast<double>(r.spring_projections)) << " | " << fixed(r.ns_per_spring_projection, 2)
      << met(r.ns_per_spring_projection, 1.5) << " | " << thousands(static_cast<double>(r.boxes)) << " | "
      << fixed(r.ns_per_box_update, 1) << met(r.ns_per_box_update, 15.0) << " |\n";
  }
  s << "\nA spring projection: the springs alone, every spring of the scene swept over and over from its start "
       "on one thread (the prediction, volumes, shapes and velocities left out). "
       "An FFD AABB update: eq. 2 for its 9 nodes and its world AABB.\n";
  return s.str();
}

namespace {
nlohmann::json thread_json(const ThreadRun& r) {
  return {{"threads", r.threads},          {"collision_mean_ms", r.collision_mean_ms}, {"collision_p99_ms", r.collision_p99_ms},
          {"step_mean_ms", r.step_mean_ms}, {"step_p50_ms", r.step_p50_ms},           {"step_p99_ms", r.step_p99_ms},
          {"dynamics_mean_ms", r.dynamics_mean_ms}, {"box_update_mean_ms", r.box_update_mean_ms},
          {"head", {{"steps", r.head.steps},
                    {"step_p50_ms", r.head.step_p50_ms},
                    {"step_mean_ms", r.head.step_mean_ms},
                    {"collision_mean_ms", r.head.collision_mean_ms},
                    {"dynamics_mean_ms", r.head.dynamics_mean_ms},
                    {"box_update_mean_ms", r.head.box_update_mean_ms}}},
          {"state_hash", r.state_hash}};
}
}  // namespace

nlohmann::json to_json(const std::vector<ScenarioResult>& results) {
  nlohmann::json rows = nlohmann::json::array();
  for (const ScenarioResult& r : results) {
    rows.push_back({{"scenario", r.scenario.key},
                    {"response", ffd::response_name(r.response)},
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
                    {"state_hash", r.state_hash},
                    {"target_step_p99_ms", r.scenario.target_step_p99_ms},
                    {"threads", {thread_json(r.single), thread_json(r.parallel)}},
                    {"spring_projections_per_step", r.spring_projections},
                    {"ns_per_spring_projection", r.ns_per_spring_projection},
                    {"ns_per_box_update", r.ns_per_box_update}});
  }
  return rows;
}

namespace {

// reference[key] as a number, or an error naming the source and where.
double number_at(const nlohmann::json& object, const char* key, const std::string& source, const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end() || !it->is_number())
    throw std::runtime_error(source + ": " + where + "." + key + ": missing or not a number (a bench.json written by " +
                             "`ffdsim bench` is expected; run it again to write one)");
  return it->get<double>();
}

}  // namespace

Comparison compare_to_reference(const std::vector<ScenarioResult>& results, const nlohmann::json& reference,
                                const std::string& cpu, const std::string& source) {
  Comparison out;
  const auto machine = reference.find("machine");
  if (!reference.is_object() || machine == reference.end() || !machine->is_object() || !machine->contains("cpu") ||
      !(*machine)["cpu"].is_string() || !reference.contains("scenarios") || !reference["scenarios"].is_array())
    throw std::runtime_error(source + ": not a bench.json (machine.cpu and scenarios expected)");
  out.reference_cpu = (*machine)["cpu"].get<std::string>();
  if (out.reference_cpu != cpu) return out;
  out.compared = true;
  const nlohmann::json& rows = reference["scenarios"];
  for (const ScenarioResult& r : results) {
    const std::string response = ffd::response_name(r.response);
    const nlohmann::json* found = nullptr;
    std::string where;
    for (std::size_t i = 0; i < rows.size(); ++i)
      if (rows[i].value("scenario", "") == r.scenario.key && rows[i].value("response", "") == response) {
        found = &rows[i];
        where = "scenarios[" + std::to_string(i) + "]";
      }
    const std::string row = r.scenario.key + " (" + response + ")";
    if (!found) {
      out.lines.push_back(row + ": not in " + source + ", not compared");
      continue;
    }
    const auto threads = found->find("threads");
    if (threads == found->end() || !threads->is_array() || threads->empty())
      throw std::runtime_error(source + ": " + where + ".threads: missing or empty");
    const nlohmann::json& ref = threads->back();
    where += ".threads[" + std::to_string(threads->size() - 1) + "]";
    const ThreadRun& now = r.parallel;
    // The same steps: a run as long as the reference's (its whole window), or its first steps
    // after the same warm-up (the reference's head).
    const std::string row_where = where.substr(0, where.find(".threads"));
    const bool whole = static_cast<double>(r.measured_steps) == number_at(*found, "measured_steps", source, row_where);
    const auto head = ref.find("head");
    if (!whole && (head == ref.end() || !head->is_object()))
      throw std::runtime_error(source + ": " + where + ".head: missing (written by an older ffdsim bench; run it again)");
    const nlohmann::json& window = whole ? ref : *head;
    const std::string window_where = whole ? where : where + ".head";
    if (static_cast<double>(r.warmup_steps) != number_at(*found, "warmup_steps", source, row_where) ||
        (!whole && static_cast<double>(r.measured_steps) != number_at(window, "steps", source, window_where))) {
      out.lines.push_back(row + ": measured over other steps than " + source + "'s, not compared");
      continue;
    }
    const auto reference_ms = [&](const char* key) { return number_at(window, key, source, window_where); };
    const double ref_p50 = reference_ms("step_p50_ms");
    char text[256];
    if (!(now.step_p50_ms > (1.0 + kSlowerAllowed) * ref_p50)) {
      std::snprintf(text, sizeof text, "%s: whole step p50 %.3f ms on %d threads, reference %.3f ms: ok", row.c_str(),
                    now.step_p50_ms, now.threads, ref_p50);
      out.lines.push_back(text);
      continue;
    }
    // The stage that grew the most, in ms per step over the same steps (means: a stage's p50
    // is not measured).
    const double dynamics = now.dynamics_mean_ms - reference_ms("dynamics_mean_ms");
    const double boxes = now.box_update_mean_ms - reference_ms("box_update_mean_ms");
    const double collision = (now.collision_mean_ms - now.box_update_mean_ms) -
                             (reference_ms("collision_mean_ms") - reference_ms("box_update_mean_ms"));
    const double rest = (now.step_mean_ms - now.collision_mean_ms - now.dynamics_mean_ms) -
                        (reference_ms("step_mean_ms") - reference_ms("collision_mean_ms") - reference_ms("dynamics_mean_ms"));
    const std::pair<double, const char*> stages[] = {{dynamics, "dynamics"},
                                                     {boxes, "FFD AABB update"},
                                                     {collision, "broad and narrow phase, planes"},
                                                     {rest, "the rest of the step (contact solve, sleep, measures)"}};
    const auto grew = *std::max_element(std::begin(stages), std::end(stages),
                                        [](const auto& a, const auto& b) { return a.first < b.first; });
    std::snprintf(text, sizeof text,
                  "%s: whole step p50 %.3f ms on %d threads, reference %.3f ms: SLOWER by %.0f %% (more than %.0f %%); "
                  "the stage that grew the most: %s, +%.3f ms per step",
                  row.c_str(), now.step_p50_ms, now.threads, ref_p50, 100.0 * (now.step_p50_ms / ref_p50 - 1.0),
                  100.0 * kSlowerAllowed, grew.second, grew.first);
    out.lines.push_back(text);
    out.failures.push_back(text);
  }
  return out;
}

}  // namespace ffdbench
