#include "ffd/mesh.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>

namespace {

using ffd::Index;
using ffd::SurfaceMesh;
using ffd::Vec3;
using ffd::Vec3i;
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
    CHECK_THROWS_WITH(ffd::clean_mesh(mesh, {}, report), Catch::Matchers::Contains("vertex 3 (counting from 1) is not finite"));
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
  // Vertex i has x = +h when bit 0 is set, y when bit 1, z when bit 2; two triangles a face,
  // -x, +x, -y, +y, -z, +z (the order scenes with boxes have always been built in).
  for (int i = 0; i < 8; ++i)
    CHECK(box.vertices[i] == Vec3((i & 1) ? 0.5 : -0.5, (i & 2) ? 1 : -1, (i & 4) ? 1.5 : -1.5));
  const std::vector<Triangle> faces = {{0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}, {0, 1, 5}, {0, 5, 4},
                                       {2, 6, 7}, {2, 7, 3}, {0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}};
  CHECK(box.triangles == faces);
  CHECK_THROWS_AS(ffd::make_box_mesh({1, 0, 1}), std::invalid_argument);
}

TEST_CASE("make_box_mesh divides each face into squares, closed, and box_divisions sizes them to a cell", "[mesh]") {
  const Vec3i divisions(3, 1, 5);
  const SurfaceMesh box = ffd::make_box_mesh({0.3, 0.1, 0.5}, divisions);
  // Faces normal to x: 1 x 5 squares, to y: 5 x 3, to z: 3 x 1; two of each, two triangles a square.
  CHECK(box.triangles.size() == 2 * 2 * (1 * 5 + 5 * 3 + 3 * 1));
  // Surface grid points: all (4 x 2 x 6) but the inner (2 x 0 x 4).
  CHECK(box.vertices.size() == 4 * 2 * 6);
  CHECK(closed_and_consistent(box));
  CHECK(faces_point_away_from_origin(box));
  CHECK(signed_volume(box) == Approx(0.015).epsilon(1e-12));
  const auto [lo, hi] = ffd::mesh_bounds(box);
  CHECK(lo == Vec3(-0.15, -0.05, -0.25));
  CHECK(hi == Vec3(0.15, 0.05, 0.25));
  // Every triangle a right triangle with legs 0.1 m (squares of 0.1 m on every face).
  for (const auto& t : box.triangles) {
    const Vec3 a = box.vertices[t[0]], b = box.vertices[t[1]], c = box.vertices[t[2]];
    CHECK((b - a).cross(c - a).norm() == Approx(0.01).epsilon(1e-9));
  }
  // The squares' diagonals alternate as a chessboard's colours: on the top face's 5 x 3
  // squares, 8 run along +x+z and 7 along +x-z.
  int along_plus = 0, along_minus = 0;
  for (const auto& t : box.triangles) {
    if (box.vertices[t[0]].y() != 0.05 || box.vertices[t[1]].y() != 0.05 || box.vertices[t[2]].y() != 0.05) continue;
    for (int e = 0; e < 3; ++e) {
      const Vec3 edge = box.vertices[t[(e + 1) % 3]] - box.vertices[t[e]];
      if (edge.x() == 0.0 || edge.z() == 0.0) continue;  // a leg, not the diagonal
      ++(edge.x() * edge.z() > 0.0 ? along_plus : along_minus);
    }
  }
  CHECK(along_plus == 2 * 8);  // each diagonal is an edge of its square's two triangles
  CHECK(along_minus == 2 * 7);

  CHECK(ffd::box_divisions({0.3, 0.1, 0.5}, 0.1) == Vec3i(3, 1, 5));
  CHECK(ffd::box_divisions({0.31, 0.01, 0.5}, 0.1) == Vec3i(4, 1, 5));  // rounded up, at least 1
  CHECK_THROWS_AS(ffd::box_divisions({1, 1, 1}, 1e-9), std::invalid_argument);  // 1e9 squares an edge
  for (const double bad_cell : {0.0, -0.1, std::nan(""), std::numeric_limits<double>::infinity()})
    CHECK_THROWS_AS(ffd::box_divisions({1, 1, 1}, bad_cell), std::invalid_argument);
  CHECK_THROWS_AS(ffd::box_divisions({1, std::nan(""), 1}, 0.1), std::invalid_argument);
  CHECK_THROWS_AS(ffd::make_box_mesh({1, 1, 1}, Vec3i(1, 0, 1)), std::invalid_argument);
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

TEST_CASE("torus, ring and bowl meshes are closed, outward and hold their volume", "[mesh]") {
  const double pi = std::numbers::pi;
  // Analytic volumes; the polygons inscribed in their circles hold a little less (fine enough
  // at 192 segments to be within 2 %).
  struct Case {
    const char* name;
    SurfaceMesh mesh;
    double volume;  // m^3
  };
  const Case cases[] = {
      {"torus", ffd::make_torus_mesh(0.05, 0.02, 192), 2.0 * pi * pi * 0.05 * 0.01 * 0.01},
      {"ring", ffd::make_ring_mesh(0.04, 0.01, 0.02, 192), pi * (0.04 * 0.04 - 0.03 * 0.03) * 0.02},
      {"bowl", ffd::make_bowl_mesh(0.05, 0.01, 192), 2.0 / 3.0 * pi * (0.05 * 0.05 * 0.05 - 0.04 * 0.04 * 0.04)},
  };
  for (const Case& c : cases) {
    INFO(c.name);
    CHECK(closed_and_consistent(c.mesh));
    CHECK(ffd::enclosed_volume(c.mesh) < c.volume);
    CHECK(ffd::enclosed_volume(c.mesh) == Approx(c.volume).epsilon(0.02));
    // Euler characteristic V - E + F: 0 for the torus and the ring (genus 1), 2 for the bowl.
    const std::ptrdiff_t euler = static_cast<std::ptrdiff_t>(c.mesh.vertices.size()) -
                                 static_cast<std::ptrdiff_t>(c.mesh.triangles.size()) / 2;
    CHECK(euler == (std::string(c.name) == "bowl" ? 2 : 0));
  }
  // A tube 2 cm thick around a 5 cm centre line has a circumference a fifth of the centre
  // line's: 192 / 5 = 38.4, so 38 pieces around it, and 192 x 38 quads; at 48 segments the
  // tube keeps 12 around (9.6 would be too coarse a circle).
  CHECK(cases[0].mesh.triangles.size() == 192u * 38u * 2u);
  CHECK(ffd::make_torus_mesh(0.05, 0.02, 48).triangles.size() == 48u * 12u * 2u);
  CHECK(closed_and_consistent(ffd::make_bowl_mesh(0.05, 0.01, 8)));
  const auto [lo, hi] = ffd::mesh_bounds(cases[2].mesh);
  CHECK(hi.y() == Approx(0.0).margin(1e-15));  // the bowl's rim
  CHECK(lo.y() == Approx(-0.05));
  CHECK_THROWS_AS(ffd::make_torus_mesh(0.05, 0.1, 48), std::invalid_argument);   // thicker than its hole allows
  CHECK_THROWS_AS(ffd::make_ring_mesh(0.04, 0.04, 0.02, 48), std::invalid_argument);  // no hole
  CHECK_THROWS_AS(ffd::make_bowl_mesh(0.05, 0.01, 7), std::invalid_argument);
  CHECK_THROWS_AS(ffd::make_ring_mesh(0.04, 0.01, -1.0, 48), std::invalid_argument);
}

TEST_CASE("mesh_bounds gives the extreme coordinates", "[mesh]") {
  SurfaceMesh mesh;
  mesh.vertices = {{1, -2, 3}, {-4, 5, 0}, {2, 0, -6}};
  const auto [lo, hi] = ffd::mesh_bounds(mesh);
  CHECK(lo == Vec3(-4, -2, -6));
  CHECK(hi == Vec3(2, 5, 3));
  CHECK_THROWS_AS(ffd::mesh_bounds(SurfaceMesh{}), std::invalid_argument);
}

namespace {

double surface_area(const SurfaceMesh& mesh) {
  double twice_area = 0.0;
  for (const Triangle& t : mesh.triangles) {
    const Vec3& a = mesh.vertices[t[0]];
    twice_area += (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a).norm();
  }
  return twice_area / 2.0;
}

// Undirected edges, each once, as (smaller index, larger index).
std::set<std::pair<Index, Index>> undirected_edges(const SurfaceMesh& mesh) {
  std::set<std::pair<Index, Index>> edges;
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) edges.insert(std::minmax(t[k], t[(k + 1) % 3]));
  return edges;
}

// Every undirected edge is in exactly two triangles.
bool every_edge_in_two_triangles(const SurfaceMesh& mesh) {
  std::map<std::pair<Index, Index>, int> uses;
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ++uses[std::minmax(t[k], t[(k + 1) % 3])];
  return std::all_of(uses.begin(), uses.end(), [](const auto& use) { return use.second == 2; });
}

}  // namespace

