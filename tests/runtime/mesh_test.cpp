#include "ffd/mesh.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <stdexcept>
#include <utility>

namespace {

using ffd::Index;
using ffd::SurfaceMesh;
using ffd::Vec3;
using Triangle = std::array<Index, 3>;

ffd::MeshCleanOptions keep_all_components() {
  ffd::MeshCleanOptions options;
  options.min_component_fraction = 0.0;
  return options;
}

// Regular tetrahedron-like solid, outward counter-clockwise: 4 vertices, 4 triangles.
SurfaceMesh tetrahedron() {
  SurfaceMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return mesh;
}

// Signed volume by the divergence theorem, m^3; > 0 for a closed outward mesh.
double signed_volume(const SurfaceMesh& mesh) {
  double six_volume = 0.0;
  for (const Triangle& t : mesh.triangles)
    six_volume += mesh.vertices[t[0]].dot(mesh.vertices[t[1]].cross(mesh.vertices[t[2]]));
  return six_volume / 6.0;
}

// Closed and consistently oriented: every directed edge appears once and its reverse once,
// so each undirected edge has exactly two triangles, traversed in opposite directions.
bool closed_and_consistent(const SurfaceMesh& mesh) {
  std::map<std::pair<Index, Index>, int> directed;
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  for (const auto& [edge, count] : directed) {
    if (count != 1) return false;
    auto reverse = directed.find({edge.second, edge.first});
    if (reverse == directed.end() || reverse->second != 1) return false;
  }
  return true;
}

bool faces_point_away_from_origin(const SurfaceMesh& mesh) {
  for (const Triangle& t : mesh.triangles) {
    const Vec3& a = mesh.vertices[t[0]];
    const Vec3 normal = (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a);
    const Vec3 centroid = (a + mesh.vertices[t[1]] + mesh.vertices[t[2]]) / 3.0;
    if (normal.dot(centroid) <= 0.0) return false;
  }
  return true;
}

}  // namespace

TEST_CASE("clean_mesh welds vertices within the tolerance and keeps the first one", "[mesh]") {
  // Two triangles of a unit square whose shared edge is stored twice; the copies are
  // 1e-12 m off, well inside 1e-9 x diagonal (1.4e-9 m).
  SurfaceMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {1 + 1e-12, 1, 0}, {0, 1e-12, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 2}, {4, 3, 5}};

  ffd::MeshCleanReport report;
  const SurfaceMesh cleaned = ffd::clean_mesh(mesh, keep_all_components(), report);
  CHECK(report.input_vertices == 6);
  CHECK(report.input_triangles == 2);
  CHECK(report.welded_vertices == 2);
  CHECK(report.unused_vertices == 0);
  CHECK(report.output_vertices == 4);
  CHECK(report.output_triangles == 2);
  REQUIRE(cleaned.vertices.size() == 4);
  // Representatives keep their own positions and the original relative order.
  CHECK(cleaned.vertices[0] == Vec3(0, 0, 0));
  CHECK(cleaned.vertices[2] == Vec3(1, 1, 0));
  CHECK(cleaned.vertices[3] == Vec3(0, 1, 0));
  CHECK(cleaned.triangles[0] == Triangle{0, 1, 2});
  CHECK(cleaned.triangles[1] == Triangle{0, 2, 3});
  CHECK(report.summary() == "welded 2 duplicate vertices");

  SECTION("tolerance 0 welds only bit-identical positions") {
    ffd::MeshCleanOptions exact = keep_all_components();
    exact.weld_tolerance = 0.0;
    mesh.vertices.push_back({1, 0, 0});  // an exact copy of vertex 1
    mesh.triangles.push_back({0, 6, 5});
    ffd::MeshCleanReport exact_report;
    const SurfaceMesh exact_cleaned = ffd::clean_mesh(mesh, exact, exact_report);
    CHECK(exact_report.welded_vertices == 1);
    CHECK(exact_cleaned.vertices.size() == 6);
    REQUIRE(exact_cleaned.triangles.size() == 3);
    CHECK(exact_cleaned.triangles[1] == Triangle{4, 3, 5});
    CHECK(exact_cleaned.triangles[2] == Triangle{0, 1, 5});
  }
}

