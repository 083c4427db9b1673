// Determinism across what a user may change without changing the simulation: the number of
// threads a step is spread over (1, 2, 8) and the SIMD target its kernels run on (the
// baseline target forced against the best this CPU has). Same scene and commands => the same
// state hash, every step.
#include <catch2/catch.hpp>
#include <hwy/targets.h>

#include <cmath>
#include <utility>

#include "ffd/command.h"
#include "ffd/random_pile.h"
#include "ffd/scene_loader.h"
#include "ffd/step.h"
#include "ffd/trilinear.h"
#include "ffd/worker_pool.h"
#include "step_memory.h"
#include "kernels/aabb_kernels.h"
#include "kernels/box_kernels.h"
#include "kernels/spring_kernels.h"
#include "support/fp_traps.h"
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

TEST_CASE("Determinism: corotated cells give the same states on 1, 2 and 8 threads under both responses",
          "[determinism]") {
  SceneSpec spec;
  spec.settings.effects = Effect::Gravity | Effect::Planes | Effect::InterCollision | Effect::SelfCollision;
  spec.planes.push_back(test::floor_plane());
  for (int i = 0; i < 4; ++i) {
    ObjectSpec box = test::box_object("box" + std::to_string(i), Vec3(0.06, 0.04, 0.06), 0.02,
                                      Vec3(0.01 * (i % 2), 0.021 + 0.045 * i, 0.005 * i));
    box.rotation_deg = Vec3(10.0 * i, 25.0, 5.0);
    box.mass_spring.stiffness = 300.0;
    box.mass_spring.shape_stiffness = 4000.0;  // N/m
    spec.objects.push_back(box);
  }
  for (const ContactResponse response : {ContactResponse::Paper, ContactResponse::Solver}) {
    spec.settings.response = response;
    check_thread_counts(test::compile_quietly(spec), 300, false);
  }
}

TEST_CASE("Determinism: a random pile with box_overlap, with edge_contacts, and with both, gives the same states "
          "on 1, 2 and 8 threads at every level",
          "[determinism]") {
  // With both, the planes answer first and leave boxes stale for the narrow phase's
  // detection: on two threads a pair was passed over that one thread answered (step 501,
  // level 0 after level 5), until stale boxes counted as moved.
  for (const auto& [box_overlap, edge_contacts] : {std::pair{true, false}, std::pair{false, true}, std::pair{true, true}}) {
    CAPTURE(box_overlap, edge_contacts);
    PileOptions options;
    options.seed = 1;
    options.box_overlap = box_overlap;
    options.edge_contacts = edge_contacts;
    const SceneSpec spec = parse_scene(random_pile_scene(options), "pile_1.toml", "");
    REQUIRE(spec.settings.box_overlap == box_overlap);
    REQUIRE(spec.settings.edge_contacts == edge_contacts);
    check_thread_counts(test::compile_quietly(spec), 600, true);  // landing from about step 200
  }
}

