#pragma once
// The broad phase (section 6.1) on its own, over given FFD AABBs of a compiled scene: the
// very code step() runs, for tools that set it against other broad phases on the same boxes
// (`ffdsim bench`'s race against FCL).
#include <array>
#include <memory>
#include <utility>
#include <vector>

#include "ffd/model.h"
#include "ffd/step.h"

namespace ffd {

class BroadPhase {
 public:
  // The FFD AABBs (Model::boxes, accuracy level 2) of `model`, which must outlive this.
  explicit BroadPhase(const Model& model);
  ~BroadPhase();

  // The boxes to pair next: the 9 world nodes of each FFD AABB (8 corners, then the centre of
  // mass), as Scratch::box_nodes() gives them after a step.
  void set_boxes(const std::vector<std::array<Vec3, 9>>& boxes);

  // Every pair of boxes whose AABBs (over their 9 nodes) overlap, touching included, each
  // once, (a < b) sorted: what a general broad phase such as FCL's reports, neighbouring cells
  // of one object included (those come from the lattice's neighbour lists, not a search).
  // Returns false when a buffer ran out (pairs missing; it is grown for the next call).
  bool find_all_pairs(std::vector<std::pair<Index, Index>>& pairs);

  // The pairs a step's narrow phase takes with inter- and self-collision on: boxes of
  // different objects, and of one object's cells that share no lattice node.
  bool find_wanted_pairs(std::vector<std::pair<Index, Index>>& pairs);

  // The AABB of box b over its 9 nodes (valid after a find).
  Vec3 box_min(Index b) const;
  Vec3 box_max(Index b) const;
  std::size_t box_count() const { return model_.box_count(); }

 private:
  bool find(bool neighbours, std::vector<std::pair<Index, Index>>& pairs);
  struct Memory;  // the boxes' bounds and the broad phase's working memory (broad_phase.cpp)
  const Model& model_;
  std::unique_ptr<Memory> memory_;
};

}  // namespace ffd
