#include "ffd/mesh_import.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <array>
#include <assimp/Importer.hpp>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace ffd {

namespace {

using Triangle = std::array<Index, 3>;

[[noreturn]] void fail(const std::string& path, const std::string& problem) {
  throw MeshImportError(path + ": " + problem);
}

std::string lowercase_extension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

std::string_view trim(std::string_view text) {
  const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!text.empty() && is_space(text.front())) text.remove_prefix(1);
  while (!text.empty() && is_space(text.back())) text.remove_suffix(1);
  return text;
}

// Splits on blanks; views into `line`.
std::vector<std::string_view> tokens_of(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

// assimp's OBJ loader emits one vertex per face corner and discards the file's vertex
// indices; its JoinIdenticalVertices cannot restore them, because it also merges distinct
// file vertices at equal positions (403 on the teapot) and drops unreferenced ones (1,113 on
// bunny.obj). So after assimp has accepted the file, the `v` and `f` records are read here
// to keep the file's own vertex list and indexing, in double precision. Polygons are split
// into fans from their first corner; faces of one or two corners (points, lines) are skipped.
SurfaceMesh read_obj_indexing(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) fail(path, "cannot open the file");
  SurfaceMesh mesh;
  std::string line, record;
  std::size_t line_number = 0, record_line = 0;
  std::vector<Index> corners;
  while (std::getline(file, line)) {
    ++line_number;
    if (record.empty()) record_line = line_number;
    std::string_view view = trim(line);
    // A trailing backslash continues the record on the next line.
    if (!view.empty() && view.back() == '\\') {
      record.append(view.substr(0, view.size() - 1)).push_back(' ');
      continue;
    }
    record.append(view);
    const std::string_view text = trim(std::string_view(record).substr(0, record.find('#')));
    const std::vector<std::string_view> tokens = tokens_of(text);
    const std::string where = "line " + std::to_string(record_line) + ": ";
    if (!tokens.empty() && tokens[0] == "v") {
      if (tokens.size() < 4) fail(path, where + "a vertex needs x, y and z");
      Vec3 position;
      for (int axis = 0; axis < 3; ++axis) {
        const std::string_view number = tokens[static_cast<std::size_t>(axis) + 1];
        const auto [end, error] = std::from_chars(number.data(), number.data() + number.size(), position[axis]);
        if (error != std::errc() || end != number.data() + number.size())
          fail(path, where + "cannot read the vertex coordinate '" + std::string(number) + "'");
        if (!std::isfinite(position[axis]))
          fail(path, where + "vertex " + std::to_string(mesh.vertices.size() + 1) + " has the coordinate '" +
                         std::string(number) + "', which is not a finite number");
      }
      mesh.vertices.push_back(position);
    } else if (!tokens.empty() && tokens[0] == "f") {
      corners.clear();
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        const std::string_view corner = tokens[k].substr(0, tokens[k].find('/'));  // position index of v/vt/vn
        std::int64_t index = 0;
        const auto [end, error] = std::from_chars(corner.data(), corner.data() + corner.size(), index);
        if (error != std::errc() || end != corner.data() + corner.size() || index == 0)
          fail(path, where + "cannot read the face index '" + std::string(tokens[k]) + "'");
        // 1-based; negative indices count back from the latest vertex.
        const std::int64_t resolved = index > 0 ? index - 1 : static_cast<std::int64_t>(mesh.vertices.size()) + index;
        if (resolved < 0 || resolved >= static_cast<std::int64_t>(mesh.vertices.size()))
          fail(path, where + "face index " + std::to_string(index) + " refers to no vertex defined before it");
        corners.push_back(static_cast<Index>(resolved));
      }
      for (std::size_t k = 2; k < corners.size(); ++k)
        mesh.triangles.push_back({corners[0], corners[k - 1], corners[k]});
    }
    record.clear();
  }
  return mesh;
}

