// The broad phase (paper section 6.1). The paper hashes every box of the scene into one
// spatial hash and visits every pair of boxes sharing a bucket; most of those pairs are
// neighbouring cells of one object, which touch by construction and are thrown away after
// the visit. Here the work follows what the narrow phase wants:
//   - between objects: only pairs of objects whose bounds overlap (sort and sweep over the
//     objects' AABBs), and of those only the boxes inside the other object's bounds, paired
//     through a small grid over the overlap region (the paper's spatial grid, per pair);
//   - within an object (self-collision): a grid over the object; a grid cell whose boxes are
//     all lattice neighbours of each other (every grid cell of an undeformed object) is
//     passed over whole, without pairing its boxes.
// A pair found in several grid cells is taken only in the cell holding the lower corner of
// the overlap of the two AABBs, so each pair is found once. The pairs are then sorted, so
// the narrow phase answers them in an order that depends on nothing but the boxes.
#include "broad_phase.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "ffd/broad_phase.h"
#include "ffd/worker_pool.h"

namespace ffd {

namespace {

// What the searches read: the boxes' AABBs grown by the margins (BoxMemory) and each
// object's bounds (BroadPhaseMemory).
struct Bounds {
  const std::array<std::vector<double>, 3>& box_lo;
  const std::array<std::vector<double>, 3>& box_hi;
  const std::vector<std::array<double, 3>>& object_lo;
  const std::vector<std::array<double, 3>>& object_hi;
};

// A dense grid over a region: integer cell coordinates clamped into [0, n) per axis, so a
// box far outside (or non-finite) lands in a border cell and is still paired correctly,
// only less selectively. Cells are numbered x fastest.
struct Grid {
  double origin[3];
  double inv_cell;
  int n[3];