TEST_CASE("clean_mesh drops degenerate triangles", "[mesh]") {
  SurfaceMesh mesh = tetrahedron();
  mesh.vertices.push_back({0.5, 0, 0});    // 4: on edge 0-1, so 0, 1, 4 is collinear
  mesh.vertices.push_back({1e-15, 0, 1});  // 5: welds onto vertex 3 (1e-15 << 1.7e-9)
  mesh.triangles.push_back({0, 0, 1});     // repeated index
  mesh.triangles.push_back({0, 1, 4});     // zero area
  mesh.triangles.push_back({3, 5, 1});     // repeated index after welding

  ffd::MeshCleanReport report;
  const SurfaceMesh cleaned = ffd::clean_mesh(mesh, keep_all_components(), report);
  CHECK(report.degenerate_triangles == 3);
  CHECK(report.welded_vertices == 1);
  CHECK(report.unused_vertices == 1);  // vertex 4 is used only by the zero-area triangle
  CHECK(cleaned.triangles == tetrahedron().triangles);
  CHECK(cleaned.vertices == tetrahedron().vertices);
  CHECK(report.summary() == "welded 1 duplicate vertex; dropped 1 unused vertex; dropped 3 degenerate triangles");
}

TEST_CASE("clean_mesh drops later same-winding copies of a triangle", "[mesh]") {
  SurfaceMesh mesh = tetrahedron();
  mesh.triangles.push_back({2, 3, 1});  // same vertex set and winding as {1, 2, 3}
  mesh.triangles.push_back({3, 1, 2});  // again

  ffd::MeshCleanReport report;
  const SurfaceMesh cleaned = ffd::clean_mesh(mesh, keep_all_components(), report);
  CHECK(report.duplicate_triangles == 2);
  CHECK(report.opposite_pair_triangles == 0);
  CHECK(cleaned.triangles == tetrahedron().triangles);
  CHECK(closed_and_consistent(cleaned));
  CHECK(report.summary() == "dropped 2 duplicate triangles");
}

TEST_CASE("clean_mesh drops both triangles of an opposite-winding pair", "[mesh]") {
  // A zero-thickness fin (0, 1, 4) glued to the tetrahedron's edge 0-1, stored both ways.
  SurfaceMesh mesh = tetrahedron();
  mesh.vertices.push_back({0.5, -1, 0});
  mesh.triangles.insert(mesh.triangles.begin() + 1, Triangle{0, 1, 4});
  mesh.triangles.push_back({4, 1, 0});

  ffd::MeshCleanReport report;
  const SurfaceMesh cleaned = ffd::clean_mesh(mesh, keep_all_components(), report);
  CHECK(report.opposite_pair_triangles == 2);
  CHECK(report.duplicate_triangles == 0);
  CHECK(report.unused_vertices == 1);  // the fin's tip
  CHECK(cleaned.triangles == tetrahedron().triangles);
  CHECK(cleaned.vertices == tetrahedron().vertices);
  CHECK(report.summary() == "dropped 1 unused vertex; dropped 2 triangles in 1 opposite-winding pair");

  SECTION("pairs cancel one for one; the earliest surplus copy stays") {
    // Face {1, 2, 3} three times one way and once the other: one pair goes, one copy is a
    // duplicate, one copy stays, and the solid stays closed.
    SurfaceMesh sheet = tetrahedron();
    sheet.triangles.push_back({3, 2, 1});
    sheet.triangles.push_back({2, 3, 1});
    sheet.triangles.push_back({1, 2, 3});
    ffd::MeshCleanReport sheet_report;
    const SurfaceMesh sheet_cleaned = ffd::clean_mesh(sheet, keep_all_components(), sheet_report);
    CHECK(sheet_report.opposite_pair_triangles == 2);
    CHECK(sheet_report.duplicate_triangles == 1);
    CHECK(sheet_cleaned.triangles == tetrahedron().triangles);
    CHECK(closed_and_consistent(sheet_cleaned));
  }
}

