#pragma once
// What a run writes for the user beside its report (docs/command-line.md, "Exports"): the deformed
// surfaces every K steps, as OBJ or PLY, and a per-step time series (energy, contacts,
// penetration, stage times) as CSV or JSON for plotting a tuning session. Fed from the
// loop's lossless telemetry and its snapshots, on the thread that drains them: the 1 kHz
// thread never writes a file.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "ffd/model.h"
#include "ffd/physics_loop.h"

namespace ffd {

enum class SurfaceFormat { Obj, Ply };
// "obj" or "ply"; throws std::invalid_argument naming the text otherwise.
SurfaceFormat parse_surface_format(const std::string& text);

struct ExportOptions {
  std::uint64_t surfaces_every = 0;  // steps between surface files (0: none)
  std::string surfaces_dir;          // DIR/<object>_<step>.obj or .ply
  SurfaceFormat surface_format = SurfaceFormat::Obj;
  std::string series_path;           // FILE.csv or FILE.json (empty: none)
  bool any() const { return surfaces_every > 0 || !series_path.empty(); }
};

// A surface as OBJ (text) or PLY (binary little-endian, double vertices). `source` is where
// it came from: a letter of a font carries the font's notice. Throws naming the file.
void write_surface(const std::filesystem::path& path, const SurfaceMesh& mesh, SurfaceFormat format,
                   const std::string& source);

class RunExports {
 public:
  // Creates the folder and the series file (a bad path throws InputError before the run)
  // and writes the surfaces of `initial` (step 0). `sources[i]` is object i's mesh source.
  RunExports(const Model& model, const State& initial, std::vector<std::string> sources, ExportOptions options);

  std::uint64_t surfaces_every() const { return options_.surfaces_every; }
  void telemetry(const Telemetry& t);                                // one row of the series
  void snapshot(std::uint64_t step, const std::vector<Vec3>& nodes);  // surfaces, when step is a multiple of K
  // Writes the JSON series, closes the files. Call once, after the last telemetry.
  void finish();

  // The first write error (then nothing more is written), or empty.
  const std::string& error() const { return error_; }
  std::uint64_t rows() const { return rows_; }
  std::uint64_t surface_steps() const { return surface_steps_; }
  std::uint64_t last_surface_step() const { return last_surface_step_; }
  const ExportOptions& options() const { return options_; }
  // "surfaces: 31 steps x 2 objects in out/surfaces/ (OBJ, every 100 steps, the last at step
  // 3000); series: out/series.csv (3000 steps)"
  std::string summary() const;

 private:
  void write_surfaces(const State& state);
  void fail(const std::string& message);

  const Model& model_;
  std::vector<std::string> sources_;
  ExportOptions options_;
  State surface_state_;  // holds a snapshot's nodes for deformed_surface()
  bool json_ = false;
  std::ofstream series_;
  std::vector<std::vector<double>> json_rows_;
  std::vector<std::string> columns_;
  std::string error_;
  std::uint64_t rows_ = 0, surface_steps_ = 0, last_surface_step_ = 0;
  bool finished_ = false;
};

}  // namespace ffd
