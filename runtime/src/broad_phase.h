#pragma once
// The BroadPhase stage (section 6.1, broad_phase.cpp): the pairs of boxes whose AABBs
// overlap, found through spatial grids and sorted into the order the narrow phase answers
// them in. Reads the boxes' AABBs (boxes.h); writes its pairs.
#include <array>
#include <cstdint>
#include <vector>

#include "boxes.h"

namespace ffd {

// A candidate pair of the broad phase: boxes a < b of the accuracy level's box set.
struct BoxPair {
  Index a, b;
};

// The broad phase's working memory: each object's bounds, the objects in sweep order, and its
// tasks (an object's own pairs: a == b; a pair of objects whose bounds meet: a < b), run
// over the pool, each thread in its own workspace; the pairs found and their sort.
struct BroadPhaseMemory {
  std::vector<std::array<double, 3>> object_lo, object_hi;
  std::vector<Index> object_order;
  // Objects a and b (a == b: a's own pairs, in part `part` of `parts`, see self_pairs).
  struct PairTask {
    Index a, b;
    std::uint32_t part = 0, parts = 1;
  };
  std::vector<PairTask> pair_tasks;  // capacity grown between steps
  // A thread's room for one task: boxes picked from one object or a pair, the grid over them
  // (counting-sorted: cell c holds grid_entries[grid_begin[c] .. grid_begin[c + 1])), and the
  // pairs it found.
  struct PairWorkspace {
    std::vector<Index> box_list_a, box_list_b;
    std::vector<std::array<int, 6>> box_range;     // grid cells a listed box covers: x0, x1, y0, y1, z0, z1
    std::vector<Index> grid_begin, grid_cursor;
    std::vector<Index> grid_entries;               // capacity grown between steps
    std::array<std::vector<int>, 3> cell_lattice;  // lattice coordinates of one grid cell's boxes
    std::vector<Index> cell_far;                   // of them, those two or more lattice steps from one
    std::vector<BoxPair> pairs;                    // capacity grown between steps
    Index pair_count = 0;
    bool dropped = false;
    std::uint32_t entries = 0;                     // grid entries made (the hash_entries counter)
  };
  std::vector<PairWorkspace> pair_workspaces;  // one per thread
  // The candidate pairs of this step, sorted.
  std::vector<BoxPair> pairs;  // [0, pair_count) used; capacity grown between steps
  Index pair_count = 0;
  bool pairs_dropped = false;  // a buffer was too small this step
  // Sorting the pairs into the order they are answered in.
  struct PairKey {
    std::uint64_t key;
    BoxPair pair;
  };
  std::vector<PairKey> pair_keys, pair_sorted_keys;
  std::array<Index, 257> radix_count{};
};
// Room for a scene's broad phase on `threads` threads; and twice the room (up to a limit: a
// blown-up scene, not a large one) after a step that ran out. Between steps only.
void size_broad_phase_memory(const Model& model, BroadPhaseMemory& memory, std::size_t threads);
void grow_broad_phase_memory(const Model& model, BroadPhaseMemory& memory);

// Teschner et al. 2003: hash of integer grid coordinates (two's complement wrap for
// negative ones) into `table_size` buckets. It orders the narrow phase's pairs (broad_phase.cpp).
inline Index spatial_hash(std::int64_t gx, std::int64_t gy, std::int64_t gz, Index table_size) {
  const std::uint64_t h = (static_cast<std::uint64_t>(gx) * 73856093ull) ^
                          (static_cast<std::uint64_t>(gy) * 19349663ull) ^
                          (static_cast<std::uint64_t>(gz) * 83492791ull);
  return static_cast<Index>(h % table_size);
}

// Integer hash-grid coordinate of a world coordinate; saturates far outside +-2^52 cells
// and maps NaN to 0, so no input is undefined behaviour.
std::int64_t hash_grid_coordinate(double x, double inv_cell);

// Cells of a broad-phase grid at most (a coarser grid covers a larger region).
inline constexpr Index kBroadPhaseGridCells = 1 << 18;

// First and last box of `object` in `boxes` (boxes are stored in cell order).
inline Index first_box(const BoxSet& boxes, const ObjectModel& object) { return boxes.cell_box_begin[object.cell_begin]; }
inline Index end_box(const BoxSet& boxes, const ObjectModel& object) { return boxes.cell_box_begin[object.cell_end]; }

// The broad phase (broad_phase.cpp): first the boxes' AABBs (from the box update) grown by
// `margin` and the wake margins, and each object's bounds; then every pair of boxes the
// narrow phase wants (boxes of different objects, or of one object's cells that share no
// lattice node, as the effects ask; never two sleepers) whose AABBs overlap, once each,
// sorted, into BroadPhaseMemory::pairs. Returns false when the buffers were too small (pairs are
// then missing this step; grow_scratch() makes room between steps).
void grow_box_bounds(const Model& model, const BoxSet& boxes, double margin, BoxMemory& bounds, BroadPhaseMemory& memory);
// What find_pairs looks for: pairs of boxes of different objects (inter), of one object's
// cells that share no lattice node (self), of one object's cells that do (neighbours: what
// a general broad phase reports too, for the race against FCL); objects asleep (per object,
// may be null) pair with nothing but awake objects' boxes.
struct PairQuery {
  bool inter = false, self = false, neighbours = false;
  const std::uint8_t* asleep = nullptr;
  bool ordered = true;  // in the order the narrow phase answers them (else as found)
};
bool find_pairs(const Model& model, const BoxSet& boxes, const PairQuery& query, const BoxMemory& bounds,
                BroadPhaseMemory& memory, WorkerPool* pool, StageCounters& counters);
// The pairs the scene's effects ask for, at the accuracy level's boxes.
bool find_candidate_pairs(const Model& model, const BoxLevel& level, const BoxMemory& bounds, BroadPhaseMemory& memory,
                          WorkerPool* pool, StageCounters& counters);

}  // namespace ffd