// PLY is read here, not by assimp, whose reader trusts the file: it reads past its buffer on a
// malformed header, loops for ever without end_header, and allocates the entries an element or
// a list declares before reading them (2^31 corners for a face of a 300-byte file). The header
// is read strictly (no element may declare more entries than the file has bytes), then the
// body, ASCII or binary of either byte order, value by value. Of the elements, "vertex" gives
// x, y, z and "face" its list "vertex_indices" (or "vertex_index"); others are read past.
// Polygons are split into fans from their first corner; points and lines are skipped.
struct PlyType {
  std::string_view name;
  int bytes;
  bool is_float, is_signed;
};
const PlyType* ply_type(std::string_view name) {
  static constexpr std::array<PlyType, 16> kTypes = {{{"char", 1, false, true},     {"uchar", 1, false, false},
                                                      {"short", 2, false, true},    {"ushort", 2, false, false},
                                                      {"int", 4, false, true},      {"uint", 4, false, false},
                                                      {"float", 4, true, true},     {"double", 8, true, true},
                                                      {"int8", 1, false, true},     {"uint8", 1, false, false},
                                                      {"int16", 2, false, true},    {"uint16", 2, false, false},
                                                      {"int32", 4, false, true},    {"uint32", 4, false, false},
                                                      {"float32", 4, true, true},   {"float64", 8, true, true}}};
  for (const PlyType& type : kTypes)
    if (type.name == name) return &type;
  return nullptr;
}

struct PlyProperty {
  std::string name;
  const PlyType* type;        // of the value, or of each item of a list
  const PlyType* list_count;  // nullptr for a scalar
};
struct PlyElement {
  std::string name;
  std::size_t count;
  std::vector<PlyProperty> properties;
};
enum class PlyFormat { ascii, binary_little_endian, binary_big_endian };

// The values of a PLY body in file order, each read as a double (exact for every PLY type).
class PlyBody {
 public:
  // `body`: the file's bytes after its header, which takes `header_bytes` bytes and ends on
  // line first_line - 1.
  PlyBody(const std::string& path, std::string_view body, std::size_t header_bytes, PlyFormat format,
          std::size_t first_line)
      : path_(path), body_(body), format_(format), line_(first_line), header_bytes_(header_bytes) {}

  double next(const PlyType& type) { return format_ == PlyFormat::ascii ? next_text(type) : next_binary(type); }

  // Where the last value was: a line for ASCII, a byte offset in the file for binary.
  std::string where() const {
    return format_ == PlyFormat::ascii ? "line " + std::to_string(value_line_) + ": "
                                       : "byte " + std::to_string(header_bytes_ + value_offset_) + ": ";
  }

 private:
  double next_text(const PlyType& type) {
    const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
    while (offset_ < body_.size() && is_space(body_[offset_])) line_ += body_[offset_++] == '\n' ? 1 : 0;
    value_line_ = line_;
    if (offset_ == body_.size()) fail(path_, where() + "the file ends before the entries its header declares");
    const std::size_t start = offset_;
    while (offset_ < body_.size() && !is_space(body_[offset_])) ++offset_;
    const std::string_view text = body_.substr(start, offset_ - start);
    const auto parse = [&](auto& value) {
      const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
      if (error != std::errc() || end != text.data() + text.size())
        fail(path_, where() + "cannot read '" + std::string(text) + "' as a PLY " + std::string(type.name));
    };
    if (type.is_float && type.bytes == 4) {
      float value = 0;  // rounded to the declared precision, as a binary file would hold it
      parse(value);
      return value;
    }
    if (type.is_float) {
      double value = 0;
      parse(value);
      return value;
    }
    std::int64_t value = 0;
    parse(value);
    const std::int64_t bits = 8 * type.bytes;
    const std::int64_t low = type.is_signed ? -(std::int64_t{1} << (bits - 1)) : 0;
    const std::int64_t high = type.is_signed ? (std::int64_t{1} << (bits - 1)) - 1 : (std::int64_t{1} << bits) - 1;
    if (value < low || value > high)
      fail(path_, where() + "'" + std::string(text) + "' is out of range for a PLY " + std::string(type.name));
    return static_cast<double>(value);
  }

