#include "ffd/glyph_mesh.h"

#include <ft2build.h>
#include FT_FREETYPE_H
#include FT_OUTLINE_H
#include <GL/glu.h>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <initializer_list>
#include <limits>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace ffd {

namespace {

using Point = Eigen::Vector2d;  // font units until the very end
using Triangle = std::array<Index, 3>;

// A bad scene must not make the mesher allocate without bound: ~180 times the samples of
// a capital at the spacing of the paper's alphabet.
constexpr std::size_t kMaxSamples = 200'000;
// Curves are flattened into pieces this many times shorter than the sample spacing, so the
// even resampling follows the curve, not a coarse polygon.
constexpr double kPiecesPerSpacing = 8.0;

// "U+0041 ('A')"; code points with nothing to show (controls, surrogates, private use,
// noncharacters, beyond Unicode) only as "U+XXXX".
std::string character_name(char32_t c) {
  char code[16];
  std::snprintf(code, sizeof code, "U+%04X", static_cast<unsigned>(c));
  std::string name = code;
  const bool control = c < 0x20 || (c >= 0x7F && c < 0xA0);
  const bool surrogate_or_private = (c >= 0xD800 && c < 0xF900) || c >= 0xF0000;
  const bool noncharacter = (c >= 0xFDD0 && c < 0xFDF0) || (c & 0xFFFE) == 0xFFFE;
  if (control || surrogate_or_private || noncharacter || c > 0x10FFFF) return name;
  std::string utf8;
  if (c < 0x80) {
    utf8 += static_cast<char>(c);
  } else if (c < 0x800) {
    utf8 += static_cast<char>(0xC0 | (c >> 6));
    utf8 += static_cast<char>(0x80 | (c & 0x3F));
  } else if (c < 0x10000) {
    utf8 += static_cast<char>(0xE0 | (c >> 12));
    utf8 += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
    utf8 += static_cast<char>(0x80 | (c & 0x3F));
  } else {
    utf8 += static_cast<char>(0xF0 | (c >> 18));
    utf8 += static_cast<char>(0x80 | ((c >> 12) & 0x3F));
    utf8 += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
    utf8 += static_cast<char>(0x80 | (c & 0x3F));
  }
  return name + " ('" + utf8 + "')";
}

std::string format(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

// FreeType's own wording of an error code (its error-string option is off in most builds).
const char* freetype_error_text(FT_Error error) {
#undef FTERRORS_H_
#define FT_ERROR_START_LIST switch (error) {
#define FT_ERRORDEF(e, v, s) \
  case v:                    \
    return s;
#define FT_ERROR_END_LIST }
#include FT_ERRORS_H
  return "unknown error";
}

struct LibraryDeleter {
  void operator()(FT_Library library) const { FT_Done_FreeType(library); }
};
struct FaceDeleter {
  void operator()(FT_Face face) const { FT_Done_Face(face); }
};
struct TessDeleter {
  void operator()(GLUtesselator* tess) const { gluDeleteTess(tess); }
};
using LibraryPtr = std::unique_ptr<FT_LibraryRec_, LibraryDeleter>;
using FacePtr = std::unique_ptr<FT_FaceRec_, FaceDeleter>;
using TessPtr = std::unique_ptr<GLUtesselator, TessDeleter>;

// ---------------------------------------------------------------------------------------
// Outline: contours of lines and Bézier curves, as FreeType decomposes them.

struct Segment {
  int degree = 1;                 // 1 line, 2 conic (quadratic), 3 cubic
  std::array<Point, 4> control;   // control[0] is the start, control[degree] the end

  double control_polygon_length() const {
    double length = 0.0;
    for (int i = 0; i < degree; ++i) length += (control[i + 1] - control[i]).norm();
    return length;  // an upper bound of the arc length
  }
  Point at(double t) const {
    const double s = 1.0 - t;
    if (degree == 1) return s * control[0] + t * control[1];
    if (degree == 2) return s * s * control[0] + 2.0 * s * t * control[1] + t * t * control[2];
    return s * s * s * control[0] + 3.0 * s * s * t * control[1] + 3.0 * s * t * t * control[2] +
           t * t * t * control[3];
  }
};

using RawContour = std::vector<Segment>;

struct Decomposition {
  std::vector<RawContour> contours;
  Point pen{0.0, 0.0};
};

Point to_point(const FT_Vector* v) { return Point(static_cast<double>(v->x), static_cast<double>(v->y)); }

// FreeType calls these from C: no exception may leave them (a non-zero result stops it).
int add_segment(Decomposition& d, int degree, std::initializer_list<const FT_Vector*> points) noexcept {
  try {
    if (d.contours.empty()) return 1;  // a segment before any move_to
    Segment segment;
    segment.degree = degree;
    segment.control[0] = d.pen;
    int i = 1;
    for (const FT_Vector* p : points) segment.control[static_cast<std::size_t>(i++)] = to_point(p);
    d.pen = segment.control[static_cast<std::size_t>(degree)];
    d.contours.back().push_back(segment);
    return 0;
  } catch (...) {
    return 1;
  }
}
int on_move_to(const FT_Vector* to, void* user) noexcept {
  try {
    auto& d = *static_cast<Decomposition*>(user);
    d.contours.emplace_back();
    d.pen = to_point(to);
    return 0;
  } catch (...) {
    return 1;
  }
}
int on_line_to(const FT_Vector* to, void* user) noexcept {
  return add_segment(*static_cast<Decomposition*>(user), 1, {to});
}
int on_conic_to(const FT_Vector* control, const FT_Vector* to, void* user) noexcept {
  return add_segment(*static_cast<Decomposition*>(user), 2, {control, to});
}
int on_cubic_to(const FT_Vector* control1, const FT_Vector* control2, const FT_Vector* to, void* user) noexcept {
  return add_segment(*static_cast<Decomposition*>(user), 3, {control1, control2, to});
}

// The closed polyline of a contour: curves cut into pieces of at most `piece` font units,
// repeated points dropped, the closing point (= the first) not repeated.
std::vector<Point> flatten(const RawContour& contour, double piece) {
  std::vector<Point> points;
  if (contour.empty()) return points;
  points.push_back(contour.front().control[0]);
  auto append = [&](const Point& p) {
    if (p != points.back()) points.push_back(p);
  };
  for (const Segment& segment : contour) {
    const int pieces =
        segment.degree == 1 ? 1 : std::max(1, static_cast<int>(std::ceil(segment.control_polygon_length() / piece)));
    for (int j = 1; j < pieces; ++j) append(segment.at(static_cast<double>(j) / pieces));
    append(segment.control[static_cast<std::size_t>(segment.degree)]);  // exact end point
  }
  while (points.size() > 1 && points.back() == points.front()) points.pop_back();
  return points;
}

double perimeter(const std::vector<Point>& polygon) {
  double length = 0.0;
  for (std::size_t i = 0; i < polygon.size(); ++i) length += (polygon[(i + 1) % polygon.size()] - polygon[i]).norm();
  return length;
}

double signed_area(const std::vector<Point>& polygon) {
  double twice = 0.0;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const Point& a = polygon[i];
    const Point& b = polygon[(i + 1) % polygon.size()];
    twice += a.x() * b.y() - b.x() * a.y();
  }
  return 0.5 * twice;
}

// `count` points at even arc-length steps around the closed polyline, the first at its start.
std::vector<Point> resample(const std::vector<Point>& polygon, double length, std::size_t count) {
  std::vector<Point> samples;
  samples.reserve(count);
  std::size_t edge = 0;
  double edge_start = 0.0;  // arc length at polygon[edge]
  for (std::size_t i = 0; i < count; ++i) {
    const double s = length * static_cast<double>(i) / static_cast<double>(count);
    const Point* a = &polygon[edge];
    const Point* b = &polygon[(edge + 1) % polygon.size()];
    double edge_length = (*b - *a).norm();
    while (edge + 1 < polygon.size() && edge_start + edge_length < s) {
      edge_start += edge_length;
      ++edge;
      a = b;
      b = &polygon[(edge + 1) % polygon.size()];
      edge_length = (*b - *a).norm();
    }
    const double t = std::clamp((s - edge_start) / edge_length, 0.0, 1.0);  // edges have length > 0
    samples.push_back(*a + t * (*b - *a));
  }
  return samples;
}

// ---------------------------------------------------------------------------------------
// Caps: the GLU tessellator triangulates the contours as one polygon with holes.

struct TessOutput {
  std::vector<Index> corners;  // 3 per triangle; capacity reserved up front
  bool not_triangles = false;  // a fan or strip: the edge-flag callback should prevent them
  bool overflow = false;       // more corners than a polygon with holes can have
  bool combine = false;        // the tessellator wanted a new vertex (contours cross or touch)
  GLenum error = 0;
};

// Called from C: they record problems instead of throwing.
void tess_begin(GLenum type, void* user) {
  if (type != GL_TRIANGLES) static_cast<TessOutput*>(user)->not_triangles = true;
}
void tess_vertex(void* vertex, void* user) {
  auto& out = *static_cast<TessOutput*>(user);
  if (out.corners.size() == out.corners.capacity()) {
    out.overflow = true;
    return;
  }
  out.corners.push_back(*static_cast<const Index*>(vertex));
}
void tess_edge_flag(GLboolean, void*) {}  // registered only so that GLU emits GL_TRIANGLES
void tess_combine(GLdouble[3], void* data[4], GLfloat[4], void** out_data, void* user) {
  // A new vertex would sit inside a cap with no wall to join (the surface would not close):
  // refuse it. data[0] is always an existing vertex and keeps the tessellator consistent.
  static_cast<TessOutput*>(user)->combine = true;
  *out_data = data[0];
}
void tess_error(GLenum error, void* user) {
  auto& out = *static_cast<TessOutput*>(user);
  if (out.error == 0) out.error = error;
}

template <typename F>
_GLUfuncptr glu_callback(F* function) {
  return reinterpret_cast<_GLUfuncptr>(function);
}

double orient(const Point& a, const Point& b, const Point& c) {
  const Point u = b - a, v = c - a;
  return u.x() * v.y() - u.y() * v.x();
}

// Positive and not zero up to rounding: the same bound clean_mesh uses for zero area, with
// a margin (corner angle above ~1e-12 rad).
bool is_proper_ccw(const Point& a, const Point& b, const Point& c) {
  const double bound = 4096.0 * std::numeric_limits<double>::epsilon();
  return orient(a, b, c) > bound * (b - a).norm() * (c - a).norm();
}

// Angle at `apex` of the triangle (apex, a, b), in [0, pi]; pi for a flat triangle with the
// apex between a and b.
double corner_angle(const Point& apex, const Point& a, const Point& b) {
  const Point u = a - apex, v = b - apex;
  return std::atan2(std::abs(u.x() * v.y() - u.y() * v.x()), u.dot(v));
}

std::uint64_t edge_key(Index a, Index b) { return (std::uint64_t{a} << 32) | b; }

// Edge flips on a cap's triangulation (contour edges never flip, no vertex is added). GLU's
// monotone sweep leaves zero-area triangles where samples are collinear (straight strokes;
// clean_mesh would drop them and open the surface) and long fans whose edges cross the
// whole letter (an embedded surface bends only at its vertices).
class CapFlipper {
 public:
  CapFlipper(const std::vector<Point>& points, std::vector<Triangle>& triangles)
      : points_(points), triangles_(triangles) {
    owner_.reserve(3 * triangles.size());
    for (std::size_t t = 0; t < triangles.size(); ++t)
      for (std::size_t k = 0; k < 3; ++k) owner_[edge_key(triangles[t][k], triangles[t][(k + 1) % 3])] = t;
  }

