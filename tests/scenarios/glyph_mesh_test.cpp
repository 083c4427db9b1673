#include "ffd/glyph_mesh.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>

#include "ffd/mesh.h"

namespace {

using ffd::GlyphMeshOptions;
using ffd::Index;
using ffd::SurfaceMesh;
using ffd::Vec3;

// fonts-dejavu-core (setup.sh). DejaVu Sans Bold: 2048 units per em.
const std::string kFont = "/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf";

GlyphMeshOptions glyph_options(char32_t character, double sample_spacing = 0.0005) {
  GlyphMeshOptions options;
  options.font_path = kFont;
  options.character = character;
  options.em_size = 0.05;
  options.depth = 0.02;
  options.sample_spacing = sample_spacing;
  return options;
}

// Closed and consistently oriented: every directed edge appears exactly once and so does
// its reverse (each undirected edge in exactly two triangles, once each way).
bool closed_and_oriented(const SurfaceMesh& mesh) {
  std::map<std::pair<Index, Index>, int> uses;
  for (const auto& t : mesh.triangles)
    for (std::size_t k = 0; k < 3; ++k) ++uses[{t[k], t[(k + 1) % 3]}];
  for (const auto& [edge, count] : uses) {
    if (count != 1) return false;
    const auto reverse = uses.find({edge.second, edge.first});
    if (reverse == uses.end() || reverse->second != 1) return false;
  }
  return true;
}

// Enclosed volume, m^3 (positive for an outward-oriented closed surface).
double signed_volume(const SurfaceMesh& mesh) {
  double six_volume = 0.0;
  for (const auto& t : mesh.triangles)
    six_volume += mesh.vertices[t[0]].dot(mesh.vertices[t[1]].cross(mesh.vertices[t[2]]));
  return six_volume / 6.0;
}

struct Cap {
  std::size_t triangles = 0;
  std::size_t facing_away = 0;  // triangles whose normal does not point along +z
  double area = 0.0;            // m^2
};

// The triangles with all three corners on the front face z = +depth/2.
Cap front_cap(const SurfaceMesh& mesh, double depth) {
  Cap cap;
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    if (a.z() != 0.5 * depth || b.z() != 0.5 * depth || c.z() != 0.5 * depth) continue;
    const double twice_area = (b - a).cross(c - a).z();
    ++cap.triangles;
    if (twice_area <= 0.0) ++cap.facing_away;
    cap.area += 0.5 * twice_area;
  }
  return cap;
}

// The error must name the font file first and say the problem.
void check_glyph_error(const GlyphMeshOptions& options, const std::string& problem) {
  try {
    ffd::make_glyph_mesh(options);
    FAIL("no std::invalid_argument");
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    INFO("message: " << message);
    CHECK(message.rfind(options.font_path + ": ", 0) == 0);
    CHECK(message.find(problem) != std::string::npos);
  }
}

void check_option_error(const GlyphMeshOptions& options, const std::string& problem) {
  try {
    ffd::make_glyph_mesh(options);
    FAIL("no std::invalid_argument");
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    INFO("message: " << message);
    CHECK(message.find(problem) != std::string::npos);
  }
}

}  // namespace

