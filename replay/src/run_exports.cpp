#include "ffd/run_exports.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "ffd/measure.h"
#include "ffd/toml_reader.h"

namespace ffd {

SurfaceFormat parse_surface_format(const std::string& text) {
  if (text == "obj") return SurfaceFormat::Obj;
  if (text == "ply") return SurfaceFormat::Ply;
  throw std::invalid_argument("unknown surface format '" + text + "' (obj or ply)");
}

namespace {

const char* extension(SurfaceFormat format) { return format == SurfaceFormat::Ply ? ".ply" : ".obj"; }

void write_obj(std::ofstream& out, const SurfaceMesh& mesh) {
  out.precision(9);
  for (const Vec3& v : mesh.vertices) out << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
  for (const auto& t : mesh.triangles) out << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
}

template <typename T>
void put(std::ofstream& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // little-endian host (x86-64, AArch64), as the header says
  out.write(bytes, sizeof(T));
}

void write_ply(std::ofstream& out, const SurfaceMesh& mesh, const std::string& comment) {
  out << "ply\nformat binary_little_endian 1.0\n" << comment << "element vertex " << mesh.vertices.size()
      << "\nproperty double x\nproperty double y\nproperty double z\nelement face " << mesh.triangles.size()
      << "\nproperty list uchar uint vertex_indices\nend_header\n";
  for (const Vec3& v : mesh.vertices) {
    put(out, v.x());
    put(out, v.y());
    put(out, v.z());
  }
  for (const auto& t : mesh.triangles) {
    put(out, std::uint8_t{3});
    for (Index i : t) put(out, static_cast<std::uint32_t>(i));
  }
}

}  // namespace

void write_surface(const std::filesystem::path& path, const SurfaceMesh& mesh, SurfaceFormat format,
                   const std::string& source) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path.string() + ": cannot write");
  const bool glyph = source.find(".ttf U+") != std::string::npos;
  const std::string notice = "An extruded glyph of " + source + ". The font's copyright and permission notice";
  const std::string licence = "(Bitstream Vera licence) applies: see scenarios/meshes/DejaVu-LICENSE.txt in ffdsim.";
  if (format == SurfaceFormat::Obj) {
    if (glyph) out << "# " << notice << "\n# " << licence << '\n';
    write_obj(out, mesh);
  } else {
    write_ply(out, mesh, glyph ? "comment " + notice + "\ncomment " + licence + "\n" : "");
  }
  if (!out) throw std::runtime_error(path.string() + ": write failed");
}

RunExports::RunExports(const Model& model, const State& initial, std::vector<std::string> sources, ExportOptions options)
    : model_(model), sources_(std::move(sources)), options_(std::move(options)), surface_state_(initial) {
  if (options_.surfaces_every > 0) {
    std::error_code ec;
    std::filesystem::create_directories(options_.surfaces_dir, ec);
    if (ec) throw InputError(options_.surfaces_dir + ": cannot create folder: " + ec.message());
  }
  if (!options_.series_path.empty()) {
    const std::filesystem::path path(options_.series_path);
    const std::string ext = path.extension().string();
    if (ext != ".csv" && ext != ".json")
      throw InputError(options_.series_path + ": the time series is written as .csv or .json; name the file so");
    json_ = ext == ".json";
    std::error_code ec;
    if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
    series_.open(path, std::ios::trunc);
    if (!series_) throw InputError(options_.series_path + ": cannot write the time series");
    columns_ = {"step",          "time_s",         "compute_us",     "lateness_us",  "deadline_met",
                "energy_j",      "kinetic_j",      "max_speed_m_s",  "rms_speed_m_s", "contacts",
                "max_penetration_m", "probe_force_n", "grab_force_n", "accuracy_level"};
    for (Stage s : model_.pipeline) columns_.push_back(std::string(stage_name(s)) + "_us");
    if (!json_) {
      for (std::size_t c = 0; c < columns_.size(); ++c) series_ << (c ? "," : "") << columns_[c];
      series_ << '\n';
    }
  }
  if (options_.surfaces_every > 0) write_surfaces(initial);
}

void RunExports::fail(const std::string& message) {
  if (error_.empty()) error_ = message;
}

