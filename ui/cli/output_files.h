#pragma once
// What the report-writing commands (bench, accuracy, piles, hard-cases) share: progress on the
// terminal, files written whole, and results pages stamped with how they were made.
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

// `--update-docs FILE`: a results page (docs/results/*.md), the table as the tool printed it
// under a stamp that says how it was made: the command line, the commit (and whether the
// checkout had changes beside the results pages), the machine and the date. The docs cite the
// page; nobody types its figures in.
void set_command_line(int argc, char** argv);  // main() records it for the stamp
// Before a long run: the page's folder exists and a file can be written there (fails at once,
// naming the file, rather than after minutes of measuring).
void check_results_page(const std::string& file);
void write_results_page(const std::string& file, const std::string& title, const std::string& cpu,
                        const std::string& body);

std::string today();                              // YYYY-MM-DD, UTC
std::string duration_text(double seconds);        // "4.2 s", "12 s", "3 min 05 s", "1 h 02 min"

}  // namespace ffdsim