TEST_CASE("clean_mesh drops components far smaller than the largest", "[mesh]") {
  const SurfaceMesh sphere = ffd::make_sphere_mesh(1.0, 2);  // 320 triangles: 1% is 3.2
  SurfaceMesh mesh = sphere;
  const auto first_extra = static_cast<Index>(mesh.vertices.size());
  // A lone triangle 5 m away, first in the list, and a 2-triangle strip 10 m away.
  mesh.vertices.insert(mesh.vertices.end(), {{5, 0, 0}, {6, 0, 0}, {5, 1, 0}});
  mesh.triangles.insert(mesh.triangles.begin(), Triangle{first_extra, first_extra + 1, first_extra + 2});
  mesh.vertices.insert(mesh.vertices.end(), {{10, 0, 0}, {11, 0, 0}, {11, 1, 0}, {10, 1, 0}});
  mesh.triangles.push_back({first_extra + 3, first_extra + 4, first_extra + 5});
  mesh.triangles.push_back({first_extra + 3, first_extra + 5, first_extra + 6});

  ffd::MeshCleanReport report;
  const SurfaceMesh cleaned = ffd::clean_mesh(mesh, ffd::MeshCleanOptions{}, report);
  CHECK(report.stray_components == 2);
  CHECK(report.stray_component_triangles == 3);
  CHECK(report.unused_vertices == 7);
  CHECK(cleaned.vertices == sphere.vertices);
  CHECK(cleaned.triangles == sphere.triangles);
  CHECK(report.summary() == "dropped 7 unused vertices; dropped 2 stray components (3 triangles)");

  SECTION("a fraction of 0 keeps every component") {
    ffd::MeshCleanReport kept;
    const SurfaceMesh all = ffd::clean_mesh(mesh, keep_all_components(), kept);
    CHECK(kept.stray_components == 0);
    CHECK(all.triangles.size() == 323);
    CHECK(kept.summary() == "clean");
  }
  SECTION("triangles touching at a single vertex are one component") {
    mesh.vertices[first_extra] = mesh.vertices[0];  // welds the lone triangle onto the sphere
    ffd::MeshCleanReport touching;
    const SurfaceMesh joined = ffd::clean_mesh(mesh, ffd::MeshCleanOptions{}, touching);
    CHECK(touching.welded_vertices == 1);
    CHECK(touching.stray_components == 1);
    CHECK(joined.triangles.size() == 321);
  }
}

TEST_CASE("clean_mesh drops unused vertices and keeps the vertex order", "[mesh]") {
  SurfaceMesh mesh;
  mesh.vertices = {{9, 9, 9}, {0, 0, 0}, {1, 0, 0}, {7, 7, 7}, {0, 1, 0}, {0, 0, 1}};
  mesh.triangles = {{1, 4, 2}, {1, 2, 5}, {1, 5, 4}, {2, 4, 5}};
  ffd::MeshCleanReport report;
  const SurfaceMesh cleaned = ffd::clean_mesh(mesh, ffd::MeshCleanOptions{}, report);
  CHECK(report.unused_vertices == 2);
  CHECK(report.output_vertices == 4);
  CHECK(cleaned.vertices == tetrahedron().vertices);
  CHECK(cleaned.triangles == tetrahedron().triangles);
  CHECK(report.summary() == "dropped 2 unused vertices");
}

TEST_CASE("clean_mesh leaves a clean mesh unchanged", "[mesh]") {
  const SurfaceMesh box = ffd::make_box_mesh({1, 2, 3});
  ffd::MeshCleanReport report;
  const SurfaceMesh cleaned = ffd::clean_mesh(box, ffd::MeshCleanOptions{}, report);
  CHECK(cleaned.vertices == box.vertices);
  CHECK(cleaned.triangles == box.triangles);
  CHECK(report.output_vertices == 8);
  CHECK(report.output_triangles == 12);
  CHECK(report.summary() == "clean");
}

TEST_CASE("MeshCleanReport::summary lists every kind of change", "[mesh]") {
  ffd::MeshCleanReport report;
  report.welded_vertices = 403;
  report.unused_vertices = 12;
  report.degenerate_triangles = 1;
  report.duplicate_triangles = 181;
  report.opposite_pair_triangles = 2938;
  report.stray_components = 1;
  report.stray_component_triangles = 8;
  CHECK(report.summary() ==
        "welded 403 duplicate vertices; dropped 12 unused vertices; dropped 1 degenerate triangle; "
        "dropped 181 duplicate triangles; dropped 2938 triangles in 1469 opposite-winding pairs; "
        "dropped 1 stray component (8 triangles)");
}

