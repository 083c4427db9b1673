#pragma once
// TOML scene files -> SceneSpec. The format is documented in docs/scene-format.md ("Scene format").
// Every error names the file, the line and the field:
//   "scenes/bad.toml:12:1: object[2].cell_size: must be > 0 (got -0.1)"
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "ffd/model.h"
#include "ffd/spec.h"
#include "ffd/toml_reader.h"

namespace ffd {

using SceneError = InputError;

// What one scene may ask for: past these a file gets an error naming the place, instead of
// exhausting memory or time in compile(). Each bounds a cost of compile(): the triangles of
// the surfaces after `subdivide`; the cells of each object's regular lattice grid (mesh
// extent / cell_size per axis), allocated before the cells the surface passes through are
// kept; the triangle-cell pairs the lattice builder clips (each triangle against every cell
// of its bounding box); the members of shape-matching regions ((2w+1)^3 lattice nodes around
// each node). The shipped scenes stay far below: at most 1,014 objects and 2.3 million
// triangles (the alphabet pile), 257,620 triangles in one object (the subdivided Buddha),
// 7,056 grid cells in one object and 35,280 in all (the bunnies), 3.2 million
// triangle-cell pairs (the alphabet pile), 156 glyph samples per em.
struct SceneLimits {
  std::size_t objects = 10'000;                   // in the scene, groups' objects included
  std::size_t object_triangles = 5'000'000;       // one object's surface
  std::size_t scene_triangles = 10'000'000;       // all objects together
  std::size_t object_lattice_cells = 1'000'000;   // one object's grid
  std::size_t scene_lattice_cells = 2'000'000;    // all objects together
  std::size_t scene_triangle_cells = 100'000'000; // triangle-cell pairs, all objects
  std::size_t scene_region_members = 50'000'000;  // shape-matching region members, all objects
  std::size_t glyph_text = 256;                   // characters in a glyph.text
  double glyph_samples_per_em = 2'000;            // glyph em_size / sample_spacing
};

// Loads a scene file; mesh paths inside it are relative to the file's folder.
SceneSpec load_scene_file(const std::string& path, const SceneLimits& limits = {});

// compile() for a scene loaded from `path`: a CompileError becomes an InputError that names
// the file first, as the loader's own errors do ("scene.toml: object 'box'.cell_size: ...").
Model compile_scene(const SceneSpec& spec, const std::string& path, std::vector<std::string>& log);

// Parses scene text; `origin` names it in messages and `base_dir` resolves mesh paths.
SceneSpec parse_scene(const std::string& text, const std::string& origin, const std::string& base_dir,
                      const SceneLimits& limits = {});

// A scene given as a TOML table inside another file (a replay script's [scene]); messages
// name `origin` with the table's own lines.
SceneSpec read_scene_table(const toml::table& table, const std::string& origin, const std::string& base_dir,
                           const SceneLimits& limits = {});

// The default scene, which needs no file from the user: two Utah teapots dropped on each
// other onto a floor (the paper's Fig. 7).
// The folder with scenes/, meshes/, replays/ and ui_scripts/: <prefix>/share/ffdsim when
// ffdsim runs installed, else the source tree's scenarios/.
std::string scenario_dir();

// Every key the loader reads, by the table it stands in: "simulation", "probe", "grab",
// "plane", "object", "object.glyph", "object.mass_spring", "object.shape_matching", "group"
// (its own keys; the object's keys but `position` are read too), "group.layout",
// "group.random". The docs test holds docs/scene-format.md to this list, both ways.
std::vector<std::pair<std::string, std::vector<std::string>>> scene_keys();
std::string default_scene_path();
SceneSpec default_scene();

}  // namespace ffd