  // Flips every flat triangle away. Each flip replaces at least one flat triangle by proper
  // ones, so this ends after at most as many flips as there are flat triangles.
  void remove_flat() {
    for (const Triangle& t : triangles_)
      if (is_flat(t))
        for (std::size_t k = 0; k < 3; ++k) pending_.emplace_back(t[k], t[(k + 1) % 3]);
    while (!pending_.empty()) {
      const auto [a, b] = pending_.back();
      pending_.pop_back();
      flip_if_not_delaunay(a, b, true);
    }
  }

  // Lawson flips towards the constrained Delaunay triangulation. From GLU's fans that takes
  // a number of flips quadratic in the samples (~25 per triangle for an 'I' of 283
  // samples): the budget bounds the time on very fine spacings, where the caps are then
  // only partly improved (still a valid triangulation).
  void towards_delaunay(std::size_t budget) {
    for (const Triangle& t : triangles_)
      for (std::size_t k = 0; k < 3; ++k)
        if (t[k] < t[(k + 1) % 3]) pending_.emplace_back(t[k], t[(k + 1) % 3]);
    while (!pending_.empty() && budget > 0) {
      const auto [a, b] = pending_.back();
      pending_.pop_back();
      if (flip_if_not_delaunay(a, b, false)) --budget;
    }
    pending_.clear();
  }

