#pragma once
// Strict reading of TOML input (scenes, replay scripts): unknown keys, wrong types, wrong
// lengths and out-of-range values are errors naming FILE:LINE:COL and the dotted field,
// with a "did you mean" where a near key exists. Shared by the scene and replay loaders.
#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "ffd/types.h"

namespace ffd {

// Bad user input: the message names the file, the place and the problem.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline constexpr double kInf = std::numeric_limits<double>::infinity();

// Shortest text that reads back as the same double.
std::string format_number(double value);
std::string in_quotes(std::string_view text);
// "a table", "an integer", ... for messages.
std::string describe_type(const toml::node& node);
// The candidate a misspelt word most plausibly meant, if any.
std::optional<std::string_view> closest_match(std::string_view word, const std::vector<std::string_view>& candidates);
std::string join(const std::vector<std::string_view>& words);

// Parses TOML text; a syntax error becomes an InputError "origin:line:col: TOML syntax error: ...".
toml::table parse_toml(const std::string& text, const std::string& origin);
// Reads a whole file; InputError "path: cannot open ..." naming `what` ("scene file").
std::string read_text_file(const std::string& path, const std::string& what);

// An allowed interval for a number; "in (0, 0.01]", "> 0", ">= 0" in messages.
struct Bounds {
  double low = -kInf;
  double high = kInf;
  bool low_open = false;
  bool high_open = false;

  bool contains(double v) const {
    const bool above = low_open ? v > low : v >= low;
    const bool below = high_open ? v < high : v <= high;
    return above && below;
  }
  std::string describe() const {
    if (high == kInf) return std::string(low_open ? "> " : ">= ") + format_number(low);
    if (low == -kInf) return std::string(high_open ? "< " : "<= ") + format_number(high);
    return "in " + std::string(low_open ? "(" : "[") + format_number(low) + ", " + format_number(high) +
           (high_open ? ")" : "]");
  }
};
constexpr Bounds kAnyValue{};
constexpr Bounds kPositive{0.0, kInf, true, false};
constexpr Bounds kNonNegative{0.0, kInf, false, false};
constexpr Bounds kUnitInterval{0.0, 1.0, false, false};

// One TOML table being read: knows its dotted path for messages, rejects keys it does
// not know as soon as it is opened, and reads typed, range-checked values.
class TableReader {
 public:
  // `misplaced_hint` may say where an unknown key belongs instead ("... goes in [simulation]").
  TableReader(const std::string& origin, const toml::table& table, std::string path,
              std::vector<std::string_view> known_keys,
              const std::function<std::string(std::string_view)>& misplaced_hint = {})
      : origin_(origin), table_(table), path_(std::move(path)), known_keys_(std::move(known_keys)) {
    reject_unknown_keys(misplaced_hint);
  }

  const toml::table& table() const { return table_; }
  const std::string& path() const { return path_; }
  std::string field(std::string_view key) const {
    return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
  }
  const toml::node* find(std::string_view key) const { return table_.get(key); }
  bool has(std::string_view key) const { return find(key) != nullptr; }

  [[noreturn]] void fail(const toml::source_region& where, const std::string& field,
                         const std::string& problem) const {
    std::ostringstream message;
    message << origin_ << ':' << where.begin.line << ':' << where.begin.column << ": " << field << ": "
            << problem;
    throw InputError(message.str());
  }
  // At the value of `key` (which must be present).
  [[noreturn]] void fail_at(std::string_view key, const std::string& problem) const {
    fail(find(key)->source(), field(key), problem);
  }
  // At the table itself: for what is missing from it.
  [[noreturn]] void fail_here(const std::string& field_name, const std::string& problem) const {
    fail(table_.source(), field_name, problem);
  }
  [[noreturn]] void fail_missing(std::string_view key, const std::string& why = "") const {
    fail_here(field(key), "missing required key" + why);
  }

  double number(std::string_view key, double fallback, const Bounds& bounds) const {
    const toml::node* node = find(key);
    return node ? to_number(*node, field(key), bounds) : fallback;
  }
  double required_number(std::string_view key, const Bounds& bounds, const std::string& why = "") const {
    if (!has(key)) fail_missing(key, why);
    return number(key, 0.0, bounds);
  }

  std::int64_t integer(std::string_view key, std::int64_t fallback, std::int64_t low,
                       std::int64_t high) const {
    const toml::node* node = find(key);
    if (!node) return fallback;
    const auto* value = node->as_integer();
    if (!value) fail_at(key, "expected an integer (got " + describe_type(*node) + ")");
    const std::int64_t v = value->get();
    if (v < low || v > high) {
      const std::string range = high == std::numeric_limits<std::int64_t>::max()
                                    ? ">= " + std::to_string(low)
                                    : "in [" + std::to_string(low) + ", " + std::to_string(high) + "]";
      fail_at(key, "must be " + range + " (got " + std::to_string(v) + ")");
    }
    return v;
  }

