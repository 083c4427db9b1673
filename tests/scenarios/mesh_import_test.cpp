#include "ffd/mesh_import.h"

#include <algorithm>
#include <bit>
#include <catch2/catch.hpp>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "ffd/mesh.h"

namespace {

namespace fs = std::filesystem;
using ffd::Index;
using ffd::SurfaceMesh;
using ffd::Vec3;
using Triangle = std::array<Index, 3>;

// A fresh directory under the system temp dir, removed with everything in it.
struct TempDir {
  fs::path path;
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "ffd_mesh_import_XXXXXX").string();
    REQUIRE(mkdtemp(pattern.data()) != nullptr);
    path = pattern;
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  std::string write(const std::string& name, const std::string& bytes) const {
    const fs::path file = path / name;
    std::ofstream out(file, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    REQUIRE(out.good());
    return file.string();
  }
};

template <typename T>
void append_binary(std::string& bytes, T value) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));  // little-endian host, as the formats want
  bytes.append(raw, sizeof(T));
}

// The error must start with the path and say the problem.
void check_import_error(const std::string& path, const std::string& problem) {
  INFO("importing " << path);
  try {
    ffd::import_mesh(path);
    FAIL("no MeshImportError");
  } catch (const ffd::MeshImportError& error) {
    const std::string message = error.what();
    INFO("message: " << message);
    CHECK(message.rfind(path + ": ", 0) == 0);
    CHECK(message.find(problem) != std::string::npos);
  }
}

}  // namespace

TEST_CASE("import_mesh reads the shipped teapot with the file's own indexing", "[mesh_import]") {
  const std::string path = std::string(FFDSIM_SCENARIO_DIR) + "/meshes/teapot.obj";
  const SurfaceMesh teapot = ffd::import_mesh(path);
  CHECK(teapot.vertices.size() == 3644);
  CHECK(teapot.triangles.size() == 6320);
  // First `v` and `f` records of the file: "v -3.000000 1.800000 0.000000", "f 2909 2921 2939".
  CHECK(teapot.vertices.front() == Vec3(-3.0, 1.8, 0.0));
  CHECK(teapot.triangles.front() == Triangle{2908, 2920, 2938});
  const auto [lo, hi] = ffd::mesh_bounds(teapot);
  CHECK(lo.y() == Approx(0.0).margin(1e-9));
  CHECK(hi.y() == Approx(3.15).margin(1e-6));

  // The patch seams repeat 403 vertex positions; nothing else is wrong with the file.
  ffd::MeshCleanReport report;
  const SurfaceMesh cleaned = ffd::clean_mesh(teapot, ffd::MeshCleanOptions{}, report);
  CHECK(report.welded_vertices == 403);
  CHECK(report.unused_vertices == 0);
  CHECK(report.degenerate_triangles == 0);
  CHECK(report.duplicate_triangles == 0);
  CHECK(report.opposite_pair_triangles == 0);
  CHECK(report.stray_components == 0);  // lid, handle and spout are 12% of the body or more
  CHECK(cleaned.vertices.size() == 3241);
  CHECK(cleaned.triangles.size() == 6320);
  CHECK(report.summary() == "welded 403 duplicate vertices");
}

TEST_CASE("import_mesh reads OBJ polygons, relative indices and unused vertices", "[mesh_import]") {
  TempDir dir;
  const std::string path = dir.write("square.obj",
                                     "# a unit square as one quad, plus one unused vertex\n"
                                     "o square\n"
                                     "v 0 0 0\n"
                                     "v 1 0 0\n"
                                     "v 1 1 0\n"
                                     "v 0 1 0\n"
                                     "v 5 5 5\n"
                                     "vn 0 0 1\n"
                                     "f 1//1 2//1 -3//1 4//1\n"
                                     "v 0 0 0\n"  // a second vertex at the origin: kept, not joined
                                     "f -1 3 4\n");
  const SurfaceMesh mesh = ffd::import_mesh(path);
  REQUIRE(mesh.vertices.size() == 6);
  CHECK(mesh.vertices[4] == Vec3(5, 5, 5));
  CHECK(mesh.vertices[5] == Vec3(0, 0, 0));
  REQUIRE(mesh.triangles.size() == 3);
  CHECK(mesh.triangles[0] == Triangle{0, 1, 2});
  CHECK(mesh.triangles[1] == Triangle{0, 2, 3});
  CHECK(mesh.triangles[2] == Triangle{5, 2, 3});

  ffd::MeshCleanReport report;
  ffd::clean_mesh(mesh, ffd::MeshCleanOptions{}, report);
  CHECK(report.welded_vertices == 1);
  CHECK(report.unused_vertices == 1);
  CHECK(report.duplicate_triangles == 1);  // {5, 2, 3} is {0, 2, 3} after welding
}

