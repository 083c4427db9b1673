#include "ffd/recording.h"

#include "ffd/replay_script.h"

#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace ffd {

namespace {

std::string num(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

std::string vec(const Vec3& v) { return "[" + num(v.x()) + ", " + num(v.y()) + ", " + num(v.z()) + "]"; }

// A TOML basic string of any text: quotes, backslashes and control characters escaped.
std::string toml_string(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
          char escaped[8];
          std::snprintf(escaped, sizeof escaped, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          out += escaped;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

std::string quoted(const std::string& s) { return toml_string(s); }

}  // namespace

namespace {

// One [[event]] block of a command, ending with a blank line.
std::string command_block(const Model& model, const Command& c) {
  std::ostringstream s;
  const double dt_ms = model.settings.dt * 1000.0;
  s << "[[event]]\nat_step = " << c.step << "\n";
  switch (c.kind) {
    case CommandKind::ProbePose: s << "probe = " << vec(c.vector) << "\n"; break;
    case CommandKind::Grab: {
      const Index object = model.cell_object[c.cell];
      s << "grab = { object = " << quoted(model.objects[object].name)
        << ", cell = " << (c.cell - model.objects[object].cell_begin) << ", local = " << vec(c.local) << " }\n";
      break;
    }
    case CommandKind::Drag: s << "drag = " << vec(c.vector) << "\n"; break;
    case CommandKind::Release: s << "release = true\n"; break;
    case CommandKind::SetAlpha: s << "alpha = " << num(c.value) << "\n"; break;
    case CommandKind::SetBeta: s << "beta = " << num(c.value) << "\n"; break;
    case CommandKind::SetGravity: s << "gravity = " << vec(c.vector) << "\n"; break;
    case CommandKind::SetStiffness:
      s << "stiffness = { object = " << quoted(model.objects[c.object].name) << ", value = " << num(c.value) << " }\n";
      break;
    case CommandKind::SetProbeStiffness: s << "probe_stiffness = " << num(c.value) << "\n"; break;
    case CommandKind::SetAccuracy: s << "accuracy = " << static_cast<int>(c.value) << "\n"; break;
    case CommandKind::SetResponse:
      s << "response = \"" << response_name(static_cast<ContactResponse>(static_cast<int>(c.value))) << "\"\n";
      break;
    case CommandKind::Reset: s << "reset = true\n"; break;
    case CommandKind::SetBudget: s << "budget_us = " << num(c.value) << "\n"; break;
    case CommandKind::Pause:
      if (c.value > 0.0) s << "pause_ms = " << num(c.value * dt_ms) << "\n";
      else s << "pause_ms = " << num(dt_ms) << "  # paused until a resume; replays pause one tick\n";
      break;
    case CommandKind::Resume: s << "resume = true\n"; break;
    case CommandKind::SingleStep: s << "single_step = true\n"; break;
    case CommandKind::AutoAccuracy: break;  // never on the applied stream: its SetAccuracy commands are
  }
  s << "\n";
  return s.str();
}

std::string hash_block(std::uint64_t step, std::uint64_t hash) {
  return "[[assert.hash]]\nstep = " + std::to_string(step) + "\nvalue = \"" + hash_hex(hash) + "\"\n\n";
}

}  // namespace

std::string recording_text(const Model& model, const Recording& r) {
  std::ostringstream s;
  s << "# Recorded by ffdsim. Replay with: ffdsim replay THIS_FILE --fast\n"
    << "format = \"ffdsim-replay\"\n"
    << "version = 1\n"
    << "description = \"recorded session: " << r.commands.size() << " commands over " << r.steps << " steps\"\n"
    << "scene = " << quoted(r.scene_path) << "\n"
    << "steps = " << r.steps << "\n\n";
  if (r.hash_every) s << "[record]\nhash_every = " << r.hash_every << "\n\n";
  for (const Command& c : r.commands) s << command_block(model, c);
  for (const auto& [step, hash] : r.hashes) s << hash_block(step, hash);
  return s.str();
}

RecordingStream::RecordingStream(const std::string& path, const Model& model, const std::string& scene_path,
                                 const SceneSpec& spec, std::uint32_t hash_every)
    : path_(path), model_(model) {
  namespace fs = std::filesystem;
  // Paths relative to the recording's folder, so that the folder can be moved as a whole.
  const fs::path folder = fs::absolute(path).parent_path();
  auto stored = [&](const fs::path& file) {
    const fs::path relative = fs::absolute(file).lexically_normal().lexically_relative(folder);
    return (relative.empty() ? fs::absolute(file) : relative).generic_string();
  };
  const std::string scene_text = read_text_file(scene_path, "scene");
  std::ostringstream header;
  header << kStreamedRecordingMarker << ". Replay with: ffdsim replay THIS_FILE --fast\n"
         << "# A run cut off mid-write replays up to its last complete block.\n"
         << "format = \"ffdsim-replay\"\n"
         << "version = 1\n"
         << "description = \"recorded session\"\n"
         << "scene = " << quoted(stored(scene_path)) << "  # relative to this file\n\n"
         << "# What ran: a replay stops before stepping if a file's content differs.\n"
         << "[recorded]\n"
         << "ffdsim = " << quoted(ffdsim_version()) << "\n"
         << "scene = " << quoted(stored(scene_path)) << "\n"
         << "scene_hash = " << quoted(content_hash_of_file(scene_path)) << "\n"
         << "scene_text = " << toml_string(scene_text) << "\n";
  std::vector<std::string> meshes;
  for (const ObjectSpec& object : spec.objects) {
    fs::path mesh(object.source);
    if (mesh.is_relative()) mesh = fs::absolute(scene_path).parent_path() / mesh;
    std::error_code error;
    if (!fs::is_regular_file(mesh, error)) continue;  // a shape ("box") or a glyph, not a mesh file
    const std::string path_stored = stored(mesh);
    if (std::find(meshes.begin(), meshes.end(), path_stored) != meshes.end()) continue;
    meshes.push_back(path_stored);
    header << "\n[[recorded.meshes]]\npath = " << quoted(path_stored)
           << "\nhash = " << quoted(content_hash_of_file(mesh.string())) << "\n";
  }
  header << "\n[record]\nhash_every = " << hash_every << "\n\n";
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) throw std::runtime_error(path + ": cannot write the recording: " + std::strerror(errno));
  pending_commands_ = header.str();
  flush();
}

std::string content_hash_of_file(const std::string& path) {
  std::error_code error;
  // Not a device or a pipe: those could be endless.
  if (!std::filesystem::is_regular_file(path, error)) throw InputError(path + ": not a regular file");
  const std::string bytes = read_text_file(path, "file");
  char digits[24];
  std::snprintf(digits, sizeof digits, "xxh3:%016llx",
                static_cast<unsigned long long>(XXH3_64bits(bytes.data(), bytes.size())));
  return digits;
}

std::string ffdsim_version() { return FFDSIM_VERSION; }

RecordingStream::~RecordingStream() {
  if (file_) std::fclose(file_);
}

void RecordingStream::command(const Command& command) {
  pending_commands_ += command_block(model_, command);
  ++commands_;
}

void RecordingStream::hash(std::uint64_t step, std::uint64_t value) {
  if (step <= last_hash_step_ && hashes_ > 0) return;  // each step once, in order
  pending_hashes_ += hash_block(step, value);
  last_hash_step_ = step;
  ++hashes_;
}

void RecordingStream::flush() {
  // Commands before hashes: a file cut off between the two never holds the hash of a step
  // without the commands that led to it.
  for (std::string* pending : {&pending_commands_, &pending_hashes_}) {
    if (pending->empty()) continue;
    if (std::fwrite(pending->data(), 1, pending->size(), file_) != pending->size())
      throw std::runtime_error(path_ + ": cannot write the recording: " + std::strerror(errno));
    pending->clear();
  }
  if (std::fflush(file_) != 0) throw std::runtime_error(path_ + ": cannot write the recording: " + std::strerror(errno));
}

void write_recording(const std::string& path, const Model& model, const Recording& recording) {
  const std::string text = recording_text(model, recording);
  const std::string temporary = path + ".partial";
  {
    std::ofstream file(temporary, std::ios::binary | std::ios::trunc);
    if (!file) throw std::runtime_error(path + ": cannot write the recording (cannot create " + temporary + ")");
    file << text;
    file.flush();
    if (!file) throw std::runtime_error(path + ": cannot write the recording (write to " + temporary + " failed)");
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) throw std::runtime_error(path + ": cannot write the recording: " + error.message());
}

}  // namespace ffd
