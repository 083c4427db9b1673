#pragma once
// Reads a triangle mesh from OBJ or STL (through assimp) or PLY or OFF (read here) into a raw
// SurfaceMesh: every triangle of every mesh in the file, vertices as the file indexes them,
// no clean-up (clean_mesh() in the runtime does that and reports it).
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "ffd/mesh.h"

namespace ffd {

struct MeshImportError : std::runtime_error {
  using std::runtime_error::runtime_error;  // message names the file and the problem
};

// Checked so that a bad file gets an error rather than exhausting memory or crashing a
// reader: its size; a PLY or OFF file's declared counts (no more entries than the file has
// bytes; nothing is allocated for a count before its entries are read); for assimp's formats,
// the vertices and triangles it made, and its faces' indices, before its post-processing uses
// them. The shipped meshes: 3 MB, 69,451 triangles at most.
inline constexpr std::uintmax_t kMaxMeshFileBytes = std::uintmax_t{1} << 30;  // 1 GiB
inline constexpr std::size_t kMaxMeshTriangles = 20'000'000;
inline constexpr std::size_t kMaxMeshVertices = 20'000'000;

SurfaceMesh import_mesh(const std::string& path);

}  // namespace ffd