void RunExports::write_surfaces(const State& state) {
  if (!error_.empty()) return;
  char step[32];
  std::snprintf(step, sizeof step, "%06llu", static_cast<unsigned long long>(state.step));
  try {
    for (Index i = 0; i < model_.objects.size(); ++i)
      write_surface(std::filesystem::path(options_.surfaces_dir) /
                        (model_.objects[i].name + "_" + step + extension(options_.surface_format)),
                    deformed_surface(model_, state, i), options_.surface_format, i < sources_.size() ? sources_[i] : "");
    ++surface_steps_;
    last_surface_step_ = state.step;
  } catch (const std::exception& e) {
    fail(e.what());
  }
}

void RunExports::snapshot(std::uint64_t step, const std::vector<Vec3>& nodes) {
  if (options_.surfaces_every == 0 || step % options_.surfaces_every != 0 || step == 0) return;
  std::copy(nodes.begin(), nodes.end(), surface_state_.x.begin());
  surface_state_.step = step;
  write_surfaces(surface_state_);
}

void RunExports::telemetry(const Telemetry& t) {
  if (options_.series_path.empty() || !error_.empty()) return;
  const double nan = std::nan("");
  std::vector<double> row = {static_cast<double>(t.step),
                             static_cast<double>(t.step) * model_.settings.dt,
                             static_cast<double>(t.compute_ns) * 1e-3,
                             static_cast<double>(t.lateness_ns) * 1e-3,
                             t.deadline_met ? 1.0 : 0.0,
                             t.has_energy ? t.energy_j : nan,
                             t.kinetic_energy_j,
                             t.max_speed_m_s,
                             t.rms_speed_m_s,
                             static_cast<double>(t.contacts),
                             t.max_penetration_m,
                             t.probe_force_n.norm(),
                             t.grab_force_n.norm(),
                             static_cast<double>(static_cast<int>(t.accuracy))};
  for (Stage s : model_.pipeline) {
    const std::int64_t ns = t.stage_ns[static_cast<std::size_t>(s)];
    row.push_back(ns < 0 ? nan : static_cast<double>(ns) * 1e-3);
  }
  ++rows_;
  if (json_) {
    json_rows_.push_back(std::move(row));
    return;
  }
  char number[32];
  for (std::size_t c = 0; c < row.size(); ++c) {
    if (c) series_ << ',';
    if (std::isnan(row[c])) continue;  // an empty field: not measured this step
    std::snprintf(number, sizeof number, "%.9g", row[c]);
    series_ << number;
  }
  series_ << '\n';
  if (!series_) fail(options_.series_path + ": write failed");
}

std::string RunExports::summary() const {
  std::string text;
  if (options_.surfaces_every > 0)
    text += "surfaces: " + std::to_string(surface_steps_) + " steps x " + std::to_string(model_.objects.size()) +
            " objects in " + options_.surfaces_dir + "/ (" + (options_.surface_format == SurfaceFormat::Ply ? "PLY" : "OBJ") +
            ", every " + std::to_string(options_.surfaces_every) + " steps, the last at step " +
            std::to_string(last_surface_step_) + ")";
  if (!options_.series_path.empty())
    text += std::string(text.empty() ? "" : "; ") + "series: " + options_.series_path + " (" + std::to_string(rows_) +
            " steps)";
  return text;
}

void RunExports::finish() {
  if (finished_) return;
  finished_ = true;
  if (options_.series_path.empty()) return;
  if (json_ && error_.empty()) {
    nlohmann::json columns = nlohmann::json::object();  // NaN (not measured) is written as null
    for (std::size_t c = 0; c < columns_.size(); ++c) {
      nlohmann::json values = nlohmann::json::array();
      for (const std::vector<double>& row : json_rows_) values.push_back(row[c]);
      columns[columns_[c]] = std::move(values);
    }
    series_ << nlohmann::json{{"dt_s", model_.settings.dt}, {"steps", rows_}, {"series", std::move(columns)}}.dump() << '\n';
  }
  series_.close();
  if (series_.fail()) fail(options_.series_path + ": write failed");
}

}  // namespace ffd
