#pragma once
// Closest point of a triangle to a point: the surface measurements (surface_metrics.h) and
// the exact accuracy level's vertex-against-triangle test share it.
#include "ffd/types.h"

namespace ffd {

// Closest feature of a triangle, in the order of Ericson's Voronoi-region tests.
enum class Feature { kVertexA, kVertexB, kVertexC, kEdgeAB, kEdgeBC, kEdgeCA, kFace };

struct ClosestPoint {
  Vec3 point;
  Feature feature;
};

// Ericson, Real-Time Collision Detection, 5.1.5. Every division is by a squared edge length
// or twice the squared area in exact arithmetic; the guards only matter for slivers.
inline ClosestPoint closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a;
  const Vec3 ac = c - a;
  const Vec3 ap = p - a;
  const double d1 = ab.dot(ap);
  const double d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return {a, Feature::kVertexA};

  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp);
  const double d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return {b, Feature::kVertexB};

  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double length_sq = d1 - d3;
    const double v = length_sq > 0.0 ? d1 / length_sq : 0.0;
    return {a + v * ab, Feature::kEdgeAB};
  }

  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp);
  const double d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return {c, Feature::kVertexC};

  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double length_sq = d2 - d6;
    const double w = length_sq > 0.0 ? d2 / length_sq : 0.0;
    return {a + w * ac, Feature::kEdgeCA};
  }

  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double length_sq = (d4 - d3) + (d5 - d6);
    const double w = length_sq > 0.0 ? (d4 - d3) / length_sq : 0.0;
    return {b + w * (c - b), Feature::kEdgeBC};
  }

  const double denom = va + vb + vc;
  if (!(denom > 0.0)) return {a, Feature::kVertexA};
  const double v = vb / denom;
  const double w = vc / denom;
  return {a + ab * v + ac * w, Feature::kFace};
}

}  // namespace ffd