TEST_CASE("Determinism: a pile of many objects, its pairs answered in waves, gives the same states and contacts",
          "[determinism]") {
  // 48 boxes of 8 cells in a column of 4 x 4 layers, each touching its neighbours from the
  // first step: many objects, so the narrow phase answers its pairs in waves over the threads.
  SceneSpec spec;
  spec.settings.effects = Effect::Gravity | Effect::Planes | Effect::InterCollision | Effect::Friction;
  spec.settings.edge_contacts = false;  // the boxes' waves alone: the edge tests run after them on one thread
  spec.planes.push_back(test::floor_plane());
  for (int i = 0; i < 48; ++i) {
    const Vec3 at(0.039 * (i % 4), 0.0205 + 0.039 * (i / 16), 0.039 * ((i / 4) % 4));
    spec.objects.push_back(test::box_object("box" + std::to_string(i), Vec3(0.04, 0.04, 0.04), 0.02, at));
  }
  const Model model = test::compile_quietly(spec);
  // A small contact list, so that the threads' shares overflow it and the merge has to keep
  // exactly the contacts the sequential loop keeps.
  struct Run {
    std::vector<std::uint64_t> hashes;
    std::vector<std::vector<Contact>> contacts;
    std::vector<std::uint32_t> dropped;
    std::uint32_t steps_in_waves = 0;
  };
  auto run = [&](int threads) {
    Run r;
    State state = initial_state(model);
    Scratch scratch = make_scratch(model);
    scratch.memory().contacts.resize(40);
    WorkerPool pool(threads);
    if (threads > 1) attach_pool(model, scratch, pool);
    StepReport report;
    for (int i = 0; i < 120; ++i) {
      step(model, state, scratch, report);
      grow_scratch(model, scratch, report);
      r.hashes.push_back(state_hash(state));
      r.contacts.emplace_back(scratch.contacts().begin(), scratch.contacts().end());
      r.dropped.push_back(report.contacts_dropped);
      if (scratch.memory().narrow_waves > 0) ++r.steps_in_waves;
    }
    return r;
  };
  const Run one = run(1);
  REQUIRE(one.steps_in_waves == 0);
  for (const int threads : {2, 8}) {
    const Run many = run(threads);
    INFO(threads << " threads");
    CHECK(many.steps_in_waves > 60);
    for (std::size_t i = 0; i < one.hashes.size(); ++i) {
      INFO("step " << i + 1);
      REQUIRE(many.hashes[i] == one.hashes[i]);
      REQUIRE(many.dropped[i] == one.dropped[i]);
      REQUIRE(many.contacts[i].size() == one.contacts[i].size());
      for (std::size_t k = 0; k < one.contacts[i].size(); ++k) {
        REQUIRE(many.contacts[i][k].point == one.contacts[i][k].point);
        REQUIRE(many.contacts[i][k].kind == one.contacts[i][k].kind);
        REQUIRE(many.contacts[i][k].depth == one.contacts[i][k].depth);
      }
    }
  }
  REQUIRE(*std::max_element(one.dropped.begin(), one.dropped.end()) > 0);  // the merge was put to the test
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

// Checks that kernel(count, p, q) keeps what scalar(count, p, q) keeps, in order, on every
// SIMD target, for every count up to `most` (tails included) and 12 edges pq on a coarse grid,
// q = p + step(e), the last with a NaN end. Returns how many the scalar test kept in all.
template <class Scalar, class Kernel, class Step>
std::size_t check_filter_on_every_target(Index most, const Scalar& scalar, const Kernel& kernel, const Step& step) {
  std::size_t found = 0;
  test::FpTrapsOff no_traps;  // a NaN compares false, as the filters rely on
  for (const std::int64_t targets : hwy::SupportedAndGeneratedTargets()) {
    for (Index count = 0; count <= most; ++count) {
      for (int e = 0; e < 12; ++e) {
        const Vec3 p(std::floor(3.0 * std::sin(0.8 * e)), std::floor(3.0 * std::cos(1.1 * e)), std::floor(2.0 * std::sin(2.3 * e)));
        Vec3 q = p + step(e);
        if (e == 11) q.y() = NAN;
        const std::vector<Index> expected = scalar(count, p, q);
        INFO("target " << hwy::TargetName(targets) << ", " << count << " of " << most << ", edge " << e);
        REQUIRE(with_targets(targets, [&] { return kernel(count, p, q); }) == expected);
        found += expected.size();
      }
    }
  }
  return found;
}

TEST_CASE("Determinism: the edge tests' box filter finds what the scalar test finds, in order, on every SIMD target",
          "[determinism]") {
  // Boxes on a coarse grid, so that many touch the edge's box exactly (a shared bound meets),
  // some with a NaN bound (separates nothing); every count up to a few vectors, tails included.
  std::array<std::vector<double>, 3> lo, hi;
  constexpr Index kBoxes = 41;
  for (int axis = 0; axis < 3; ++axis) {
    for (Index i = 0; i < kBoxes; ++i) {
      const double a = std::floor(4.0 * std::sin(1.7 * i + axis)), b = a + std::floor(3.0 * std::fabs(std::cos(0.9 * i * (axis + 1))));
      lo[axis].push_back(a);
      hi[axis].push_back(b);
    }
  }
  lo[1][7] = NAN;
  hi[2][20] = NAN;
  const BoxColumns boxes{{lo[0].data(), lo[1].data(), lo[2].data()}, {hi[0].data(), hi[1].data(), hi[2].data()}};
  const auto scalar = [&](Index count, const Vec3& a, const Vec3& b) {
    std::vector<Index> hits;
    for (Index i = 0; i < count; ++i) {
      bool apart = false;
      for (int axis = 0; axis < 3; ++axis) apart = apart || b[axis] < lo[axis][i] || a[axis] > hi[axis][i];
      if (!apart) hits.push_back(i);
    }
    return hits;
  };
  const auto kernel = [&](Index count, const Vec3& a, const Vec3& b) {
    std::vector<Index> hits(kBoxes);
    hits.resize(boxes_meeting(boxes, count, a, b, hits.data()));
    return hits;
  };
  // An edge with a NaN end meets every box.
  const std::size_t found = check_filter_on_every_target(kBoxes, scalar, kernel, [](int e) { return Vec3::Constant(e % 3); });
  CHECK(found > 0);  // the boxes met some edges
}

TEST_CASE("Determinism: the edge tests' triangle filter finds what the scalar test finds, in order, on every SIMD target",
          "[determinism]") {
  // Triangles on a coarse grid with faces of small integers, so that edges end exactly on
  // their planes (touching is no crossing) and boxes touch exactly (a shared bound meets); a
  // NaN in a bound, a face and a corner; every count up to a few vectors, tails included.
  constexpr Index kTriangles = 41;
  std::array<std::vector<double>, 3> lo, hi, face, corner;
  for (int axis = 0; axis < 3; ++axis) {
    for (Index i = 0; i < kTriangles; ++i) {
      const double a = std::floor(4.0 * std::sin(1.7 * i + axis)), b = a + std::floor(3.0 * std::fabs(std::cos(0.9 * i * (axis + 1))));
      lo[axis].push_back(a);
      hi[axis].push_back(b);
      face[axis].push_back(std::floor(3.0 * std::sin(2.1 * i + 1.3 * axis)));
      corner[axis].push_back(std::floor(2.0 * std::cos(1.3 * i + axis)));
    }
  }
  lo[1][7] = NAN;
  face[0][20] = NAN;
  corner[2][33] = NAN;
  const TriangleColumns triangles{{{lo[0].data(), lo[1].data(), lo[2].data()}, {hi[0].data(), hi[1].data(), hi[2].data()}},
                                  {face[0].data(), face[1].data(), face[2].data()},
                                  {corner[0].data(), corner[1].data(), corner[2].data()}};
  const auto scalar = [&](Index count, const Vec3& p, const Vec3& q) {
    const Vec3 a = p.cwiseMin(q), b = p.cwiseMax(q);
    std::vector<Index> hits;
    for (Index i = 0; i < count; ++i) {
      bool apart = false;
      for (int axis = 0; axis < 3; ++axis) apart = apart || b[axis] < lo[axis][i] || a[axis] > hi[axis][i];
      const Vec3 f(face[0][i], face[1][i], face[2][i]), c(corner[0][i], corner[1][i], corner[2][i]);
      const double hp = plane_height(f, c, p), hq = plane_height(f, c, q);
      if (!apart && ((hp > 0.0 && hq < 0.0) || (hp < 0.0 && hq > 0.0))) hits.push_back(i);
    }
    return hits;
  };
  const auto kernel = [&](Index count, const Vec3& p, const Vec3& q) {
    std::vector<Index> hits(kTriangles);
    hits.resize(triangles_straddled(triangles, count, p, q, p.cwiseMin(q), p.cwiseMax(q), hits.data()));
    return hits;
  };
  // An edge with a NaN end crosses nothing.
  const std::size_t found = check_filter_on_every_target(kTriangles, scalar, kernel,
                                                         [](int e) { return Vec3(e % 3, 2 - e % 2, (e % 4) - 1.5); });
  CHECK(found > 0);  // some edges passed through some planes
}

TEST_CASE("Determinism: the box kernel gives trilinear_map's bits for every node of every box", "[determinism]") {
  const Model model = shipped("two_teapots.toml");
  State state = initial_state(model);
  for (std::size_t n = 0; n < state.x.size(); ++n)  // a deformed lattice
    state.x[n] += 0.003 * Vec3(std::sin(1.3 * n), std::cos(0.7 * n), std::sin(2.1 * n + 1.0));
  Scratch scratch = make_scratch(model);
  for (const BoxSet* set : {&model.boxes, &model.grid_boxes, &model.sub_boxes}) {
    update_boxes(model, *set, state, scratch.memory(), nullptr);
    for (Index b = 0; b < set->size(); ++b) {
      const std::array<Index, 8>& corner = model.cell_nodes[set->box_cell[b]];
      for (int k = 0; k < 9; ++k) {
        const Vec3 expected =
            trilinear_map(set->box_local[b][k], [&](int j) -> const Vec3& { return state.x[corner[j]]; });
        INFO("box " << b << " node " << k);
        REQUIRE(scratch.box_nodes()[b][k] == expected);
      }
    }
  }
}