 private:
  bool is_flat(const Triangle& t) const { return !is_proper_ccw(points_[t[0]], points_[t[1]], points_[t[2]]); }

  static Index third(const Triangle& t, Index a, Index b) {
    for (Index v : t)
      if (v != a && v != b) return v;
    return t[0];  // not reached: a and b are two corners of t
  }

  // Flips the edge a-b when the angles facing it sum to more than pi (an apex of a flat
  // triangle between a and b faces it with pi) and the two new triangles are proper;
  // `flat_only`: only when one of its triangles is flat. Queues the four outer edges.
  bool flip_if_not_delaunay(Index a, Index b, bool flat_only) {
    const auto ab = owner_.find(edge_key(a, b));
    const auto ba = owner_.find(edge_key(b, a));
    if (ab == owner_.end() || ba == owner_.end()) return false;  // a contour edge, or flipped away
    const std::size_t t1 = ab->second, t2 = ba->second;
    if (flat_only && !is_flat(triangles_[t1]) && !is_flat(triangles_[t2])) return false;
    const Index c = third(triangles_[t1], a, b);  // t1 = (a, b, c), t2 = (b, a, d)
    const Index d = third(triangles_[t2], a, b);
    const Point &pa = points_[a], &pb = points_[b], &pc = points_[c], &pd = points_[d];
    // Sums this close to pi (cocircular samples on round strokes) are left alone: flipping
    // on rounding noise could cycle.
    constexpr double kAngleTolerance = 1e-10;
    if (corner_angle(pc, pa, pb) + corner_angle(pd, pa, pb) <= std::numbers::pi + kAngleTolerance) return false;
    if (!is_proper_ccw(pc, pa, pd) || !is_proper_ccw(pd, pb, pc)) return false;  // not a convex quad
    triangles_[t1] = {c, a, d};
    triangles_[t2] = {d, b, c};
    owner_.erase(ab);
    owner_.erase(ba);
    owner_[edge_key(a, d)] = t1;
    owner_[edge_key(d, c)] = t1;
    owner_[edge_key(c, d)] = t2;
    owner_[edge_key(b, c)] = t2;
    pending_.emplace_back(c, a);
    pending_.emplace_back(a, d);
    pending_.emplace_back(d, b);
    pending_.emplace_back(b, c);
    return true;
  }