  double next_binary(const PlyType& type) {
    value_offset_ = offset_;
    const auto size = static_cast<std::size_t>(type.bytes);
    if (body_.size() - offset_ < size) fail(path_, where() + "the file ends before the entries its header declares");
    std::array<unsigned char, 8> raw{};
    std::memcpy(raw.data(), body_.data() + offset_, size);
    offset_ += size;
    const bool file_little = format_ == PlyFormat::binary_little_endian;
    if (file_little != (std::endian::native == std::endian::little)) std::reverse(raw.begin(), raw.begin() + type.bytes);
    const auto as = [&raw]<typename T>(T) {
      T value;
      std::memcpy(&value, raw.data(), sizeof(T));
      return static_cast<double>(value);
    };
    switch (type.bytes) {
      case 1: return type.is_signed ? as(std::int8_t{}) : as(std::uint8_t{});
      case 2: return type.is_signed ? as(std::int16_t{}) : as(std::uint16_t{});
      case 4: return type.is_float ? as(float{}) : type.is_signed ? as(std::int32_t{}) : as(std::uint32_t{});
      default: return as(double{});
    }
  }

  const std::string& path_;
  std::string_view body_;
  PlyFormat format_;
  std::size_t offset_ = 0, line_, value_line_ = 0, value_offset_ = 0, header_bytes_ = 0;
};