TEST_CASE("subdivide_mesh splits every triangle into four and keeps the shape", "[mesh]") {
  const std::pair<const char*, SurfaceMesh> meshes[] = {
      {"box", ffd::make_box_mesh({1, 2, 3})},
      {"icosphere", ffd::make_sphere_mesh(0.5, 1)},
      {"tetrahedron", tetrahedron()},
  };
  for (const auto& [name, mesh] : meshes) {
    INFO(name);
    REQUIRE(closed_and_consistent(mesh));
    const std::set<std::pair<Index, Index>> edges = undirected_edges(mesh);
    const SurfaceMesh fine = ffd::subdivide_mesh(mesh, 1);

    CHECK(fine.triangles.size() == 4 * mesh.triangles.size());
    // One new vertex per edge, shared by the edge's two triangles.
    CHECK(fine.vertices.size() == mesh.vertices.size() + edges.size());
    // The old vertices keep their places and indices; the new ones are edge midpoints.
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) REQUIRE(fine.vertices[v] == mesh.vertices[v]);
    std::set<std::size_t> midpoints;
    for (const auto& [a, b] : edges) {
      const Vec3 middle = 0.5 * (mesh.vertices[a] + mesh.vertices[b]);
      for (std::size_t v = mesh.vertices.size(); v < fine.vertices.size(); ++v)
        if (fine.vertices[v] == middle) midpoints.insert(v);
    }
    CHECK(midpoints.size() == edges.size());

    CHECK(closed_and_consistent(fine));
    CHECK(every_edge_in_two_triangles(fine));
    CHECK(undirected_edges(fine).size() == 2 * edges.size() + 3 * mesh.triangles.size());
    // Euler characteristic unchanged: still one closed genus-0 surface.
    const auto euler = [](const SurfaceMesh& m) {
      return static_cast<long>(m.vertices.size()) - static_cast<long>(undirected_edges(m).size()) +
             static_cast<long>(m.triangles.size());
    };
    CHECK(euler(fine) == 2);
    CHECK(surface_area(fine) == Approx(surface_area(mesh)).epsilon(1e-12));
    CHECK(signed_volume(fine) == Approx(signed_volume(mesh)).epsilon(1e-12));
    CHECK(ffd::mesh_bounds(fine) == ffd::mesh_bounds(mesh));

    // Levels compose: two levels are one level twice.
    const SurfaceMesh finer = ffd::subdivide_mesh(mesh, 2);
    const SurfaceMesh twice = ffd::subdivide_mesh(fine, 1);
    CHECK(finer.triangles.size() == 16 * mesh.triangles.size());
    CHECK(finer.vertices == twice.vertices);
    CHECK(finer.triangles == twice.triangles);
    CHECK(closed_and_consistent(finer));
    CHECK(signed_volume(finer) == Approx(signed_volume(mesh)).epsilon(1e-12));
  }
}

