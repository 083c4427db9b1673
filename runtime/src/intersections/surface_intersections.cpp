#include "ffd/surface_intersections.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/intersections.h>

#include <algorithm>

#include "ffd/measure.h"

namespace ffd {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Triangle = Kernel::Triangle_3;
// A triangle's bounding box, carrying its index in the flat list of all meshes' triangles.
using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, std::size_t>;

Point to_point(const Vec3& v) { return Point(v.x(), v.y(), v.z()); }

}  // namespace

IntersectionCount find_intersections(const std::vector<SurfaceMesh>& meshes, std::vector<TrianglePair>* pairs) {
  std::vector<TriangleRef> refs;
  std::vector<Triangle> triangles;
  std::vector<Box> boxes;
  for (Index m = 0; m < meshes.size(); ++m) {
    const SurfaceMesh& mesh = meshes[m];
    for (Index t = 0; t < mesh.triangles.size(); ++t) {
      const std::array<Index, 3>& f = mesh.triangles[t];
      const Triangle triangle(to_point(mesh.vertices[f[0]]), to_point(mesh.vertices[f[1]]),
                              to_point(mesh.vertices[f[2]]));
      if (triangle.is_degenerate()) continue;  // no area: exact do_intersect needs a plane
      boxes.emplace_back(triangle.bbox(), refs.size());
      refs.push_back({m, t});
      triangles.push_back(triangle);
    }
  }
  IntersectionCount count;
  auto shares_vertex = [&](const TriangleRef& a, const TriangleRef& b) {
    if (a.mesh != b.mesh) return false;
    const std::array<Index, 3>& fa = meshes[a.mesh].triangles[a.triangle];
    const std::array<Index, 3>& fb = meshes[b.mesh].triangles[b.triangle];
    for (Index i : fa)
      for (Index j : fb)
        if (i == j) return true;
    return false;
  };
  // Candidate pairs from the boxes (CGAL's streamed segment tree, closed boxes: boxes that
  // only touch are candidates too), then the exact triangle test.
  CGAL::box_self_intersection_d(boxes.begin(), boxes.end(), [&](const Box& x, const Box& y) {
    TriangleRef a = refs[x.info()], b = refs[y.info()];
    if (b < a) std::swap(a, b);
    if (shares_vertex(a, b)) return;
    if (!CGAL::do_intersect(triangles[x.info()], triangles[y.info()])) return;
    if (a.mesh == b.mesh) ++count.within;
    else ++count.between;
    if (pairs) pairs->push_back({a, b});
  });
  if (pairs) std::sort(pairs->begin(), pairs->end());
  return count;
}

namespace {
std::vector<SurfaceMesh> surfaces(const Model& model, const State& state) {
  std::vector<SurfaceMesh> meshes;
  for (Index i = 0; i < model.objects.size(); ++i) meshes.push_back(deformed_surface(model, state, i));
  return meshes;
}
}  // namespace

SurfaceIntersections::SurfaceIntersections(const Model& model)
    : model_(model), rest_triangles_(model.objects.size()) {
  // Each surface in its rest shape, alone (objects may start anywhere relative to each other).
  State rest;
  rest.x = model.node_rest;
  for (Index i = 0; i < model.objects.size(); ++i) {
    std::vector<TrianglePair> found;
    find_intersections({deformed_surface(model, rest, i)}, &found);
    for (TrianglePair& p : found) {
      p.first.mesh = p.second.mesh = i;
      rest_.push_back(p);
      rest_triangles_[i].push_back(p.first.triangle);
      rest_triangles_[i].push_back(p.second.triangle);
    }
    std::sort(rest_triangles_[i].begin(), rest_triangles_[i].end());
  }
  std::sort(rest_.begin(), rest_.end());
}

std::vector<TrianglePair> SurfaceIntersections::pairs(const State& state) const {
  std::vector<TrianglePair> found;
  find_intersections(surfaces(model_, state), &found);
  std::vector<TrianglePair> kept;
  auto crosses_at_rest = [&](const TriangleRef& t) {
    const std::vector<Index>& r = rest_triangles_[t.mesh];
    return std::binary_search(r.begin(), r.end(), t.triangle);
  };
  for (const TrianglePair& p : found)
    if (p.first.mesh != p.second.mesh || !crosses_at_rest(p.first) || !crosses_at_rest(p.second)) kept.push_back(p);
  return kept;
}

IntersectionCount SurfaceIntersections::count(const State& state) const {
  IntersectionCount count;
  for (const TrianglePair& p : pairs(state)) {
    if (p.first.mesh == p.second.mesh) ++count.within;
    else ++count.between;
  }
  return count;
}

}  // namespace ffd
