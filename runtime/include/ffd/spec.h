#pragma once
// SceneSpec: what a scene asks for, as parsed from a scene file (scenarios/) or built in
// code. compile() (model.h) validates it and derives everything the step needs.
// Units are SI: metres, seconds, kilograms; angles in degrees where a name says so.
#include <cstdint>
#include <string>
#include <vector>

#include "ffd/mesh.h"

namespace ffd {

// The effects a scene may call for. The step is assembled from only these (see step.h).
enum class Effect : std::uint32_t {
  Gravity = 1u << 0,         // uniform acceleration `gravity`
  Planes = 1u << 1,          // static planes (a floor, walls of a bin)
  InterCollision = 1u << 2,  // FFD AABB collisions between different objects
  SelfCollision = 1u << 3,   // FFD AABB collisions between non-adjacent cells of one object
  Friction = 1u << 4,        // tangential term of eq. 8 (beta); without it beta is unused
  Probe = 1u << 5,           // haptic probe: a sphere proxy coupled to the device pose
  Grab = 1u << 6,            // grab: a picked point of an object pulled towards a target
  Sleeping = 1u << 7,        // objects at rest freeze until something moves against them
};
using EffectSet = std::uint32_t;
inline constexpr bool has(EffectSet set, Effect e) { return (set & static_cast<std::uint32_t>(e)) != 0; }
inline constexpr EffectSet operator|(Effect a, Effect b) {
  return static_cast<std::uint32_t>(a) | static_cast<std::uint32_t>(b);
}
inline constexpr EffectSet operator|(EffectSet a, Effect b) { return a | static_cast<std::uint32_t>(b); }

// Name <-> effect, for scene files and reports ("gravity", "planes", "inter_collision",
// "self_collision", "friction", "probe", "grab"). effect_from_name returns false for an
// unknown name.
const char* effect_name(Effect e);
bool effect_from_name(const std::string& name, Effect& out);
inline constexpr Effect kAllEffects[] = {Effect::Gravity,       Effect::Planes,   Effect::InterCollision,
                                         Effect::SelfCollision, Effect::Friction, Effect::Probe,
                                         Effect::Grab,          Effect::Sleeping};

enum class DynamicsKind : std::uint8_t {
  MassSpring,     // edge, face- and body-diagonal springs, XPBD compliant constraints
  ShapeMatching,  // lattice shape matching (FastLSM-style regions of half-width w)
};

struct MassSpringParams {
  double stiffness = 5.0e3;  // N/m per spring; any value > 0 is stable (XPBD)
  double damping = 0.5;      // N*s/m along each spring
  int iterations = 4;        // Gauss-Seidel sweeps per step
  // Pa; 0: springs only. Above 0, each cell's six tetrahedra also keep their signed volume
  // (XPBD, compliance V0 / K each): springs alone hold a cell turned inside out as well as
  // the upright one (a mirrored cell has every spring at its rest length).
  double bulk_modulus = 0.0;
  // N/m; 0: off. Above 0, each lattice cell is also pulled towards its rest shape turned by
  // the cell's best-fit rotation (a corotated element: shape matching on the cell's 8 nodes,
  // solved as one XPBD constraint per cell). Its goal is never mirrored, so a cell turned
  // inside out is pulled back upright, where springs alone hold it inverted.
  double shape_stiffness = 0.0;
};

struct ShapeMatchingParams {
  double stiffness = 0.5;     // fraction of the way to the goal shape per step, (0, 1]
  int region_half_width = 1;  // w: a region spans (2w+1)^3 lattice nodes
  double damping = 2.0;       // 1/s, linear damping of the lattice node velocities
};

struct ObjectSpec {
  std::string name;
  std::string source;  // where the surface came from (mesh path or "box", "sphere"), for logs
  SurfaceMesh mesh;    // in the object's own frame, metres (already scaled)
  Vec3 position = Vec3::Zero();     // m, translation applied after rotation
  Vec3 rotation_deg = Vec3::Zero(); // rotation about x, then y, then z (degrees)
  Vec3 velocity = Vec3::Zero();     // m/s, initial velocity of every lattice node
  // rad/s, initial spin about the lattice's centre of mass: node velocity += w x (x - c)
  Vec3 angular_velocity = Vec3::Zero();
  double cell_size = 0.05;          // m, FFD lattice cell edge
  double mass = 1.0;                // kg, whole object
  bool fill_interior = false;       // also keep interior cells (flood fill) for a solid feel
  MeshCleanOptions clean;
  int subdivisions = 0;             // 1-to-4 midpoint subdivisions of the cleaned mesh (0..3)
  DynamicsKind dynamics = DynamicsKind::MassSpring;
  MassSpringParams mass_spring;
  ShapeMatchingParams shape_matching;
};

struct PlaneSpec {
  std::string name;
  Vec3 normal = Vec3::UnitY();  // points out of the solid side; normalised at compile time
  double offset = 0.0;          // plane: normal . x = offset (m)
};

// The haptic probe: a rigid sphere proxy of mass `mass` tied to the device position by a
// spring-damper (the virtual coupling). The coupling force is the force output a device
// renders. Its nodes are tested against the FFD AABBs like the nodes of a box.
struct ProbeSettings {
  double radius = 0.01;               // m
  double mass = 0.05;                 // kg, of the proxy
  double coupling_stiffness = 300.0;  // N/m
  double coupling_damping = 6.0;      // N*s/m, on the proxy's velocity relative to the device
  Vec3 start = Vec3(0.0, 0.5, 0.0);   // m, device and proxy position at time zero
  // A haptic device on the probe (ffdsim run --device): what the link lets out. Not physics:
  // the step never reads them.
  double force_limit = 8.0;           // N, |F| sent to the device at most
  double force_rate_limit = 1.0;      // N/ms, change of the force sent per millisecond at most
  double watchdog_ms = 20.0;          // ms without a device sample: force zero, probe held
};

// Grab: a point of an object (a lattice cell and local coordinates in it) pulled towards a
// target by a spring-damper acting on the cell's 8 nodes.
struct GrabSettings {
  double stiffness = 200.0;  // N/m
  double damping = 2.0;      // N*s/m, on the point's velocity
};

// Collision accuracy levels: what stands for a surface in contact, from the coarsest to the
// exact surfaces. Each level's cost per step is measured by the same stage timers.
enum class Accuracy : std::uint8_t {
  GridCells = 0,      // the plain lattice cells as boxes, 8 corner nodes (floats: Fig. 7a)
  BoundaryNodes = 1,  // FFD AABBs with their 8 boundary nodes
  CentreOfMass = 2,   // + the surface's centre of mass in the cell (the paper's default)
  SampleNodes = 3,    // FFD AABBs; their nodes: the centre of mass + 26 extreme points of the surface
  SubBoxes = 4,       // each FFD AABB split into k x k x k sub-boxes fitted to the surface
  Exact = 5,          // surface vertices against surface triangles, with their own broad phase
};
inline constexpr int kAccuracyLevels = 6;
const char* accuracy_name(Accuracy a);

// How the contacts the narrow phase finds are answered (docs/step.md, "Two contact responses").
enum class ContactResponse : std::uint8_t {
  Paper = 0,   // at once, pair by pair: eq. 7-9 on the two cells' nodes (section 7, Algorithm 1)
  Solver = 1,  // as constraints, solved with the springs and volumes in the same iterations
};
const char* response_name(ContactResponse r);
bool response_from_name(const std::string& name, ContactResponse& out);

// Scene-wide settings. alpha, beta and gravity are the starting values of State::params,
// which commands may change while a scene runs.
struct SimulationSettings {
  double dt = 0.001;                     // s, fixed step
  Vec3 gravity = Vec3(0.0, -9.81, 0.0);  // m/s^2
  double alpha = 0.5;                    // collision damping, eq. 8, [0, 1]: 1 - restitution (response.h)
  double beta = 0.3;                     // friction, eq. 8, [0, 1]
  std::uint64_t seed = 1;                // for anything random a scene asks for
  EffectSet effects = 0;
  double hash_cell_size = 0.0;           // m; broad-phase grid cell edge, 0 = the objects' cell sizes
  double min_box_thickness = 0.1;        // fraction of the cell size, see compile()
  Accuracy accuracy = Accuracy::CentreOfMass;  // starting level; commands may switch it
  ContactResponse response = ContactResponse::Paper;  // starting response; commands may switch it
  // Response "solver" only: rolling resistance, the most torque a contact resists rolling and
  // spinning with, as a share of its normal force times the object's radius of gyration
  // (contact_solver.cpp). Without it an object resting on a curved support rocks on it for ever.
  // Off where beta = 0: a frictionless contact has no grip.
  double rolling_resistance = 0.2;
  int sub_box_split = 2;                 // k of accuracy level 4, [2, 4]
  // Levels 0-4 under the paper's response: two boxes of different objects are also kept
  // apart as wholes (the separating axes of their faces), with a skin of 1 % of the finer
  // cell size between them, where testing their nodes alone lets two thin boxes cross like
  // an X (docs/accuracy.md, "Random piles").
  bool box_overlap = false;
  // Levels 0-3 under the paper's response: after the node tests, the exact surfaces' edges
  // are tested against the other object's triangles and a crossed edge is sent back the way
  // it came, as at levels 4 and 5 (docs/accuracy.md, "Random piles"), with the planes answered first.
  // false is the paper's method as published (surfaces may stay crossed): its scenes of
  // several objects keep it. Under the response "solver" the same edges are constraints
  // solved with the others (contact_solver.h), at levels 4 and 5 also only with it, and at
  // level 5 the surface vertices' contacts too (without, answered at once).
  bool edge_contacts = true;
  // Under the response "solver": its sweeps as substeps of dt / sweeps (XPBD with small
  // steps, Macklin et al. 2019), each with its own prediction and the contacts' loads
  // carried over, instead of iterations of one step. A stiff lattice then holds its shape
  // where a contact pushes a few of its nodes (docs/limits.md). Not at level 5 without
  // edge_contacts (or inter-collision), whose vertex contacts are then answered before the solve.
  bool solver_substeps = false;
  ProbeSettings probe;                   // used with the "probe" effect
  // Used with the "sleeping" effect: an object whose centre of mass has stayed within
  // sleep_radius of one point for sleep_time falls asleep (runtime/src/sleep.h).
  double sleep_radius = 0.002;           // m
  double sleep_time = 0.3;               // s
  GrabSettings grab;                     // used with the "grab" effect
};

struct SceneSpec {
  std::string name;
  SimulationSettings settings;
  std::vector<ObjectSpec> objects;
  std::vector<PlaneSpec> planes;
};

}  // namespace ffd