  int coordinate(double v, int axis) const {
    const double g = (v - origin[axis]) * inv_cell;
    if (!(g > 0.0)) return 0;  // also NaN
    return g >= n[axis] - 1 ? n[axis] - 1 : static_cast<int>(g);  // truncation: floor for g > 0
  }
  std::size_t cells() const { return static_cast<std::size_t>(n[0]) * n[1] * n[2]; }
  std::size_t index(int x, int y, int z) const {
    return static_cast<std::size_t>(x) + static_cast<std::size_t>(n[0]) * (static_cast<std::size_t>(y) + static_cast<std::size_t>(n[1]) * z);
  }
};

// A grid of about `cell` over [lo, hi], with at most kBroadPhaseGridCells cells (coarser if the
// region is huge: a blown-up object).
Grid make_grid(const double lo[3], const double hi[3], double cell) {
  Grid g;
  double extent[3];
  for (int a = 0; a < 3; ++a) {
    g.origin[a] = std::isfinite(lo[a]) ? lo[a] : 0.0;
    extent[a] = std::isfinite(hi[a] - g.origin[a]) && hi[a] > g.origin[a] ? hi[a] - g.origin[a] : 0.0;
  }
  if (!(cell > 0.0)) cell = 1.0;
  for (;;) {
    double cells = 1.0;
    for (int a = 0; a < 3; ++a) cells *= std::floor(extent[a] / cell) + 1.0;
    if (cells <= kBroadPhaseGridCells) break;
    cell *= 2.0;
  }
  g.inv_cell = 1.0 / cell;
  for (int a = 0; a < 3; ++a) g.n[a] = static_cast<int>(std::floor(extent[a] / cell)) + 1;
  return g;
}

// The grid cell edge: the scene's hash_cell_size, or the objects' lattice cell size (a box
// lies within its cell, so it covers at most 2 x 2 x 2 grid cells until it turns).
double grid_cell(const Model& model, double object_cell) {
  return model.settings.hash_cell_size > 0.0 ? model.settings.hash_cell_size : object_cell;
}

bool overlap(const Bounds& s, Index a, Index b) {
  for (int axis = 0; axis < 3; ++axis)
    if (!(s.box_lo[axis][a] <= s.box_hi[axis][b] && s.box_lo[axis][b] <= s.box_hi[axis][a])) return false;
  return true;
}

// The pair is taken in grid cell (x, y, z) only if it holds the lower corner of the overlap.
bool lower_corner_here(const Grid& g, const Bounds& s, Index a, Index b, int x, int y, int z) {
  return g.coordinate(std::max(s.box_lo[0][a], s.box_lo[0][b]), 0) == x &&
         g.coordinate(std::max(s.box_lo[1][a], s.box_lo[1][b]), 1) == y &&
         g.coordinate(std::max(s.box_lo[2][a], s.box_lo[2][b]), 2) == z;
}

// The cell of the hash that orders the pairs: the scene's hash_cell_size, or the largest
// lattice cell.
double hash_order_cell(const Model& model) {
  if (model.settings.hash_cell_size > 0.0) return model.settings.hash_cell_size;
  double largest = 0.0;
  for (const ObjectModel& o : model.objects) largest = std::max(largest, o.cell_size);
  return largest > 0.0 ? largest : 1.0;
}

using PairWorkspace = BroadPhaseMemory::PairWorkspace;
using PairTask = BroadPhaseMemory::PairTask;

bool push_pair(PairWorkspace& w, Index a, Index b) {
  if (w.pair_count == w.pairs.size()) {
    w.dropped = true;
    return false;
  }
  w.pairs[w.pair_count++] = a < b ? BoxPair{a, b} : BoxPair{b, a};
  return true;
}

// Counting sort of the entries of `boxes` into the grid cells their AABBs cover:
// w.grid_begin[c] .. grid_begin[c + 1] hold the boxes of cell c. False if the entry
// buffer is too small (grow_scratch() makes room between steps).
bool fill_grid(const Grid& g, const Index* boxes, Index count, const Bounds& s, PairWorkspace& w) {
  const std::size_t cells = g.cells();
  std::fill(w.grid_begin.begin(), w.grid_begin.begin() + cells + 1, 0);
  std::size_t entries = 0;
  std::array<int, 6>* range = w.box_range.data();  // per listed box: x0, x1, y0, y1, z0, z1
  for (Index i = 0; i < count; ++i) {
    const Index b = boxes[i];
    std::array<int, 6>& r = range[i];
    for (int axis = 0; axis < 3; ++axis) {
      r[2 * axis] = g.coordinate(s.box_lo[axis][b], axis);
      r[2 * axis + 1] = g.coordinate(s.box_hi[axis][b], axis);
    }
    entries += static_cast<std::size_t>(r[1] - r[0] + 1) * (r[3] - r[2] + 1) * (r[5] - r[4] + 1);
    if (entries > w.grid_entries.size()) {
      w.dropped = true;  // room for the next step is made between steps
      return false;
    }
    for (int z = r[4]; z <= r[5]; ++z)
      for (int y = r[2]; y <= r[3]; ++y) {
        const std::size_t row = g.index(0, y, z);
        for (int x = r[0]; x <= r[1]; ++x) ++w.grid_begin[row + x + 1];
      }
  }
  for (std::size_t c = 0; c < cells; ++c) w.grid_begin[c + 1] += w.grid_begin[c];
  // Fill through a running cursor per cell, so that a cell's entries keep list order.
  std::copy(w.grid_begin.begin(), w.grid_begin.begin() + cells, w.grid_cursor.begin());
  for (Index i = 0; i < count; ++i) {
    const std::array<int, 6>& r = range[i];
    for (int z = r[4]; z <= r[5]; ++z)
      for (int y = r[2]; y <= r[3]; ++y) {
        const std::size_t row = g.index(0, y, z);
        for (int x = r[0]; x <= r[1]; ++x) w.grid_entries[w.grid_cursor[row + x]++] = boxes[i];
      }
  }
  w.entries += static_cast<std::uint32_t>(entries);
  return true;
}

// A large object's own pairs are found in parts, so that they spread over the threads: part
// k of n takes the k-th of n slabs of the object's grid along its longest axis. Boxes of
// about kBoxesPerSelfPart a part, at most kMaxSelfParts; fixed by the box count alone, so the
// work (and its counters) is the same whatever the thread count.
constexpr Index kBoxesPerSelfPart = 256;
constexpr std::uint32_t kMaxSelfParts = 8;

std::uint32_t self_parts(const BoxSet& boxes, const ObjectModel& object) {
  const Index count = end_box(boxes, object) - first_box(boxes, object);
  std::uint32_t parts = 1;
  while (parts < kMaxSelfParts && count >= 2 * parts * kBoxesPerSelfPart) parts *= 2;
  return parts;
}

// Self-collision of one object: pairs of boxes of cells that share no lattice node. Part
// `part` of `parts` (self_parts): the grid cells of one slab, and the boxes that reach into
// it. A pair is taken in the grid cell of the lower corner of its overlap, which lies in one
// slab: the parts together find each pair once, as one part would.
void self_pairs(const Model& model, const BoxSet& boxes, const ObjectModel& object, std::uint32_t part,
                std::uint32_t parts, const Bounds& s, PairWorkspace& w) {
  const Index first = first_box(boxes, object), last = end_box(boxes, object);
  if (last - first < 2) return;
  const Index o = static_cast<Index>(&object - model.objects.data());
  const Grid g = make_grid(s.object_lo[o].data(), s.object_hi[o].data(), grid_cell(model, object.cell_size));
  if (g.cells() + 1 > w.grid_begin.size()) return;  // cannot happen: sized for kBroadPhaseGridCells
  int cell_lo[3] = {0, 0, 0}, cell_hi[3] = {g.n[0], g.n[1], g.n[2]};  // the slab's grid cells, [lo, hi)
  const int axis = static_cast<int>(std::max_element(g.n, g.n + 3) - g.n);
  cell_lo[axis] = static_cast<int>(static_cast<std::int64_t>(g.n[axis]) * part / parts);
  cell_hi[axis] = static_cast<int>(static_cast<std::int64_t>(g.n[axis]) * (part + 1) / parts);
  if (cell_lo[axis] == cell_hi[axis]) return;
  Index* list = w.box_list_a.data();
  Index count = 0;
  for (Index b = first; b < last; ++b) {
    list[count] = b;  // kept if it reaches into the slab
    count += static_cast<Index>(g.coordinate(s.box_hi[axis][b], axis) >= cell_lo[axis] &&
                                g.coordinate(s.box_lo[axis][b], axis) < cell_hi[axis]);
  }
  if (!fill_grid(g, list, count, s, w)) return;
  for (int z = cell_lo[2]; z < cell_hi[2]; ++z)
    for (int y = cell_lo[1]; y < cell_hi[1]; ++y)
      for (int x = cell_lo[0]; x < cell_hi[0]; ++x) {
        const std::size_t c = g.index(x, y, z);
        const Index begin = w.grid_begin[c], end = w.grid_begin[c + 1];
        if (end - begin < 2) continue;
        // Lattice neighbours all? Then no pair here is wanted.
        const Vec3i* lattice = boxes.box_lattice.data();
        const Index* entry = w.grid_entries.data() + begin;
        const Index k = end - begin;
        Vec3i lo = lattice[entry[0]], hi = lo;
        for (Index i = 1; i < k; ++i) {
          lo = lo.cwiseMin(lattice[entry[i]]);
          hi = hi.cwiseMax(lattice[entry[i]]);
        }
        if (((hi - lo).array() <= 1).all()) continue;
        // Else the pairs two or more lattice steps apart, found branch-free over the cell's
        // lattice coordinates first; then their AABBs.
        int* cx = w.cell_lattice[0].data();
        int* cy = w.cell_lattice[1].data();
        int* cz = w.cell_lattice[2].data();
        for (Index i = 0; i < k; ++i) {
          cx[i] = lattice[entry[i]].x();
          cy[i] = lattice[entry[i]].y();
          cz[i] = lattice[entry[i]].z();
        }
        Index* far = w.cell_far.data();
        for (Index i = 0; i < k; ++i) {
          Index count = 0;
          for (Index j = i + 1; j < k; ++j) {
            far[count] = j;
            const int dx = cx[i] - cx[j], dy = cy[i] - cy[j], dz = cz[i] - cz[j];
            count += static_cast<Index>(static_cast<unsigned>(dx + 1) > 2u) | static_cast<Index>(static_cast<unsigned>(dy + 1) > 2u) |
                     static_cast<Index>(static_cast<unsigned>(dz + 1) > 2u);  // |d| > 1 on some axis
          }
          for (Index f = 0; f < count; ++f) {
            const Index a = entry[i], b = entry[far[f]];
            if (overlap(s, a, b) && lower_corner_here(g, s, a, b, x, y, z) && !push_pair(w, a, b)) return;
          }
        }
      }
}

// Boxes of `object` whose AABBs reach into [lo, hi].
Index boxes_within(const BoxSet& boxes, const ObjectModel& object, const std::array<double, 3>& lo,
                   const std::array<double, 3>& hi, const Bounds& s, Index* out) {
  const double *lx = s.box_lo[0].data(), *ly = s.box_lo[1].data(), *lz = s.box_lo[2].data();
  const double *hx = s.box_hi[0].data(), *hy = s.box_hi[1].data(), *hz = s.box_hi[2].data();
  const double lo_x = lo[0], lo_y = lo[1], lo_z = lo[2], hi_x = hi[0], hi_y = hi[1], hi_z = hi[2];
  Index count = 0;
  for (Index b = first_box(boxes, object); b < end_box(boxes, object); ++b) {
    out[count] = b;  // kept, in order, only if it reaches in (no branch to mispredict)
    count += static_cast<Index>((lx[b] <= hi_x) & (hx[b] >= lo_x) & (ly[b] <= hi_y) & (hy[b] >= lo_y) &
                                (lz[b] <= hi_z) & (hz[b] >= lo_z));
  }
  return count;
}

// Pairs between two objects whose bounds overlap.
void object_pairs(const Model& model, const BoxSet& boxes, Index oa, Index ob, const Bounds& s, PairWorkspace& w) {
  const ObjectModel& A = model.objects[oa];
  const ObjectModel& B = model.objects[ob];
  Index* list_a = w.box_list_a.data();
  Index* list_b = w.box_list_b.data();
  const Index na = boxes_within(boxes, A, s.object_lo[ob], s.object_hi[ob], s, list_a);
  if (na == 0) return;
  const Index nb = boxes_within(boxes, B, s.object_lo[oa], s.object_hi[oa], s, list_b);
  if (nb == 0) return;
  if (static_cast<std::size_t>(na) * nb <= 256) {  // small: every pair
    for (Index i = 0; i < na; ++i)
      for (Index j = 0; j < nb; ++j)
        if (overlap(s, list_a[i], list_b[j]) && !push_pair(w, list_a[i], list_b[j])) return;
    return;
  }
  // A grid over the overlap of the two objects' bounds, A's boxes in it; B's boxes look up
  // the cells they cover.
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::max(s.object_lo[oa][a], s.object_lo[ob][a]);
    hi[a] = std::min(s.object_hi[oa][a], s.object_hi[ob][a]);
  }
  const Grid g = make_grid(lo, hi, grid_cell(model, std::max(A.cell_size, B.cell_size)));
  if (!fill_grid(g, list_a, na, s, w)) return;
  for (Index j = 0; j < nb; ++j) {
    const Index b = list_b[j];
    const int x0 = g.coordinate(s.box_lo[0][b], 0), x1 = g.coordinate(s.box_hi[0][b], 0);
    const int y0 = g.coordinate(s.box_lo[1][b], 1), y1 = g.coordinate(s.box_hi[1][b], 1);
    const int z0 = g.coordinate(s.box_lo[2][b], 2), z1 = g.coordinate(s.box_hi[2][b], 2);
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          const std::size_t c = g.index(x, y, z);
          for (Index i = w.grid_begin[c]; i < w.grid_begin[c + 1]; ++i) {
            const Index a = w.grid_entries[i];
            if (overlap(s, a, b) && lower_corner_here(g, s, a, b, x, y, z) && !push_pair(w, a, b)) return;
          }
        }
  }
}