TEST_CASE("import_mesh reads ASCII and binary PLY with the file's vertex list", "[mesh_import]") {
  TempDir dir;
  SECTION("ASCII") {
    const std::string path = dir.write("square.ply",
                                       "ply\n"
                                       "format ascii 1.0\n"
                                       "element vertex 5\n"
                                       "property float x\n"
                                       "property float y\n"
                                       "property float z\n"
                                       "element face 1\n"
                                       "property list uchar int vertex_indices\n"
                                       "end_header\n"
                                       "9 9 9\n"
                                       "0 0 0\n"
                                       "1 0 0\n"
                                       "1 1 0\n"
                                       "0 1 0\n"
                                       "4 1 2 3 4\n");
    const SurfaceMesh mesh = ffd::import_mesh(path);
    REQUIRE(mesh.vertices.size() == 5);  // the unused first vertex stays
    CHECK(mesh.vertices[0] == Vec3(9, 9, 9));
    CHECK(mesh.vertices[3] == Vec3(1, 1, 0));
    REQUIRE(mesh.triangles.size() == 2);
    for (const Triangle& t : mesh.triangles) {
      for (Index v : t) CHECK(v >= 1);
      // Both halves face +z like the quad.
      const Vec3 normal = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
      CHECK(normal.z() > 0.0);
    }
  }
  SECTION("binary little-endian") {
    std::string bytes =
        "ply\n"
        "format binary_little_endian 1.0\n"
        "element vertex 4\n"
        "property float x\n"
        "property float y\n"
        "property float z\n"
        "element face 2\n"
        "property list uchar int vertex_indices\n"
        "end_header\n";
    for (const float coordinate : {0.f, 0.f, 0.f, 2.f, 0.f, 0.f, 0.f, 2.f, 0.f, 0.f, 0.f, 2.f})
      append_binary(bytes, coordinate);
    for (const auto& face : {Triangle{0, 2, 1}, Triangle{0, 1, 3}}) {
      append_binary(bytes, std::uint8_t{3});
      for (Index v : face) append_binary(bytes, static_cast<std::int32_t>(v));
    }
    const SurfaceMesh mesh = ffd::import_mesh(dir.write("binary.ply", bytes));
    REQUIRE(mesh.vertices.size() == 4);
    CHECK(mesh.vertices[3] == Vec3(0, 0, 2));
    REQUIRE(mesh.triangles.size() == 2);
    CHECK(mesh.triangles[0] == Triangle{0, 2, 1});
    CHECK(mesh.triangles[1] == Triangle{0, 1, 3});
  }
}

// Big-endian bytes of a value, whatever the host's order.
template <typename T>
void append_big_endian(std::string& bytes, T value) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::little) std::reverse(raw, raw + sizeof(T));
  bytes.append(raw, sizeof(T));
}

TEST_CASE("import_mesh reads big-endian PLY past the properties and elements it does not use", "[mesh_import]") {
  TempDir dir;
  std::string bytes =
      "ply\n"
      "format binary_big_endian 1.0\n"
      "comment a quad with a colour on each vertex, then an edge element\n"
      "element vertex 4\n"
      "property double x\n"
      "property uchar red\n"
      "property double y\n"
      "property double z\n"
      "element face 1\n"
      "property list uchar uint vertex_index\n"
      "property list int short flags\n"
      "element edge 1\n"
      "property int vertex1\n"
      "property int vertex2\n"
      "end_header\n";
  const double corners[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0.1}};
  for (const auto& corner : corners) {
    append_big_endian(bytes, corner[0]);
    append_big_endian(bytes, std::uint8_t{200});
    append_big_endian(bytes, corner[1]);
    append_big_endian(bytes, corner[2]);
  }
  append_big_endian(bytes, std::uint8_t{4});
  for (const std::uint32_t v : {0u, 1u, 2u, 3u}) append_big_endian(bytes, v);
  append_big_endian(bytes, std::int32_t{2});
  append_big_endian(bytes, std::int16_t{-7});
  append_big_endian(bytes, std::int16_t{9});
  append_big_endian(bytes, std::int32_t{0});
  append_big_endian(bytes, std::int32_t{1});
  const SurfaceMesh mesh = ffd::import_mesh(dir.write("quad_be.ply", bytes));
  REQUIRE(mesh.vertices.size() == 4);
  CHECK(mesh.vertices[3] == Vec3(0, 1, 0.1));  // doubles kept to the bit
  REQUIRE(mesh.triangles.size() == 2);
  CHECK(mesh.triangles[0] == Triangle{0, 1, 2});
  CHECK(mesh.triangles[1] == Triangle{0, 2, 3});
}

