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

namespace {
std::string recorded_command_line = "ffdsim";

// The first line a shell command prints, or "" when it fails (no git, not a checkout).
std::string first_line_of(const std::string& command) {
  std::FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return "";
  std::string text;
  char buffer[512];
  while (std::fgets(buffer, sizeof buffer, pipe)) text += buffer;
  if (pclose(pipe) != 0) return "";
  return text.substr(0, text.find('\n'));
}

std::string shell_quoted(const std::string& word) {
  std::string quoted = "'";
  for (char c : word) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

// The commit the results page's checkout is at, "+ changes" when tracked files other than
// the results pages themselves (and the JSON written beside them) differ from it (a page made
// from uncommitted code says so).
std::string commit_of(const std::filesystem::path& folder) {
  const std::string git = "git -C " + shell_quoted(folder.string());
  const std::string commit = first_line_of(git + " rev-parse --short=12 HEAD 2>/dev/null");
  if (commit.empty()) return "unknown (not a git checkout)";
  const std::string prefix = first_line_of(git + " rev-parse --show-prefix 2>/dev/null");
  const std::string changes = first_line_of(git + " status --porcelain --untracked-files=no -- ':/' ':(exclude,top)" +
                                            prefix + "*.md' ':(exclude,top)" + prefix + "*.png' ':(exclude,top)" + prefix +
                                            "*.json' 2>/dev/null | head -1");
  return changes.empty() ? commit : commit + " with uncommitted changes";
}
}  // namespace

void set_command_line(int argc, char** argv) {
  recorded_command_line = "ffdsim";
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    const bool plain = word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_./=:,") ==
                       std::string::npos;
    recorded_command_line += " " + (plain && !word.empty() ? word : shell_quoted(word));
  }
}

void check_results_page(const std::string& file) {
  const std::filesystem::path path(file);
  const std::filesystem::path folder = path.has_parent_path() ? path.parent_path() : ".";
  if (!std::filesystem::is_directory(folder)) throw std::runtime_error(file + ": cannot write: no folder " + folder.string());
  std::filesystem::path probe = path;
  probe += ".partial";
  std::ofstream out(probe);
  const bool writable = static_cast<bool>(out);
  out.close();
  std::error_code ignored;
  std::filesystem::remove(probe, ignored);
  if (!writable) throw std::runtime_error(file + ": cannot write");
}

void write_results_page(const std::string& file, const std::string& title, const std::string& cpu,
                        const std::string& body) {
  const std::filesystem::path path(file);
  const std::string stamp = "- Command: `" + recorded_command_line + "`\n- Commit: " +
                            commit_of(path.has_parent_path() ? path.parent_path() : ".") + "\n- Machine: " + cpu +
                            "\n- Date: " + today() + "\n";
  write_file(path, "# " + title + "\n\n<!-- Written by ffdsim; run the command below again to update it. -->\n\n" + stamp +
                       "\n" + body);
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