// Pairs of boxes of one object's cells that share a lattice node (touching by construction)
// and whose AABBs overlap: from the lattice's neighbour lists, no search.
void neighbour_pairs(const Model& model, const BoxSet& boxes, const ObjectModel& object, const Bounds& s,
                     PairWorkspace& w) {
  for (Index c = object.cell_begin; c < object.cell_end; ++c)
    for (Index a = boxes.cell_box_begin[c]; a < boxes.cell_box_begin[c + 1]; ++a)
      for (Index i = model.cell_neighbour_begin[c]; i < model.cell_neighbour_begin[c + 1]; ++i) {
        const Index n = model.cell_neighbours[i];
        if (n < c) continue;
        for (Index b = boxes.cell_box_begin[n]; b < boxes.cell_box_begin[n + 1]; ++b)
          if (b > a && overlap(s, a, b) && !push_pair(w, a, b)) return;
      }
}

// Sorts keyed pairs by (key, b): std::sort when few, else a least-significant-digit radix
// sort, 8 bits a pass (b's 3 bytes, then the key's 8), stable, in O(n).
void sort_pair_keys(BroadPhaseMemory::PairKey* keys, BroadPhaseMemory::PairKey* spare, Index count, Index* counts) {
  auto less = [](const BroadPhaseMemory::PairKey& x, const BroadPhaseMemory::PairKey& y) {
    return x.key < y.key || (x.key == y.key && x.pair.b < y.pair.b);
  };
  if (count < 2048) {
    std::sort(keys, keys + count, less);
    return;
  }
  BroadPhaseMemory::PairKey* from = keys;
  BroadPhaseMemory::PairKey* to = spare;
  for (int pass = 0; pass < 11; ++pass) {
    auto digit = [pass](const BroadPhaseMemory::PairKey& k) -> Index {
      return pass < 3 ? (k.pair.b >> (8 * pass)) & 0xFF : static_cast<Index>((k.key >> (8 * (pass - 3))) & 0xFF);
    };
    std::fill(counts, counts + 257, 0);
    for (Index i = 0; i < count; ++i) ++counts[digit(from[i]) + 1];
    if (counts[1] == count) continue;  // one digit value: nothing moves
    for (int d = 0; d < 256; ++d) counts[d + 1] += counts[d];
    for (Index i = 0; i < count; ++i) to[counts[digit(from[i])]++] = from[i];
    std::swap(from, to);
  }
  if (from != keys) std::copy(from, from + count, keys);
}

}  // namespace

