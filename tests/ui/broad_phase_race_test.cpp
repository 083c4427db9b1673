// The broad-phase race against FCL: every pair FCL's managers report as overlapping is one
// of our spatial hash's pairs, on random boxes, on boxes touching at a face, on a stepped
// two-teapot scene, and on empty and single-box sets; and the results format as Markdown and
// JSON.
#include "bench/broad_phase_race.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>
#include <memory>
#include <random>

#include "ffd/scene_loader.h"
#include "ffd/step.h"
#include "support/test_scenes.h"

using ffdbench::BoxSet;
using ffdbench::RaceResult;
using ffd::Vec3;

namespace {

// Uniform in [lo, hi) from the raw 32-bit output of std::mt19937, which the standard fixes:
// the same values on every platform (std::uniform_real_distribution is not specified).
double uniform(std::mt19937& rng, double lo, double hi) {
  return lo + (hi - lo) * (static_cast<double>(rng()) / 4294967296.0);
}

// The 9 nodes of an FFD box: 8 corners of [lo, hi] (x fastest), then the centre.
std::array<Vec3, 9> box_nodes(const Vec3& lo, const Vec3& hi) {
  std::array<Vec3, 9> nodes;
  for (int k = 0; k < 8; ++k)
    nodes[k] = Vec3(k & 1 ? hi.x() : lo.x(), k & 2 ? hi.y() : lo.y(), k & 4 ? hi.z() : lo.z());
  nodes[8] = 0.5 * (lo + hi);
  return nodes;
}

// `count` boxes in a 50 cm cube, 2 to 10 cm wide; corners jittered by up to 5 mm so the boxes
// are deformed hexahedra whose AABBs come from different nodes, as in a running scene.
BoxSet random_boxes(std::size_t count, std::uint32_t seed) {
  std::mt19937 rng(seed);
  BoxSet set;
  set.scenario = "random";
  set.moment = "synthetic";
  set.hash_cell_size = 0.1;  // m
  set.hash_table_size = 4093;
  set.model = ffdbench::unconnected_boxes(count);
  for (std::size_t i = 0; i < count; ++i) {
    const Vec3 centre(uniform(rng, 0.0, 0.5), uniform(rng, 0.0, 0.5), uniform(rng, 0.0, 0.5));
    const Vec3 half(uniform(rng, 0.01, 0.05), uniform(rng, 0.01, 0.05), uniform(rng, 0.01, 0.05));
    std::array<Vec3, 9> nodes = box_nodes(centre - half, centre + half);
    for (int k = 0; k < 8; ++k)
      for (int d = 0; d < 3; ++d) nodes[k][d] += uniform(rng, -0.005, 0.005);
    set.boxes.push_back(nodes);
  }
  return set;
}

// Pairs whose AABBs over the 9 nodes overlap (closed), by testing every pair.
std::size_t brute_force_pairs(const BoxSet& set) {
  std::vector<Vec3> lo, hi;
  for (const auto& nodes : set.boxes) {
    Vec3 a = nodes[0], b = nodes[0];
    for (const Vec3& p : nodes) {
      a = a.cwiseMin(p);
      b = b.cwiseMax(p);
    }
    lo.push_back(a);
    hi.push_back(b);
  }
  std::size_t pairs = 0;
  for (std::size_t i = 0; i < lo.size(); ++i)
    for (std::size_t j = i + 1; j < lo.size(); ++j)
      if ((lo[i].array() <= hi[j].array()).all() && (lo[j].array() <= hi[i].array()).all()) ++pairs;
  return pairs;
}

}  // namespace