TEST_CASE("clean_mesh rejects bad input", "[mesh]") {
  ffd::MeshCleanReport report;
  SECTION("an index out of range") {
    SurfaceMesh mesh = tetrahedron();
    mesh.triangles.push_back({0, 1, 4});
    CHECK_THROWS_AS(ffd::clean_mesh(mesh, {}, report), std::invalid_argument);
    CHECK_THROWS_WITH(ffd::clean_mesh(mesh, {}, report), Catch::Matchers::Contains("triangle 4 uses vertex index 4") &&
                                                             Catch::Matchers::Contains("4 vertices"));
  }
  SECTION("a non-finite vertex") {
    SurfaceMesh mesh = tetrahedron();
    mesh.vertices[2].y() = std::numeric_limits<double>::infinity();
    CHECK_THROWS_AS(ffd::clean_mesh(mesh, {}, report), std::invalid_argument);
    CHECK_THROWS_WITH(ffd::clean_mesh(mesh, {}, report), Catch::Matchers::Contains("vertex 2 is not finite"));
  }
  SECTION("nothing left") {
    SurfaceMesh mesh;
    mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
    mesh.triangles = {{0, 1, 2}};
    CHECK_THROWS_AS(ffd::clean_mesh(mesh, {}, report), std::invalid_argument);
    CHECK_THROWS_WITH(ffd::clean_mesh(mesh, {}, report), Catch::Matchers::Contains("no triangles remain"));
    CHECK(report.degenerate_triangles == 1);
    CHECK_THROWS_AS(ffd::clean_mesh(SurfaceMesh{}, {}, report), std::invalid_argument);
  }
  SECTION("a huge tolerance welds everything") {
    ffd::MeshCleanOptions options;
    options.weld_tolerance = std::numeric_limits<double>::max();
    CHECK_THROWS_WITH(ffd::clean_mesh(tetrahedron(), options, report),
                      Catch::Matchers::Contains("no triangles remain"));
    CHECK(report.welded_vertices == 3);
  }
  SECTION("a negative tolerance") {
    ffd::MeshCleanOptions options;
    options.weld_tolerance = -1.0;
    CHECK_THROWS_AS(ffd::clean_mesh(tetrahedron(), options, report), std::invalid_argument);
  }
}

TEST_CASE("clean_mesh handles extreme coordinates without floating-point traps", "[mesh]") {
  // Differences and squares of these would overflow in plain arithmetic.
  for (const double scale : {1e300, 1e-300}) {
    SurfaceMesh mesh = tetrahedron();
    for (Vec3& p : mesh.vertices) p = p * scale - Vec3::Constant(0.5 * scale);
    ffd::MeshCleanReport report;
    const SurfaceMesh cleaned = ffd::clean_mesh(mesh, {}, report);
    CHECK(cleaned.triangles.size() == 4);
    CHECK(report.summary() == "clean");
  }
}

TEST_CASE("make_box_mesh is a closed outward box", "[mesh]") {
  const SurfaceMesh box = ffd::make_box_mesh({1, 2, 3});
  CHECK(box.vertices.size() == 8);
  CHECK(box.triangles.size() == 12);
  CHECK(closed_and_consistent(box));
  CHECK(faces_point_away_from_origin(box));
  CHECK(signed_volume(box) == Approx(6.0).epsilon(1e-12));
  const auto [lo, hi] = ffd::mesh_bounds(box);
  CHECK(lo == Vec3(-0.5, -1, -1.5));
  CHECK(hi == Vec3(0.5, 1, 1.5));
  CHECK_THROWS_AS(ffd::make_box_mesh({1, 0, 1}), std::invalid_argument);
}

TEST_CASE("make_sphere_mesh is a closed outward icosphere", "[mesh]") {
  for (int subdivisions = 0; subdivisions <= 6; ++subdivisions) {
    const SurfaceMesh sphere = ffd::make_sphere_mesh(2.0, subdivisions);
    const std::size_t faces = 20u << (2 * subdivisions);
    CHECK(sphere.triangles.size() == faces);
    CHECK(sphere.vertices.size() == faces / 2 + 2);  // Euler: V - E + F = 2, E = 3F/2
    if (subdivisions <= 4) {
      CHECK(closed_and_consistent(sphere));
      CHECK(faces_point_away_from_origin(sphere));
    }
    for (const Vec3& p : sphere.vertices) CHECK(p.norm() == Approx(2.0).epsilon(1e-14));
    const double ball = 4.0 / 3.0 * std::numbers::pi * 8.0;  // m^3
    CHECK(signed_volume(sphere) < ball);
    if (subdivisions >= 4) CHECK(signed_volume(sphere) == Approx(ball).epsilon(0.01));
  }
  CHECK_THROWS_AS(ffd::make_sphere_mesh(1.0, -1), std::invalid_argument);
  CHECK_THROWS_AS(ffd::make_sphere_mesh(1.0, 7), std::invalid_argument);
  CHECK_THROWS_AS(ffd::make_sphere_mesh(0.0, 2), std::invalid_argument);
}

TEST_CASE("mesh_bounds gives the extreme coordinates", "[mesh]") {
  SurfaceMesh mesh;
  mesh.vertices = {{1, -2, 3}, {-4, 5, 0}, {2, 0, -6}};
  const auto [lo, hi] = ffd::mesh_bounds(mesh);
  CHECK(lo == Vec3(-4, -2, -6));
  CHECK(hi == Vec3(2, 5, 3));
  CHECK_THROWS_AS(ffd::mesh_bounds(SurfaceMesh{}), std::invalid_argument);
}