SurfaceMesh read_ply(const std::string& path, std::uintmax_t file_bytes) {
  std::ifstream file(path, std::ios::binary);
  if (!file) fail(path, "cannot open the file");
  std::string bytes(static_cast<std::size_t>(file_bytes), '\0');
  if (!file.read(bytes.data(), static_cast<std::streamsize>(bytes.size())))
    fail(path, "cannot read the file's " + std::to_string(file_bytes) + " bytes");

  // The header: "ply", "format ...", then element and property lines, up to "end_header".
  std::size_t offset = 0, line_number = 0;
  std::string_view line;
  const auto next_line = [&]() {
    if (offset >= bytes.size()) return false;
    const std::size_t end = std::min(bytes.find('\n', offset), bytes.size());
    line = std::string_view(bytes).substr(offset, end - offset);
    offset = end + 1;
    ++line_number;
    return true;
  };
  const auto lower = [](char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); };
  if (!next_line() || trim(line).size() != 3 || lower(trim(line)[0]) != 'p' || lower(trim(line)[1]) != 'l' ||
      lower(trim(line)[2]) != 'y')
    fail(path, "cannot read the mesh: the file does not start with the PLY magic number 'ply'");
  std::optional<PlyFormat> format;
  std::vector<PlyElement> elements;
  constexpr std::size_t kMaxHeaderLine = 4096;
  bool header_ended = false;
  while (!header_ended && next_line()) {
    const std::string where = "line " + std::to_string(line_number) + " of the PLY header: ";
    if (line.size() > kMaxHeaderLine) fail(path, where + "the line is too long");
    const std::vector<std::string_view> tokens = tokens_of(trim(line));
    if (tokens.empty() || tokens[0] == "comment" || tokens[0] == "obj_info") continue;
    if (tokens[0] == "end_header") {
      if (tokens.size() != 1 || !format) fail(path, where + "end_header before a format line, or with words after it");
      header_ended = true;
    } else if (tokens[0] == "format") {
      if (tokens.size() != 3 || format) fail(path, where + "expected one 'format ascii|binary_little_endian|binary_big_endian 1.0'");
      if (tokens[1] == "ascii") format = PlyFormat::ascii;
      else if (tokens[1] == "binary_little_endian") format = PlyFormat::binary_little_endian;
      else if (tokens[1] == "binary_big_endian") format = PlyFormat::binary_big_endian;
      else fail(path, where + "expected one 'format ascii|binary_little_endian|binary_big_endian 1.0'");
    } else if (tokens[0] == "element") {
      if (tokens.size() != 3) fail(path, where + "expected 'element NAME COUNT'");
      std::uintmax_t count = 0;
      const std::string_view text = tokens[2];
      const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), count);
      if (end != text.data() + text.size() || (error != std::errc() && error != std::errc::result_out_of_range))
        fail(path, where + "the count of element '" + std::string(tokens[1]) + "' is not a whole number");
      if (error == std::errc::result_out_of_range || count > file_bytes)
        fail(path, where + "element '" + std::string(tokens[1]) + "' declares " + std::string(text) +
                       " entries, more than a file of " + std::to_string(file_bytes) + " bytes holds");
      elements.push_back({std::string(tokens[1]), static_cast<std::size_t>(count), {}});
    } else if (tokens[0] == "property") {
      const bool list = tokens.size() == 5 && tokens[1] == "list" && ply_type(tokens[2]) && ply_type(tokens[3]) &&
                        !ply_type(tokens[2])->is_float;
      const bool scalar = tokens.size() == 3 && ply_type(tokens[1]);
      if (elements.empty() || !(list || scalar))
        fail(path, where + "expected 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME' after an element");
      elements.back().properties.push_back(list ? PlyProperty{std::string(tokens[4]), ply_type(tokens[3]), ply_type(tokens[2])}
                                                : PlyProperty{std::string(tokens[2]), ply_type(tokens[1]), nullptr});
    } else {
      fail(path, where + "unknown header line '" + std::string(tokens[0]) + "'");
    }
  }
  if (!header_ended) fail(path, "cannot read the mesh: the PLY header has no end_header line");

  // Which properties carry the mesh.
  std::size_t vertex_count = 0;
  for (const PlyElement& element : elements) {
    if (element.name != "vertex") continue;
    for (const char* axis : {"x", "y", "z"}) {
      const auto property = std::find_if(element.properties.begin(), element.properties.end(),
                                         [&](const PlyProperty& p) { return p.name == axis; });
      if (property == element.properties.end() || property->list_count)
        fail(path, std::string("the PLY element 'vertex' has no scalar property '") + axis + "'");
    }
    vertex_count = element.count;
  }
  if (vertex_count > kMaxMeshVertices)
    fail(path, "the file has " + std::to_string(vertex_count) + " vertices, more than the limit of " +
                   std::to_string(kMaxMeshVertices));

  const std::size_t header_bytes = std::min(offset, bytes.size());
  PlyBody body(path, std::string_view(bytes).substr(header_bytes), header_bytes, *format, line_number + 1);
  SurfaceMesh mesh;
  mesh.vertices.reserve(vertex_count);
  std::vector<Index> corners;
  std::size_t face_number = 0;
  for (const PlyElement& element : elements) {
    const bool is_vertex = element.name == "vertex", is_face = element.name == "face";
    for (std::size_t entry = 0; entry < element.count; ++entry) {
      Vec3 position = Vec3::Zero();
      corners.clear();
      for (const PlyProperty& property : element.properties) {
        if (!property.list_count) {
          const double value = body.next(*property.type);
          if (is_vertex && property.name.size() == 1 && property.name[0] >= 'x' && property.name[0] <= 'z') {
            if (!std::isfinite(value))
              fail(path, body.where() + "vertex " + std::to_string(entry + 1) + " has a " + property.name +
                             " that is not a finite number");
            position[property.name[0] - 'x'] = value;
          }
          continue;
        }
        const bool is_corners = is_face && (property.name == "vertex_indices" || property.name == "vertex_index");
        const auto count = static_cast<std::int64_t>(body.next(*property.list_count));  // an integer type
        if (count < 0) fail(path, body.where() + "a list of " + std::to_string(count) + " items");
        // Nothing is reserved for the count: one the file does not hold fails at the file's end.
        for (std::int64_t item = 0; item < count; ++item) {
          const double index = body.next(*property.type);
          if (!is_corners) continue;
          if (!(index >= 0 && index < static_cast<double>(vertex_count) && index == std::floor(index))) {
            std::array<char, 32> text{};
            const auto printed = std::to_chars(text.data(), text.data() + text.size(), index);
            fail(path, body.where() + "face " + std::to_string(face_number) + " refers to vertex " +
                           std::string(text.data(), printed.ptr) + " of a mesh with " + std::to_string(vertex_count) +
                           " vertices");
          }
          corners.push_back(static_cast<Index>(index));
        }
      }
      if (is_vertex) mesh.vertices.push_back(position);
      if (!is_face) continue;
      if (mesh.triangles.size() + (corners.size() >= 3 ? corners.size() - 2 : 0) > kMaxMeshTriangles)
        fail(path, body.where() + "more than the limit of " + std::to_string(kMaxMeshTriangles) + " triangles");
      for (std::size_t k = 2; k < corners.size(); ++k) mesh.triangles.push_back({corners[0], corners[k - 1], corners[k]});
      ++face_number;
    }
  }
  if (mesh.triangles.empty()) fail(path, "the file has no triangles (only points, lines or nothing)");
  return mesh;
}

