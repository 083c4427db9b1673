// Section 6.1: the broad phase finds every pair of boxes whose AABBs overlap and that the
// narrow phase wants, exactly once, as brute force does: between objects, within one object
// (cells two or more lattice steps apart) and, for the race against FCL, between
// neighbouring cells too; also far from the origin and after a buffer ran out.
#include <catch2/catch.hpp>
#include <algorithm>
#include <functional>
#include <random>

#include "step_memory.h"
#include "ffd/broad_phase.h"
#include "ffd/step.h"
#include "support/test_scenes.h"

using namespace ffd;

namespace {

// Uniform in [lo, hi) from std::mt19937's raw output (fixed by the standard).
double uniform(std::mt19937& rng, double lo, double hi) { return lo + (hi - lo) * (rng() / 4294967296.0); }

std::vector<std::pair<Index, Index>> brute_force(const StepMemory& s, std::size_t count,
                                                 const std::function<bool(Index, Index)>& wanted) {
  std::vector<std::pair<Index, Index>> pairs;
  for (Index a = 0; a < count; ++a)
    for (Index b = a + 1; b < count; ++b) {
      bool overlap = true;
      for (int axis = 0; axis < 3; ++axis)
        overlap = overlap && s.box_lo[axis][a] <= s.box_hi[axis][b] && s.box_lo[axis][b] <= s.box_hi[axis][a];
      if (overlap && wanted(a, b)) pairs.emplace_back(a, b);
    }
  return pairs;
}

// The pairs found, sorted (the broad phase hands them over in the order the narrow phase
// answers them).
std::vector<std::pair<Index, Index>> found(const StepMemory& s) {
  std::vector<std::pair<Index, Index>> pairs;
  for (Index p = 0; p < s.pair_count; ++p) pairs.emplace_back(s.pairs[p].a, s.pairs[p].b);
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

// A scene of `count` small spheres (one object each, a few cells), placed at random in a
// cube of `spread` around `centre`, their boxes from the lattice as a step makes them.
struct Scene {
  Model model;
  State state;
  Scratch scratch;
  StepMemory& memory() { return scratch.memory(); }
};

Scene spheres(int count, const Vec3& centre, double spread, unsigned seed) {
  SceneSpec spec;
  spec.settings.effects = static_cast<EffectSet>(Effect::InterCollision);
  std::mt19937 rng(seed);
  for (int i = 0; i < count; ++i) {
    ObjectSpec o = test::sphere_object("s" + std::to_string(i), uniform(rng, 0.01, 0.03), 0.012,
                                       centre + Vec3(uniform(rng, -spread, spread), uniform(rng, -spread, spread),
                                                     uniform(rng, -spread, spread)));
    spec.objects.push_back(o);
  }
  Scene s{test::compile_quietly(spec), {}, {}};
  s.state = initial_state(s.model);
  s.scratch = make_scratch(s.model);
  return s;
}

// One slab of `size` with self-collision on, undeformed.
Scene slab(const Vec3& size) {
  SceneSpec spec;
  spec.settings.effects = static_cast<EffectSet>(Effect::SelfCollision);
  spec.objects.push_back(test::box_object("slab", size, 0.02, Vec3::Zero()));
  Scene s{test::compile_quietly(spec), {}, {}};
  s.state = initial_state(s.model);
  s.scratch = make_scratch(s.model);
  return s;
}

// The boxes of the scene's State, then find_pairs with `query` as a step runs it.
bool find(Scene& s, const PairQuery& query, StageCounters& counters) {
  update_boxes(s.model, s.model.boxes, s.state, s.memory(), nullptr);
  grow_box_bounds(s.model, s.model.boxes, 0.0, s.memory(), s.memory());
  return find_pairs(s.model, s.model.boxes, query, s.memory(), s.memory(), nullptr, counters);
}

void check_inter(const Vec3& centre, unsigned seed) {
  Scene s = spheres(60, centre, 0.08, seed);
  StageCounters counters;
  PairQuery query;
  query.inter = true;
  REQUIRE(find(s, query, counters));
  const auto expected = brute_force(s.memory(), s.model.box_count(), [&](Index a, Index b) {
    return s.model.cell_object[s.model.boxes.box_cell[a]] != s.model.cell_object[s.model.boxes.box_cell[b]];
  });
  CHECK(expected.size() > 20);  // the test means something: many overlaps
  CHECK(found(s.memory()) == expected);  // each once, sorted
}

}  // namespace

TEST_CASE("broad phase: pairs between objects equal brute force near the origin", "[broad_phase]") {
  check_inter(Vec3::Zero(), 1);
}

TEST_CASE("broad phase: pairs between objects equal brute force at negative coordinates", "[broad_phase]") {
  check_inter(Vec3(-3.7, -12.2, -0.9), 2);
}

TEST_CASE("broad phase: pairs between objects equal brute force far away", "[broad_phase]") {
  check_inter(Vec3(4.0e3, -7.5e3, 1.0e4), 3);
}

TEST_CASE("broad phase: self pairs and neighbour pairs of a folded lattice equal brute force", "[broad_phase]") {
  Scene s = slab(Vec3(0.3, 0.02, 0.1));
  // Fold the slab in two about x = 0 (the right half over the left, 1 cm above it) and
  // jitter every node, so that cells far apart in the lattice overlap.
  std::mt19937 rng(7);
  for (Vec3& x : s.state.x) {
    if (x.x() > 0.0) x = Vec3(-x.x(), 0.03 - x.y(), x.z());
    x += Vec3::Constant(0.002).cwiseProduct(Vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)));
  }
  update_boxes(s.model, s.model.boxes, s.state, s.memory(), nullptr);
  grow_box_bounds(s.model, s.model.boxes, 0.0, s.memory(), s.memory());
  auto lattice_distance = [&](Index a, Index b) {
    return (s.model.boxes.box_lattice[a] - s.model.boxes.box_lattice[b]).cwiseAbs().maxCoeff();
  };
  StageCounters counters;
  PairQuery query;
  query.self = true;
  REQUIRE(find_pairs(s.model, s.model.boxes, query, s.memory(), s.memory(), nullptr, counters));
  const auto self = brute_force(s.memory(), s.model.box_count(), [&](Index a, Index b) { return lattice_distance(a, b) >= 2; });
  CHECK(self.size() > 20);
  CHECK(found(s.memory()) == self);
  query.neighbours = true;
  REQUIRE(find_pairs(s.model, s.model.boxes, query, s.memory(), s.memory(), nullptr, counters));
  const auto all = brute_force(s.memory(), s.model.box_count(), [](Index, Index) { return true; });
  CHECK(all.size() > self.size());
  CHECK(found(s.memory()) == all);
}

