#pragma once
// Reads a triangle mesh from OBJ, PLY or STL (through assimp) into a raw SurfaceMesh:
// every triangle of every mesh in the file, vertices as the file indexes them, no clean-up
// (clean_mesh() in the runtime does that and reports it).
#include <stdexcept>
#include <string>

#include "ffd/mesh.h"

namespace ffd {

struct MeshImportError : std::runtime_error {
  using std::runtime_error::runtime_error;  // message names the file and the problem
};

SurfaceMesh import_mesh(const std::string& path);

}  // namespace ffd
