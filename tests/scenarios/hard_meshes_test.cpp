// The hard cases' degenerate meshes (scenarios/meshes/hard/): a single triangle, a mesh with
// holes and a mesh with every vertex in one plane load and compile into lattices; a mesh
// whose only triangle has no area is refused with a message naming the object and the file.
#include <catch2/catch.hpp>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "ffd/model.h"
#include "ffd/scene_loader.h"

namespace {

using Catch::Matchers::Equals;

const std::string kHardScene = FFDSIM_SCENARIO_DIR "/scenes/hard/degenerate_meshes.toml";

const ffd::ObjectModel& object_named(const ffd::Model& model, const std::string& name) {
  for (const ffd::ObjectModel& o : model.objects)
    if (o.name == name) return o;
  FAIL("no object " << name);
  return model.objects.front();
}

}  // namespace

TEST_CASE("Hard meshes: a single triangle and an open tube and a flat square compile into lattices", "[scene_loader]") {
  const ffd::SceneSpec spec = ffd::load_scene_file(kHardScene);
  std::vector<std::string> log;
  const ffd::Model model = ffd::compile(spec, log);
  REQUIRE(model.objects.size() == 3);

  const ffd::ObjectModel& triangle = object_named(model, "triangle");
  CHECK(triangle.surface.triangles.size() == 1);
  // Flat in y: one layer of 2 cm cells under a 10 cm triangle, only those it passes through.
  CHECK(triangle.lattice_dims == ffd::Vec3i(6, 1, 6));
  CHECK(triangle.cell_end - triangle.cell_begin == 21);
  CHECK(triangle.box_end - triangle.box_begin == 21);

  const ffd::ObjectModel& square = object_named(model, "square");
  CHECK(square.surface.triangles.size() == 4);
  CHECK(square.lattice_dims == ffd::Vec3i(6, 1, 6));
  CHECK(square.cell_end - square.cell_begin == 36);  // the whole 6 x 6 layer

  const ffd::ObjectModel& tube = object_named(model, "tube");
  CHECK(tube.surface.triangles.size() == 8);
  CHECK(tube.lattice_dims == ffd::Vec3i(6, 6, 6));
  // The 152 cells of the 6 x 6 x 6 lattice's outer layer less the 2 x 4 x 4 that only the
  // missing end faces would pass through.
  CHECK(tube.cell_end - tube.cell_begin == 120);

  // Every FFD AABB of a flat surface is thickened (min_box_thickness, 0.1 of a cell), so
  // none is flat: its 8 corners span at least that much along every local axis.
  for (ffd::Index b = 0; b < model.box_count(); ++b) {
    ffd::Vec3 low = model.boxes.box_local[b][0], high = low;
    for (int k = 1; k < 8; ++k) {
      low = low.cwiseMin(model.boxes.box_local[b][k]);
      high = high.cwiseMax(model.boxes.box_local[b][k]);
    }
    INFO("box " << b);
    CHECK((high - low).minCoeff() >= 0.1 - 1e-12);
  }
}

TEST_CASE("Hard meshes: a mesh whose only triangle has no area is refused by name") {
  // Three corners on one line: nothing is left to embed once the degenerate triangle goes.
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("ffdsim_hard_meshes_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "line.obj") << "v 0 0 0\nv 0.1 0 0\nv 0.2 0 0\nf 1 2 3\n";
  const ffd::SceneSpec spec = ffd::parse_scene(R"(
[simulation]
effects = ["gravity"]
[[object]]
name = "line"
mesh = "line.obj"
  [object.mass_spring]
)",
                                               "inline.toml", dir.string());
  std::vector<std::string> log;
  REQUIRE_THROWS_AS(ffd::compile(spec, log), ffd::CompileError);
  REQUIRE_THROWS_WITH(ffd::compile(spec, log),
                      Equals("object 'line' (line.obj): clean_mesh: no triangles remain (dropped 3 unused vertices; "
                             "dropped 1 degenerate triangle)"));
  std::filesystem::remove_all(dir);
}
