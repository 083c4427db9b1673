#pragma once
// Seeded random piles: drop scenes of the hollow and thin shapes whose surfaces can pass
// through each other edge first (rings, tori, thin plates, bowls, extruded letters), for the
// tests and `ffdsim piles`. A pile is scene text (docs/scene-format.md, "Scene format"): the same seed
// gives the same file on every machine, and a pile that goes wrong can be written out, opened
// in the viewer and replayed.
#include <cstdint>
#include <string>

namespace ffd {

inline constexpr double kPileSpringStiffness = 5000.0;  // N/m, every pile object's lattice springs

struct PileOptions {
  std::uint64_t seed = 1;
  int objects = 6;
  double cell_size = 0.01;  // m, every object's FFD lattice cell
  // Each object's size across (its largest extent before rotation) in cells, drawn uniformly.
  int min_cells = 3, max_cells = 12;
  // Each object's mass_spring.iterations: Gauss-Seidel sweeps of its lattice a step. The
  // lattices are soft (kPileSpringStiffness): in few sweeps a heavy object's contacts push the
  // nodes under them through a thin partner before the lattice around them follows.
  int iterations = 4;
  // The letters' font (the one the alphabet scene uses: fonts-dejavu-core).
  std::string font = "/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf";
  bool box_overlap = false;    // written as [simulation] box_overlap = true
  bool edge_contacts = true;   // the default; off: written as [simulation] edge_contacts = false
  bool solver_substeps = false;       // written as [simulation] solver_substeps = true
};

// The scene: `objects` objects of random shape, size and orientation in a column above a
// floor, inside four walls twice the largest object across; their bounding spheres do not
// overlap, so no two surfaces touch at the start. Inelastic contacts (alpha = 1) with
// friction (beta = 0.5), self-collision on. Throws std::invalid_argument on options out of
// range (objects 1..64, cells 1 <= min <= max <= 64, cell_size > 0, iterations 1..100).
std::string random_pile_scene(const PileOptions& options);

}  // namespace ffd