TEST_CASE("broad phase: an undeformed lattice gives no self pair", "[broad_phase]") {
  Scene s = slab(Vec3(0.3, 0.1, 0.2));
  StageCounters counters;
  PairQuery query;
  query.self = true;
  REQUIRE(find(s, query, counters));
  CHECK(s.memory().pair_count == 0);
  CHECK(counters.hash_entries > s.model.box_count());
}

TEST_CASE("broad phase: a pair buffer too small is reported, and grows between steps", "[broad_phase]") {
  Scene s = spheres(60, Vec3::Zero(), 0.05, 9);
  s.memory().pair_workspaces[0].pairs.resize(3);
  update_boxes(s.model, s.model.boxes, s.state, s.memory(), nullptr);
  grow_box_bounds(s.model, s.model.boxes, 0.0, s.memory(), s.memory());
  StageCounters counters;
  PairQuery query;
  query.inter = true;
  CHECK_FALSE(find_pairs(s.model, s.model.boxes, query, s.memory(), s.memory(), nullptr, counters));
  StepReport last;
  last.hash_overflow = true;
  for (int i = 0; i < 30 && !find_pairs(s.model, s.model.boxes, query, s.memory(), s.memory(), nullptr, counters); ++i)
    grow_scratch(s.model, s.scratch, last);
  CHECK(find_pairs(s.model, s.model.boxes, query, s.memory(), s.memory(), nullptr, counters));
  CHECK(s.memory().pair_count > 3);
}

TEST_CASE("broad phase: BroadPhase on recorded boxes finds what the step finds", "[broad_phase]") {
  Scene s = spheres(40, Vec3(1.0, 2.0, 3.0), 0.06, 4);
  update_boxes(s.model, s.model.boxes, s.state, s.memory(), nullptr);
  BroadPhase ours(s.model);
  ours.set_boxes(std::vector<std::array<Vec3, 9>>(s.scratch.box_nodes().begin(), s.scratch.box_nodes().begin() + s.model.box_count()));
  std::vector<std::pair<Index, Index>> wanted, all;
  REQUIRE(ours.find_wanted_pairs(wanted));
  REQUIRE(ours.find_all_pairs(all));
  std::sort(wanted.begin(), wanted.end());
  std::sort(all.begin(), all.end());
  grow_box_bounds(s.model, s.model.boxes, 0.0, s.memory(), s.memory());
  const auto expected_all = brute_force(s.memory(), s.model.box_count(), [](Index, Index) { return true; });
  CHECK(all == expected_all);
  CHECK(wanted.size() < all.size());  // neighbouring cells of one sphere overlap
  for (const auto& p : wanted) CHECK(std::binary_search(all.begin(), all.end(), p));
}