// OFF is read here, not by assimp, whose OFF reader reads out of bounds on malformed faces:
// an optional keyword line ("OFF", or with the prefixes ST, C, N for texture coordinates,
// colours and normals on each vertex line, which are ignored), then "VERTICES FACES EDGES",
// VERTICES lines "x y z ...", FACES lines "n i1 ... in ..." (indices from 0; polygons split
// into fans from their first corner, points and lines skipped). '#' starts a comment.
SurfaceMesh read_off(const std::string& path, std::uintmax_t file_bytes) {
  std::ifstream file(path, std::ios::binary);
  if (!file) fail(path, "cannot open the file");
  std::string line;
  std::size_t line_number = 0;
  // The next line with something on it, as tokens; empty at the end of the file.
  const auto next_tokens = [&]() {
    while (std::getline(file, line)) {
      ++line_number;
      std::vector<std::string_view> tokens = tokens_of(trim(std::string_view(line).substr(0, line.find('#'))));
      if (!tokens.empty()) return tokens;
    }
    return std::vector<std::string_view>{};
  };
  const auto where = [&]() { return "line " + std::to_string(line_number) + ": "; };
  const auto count = [&](std::string_view text, const std::string& what) {
    std::uintmax_t n = 0;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), n);
    if (error == std::errc::result_out_of_range || (error == std::errc() && end == text.data() + text.size() && n > file_bytes))
      fail(path, where() + "the header declares " + std::string(text) + " " + what + ", more than a file of " +
                     std::to_string(file_bytes) + " bytes holds");
    if (error != std::errc() || end != text.data() + text.size())
      fail(path, where() + "cannot read the count of " + what + " '" + std::string(text) + "'");
    return static_cast<std::size_t>(n);
  };

  std::vector<std::string_view> tokens = next_tokens();
  if (!tokens.empty() && tokens[0].ends_with("OFF")) {
    const std::string_view prefix = tokens[0].substr(0, tokens[0].size() - 3);
    if (prefix.find_first_not_of("STCN") != std::string_view::npos)
      fail(path, where() + "unsupported OFF variant '" + std::string(tokens[0]) + "' (only 3D vertices are read)");
    if (tokens.size() == 1) tokens = next_tokens();
    else tokens.erase(tokens.begin());  // the counts may follow on the keyword's line
  }
  if (tokens.size() < 2) fail(path, where() + "expected the counts 'VERTICES FACES EDGES'");
  const std::size_t vertex_count = count(tokens[0], "vertices");
  const std::size_t face_count = count(tokens[1], "faces");
  if (vertex_count > kMaxMeshVertices)
    fail(path, where() + std::to_string(vertex_count) + " vertices, more than the limit of " +
                   std::to_string(kMaxMeshVertices));

  SurfaceMesh mesh;
  mesh.vertices.reserve(vertex_count);
  for (std::size_t v = 0; v < vertex_count; ++v) {
    tokens = next_tokens();
    if (tokens.size() < 3) fail(path, where() + "expected vertex " + std::to_string(v) + " as x y z");
    Vec3 position;
    for (int axis = 0; axis < 3; ++axis) {
      const std::string_view number = tokens[static_cast<std::size_t>(axis)];
      const auto [end, error] = std::from_chars(number.data(), number.data() + number.size(), position[axis]);
      if (error != std::errc() || end != number.data() + number.size())
        fail(path, where() + "cannot read the vertex coordinate '" + std::string(number) + "'");
      if (!std::isfinite(position[axis]))
        fail(path, where() + "vertex " + std::to_string(v + 1) + " has the coordinate '" + std::string(number) +
                       "', which is not a finite number");
    }
    mesh.vertices.push_back(position);
  }
  std::vector<Index> corners;
  for (std::size_t f = 0; f < face_count; ++f) {
    tokens = next_tokens();
    std::size_t n = 0;
    const std::string_view head = tokens.empty() ? std::string_view() : tokens[0];
    const auto [end, error] = std::from_chars(head.data(), head.data() + head.size(), n);
    if (tokens.empty() || error != std::errc() || end != head.data() + head.size() || n == 0 || n > tokens.size() - 1)
      fail(path, where() + "expected face " + std::to_string(f) + " as 'n i1 ... in'");
    corners.clear();
    for (std::size_t k = 1; k <= n; ++k) {
      std::size_t index = 0;
      const auto [index_end, index_error] = std::from_chars(tokens[k].data(), tokens[k].data() + tokens[k].size(), index);
      if (index_error != std::errc() || index_end != tokens[k].data() + tokens[k].size() || index >= vertex_count)
        fail(path, where() + "face " + std::to_string(f) + ": '" + std::string(tokens[k]) + "' is not a vertex index below " +
                       std::to_string(vertex_count));
      corners.push_back(static_cast<Index>(index));
    }
    if (mesh.triangles.size() + (n >= 3 ? n - 2 : 0) > kMaxMeshTriangles)
      fail(path, where() + "more than the limit of " + std::to_string(kMaxMeshTriangles) + " triangles");
    for (std::size_t k = 2; k < corners.size(); ++k) mesh.triangles.push_back({corners[0], corners[k - 1], corners[k]});
  }
  if (mesh.triangles.empty()) fail(path, "the file has no triangles (only points, lines or nothing)");
  return mesh;
}