namespace {

void make_workspace(std::size_t boxes, PairWorkspace& w) {
  w.box_list_a.resize(boxes);
  w.box_list_b.resize(boxes);
  w.box_range.resize(boxes);
  w.grid_begin.resize(kBroadPhaseGridCells + 1);
  w.grid_cursor.resize(kBroadPhaseGridCells + 1);
  w.grid_entries.resize(8 * boxes + 64);
  for (std::vector<int>& c : w.cell_lattice) c.resize(boxes);
  w.cell_far.resize(boxes);
  w.pairs.resize(8 * boxes + 64);
}

}  // namespace

void size_broad_phase_memory(const Model& model, BroadPhaseMemory& memory, std::size_t threads) {
  if (!model.collides) return;
  const std::size_t boxes = largest_box_set(model);
  if (memory.pair_workspaces.empty()) {
    memory.object_lo.resize(model.objects.size());
    memory.object_hi.resize(model.objects.size());
    memory.object_order.resize(model.objects.size());
    memory.pair_tasks.resize(32 * model.objects.size() + 64);
    memory.pairs.resize(8 * boxes + 64);
    memory.pair_keys.resize(memory.pairs.size());
    memory.pair_sorted_keys.resize(memory.pairs.size());
  }
  while (memory.pair_workspaces.size() < std::max<std::size_t>(threads, 1)) {
    memory.pair_workspaces.emplace_back();
    make_workspace(boxes, memory.pair_workspaces.back());
    // As much room as the first workspace has grown to.
    memory.pair_workspaces.back().grid_entries.resize(memory.pair_workspaces[0].grid_entries.size());
    memory.pair_workspaces.back().pairs.resize(memory.pair_workspaces[0].pairs.size());
  }
}