TEST_CASE("make_glyph_mesh extrudes letters with 0 to 2 holes into closed outward solids", "[glyph]") {
  const std::pair<char32_t, int> letters[] = {{U'I', 0}, {U'W', 0}, {U'A', 1}, {U'O', 1}, {U'Q', 1},
                                              {U'R', 1}, {U'g', 1}, {U'B', 2}};
  for (const auto& [character, holes] : letters) {
    const GlyphMeshOptions options = glyph_options(character);
    INFO("U+" << std::hex << static_cast<std::uint32_t>(character) << std::dec << ", " << holes << " holes");
    const SurfaceMesh mesh = ffd::make_glyph_mesh(options);
    const auto V = static_cast<long>(mesh.vertices.size());
    const auto F = static_cast<long>(mesh.triangles.size());
    REQUIRE(V > 100);

    // The contour samples, once on each cap.
    std::size_t front = 0, back = 0;
    for (const Vec3& p : mesh.vertices) {
      if (p.z() == 0.5 * options.depth) ++front;
      if (p.z() == -0.5 * options.depth) ++back;
    }
    CHECK(front == mesh.vertices.size() / 2);
    CHECK(back == mesh.vertices.size() / 2);

    CHECK(closed_and_oriented(mesh));
    // V - E + F = 2 - 2 g with E = 3 F / 2; so F = 2 V - 4 + 4 g.
    CHECK(V - 3 * F / 2 + F == 2 - 2 * holes);
    CHECK(F == 2 * V - 4 + 4 * holes);

    // The front cap: a polygon with holes triangulated on its n = V / 2 samples only, all
    // counter-clockwise seen from +z; the solid is that cap swept over the depth.
    const Cap cap = front_cap(mesh, options.depth);
    CHECK(static_cast<long>(cap.triangles) == V / 2 + 2 * holes - 2);
    CHECK(cap.facing_away == 0);
    const double volume = signed_volume(mesh);
    CHECK(volume > 0.0);
    CHECK(volume == Approx(cap.area * options.depth).epsilon(1e-9));
    // A bold capital fills roughly a fifth to a half of a 0.05 m em square.
    CHECK(cap.area > 0.05 * 0.05 * 0.05);
    CHECK(cap.area < 0.05 * 0.05 * 0.5);

    // Nothing to weld, drop or split off.
    ffd::MeshCleanReport report;
    ffd::clean_mesh(mesh, ffd::MeshCleanOptions{}, report);
    CHECK(report.summary() == "clean");
    CHECK(report.output_vertices == mesh.vertices.size());
    CHECK(report.output_triangles == mesh.triangles.size());

    // Centred on its bounding box; the caps exactly depth apart.
    const auto [lo, hi] = ffd::mesh_bounds(mesh);
    CHECK(std::abs(lo.x() + hi.x()) < 1e-12);
    CHECK(std::abs(lo.y() + hi.y()) < 1e-12);
    CHECK(hi.z() == 0.5 * options.depth);
    CHECK(lo.z() == -0.5 * options.depth);
  }
}

TEST_CASE("make_glyph_mesh samples the contours evenly at the sample spacing", "[glyph]") {
  // DejaVu Sans Bold's 'I' is one rectangle of 385 x 1493 font units, 2048 per em: at
  // em_size 0.05 m a perimeter of 0.0917 m, so 183 samples 0.501 mm apart.
  const GlyphMeshOptions options = glyph_options(U'I', 0.0005);
  const double scale = options.em_size / 2048.0;
  const double width = 385 * scale, height = 1493 * scale, perimeter = 2.0 * (width + height);
  const SurfaceMesh mesh = ffd::make_glyph_mesh(options);
  CHECK(mesh.vertices.size() == 2 * 183);

  // Corners of the rectangle other than a sample's are cut by less than one spacing.
  const auto [lo, hi] = ffd::mesh_bounds(mesh);
  CHECK(hi.x() - lo.x() <= width + 1e-12);
  CHECK(hi.x() - lo.x() > width - options.sample_spacing);
  CHECK(hi.y() - lo.y() <= height + 1e-12);
  CHECK(hi.y() - lo.y() > height - options.sample_spacing);

  // The front cap's boundary: edges its triangles use only one way round.
  std::map<std::pair<Index, Index>, int> cap_edges;
  for (const auto& t : mesh.triangles) {
    bool on_front = true;
    for (Index v : t) on_front = on_front && mesh.vertices[v].z() > 0.0;
    if (!on_front) continue;
    for (std::size_t k = 0; k < 3; ++k) ++cap_edges[{t[k], t[(k + 1) % 3]}];
  }
  std::size_t boundary_edges = 0;
  double boundary_length = 0.0, longest = 0.0;
  for (const auto& [edge, count] : cap_edges) {
    if (cap_edges.count({edge.second, edge.first}) != 0) continue;
    const double length = (mesh.vertices[edge.first] - mesh.vertices[edge.second]).norm();
    ++boundary_edges;
    boundary_length += length;
    longest = std::max(longest, length);
  }
  CHECK(boundary_edges == 183);
  CHECK(longest <= perimeter / 183 * (1 + 1e-9));  // even steps along the arc; chords are shorter
  CHECK(boundary_length > 0.99 * perimeter);
}

TEST_CASE("make_glyph_mesh vertex counts scale inversely with the sample spacing", "[glyph]") {
  for (char32_t character : {U'B', U'S', U'W'}) {
    INFO("U+" << std::hex << static_cast<std::uint32_t>(character));
    const double coarse = static_cast<double>(ffd::make_glyph_mesh(glyph_options(character, 0.001)).vertices.size());
    const double medium = static_cast<double>(ffd::make_glyph_mesh(glyph_options(character, 0.0005)).vertices.size());
    const double fine = static_cast<double>(ffd::make_glyph_mesh(glyph_options(character, 0.00025)).vertices.size());
    CHECK(medium / coarse == Approx(2.0).epsilon(0.05));
    CHECK(fine / medium == Approx(2.0).epsilon(0.05));
  }
}

