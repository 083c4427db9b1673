#pragma once
// Included by exactly one file of each fuzz target.
//
// Scene limits for the fuzz targets: the same checks as the defaults with smaller numbers,
// so that the largest scene a fuzzer can reach compiles in well under a second under
// ASan/UBSan and a slow or large unit means a missing check, not a big valid scene.
#include "ffd/scene_loader.h"

namespace ffd_fuzz {

inline ffd::SceneLimits scene_limits() {
  ffd::SceneLimits limits;
  limits.objects = 64;
  limits.object_triangles = 20'000;
  limits.scene_triangles = 40'000;
  limits.object_lattice_cells = 20'000;
  limits.scene_lattice_cells = 40'000;
  limits.scene_triangle_cells = 100'000;
  limits.scene_region_members = 500'000;
  limits.glyph_text = 4;
  limits.glyph_samples_per_em = 100;
  return limits;
}

}  // namespace ffd_fuzz

// assimp 5.2's readers leak the mesh they were filling when they give up on a malformed
// file (about 1 KB per file). That is assimp's, not ours, and cannot be fixed here without
// patching the library, so LeakSanitizer ignores leaks allocated inside it; leaks of our own
// code are still findings.
extern "C" const char* __lsan_default_suppressions() { return "leak:libassimp.so\n"; }
