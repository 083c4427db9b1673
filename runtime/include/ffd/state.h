#pragma once
// State: everything that changes while a scene runs. The step index is the only clock.
// Two States built from the same Model and advanced by the same commands are bit-identical.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "ffd/spec.h"
#include "ffd/types.h"

namespace ffd {

// Parameters a user may tune while the scene runs (they start from the scene's settings).
struct TunableParams {
  Vec3 gravity = Vec3::Zero();  // m/s^2
  double alpha = 0.0;           // collision damping, eq. 8
  double beta = 0.0;            // friction, eq. 8
  // (objects) per object: N/m per spring (mass_spring) or the pull fraction (shape_matching)
  std::vector<double> stiffness;
  double probe_stiffness = 0.0;  // N/m, the probe's virtual coupling spring
  Accuracy accuracy = Accuracy::CentreOfMass;  // collision accuracy level (spec.h)
  ContactResponse response = ContactResponse::Paper;  // how contacts are answered (spec.h)
};

// The haptic probe (the "probe" effect): the device position commanded from outside and the
// sphere proxy that follows it through the virtual coupling.
struct ProbeState {
  Vec3 device = Vec3::Zero();           // m, commanded device position
  Vec3 device_previous = Vec3::Zero();  // m, at the previous step (device velocity = difference / dt)
  Vec3 x = Vec3::Zero();                // m, proxy centre
  Vec3 v = Vec3::Zero();                // m/s, proxy velocity
  Vec3 force = Vec3::Zero();            // N, coupling force on the device: the force output
};

// A grabbed point (the "grab" effect): trilinear coordinates `local` in lattice cell `cell`,
// pulled towards `target`.
struct GrabState {
  bool active = false;
  Index cell = kNoIndex;         // global cell index
  Vec3 local = Vec3::Zero();     // (s, t, u) in [0, 1]^3
  Vec3 target = Vec3::Zero();    // m
  Vec3 force = Vec3::Zero();     // N, spring force on the object at the grabbed point
};

// A contact's static-friction anchor (response "solver", contact_solver.cpp): while a contact
// sticks, its friction holds its points at the offset p_b - p_a (m) where it first stuck, not
// where each step began, so that what one step's solve leaves unconverged does not add up
// step after step into a slide.
struct ContactAnchor {
  std::uint64_t key = 0;  // which contact: its boxes, face and tested node (contact_solver.cpp)
  Vec3 offset = Vec3::Zero();  // m, in the frame of the face it lies on, so that it turns with it
};

// An edge contact of the response "solver" (edge_contacts) that the last step ended
// with its points within kSpeculativeDistance of each other: held the next step as a
// speculative contact though the edge no longer crosses, so that a surface pushed out the
// skin's width is not let fall back through it (an edge crossing is found only once made).
// Its points as find_edge_contacts takes them: on surface edge `edge` at `along`, and on
// surface triangle `triangle` at `barycentric`.
struct EdgeHold {
  std::uint64_t key = 0;  // the contact's key (contact_solver.cpp), the order they are kept in
  std::array<Index, 2> edge{};
  double along = 0.0;
  Index triangle = 0;
  Vec3 barycentric = Vec3::Zero();
  Vec3 normal = Vec3::Zero();  // unit, out of the triangle's side, as when the edge crossed
};

struct State {
  std::uint64_t step = 0;  // steps taken since time zero
  TunableParams params;
  std::vector<Vec3> x;  // (N) lattice node positions, m
  std::vector<Vec3> v;  // (N) lattice node velocities, m/s
  std::vector<Quat> region_rotation;  // (R) shape-matching rotations, warm start of the next step
  // (C) each lattice cell's best-fit rotation from its rest shape, for the cells of
  // mass-spring objects with a shape stiffness (MassSpringParams::shape_stiffness), fitted
  // once a step; the warm start of the next step's fit.
  std::vector<Quat> cell_rotation;
  // (S) N: each spring's force in the last step, elastic and damping, from its XPBD
  // multiplier (lambda / dt^2).
  // The elastic energy is read from it (measure.h); not part of the state hash (derived).
  std::vector<double> spring_force;
  // (T) Pa: each volume constraint's pressure in the last step (lambda / dt^2), as above.
  std::vector<double> volume_pressure;
  // (C) N: each cell's shape force in the last step (lambda / dt^2), as above.
  std::vector<double> cell_shape_force;
  ProbeState probe;
  GrabState grab;
  // The "sleeping" effect, per object (O): an object asleep is frozen (v = 0), takes no
  // dynamics, and collides as a static body until something moving touches it (sleep.cpp).
  std::vector<std::uint8_t> asleep;
  std::vector<std::uint32_t> still_steps;  // steps its centre of mass has stayed near rest_anchor
  std::vector<Vec3> rest_anchor;           // m, where its centre of mass was when it last moved
  std::vector<std::uint8_t> moving;        // it left its anchor at the last Sleep stage, fast enough to wake others
  // The contacts that stuck in the last step under the response "solver", sorted by key:
  // anchors[0 .. anchor_count); the vector's size is its fixed capacity (initial_state).
  std::vector<ContactAnchor> anchors;
  std::size_t anchor_count = 0;
  // The edge contacts held from the last step, sorted by key: edge_holds[0 .. edge_hold_count);
  // the vector's size is its fixed capacity (initial_state).
  std::vector<EdgeHold> edge_holds;
  std::size_t edge_hold_count = 0;
};

// FNV-1a (64 bit) over the raw bits, one 64-bit word at a time, of every x, then every v,
// then the probe proxy's x and v, in node order: one pass over the state, no allocation.
std::uint64_t state_hash(const State& state);

// A state hash as printed and as replay scripts hold it: 16 lower-case hex digits.
std::string hash_hex(std::uint64_t hash);

}  // namespace ffd