void grow_broad_phase_memory(const Model& model, BroadPhaseMemory& memory) {
  if (!model.collides) return;
  // Boxes stretched over hundreds of grid cells, or millions of pairs, mean a blown-up scene,
  // not a large one: stop growing there and keep reporting the overflow.
  const std::size_t boxes = largest_box_set(model);
  const std::size_t entry_limit = 512 * (8 * boxes + 64), pair_limit = 256 * (4 * boxes + 64);
  auto grow = [](auto& v, std::size_t limit) {
    if (v.size() < limit) v.resize(std::min(limit, 2 * v.size()));
  };
  for (PairWorkspace& w : memory.pair_workspaces) {
    grow(w.grid_entries, entry_limit);
    grow(w.pairs, pair_limit);
  }
  grow(memory.pair_tasks, 256 * (32 * model.objects.size() + 64));
  grow(memory.pairs, pair_limit);
  memory.pair_keys.resize(memory.pairs.size());
  memory.pair_sorted_keys.resize(memory.pairs.size());
}

std::int64_t hash_grid_coordinate(double x, double inv_cell) {
  constexpr double kLimit = 4503599627370496.0;  // 2^52: beyond it cells are meaningless anyway
  const double v = x * inv_cell;
  if (!(v > -kLimit)) return v < 0.0 ? static_cast<std::int64_t>(-kLimit) : 0;  // -inf / NaN
  if (!(v < kLimit)) return static_cast<std::int64_t>(kLimit);
  // floor(v), without a call to the C library's floor on a machine without SSE4.1: below
  // 2^52 in magnitude the truncation is exact, and one less for a negative fraction.
  const std::int64_t t = static_cast<std::int64_t>(v);
  return static_cast<double>(t) > v ? t - 1 : t;
}