TEST_CASE("random boxes in general position: FCL finds exactly our pairs", "[race]") {
  const BoxSet set = random_boxes(400, 20240601u);
  const RaceResult r = ffdbench::race(set, 3);
  INFO(ffdbench::markdown_table({r}));
  CHECK(r.boxes == 400);
  REQUIRE(r.our_pairs == brute_force_pairs(set));
  CHECK(r.our_pairs > r.boxes);  // dense enough to mean something (measured: 3.1 per box)
  CHECK(r.missing_tree == 0);
  CHECK(r.missing_hash == 0);
  CHECK(r.missing_any == 0);
  // No two faces coincide, so every manager sees the same overlaps.
  CHECK(r.fcl_tree_pairs == r.our_pairs);
  CHECK(r.fcl_hash_pairs == r.our_pairs);
  CHECK(r.fcl_distinct_pairs == r.our_pairs);
  CHECK(r.extra_vs_tree == 0);
  CHECK(r.extra_vs_hash == 0);
  CHECK(r.fcl_hash_candidates >= r.fcl_hash_pairs);
  CHECK(r.our_us > 0.0);
  CHECK(r.fcl_tree_us == std::min(r.fcl_tree_build_us, r.fcl_tree_update_us));
  CHECK(r.fcl_hash_us == std::min(r.fcl_hash_build_us, r.fcl_hash_update_us));
}

TEST_CASE("boxes touching at a face are a pair for us and FCL's tree", "[race]") {
  BoxSet set;
  set.scenario = "touching";
  set.hash_cell_size = 0.5;  // m
  set.hash_table_size = 101;
  // A and B touch at x = 0.5, a hash-cell boundary (FCL's grid starts at the boxes' lower
  // bound, 0, padded by whole cells); D and E touch at x = 2.2, inside a cell. F is 1 µm
  // beyond E: no pair.
  set.boxes.push_back(box_nodes(Vec3(0.0, 0.0, 0.0), Vec3(0.5, 0.5, 0.5)));  // A
  set.boxes.push_back(box_nodes(Vec3(0.5, 0.0, 0.0), Vec3(1.0, 0.5, 0.5)));  // B
  set.boxes.push_back(box_nodes(Vec3(1.9, 0.0, 0.0), Vec3(2.2, 0.5, 0.5)));  // D
  set.boxes.push_back(box_nodes(Vec3(2.2, 0.0, 0.0), Vec3(2.4, 0.5, 0.5)));  // E
  set.boxes.push_back(box_nodes(Vec3(2.400001, 0.0, 0.0), Vec3(2.6, 0.5, 0.5)));  // F
  set.model = ffdbench::unconnected_boxes(set.boxes.size());
  const RaceResult r = ffdbench::race(set, 3);
  INFO(ffdbench::markdown_table({r}));
  CHECK(r.our_pairs == 2);
  CHECK(r.fcl_tree_pairs == 2);
  CHECK(r.extra_vs_tree == 0);
  CHECK(r.missing_any == 0);
  // FCL 0.7's spatial hash puts a box in cells [floor(min / cell), ceil(max / cell)): A and
  // B share no cell and never meet. Only D and E.
  CHECK(r.fcl_hash_pairs == 1);
  CHECK(r.extra_vs_hash == 1);
}

TEST_CASE("two teapots mid-pile: FCL's pairs are all among ours", "[race]") {
  const auto shared = std::make_shared<const ffd::Model>(
      ffd::test::compile_quietly(ffd::load_scene_file(std::string(FFDSIM_SCENARIO_DIR) + "/scenes/two_teapots.toml")));
  const ffd::Model& model = *shared;
  ffd::State state = ffd::initial_state(model);
  ffd::Scratch scratch = ffd::make_scratch(model);
  ffd::StepReport report;
  constexpr int kSteps = 300;  // 0.3 s: the upper teapot landed on the lower one at ~0.1 s
  for (int i = 0; i < kSteps; ++i) {
    ffd::step(model, state, scratch, report);
    ffd::grow_scratch(model, scratch, report);
  }
  REQUIRE(report.finite);
  ffd::update_all_boxes(model, state, scratch);
  const BoxSet set = ffdbench::record_boxes(shared, scratch, "two_teapots", "mid-pile", state.step);
  REQUIRE(set.boxes.size() == model.box_count());

  const RaceResult r = ffdbench::race(set, 3);
  INFO(ffdbench::markdown_table({r}));
  CHECK(r.step == kSteps);
  CHECK(r.our_pairs > r.boxes);  // neighbouring cells of one object overlap: several per box
  CHECK(r.missing_tree == 0);
  CHECK(r.missing_hash == 0);
  CHECK(r.missing_any == 0);
  CHECK(r.fcl_tree_pairs == r.our_pairs);
  CHECK(r.extra_vs_tree == 0);
  // The hash can only lose pairs that touch exactly on a cell boundary.
  CHECK(r.fcl_hash_pairs + r.extra_vs_hash == r.our_pairs);
  CHECK(r.extra_vs_hash <= r.our_pairs / 100);
  // The step asks for fewer: no neighbouring cells of one teapot.
  CHECK(r.wanted_pairs < r.our_pairs / 2);
}

