#pragma once
// Reads a triangle mesh from OBJ, PLY or STL (through assimp) or OFF (read here) into a raw
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

// Checked before assimp reads a file, so that a bad one gets an error rather than exhausting
// memory or crashing the reader: its size; a PLY header, read strictly (it must end, and no
// element may declare more entries than the file has bytes: assimp allocates them up front);
// an OFF file's counts likewise. Then the vertices and triangles assimp made, and its
// faces' indices, before its post-processing uses them. The shipped meshes: 3 MB, 69,451
// triangles at most.
inline constexpr std::uintmax_t kMaxMeshFileBytes = std::uintmax_t{1} << 30;  // 1 GiB
inline constexpr std::size_t kMaxMeshTriangles = 20'000'000;
inline constexpr std::size_t kMaxMeshVertices = 20'000'000;

SurfaceMesh import_mesh(const std::string& path);

}  // namespace ffd
