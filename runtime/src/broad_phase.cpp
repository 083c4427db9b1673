#include "ffd/broad_phase.h"

#include "collision.h"

namespace ffd {

SpatialHashBroadPhase::SpatialHashBroadPhase(double hash_cell_size, Index table_size) {
  model_.hash_cell_size = hash_cell_size;
  model_.hash_table_size = table_size;
  scratch_ = make_scratch(model_);  // sized for no boxes: find_pairs works before set_boxes
}

void SpatialHashBroadPhase::set_boxes(const std::vector<std::array<Vec3, 9>>& boxes) {
  if (boxes.size() != model_.box_count()) {
    model_.boxes.box_cell.assign(boxes.size(), 0);  // box_count() is all the broad phase reads
    scratch_ = make_scratch(model_);
  }
  scratch_.box_nodes = boxes;
}

bool SpatialHashBroadPhase::find_pairs(std::vector<std::pair<Index, Index>>& pairs) {
  StageCounters counters;
  StepReport report;
  report.hash_overflow = !build_spatial_hash(model_, model_.box_count(), 0.0, model_.hash_table_size, scratch_, counters);
  broad_phase_pairs(model_, scratch_, pairs);
  if (report.hash_overflow) grow_scratch(model_, scratch_, report);
  return !report.hash_overflow;
}

}  // namespace ffd