// What assimp's post-processing relies on, checked on the reader's output; each mesh's
// primitive types are set from its faces (a reader may claim polygons it did not make). Also
// the size limits, with polygons counted as the triangles they become.
void check_structure(const std::string& path, const aiScene& scene) {
  if (scene.mNumMeshes > 0 && scene.mMeshes == nullptr) fail(path, "cannot read the mesh: no mesh data");
  std::size_t vertex_total = 0, triangle_total = 0;
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    aiMesh* part = scene.mMeshes[m];
    if (part == nullptr || (part->mNumVertices > 0 && part->mVertices == nullptr) ||
        (part->mNumFaces > 0 && part->mFaces == nullptr))
      fail(path, "cannot read the mesh: mesh " + std::to_string(m) + " lacks its vertices or faces");
    vertex_total += part->mNumVertices;
    unsigned types = 0;
    for (unsigned f = 0; f < part->mNumFaces; ++f) {
      const aiFace& face = part->mFaces[f];
      if (face.mNumIndices == 0 || face.mIndices == nullptr)
        fail(path, "face " + std::to_string(f) + " of mesh " + std::to_string(m) + " has no corners");
      for (unsigned k = 0; k < face.mNumIndices; ++k) {
        if (face.mIndices[k] >= part->mNumVertices)
          fail(path, "face " + std::to_string(f) + " refers to vertex " + std::to_string(face.mIndices[k]) +
                         " of a mesh with " + std::to_string(part->mNumVertices) + " vertices");
      }
      types |= face.mNumIndices == 1   ? aiPrimitiveType_POINT
               : face.mNumIndices == 2 ? aiPrimitiveType_LINE
               : face.mNumIndices == 3 ? aiPrimitiveType_TRIANGLE
                                       : aiPrimitiveType_POLYGON;
      triangle_total += face.mNumIndices >= 3 ? face.mNumIndices - 2 : 0;
    }
    part->mPrimitiveTypes = types;
  }
  if (vertex_total > kMaxMeshVertices)
    fail(path, "the file has " + std::to_string(vertex_total) + " vertices, more than the limit of " +
                   std::to_string(kMaxMeshVertices));
  if (triangle_total > kMaxMeshTriangles)
    fail(path, "the file has " + std::to_string(triangle_total) + " triangles, more than the limit of " +
                   std::to_string(kMaxMeshTriangles));
  // Pre-transforming walks the node graph: every mesh a node names must exist.
  std::vector<const aiNode*> nodes;
  if (scene.mRootNode != nullptr) nodes.push_back(scene.mRootNode);
  for (std::size_t visited = 0; !nodes.empty(); ++visited) {
    if (visited > kMaxMeshVertices) fail(path, "cannot read the mesh: its node graph does not end");
    const aiNode* node = nodes.back();
    nodes.pop_back();
    for (unsigned i = 0; i < node->mNumMeshes; ++i)
      if (node->mMeshes == nullptr || node->mMeshes[i] >= scene.mNumMeshes)
        fail(path, "cannot read the mesh: a node names a mesh that does not exist");
    for (unsigned i = 0; i < node->mNumChildren; ++i) {
      if (node->mChildren == nullptr || node->mChildren[i] == nullptr)
        fail(path, "cannot read the mesh: a node has a missing child");
      nodes.push_back(node->mChildren[i]);
    }
  }
}

}  // namespace

