#include "ffd/surface_metrics.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <utility>
#include <vector>

#include "ffd/mesh.h"

namespace {

using ffd::SurfaceDistance;
using ffd::SurfaceMesh;
using ffd::Vec3;

SurfaceMesh translated(SurfaceMesh mesh, const Vec3& offset) {
  for (Vec3& p : mesh.vertices) p += offset;
  return mesh;
}

// Exact distance to the surface of the box [-h, h] and whether p is strictly inside.
std::pair<double, bool> box_distance(const Vec3& p, const Vec3& h) {
  const Vec3 excess = p.cwiseAbs() - h;
  if (excess.maxCoeff() < 0.0) return {-excess.maxCoeff(), true};
  return {excess.cwiseMax(0.0).norm(), false};
}

// Generalized winding number of a closed mesh around p (1 inside, 0 outside), from the
// solid angles of its triangles (Van Oosterom & Strackee 1983): independent of the
// closest-point and pseudo-normal code under test.
double winding_number(const SurfaceMesh& mesh, const Vec3& p) {
  double solid_angle = 0.0;  // sr
  for (const auto& t : mesh.triangles) {
    const Vec3 a = mesh.vertices[t[0]] - p, b = mesh.vertices[t[1]] - p, c = mesh.vertices[t[2]] - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double numerator = a.dot(b.cross(c));
    const double denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    solid_angle += 2.0 * std::atan2(numerator, denominator);
  }
  return solid_angle / (4.0 * std::numbers::pi);
}

// Deterministic points in [-extent, extent]^3.
std::vector<Vec3> scattered_points(int count, double extent) {
  std::uint64_t state = 12345;
  auto next = [&state] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0;  // [0, 1)
  };
  std::vector<Vec3> points;
  for (int i = 0; i < count; ++i) {
    const double x = next(), y = next(), z = next();
    points.push_back(extent * (2.0 * Vec3(x, y, z) - Vec3::Ones()));
  }
  return points;
}

// Checks inside/outside against the winding number for points clearly off the surface.
int check_signs_against_winding_number(const SurfaceMesh& mesh, double search_radius, double extent) {
  const SurfaceDistance distance(mesh, search_radius);
  int checked = 0;
  for (const Vec3& p : scattered_points(4000, extent)) {
    const SurfaceDistance::Query q = distance.query(p);
    if (!q.within_radius || q.distance < 1e-6) continue;
    INFO("point " << p.transpose() << ", distance " << q.distance);
    CHECK(q.inside == (winding_number(mesh, p) > 0.5));
    ++checked;
  }
  return checked;
}

}  // namespace

TEST_CASE("SurfaceDistance on a unit box: faces, edges and corners", "[surface_metrics]") {
  const SurfaceDistance box(ffd::make_box_mesh({1, 1, 1}), 1.0);

  auto check = [&](const Vec3& p, double distance, bool inside) {
    INFO("point " << p.transpose());
    const SurfaceDistance::Query q = box.query(p);
    CHECK(q.within_radius);
    CHECK(q.distance == Approx(distance).margin(1e-12));
    CHECK(q.inside == inside);
  };
  check({0, 0, 0}, 0.5, true);                     // centre: every face at 0.5
  check({0.7, 0, 0}, 0.2, false);                  // face region
  check({0.6, 0.6, 0}, std::sqrt(0.02), false);    // edge region: a face normal alone gets this wrong
  check({0.6, 0.6, 0.6}, std::sqrt(0.03), false);  // corner region
  check({0.45, 0.45, 0.1}, 0.05, true);            // inside, two faces equally close
  check({0.49, 0.49, 0.49}, 0.01, true);           // inside, near a corner
  check({0.5, 0.1, -0.2}, 0.0, false);             // on the surface: not behind it

  const SurfaceDistance::Query far = box.query({3, 0, 0});
  CHECK_FALSE(far.within_radius);
  CHECK_FALSE(far.inside);
  CHECK(far.distance == 1.0);  // reported as the search radius
}

TEST_CASE("SurfaceDistance matches the exact box distance on a grid of points", "[surface_metrics]") {
  const Vec3 half(0.5, 0.25, 0.75);
  const SurfaceDistance box(ffd::make_box_mesh(2.0 * half), 0.6);
  int checked = 0;
  for (int i = -10; i <= 10; ++i) {
    for (int j = -10; j <= 10; ++j) {
      for (int k = -10; k <= 10; ++k) {
        const Vec3 p = Vec3(i, j, k) * 0.0937;  // not commensurate with the box
        const auto [distance, inside] = box_distance(p, half);
        if (distance < 1e-9 || distance > 0.6) continue;
        INFO("point " << p.transpose());
        const SurfaceDistance::Query q = box.query(p);
        REQUIRE(q.within_radius);
        CHECK(q.distance == Approx(distance).margin(1e-12));
        CHECK(q.inside == inside);
        ++checked;
      }
    }
  }
  CHECK(checked > 3000);
}

