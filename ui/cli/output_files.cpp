#include "output_files.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace ffdsim {

ProgressBar::ProgressBar(std::string command, bool quiet, bool lines_off_terminal)
    : command_(std::move(command)),
      quiet_(quiet),
      terminal_(isatty(STDERR_FILENO) == 1 && std::getenv("CI") == nullptr),
      lines_off_terminal_(lines_off_terminal) {}


void ProgressBar::operator()(const std::string& what, std::uint64_t done, std::uint64_t total) {
  if (quiet_) return;
  if (!terminal_) {
    if (what != last_ && lines_off_terminal_)
      std::fprintf(stderr, "%s: %s (%llu steps)\n", command_.c_str(), what.c_str(), static_cast<unsigned long long>(total));
    last_ = what;
    return;
  }
  const Clock::time_point now = Clock::now();
  if (what != last_ || !drawn_) {
    phase_start_ = now;
    phase_start_done_ = done;
  } else if (done < total && now - last_draw_ < std::chrono::milliseconds(100)) {
    return;
  }
  constexpr int kWidth = 30;
  const double fraction = total ? static_cast<double>(done) / static_cast<double>(total) : 1.0;
  const int filled = static_cast<int>(fraction * kWidth);
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.resize(kWidth, '.');
  std::string pace;  // once there is something to go on
  const double seconds = std::chrono::duration<double>(now - phase_start_).count();
  if (done > phase_start_done_ && seconds > 0.0) {
    const double rate = static_cast<double>(done - phase_start_done_) / seconds;
    char text[64];
    std::snprintf(text, sizeof text, "  %.0f steps/s", rate);
    pace = text;
    if (done < total) pace += ", " + duration_text(static_cast<double>(total - done) / rate) + " left";
  }
  std::fprintf(stderr, "\r\033[K%-28s [%s] %3d%%  %llu/%llu%s", what.c_str(), bar.c_str(), static_cast<int>(fraction * 100.0),
               static_cast<unsigned long long>(done), static_cast<unsigned long long>(total), pace.c_str());
  std::fflush(stderr);
  last_ = what;
  last_draw_ = now;
  drawn_ = true;
}

void ProgressBar::finish_line(const std::string& text) {
  if (quiet_) return;
  std::fprintf(stderr, terminal_ ? "\r\033[K%s\n" : "%s\n", text.c_str());
}

void ProgressBar::clear() {
  if (quiet_ || !terminal_ || !drawn_) return;
  std::fprintf(stderr, "\r\033[K");
  std::fflush(stderr);
  drawn_ = false;
}

void write_file(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::path temporary = path;
  temporary += ".partial";
  {
    std::ofstream out(temporary);
    out << text;
    out.flush();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(temporary, ignored);
      throw std::runtime_error(path.string() + ": cannot write");
    }
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) {
    std::error_code ignored;  // the rename's error is the one to report
    std::filesystem::remove(temporary, ignored);
    throw std::runtime_error(path.string() + ": cannot write (" + error.message() + ")");
  }
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot read");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string replace_section(const std::string& text, const std::string& file, const std::string& name,
                            const std::string& body) {
  const std::string begin = "<!-- " + name + ":begin -->", end = "<!-- " + name + ":end -->";
  const std::size_t b = text.find(begin), e = text.find(end);
  if (b == std::string::npos || e == std::string::npos || e < b)
    throw std::runtime_error(file + ": no section " + begin + " ... " + end + " to replace");
  return text.substr(0, b + begin.size()) + "\n" + body + text.substr(e);
}

void check_sections(const std::string& file, const std::vector<std::string>& names) {
  std::string text = read_file(file);
  for (const std::string& name : names) text = replace_section(text, file, name, "");
}

void update_sections(const std::string& file, const Sections& sections) {
  std::string text = read_file(file);
  for (const auto& [name, body] : sections) text = replace_section(text, file, name, body);
  write_file(file, text);
}

std::string duration_text(double seconds) {
  char text[32];
  if (seconds < 10.0) std::snprintf(text, sizeof text, "%.1f s", seconds);
  else if (seconds < 60.0) std::snprintf(text, sizeof text, "%.0f s", seconds);
  else if (seconds < 3600.0) std::snprintf(text, sizeof text, "%.0f min %02.0f s", std::floor(seconds / 60.0), std::fmod(seconds, 60.0));
  else std::snprintf(text, sizeof text, "%.0f h %02.0f min", std::floor(seconds / 3600.0), std::fmod(seconds / 60.0, 60.0));
  return text;
}

std::string today() {
  const std::time_t now = std::time(nullptr);
  char buffer[32];
  std::strftime(buffer, sizeof buffer, "%Y-%m-%d", std::gmtime(&now));
  return buffer;
}

}  // namespace ffdsim
