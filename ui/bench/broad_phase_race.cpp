#include "bench/broad_phase_race.h"

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/broadphase/broadphase_spatialhash.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/narrowphase/collision_object.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "ffd/broad_phase.h"

namespace ffdbench {

namespace {

using Pair = std::pair<ffd::Index, ffd::Index>;
using Clock = std::chrono::steady_clock;

// An FCL object for one FFD AABB: a Box of the AABB's extents at its centre (identity
// rotation), whose world AABB is then set to ours exactly. FCL would compute centre +- half
// extents, which can differ from our min/max in the last bit and make pairs that touch
// exactly come and go; with identical AABBs and the same closed overlap test on both sides,
// the coverage check needs no tolerance. CollisionObject<double>::aabb is protected in 0.7
// (getAABB() is read-only), hence the subclass. The managers read it through getAABB() and
// never recompute it (computeAABB() is the caller's to call), so it stays ours.
class BoxObject : public fcl::CollisionObject<double> {
 public:
  BoxObject(ffd::Index index, const ffd::Vec3& lo, const ffd::Vec3& hi)
      : fcl::CollisionObject<double>(std::make_shared<fcl::Box<double>>(ffd::Vec3(hi - lo)),
                                     Eigen::Matrix3d::Identity(), ffd::Vec3(0.5 * (lo + hi))),
        index_(index) {
    set_aabb(lo, hi);
  }
  void set_aabb(const ffd::Vec3& lo, const ffd::Vec3& hi) {
    aabb.min_ = lo;
    aabb.max_ = hi;
  }
  ffd::Index index() const { return index_; }

