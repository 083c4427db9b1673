#pragma once
// Closed, extruded letter meshes from a real font (the paper's alphabet experiment): the
// glyph's outline is read with FreeType, its curves flattened and every contour resampled at
// an even spacing, the two caps triangulated as polygons with holes by the GLU tessellator,
// and the contours joined front to back by side walls.
#include <string>

#include "ffd/mesh.h"

namespace ffd {

struct GlyphMeshOptions {
  std::string font_path;     // a TrueType / OpenType file, e.g. DejaVuSans-Bold.ttf
  char32_t character = U'A';
  double em_size = 0.05;     // m: the font's em square maps to this size (a 'font size')
  double depth = 0.02;       // m: extrusion along z, the caps at z = -depth/2 and +depth/2
  double sample_spacing = 0.0005;  // m: distance between consecutive contour samples
};

// A closed, consistently outward-oriented triangle mesh of the glyph, centred on its
// bounding box, x to the right, y up, z out of the front cap. Its vertices are the contour
// samples on both caps (no interior vertices), so V = 2 * samples and F = 2 * V - 4 + 4 g
// for a glyph with g holes. Throws std::invalid_argument naming the font file and the
// character when the font cannot be read, has no such glyph, or the glyph has no outline
// (a space).
SurfaceMesh make_glyph_mesh(const GlyphMeshOptions& options);

}  // namespace ffd
