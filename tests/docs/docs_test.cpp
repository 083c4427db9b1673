// The documents hold to the program: every relative link and #anchor in README.md, CHANGELOG.md
// and docs/ resolves (and every docs link in a source comment); every scene key the loader
// reads is in the scene format reference and every key the reference names is read; every
// command and option of `ffdsim --help` is in the command-line reference and every option
// the reference's usage lines name is accepted; the README stays short and starts with its
// two commands (CI runs the second).
#include <catch2/catch.hpp>
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "ffd/scene_loader.h"
#include "support/run_ffdsim.h"

namespace {

namespace fs = std::filesystem;
const fs::path kRoot = fs::path(FFDSIM_SCENARIO_DIR).parent_path();

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = text.find('\n', start);
    lines.push_back(text.substr(start, end == std::string::npos ? std::string::npos : end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return lines;
}

// The Markdown outside fenced code blocks, with inline code spans blanked out.
std::vector<std::string> prose_lines(const std::string& text) {
  std::vector<std::string> out;
  bool fenced = false;
  for (std::string line : lines_of(text)) {
    if (line.rfind("```", 0) == 0) {
      fenced = !fenced;
      out.emplace_back();
      continue;
    }
    if (fenced) {
      out.emplace_back();
      continue;
    }
    out.push_back(std::regex_replace(line, std::regex("`[^`]*`"), "``"));
  }
  return out;
}

// GitHub's anchor of a heading: lower case, punctuation dropped (letters, digits, '_', '-'
// and spaces kept, non-ASCII letters too), spaces to '-', "-1", "-2" ... for repeats.
std::set<std::string> anchors_of(const std::string& text) {
  std::set<std::string> anchors;
  std::map<std::string, int> seen;
  bool fenced = false;
  for (const std::string& line : lines_of(text)) {
    if (line.rfind("```", 0) == 0) fenced = !fenced;
    std::smatch m;
    if (fenced || !std::regex_match(line, m, std::regex("^#{1,6} (.*)$"))) continue;
    std::string slug;
    for (const char c : m[1].str()) {
      const auto u = static_cast<unsigned char>(c);
      if (u >= 0x80 || std::isalnum(u) || c == '_' || c == '-') slug += static_cast<char>(u < 0x80 ? std::tolower(u) : c);
      else if (c == ' ') slug += '-';
    }
    const int n = seen[slug]++;
    anchors.insert(n == 0 ? slug : slug + "-" + std::to_string(n));
  }
  return anchors;
}

std::vector<fs::path> markdown_files() {
  std::vector<fs::path> files = {kRoot / "README.md", kRoot / "CHANGELOG.md"};
  for (const auto& entry : fs::recursive_directory_iterator(kRoot / "docs"))
    if (entry.path().extension() == ".md") files.push_back(entry.path());
  return files;
}

// "what is wrong" for a link target seen from `from`, or "" when it resolves.
std::string check_target(const fs::path& from, const std::string& target) {
  const std::size_t hash = target.find('#');
  const std::string path = target.substr(0, hash), anchor = hash == std::string::npos ? "" : target.substr(hash + 1);
  const fs::path file = path.empty() ? from : (from.parent_path() / path).lexically_normal();
  if (!fs::exists(file)) return "no file " + file.string();
  if (anchor.empty()) return "";
  if (file.extension() != ".md") return "an anchor into a file that is not Markdown";
  if (!anchors_of(test::read_text(file)).count(anchor)) return "no heading with anchor #" + anchor + " in " + file.string();
  return "";
}

}  // namespace

TEST_CASE("Docs: every relative link and #anchor in README.md, CHANGELOG.md and docs/ resolves", "[docs]") {
  std::size_t links = 0;
  for (const fs::path& file : markdown_files()) {
    const std::vector<std::string> lines = prose_lines(test::read_text(file));
    for (std::size_t i = 0; i < lines.size(); ++i) {
      const std::regex link(R"(\]\(([^)\s]+)\))");
      for (auto it = std::sregex_iterator(lines[i].begin(), lines[i].end(), link); it != std::sregex_iterator(); ++it) {
        const std::string target = (*it)[1];
        if (target.find("://") != std::string::npos || target.rfind("mailto:", 0) == 0) continue;
        ++links;
        const std::string problem = check_target(file, target);
        INFO(file.string() << ":" << i + 1 << ": (" << target << ")");
        CHECK(problem == "");
      }
    }
  }
  CHECK(links > 50);  // the docs do link to each other
}

TEST_CASE("Docs: every docs/ link in a source comment resolves", "[docs]") {
  std::size_t links = 0;
  for (const char* folder : {"runtime", "ui", "replay", "scenarios", "tests"}) {
    for (const auto& entry : fs::recursive_directory_iterator(kRoot / folder)) {
      const std::string ext = entry.path().extension().string();
      if (ext != ".cpp" && ext != ".h" && ext != ".c" && ext != ".py") continue;
      const std::vector<std::string> lines = lines_of(test::read_text(entry.path()));
      for (std::size_t i = 0; i < lines.size(); ++i) {
        const std::regex link(R"(docs/[A-Za-z0-9_./-]+\.md(#[a-z0-9_-]+)?)");
        for (auto it = std::sregex_iterator(lines[i].begin(), lines[i].end(), link); it != std::sregex_iterator(); ++it) {
          ++links;
          INFO(entry.path().string() << ":" << i + 1 << ": " << it->str());
          CHECK(check_target(kRoot / "README.md", it->str()) == "");
        }
      }
    }
  }
  CHECK(links > 10);
}

TEST_CASE("Docs: the scene format reference names every key the loader reads, and only those", "[docs]") {
  const std::string reference = test::read_text(kRoot / "docs" / "scene-format.md");
  std::set<std::string> read;  // as the reference writes them: probe.radius, layout.grid, stiffness ...
  for (const auto& [table, keys] : ffd::scene_keys()) {
    for (const std::string& key : keys) {
      std::string written = key;
      if (table == "probe" || table == "grab") written = table + "." + key;
      if (table == "group.layout") written = "layout." + key;
      if (table == "group.random") written = "random." + key;
      read.insert(written);
      // A key that holds a table is written as its table ([object.mass_spring]) or by its
      // keys (`layout.grid`).
      const bool named = reference.find("`" + written + "`") != std::string::npos ||
                         reference.find("[object." + key + "]") != std::string::npos ||
                         reference.find("`" + key + ".") != std::string::npos;
      INFO("[" << table << "] " << key << ": written as `" << written << "`");
      CHECK(named);
    }
  }
  // Every key in the first column of a reference table is read by the loader.
  std::size_t rows = 0;
  for (const std::string& line : lines_of(reference)) {
    std::smatch m;
    if (!std::regex_search(line, m, std::regex(R"(^\| `([a-z_.]+)` \|)"))) continue;
    ++rows;
    INFO(line.substr(0, 80));
    CHECK(read.count(m[1].str()) == 1);
  }
  CHECK(rows > 40);
}

TEST_CASE("Docs: the command-line reference names every command and option, and only real ones", "[docs]") {
  const std::string reference = test::read_text(kRoot / "docs" / "command-line.md");
  const std::string readme = test::read_text(kRoot / "README.md");
  const test::ProgramResult top = test::run_ffdsim("--help");
  REQUIRE(top.exit_code == 0);
  const std::string subcommands = top.output.substr(top.output.find("Subcommands:"));
  std::vector<std::string> commands;
  const std::regex command_line(R"(\n  ([a-z-]+) )");
  for (auto it = std::sregex_iterator(subcommands.begin(), subcommands.end(), command_line); it != std::sregex_iterator(); ++it)
    commands.push_back((*it)[1]);
  REQUIRE(commands.size() >= 8);
  for (const std::string& command : commands) {
    INFO("ffdsim " << command);
    CHECK(reference.find("ffdsim " + command) != std::string::npos);
    CHECK(readme.find("ffdsim " + command) != std::string::npos);  // the README's tour
    const test::ProgramResult help = test::run_ffdsim(command + " --help");
    REQUIRE(help.exit_code == 0);
    // A command with commands of its own (`ffdsim sweep plan`, ...): their options too.
    std::string helps = help.output;
    if (const std::size_t own = help.output.find("Subcommands:"); own != std::string::npos) {
      const std::string list = help.output.substr(own);
      for (auto it = std::sregex_iterator(list.begin(), list.end(), command_line); it != std::sregex_iterator(); ++it) {
        const test::ProgramResult sub = test::run_ffdsim(command + " " + std::string((*it)[1]) + " --help");
        REQUIRE(sub.exit_code == 0);
        CHECK(reference.find("ffdsim " + command + " " + std::string((*it)[1])) != std::string::npos);
        helps += sub.output;
      }
    }
    std::set<std::string> accepted;
    const std::regex option(R"((--[a-z][a-z0-9-]*))");
    for (auto it = std::sregex_iterator(helps.begin(), helps.end(), option); it != std::sregex_iterator(); ++it)
      accepted.insert((*it)[1]);
    for (const std::string& o : accepted) {
      if (o == "--help") continue;
      INFO("option " << o << " of ffdsim " << command);
      CHECK(reference.find(o) != std::string::npos);
    }
    // The usage block of the command: every option it names is accepted.
    const std::size_t usage = reference.find("\nffdsim " + command + " ");
    REQUIRE(usage != std::string::npos);
    const std::string block = reference.substr(usage, reference.find("```", usage) - usage);
    for (auto it = std::sregex_iterator(block.begin(), block.end(), option); it != std::sregex_iterator(); ++it) {
      INFO("usage of ffdsim " << command << " names " << (*it)[1]);
      CHECK(accepted.count((*it)[1]) == 1);
    }
  }
}

TEST_CASE("Docs: the README is at most 400 lines and starts with its two commands", "[docs]") {
  const std::string readme = test::read_text(kRoot / "README.md");
  CHECK(lines_of(readme).size() <= 401);  // 400 lines and the final newline
  // The first code block holds exactly two commands: the main job, then the tests (.ci/run
  // runs the second).
  const std::size_t open = readme.find("```");
  REQUIRE(open != std::string::npos);
  const std::size_t body = readme.find('\n', open) + 1;
  const std::vector<std::string> commands = lines_of(readme.substr(body, readme.find("```", body) - body - 1));
  REQUIRE(commands.size() == 2);
  CHECK_THAT(commands[0], Catch::StartsWith("./setup.sh && ") && Catch::Contains("ffdsim run"));
  CHECK_THAT(commands[1], Catch::StartsWith("./setup.sh && ") && Catch::Contains("ctest"));
}
