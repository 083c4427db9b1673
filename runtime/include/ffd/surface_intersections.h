#pragma once
// Intersecting triangle pairs of the embedded surfaces, outside the 1 kHz step: the measure
// that sees every crossing, edge through edge included, where vertex-to-surface distances
// (measure.h, surface_metrics.h) see only vertices behind a surface. Two closed triangles
// intersect when they share a point. The predicates are exact (CGAL's exact-predicates
// kernel), so a count does not depend on rounding.
#include <cstddef>
#include <utility>
#include <vector>

#include "ffd/mesh.h"
#include "ffd/model.h"
#include "ffd/state.h"

namespace ffd {

// Triangle `triangle` of mesh `mesh` among several.
struct TriangleRef {
  Index mesh = 0;
  Index triangle = 0;
  friend bool operator<(const TriangleRef& a, const TriangleRef& b) {
    return a.mesh != b.mesh ? a.mesh < b.mesh : a.triangle < b.triangle;
  }
  friend bool operator==(const TriangleRef& a, const TriangleRef& b) {
    return a.mesh == b.mesh && a.triangle == b.triangle;
  }
};
using TrianglePair = std::pair<TriangleRef, TriangleRef>;  // first < second

struct IntersectionCount {
  std::size_t between = 0;  // pairs of triangles of two different meshes
  std::size_t within = 0;   // pairs of triangles of one mesh that share no vertex
  std::size_t total() const { return between + within; }
};

// Every intersecting triangle pair among `meshes`, but a mesh's pairs that share a vertex
// (neighbours touch by construction) and triangles of zero area. `pairs` (may be null)
// receives them, sorted.
IntersectionCount find_intersections(const std::vector<SurfaceMesh>& meshes, std::vector<TrianglePair>* pairs = nullptr);

// The same on a Model's surfaces as a State moves them (eq. 2), leaving out the crossings each
// surface already has in its rest shape, found once here: the Utah teapot's spout and handle
// pass through its body (156 pairs). A pair of one surface's triangles that both cross in the
// rest shape is left out too: as the surface bends, a rest crossing moves on to the next
// triangle (the teapots, apart at level 0, kept 5 such pairs). Meshes are the Model's
// objects, in order; the Model must outlive this (it is read at every count). A count grows
// with the triangles and the crossing pairs: milliseconds for thousands of triangles, tens of
// seconds for millions (docs/notes/2026-11-28-code-findings.md#intersection-count).
class SurfaceIntersections {
 public:
  explicit SurfaceIntersections(const Model& model);
  IntersectionCount count(const State& state) const;
  // The pairs themselves (sorted), rest-shape pairs left out.
  std::vector<TrianglePair> pairs(const State& state) const;
  std::size_t rest_pairs() const { return rest_.size(); }

 private:
  const Model& model_;
  std::vector<TrianglePair> rest_;                 // sorted
  std::vector<std::vector<Index>> rest_triangles_;  // per object: its triangles in rest_, sorted
};

}  // namespace ffd