  // A file format's header: `format` (optional, must be `name` when given) and `version`
  // (required, must be `version`).
  void check_format(std::string_view name, std::int64_t version) const {
    if (const auto given = string("format"); given && *given != name)
      fail_at("format", "expected \"" + std::string(name) + "\" (got " + in_quotes(*given) + ")");
    const std::string reads = "this program reads version " + std::to_string(version);
    if (!has("version")) fail_missing("version", " (" + reads + ")");
    const std::int64_t given = integer("version", 0, 1, std::numeric_limits<std::int64_t>::max());
    if (given != version) fail_at("version", "unsupported version " + std::to_string(given) + "; " + reads);
  }

  bool boolean(std::string_view key, bool fallback) const {
    const toml::node* node = find(key);
    if (!node) return fallback;
    const auto* value = node->as_boolean();
    if (!value) fail_at(key, "expected true or false (got " + describe_type(*node) + ")");
    return value->get();
  }

  std::optional<std::string> string(std::string_view key) const {
    const toml::node* node = find(key);
    if (!node) return std::nullopt;
    const auto* value = node->as_string();
    if (!value) fail_at(key, "expected a string (got " + describe_type(*node) + ")");
    if (value->get().empty()) fail_at(key, "must not be empty");
    return value->get();
  }

  Vec3 vec3(std::string_view key, const Vec3& fallback, const Bounds& bounds = kAnyValue) const {
    const toml::node* node = find(key);
    return node ? to_vec3(*node, field(key), bounds) : fallback;
  }

  const toml::table* subtable(std::string_view key) const {
    const toml::node* node = find(key);
    if (!node) return nullptr;
    const auto* table = node->as_table();
    if (!table) fail_at(key, "expected a table (got " + describe_type(*node) + ")");
    return table;
  }

  double to_number(const toml::node& node, const std::string& field_name, const Bounds& bounds) const {
    double v = 0.0;
    if (const auto* integer = node.as_integer()) {
      v = static_cast<double>(integer->get());
    } else if (const auto* floating = node.as_floating_point()) {
      v = floating->get();
    } else {
      fail(node.source(), field_name, "expected a number (got " + describe_type(node) + ")");
    }
    // Checked before any comparison: comparing a NaN raises FE_INVALID.
    if (!std::isfinite(v)) fail(node.source(), field_name, "must be finite (got " + format_number(v) + ")");
    if (!bounds.contains(v)) {
      fail(node.source(), field_name, "must be " + bounds.describe() + " (got " + format_number(v) + ")");
    }
    return v;
  }

  Vec3 to_vec3(const toml::node& node, const std::string& field_name, const Bounds& bounds) const {
    const auto* array = node.as_array();
    if (!array)
      fail(node.source(), field_name, "expected an array [x, y, z] (got " + describe_type(node) + ")");
    if (array->size() != 3) {
      fail(node.source(), field_name,
           "expected 3 numbers [x, y, z] (got " + std::to_string(array->size()) + ")");
    }
    Vec3 v;
    for (int i = 0; i < 3; ++i) {
      v[i] = to_number(*array->get(static_cast<std::size_t>(i)), field_name + "[" + std::to_string(i) + "]",
                       bounds);
    }
    return v;
  }

 private:
  void reject_unknown_keys(const std::function<std::string(std::string_view)>& misplaced_hint) const {
    // The earliest unknown key in the file, not the first in the table's sorted order.
    const toml::key* first_unknown = nullptr;
    for (auto&& [key, value] : table_) {
      (void)value;
      if (std::find(known_keys_.begin(), known_keys_.end(), key.str()) != known_keys_.end()) continue;
      const auto& here = key.source().begin;
      if (!first_unknown || here.line < first_unknown->source().begin.line ||
          (here.line == first_unknown->source().begin.line &&
           here.column < first_unknown->source().begin.column)) {
        first_unknown = &key;
      }
    }
    if (!first_unknown) return;
    const std::string_view name = first_unknown->str();
    std::string problem = "unknown key " + in_quotes(name);
    if (const auto suggestion = closest_match(name, known_keys_)) {
      problem += "; did you mean " + in_quotes(*suggestion) + "?";
    } else if (std::string hint = misplaced_hint ? misplaced_hint(name) : ""; !hint.empty()) {
      problem += "; " + hint;
    } else {
      problem += " (valid keys: " + join(known_keys_) + ")";
    }
    fail(first_unknown->source(), field(name), problem);
  }

  const std::string& origin_;
  const toml::table& table_;
  std::string path_;
  std::vector<std::string_view> known_keys_;
};


// `[[key]]` in `root`: an array whose every element is a table (empty when absent).
std::vector<const toml::table*> array_of_tables(const TableReader& root, std::string_view key);

}  // namespace ffd