 private:
  ffd::Index index_;  // the box's index in the BoxSet
};

// What the collide callback gathers. FCL's spatial hash reports every pair sharing a bucket
// (its callback is meant to run the narrow phase), the tree only pairs whose AABBs overlap:
// the callback applies FCL's own AABB overlap test (closed, as ours) to both, the cheapest
// first test a user's callback would make.
struct Collector {
  std::vector<Pair> pairs;  // (a < b)
  std::size_t candidates = 0;
  void clear() {
    pairs.clear();  // keeps the capacity: no allocation inside the timed runs after warm-up
    candidates = 0;
  }
};

bool collect(fcl::CollisionObject<double>* o1, fcl::CollisionObject<double>* o2, void* data) {
  Collector& c = *static_cast<Collector*>(data);
  ++c.candidates;
  if (o1->getAABB().overlap(o2->getAABB())) {
    const ffd::Index a = static_cast<const BoxObject*>(o1)->index();
    const ffd::Index b = static_cast<const BoxObject*>(o2)->index();
    c.pairs.emplace_back(std::min(a, b), std::max(a, b));
  }
  return false;  // never stop early: we want every pair
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Median µs of `run` over `repetitions` timed runs after one untimed warm-up; `prepare`
// runs untimed before each run.
template <class PrepareFn, class RunFn>
double median_us(int repetitions, PrepareFn&& prepare, RunFn&& run) {
  prepare();
  run();
  std::vector<double> us;
  us.reserve(static_cast<std::size_t>(repetitions));
  for (int r = 0; r < repetitions; ++r) {
    prepare();
    const Clock::time_point t0 = Clock::now();
    run();
    const Clock::time_point t1 = Clock::now();
    us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  return median(std::move(us));
}

std::vector<Pair> sorted_unique(std::vector<Pair> v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

std::vector<Pair> merged(const std::vector<Pair>& a, const std::vector<Pair>& b) {
  std::vector<Pair> all(a);
  all.insert(all.end(), b.begin(), b.end());
  return sorted_unique(std::move(all));
}

// How many pairs of `of` are not in `in` (sorted).
std::size_t count_not_in(const std::vector<Pair>& of, const std::vector<Pair>& in) {
  return static_cast<std::size_t>(
      std::count_if(of.begin(), of.end(), [&](const Pair& p) { return !std::binary_search(in.begin(), in.end(), p); }));
}

double ratio(double fcl_us, double our_us) { return our_us > 0.0 ? fcl_us / our_us : 0.0; }

std::string format(const char* fmt, double value) {
  char text[64];
  std::snprintf(text, sizeof text, fmt, value);
  return text;
}

std::string format_ratio(double fcl_us, double our_us) {
  if (!(our_us > 0.0)) return "n/a";
  const double r = fcl_us / our_us;
  return format(r < 10.0 ? "%.2f×" : r < 100.0 ? "%.1f×" : "%.0f×", r);
}

std::string markdown_cell(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '|') out += '\\';
    out += c;
  }
  return out;
}

}  // namespace

BoxSet record_boxes(std::shared_ptr<const ffd::Model> model, const ffd::Scratch& scratch, std::string scenario,
                    std::string moment, std::uint64_t step) {
  BoxSet set;
  set.scenario = std::move(scenario);
  set.moment = std::move(moment);
  set.step = step;
  for (const ffd::ObjectModel& o : model->objects) set.hash_cell_size = std::max(set.hash_cell_size, o.cell_size);
  set.hash_table_size = static_cast<ffd::Index>(std::max<std::size_t>(4000, 2 * model->box_count()));
  set.boxes.assign(scratch.box_nodes().begin(), scratch.box_nodes().begin() + model->box_count());
  set.model = std::move(model);
  return set;
}

std::shared_ptr<const ffd::Model> unconnected_boxes(std::size_t count) {
  auto model = std::make_shared<ffd::Model>();
  model->collides = true;
  for (std::size_t b = 0; b < count; ++b) {
    const auto i = static_cast<ffd::Index>(b);
    ffd::ObjectModel o;
    o.name = "box" + std::to_string(b);
    o.cell_size = 1.0;
    o.cell_begin = o.box_begin = i;
    o.cell_end = o.box_end = i + 1;
    model->objects.push_back(o);
    model->cell_object.push_back(i);
    model->cell_coord.push_back(ffd::Vec3i::Zero());
    model->cell_neighbour_begin.push_back(i);
    model->cell_neighbours.push_back(i);
    model->boxes.box_cell.push_back(i);
    model->boxes.cell_box_begin.push_back(i);
    model->boxes.box_lattice.push_back(ffd::Vec3i::Zero());
  }
  model->cell_neighbour_begin.push_back(static_cast<ffd::Index>(count));
  model->boxes.cell_box_begin.push_back(static_cast<ffd::Index>(count));
  return model;
}

RaceResult race(const BoxSet& set, int repetitions) {
  if (!set.model) throw std::invalid_argument("race: the box set has no model");
  if (!(set.hash_cell_size > 0.0)) throw std::invalid_argument("race: hash_cell_size must be > 0");
  if (set.hash_table_size == 0) throw std::invalid_argument("race: hash_table_size must be > 0");
  repetitions = std::max(repetitions, 1);

  RaceResult result;
  result.scenario = set.scenario;
  result.moment = set.moment;
  result.step = set.step;
  result.boxes = set.boxes.size();
  const std::size_t n = set.boxes.size();

  // Ours: each call recomputes the AABBs from the nodes and pairs from scratch, as step()
  // does. The warm-up also grows the buffers until every pair fits.
  ffd::BroadPhase ours(*set.model);
  std::vector<Pair> our_pairs, wanted;
  ours.set_boxes(set.boxes);
  for (int attempt = 0; !ours.find_all_pairs(our_pairs); ++attempt)
    if (attempt == 64) throw std::runtime_error("race: our broad phase keeps running out of room");
  result.our_us = median_us(repetitions, [] {}, [&] {
    if (!ours.find_all_pairs(our_pairs)) throw std::runtime_error("race: our broad phase ran out of room after warm-up");
  });
  result.our_pairs = our_pairs.size();
  for (int attempt = 0; !ours.find_wanted_pairs(wanted); ++attempt)
    if (attempt == 64) throw std::runtime_error("race: our broad phase keeps running out of room");
  result.wanted_us = median_us(repetitions, [] {}, [&] {
    if (!ours.find_wanted_pairs(wanted)) throw std::runtime_error("race: our broad phase ran out of room after warm-up");
  });
  result.wanted_pairs = wanted.size();
  ours.find_all_pairs(our_pairs);  // the AABBs FCL gets below

  // FCL's objects, built from our hash-time AABBs. The vector is sized once and outlives
  // both managers (declared after it, destroyed first), so their pointers never dangle.
  std::vector<BoxObject> objects;
  objects.reserve(n);
  ffd::Vec3 scene_lo = ffd::Vec3::Zero(), scene_hi = ffd::Vec3::Zero();
  for (std::size_t b = 0; b < n; ++b) {
    const auto i = static_cast<ffd::Index>(b);
    objects.emplace_back(i, ours.box_min(i), ours.box_max(i));
    scene_lo = b == 0 ? ours.box_min(i) : scene_lo.cwiseMin(ours.box_min(i));
    scene_hi = b == 0 ? ours.box_max(i) : scene_hi.cwiseMax(ours.box_max(i));
  }
  std::vector<fcl::CollisionObject<double>*> pointers;
  pointers.reserve(n);
  for (BoxObject& o : objects) pointers.push_back(&o);
  // The "AABBs changed" of the update variants: every object's AABB rewritten. The values
  // are the same, which gives FCL 0.7 no shortcut in the work done: the tree's update()
  // copies every leaf's AABB, refits and rebalances; the hash's clears and re-inserts every
  // object. It does keep the tree in its bulk-built shape, which boxes moving from step to
  // step would slowly degrade: the update figure leans in FCL's favour.
  const auto rewrite_aabbs = [&] {
    for (std::size_t b = 0; b < n; ++b) {
      const auto i = static_cast<ffd::Index>(b);
      objects[b].set_aabb(ours.box_min(i), ours.box_max(i));
    }
  };

  // Dynamic AABB tree, default settings. registerObjects on an empty tree builds it in bulk
  // (and marks it set up); one at a time it would insert incrementally.
  fcl::DynamicAABBTreeCollisionManager<double> tree;
  Collector tree_build, tree_update;
  result.fcl_tree_build_us = median_us(
      repetitions,
      [&] {
        tree.clear();
        tree_build.clear();
      },
      [&] {
        tree.registerObjects(pointers);
        tree.setup();
        tree.collide(&tree_build, collect);
      });
  result.fcl_tree_update_us = median_us(
      repetitions,
      [&] {
        rewrite_aabbs();
        tree_update.clear();
      },
      [&] {
        tree.update();
        tree.collide(&tree_update, collect);
      });

  // Spatial hashing with the default hash table (SimpleHashTable: a vector of std::list
  // buckets), our cell size and bucket count. The scene limits are the boxes' bounds padded
  // by one cell, so every box lies inside: FCL keeps boxes reaching out of the limits in
  // lists tested against everything, and 0.7's clear() forgets to empty one of them.
  const ffd::Vec3 pad = ffd::Vec3::Constant(set.hash_cell_size);
  fcl::SpatialHashingCollisionManager<double> hash(set.hash_cell_size, scene_lo - pad, scene_hi + pad,
                                                   set.hash_table_size);
  Collector hash_build, hash_update;
  result.fcl_hash_build_us = median_us(
      repetitions,
      [&] {
        hash.clear();
        hash_build.clear();
      },
      [&] {
        hash.registerObjects(pointers);
        hash.setup();
        hash.collide(&hash_build, collect);
      });
  result.fcl_hash_update_us = median_us(
      repetitions,
      [&] {
        rewrite_aabbs();
        hash_update.clear();
      },
      [&] {
        hash.update();
        hash.collide(&hash_update, collect);
      });

  result.fcl_tree_us = std::min(result.fcl_tree_build_us, result.fcl_tree_update_us);
  result.fcl_hash_us = std::min(result.fcl_hash_build_us, result.fcl_hash_update_us);
  result.fcl_tree_pairs = tree_build.pairs.size();
  result.fcl_hash_pairs = hash_build.pairs.size();
  result.fcl_hash_candidates = hash_build.candidates;

  // Coverage, over the pairs of both variants of each manager (they should agree). No
  // tolerance: FCL tested exactly our AABBs (see BoxObject).
  const std::vector<Pair> ours_sorted = sorted_unique(our_pairs);
  const std::vector<Pair> tree_set = merged(tree_build.pairs, tree_update.pairs);
  const std::vector<Pair> hash_set = merged(hash_build.pairs, hash_update.pairs);
  const std::vector<Pair> fcl_set = merged(tree_set, hash_set);
  result.missing_tree = count_not_in(tree_set, ours_sorted);
  result.missing_hash = count_not_in(hash_set, ours_sorted);
  result.missing_any = count_not_in(fcl_set, ours_sorted);
  result.fcl_distinct_pairs = fcl_set.size();
  result.extra_vs_tree = count_not_in(ours_sorted, tree_set);
  result.extra_vs_hash = count_not_in(ours_sorted, hash_set);
  return result;
}

std::string markdown_table(const std::vector<RaceResult>& results) {
  std::ostringstream out;
  out << "| scenario | moment | step | boxes | overlapping pairs (ours / FCL tree / FCL hash) | ours µs "
         "| FCL tree µs (× ours) | FCL spatial hash µs (× ours) | pairs the step wants: count, µs | coverage |\n"
      << "|---|---|---:|---:|---:|---:|---:|---:|---:|---|\n";
  for (const RaceResult& r : results) {
    out << "| " << markdown_cell(r.scenario) << " | " << markdown_cell(r.moment) << " | " << r.step << " | " << r.boxes
        << " | " << r.our_pairs << " / " << r.fcl_tree_pairs << " / " << r.fcl_hash_pairs << " | "
        << format("%.1f", r.our_us) << " | " << format("%.1f", r.fcl_tree_us) << " ("
        << format_ratio(r.fcl_tree_us, r.our_us) << ") | " << format("%.1f", r.fcl_hash_us) << " ("
        << format_ratio(r.fcl_hash_us, r.our_us) << ") | " << r.wanted_pairs << ", " << format("%.1f", r.wanted_us)
        << " | ";
    if (r.missing_any == 0) out << "all " << r.fcl_distinct_pairs << " FCL pairs found";
    else out << r.missing_any << " missing (tree " << r.missing_tree << ", hash " << r.missing_hash << ")";
    out << " |\n";
  }
  out << "\nMedian µs per run after one warm-up. Ours: every overlapping pair, as FCL reports them (AABBs from the "
         "9 nodes, object bounds, grids; neighbouring cells of one object from the lattice's neighbour lists); the "
         "step itself asks only for the pairs it wants (last but one column). "
         "FCL (0.7): the faster of a rebuild (registerObjects + setup + collide) and a per-step update "
         "(update + collide, objects registered); its AABBs are given, not computed. Pairs: AABBs overlapping "
         "(touching counts); FCL's spatial hash misses pairs that only touch on a hash-cell boundary.\n";
  return out.str();
}

nlohmann::json to_json(const std::vector<RaceResult>& results) {
  nlohmann::json rows = nlohmann::json::array();
  const auto ratio_or_null = [](double fcl_us, double our_us) -> nlohmann::json {
    if (!(our_us > 0.0)) return nullptr;
    return ratio(fcl_us, our_us);
  };
  for (const RaceResult& r : results) {
    rows.push_back({{"scenario", r.scenario},
                    {"moment", r.moment},
                    {"step", r.step},
                    {"boxes", r.boxes},
                    {"our_pairs", r.our_pairs},
                    {"fcl_tree_pairs", r.fcl_tree_pairs},
                    {"fcl_hash_pairs", r.fcl_hash_pairs},
                    {"fcl_hash_candidates", r.fcl_hash_candidates},
                    {"wanted_pairs", r.wanted_pairs},
                    {"wanted_us", r.wanted_us},
                    {"our_us", r.our_us},
                    {"fcl_tree_us", r.fcl_tree_us},
                    {"fcl_tree_build_us", r.fcl_tree_build_us},
                    {"fcl_tree_update_us", r.fcl_tree_update_us},
                    {"fcl_tree_ratio", ratio_or_null(r.fcl_tree_us, r.our_us)},
                    {"fcl_hash_us", r.fcl_hash_us},
                    {"fcl_hash_build_us", r.fcl_hash_build_us},
                    {"fcl_hash_update_us", r.fcl_hash_update_us},
                    {"fcl_hash_ratio", ratio_or_null(r.fcl_hash_us, r.our_us)},
                    {"missing_tree", r.missing_tree},
                    {"missing_hash", r.missing_hash},
                    {"missing_any", r.missing_any},
                    {"fcl_distinct_pairs", r.fcl_distinct_pairs},
                    {"extra_vs_tree", r.extra_vs_tree},
                    {"extra_vs_hash", r.extra_vs_hash}});
  }
  return rows;
}

}  // namespace ffdbench