void grow_box_bounds(const Model& model, const BoxSet& boxes, double margin, BoxMemory& bounds, BroadPhaseMemory& s) {
  const bool wake = !bounds.box_wake_margin.empty();
  if (margin > 0.0 || wake)
    for (Index b = 0; b < boxes.size(); ++b) {
      const double grow = margin + (wake ? bounds.box_wake_margin[b] : 0.0);
      for (int axis = 0; axis < 3; ++axis) {
        bounds.box_lo[axis][b] -= grow;
        bounds.box_hi[axis][b] += grow;
      }
    }
  for (Index o = 0; o < model.objects.size(); ++o) {
    const ObjectModel& object = model.objects[o];
    std::array<double, 3> lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    for (Index b = first_box(boxes, object); b < end_box(boxes, object); ++b)
      for (int axis = 0; axis < 3; ++axis) {
        lo[axis] = std::min(lo[axis], bounds.box_lo[axis][b]);
        hi[axis] = std::max(hi[axis], bounds.box_hi[axis][b]);
      }
    s.object_lo[o] = lo;
    s.object_hi[o] = hi;
  }
}

bool find_pairs(const Model& model, const BoxSet& boxes, const PairQuery& query, const BoxMemory& box_memory,
                BroadPhaseMemory& s, WorkerPool* pool, StageCounters& counters) {
  const Bounds bounds{box_memory.box_lo, box_memory.box_hi, s.object_lo, s.object_hi};
  s.pair_count = 0;
  s.pairs_dropped = false;
  const Index objects = static_cast<Index>(model.objects.size());
  auto asleep = [&](Index o) { return query.asleep && query.asleep[o]; };
  // The work as tasks: each object's own pairs, and each pair of objects whose bounds meet.
  Index tasks = 0;
  auto add_task = [&](PairTask task) {
    if (tasks == s.pair_tasks.size()) {
      s.pairs_dropped = true;  // more object pairs than room: grown between steps
      return;
    }
    s.pair_tasks[tasks++] = task;
  };
  if (query.self || query.neighbours)
    for (Index o = 0; o < objects; ++o) {
      if (asleep(o)) continue;
      const std::uint32_t parts = query.self ? self_parts(boxes, model.objects[o]) : 1;
      for (std::uint32_t part = 0; part < parts; ++part) add_task({o, o, part, parts});
    }
  if (query.inter && objects > 1) {
    // Sort and sweep over the objects' bounds along x.
    Index* order = s.object_order.data();
    for (Index o = 0; o < objects; ++o) order[o] = o;
    // Ordered by lower x bound (a NaN bound first: it pairs with nothing), then index.
    auto key = [&](Index o) { return std::isnan(s.object_lo[o][0]) ? -INFINITY : s.object_lo[o][0]; };
    std::sort(order, order + objects, [&](Index a, Index b) { return key(a) < key(b) || (key(a) == key(b) && a < b); });
    for (Index i = 0; i < objects; ++i) {
      const Index a = order[i];
      for (Index j = i + 1; j < objects && s.object_lo[order[j]][0] <= s.object_hi[a][0]; ++j) {
        const Index b = order[j];
        if (asleep(a) && asleep(b)) continue;  // two sleepers never meet
        if (!(s.object_lo[a][1] <= s.object_hi[b][1] && s.object_lo[b][1] <= s.object_hi[a][1] &&
              s.object_lo[a][2] <= s.object_hi[b][2] && s.object_lo[b][2] <= s.object_hi[a][2]))
          continue;
        add_task({std::min(a, b), std::max(a, b)});
      }
    }
  }
  // The tasks over the pool, each thread with its own workspace. Which thread finds a pair
  // does not matter: the pairs are sorted below.
  for (PairWorkspace& w : s.pair_workspaces) {
    w.pair_count = 0;
    w.dropped = false;
    w.entries = 0;
  }
  // A task a chunk where there are few (an object's self-collision is much work), eight where
  // there are many (pairs of small letters), so that claiming a chunk costs little.
  const Index per_chunk = tasks < 64 ? 1 : 8;
  auto run = [&](std::uint32_t chunk, std::uint32_t thread) {
    PairWorkspace& w = s.pair_workspaces[thread];
    for (Index t = chunk * per_chunk; t < std::min(tasks, (chunk + 1) * per_chunk); ++t) {
      const PairTask task = s.pair_tasks[t];
      if (task.a != task.b) {
        object_pairs(model, boxes, task.a, task.b, bounds, w);
        continue;
      }
      if (query.self) self_pairs(model, boxes, model.objects[task.a], task.part, task.parts, bounds, w);
      if (query.neighbours && task.part == 0) neighbour_pairs(model, boxes, model.objects[task.a], bounds, w);
    }
  };
  const Index chunks = (tasks + per_chunk - 1) / per_chunk;
  if (pool && s.pair_workspaces.size() >= static_cast<std::size_t>(pool->threads())) pool->parallel_for(chunks, run);
  else
    for (Index c = 0; c < chunks; ++c) run(c, 0);
  for (const PairWorkspace& w : s.pair_workspaces) {
    counters.hash_entries += w.entries;
    if (w.dropped || s.pair_count + w.pair_count > s.pairs.size()) {
      s.pairs_dropped = true;
      continue;
    }
    std::copy(w.pairs.begin(), w.pairs.begin() + w.pair_count, s.pairs.begin() + s.pair_count);
    s.pair_count += w.pair_count;
  }
  // The narrow phase answers the pairs in this order: the order in which the paper's
  // spatial hash visits them (Teschner et al. 2003: the hash of the grid cell that holds the
  // lower corner of their overlap, in T buckets of cells as large as the largest lattice
  // cell; then by box). It has no direction in space: box order alone would sweep every
  // contact region from its lowest cells up, and the pairs answered first take the rebound
  // (two spheres meeting head on leave skewed).
  if (!query.ordered) return !s.pairs_dropped;
  const double inv_cell = 1.0 / hash_order_cell(model);
  const Index table = static_cast<Index>(std::max<std::size_t>(4000, 2 * boxes.size()));
  // Within a bucket the hash holds box a's cells in its z, y, x order: a pair comes after
  // a's pairs in earlier cells of a that share the bucket (a hash collision), then by box b.
  // One 64-bit key per pair: bucket (24 bits), box a (24), a's cell rank (16); then box b.
  for (Index p = 0; p < s.pair_count; ++p) {
    const BoxPair& pair = s.pairs[p];
    std::int64_t g[3], first[3], span[3];
    for (int axis = 0; axis < 3; ++axis) {
      g[axis] = hash_grid_coordinate(std::max(bounds.box_lo[axis][pair.a], bounds.box_lo[axis][pair.b]), inv_cell);
      first[axis] = hash_grid_coordinate(bounds.box_lo[axis][pair.a], inv_cell);
      span[axis] = hash_grid_coordinate(bounds.box_hi[axis][pair.a], inv_cell) - first[axis] + 1;
    }
    const std::uint64_t bucket = spatial_hash(g[0], g[1], g[2], table);
    const std::int64_t rank = ((g[2] - first[2]) * span[1] + (g[1] - first[1])) * span[0] + (g[0] - first[0]);
    s.pair_keys[p] = {bucket << 40 | static_cast<std::uint64_t>(pair.a) << 16 |
                          static_cast<std::uint64_t>(std::clamp<std::int64_t>(rank, 0, 0xFFFF)),
                      pair};
  }
  sort_pair_keys(s.pair_keys.data(), s.pair_sorted_keys.data(), s.pair_count, s.radix_count.data());
  for (Index p = 0; p < s.pair_count; ++p) s.pairs[p] = s.pair_keys[p].pair;
  return !s.pairs_dropped;
}

