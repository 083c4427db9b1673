#pragma once
// TOML scene files -> SceneSpec. The format is documented in README.md ("Scene format").
// Every error names the file, the line and the field:
//   "scenes/bad.toml:12:1: object[2].cell_size: must be > 0 (got -0.1)"
#include <stdexcept>
#include <string>

#include "ffd/spec.h"
#include "ffd/toml_reader.h"

namespace ffd {

using SceneError = InputError;

// Loads a scene file; mesh paths inside it are relative to the file's folder.
SceneSpec load_scene_file(const std::string& path);

// Parses scene text; `origin` names it in messages and `base_dir` resolves mesh paths.
SceneSpec parse_scene(const std::string& text, const std::string& origin, const std::string& base_dir);

// A scene given as a TOML table inside another file (a replay script's [scene]); messages
// name `origin` with the table's own lines.
SceneSpec read_scene_table(const toml::table& table, const std::string& origin, const std::string& base_dir);

// The default scene, which needs no file from the user: two Utah teapots dropped on each
// other onto a floor (the paper's Fig. 7).
std::string default_scene_path();
SceneSpec default_scene();

}  // namespace ffd
