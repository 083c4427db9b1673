#pragma once
// What the report-writing commands (bench, accuracy) share: progress on the terminal, files
// written whole, and generated sections of a Markdown file replaced in place.
#include <cstdint>
#include <filesystem>
#include <string>

namespace ffdsim {

// One line redrawn in place on a terminal; elsewhere (a CI log) a line per phase.
class ProgressBar {
 public:
  ProgressBar(std::string command, bool quiet);
  void operator()(const std::string& what, std::uint64_t done, std::uint64_t total);
  void finish_line(const std::string& text);

 private:
  std::string command_;
  bool quiet_, terminal_;
  std::string last_;
};

void write_file(const std::filesystem::path& path, const std::string& text);  // throws naming the file
std::string read_file(const std::string& path);                               // throws naming the file

// Replaces the text between "<!-- NAME:begin -->" and "<!-- NAME:end -->"; throws naming
// `file` when the markers are missing.
std::string replace_section(const std::string& text, const std::string& file, const std::string& name,
                            const std::string& body);

std::string today();  // YYYY-MM-DD, UTC

}  // namespace ffdsim