TEST_CASE("SurfaceDistance: a query whose search range rounds onto four cells along every axis", "[surface_metrics]") {
  // A 1 m box from 0 to 1 (the grid starts at 0), cells of the search radius, 0.1 m: around
  // p = 0.3, (p - 0.1) / 0.1 rounds below 2 and (p + 0.1) / 0.1 to 4, so cells 1 to 4 along
  // each axis, 64 in all (under ASan, a buffer too small for them is a stack overflow).
  SurfaceMesh mesh = ffd::make_box_mesh({1.0, 1.0, 1.0});
  for (Vec3& v : mesh.vertices) v += Vec3::Constant(0.5);
  const SurfaceDistance box(mesh, 0.1);
  REQUIRE(std::floor((0.3 - 0.1) / 0.1) == 1.0);
  REQUIRE(std::floor((0.3 + 0.1) / 0.1) == 4.0);
  const SurfaceDistance::Query far = box.query(Vec3(0.3, 0.3, 0.3));  // 0.3 m inside every face
  CHECK_FALSE(far.within_radius);
  CHECK(far.distance == 0.1);
  const SurfaceDistance::Query near = box.query(Vec3(0.3, 0.3, 0.95));  // 5 cm inside the face z = 1
  REQUIRE(near.within_radius);
  CHECK(near.distance == Approx(0.05).margin(1e-12));
  CHECK(near.inside);
}

TEST_CASE("SurfaceDistance signs in edge and vertex regions of a tetrahedron", "[surface_metrics]") {
  // Face normals here are 109.5 degrees apart: outside points near an edge or a corner are
  // behind some of the faces that share the closest point, so only the pseudo-normal of the
  // closest edge or vertex gives the right sign.
  SurfaceMesh tetrahedron;
  tetrahedron.vertices = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  tetrahedron.triangles = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  const Vec3 a = tetrahedron.vertices[0], b = tetrahedron.vertices[1];
  REQUIRE((b - a).cross(tetrahedron.vertices[2] - a).dot(a) > 0.0);  // outward
  CHECK(check_signs_against_winding_number(tetrahedron, 1.5, 2.0) > 2000);

  const SurfaceDistance distance(tetrahedron, 1.5);
  // Straight out from the middle of edge 0-1, and straight out from corner 0.
  const Vec3 edge_midpoint = 0.5 * (a + b);  // (1, 0, 0)
  const SurfaceDistance::Query off_edge = distance.query(edge_midpoint + Vec3(0.1, 0.0, 0.0));
  CHECK_FALSE(off_edge.inside);
  CHECK(off_edge.distance == Approx(0.1).margin(1e-12));
  const SurfaceDistance::Query off_corner = distance.query(a * 1.1);
  CHECK_FALSE(off_corner.inside);
  CHECK(off_corner.distance == Approx(0.1 * std::sqrt(3.0)).margin(1e-12));
}

TEST_CASE("SurfaceDistance signs on a non-convex closed mesh", "[surface_metrics]") {
  // An icosphere with radial bumps: concave and convex edges and vertices of every kind.
  SurfaceMesh bumpy = ffd::make_sphere_mesh(1.0, 3);
  for (Vec3& p : bumpy.vertices)
    p *= 1.0 + 0.35 * std::sin(5.0 * p.x()) * std::sin(4.0 * p.y() + 1.0) * std::cos(3.0 * p.z());
  CHECK(check_signs_against_winding_number(bumpy, 0.5, 1.4) > 2000);
}

TEST_CASE("SurfaceDistance on an icosphere", "[surface_metrics]") {
  const double radius = 1.0;  // m
  const SurfaceDistance sphere(ffd::make_sphere_mesh(radius, 3), 0.75);
  // Facets lie inside the true sphere by at most the sag 1 - cos(half the vertex spacing):
  // about 0.005 at 3 subdivisions.
  const double sag = 0.006;
  for (int n = 0; n < 200; ++n) {
    // Directions spread by the golden angle.
    const double z = 1.0 - (2.0 * n + 1.0) / 200.0;
    const double phi = 2.399963229728653 * n;
    const Vec3 direction(std::sqrt(1.0 - z * z) * std::cos(phi), std::sqrt(1.0 - z * z) * std::sin(phi), z);
    for (const double r : {0.5, 0.9, 1.1, 1.5}) {
      INFO("r = " << r << ", direction " << direction.transpose());
      const SurfaceDistance::Query q = sphere.query(r * direction);
      REQUIRE(q.within_radius);
      CHECK(q.inside == (r < 1.0));
      CHECK(q.distance == Approx(std::abs(r - radius)).margin(sag));
    }
  }
}

