// Section 6.1: the spatial hash finds every pair of overlapping boxes that brute force
// finds, exactly once, also for negative and far-away coordinates.
#include <catch2/catch.hpp>
#include <algorithm>
#include <random>

#include "collision.h"
#include "ffd/step.h"

using namespace ffd;

namespace {

struct RandomBoxes {
  Model model;
  Scratch scratch;
};

RandomBoxes random_boxes(std::size_t count, const Vec3& centre, double spread, double cell, Index table, unsigned seed) {
  RandomBoxes r;
  r.model.boxes.box_cell.assign(count, 0);
  r.model.hash_table_size = table;
  r.model.hash_cell_size = cell;
  r.scratch = make_scratch(r.model);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> pos(-spread, spread), size(0.1 * cell, 1.5 * cell), jitter(-0.2, 0.2);
  for (std::size_t b = 0; b < count; ++b) {
    const Vec3 lo = centre + Vec3(pos(rng), pos(rng), pos(rng));
    const Vec3 ext(size(rng), size(rng), size(rng));
    for (int k = 0; k < 8; ++k)
      r.scratch.box_nodes[b][k] = lo + Vec3((k & 1) * ext.x(), ((k >> 1) & 1) * ext.y(), ((k >> 2) & 1) * ext.z()) +
                                  cell * Vec3(jitter(rng), jitter(rng), jitter(rng));
    r.scratch.box_nodes[b][8] = lo + 0.5 * ext;
  }
  return r;
}

std::vector<std::pair<Index, Index>> brute_force_pairs(const Scratch& s, std::size_t count) {
  std::vector<std::pair<Index, Index>> pairs;
  auto bounds = [&](Index b) {
    Vec3 lo = s.box_nodes[b][0], hi = lo;
    for (const Vec3& p : s.box_nodes[b]) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    return std::make_pair(lo, hi);
  };
  for (Index a = 0; a < count; ++a)
    for (Index b = a + 1; b < count; ++b) {
      const auto [alo, ahi] = bounds(a);
      const auto [blo, bhi] = bounds(b);
      if ((alo.array() <= bhi.array()).all() && (blo.array() <= ahi.array()).all()) pairs.emplace_back(a, b);
    }
  return pairs;
}

void check_against_brute_force(const Vec3& centre, double cell, Index table, unsigned seed) {
  RandomBoxes r = random_boxes(400, centre, 6 * cell, cell, table, seed);
  StageCounters counters;
  StepReport last;
  last.hash_overflow = true;
  // Boxes of up to 1.5 hash cells touch up to 27 cells: the first try overflows and the
  // buffer grows between "steps", as in a run.
  for (int i = 0; i < 10 && !build_spatial_hash(r.model, r.model.box_count(), 0.0, r.model.hash_table_size, r.scratch, counters); ++i) grow_scratch(r.model, r.scratch, last);
  REQUIRE(build_spatial_hash(r.model, r.model.box_count(), 0.0, r.model.hash_table_size, r.scratch, counters));
  CHECK(counters.hash_entries >= 400);
  std::vector<std::pair<Index, Index>> hashed = broad_phase_pairs(r.model, r.scratch);
  std::vector<std::pair<Index, Index>> expected = brute_force_pairs(r.scratch, 400);
  std::sort(hashed.begin(), hashed.end());
  CHECK(std::adjacent_find(hashed.begin(), hashed.end()) == hashed.end());  // each pair once
  CHECK(expected.size() > 50);  // the test means something: many overlaps
  CHECK(hashed == expected);
}

}  // namespace

TEST_CASE("spatial hash pairs equal brute-force pairs near the origin", "[broad_phase]") {
  check_against_brute_force(Vec3::Zero(), 0.02, 4000, 1);
}

TEST_CASE("spatial hash pairs equal brute-force pairs at negative coordinates", "[broad_phase]") {
  check_against_brute_force(Vec3(-3.7, -12.2, -0.9), 0.02, 4000, 2);
}

TEST_CASE("spatial hash pairs equal brute-force pairs far away", "[broad_phase]") {
  check_against_brute_force(Vec3(4.0e5, -7.5e5, 1.0e6), 1.0, 4000, 3);
}

TEST_CASE("spatial hash pairs equal brute-force pairs with a tiny table (many collisions)", "[broad_phase]") {
  check_against_brute_force(Vec3(0.5, -0.5, 0.25), 0.02, 7, 4);
}

TEST_CASE("hash grid coordinates saturate instead of overflowing", "[broad_phase]") {
  CHECK(hash_grid_coordinate(-0.5, 1.0) == -1);
  CHECK(hash_grid_coordinate(0.5, 1.0) == 0);
  CHECK(hash_grid_coordinate(1e300, 1.0) == 4503599627370496LL);
  CHECK(hash_grid_coordinate(-1e300, 1.0) == -4503599627370496LL);
  CHECK(spatial_hash(-1, -1, -1, 4000) < 4000);
}

TEST_CASE("the entry buffer overflows into a flag, and grows between steps", "[broad_phase]") {
  RandomBoxes r = random_boxes(50, Vec3::Zero(), 0.1, 0.02, 4000, 9);
  for (auto& nodes : r.scratch.box_nodes) nodes[8] = nodes[0] + Vec3(0.2, 0.2, 0.2);  // 10 hash cells a side
  StageCounters counters;
  CHECK_FALSE(build_spatial_hash(r.model, r.model.box_count(), 0.0, r.model.hash_table_size, r.scratch, counters));
  StepReport last;
  last.hash_overflow = true;
  for (int i = 0; i < 30 && !build_spatial_hash(r.model, r.model.box_count(), 0.0, r.model.hash_table_size, r.scratch, counters); ++i) grow_scratch(r.model, r.scratch, last);
  CHECK(build_spatial_hash(r.model, r.model.box_count(), 0.0, r.model.hash_table_size, r.scratch, counters));
}
