#include "ffd/recording.h"

#include <cstdio>
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

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

std::string recording_text(const Model& model, const Recording& r) {
  std::ostringstream s;
  const double dt_ms = model.settings.dt * 1000.0;
  s << "# Recorded by ffdsim run. Replay with: ffdsim replay THIS_FILE --fast\n"
    << "format = \"ffdsim-replay\"\n"
    << "version = 1\n"
    << "description = \"recorded session: " << r.commands.size() << " commands over " << r.steps << " steps\"\n"
    << "scene = " << quoted(r.scene_path) << "\n"
    << "steps = " << r.steps << "\n\n";
  if (r.hash_every) s << "[record]\nhash_every = " << r.hash_every << "\n\n";
  for (const Command& c : r.commands) {
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
  }
  for (const auto& [step, hash] : r.hashes) {
    s << "[[assert.hash]]\nstep = " << step << "\nvalue = \"" << hash_hex(hash) << "\"\n\n";
  }
  return s.str();
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