TEST_CASE("SurfaceDistance keeps working with a radius much smaller than the mesh", "[surface_metrics]") {
  // 1e-9 m cells would be 1e27 cells; the grid is coarsened instead.
  const SurfaceDistance box(ffd::make_box_mesh({1, 1, 1}), 1e-9);
  const SurfaceDistance::Query just_outside = box.query({0.5 + 4e-10, 0.1, 0.2});
  CHECK(just_outside.within_radius);
  CHECK_FALSE(just_outside.inside);
  CHECK(just_outside.distance == Approx(4e-10).margin(1e-15));
  const SurfaceDistance::Query just_inside = box.query({0.1, -0.5 + 3e-10, 0.2});
  CHECK(just_inside.within_radius);
  CHECK(just_inside.inside);
  CHECK_FALSE(box.query({0.1, 0.1, 0.1}).within_radius);
}

TEST_CASE("SurfaceDistance moves and rejects bad input", "[surface_metrics]") {
  SurfaceDistance first(ffd::make_box_mesh({1, 1, 1}), 1.0);
  SurfaceDistance moved(std::move(first));
  CHECK(moved.query({0.75, 0, 0}).distance == Approx(0.25));
  SurfaceDistance assigned(ffd::make_sphere_mesh(1.0, 0), 1.0);
  assigned = std::move(moved);
  CHECK(assigned.query({0.75, 0, 0}).distance == Approx(0.25));

  CHECK_THROWS_AS(SurfaceDistance(ffd::make_box_mesh({1, 1, 1}), 0.0), std::invalid_argument);
  SurfaceMesh flat;
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  flat.triangles = {{0, 1, 2}};
  CHECK_THROWS_AS(SurfaceDistance(flat, 1.0), std::invalid_argument);
  CHECK_THROWS_AS(assigned.query({std::numeric_limits<double>::quiet_NaN(), 0, 0}), std::invalid_argument);
}

TEST_CASE("measure_pair: two boxes with a gap", "[surface_metrics]") {
  const SurfaceMesh a = ffd::make_box_mesh({1, 1, 1});
  // Offset in y and z too, so corners face the other box's face instead of its edges.
  const SurfaceMesh b = translated(a, {1.05, 0.2, 0.1});
  const ffd::PairContactMetrics metrics = ffd::measure_pair(a, b, 0.1);
  CHECK(metrics.near);
  CHECK(metrics.penetration_m == 0.0);
  CHECK(metrics.gap_m == Approx(0.05).margin(1e-12));
}

TEST_CASE("measure_pair: two overlapping boxes", "[surface_metrics]") {
  const SurfaceMesh a = ffd::make_box_mesh({1, 1, 1});
  const SurfaceMesh b = translated(a, {0.97, 0.2, 0.1});
  const ffd::PairContactMetrics metrics = ffd::measure_pair(a, b, 0.1);
  CHECK(metrics.near);
  CHECK(metrics.penetration_m == Approx(0.03).margin(1e-12));
  CHECK(metrics.gap_m == 0.0);

  SECTION("a deeper overlap reads deeper") {
    const ffd::PairContactMetrics deeper = ffd::measure_pair(a, translated(a, {0.9, 0.2, 0.1}), 0.2);
    CHECK(deeper.penetration_m == Approx(0.1).margin(1e-12));
  }
}

TEST_CASE("measure_pair: surfaces farther apart than the search radius", "[surface_metrics]") {
  const SurfaceMesh a = ffd::make_box_mesh({1, 1, 1});
  const ffd::PairContactMetrics metrics = ffd::measure_pair(a, translated(a, {1.5, 0, 0}), 0.1);
  CHECK_FALSE(metrics.near);
  CHECK(metrics.penetration_m == 0.0);
  CHECK(metrics.gap_m == 0.1);
}

TEST_CASE("measure_pair: two spheres", "[surface_metrics]") {
  const SurfaceMesh a = ffd::make_sphere_mesh(1.0, 4);
  // Vertices lie on the true spheres; facets are up to ~0.0013 m inside them.
  const ffd::PairContactMetrics apart = ffd::measure_pair(a, translated(a, {2.2, 0, 0}), 0.5);
  CHECK(apart.near);
  CHECK(apart.penetration_m == 0.0);
  CHECK(apart.gap_m >= 0.2);
  CHECK(apart.gap_m == Approx(0.2).margin(0.003));

  const ffd::PairContactMetrics overlapping = ffd::measure_pair(a, translated(a, {0, 1.8, 0}), 0.5);
  CHECK(overlapping.gap_m == 0.0);
  CHECK(overlapping.penetration_m <= 0.2);
  CHECK(overlapping.penetration_m == Approx(0.2).margin(0.003));
}