SurfaceMesh import_mesh(const std::string& path) {
  std::error_code status_error;
  const auto status = std::filesystem::status(path, status_error);
  if (!std::filesystem::exists(status)) fail(path, "file not found");
  if (!std::filesystem::is_regular_file(status)) fail(path, "not a regular file");
  std::error_code size_error;
  const std::uintmax_t file_bytes = std::filesystem::file_size(path, size_error);
  if (size_error) fail(path, "cannot read the file size: " + size_error.message());
  if (file_bytes > kMaxMeshFileBytes) {
    fail(path, "the file has " + std::to_string(file_bytes) + " bytes, more than the limit of " +
                   std::to_string(kMaxMeshFileBytes) + " (1 GiB)");
  }
  const std::string extension = lowercase_extension(path);
  if (extension == ".off") return read_off(path, file_bytes);
  if (extension == ".ply") return read_ply(path, file_bytes);

  // No clean-up steps: no JoinIdenticalVertices (it welds with its own epsilon and drops
  // unreferenced vertices), no FindDegenerates, no validation fixes. clean_mesh() does the
  // clean-up and reports it. The file is read without post-processing first: assimp's steps
  // trust what its readers made (a face's indices, a mesh's primitive types) and abort or
  // read out of bounds where a malformed file made it wrong, so that is checked in between.
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, 0);
  if (scene == nullptr) fail(path, std::string("cannot read the mesh: ") + importer.GetErrorString());
  check_structure(path, *scene);
  scene = importer.ApplyPostProcessing(aiProcess_Triangulate | aiProcess_PreTransformVertices);
  if (scene == nullptr) fail(path, std::string("cannot read the mesh: ") + importer.GetErrorString());

  SurfaceMesh mesh;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh& part = *scene->mMeshes[m];
    const bool has_triangles = std::any_of(part.mFaces, part.mFaces + part.mNumFaces,
                                           [](const aiFace& face) { return face.mNumIndices == 3; });
    if (!has_triangles) continue;  // points or lines only
    const auto base = mesh.vertices.size();
    for (unsigned v = 0; v < part.mNumVertices; ++v) {
      const aiVector3D& p = part.mVertices[v];
      mesh.vertices.emplace_back(static_cast<double>(p.x), static_cast<double>(p.y), static_cast<double>(p.z));
      // A format without lines (binary STL): the vertex as the file counts them, from 1.
      if (!is_finite(mesh.vertices.back()) && extension != ".obj")
        fail(path, "vertex " + std::to_string(mesh.vertices.size()) + " (counting from 1) is not finite");
    }
    for (unsigned f = 0; f < part.mNumFaces; ++f) {
      const aiFace& face = part.mFaces[f];
      if (face.mNumIndices != 3) continue;
      Triangle triangle{};
      for (int k = 0; k < 3; ++k) {
        if (face.mIndices[k] >= part.mNumVertices)
          fail(path, "face " + std::to_string(f) + " refers to vertex " + std::to_string(face.mIndices[k]) +
                         " of a mesh with " + std::to_string(part.mNumVertices) + " vertices");
        triangle[static_cast<std::size_t>(k)] = static_cast<Index>(base + face.mIndices[k]);
      }
      mesh.triangles.push_back(triangle);
    }
  }
  if (mesh.triangles.empty()) fail(path, "the file has no triangles (only points, lines or nothing)");

  if (extension == ".obj") {
    SurfaceMesh indexed = read_obj_indexing(path);
    // Both readers must see the same faces; a mismatch means an OBJ feature the record
    // reader does not know, and its indexing would be wrong.
    if (indexed.triangles.size() != mesh.triangles.size())
      fail(path, "the OBJ face records give " + std::to_string(indexed.triangles.size()) +
                     " triangles, but assimp read " + std::to_string(mesh.triangles.size()));
    return indexed;
  }
  return mesh;
}

}  // namespace ffd
