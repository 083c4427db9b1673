#pragma once
// The paper's response (section 7): one contact answered at once, eq. 8 on the velocities
// and eq. 9 on the positions of its two sides. The one place eq. 8-9 are applied: box pairs,
// surface vertices and edges, static planes and the probe all come here.
#include "ffd/model.h"
#include "ffd/state.h"

namespace ffd {

// One side of a contact as eq. 8-9 move it: the 8 lattice nodes of a cell, the probe proxy,
// or a static plane (nothing moves).
struct ResponseSide {
  enum class Kind : std::uint8_t { Plane, Cell, Probe };
  Kind kind = Kind::Plane;
  Index cell = kNoIndex;
  // Static for this contact though it could move: held by a plane against the push
  // (collision.cpp, plane_holds). An object asleep is static anyway (sleep.h).
  bool held = false;

  static ResponseSide plane() { return {}; }
  static ResponseSide of_cell(Index cell, bool held = false) { return {Kind::Cell, cell, held}; }
  static ResponseSide probe() { return {Kind::Probe, kNoIndex, false}; }
};

// Side b's point is `r` (m) inside side a along n (unit, a's outward normal; eq. 7). Eq. 8:
// while the sides approach, each moving side's velocities are damped along n by alpha and
// across it by `beta` (friction; 0 without it) relative to v_ref, the sides' mass-weighted
// mean velocity (a static side's own), then the fresh contact's rebound (response.h) when
// `may_rebound`. Eq. 9: the depth split by inverse mass, a along -n and b along +n.
void answer_at_once(const Model& model, State& state, const ResponseSide& a, const ResponseSide& b, const Vec3& n,
                    double r, double beta, bool may_rebound);

// How far back (in steps) a node's way into a box is trusted to pick the contact face
// (box_test.h, the velocity-aware node_in_box), and a contact counts as fresh for the
// rebound (response.h).
inline constexpr double kRecentEntrySteps = 2.0;

// Mean velocity of a cell's 8 lattice nodes (m/s): the velocity eq. 8 works with.
Vec3 mean_velocity(const State& state, const std::array<Index, 8>& nodes);

}  // namespace ffd
