// Mesh files through import_mesh() (PLY and OFF readers of our own; OBJ and STL through assimp, OBJ
// also through the record reader) and clean_mesh().
// The importer takes a path and picks the format by extension, so the first byte of the
// input picks the extension (its value mod 4: .obj, .ply, .stl, .off; the seeds start with
// '0' to '3') and the rest is written to a file of this process's own temporary folder.
#include <unistd.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "ffd/mesh.h"
#include "ffd/mesh_import.h"
#include "fuzz_support.h"

namespace {

struct TemporaryFolder {
  std::filesystem::path path;
  TemporaryFolder() {
    std::string pattern = (std::filesystem::temp_directory_path() / "ffdsim-fuzz-mesh-XXXXXX").string();
    if (!mkdtemp(pattern.data())) std::abort();
    path = pattern;
  }
  ~TemporaryFolder() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const TemporaryFolder folder;
  static constexpr std::array<const char*, 4> kExtensions = {".obj", ".ply", ".stl", ".off"};
  if (size == 0) return 0;
  const std::string path = (folder.path / (std::string("input") + kExtensions[data[0] % 4])).string();
  {
    std::ofstream file(path, std::ios::binary | std::ios::trunc);
    file.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
    if (!file) std::abort();
  }
  ffd::SurfaceMesh mesh;
  try {
    mesh = ffd::import_mesh(path);
  } catch (const ffd::MeshImportError&) {
    return 0;
  }
  try {
    ffd::MeshCleanReport report;
    const ffd::SurfaceMesh clean = ffd::clean_mesh(mesh, ffd::MeshCleanOptions{}, report);
    (void)clean;
  } catch (const std::invalid_argument&) {  // clean_mesh's "nothing left" and bad values
  }
  return 0;
}
