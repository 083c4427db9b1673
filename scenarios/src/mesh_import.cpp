#include "ffd/mesh_import.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace ffd {

namespace {

using Triangle = std::array<Index, 3>;

[[noreturn]] void fail(const std::string& path, const std::string& problem) {
  throw MeshImportError(path + ": " + problem);
}

std::string lowercase_extension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

std::string_view trim(std::string_view text) {
  const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!text.empty() && is_space(text.front())) text.remove_prefix(1);
  while (!text.empty() && is_space(text.back())) text.remove_suffix(1);
  return text;
}

// Splits on blanks; views into `line`.
std::vector<std::string_view> tokens_of(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

// assimp's OBJ loader emits one vertex per face corner and discards the file's vertex
// indices; its JoinIdenticalVertices cannot restore them, because it also merges distinct
// file vertices at equal positions (403 on the teapot) and drops unreferenced ones (1,113 on
// bunny.obj). So after assimp has accepted the file, the `v` and `f` records are read here
// to keep the file's own vertex list and indexing, in double precision. Polygons are split
// into fans from their first corner; faces of one or two corners (points, lines) are skipped.
SurfaceMesh read_obj_indexing(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) fail(path, "cannot open the file");
  SurfaceMesh mesh;
  std::string line, record;
  std::size_t line_number = 0, record_line = 0;
  std::vector<Index> corners;
  while (std::getline(file, line)) {
    ++line_number;
    if (record.empty()) record_line = line_number;
    std::string_view view = trim(line);
    // A trailing backslash continues the record on the next line.
    if (!view.empty() && view.back() == '\\') {
      record.append(view.substr(0, view.size() - 1)).push_back(' ');
      continue;
    }
    record.append(view);
    const std::string_view text = trim(std::string_view(record).substr(0, record.find('#')));
    const std::vector<std::string_view> tokens = tokens_of(text);
    const std::string where = "line " + std::to_string(record_line) + ": ";
    if (!tokens.empty() && tokens[0] == "v") {
      if (tokens.size() < 4) fail(path, where + "a vertex needs x, y and z");
      Vec3 position;
      for (int axis = 0; axis < 3; ++axis) {
        const std::string_view number = tokens[static_cast<std::size_t>(axis) + 1];
        const auto [end, error] = std::from_chars(number.data(), number.data() + number.size(), position[axis]);
        if (error != std::errc() || end != number.data() + number.size())
          fail(path, where + "cannot read the vertex coordinate '" + std::string(number) + "'");
      }
      mesh.vertices.push_back(position);
    } else if (!tokens.empty() && tokens[0] == "f") {
      corners.clear();
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        const std::string_view corner = tokens[k].substr(0, tokens[k].find('/'));  // position index of v/vt/vn
        std::int64_t index = 0;
        const auto [end, error] = std::from_chars(corner.data(), corner.data() + corner.size(), index);
        if (error != std::errc() || end != corner.data() + corner.size() || index == 0)
          fail(path, where + "cannot read the face index '" + std::string(tokens[k]) + "'");
        // 1-based; negative indices count back from the latest vertex.
        const std::int64_t resolved = index > 0 ? index - 1 : static_cast<std::int64_t>(mesh.vertices.size()) + index;
        if (resolved < 0 || resolved >= static_cast<std::int64_t>(mesh.vertices.size()))
          fail(path, where + "face index " + std::to_string(index) + " refers to no vertex defined before it");
        corners.push_back(static_cast<Index>(resolved));
      }
      for (std::size_t k = 2; k < corners.size(); ++k)
        mesh.triangles.push_back({corners[0], corners[k - 1], corners[k]});
    }
    record.clear();
  }
  return mesh;
}

}  // namespace

SurfaceMesh import_mesh(const std::string& path) {
  std::error_code status_error;
  const auto status = std::filesystem::status(path, status_error);
  if (!std::filesystem::exists(status)) fail(path, "file not found");
  if (!std::filesystem::is_regular_file(status)) fail(path, "not a regular file");

  // No clean-up steps: no JoinIdenticalVertices (it welds with its own epsilon and drops
  // unreferenced vertices), no FindDegenerates, no validation fixes. clean_mesh() does the
  // clean-up and reports it.
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_PreTransformVertices);
  if (scene == nullptr) fail(path, std::string("cannot read the mesh: ") + importer.GetErrorString());

  SurfaceMesh mesh;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh& part = *scene->mMeshes[m];
    const bool has_triangles = std::any_of(part.mFaces, part.mFaces + part.mNumFaces,
                                           [](const aiFace& face) { return face.mNumIndices == 3; });
    if (!has_triangles) continue;  // points or lines only
    const auto base = mesh.vertices.size();
    for (unsigned v = 0; v < part.mNumVertices; ++v) {
      const aiVector3D& p = part.mVertices[v];
      mesh.vertices.emplace_back(static_cast<double>(p.x), static_cast<double>(p.y), static_cast<double>(p.z));
    }
    for (unsigned f = 0; f < part.mNumFaces; ++f) {
      const aiFace& face = part.mFaces[f];
      if (face.mNumIndices != 3) continue;
      Triangle triangle{};
      for (int k = 0; k < 3; ++k) {
        if (face.mIndices[k] >= part.mNumVertices)
          fail(path, "face " + std::to_string(f) + " refers to vertex " + std::to_string(face.mIndices[k]) +
                         " of a mesh with " + std::to_string(part.mNumVertices) + " vertices");
        triangle[static_cast<std::size_t>(k)] = static_cast<Index>(base + face.mIndices[k]);
      }
      mesh.triangles.push_back(triangle);
    }
  }
  if (mesh.triangles.empty()) fail(path, "the file has no triangles (only points, lines or nothing)");

  if (lowercase_extension(path) == ".obj") {
    SurfaceMesh indexed = read_obj_indexing(path);
    // Both readers must see the same faces; a mismatch means an OBJ feature the record
    // reader does not know, and its indexing would be wrong.
    if (indexed.triangles.size() != mesh.triangles.size())
      fail(path, "the OBJ face records give " + std::to_string(indexed.triangles.size()) +
                     " triangles, but assimp read " + std::to_string(mesh.triangles.size()));
    return indexed;
  }
  return mesh;
}

}  // namespace ffd
