#include "boxes.h"

#include <algorithm>

#include "ffd/worker_pool.h"
#include "kernels/box_kernels.h"

namespace ffd {

BoxLevel box_level(const Model& model, Accuracy accuracy) {
  const double skin = model.box_skin;
  // The exact edges are tested between objects: a scene without inter-collision has none, at
  // any level (its objects, if several, do not collide with each other at all).
  const bool between = has(model.settings.effects, Effect::InterCollision);
  const bool edges = between && model.settings.edge_contacts;  // levels 0-3: the scene's choice
  // The solver's edges follow edge_contacts at every level, 4 and 5 too: a soft lattice at
  // level 5 rests only with its vertex contacts answered at once (docs/limits.md), and a
  // scene chooses that with edge_contacts = false.
  switch (accuracy) {
    case Accuracy::GridCells: return {&model.grid_boxes, 0, 8, false, false, edges, edges, skin};
    case Accuracy::BoundaryNodes: return {&model.boxes, 0, 8, false, false, edges, edges, skin};
    case Accuracy::CentreOfMass: return {&model.boxes, 0, 9, false, false, edges, edges, skin};
    case Accuracy::SampleNodes: return {&model.boxes, 8, 9, true, false, edges, edges, skin};
    case Accuracy::SubBoxes: return {&model.sub_boxes, 0, 9, false, false, between, edges, std::max(skin, model.sub_box_skin)};
    case Accuracy::Exact: return {&model.boxes, 0, 9, false, true, between, edges, skin};
  }
  return {&model.boxes, 0, 9, false, false, edges, edges, skin};
}

namespace {
BoxOutput box_output(BoxMemory& memory, bool bounds) {
  BoxOutput out{memory.box_nodes.data(), {nullptr, nullptr, nullptr}, {nullptr, nullptr, nullptr}, memory.box_valid.data()};
  if (bounds)
    for (int axis = 0; axis < 3; ++axis) {
      out.lo[axis] = memory.box_lo[axis].data();
      out.hi[axis] = memory.box_hi[axis].data();
    }
  return out;
}
}  // namespace

void update_box(const Model&, const BoxSet& boxes, const State& state, BoxMemory& memory, Index b) {
  // The AABB too: the planes' early-out reads it (it stays grown by no broad-phase margin).
  update_one_box(boxes, b, state.x.data()->data(), box_output(memory, true));
}

void update_boxes(const Model&, const BoxSet& boxes, const State& state, BoxMemory& memory, WorkerPool* pool) {
  const BoxOutput out = box_output(memory, true);
  const double* x = state.x.data()->data();
  const Index blocks = static_cast<Index>(boxes.block_count());
  constexpr Index kBlocksPerChunk = 64;  // 256 boxes: a few microseconds of work
  const Index chunks = (blocks + kBlocksPerChunk - 1) / kBlocksPerChunk;
  auto run = [&](std::uint32_t chunk, std::uint32_t) {
    update_box_blocks(boxes, chunk * kBlocksPerChunk, std::min(blocks, (chunk + 1) * kBlocksPerChunk), x, out);
  };
  parallel_for(pool, chunks, run);
}

void invalidate_around(const Model& model, const BoxSet& boxes, BoxMemory& memory, Index cell) {
  for (Index i = model.cell_neighbour_begin[cell]; i < model.cell_neighbour_begin[cell + 1]; ++i) {
    const Index c = model.cell_neighbours[i];
    for (Index b = boxes.cell_box_begin[c]; b < boxes.cell_box_begin[c + 1]; ++b) {
      memory.box_valid[b] = 0;
      memory.box_moved[b] = 1;
    }
  }
}

void ensure_box(const Model& model, const BoxSet& boxes, const State& state, BoxMemory& memory, Index b,
                StageCounters& counters) {
  if (memory.box_valid[b]) return;
  update_box(model, boxes, state, memory, b);
  ++counters.boxes_updated;
}

std::size_t largest_box_set(const Model& model) {
  return std::max({model.boxes.size(), model.grid_boxes.size(), model.sub_boxes.size()});
}

void size_box_memory(const Model& model, BoxMemory& memory) {
  const std::size_t boxes = largest_box_set(model);
  memory.box_nodes.resize(boxes);
  memory.box_valid.assign(boxes, 0);
  memory.box_moved.assign(boxes, 0);
  for (int axis = 0; axis < 3; ++axis) {
    memory.box_lo[axis].resize(boxes);
    memory.box_hi[axis].resize(boxes);
  }
  if (has(model.settings.effects, Effect::Sleeping)) memory.box_wake_margin.assign(boxes, 0.0);
}

}  // namespace ffd
