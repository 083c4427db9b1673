#pragma once
// Measurements of a State for reports and tests, outside the 1 kHz step: energy, the
// deformed embedded surfaces (eq. 2 per vertex) and contact accuracy on those surfaces.
#include <string>
#include <vector>

#include "ffd/model.h"

namespace ffd {

struct Energy {
  double kinetic = 0.0;        // J, sum of 1/2 m v^2 over lattice nodes
  double gravitational = 0.0;  // J, sum of -m g . x (zero without the gravity effect)
  double elastic = 0.0;        // J, sum of f^2 / 2k over springs (f: the spring's force in the last step)
  double total() const { return kinetic + gravitational + elastic; }
};
Energy compute_energy(const Model& model, const State& state);

// The embedded surface of one object moved by its lattice (eq. 2).
SurfaceMesh deformed_surface(const Model& model, const State& state, Index object);

// Contact accuracy measured on the embedded surfaces: for every pair of objects, and every
// object and plane, whose surfaces come within `search_radius` of each other (default: the
// largest cell size), the deepest penetration and the gap between them.
struct SurfaceContact {
  std::string a, b;  // object names; b may be a plane's name
  double penetration_m = 0.0;
  double gap_m = 0.0;
  std::size_t penetrating_vertices = 0;  // of either surface behind the other (below the plane)
};
struct SurfaceContactReport {
  std::vector<SurfaceContact> contacts;
  double max_penetration_m = 0.0;
  double max_gap_m = 0.0;
  std::size_t penetrating_vertices = 0;  // summed over the contacts
  double search_radius_m = 0.0;          // pairs farther apart than this are not reported
};
SurfaceContactReport measure_surface_contacts(const Model& model, const State& state, double search_radius = 0.0);

}  // namespace ffd
