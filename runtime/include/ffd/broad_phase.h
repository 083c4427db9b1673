#pragma once
// The spatial-hash broad phase (section 6.1) on its own, over given FFD AABBs: the very code
// step() runs, for tools that set it against other broad phases on the same boxes
// (`ffdsim bench`'s race against FCL).
#include <array>
#include <utility>
#include <vector>

#include "ffd/model.h"
#include "ffd/step.h"

namespace ffd {

class SpatialHashBroadPhase {
 public:
  // hash_cell_size: m (step() uses the largest object cell size); table_size: buckets.
  SpatialHashBroadPhase(double hash_cell_size, Index table_size);

  // The boxes to hash next: the 9 world nodes of each FFD AABB (8 corners, then the centre
  // of mass), as Scratch::box_nodes holds them after a step. Sizes the buffers.
  void set_boxes(const std::vector<std::array<Vec3, 9>>& boxes);

  // Hashes the boxes (their AABBs over the 9 nodes) and writes every candidate pair into
  // `pairs` (cleared first): box a < box b, each pair once, their AABBs overlapping.
  // Returns false when a box spans so many hash cells that the entry buffer ran out (its
  // pairs are then missing); the buffer is grown for the next call.
  bool find_pairs(std::vector<std::pair<Index, Index>>& pairs);

  // The hash-time AABB of box b (valid after find_pairs).
  const Vec3& box_min(Index b) const { return scratch_.box_min[b]; }
  const Vec3& box_max(Index b) const { return scratch_.box_max[b]; }
  std::size_t box_count() const { return model_.box_count(); }

 private:
  Model model_;      // only the broad phase's fields are set
  Scratch scratch_;
};

}  // namespace ffd