bool find_candidate_pairs(const Model& model, const BoxLevel& level, const BoxMemory& bounds, BroadPhaseMemory& memory,
                          WorkerPool* pool, StageCounters& counters) {
  PairQuery query;
  query.inter = has(model.settings.effects, Effect::InterCollision);
  query.self = has(model.settings.effects, Effect::SelfCollision);
  // Objects asleep are paired too: the narrow phase passes over a pair of two sleepers as it
  // comes to it, since a pair answered before may have woken one of them.
  return find_pairs(model, *level.boxes, query, bounds, memory, pool, counters);
}

}  // namespace ffd

// ---- BroadPhase (ffd/broad_phase.h) ----

namespace ffd {

struct BroadPhase::Memory {
  BoxMemory boxes;
  BroadPhaseMemory pairs;
};

BroadPhase::BroadPhase(const Model& model) : model_(model), memory_(std::make_unique<Memory>()) {
  size_box_memory(model, memory_->boxes);
  size_broad_phase_memory(model, memory_->pairs, 1);
}

BroadPhase::~BroadPhase() = default;

void BroadPhase::set_boxes(const std::vector<std::array<Vec3, 9>>& boxes) {
  if (boxes.size() != model_.box_count()) throw std::invalid_argument("BroadPhase::set_boxes: box count differs from the model's");
  std::copy(boxes.begin(), boxes.end(), memory_->boxes.box_nodes.begin());
}

bool BroadPhase::find(bool neighbours, std::vector<std::pair<Index, Index>>& pairs) {
  BoxMemory& bounds = memory_->boxes;
  BroadPhaseMemory& found = memory_->pairs;
  const Index count = static_cast<Index>(model_.box_count());
  for (Index b = 0; b < count; ++b) {
    const std::array<Vec3, 9>& nodes = bounds.box_nodes[b];
    Vec3 lo = nodes[0], hi = nodes[0];
    for (int k = 1; k < 9; ++k) {
      lo = lo.cwiseMin(nodes[k]);
      hi = hi.cwiseMax(nodes[k]);
    }
    for (int axis = 0; axis < 3; ++axis) {
      bounds.box_lo[axis][b] = lo[axis];
      bounds.box_hi[axis][b] = hi[axis];
    }
  }
  grow_box_bounds(model_, model_.boxes, 0.0, bounds, found);
  PairQuery query;
  query.inter = query.self = true;
  query.neighbours = neighbours;
  query.ordered = !neighbours;  // every pair, as a general broad phase reports them: no order
  StageCounters counters;
  const bool complete = find_pairs(model_, model_.boxes, query, bounds, found, nullptr, counters);
  pairs.resize(found.pair_count);
  for (Index p = 0; p < found.pair_count; ++p) pairs[p] = {found.pairs[p].a, found.pairs[p].b};
  if (!complete) grow_broad_phase_memory(model_, found);
  return complete;
}

bool BroadPhase::find_all_pairs(std::vector<std::pair<Index, Index>>& pairs) { return find(true, pairs); }
bool BroadPhase::find_wanted_pairs(std::vector<std::pair<Index, Index>>& pairs) { return find(false, pairs); }

Vec3 BroadPhase::box_min(Index b) const {
  const BoxMemory& bounds = memory_->boxes;
  return Vec3(bounds.box_lo[0][b], bounds.box_lo[1][b], bounds.box_lo[2][b]);
}
Vec3 BroadPhase::box_max(Index b) const {
  const BoxMemory& bounds = memory_->boxes;
  return Vec3(bounds.box_hi[0][b], bounds.box_hi[1][b], bounds.box_hi[2][b]);
}

}  // namespace ffd