TEST_CASE("make_glyph_mesh is deterministic and scales with em_size at a fixed spacing per em", "[glyph]") {
  const SurfaceMesh small = ffd::make_glyph_mesh(glyph_options(U'R'));
  CHECK(ffd::make_glyph_mesh(glyph_options(U'R')).vertices == small.vertices);
  GlyphMeshOptions doubled = glyph_options(U'R', 2 * 0.0005);
  doubled.em_size = 2 * 0.05;
  const SurfaceMesh large = ffd::make_glyph_mesh(doubled);
  REQUIRE(large.vertices.size() == small.vertices.size());
  CHECK(large.triangles == small.triangles);
  for (std::size_t i = 0; i < small.vertices.size(); ++i) {
    CHECK(large.vertices[i].x() == 2 * small.vertices[i].x());  // powers of two: exact
    CHECK(large.vertices[i].y() == 2 * small.vertices[i].y());
    CHECK(large.vertices[i].z() == small.vertices[i].z());
  }
}

TEST_CASE("make_glyph_mesh meshes glyphs of several pieces and composite glyphs", "[glyph]") {
  // 'i': stem and dot, no hole; U+00E9 'e acute' is composed of 'e' (one hole) and an accent.
  // With c pieces and g holes V - E + F = 2 c - 2 g.
  const std::pair<char32_t, int> glyphs[] = {{U'i', 2 * 2 - 0}, {U'\u00E9', 2 * 2 - 2}, {U'%', 2 * 3 - 2 * 2}};
  for (const auto& [character, euler] : glyphs) {
    INFO("U+" << std::hex << static_cast<std::uint32_t>(character));
    const SurfaceMesh mesh = ffd::make_glyph_mesh(glyph_options(character));
    const auto V = static_cast<long>(mesh.vertices.size());
    const auto F = static_cast<long>(mesh.triangles.size());
    CHECK(closed_and_oriented(mesh));
    CHECK(V - 3 * F / 2 + F == euler);
    CHECK(signed_volume(mesh) > 0.0);
    ffd::MeshCleanReport report;
    ffd::clean_mesh(mesh, ffd::MeshCleanOptions{}, report);
    CHECK(report.summary() == "clean");
  }
}

TEST_CASE("make_glyph_mesh names the font and the character when it cannot mesh a glyph", "[glyph]") {
  GlyphMeshOptions missing = glyph_options(U'A');
  missing.font_path = "/nonexistent/ffd_no_such_font.ttf";
  check_glyph_error(missing, "cannot read the font (FreeType error 1");

  GlyphMeshOptions not_a_font = glyph_options(U'A');
  not_a_font.font_path = std::string(FFDSIM_SCENARIO_DIR) + "/meshes/teapot.obj";
  check_glyph_error(not_a_font, "cannot read the font");

  check_glyph_error(glyph_options(U'\U0010FFFF'), "no glyph for U+10FFFF");
  check_glyph_error(glyph_options(U'\uE000'), "no glyph for U+E000");  // private use: not in DejaVu
  check_glyph_error(glyph_options(U'\u4E2D'), "no glyph for U+4E2D ('\xE4\xB8\xAD')");  // CJK, UTF-8
  check_glyph_error(glyph_options(U' '), "the glyph for U+0020 (' ') has no outline");
}

TEST_CASE("make_glyph_mesh rejects bad sizes and spacings", "[glyph]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double spacing : {0.0, -0.0005, nan, inf}) {
    INFO("sample_spacing " << spacing);
    check_option_error(glyph_options(U'A', spacing), "sample_spacing must be finite and > 0");
  }
  GlyphMeshOptions options = glyph_options(U'A');
  options.em_size = 0.0;
  check_option_error(options, "em_size must be finite and > 0");
  options = glyph_options(U'A');
  options.depth = nan;
  check_option_error(options, "depth must be finite and > 0");
  options = glyph_options(U'A');
  options.depth = -0.01;
  check_option_error(options, "depth must be finite and > 0");

  // Coarser than the em square, or so fine that the samples would run into the millions.
  check_option_error(glyph_options(U'A', 0.06), "sample_spacing must be at most em_size");
  check_option_error(glyph_options(U'A', 1e-12), "sample_spacing must be at least em_size / 1e7");
  check_glyph_error(glyph_options(U'A', 1e-7), "the limit is 200000");
}
