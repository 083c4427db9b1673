#pragma once
// What the report-writing commands (bench, accuracy) share: progress on the terminal, files
// written whole, and generated sections of a Markdown file replaced in place.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace ffdsim {

// One line redrawn in place on a terminal (a bar, the rate and the time left in the current
// phase, at most 10 redraws a second); elsewhere (a CI log) a line per phase, or nothing
// with `lines_off_terminal` false. A terminal under CI (the CI variable set) counts as elsewhere.
class ProgressBar {
 public:
  ProgressBar(std::string command, bool quiet, bool lines_off_terminal = true);
  void operator()(const std::string& what, std::uint64_t done, std::uint64_t total);
  void finish_line(const std::string& text);
  void clear();  // removes the bar from the terminal's line

 private:
  using Clock = std::chrono::steady_clock;
  std::string command_;
  bool quiet_, terminal_, lines_off_terminal_;
  std::string last_;
  Clock::time_point phase_start_{}, last_draw_{};
  std::uint64_t phase_start_done_ = 0;
  bool drawn_ = false;
};

// Writes through a temporary file beside it, renamed over it: a run cut short leaves the old
// file whole. Throws naming the file.
void write_file(const std::filesystem::path& path, const std::string& text);
std::string read_file(const std::string& path);                               // throws naming the file

// Replaces the text between "<!-- NAME:begin -->" and "<!-- NAME:end -->"; throws naming
// `file` when the markers are missing.
std::string replace_section(const std::string& text, const std::string& file, const std::string& name,
                            const std::string& body);

// `--update-readme`: check_sections() before a long run (a wrong path or a missing marker fails
// at once), update_sections() after it, on the file as it is then, so that edits made to it
// while the run went on are kept. Each pair: a section's name and its new body.
using Sections = std::vector<std::pair<std::string, std::string>>;
void check_sections(const std::string& file, const std::vector<std::string>& names);
void update_sections(const std::string& file, const Sections& sections);

std::string today();                              // YYYY-MM-DD, UTC
std::string duration_text(double seconds);        // "4.2 s", "12 s", "3 min 05 s", "1 h 02 min"

}  // namespace ffdsim