TEST_CASE("subdivide_mesh sizes for the box and the icosphere", "[mesh]") {
  // Box: 8 vertices, 18 edges, 12 triangles. Icosphere of 1 subdivision: 42, 120, 80.
  const SurfaceMesh box = ffd::subdivide_mesh(ffd::make_box_mesh({1, 1, 1}), 1);
  CHECK(box.vertices.size() == 26);
  CHECK(box.triangles.size() == 48);
  const SurfaceMesh sphere = ffd::subdivide_mesh(ffd::make_sphere_mesh(1.0, 1), 1);
  CHECK(sphere.vertices.size() == 162);
  CHECK(sphere.triangles.size() == 320);
  const SurfaceMesh three = ffd::subdivide_mesh(ffd::make_box_mesh({1, 1, 1}), 3);
  CHECK(three.triangles.size() == 12u * 64u);
  CHECK(three.vertices.size() == 386);  // V = F / 2 + 2 for a closed genus-0 triangle mesh
}

TEST_CASE("subdivide_mesh keeps an open mesh's boundary open", "[mesh]") {
  // A single triangle: 3 boundary edges become 6 boundary edges, the 3 inner ones are shared.
  SurfaceMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 2}};
  const SurfaceMesh fine = ffd::subdivide_mesh(mesh, 1);
  CHECK(fine.vertices.size() == 6);
  CHECK(fine.triangles.size() == 4);
  std::map<std::pair<Index, Index>, int> uses;
  for (const Triangle& t : fine.triangles)
    for (int k = 0; k < 3; ++k) ++uses[std::minmax(t[k], t[(k + 1) % 3])];
  int boundary = 0, inner = 0;
  for (const auto& [edge, count] : uses) (count == 1 ? boundary : inner) += 1;
  CHECK(boundary == 6);
  CHECK(inner == 3);
  CHECK(surface_area(fine) == Approx(0.5).epsilon(1e-15));
  // Every small triangle faces the same way as the big one (+z).
  for (const Triangle& t : fine.triangles) {
    const Vec3 normal = (fine.vertices[t[1]] - fine.vertices[t[0]]).cross(fine.vertices[t[2]] - fine.vertices[t[0]]);
    CHECK(normal.z() > 0.0);
  }
}

TEST_CASE("subdivide_mesh with 0 levels returns the mesh and rejects levels outside 0..3", "[mesh]") {
  const SurfaceMesh sphere = ffd::make_sphere_mesh(1.0, 1);
  const SurfaceMesh same = ffd::subdivide_mesh(sphere, 0);
  CHECK(same.vertices == sphere.vertices);
  CHECK(same.triangles == sphere.triangles);
  CHECK_THROWS_AS(ffd::subdivide_mesh(sphere, 4), std::invalid_argument);
  CHECK_THROWS_AS(ffd::subdivide_mesh(sphere, -1), std::invalid_argument);
  CHECK_THROWS_WITH(ffd::subdivide_mesh(sphere, 4), Catch::Matchers::Contains("0..3") && Catch::Matchers::Contains("4"));
}
