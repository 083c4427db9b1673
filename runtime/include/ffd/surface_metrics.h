#pragma once
// Measurements on the embedded (deformed) surfaces, outside the 1 kHz step: how deep one
// surface penetrates another and how wide the gap between two surfaces in contact is.
// Used for the end-of-run report and for the tests' accuracy bounds.
#include <vector>

#include "ffd/mesh.h"

namespace ffd {

// Signed-distance helper for a closed or open oriented mesh: the sign comes from the
// angle-weighted pseudo-normal (Baerentzen & Aanaes 2005) of the closest feature, so it is
// right near edges and vertices too. Built once per mesh pose; queries are read-only.
class SurfaceDistance {
 public:
  // `search_radius` bounds the queries (m): points farther than it from the surface
  // report +/- infinity-free "far" with distance = search_radius.
  SurfaceDistance(const SurfaceMesh& mesh, double search_radius);
  ~SurfaceDistance();
  SurfaceDistance(SurfaceDistance&&) noexcept;
  SurfaceDistance& operator=(SurfaceDistance&&) noexcept;

  struct Query {
    bool within_radius = false;  // a surface point lies within search_radius
    double distance = 0.0;       // unsigned distance to the closest surface point, m
    bool inside = false;         // the query point is behind the closest feature
  };
  Query query(const Vec3& point) const;

 private:
  struct Impl;
  Impl* impl_;
};

struct PairContactMetrics {
  double penetration_m = 0.0;  // deepest vertex of either surface behind the other one
  double gap_m = 0.0;          // smallest distance between the surfaces when not penetrating
  bool near = false;           // some vertex lies within the search radius of the other surface
  std::size_t penetrating_vertices = 0;  // vertices of either surface behind the other one
};

// Vertex-to-surface both ways between two posed meshes, within search_radius.
PairContactMetrics measure_pair(const SurfaceMesh& a, const SurfaceMesh& b, double search_radius);
// The same with each mesh's distance helper built already (one per mesh, whatever its pairs).
PairContactMetrics measure_pair(const SurfaceMesh& a, const SurfaceDistance& distance_to_a, const SurfaceMesh& b,
                                const SurfaceDistance& distance_to_b, double search_radius);

}  // namespace ffd
