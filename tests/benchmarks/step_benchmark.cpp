// Step time of the default scene (two teapots), per stage and whole, against the 1000 us
// budget of the 1 kHz loop. The scene is warmed up until the teapots are in contact, then
// every benchmark iteration is one step; the counters are the stage times from StepReport.
#include <benchmark/benchmark.h>

#include <cstdio>

#include "ffd/scene_loader.h"
#include "ffd/step.h"
#include "ffd/step_statistics.h"

namespace {

constexpr int kWarmupSteps = 1500;  // 1.5 s: the upper teapot has landed

void run_scene_steps(benchmark::State& bench, const ffd::SceneSpec& spec) {
  std::vector<std::string> log;
  const ffd::Model model = ffd::compile(spec, log);
  ffd::State state = ffd::initial_state(model);
  ffd::Scratch scratch = ffd::make_scratch(model);
  ffd::StepReport report;
  for (int i = 0; i < kWarmupSteps; ++i) {
    ffd::step(model, state, scratch, report);
    ffd::grow_scratch(model, scratch, report);
  }
  ffd::StepStatistics stats;
  stats.reserve(1 << 20);
  for (auto _ : bench) {
    ffd::step(model, state, scratch, report);
    stats.add(report);
  }
  for (ffd::Stage stage : model.pipeline) {
    const ffd::TimeSummary t = stats.stage_time(stage);
    bench.counters[std::string(ffd::stage_name(stage)) + "_p50_us"] = t.p50_us;
    bench.counters[std::string(ffd::stage_name(stage)) + "_p99_us"] = t.p99_us;
  }
  const ffd::TimeSummary whole = stats.step_time();
  bench.counters["step_p50_us"] = whole.p50_us;
  bench.counters["step_p99_us"] = whole.p99_us;
  bench.counters["step_max_us"] = whole.max_us;
  double collision_p50 = 0.0;
  for (ffd::Stage s : {ffd::Stage::BoxUpdate, ffd::Stage::BroadPhase, ffd::Stage::NarrowPhase, ffd::Stage::Planes})
    if (stats.ran(s)) collision_p50 += stats.stage_time(s).p50_us;
  bench.counters["collision_p50_us"] = collision_p50;
  bench.SetLabel("state_hash " + ffd::hash_hex(ffd::state_hash(state)));
}

void BM_DefaultSceneStep(benchmark::State& bench) { run_scene_steps(bench, ffd::default_scene()); }
BENCHMARK(BM_DefaultSceneStep)->Unit(benchmark::kMicrosecond)->Iterations(3000);

}  // namespace

BENCHMARK_MAIN();