TEST_CASE("an empty set and a single box give no pairs", "[race]") {
  BoxSet set;
  set.scenario = "tiny";
  set.hash_cell_size = 0.1;
  set.hash_table_size = 17;
  set.model = ffdbench::unconnected_boxes(0);
  const RaceResult empty = ffdbench::race(set, 2);
  CHECK(empty.boxes == 0);
  CHECK(empty.our_pairs == 0);
  CHECK(empty.fcl_tree_pairs == 0);
  CHECK(empty.fcl_hash_pairs == 0);
  CHECK(empty.missing_any == 0);

  set.boxes.push_back(box_nodes(Vec3(0.1, 0.2, 0.3), Vec3(0.15, 0.25, 0.35)));
  set.model = ffdbench::unconnected_boxes(1);
  const RaceResult one = ffdbench::race(set, 2);
  CHECK(one.boxes == 1);
  CHECK(one.our_pairs == 0);
  CHECK(one.fcl_tree_pairs == 0);
  CHECK(one.fcl_hash_pairs == 0);
  CHECK(one.fcl_hash_candidates == 0);
  CHECK(one.missing_any == 0);

  set.hash_table_size = 0;
  CHECK_THROWS_AS(ffdbench::race(set, 2), std::invalid_argument);
}

TEST_CASE("race results format as a Markdown table and as JSON", "[race]") {
  RaceResult a;
  a.scenario = "bunnies_soft";
  a.moment = "settled";
  a.step = 3000;
  a.boxes = 1200;
  a.our_pairs = a.fcl_tree_pairs = a.fcl_distinct_pairs = 5000;
  a.fcl_hash_pairs = 4990;
  a.our_us = 100.0;
  a.fcl_tree_us = 250.0;
  a.fcl_hash_us = 1234.5;
  RaceResult b = a;
  b.moment = "early";
  b.missing_any = b.missing_tree = 3;
  b.our_us = 0.0;

  const std::string table = ffdbench::markdown_table({a, b});
  INFO(table);
  CHECK(table.find("| scenario | moment | step | boxes |") == 0);
  CHECK(table.find("| bunnies_soft | settled | 3000 | 1200 | 5000 / 5000 / 4990 | 100.0 | 250.0 (2.50×) | "
                   "1234.5 (12.3×) | 0, 0.0 | all 5000 FCL pairs found |") != std::string::npos);
  CHECK(table.find("3 missing (tree 3, hash 0)") != std::string::npos);
  CHECK(table.find("(n/a)") != std::string::npos);

  const nlohmann::json json = ffdbench::to_json({a, b});
  REQUIRE(json.is_array());
  REQUIRE(json.size() == 2);
  CHECK(json[0]["scenario"] == "bunnies_soft");
  CHECK(json[0]["fcl_tree_ratio"].get<double>() == Approx(2.5));
  CHECK(json[1]["fcl_tree_ratio"].is_null());
  CHECK(json[1]["missing_any"] == 3);
}
