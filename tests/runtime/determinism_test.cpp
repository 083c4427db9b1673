// Determinism across what a user may change without changing the simulation: the number of
// threads a step is spread over (1, 2, 8) and the SIMD target its kernels run on (the
// baseline target forced against the best this CPU has). Same scene and commands => the same
// state hash, every step.
#include <catch2/catch.hpp>
#include <hwy/targets.h>

#include "ffd/command.h"
#include "ffd/scene_loader.h"
#include "ffd/step.h"
#include "ffd/trilinear.h"
#include "ffd/worker_pool.h"
#include "collision.h"
#include "kernels/box_kernels.h"
#include "kernels/spring_kernels.h"
#include "support/test_scenes.h"

using namespace ffd;

namespace {

// State hashes of `steps` steps of `model` on `threads` threads (1: no pool), with an
// accuracy switch through every level on the way when `levels`.
std::vector<std::uint64_t> run_hashes(const Model& model, int threads, std::uint64_t steps, bool levels) {
  State state = initial_state(model);
  const State initial = state;
  Scratch scratch = make_scratch(model);
  WorkerPool pool(threads);
  if (threads > 1) attach_pool(model, scratch, pool);
  StepReport report;
  std::vector<std::uint64_t> hashes;
  for (std::uint64_t i = 0; i < steps; ++i) {
    if (levels && i % 40 == 20) {
      Command c;
      c.kind = CommandKind::SetAccuracy;
      c.value = static_cast<double>((i / 40) % kAccuracyLevels);
      apply_command(model, initial, state, c);
    }
    step(model, state, scratch, report);
    grow_scratch(model, scratch, report);
    hashes.push_back(state_hash(state));
  }
  return hashes;
}

Model shipped(const std::string& scene) {
  return test::compile_quietly(load_scene_file(std::string(FFDSIM_SCENARIO_DIR) + "/scenes/" + scene));
}

void check_thread_counts(const Model& model, std::uint64_t steps, bool levels) {
  const std::vector<std::uint64_t> one = run_hashes(model, 1, steps, levels);
  for (const int threads : {2, 8}) {
    const std::vector<std::uint64_t> many = run_hashes(model, threads, steps, levels);
    for (std::uint64_t i = 0; i < steps; ++i) {
      INFO(threads << " threads, step " << i + 1);
      REQUIRE(many[i] == one[i]);
    }
  }
}

// Runs `fn` with the kernels dispatched to `targets` only (Highway's test hook), then back to
// every target this CPU has.
template <class Fn>
auto with_targets(std::int64_t targets, Fn fn) {
  hwy::SetSupportedTargetsForTest(targets);
  auto result = fn();
  hwy::SetSupportedTargetsForTest(0);
  return result;
}

}  // namespace

TEST_CASE("Determinism: the teapots give the same states on 1, 2 and 8 threads", "[determinism]") {
  check_thread_counts(shipped("two_teapots.toml"), 250, false);
}

TEST_CASE("Determinism: every accuracy level gives the same states on 1, 2 and 8 threads", "[determinism]") {
  check_thread_counts(shipped("shape_matching_pair.toml"), 260, true);
}

TEST_CASE("Determinism: sleeping objects give the same states on 1, 2 and 8 threads", "[determinism]") {
  SceneSpec spec;
  spec.settings.effects = Effect::Gravity | Effect::Planes | Effect::InterCollision | Effect::Sleeping;
  spec.settings.sleep_time = 0.05;
  spec.planes.push_back(test::floor_plane());
  for (int i = 0; i < 6; ++i)
    spec.objects.push_back(test::box_object("box" + std::to_string(i), Vec3(0.06, 0.04, 0.06), 0.02,
                                            Vec3(0.01 * (i % 2), 0.021 + 0.045 * i, 0.005 * i)));
  check_thread_counts(test::compile_quietly(spec), 400, false);
}

TEST_CASE("Determinism: the baseline SIMD target and the best one give the same states", "[determinism]") {
  const Model model = shipped("two_teapots.toml");
  const std::vector<std::uint64_t> best = run_hashes(model, 2, 200, false);
  const std::string best_name = simd_target_name();
  const std::vector<std::uint64_t> baseline =
      with_targets(HWY_STATIC_TARGET, [&] { return run_hashes(model, 2, 200, false); });
  INFO("best target " << best_name << ", baseline " << hwy::TargetName(HWY_STATIC_TARGET));
  CHECK(with_targets(HWY_STATIC_TARGET, [] { return std::string(simd_target_name()); }) ==
        hwy::TargetName(HWY_STATIC_TARGET));
  for (std::size_t i = 0; i < best.size(); ++i) {
    INFO("step " << i + 1);
    REQUIRE(baseline[i] == best[i]);
  }
}

TEST_CASE("Determinism: the box kernel gives trilinear_map's bits for every node of every box", "[determinism]") {
  const Model model = shipped("two_teapots.toml");
  State state = initial_state(model);
  for (std::size_t n = 0; n < state.x.size(); ++n)  // a deformed lattice
    state.x[n] += 0.003 * Vec3(std::sin(1.3 * n), std::cos(0.7 * n), std::sin(2.1 * n + 1.0));
  Scratch scratch = make_scratch(model);
  for (const BoxSet* set : {&model.boxes, &model.grid_boxes, &model.sub_boxes}) {
    update_boxes(model, *set, state, scratch);
    for (Index b = 0; b < set->size(); ++b) {
      const std::array<Index, 8>& corner = model.cell_nodes[set->box_cell[b]];
      for (int k = 0; k < 9; ++k) {
        const Vec3 expected =
            trilinear_map(set->box_local[b][k], [&](int j) -> const Vec3& { return state.x[corner[j]]; });
        INFO("box " << b << " node " << k);
        REQUIRE(scratch.box_nodes[b][k] == expected);
      }
    }
  }
}