TEST_CASE("import_mesh names the place of a malformed PLY body", "[mesh_import]") {
  TempDir dir;
  const std::string ascii_head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  SECTION("a binary face whose list declares more corners than the file holds, read without allocating them") {
    std::string bytes =
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n";
    const std::size_t header = bytes.size();
    for (const float coordinate : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) append_binary(bytes, coordinate);
    append_binary(bytes, std::uint32_t{0x7fffffff});
    for (const std::int32_t v : {0, 1, 2}) append_binary(bytes, v);
    check_import_error(dir.write("long_list.ply", bytes),
                       "byte " + std::to_string(header + 9 * 4 + 4 + 3 * 4) +
                           ": the file ends before the entries its header declares");
  }
  SECTION("an ASCII file shorter than its header says") {
    check_import_error(dir.write("short.ply", ascii_head + "0 0 0\n1 0 0\n"),
                       "line 12: the file ends before the entries its header declares");
  }
  SECTION("a value out of its type's range, and one that is not a number") {
    check_import_error(dir.write("range.ply", ascii_head + "0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n"),
                       "line 13: '300' is out of range for a PLY uchar");
    check_import_error(dir.write("word.ply", ascii_head + "0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n"),
                       "line 11: cannot read 'zero' as a PLY float");
  }
  SECTION("a vertex element without z") {
    check_import_error(dir.write("flat.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                 "end_header\n0 0\n1 0\n0 1\n"),
                       "the PLY element 'vertex' has no scalar property 'z'");
  }
  SECTION("a corner index that is not whole") {
    check_import_error(dir.write("half.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                 "property float z\nelement face 1\nproperty list uchar float vertex_indices\n"
                                 "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 1.5\n"),
                       "line 13: face 0 refers to vertex 1.5 of a mesh with 3 vertices");
  }
}

TEST_CASE("import_mesh reads ASCII and binary STL", "[mesh_import]") {
  TempDir dir;
  // STL stores each facet's corners separately: 2 facets are 6 vertices, 4 after welding.
  auto check_square = [](const SurfaceMesh& mesh) {
    CHECK(mesh.vertices.size() == 6);
    REQUIRE(mesh.triangles.size() == 2);
    ffd::MeshCleanReport report;
    const SurfaceMesh cleaned = ffd::clean_mesh(mesh, ffd::MeshCleanOptions{}, report);
    CHECK(report.welded_vertices == 2);
    CHECK(cleaned.vertices.size() == 4);
    for (const Triangle& t : cleaned.triangles) {
      const Vec3 normal =
          (cleaned.vertices[t[1]] - cleaned.vertices[t[0]]).cross(cleaned.vertices[t[2]] - cleaned.vertices[t[0]]);
      CHECK(normal.z() == Approx(1.0));
    }
  };
  SECTION("ASCII") {
    const std::string path = dir.write("square.stl",
                                       "solid square\n"
                                       "  facet normal 0 0 1\n"
                                       "    outer loop\n"
                                       "      vertex 0 0 0\n"
                                       "      vertex 1 0 0\n"
                                       "      vertex 1 1 0\n"
                                       "    endloop\n"
                                       "  endfacet\n"
                                       "  facet normal 0 0 1\n"
                                       "    outer loop\n"
                                       "      vertex 0 0 0\n"
                                       "      vertex 1 1 0\n"
                                       "      vertex 0 1 0\n"
                                       "    endloop\n"
                                       "  endfacet\n"
                                       "endsolid square\n");
    check_square(ffd::import_mesh(path));
  }
  SECTION("binary") {
    std::string bytes(80, ' ');  // header; must not start with "solid"
    bytes.replace(0, 10, "binary stl");
    append_binary(bytes, std::uint32_t{2});
    const float facets[2][4][3] = {{{0, 0, 1}, {0, 0, 0}, {1, 0, 0}, {1, 1, 0}},
                                   {{0, 0, 1}, {0, 0, 0}, {1, 1, 0}, {0, 1, 0}}};  // normal, 3 corners
    for (const auto& facet : facets) {
      for (const auto& row : facet)
        for (const float value : row) append_binary(bytes, value);
      append_binary(bytes, std::uint16_t{0});  // attribute byte count
    }
    check_square(ffd::import_mesh(dir.write("square_binary.stl", bytes)));
  }
}

TEST_CASE("import_mesh reports unreadable files with the path and the reason", "[mesh_import]") {
  TempDir dir;
  SECTION("missing file") { check_import_error((dir.path / "missing.obj").string(), "file not found"); }
  SECTION("a directory") { check_import_error(dir.path.string(), "not a regular file"); }
  SECTION("garbage PLY") {
    check_import_error(dir.write("garbage.ply", std::string("\x01\x02 this is not a mesh \xff\xfe", 24)),
                       "cannot read the mesh: the file does not start with the PLY magic number 'ply'");
  }
  SECTION("garbage STL") { check_import_error(dir.write("garbage.stl", "not an stl file"), "cannot read the mesh: "); }
  SECTION("unknown format") { check_import_error(dir.write("mesh.txt", "hello\n"), "cannot read the mesh: "); }
  SECTION("text that is not OBJ") {
    check_import_error(dir.write("text.obj", "hello world\nthis is not a mesh\n"), "no triangles");
  }
  SECTION("an OBJ with only lines") {
    check_import_error(dir.write("lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n"), "no triangles");
  }
  SECTION("a PLY with only points") {
    check_import_error(dir.write("points.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                 "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n"),
                       "no triangles");
  }
  SECTION("an OBJ face index out of range") {
    check_import_error(dir.write("bad_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"), "vertex index out of range");
  }
  SECTION("a PLY face index out of range") {
    check_import_error(dir.write("bad_index.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                 "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                 "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"),
                       "line 13: face 0 refers to vertex 7 of a mesh with 3 vertices");
  }
}

TEST_CASE("import_mesh reads OFF with the file's vertex list and polygons as fans", "[mesh_import]") {
  TempDir dir;
  SECTION("a square and a triangle, comments, counts on the keyword's line") {
    const SurfaceMesh mesh = ffd::import_mesh(dir.write("shapes.off",
                                                        "OFF 5 3 0  # counts\n"
                                                        "# a square, a point and a triangle\n"
                                                        "0 0 0\n1 0 0\n1 1 0\n0 1 0\n\n0.5 0.5 1\n"
                                                        "4 0 1 2 3\n1 4\n3 0 1 4\n"));
    CHECK(mesh.vertices.size() == 5);
    CHECK(mesh.vertices[4] == Vec3(0.5, 0.5, 1.0));
    REQUIRE(mesh.triangles.size() == 3);
    CHECK(mesh.triangles[0] == Triangle{0, 1, 2});
    CHECK(mesh.triangles[1] == Triangle{0, 2, 3});
    CHECK(mesh.triangles[2] == Triangle{0, 1, 4});
  }
  SECTION("COFF: colours after the coordinates and the corners are ignored") {
    const SurfaceMesh mesh = ffd::import_mesh(
        dir.write("coloured.off", "COFF\n3 1 3\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2 9 9 9\n"));
    CHECK(mesh.vertices.size() == 3);
    CHECK(mesh.triangles.size() == 1);
  }
  SECTION("errors name the line") {
    check_import_error(dir.write("index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"),
                       "line 6: face 0: '3' is not a vertex index below 3");
    check_import_error(dir.write("short.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n"), "line 4: expected vertex 2 as x y z");
    check_import_error(dir.write("corners.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n"),
                       "line 6: expected face 0 as 'n i1 ... in'");
    check_import_error(dir.write("number.off", "OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n"),
                       "line 4: cannot read the vertex coordinate 'x'");
    check_import_error(dir.write("4d.off", "4OFF\n3 1 0\n"), "line 1: unsupported OFF variant '4OFF'");
    check_import_error(dir.write("lines.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n"), "no triangles");
  }
}

TEST_CASE("import_mesh rejects files and headers over its limits before reading them", "[mesh_import]") {
  TempDir dir;
  const std::string ply_head = "ply\nformat ascii 1.0\nelement vertex ";
  const std::string ply_tail = "\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n";
  SECTION("a PLY header declaring more vertices than the file holds") {
    const std::string text = ply_head + "4000000000" + ply_tail;
    check_import_error(dir.write("huge.ply", text), "line 3 of the PLY header: element 'vertex' declares 4000000000 "
                                                    "entries, more than a file of " +
                                                        std::to_string(text.size()) + " bytes holds");
  }
  SECTION("a PLY count beyond 64 bits") {
    check_import_error(dir.write("huger.ply", ply_head + "99999999999999999999999" + ply_tail),
                       "element 'vertex' declares 99999999999999999999999 entries");
  }
  SECTION("a PLY header without its end") {
    check_import_error(dir.write("endless.ply", ply_head + "4\nproperty float x\n"),
                       "the PLY header has no end_header line");
  }
  SECTION("a PLY header with a malformed line") {
    check_import_error(dir.write("odd.ply", ply_head + "4\nproperty list float int vertex_indices\nend_header\n"),
                       "line 4 of the PLY header: expected 'property TYPE NAME' or 'property list COUNT_TYPE TYPE "
                       "NAME' after an element");
    check_import_error(dir.write("unknown.ply", ply_head + "4\nproperty float x\nvertex 1 2 3\nend_header\n"),
                       "line 5 of the PLY header: unknown header line 'vertex'");
  }
  SECTION("an OFF header declaring more faces than the file holds") {
    const std::string text = "OFF\n# a comment\n3 2000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    check_import_error(dir.write("huge.off", text),
                       "line 3: the header declares 2000000000 faces, more than a file of " +
                           std::to_string(text.size()) + " bytes holds");
  }
  SECTION("an OFF header with its counts on the keyword line") {
    check_import_error(dir.write("huge_one_line.off", "OFF 900000000 1 0\n0 0 0\n"),
                       "line 1: the header declares 900000000 vertices");
  }
  SECTION("a file over 1 GiB") {
    // Sparse: no disk space is used.
    const std::string path = dir.write("big.stl", "solid big\n");
    fs::resize_file(path, ffd::kMaxMeshFileBytes + 1);
    check_import_error(path, "the file has 1073741825 bytes, more than the limit of 1073741824 (1 GiB)");
  }
}

TEST_CASE("import_mesh names the file and the 1-based line of a vertex that is not finite", "[mesh_import]") {
  TempDir dir;
  const std::string tetrahedron_faces = "f 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n";
  check_import_error(dir.write("nan.obj", "# a comment\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 1\n" + tetrahedron_faces),
                     "line 5: vertex 4 has the coordinate 'nan', which is not a finite number");
  check_import_error(dir.write("inf.obj", "v 0 0 0\nv 1 0 0\nv 0 inf 0\nv 0 0 1\n" + tetrahedron_faces),
                     "line 3: vertex 3 has the coordinate 'inf', which is not a finite number");
  check_import_error(dir.write("nan.off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\nnan 0 1\n3 0 1 2\n3 0 2 3\n3 0 3 1\n3 1 3 2\n"),
                     "line 6: vertex 4 has the coordinate 'nan', which is not a finite number");
  check_import_error(dir.write("nan.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                          "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                          "end_header\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"),
                     "line 11: vertex 2 has a y that is not a finite number");
}

TEST_CASE("a closed mesh wound inside out is turned outward, with a note, and simulates as the outward one",
          "[mesh_import]") {
  SurfaceMesh box = ffd::make_box_mesh(Vec3(0.1, 0.2, 0.3));
  SurfaceMesh inside_out = box;
  for (Triangle& t : inside_out.triangles) std::swap(t[1], t[2]);
  CHECK(ffd::enclosed_volume(box) == Approx(0.006));
  CHECK(ffd::enclosed_volume(inside_out) == Approx(-0.006));
  ffd::MeshCleanReport report;
  const SurfaceMesh turned = ffd::clean_mesh(inside_out, {}, report);
  CHECK(report.turned_outward);
  CHECK(report.inside_out_volume_m3 == Approx(-0.006));
  CHECK(report.summary() == "wound inside out (enclosed volume -0.006 m^3): turned outward");
  CHECK(turned.triangles == box.triangles);
  // An outward box and an open surface (one face missing) are left as they are.
  ffd::clean_mesh(box, {}, report);
  CHECK_FALSE(report.turned_outward);
  SurfaceMesh open = inside_out;
  open.triangles.pop_back();
  open.triangles.pop_back();
  CHECK_FALSE(ffd::is_closed_and_consistent(open));
  CHECK(ffd::clean_mesh(open, {}, report).triangles == open.triangles);
  CHECK_FALSE(report.turned_outward);
}