  const std::vector<Point>& points_;
  std::vector<Triangle>& triangles_;
  std::unordered_map<std::uint64_t, std::size_t> owner_;  // directed edge -> its triangle
  std::vector<std::pair<Index, Index>> pending_;          // edges to check
};

}  // namespace

SurfaceMesh make_glyph_mesh(const GlyphMeshOptions& options) {
  const std::string& path = options.font_path;
  const std::string glyph = character_name(options.character);
  auto positive = [](double x) { return std::isfinite(x) && x > 0.0; };  // isfinite first: no FE_INVALID on NaN
  auto option_error = [&](const std::string& what, double value) {
    return std::invalid_argument("make_glyph_mesh: " + what + " (got " + format(value) + ")");
  };
  if (!positive(options.em_size)) throw option_error("em_size must be finite and > 0", options.em_size);
  if (!positive(options.depth)) throw option_error("depth must be finite and > 0", options.depth);
  if (!positive(options.sample_spacing))
    throw option_error("sample_spacing must be finite and > 0", options.sample_spacing);
  // Coarser than the em square, every contour would be a triangle. The lower bound, far
  // below what the sample limit allows, keeps the spacing in font units finite.
  if (options.sample_spacing > options.em_size)
    throw option_error("sample_spacing must be at most em_size (" + format(options.em_size) + " m)",
                       options.sample_spacing);
  if (options.sample_spacing < options.em_size * 1e-7)
    throw option_error("sample_spacing must be at least em_size / 1e7", options.sample_spacing);

  // --- The glyph's outline, in font units.
  FT_Library raw_library = nullptr;
  if (const FT_Error error = FT_Init_FreeType(&raw_library))
    throw std::runtime_error("make_glyph_mesh: cannot start FreeType (error " + std::to_string(error) + ")");
  const LibraryPtr library(raw_library);
  FT_Face raw_face = nullptr;
  if (const FT_Error error = FT_New_Face(library.get(), path.c_str(), 0, &raw_face))
    throw std::invalid_argument(path + ": cannot read the font (FreeType error " + std::to_string(error) + ": " +
                                freetype_error_text(error) + ")");
  const FacePtr face(raw_face);
  const FT_UInt glyph_index = FT_Get_Char_Index(face.get(), options.character);
  if (glyph_index == 0) throw std::invalid_argument(path + ": no glyph for " + glyph);
  // Font units, as drawn: no hinting, no embedded bitmaps.
  const FT_Int32 load_flags = FT_LOAD_NO_SCALE | FT_LOAD_NO_HINTING | FT_LOAD_NO_BITMAP;
  if (const FT_Error error = FT_Load_Glyph(face.get(), glyph_index, load_flags))
    throw std::invalid_argument(path + ": cannot load the glyph for " + glyph + " (FreeType error " +
                                std::to_string(error) + ": " + freetype_error_text(error) + ")");
  const FT_GlyphSlot slot = face->glyph;
  if (slot->format != FT_GLYPH_FORMAT_OUTLINE || slot->outline.n_contours <= 0)
    throw std::invalid_argument(path + ": the glyph for " + glyph + " has no outline");
  if (face->units_per_EM == 0) throw std::invalid_argument(path + ": the font has no em size (units_per_EM is 0)");

  Decomposition decomposition;
  FT_Outline_Funcs funcs{};
  funcs.move_to = on_move_to;
  funcs.line_to = on_line_to;
  funcs.conic_to = on_conic_to;
  funcs.cubic_to = on_cubic_to;
  if (const FT_Error error = FT_Outline_Decompose(&slot->outline, &funcs, &decomposition))
    throw std::invalid_argument(path + ": cannot read the outline of " + glyph + " (FreeType error " +
                                std::to_string(error) + ")");
  const bool even_odd = (slot->outline.flags & FT_OUTLINE_EVEN_ODD_FILL) != 0;

  const double scale = options.em_size / static_cast<double>(face->units_per_EM);  // m per font unit
  const double spacing = options.sample_spacing / scale;                           // font units
  auto too_many = [&](double samples) {
    return std::invalid_argument(path + ": sample_spacing " + format(options.sample_spacing) +
                                 " m is too fine for " + glyph + " at em_size " + format(options.em_size) +
                                 " m: about " + std::to_string(static_cast<long long>(samples)) +
                                 " contour samples, the limit is " + std::to_string(kMaxSamples));
  };
  // Bound the flattening work before doing it: the control polygons are at least as long
  // as the curves (and rarely much longer).
  double control_length = 0.0;
  for (const RawContour& contour : decomposition.contours)
    for (const Segment& segment : contour) control_length += segment.control_polygon_length();
  if (control_length / spacing > 2.0 * static_cast<double>(kMaxSamples)) throw too_many(control_length / spacing);

  // --- Contours resampled at even arc length.
  std::vector<std::vector<Point>> contours;
  std::size_t sample_count = 0;
  for (const RawContour& raw : decomposition.contours) {
    const std::vector<Point> polygon = flatten(raw, spacing / kPiecesPerSpacing);
    if (polygon.size() < 3) continue;  // a point or a line: encloses nothing
    const double length = perimeter(polygon);
    // A zero-width sliver would only give the tessellator collinear samples.
    if (std::abs(signed_area(polygon)) <= 1e-9 * length * length) continue;
    const auto count = static_cast<std::size_t>(std::max(3.0, std::round(length / spacing)));
    sample_count += count;
    if (sample_count > kMaxSamples) throw too_many(control_length / spacing);
    contours.push_back(resample(polygon, length, count));
  }
  if (contours.empty()) throw std::invalid_argument(path + ": the glyph for " + glyph + " has no outline");

  std::vector<Point> points;  // all samples, contour after contour
  std::vector<std::size_t> contour_begin;
  points.reserve(sample_count);
  for (const std::vector<Point>& contour : contours) {
    contour_begin.push_back(points.size());
    points.insert(points.end(), contour.begin(), contour.end());
  }
  contour_begin.push_back(points.size());

  // --- Front cap: one polygon with holes. The tessellator keeps pointers to the
  // coordinates and the vertex data until gluTessEndPolygon.
  std::vector<std::array<GLdouble, 3>> coordinates(points.size());
  std::vector<Index> ids(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    coordinates[i] = {points[i].x(), points[i].y(), 0.0};
    ids[i] = static_cast<Index>(i);
  }
  TessOutput tess_output;
  // A polygon with holes and no interior vertex has n + 2 h - 2 c triangles; the slack
  // only matters when the tessellator misbehaves.
  tess_output.corners.reserve(3 * (points.size() + 2 * contours.size()));
  {
    const TessPtr tess(gluNewTess());
    if (!tess) throw std::runtime_error("make_glyph_mesh: gluNewTess failed (out of memory)");
    gluTessCallback(tess.get(), GLU_TESS_BEGIN_DATA, glu_callback(tess_begin));
    gluTessCallback(tess.get(), GLU_TESS_VERTEX_DATA, glu_callback(tess_vertex));
    gluTessCallback(tess.get(), GLU_TESS_EDGE_FLAG_DATA, glu_callback(tess_edge_flag));
    gluTessCallback(tess.get(), GLU_TESS_COMBINE_DATA, glu_callback(tess_combine));
    gluTessCallback(tess.get(), GLU_TESS_ERROR_DATA, glu_callback(tess_error));
    gluTessProperty(tess.get(), GLU_TESS_WINDING_RULE, even_odd ? GLU_TESS_WINDING_ODD : GLU_TESS_WINDING_NONZERO);
    gluTessProperty(tess.get(), GLU_TESS_BOUNDARY_ONLY, GL_FALSE);
    gluTessNormal(tess.get(), 0.0, 0.0, 1.0);
    gluTessBeginPolygon(tess.get(), &tess_output);
    for (std::size_t c = 0; c < contours.size(); ++c) {
      gluTessBeginContour(tess.get());
      for (std::size_t i = contour_begin[c]; i < contour_begin[c + 1]; ++i)
        gluTessVertex(tess.get(), coordinates[i].data(), &ids[i]);
      gluTessEndContour(tess.get());
    }
    gluTessEndPolygon(tess.get());
  }
  const std::string cannot_mesh = path + ": cannot mesh the glyph for " + glyph + ": ";
  if (tess_output.error != 0)
  {
    const auto* text = reinterpret_cast<const char*>(gluErrorString(tess_output.error));
    throw std::invalid_argument(cannot_mesh + "the GLU tessellator failed (" + (text ? text : "GLU error") + " " +
                                std::to_string(tess_output.error) + ")");
  }
  if (tess_output.combine)
    throw std::invalid_argument(cannot_mesh + "its resampled contours cross or touch (overlapping contours in " +
                                "the font, or a sample_spacing too coarse for its thin parts)");
  if (tess_output.not_triangles || tess_output.overflow || tess_output.corners.size() % 3 != 0)
    throw std::invalid_argument(cannot_mesh + "the GLU tessellator returned no plain triangle list");

  std::vector<Triangle> cap(tess_output.corners.size() / 3);
  double cap_twice_area = 0.0;
  for (std::size_t t = 0; t < cap.size(); ++t) {
    cap[t] = {tess_output.corners[3 * t], tess_output.corners[3 * t + 1], tess_output.corners[3 * t + 2]};
    cap_twice_area += orient(points[cap[t][0]], points[cap[t][1]], points[cap[t][2]]);
  }
  // Counter-clockwise seen from +z. Decided for the cap as a whole: a flat triangle's own
  // sign is noise, its winding must follow its neighbours'.
  if (cap_twice_area < 0.0)
    for (Triangle& t : cap) std::swap(t[1], t[2]);
  {
    CapFlipper flipper(points, cap);
    flipper.remove_flat();
    // Enough for the capitals down to a spacing of ~em/250; ~1 s of flips at most.
    flipper.towards_delaunay(std::min<std::size_t>(64 * cap.size(), 2'000'000));
  }
  for (const Triangle& t : cap)
    if (!is_proper_ccw(points[t[0]], points[t[1]], points[t[2]]))
      throw std::invalid_argument(cannot_mesh + "a cap triangle is flat or inverted");

  // --- The closed mesh: front samples 0..n-1 at z = +depth/2, back samples n..2n-1.
  const auto n = static_cast<Index>(points.size());
  Point lo = points[0], hi = points[0];
  for (const Point& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Point centre = 0.5 * (lo + hi);
  const double half_depth = 0.5 * options.depth;
  SurfaceMesh mesh;
  mesh.vertices.resize(2 * points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Point p = scale * (points[i] - centre);
    mesh.vertices[i] = Vec3(p.x(), p.y(), half_depth);
    mesh.vertices[n + i] = Vec3(p.x(), p.y(), -half_depth);
  }
  mesh.triangles.reserve(2 * cap.size() + 2 * points.size());
  for (const Triangle& t : cap) mesh.triangles.push_back(t);
  for (const Triangle& t : cap) mesh.triangles.push_back({n + t[0], n + t[2], n + t[1]});

  // Walls: the front cap runs along each contour edge with the solid on its left (whether the
  // contour is an outline or a hole, and whatever the font's direction convention); the wall
  // runs along it the other way, so it faces away from the solid.
  std::unordered_map<std::uint64_t, char> cap_edges;
  cap_edges.reserve(3 * cap.size());
  for (const Triangle& t : cap)
    for (std::size_t k = 0; k < 3; ++k) cap_edges[edge_key(t[k], t[(k + 1) % 3])] = 1;
  for (std::size_t c = 0; c < contours.size(); ++c) {
    const auto begin = static_cast<Index>(contour_begin[c]);
    const auto end = static_cast<Index>(contour_begin[c + 1]);
    for (Index i = begin; i < end; ++i) {
      const Index j = i + 1 < end ? i + 1 : begin;
      const bool forward = cap_edges.count(edge_key(i, j)) != 0;
      if (forward == (cap_edges.count(edge_key(j, i)) != 0))
        throw std::invalid_argument(cannot_mesh + "a contour does not bound the filled area (overlapping contours)");
      const Index a = forward ? i : j, b = forward ? j : i;  // the cap's direction
      mesh.triangles.push_back({b, a, n + a});
      mesh.triangles.push_back({b, n + a, n + b});
    }
  }

  // Closed and consistently oriented: every directed edge once, and its reverse too.
  std::vector<std::uint64_t> edges;
  edges.reserve(3 * mesh.triangles.size());
  for (const Triangle& t : mesh.triangles)
    for (std::size_t k = 0; k < 3; ++k) edges.push_back(edge_key(t[k], t[(k + 1) % 3]));
  std::sort(edges.begin(), edges.end());
  const bool repeated = std::adjacent_find(edges.begin(), edges.end()) != edges.end();
  const bool open = std::any_of(edges.begin(), edges.end(), [&](std::uint64_t e) {
    return !std::binary_search(edges.begin(), edges.end(), (e << 32) | (e >> 32));
  });
  if (repeated || open) throw std::invalid_argument(cannot_mesh + "the surface does not close");
  return mesh;
}

}  // namespace ffd
