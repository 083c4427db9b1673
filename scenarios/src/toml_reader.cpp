#include "ffd/toml_reader.h"

#include <charconv>
#include <filesystem>
#include <fstream>

namespace ffd {

std::string format_number(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

std::string in_quotes(std::string_view text) { return "'" + std::string(text) + "'"; }

std::string describe_type(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a floating-point number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::date: return "a date";
    case toml::node_type::time: return "a time";
    case toml::node_type::date_time: return "a date-time";
    default: return "nothing";
  }
}

// Optimal string alignment distance: a transposed pair ("nmae") counts as one edit,
// which is the commonest typo in key names.
namespace {
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[a.size()][b.size()];
}

}  // namespace

// The closest candidate within a couple of edits, else one the word is a prefix of or
// extends ("rotation" for "rotation_deg"), else nothing: no candidate is a plausible intent.
std::optional<std::string_view> closest_match(std::string_view word,
                                              const std::vector<std::string_view>& candidates) {
  const std::size_t budget = word.size() >= 6 ? 2 : 1;
  std::optional<std::string_view> best;
  std::size_t best_distance = budget + 1;
  for (const std::string_view candidate : candidates) {
    const std::size_t distance = edit_distance(word, candidate);
    if (distance < best_distance) {
      best_distance = distance;
      best = candidate;
    }
  }
  if (best) return best;
  constexpr std::size_t kMinPrefix = 4;  // shorter prefixes match too much to be a hint
  for (const std::string_view candidate : candidates) {
    if (std::min(word.size(), candidate.size()) < kMinPrefix) continue;
    if (candidate.starts_with(word) || word.starts_with(candidate)) return candidate;
  }
  return std::nullopt;
}

std::string join(const std::vector<std::string_view>& words) {
  std::string out;
  for (const std::string_view word : words) {
    if (!out.empty()) out += ", ";
    out += word;
  }
  return out;
}

std::vector<const toml::table*> array_of_tables(const TableReader& root, std::string_view key) {
  std::vector<const toml::table*> tables;
  const toml::node* node = root.find(key);
  if (!node) return tables;
  const auto* array = node->as_array();
  if (!array) {
    root.fail_at(key,
                 "expected an array of tables; write [[" + std::string(key) + "]] with double brackets");
  }
  for (std::size_t i = 0; i < array->size(); ++i) {
    const toml::node& element = *array->get(i);
    const auto* table = element.as_table();
    if (!table) {
      root.fail(element.source(), std::string(key) + "[" + std::to_string(i) + "]",
                "expected a table (got " + describe_type(element) + ")");
    }
    tables.push_back(table);
  }
  return tables;
}

toml::table parse_toml(const std::string& text, const std::string& origin) {
  try {
    return toml::parse(text, std::string_view(origin));
  } catch (const toml::parse_error& e) {
    std::ostringstream message;
    message << origin << ':' << e.source().begin.line << ':' << e.source().begin.column
            << ": TOML syntax error: " << e.description();
    throw InputError(message.str());
  }
}

std::string read_text_file(const std::string& path, const std::string& what) {
  std::error_code error;
  std::ifstream file(path, std::ios::binary);
  // A folder opens as a stream on Linux but cannot be read.
  if (!file || std::filesystem::is_directory(path, error)) throw InputError(path + ": cannot open " + what);
  std::ostringstream text;
  text << file.rdbuf();
  if (file.bad()) throw InputError(path + ": cannot read " + what);
  return text.str();
}

}  // namespace ffd
