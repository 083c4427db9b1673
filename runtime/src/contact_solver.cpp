#include "contact_solver.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "dynamics.h"
#include "ffd/box_test.h"
#include "ffd/response.h"
#include "ffd/trilinear.h"
#include "ffd/worker_pool.h"
#include "interaction.h"
#include "step_memory.h"
#include "sleep.h"

namespace ffd {

namespace {

// Below this approach speed (m/s) a contact is resting: it gets no restitution, only its
// approach stopped (Mueller et al. 2020 use 2 |g| dt likewise), so a pile does not bounce on
// the velocity gravity adds in one step.
constexpr double kRestingApproach = 0.05;

}  // namespace

namespace {
// A node found deeper inside than this (m) beyond what its approach made in the last
// kRecentEntrySteps steps is lodged: it got there by an error (a large step, a thin box, a
// lattice that folded), not by touching. It is pushed out without friction: friction on such
// a contact grips what it should release (the lower teapot's knob, lodged laterally in the
// upper teapot's bottom boxes, was lifted with it by the grab).
constexpr double kLodgedDepth = 0.0002;

// A relative spin whose speed at the radius of gyration is below this (m/s) is the lattice's
// node noise, not rolling: rolling resistance leaves it alone. Bodies at rest keep a little
// node noise, and resisting it as if it were rolling stirred them more
// (docs/notes/2026-11-28-code-findings.md#spin-noise).
constexpr double kSpinNoise = 1.0e-4;

// A contact's friction below this share of its Coulomb limit held: the contact stuck (the
// solve clamps a sliding contact's friction to the limit itself).
constexpr double kStuck = 0.999;

// Passes over the resting contacts' friction alone after each sweep's contact pass. One
// pass leaves Gauss-Seidel's friction far from converged where many contacts share nodes:
// in a deep stack at rest most contacts that push sit at the Coulomb limit and slide, and
// the letters creep. The normal corrections are left alone: repeating them too threw a fast
// bullet through its plate and made a lifted teapot's nodes spike
// (docs/notes/2026-11-28-code-findings.md#friction-passes).
constexpr int kFrictionPasses = 7;

// Passes over the edge contacts alone at the end of the last sweep, until the largest
// correction of a pass is below kEdgeConverged (m). One pass leaves Gauss-Seidel far from
// converged where many edge contacts share an object's nodes from both sides: a letter lying
// between two thin plates, pushed up out of one and down out of the other, ended each step
// with its edges still crossed by most of their depth and stayed crossed at rest.
constexpr int kEdgePasses = 16;
constexpr double kEdgeConverged = 1.0e-6;

// Whether a contact's friction held inside the Coulomb cone in the solve: it stuck.
bool sticks(const ContactConstraint& c, double mu) {
  return mu > 0.0 && !c.lodged && c.friction.norm() < kStuck * mu * c.lambda;
}

// The proxy's inverse mass as the contacts see it: its coupling is integrated by backward
// Euler (interaction.cpp), so within a step it answers a push like a mass m + dt c + dt^2 k.
// With the bare mass, a very stiff coupling held the proxy back at a box pinned on the floor
// while the device went on, until it tore through at speed
// (docs/notes/2026-11-28-code-findings.md#probe-mass).
double probe_inv_mass(const Model& model, const State& state) {
  const double dt = model.settings.dt;
  return 1.0 / (model.settings.probe.mass + dt * model.settings.probe.coupling_damping +
                dt * dt * state.params.probe_stiffness);
}

// The solve's view of the nodes: positions, velocities and inverse masses, the probe proxy
// included; an object not solved this step (asleep at its start) is static.
struct Bodies {
  const Model& model;
  State& state;
  const StepMemory& scratch;

  Vec3& x(Index n) const { return n == kProbeNode ? state.probe.x : state.x[n]; }
  Vec3& v(Index n) const { return n == kProbeNode ? state.probe.v : state.v[n]; }
  const Vec3& x_prev(Index n) const { return n == kProbeNode ? scratch.probe_x_prev : scratch.x_prev[n]; }
  // Where the substep began (the step, without substeps).
  Vec3 x_start(Index n) const {
    if (scratch.substeps == 1) return x_prev(n);
    if (n == kProbeNode) return scratch.probe_x_sub;
    return Eigen::Map<const Vec3>(scratch.start_record.get() + kNodeRecord * n);
  }
  Vec3 point_start(const ContactSide& s) const {
    Vec3 p = Vec3::Zero();
    for (int j = 0; j < s.count; ++j) p += s.weight[j] * x_start(s.node[j]);
    return p;
  }
  double inv_mass(Index n) const {
    if (n == kProbeNode) return probe_inv_mass(model, state);
    return scratch.object_solving[model.node_object[n]] ? model.node_inv_mass[n] : 0.0;
  }
  Vec3 point(const ContactSide& s) const {
    Vec3 p = Vec3::Zero();
    for (int j = 0; j < s.count; ++j) p += s.weight[j] * x(s.node[j]);
    return p;
  }
  Vec3 point_prev(const ContactSide& s) const {
    Vec3 p = Vec3::Zero();
    for (int j = 0; j < s.count; ++j) p += s.weight[j] * x_prev(s.node[j]);
    return p;
  }
  Vec3 velocity(const ContactSide& s) const {
    Vec3 u = Vec3::Zero();
    for (int j = 0; j < s.count; ++j) u += s.weight[j] * v(s.node[j]);
    return u;
  }
  double weighted_inv_mass(const ContactSide& s) const {
    double w = 0.0;
    for (int j = 0; j < s.count; ++j) w += s.weight[j] * s.weight[j] * inv_mass(s.node[j]);
    return w;
  }
  // Each node's share of a push on the side's point, w_j / m_j, fixed for the step: the
  // passes move the point many times a step and need not look the masses up each time.
  void prepare(ContactSide& s) const {
    for (int j = 0; j < s.count; ++j) s.share[j] = s.weight[j] * inv_mass(s.node[j]);
  }
  // Moves the side's point by `delta` / (its share): node j by w_j / m_j * delta, so that the
  // point moves by weighted_inv_mass * delta. The side is prepare()d.
  void move(const ContactSide& s, const Vec3& delta) const {
    for (int j = 0; j < s.count; ++j) x(s.node[j]) += s.share[j] * delta;
  }
};

// Box `mover`'s tested node k against face `face` of box `container`.
std::uint64_t box_contact_key(Accuracy accuracy, Index container, int face, Index mover, int k) {
  if (k >= 256) return 0;
  return contact_key(ContactKey::BoxNode, accuracy, std::uint64_t{container} * 8 + static_cast<std::uint64_t>(face),
                     std::uint64_t{mover} * 256 + static_cast<std::uint64_t>(k));
}

// Box b's tested node k against plane `plane`.
std::uint64_t plane_contact_key(Accuracy accuracy, Index plane, Index b, int k) {
  if (k >= 256) return 0;
  return contact_key(ContactKey::PlaneNode, accuracy, plane, std::uint64_t{b} * 256 + static_cast<std::uint64_t>(k));
}

// The anchor the last step left for `key`, if any (State::anchors is sorted by key).
const ContactAnchor* find_anchor(const State& state, std::uint64_t key) {
  if (key == 0) return nullptr;
  const auto begin = state.anchors.begin(), end = begin + static_cast<std::ptrdiff_t>(state.anchor_count);
  const auto it = std::lower_bound(begin, end, key, [](const ContactAnchor& a, std::uint64_t k) { return a.key < k; });
  return it != end && it->key == key ? &*it : nullptr;
}

// An orthonormal frame that turns with face `face` of box b, where the step began: its first
// edge, the normal of its diagonals (eq. 3) x that edge, the normal. The world's where the face
// has no such frame (a degenerate box).
Mat3 face_frame(const Bodies& bodies, const BoxSet& boxes, Index b, int face) {
  std::array<Vec3, 4> corner;
  for (int i = 0; i < 4; ++i)
    corner[i] = bodies.point_prev(cell_point(bodies.model, boxes.box_cell[b], boxes.box_local[b][kBoxFaces[face][i]]));
  const Vec3 normal = (corner[2] - corner[0]).cross(corner[3] - corner[1]);
  const Vec3 edge = corner[1] - corner[0];
  const Vec3 tangent = edge - edge.dot(normal) / normal.squaredNorm() * normal;
  Mat3 frame = Mat3::Identity();
  if (!(normal.squaredNorm() > 0.0) || !(tangent.squaredNorm() > 0.0) || !is_finite(tangent)) return frame;
  frame.col(2) = normal.normalized();
  frame.col(0) = tangent.normalized();
  frame.col(1) = frame.col(2).cross(frame.col(0));
  return frame;
}

// The frame contact c's anchor is kept in: its box face's (face_frame, a face of `boxes`), or
// the world's (a plane's contact, whose `boxes` may be null).
Mat3 anchor_frame(const Bodies& bodies, const BoxSet* boxes, const ContactConstraint& c) {
  return c.face_box == kNoIndex ? Mat3::Identity() : face_frame(bodies, *boxes, c.face_box, c.face);
}

// Contact record r as a constraint: side b's point must stay on the outer side (along n) of
// side a's surface; it is `depth` inside now. Its key names it from step to step (0: never
// anchored); a contact on a face of a box of `boxes` keeps its anchor in that face's frame.
void make_constraint(const Bodies& bodies, const ContactRecord& r, const BoxSet* boxes, ContactConstraint& c) {
  const double dt = bodies.model.settings.dt;
  c.a = r.a;
  c.b = r.b;
  c.normal = r.normal;
  c.rest = r.normal.dot(bodies.point(r.b) - bodies.point(r.a)) + r.depth;
  c.key = r.key;
  const ContactAnchor* anchor = find_anchor(bodies.state, r.key);
  c.face_box = r.face_box;
  c.face = r.face;
  c.hold = anchor ? Vec3(anchor_frame(bodies, boxes, c) * anchor->offset)
                  : Vec3(bodies.point_prev(r.b) - bodies.point_prev(r.a));
  c.approach = r.normal.dot(bodies.velocity(r.b) - bodies.velocity(r.a));
  c.inv_mass = 0.0;
  c.lambda = 0.0;
  c.pushed = 0.0;
  c.friction = Vec3::Zero();
  c.lodged = r.depth > kLodgedDepth + std::max(0.0, -c.approach) * kRecentEntrySteps * dt;
}

// Appends contact record r to the constraints (make_constraint); beyond their room, dropped.
void add_contact(const Bodies& bodies, StepMemory& scratch, const ContactRecord& r, const BoxSet* boxes = nullptr) {
  if (scratch.constraint_count >= scratch.constraints.size()) {
    scratch.constraints_dropped = true;
    return;
  }
  make_constraint(bodies, r, boxes, scratch.constraints[scratch.constraint_count++]);
}

// Candidate pair p's contacts, in order: each tested node of one box inside the other, or
// near a face of it (within kSpeculativeDistance outside: a speculative contact, which holds
// the node at the face should the solve move it in, so that a resting contact stays in the
// list from step to step). `on_contact(record, inside, node)` for each, node the tested
// node's position. Read-only, against the planes take_pair_planes took.
template <class OnContact>
void pair_box_contacts(const Model& model, const BoxLevel& level, const State& state, const StepMemory& scratch, Index p,
                       const OnContact& on_contact) {
  const BoxSet& boxes = *level.boxes;
  const BoxPair& pair = scratch.pairs[p];
  const double margin = kSpeculativeDistance, recent = kRecentEntrySteps * model.settings.dt;
  for (int half = 0; half < 2; ++half) {
    const Index mover = half == 0 ? pair.a : pair.b, container = half == 0 ? pair.b : pair.a;
    const Index cell_a = boxes.box_cell[container], cell_b = boxes.box_cell[mover];
    scan_points_in_planes(
        scratch.box_planes[container], recent, tested_node_count(level),
        [&](int k) { return tested_node(model, level, state, scratch, mover, k); },
        [&] { return Vec3(mean_velocity(state, model.cell_nodes[cell_b]) - mean_velocity(state, model.cell_nodes[cell_a])); },
        [&](int k, const Vec3& node, const NodeInBox& hit, const BoxPlanes& planes) {
          int face = hit.face;
          double depth = hit.depth;
          if (!hit.inside) {
            const NearFace near = near_face(planes, node, margin);
            if (near.face < 0) return;
            face = near.face;
            depth = -near.height;
          }
          ContactRecord r;
          r.a = face_point(model, boxes, container, face);
          r.b = cell_point(model, cell_b, tested_node_local(model, level, mover, k));
          r.normal = planes.normal[face];
          r.depth = depth;
          r.key = box_contact_key(state.params.accuracy, container, face, mover, k);
          r.face_box = container;
          r.face = static_cast<std::uint8_t>(face);
          on_contact(r, hit.inside, node);
        });
  }
}

// The planes of every candidate pair's boxes, once each (SolverMemory::box_planes).
void take_pair_planes(StepMemory& scratch) {
  const std::uint64_t mark = ++scratch.box_planes_epoch;
  Index count = 0;
  for (Index p = 0; p < scratch.pair_count; ++p)
    for (const Index b : {scratch.pairs[p].a, scratch.pairs[p].b})
      if (scratch.box_planes_mark[b] != mark) {
        scratch.box_planes_mark[b] = mark;
        scratch.planned_boxes[count++] = b;
      }
  constexpr Index kBoxesPerChunk = 64;
  parallel_for(scratch.pool, (count + kBoxesPerChunk - 1) / kBoxesPerChunk, [&](std::uint32_t chunk, std::uint32_t) {
    for (Index i = chunk * kBoxesPerChunk; i < std::min(count, (chunk + 1) * kBoxesPerChunk); ++i) {
      const Index b = scratch.planned_boxes[i];
      scratch.box_planes[b] = box_planes(scratch.box_nodes[b]);
    }
  });
}

}  // namespace

void begin_solver_step(const Model& model, State& state, StepMemory& scratch) {
  scratch.constraint_count = 0;
  scratch.edge_contact_begin = scratch.edge_contact_end = 0;
  scratch.constraints_dropped = false;
  for (std::size_t o = 0; o < model.objects.size(); ++o) scratch.object_solving[o] = !state.asleep[o];
  // Not where level 5's vertex contacts are answered at once in the narrow phase, before the
  // solve (without the solver's edges, step.cpp): substep 0's prediction from the step's start
  // would undo those answers.
  const bool substeps =
      model.settings.solver_substeps && !box_level(model, state.params.accuracy).vertex_contacts_at_once();
  scratch.substeps = substeps ? dynamics_iterations(model) : 1;
  scratch.substep_gravity = substeps && has(model.settings.effects, Effect::Gravity) ? state.params.gravity : Vec3::Zero();
  predict_dynamics(model, state, scratch, scratch.pool);
  scratch.grab_force = Vec3::Zero();
}

// The detection over the pool, in two passes over the candidate pairs: the first counts
// each pair's contacts, the second writes them where the counts put them in the list. The
// list is the one a single thread writes in pair order, whatever the thread count.
void find_box_contacts(const Model& model, const BoxLevel& level, State& state, StepMemory& scratch,
                       StageCounters& counters, double& max_depth) {
  const BoxSet& boxes = *level.boxes;
  const Index pairs = scratch.pair_count;
  const Bodies bodies{model, state, scratch};
  constexpr Index kPairsPerChunk = 32;
  const Index chunks = (pairs + kPairsPerChunk - 1) / kPairsPerChunk;
  auto chunk_pairs = [&](std::uint32_t chunk) {
    return std::pair{chunk * kPairsPerChunk, std::min(pairs, (chunk + 1) * kPairsPerChunk)};
  };
  take_pair_planes(scratch);
  // Pass 1: each pair's constraints and logged contacts (those inside), counted.
  parallel_for(scratch.pool, chunks, [&](std::uint32_t chunk, std::uint32_t) {
    const auto [begin, end] = chunk_pairs(chunk);
    for (Index p = begin; p < end; ++p) {
      std::array<Index, 2> found{0, 0};
      if (pair_hit(model, level, state, scratch, p, kSpeculativeDistance, scratch.box_planes.data()))
        pair_box_contacts(model, level, state, scratch, p, [&](const ContactRecord&, bool inside, const Vec3&) {
          ++found[0];
          found[1] += inside ? 1 : 0;
        });
      scratch.pair_contacts[p + 1] = found;
    }
  });
  counters.node_tests += 2 * tested_node_count(level) * pairs;
  // Where each pair's share starts; the pairs tested; a moving object wakes a sleeper it meets
  // (from the next step).
  const Index first_constraint = scratch.constraint_count, first_logged = scratch.contact_count;
  scratch.pair_contacts[0] = {first_constraint, first_logged};
  for (Index p = 0; p < pairs; ++p) {
    for (int i = 0; i < 2; ++i) scratch.pair_contacts[p + 1][i] += scratch.pair_contacts[p][i];
    const BoxPair& pair = scratch.pairs[p];
    const Index o1 = model.cell_object[boxes.box_cell[pair.a]], o2 = model.cell_object[boxes.box_cell[pair.b]];
    if (sleeping(model)) meet(state, o1, o2);
    if (o1 == o2) ++counters.self_pairs_tested;
    else ++counters.inter_pairs_tested;
  }
  // Pass 2: the pairs with contacts write them into their places (beyond the room: dropped).
  const std::array<Index, 2> total = scratch.pair_contacts[pairs];
  const std::size_t constraint_room = scratch.constraints.size(), log_room = scratch.contacts.size();
  using ContactShare = SolverMemory::ContactShare;
  for (ContactShare& share : scratch.contact_shares) share = ContactShare{};
  parallel_for(scratch.pool, chunks, [&](std::uint32_t chunk, std::uint32_t thread) {
    ContactShare& share = scratch.contact_shares[thread];
    const auto [begin, end] = chunk_pairs(chunk);
    for (Index p = begin; p < end; ++p) {
      std::array<Index, 2> next = scratch.pair_contacts[p];
      if (next == scratch.pair_contacts[p + 1]) continue;
      const bool self = model.cell_object[boxes.box_cell[scratch.pairs[p].a]] == model.cell_object[boxes.box_cell[scratch.pairs[p].b]];
      pair_box_contacts(model, level, state, scratch, p, [&](const ContactRecord& r, bool inside, const Vec3& node) {
        if (next[0] < constraint_room) make_constraint(bodies, r, &boxes, scratch.constraints[next[0]]);
        ++next[0];
        if (!inside) return;
        ++(self ? share.self_contacts : share.inter_contacts);
        share.max_depth = std::max(share.max_depth, r.depth);
        if (next[1] < log_room)
          scratch.contacts[next[1]] = {node, r.normal, r.depth, self ? ContactKind::Self : ContactKind::Inter};
        ++next[1];
      });
    }
  });
  for (const ContactShare& share : scratch.contact_shares) {
    counters.self_contacts += share.self_contacts;
    counters.inter_contacts += share.inter_contacts;
    max_depth = std::max(max_depth, share.max_depth);
  }
  scratch.constraint_count = static_cast<Index>(std::min<std::size_t>(total[0], constraint_room));
  if (total[0] > constraint_room) scratch.constraints_dropped = true;
  scratch.contact_count = static_cast<Index>(std::min<std::size_t>(total[1], log_room));
  scratch.contacts_dropped += static_cast<std::uint32_t>(total[1] - scratch.contact_count);
}

// Level 5 with edge_contacts (BoxLevel::solver_edges): of each half of a pair of cells, every
// surface vertex inside the other's surface, or where none is the one nearest to it within
// the skin and the speculative distance in front (find_vertex_contacts), becomes a
// constraint between the vertex and the closest point of the closest triangle, carried by
// the cell that holds that point at rest, to go out along the triangle's normal to the skin
// in front. Where the carried point and the flat triangle's differ by more than the
// speculative distance the constraint would push the wrong point: left out, as an edge
// contact's.
void find_vertex_constraints(const Model& model, State& state, StepMemory& scratch, StageCounters& counters,
                             double& max_depth) {
  struct Sink final : VertexContactSink {
    const Bodies& bodies;
    StepMemory& scratch;
    StageCounters& counters;
    double& max_depth;
    Sink(const Bodies& b, StepMemory& s, StageCounters& c, double& d) : bodies(b), scratch(s), counters(c), max_depth(d) {}
    void add(const VertexContact& contact, bool self) override {
      const Model& model = bodies.model;
      ContactRecord r;
      r.b = vertex_point(model, contact.vertex);
      if (!triangle_point(model, contact.triangle, contact.barycentric, r.a)) return;
      if ((bodies.point(r.a) - contact.closest).norm() > kSpeculativeDistance) return;
      r.normal = contact.normal;
      r.depth = contact.depth;
      r.key = contact_key(ContactKey::SurfaceVertex, bodies.state.params.accuracy, contact.vertex, contact.triangle);
      add_contact(bodies, scratch, r);
      if (!contact.inside) return;
      ++(self ? counters.self_contacts : counters.inter_contacts);
      const double skin = self ? 0.0 : model.surface_skin;
      max_depth = std::max(max_depth, contact.depth - skin);  // the penetration
      scratch.record_contact(contact.point, contact.normal, contact.depth, self ? ContactKind::Self : ContactKind::Inter);
    }
  };
  const Bodies bodies{model, state, scratch};
  Sink sink(bodies, scratch, counters, max_depth);
  find_vertex_contacts(model, state, scratch, counters, kSpeculativeDistance, sink);
}

namespace {

// An edge contact's two points (the edge's, side b; the triangle's, side a), each carried by
// the cell that holds it at rest. False where no cell holds one.
bool edge_contact_sides(const Model& model, const EdgeHold& e, ContactRecord& r) {
  const auto rest = [&](Index v) -> const Vec3& { return model.surface_vertex_rest[v]; };
  const Vec3 on_edge = (1.0 - e.along) * rest(e.edge[0]) + e.along * rest(e.edge[1]);
  return surface_point(model, e.edge[0], on_edge, r.b) && triangle_point(model, e.triangle, e.barycentric, r.a);
}

// Whether an edge contact's points are within the speculative distance: apart along its
// normal by less (or crossed), and across it by less (they have not slid apart).
bool edge_points_near(const Vec3& normal, const Vec3& offset) {
  const double along = normal.dot(offset);
  return along < kSpeculativeDistance && (offset - along * normal).norm() < kSpeculativeDistance;
}

void add_edge_contact(const Bodies& bodies, StepMemory& scratch, const ContactRecord& r, const EdgeHold& source) {
  if (scratch.constraint_count < scratch.constraints.size())
    scratch.edge_sources[scratch.constraint_count - scratch.edge_contact_begin] = source;
  add_contact(bodies, scratch, r);
}

// Whether edge contacts c and d push their two cells opposite ways: between the same two
// cells, with normals turned to the same side's frame more than 90 degrees apart.
bool opposed(const ContactConstraint& c, const ContactConstraint& d) {
  const bool same = c.a.cell == d.a.cell && c.b.cell == d.b.cell;
  const bool swapped = c.a.cell == d.b.cell && c.b.cell == d.a.cell;
  return (same && c.normal.dot(d.normal) < 0.0) || (swapped && c.normal.dot(d.normal) > 0.0);
}

// Two edge contacts that push the same two cells opposite ways cannot both be met: a held
// contact whose normal a later crossing has turned round, an edge through both faces of a
// thin part, or two thin parts crossed through each other, an edge of each through the
// other's face. Each Gauss-Seidel pass moved the cells back and forth by the same fraction
// of a millimetre and the surfaces stayed crossed where the two met. Of such a pair the
// contact asking the lesser correction lets go; the list keeps its order. Two halves of
// one pair of cells can so win in turn from step to step (docs/limits.md, item 6). Every
// other rule tried left more random piles crossed: another winning (the one that moves the
// cells' centres apart, the contact held from the last step or the one asking the lesser
// correction, each everywhere or only where both halves ask one), or the larger asking only
// the difference of the two, which can hold two parts still where they cross.
void drop_opposed_edge_contacts(const Bodies& bodies, StepMemory& scratch) {
  const Index begin = scratch.edge_contact_begin, end = std::min(scratch.edge_contact_end, scratch.constraint_count);
  if (end - begin < 2) return;
  // The contacts by their unordered pair of cells, then by place in the list.
  const auto cells = [&](Index i) {
    const ContactConstraint& c = scratch.constraints[i];
    return std::pair{std::min(c.a.cell, c.b.cell), std::max(c.a.cell, c.b.cell)};
  };
  Index* order = scratch.edge_order.data();
  const Index count = end - begin;
  for (Index i = 0; i < count; ++i) order[i] = begin + i;
  std::sort(order, order + count, [&](Index i, Index j) { return std::pair{cells(i), i} < std::pair{cells(j), j}; });
  const auto correction = [&](const ContactConstraint& c) {
    return c.rest - c.normal.dot(bodies.point(c.b) - bodies.point(c.a));
  };
  std::uint8_t* dropped = scratch.edge_dropped.data();
  std::fill(dropped, dropped + count, std::uint8_t{0});
  for (Index g = 0, g_end = 0; g < count; g = g_end) {
    while (g_end < count && cells(order[g_end]) == cells(order[g])) ++g_end;
    for (Index i = g; i < g_end; ++i)
      for (Index j = i + 1; j < g_end; ++j) {
        const Index ci = order[i], cj = order[j];
        if (dropped[ci - begin] || dropped[cj - begin]) continue;
        const ContactConstraint &c = scratch.constraints[ci], &d = scratch.constraints[cj];
        if (opposed(c, d)) dropped[(correction(c) < correction(d) ? ci : cj) - begin] = 1;
      }
  }
  // (The edge contacts end the list here.)
  Index kept = begin;
  for (Index i = begin; i < end; ++i) {
    if (dropped[i - begin]) continue;
    scratch.constraints[kept] = scratch.constraints[i];
    scratch.edge_sources[kept - begin] = scratch.edge_sources[i - begin];
    ++kept;
  }
  scratch.constraint_count = scratch.edge_contact_end = kept;
}

}  // namespace

// The edge contacts ([simulation] edge_contacts, BoxLevel::solver_edges): each half of a pair of cells of two
// objects whose deepest edge crossing (find_crossed_edges) becomes a constraint between the
// point of the edge and the point of the triangle where they cross, each carried by the cell
// that holds it at rest, the edge to go back along the crossing's normal by its depth and the
// skin further (Model::surface_skin), as the paper's response puts a vertex, so that it is not
// found crossed again the next step: moved only to the face or the edge it passes, a letter
// leaning on a plate's rim touched it for ever (box_overlap_test.cpp). A carried point is
// where the lattice maps the surface's point, the crossing's where the flat triangles put it;
// where the two differ by more than the speculative distance the constraint would push the
// wrong point, and the crossing is left to the box contacts. Then the contacts the last step
// held (State::edge_holds) and this one did not find crossed, speculative; of two that push
// the same two cells opposite ways, one lets go (drop_opposed_edge_contacts).
void find_edge_contacts(const Model& model, const BoxLevel& level, State& state, StepMemory& scratch,
                        StageCounters& counters, double& max_depth) {
  const Bodies bodies{model, state, scratch};
  find_crossed_edges(model, *level.boxes, state, scratch, counters);
  scratch.edge_contact_begin = scratch.constraint_count;
  Index crossed = 0;
  for (Index i = 0; i < scratch.edge_crossing_count; ++i) {
    const EdgeCrossing& crossing = scratch.edge_crossings[i];
    const EdgeHold source{contact_key(ContactKey::SurfaceEdge, state.params.accuracy, crossing.triangle, crossing.edge[0]),
                          crossing.edge,
                          crossing.along,
                          crossing.triangle,
                          crossing.barycentric,
                          crossing.normal};
    ContactRecord r;
    if (!edge_contact_sides(model, source, r)) continue;
    if ((bodies.point(r.b) - crossing.point).norm() > kSpeculativeDistance ||
        (bodies.point(r.a) - crossing.point).norm() > kSpeculativeDistance)
      continue;
    r.normal = crossing.normal;
    r.depth = crossing.depth + model.surface_skin;
    r.key = source.key;
    ++counters.inter_contacts;
    max_depth = std::max(max_depth, crossing.depth);
    scratch.record_contact(crossing.point, crossing.normal, crossing.depth, ContactKind::Inter);
    add_edge_contact(bodies, scratch, r, source);
    if (crossed < scratch.crossing_keys.size()) scratch.crossing_keys[crossed++] = source.key;
  }
  // The contacts the last step held and this one did not find crossed: speculative while
  // their points stay near, holding the edge the skin in front of the triangle.
  const auto keys = scratch.crossing_keys.begin();
  std::sort(keys, keys + crossed);
  for (std::size_t h = 0; h < state.edge_hold_count; ++h) {
    const EdgeHold& hold = state.edge_holds[h];
    if (std::binary_search(keys, keys + crossed, hold.key)) continue;
    ContactRecord r;
    if (!edge_contact_sides(model, hold, r)) continue;
    const Vec3 offset = bodies.point(r.b) - bodies.point(r.a);
    if (!edge_points_near(hold.normal, offset)) continue;
    r.normal = hold.normal;
    r.depth = model.surface_skin - hold.normal.dot(offset);
    r.key = hold.key;
    add_edge_contact(bodies, scratch, r, hold);
  }
  scratch.edge_contact_end = scratch.constraint_count;
  drop_opposed_edge_contacts(bodies, scratch);
}

void find_plane_contacts(const Model& model, const BoxLevel& level, State& state, StepMemory& scratch,
                         StageCounters& counters, double& max_depth) {
  const BoxSet& boxes = *level.boxes;
  const Bodies bodies{model, state, scratch};
  // Within kSpeculativeDistance above the plane, a node gets a contact too, as in a box: held
  // at the plane should the solve move it in. Without it a node resting on a plane was pushed
  // out in one step and pulled back through by its springs in the next, and swung so for
  // ever (docs/notes/2026-11-28-code-findings.md#speculative-plane-contacts).
  const double margin = kSpeculativeDistance;
  const int node_count = tested_node_count(level);
  const Accuracy accuracy = state.params.accuracy;
  // Side b's point (`side`, at `p`) `height` above the plane: a contact within the margin.
  const auto plane_contact = [&](const PlaneModel& plane, const ContactSide& side, const Vec3& p, double height,
                                 std::uint64_t key) {
    ++counters.node_tests;
    if (!(height < margin)) return;
    if (height < 0.0) {
      ++counters.plane_contacts;
      max_depth = std::max(max_depth, -height);
      scratch.record_contact(p, plane.normal, -height, ContactKind::Plane);
    }
    ContactRecord r;
    r.a = static_side();
    r.b = side;
    r.normal = plane.normal;
    r.depth = -height;
    r.key = key;
    add_contact(bodies, scratch, r);
  };
  for (Index plane_index = 0; plane_index < model.planes.size(); ++plane_index) {
    const PlaneModel& plane = model.planes[plane_index];
    for (Index b = 0; b < boxes.size(); ++b) {
      const Index cell = boxes.box_cell[b];
      if (!scratch.object_solving[model.cell_object[cell]]) continue;  // frozen where it rests
      double support = -plane.offset;  // the box's AABB bounds its nodes
      for (int axis = 0; axis < 3; ++axis)
        support += plane.normal[axis] * (plane.normal[axis] > 0.0 ? scratch.box_lo[axis][b] : scratch.box_hi[axis][b]);
      if (support >= margin) continue;
      if (level.exact) {
        // Level 5: the cell's surface vertices.
        for (Index i = model.cell_vertex_begin[cell]; i < model.cell_vertex_begin[cell + 1]; ++i) {
          const Index vertex = model.cell_vertices[i];
          const ContactSide side = vertex_point(model, vertex);
          const Vec3 p = bodies.point(side);
          plane_contact(plane, side, p, plane.normal.dot(p) - plane.offset,
                        contact_key(ContactKey::PlaneVertex, accuracy, plane_index, vertex));
        }
        continue;
      }
      for (int k = 0; k < node_count; ++k) {
        const Vec3 p = tested_node(model, level, state, scratch, b, k);
        plane_contact(plane, cell_point(model, cell, tested_node_local(model, level, b, k)), p,
                      plane.normal.dot(p) - plane.offset, plane_contact_key(accuracy, plane_index, b, k));
      }
    }
  }
}

void find_probe_contacts(const Model& model, const BoxSet& boxes, State& state, StepMemory& scratch,
                         StageCounters& counters, double& max_depth) {
  ProbeState& probe = state.probe;
  scratch.probe_x_prev = probe.x;
  scratch.probe_device_velocity = step_probe_coupling(model, state);  // the proxy's prediction

  const Bodies bodies{model, state, scratch};
  find_probe_box_contacts(
      model, boxes, state, scratch, counters, max_depth,
      [&](Index b) { wake(state, model.cell_object[boxes.box_cell[b]]); },
      [&](const ProbeContact& c) {
        ContactRecord r;
        if (c.node >= 0) {  // the box's node (side b) stays out of the sphere (side a)
          r.a = probe_point();
          r.b = cell_point(model, c.cell, boxes.box_local[c.box][static_cast<std::size_t>(c.node)]);
        } else {  // the probe (side b) stays out of the box's face (side a)
          r.a = face_point(model, boxes, c.box, c.face);
          r.b = probe_point();
        }
        r.normal = c.normal;
        r.depth = c.depth;
        add_contact(bodies, scratch, r);
        return false;  // answered in the solve, not at once
      });
}

namespace {

// A contact's friction: a tangential correction that brings its points back to their held
// offset (its anchor, or where the step began) within the Coulomb cone |friction| <= mu lambda,
// lambda its normal correction so far.
void project_friction(const Bodies& bodies, ContactConstraint& c, double mu) {
  const double load = c.lambda + c.pushed;  // m
  if (!(mu > 0.0) || !(load > 0.0) || c.lodged) return;
  const Vec3 slide = (bodies.point(c.b) - bodies.point(c.a)) - c.hold;
  const Vec3 tangential = slide - c.normal.dot(slide) * c.normal;
  Vec3 friction = c.friction - tangential / c.inv_mass;
  const double limit = mu * load, size = friction.norm();
  if (size > limit) friction *= limit / size;
  const Vec3 delta = friction - c.friction;
  c.friction = friction;
  bodies.move(c.b, delta);
  bodies.move(c.a, -delta);
}

enum class ContactPass {
  All,     // every contact: non-penetration, then friction
  Planes,  // the plane contacts alone, likewise: the planes have the last word
  Edges,   // the edge contacts' non-penetration alone, after the friction passes
};

// One pass over the contact list: each contact's non-penetration (an inequality: its
// correction lambda stays >= 0), then its friction (none in an Edges pass). Returns the
// largest normal correction the pass made, m.
double project_contacts(const Bodies& bodies, StepMemory& scratch, double mu, ContactPass pass) {
  const bool edges = pass == ContactPass::Edges;
  if (edges) mu = 0.0;
  const Index begin = edges ? scratch.edge_contact_begin : 0;
  const Index end = edges ? std::min(scratch.edge_contact_end, scratch.constraint_count) : scratch.constraint_count;
  double largest = 0.0;
  for (Index i = begin; i < end; ++i) {
    ContactConstraint& c = scratch.constraints[i];
    if (!(c.inv_mass > 0.0)) continue;
    if (pass == ContactPass::Planes && c.a.count != 0) continue;
    const Vec3 pa = bodies.point(c.a), pb = bodies.point(c.b);
    const double C = c.normal.dot(pb - pa) - c.rest;
    const double lambda = std::max(c.lambda - C / c.inv_mass, 0.0);
    const double d_lambda = lambda - c.lambda;
    c.lambda = lambda;
    if (d_lambda != 0.0) {
      bodies.move(c.b, d_lambda * c.normal);
      bodies.move(c.a, -d_lambda * c.normal);
      largest = std::max(largest, std::abs(d_lambda) * c.inv_mass);
    }
    project_friction(bodies, c, mu);
  }
  return largest;
}

// The resting contacts whose friction can act, in list order, into scratch.friction_contacts:
// those that pushed in the pass just made (lambda > 0) and are neither approaching nor lodged.
// Their normal corrections are held through the friction passes, so the set does not change
// there; the passes visit these alone (on the teapots at rest, most of the list is
// speculative contacts that never push).
void gather_friction_contacts(StepMemory& scratch, double mu) {
  Index count = 0;
  for (Index i = 0; i < scratch.constraint_count && mu > 0.0; ++i) {
    const ContactConstraint& c = scratch.constraints[i];
    if (c.inv_mass > 0.0 && c.lambda + c.pushed > 0.0 && !c.lodged && !(c.approach < -kRestingApproach))
      scratch.friction_contacts[count++] = i;
  }
  scratch.friction_contact_count = count;
}

// One pass over the resting contacts' friction alone, their normal corrections held.
void project_resting_friction(const Bodies& bodies, StepMemory& scratch, double mu) {
  for (Index k = 0; k < scratch.friction_contact_count; ++k)
    project_friction(bodies, scratch.constraints[scratch.friction_contacts[k]], mu);
}

// The grab (interaction.h), solved with the rest as a position correction each iteration:
// the point moves by dt times the spring's change of velocity, and the force it gave so far
// (Scratch::grab_force) enters the next, so that a heavy object hangs from it without the
// explicit spring's overshoot.
void project_grab(const Model& model, const Bodies& bodies, StepMemory& scratch) {
  const GrabState& grab = bodies.state.grab;
  ContactSide side = cell_point(model, grab.cell, grab.local);
  bodies.prepare(side);
  const double w = bodies.weighted_inv_mass(side);
  if (!(w > 0.0)) return;
  const double dt = model.settings.dt / scratch.substeps;  // s: the step, or the substep
  const Vec3 p = bodies.point(side);
  const Vec3 velocity = (p - bodies.point_start(side)) / dt;
  const Vec3 moved = dt * grab_velocity_change(model, w, grab.target - p, velocity, scratch.grab_force, dt);  // m
  scratch.grab_force += moved / (w * dt * dt);
  bodies.move(side, moved / w);
}

}  // namespace

namespace {

// A contact side's body for eq. 8: its cell (mean velocity of the 8 nodes, the cell's inverse
// mass), the probe, or nothing (a plane: inverse mass 0, velocity 0).
struct SideBody {
  Vec3 v = Vec3::Zero();
  double inv_mass = 0.0;
};
SideBody side_body(const Model& model, const State& state, const StepMemory& scratch, const ContactSide& s) {
  SideBody body;
  if (s.count == 0) return body;
  if (s.cell == kNoIndex) return {state.probe.v, probe_inv_mass(model, state)};
  body.v = mean_velocity(state, model.cell_nodes[s.cell]);
  body.inv_mass = scratch.object_solving[model.cell_object[s.cell]] ? model.cell_inv_mass[s.cell] : 0.0;
  return body;
}

void set_side_velocity(const Model& model, State& state, const ContactSide& s, const SideBody& body,
                       const Vec3& v_ref, const Vec3& n, double beta) {
  if (!(body.inv_mass > 0.0)) return;
  if (s.cell == kNoIndex) {
    state.probe.v = respond_velocity(state.probe.v, v_ref, n, 1.0, beta);
    return;
  }
  for (Index i : model.cell_nodes[s.cell]) state.v[i] = respond_velocity(state.v[i], v_ref, n, 1.0, beta);
}

// One pass over the nodes of contacts' cells (and the probe) that visits each node once: a
// node shared by several contacts' cells is visited for the first of them only. Each pass
// takes a fresh mark (Scratch::node_stamp_epoch), so marks left by earlier passes, steps or
// runs on the same Scratch never match.
class NodeVisit {
 public:
  NodeVisit(const Model& model, State& state, StepMemory& scratch)
      : model_(model), state_(state), scratch_(scratch), mark_(++scratch.node_stamp_epoch) {}
  // Calls f(velocity, mass) for each node of side s not visited yet in this pass.
  template <class F>
  void side(const ContactSide& s, F&& f) {
    if (s.count == 0) return;  // a plane
    if (s.cell == kNoIndex) {
      if (!probe_seen_) f(state_.probe.v, model_.settings.probe.mass);
      probe_seen_ = true;
      return;
    }
    for (Index n : model_.cell_nodes[s.cell]) {
      if (scratch_.node_stamp[n] == mark_) continue;
      scratch_.node_stamp[n] = mark_;
      f(state_.v[n], model_.node_mass[n]);
    }
  }

 private:
  const Model& model_;
  State& state_;
  StepMemory& scratch_;
  std::uint64_t mark_;
  bool probe_seen_ = false;
};

// The kinetic energy (J) of the nodes of the cells in active contacts, and of the probe if it
// is in one, each counted once.
double answered_energy(const Model& model, State& state, StepMemory& scratch) {
  double energy = 0.0;
  NodeVisit visit(model, state, scratch);
  const auto add = [&energy](const Vec3& v, double m) { energy += 0.5 * m * v.squaredNorm(); };
  for (Index i = 0; i < scratch.constraint_count; ++i) {
    const ContactConstraint& c = scratch.constraints[i];
    if (!(c.lambda > 0.0) || !(c.inv_mass > 0.0)) continue;
    visit.side(c.a, add);
    visit.side(c.b, add);
  }
  return energy;
}

// The rebound of the contacts found approaching: each node of their cells, stopped by the
// velocity pass, leaves along n at its side's share of -(1 - alpha) approach, times `scale`,
// once whatever the number of contacts its cells are in. Returns the kinetic energy it adds
// as A scale + B scale^2 (J): {A, B} for scale 1.
std::array<double, 2> rebound(const Model& model, State& state, StepMemory& scratch, double scale) {
  const double alpha = state.params.alpha;
  std::array<double, 2> added{0.0, 0.0};
  NodeVisit visit(model, state, scratch);
  auto kick = [&](const ContactSide& s, const SideBody& body, const Vec3& dv) {
    if (!(body.inv_mass > 0.0)) return;  // static: a plane, a sleeper
    visit.side(s, [&](Vec3& v, double mass) {
      added[0] += mass * v.dot(dv);
      added[1] += 0.5 * mass * dv.squaredNorm();
      v += dv;
    });
  };
  for (Index i = 0; i < scratch.constraint_count; ++i) {
    const ContactConstraint& c = scratch.constraints[i];
    if (!(c.lambda > 0.0) || !(c.inv_mass > 0.0) || !(c.approach < -kRestingApproach)) continue;
    const SideBody a = side_body(model, state, scratch, c.a), b = side_body(model, state, scratch, c.b);
    const PositionShares share = position_shares(a.inv_mass, b.inv_mass);
    const double bounce = -(1.0 - alpha) * c.approach * scale;  // m/s
    kick(c.a, a, -share.a * bounce * c.normal);
    kick(c.b, b, share.b * bounce * c.normal);
  }
  return added;
}

enum class Rebound { No, Yes };  // the rebound once a step: not after each substep

// The velocities after the solve, contact by contact in list order, for each contact that
// pushed: eq. 8 on its two cells' nodes, relative to the pair's mass-weighted mean velocity
// v_ref, with the normal part stopped; then the rebound: -(1 - alpha) of the approach the
// contact was found with (response.h), none for a resting contact. The tangential part is
// stopped where the contact stuck and kept where it slid (Coulomb's friction acted in the
// solve). So alpha and beta mean what they mean in the paper (beta as Coulomb's mu), and a
// position correction of the solve never leaves as metres per second (v = dx / dt of a
// millimetre is 1 m/s).
void answer_velocities(const Model& model, State& state, StepMemory& scratch, double beta, Rebound rebound_now) {
  const bool rebounds = rebound_now == Rebound::Yes && state.params.alpha < 1.0;
  const double energy_before = rebounds ? answered_energy(model, state, scratch) : 0.0;  // J
  for (Index i = 0; i < scratch.constraint_count; ++i) {
    const ContactConstraint& c = scratch.constraints[i];
    if (!(c.lambda > 0.0) || !(c.inv_mass > 0.0)) continue;
    const SideBody a = side_body(model, state, scratch, c.a), b = side_body(model, state, scratch, c.b);
    const PositionShares share = position_shares(a.inv_mass, b.inv_mass);
    if (!(share.a + share.b > 0.0)) continue;
    // v_ref: the mass-weighted mean; a static side's velocity (zero) where there is one.
    Vec3 v_ref = a.inv_mass > 0.0 ? b.v : a.v;
    if (a.inv_mass > 0.0 && b.inv_mass > 0.0) v_ref = (a.v / a.inv_mass + b.v / b.inv_mass) / (1.0 / a.inv_mass + 1.0 / b.inv_mass);
    // A contact whose friction held inside the Coulomb cone in the solve sticks: static
    // friction, its tangential motion stopped (kept at 1 - beta, the sticking nodes under a
    // box at rest swung sideways every other step). One that slid keeps its tangential
    // motion: the solve's kinetic friction, mu lambda, is its friction. Taking 1 - beta of it
    // as well was a drag in proportion to the speed, not to the load: a letter lightly pressed
    // against a wall hung there (docs/notes/2026-11-28-code-findings.md#sliding-contacts).
    // A lodged node's contact has no friction in the solve and keeps 1 - beta here, eq. 8.
    const bool stuck = sticks(c, beta);
    const double tangential_loss = stuck ? 1.0 : c.lodged ? beta : 0.0;
    set_side_velocity(model, state, c.a, a, v_ref, c.normal, tangential_loss);
    set_side_velocity(model, state, c.b, b, v_ref, c.normal, tangential_loss);
  }
  if (!rebounds) return;
  // The stop and the rebound together never add kinetic energy to the nodes they answer: a
  // cell's rebound is its pair's, but cells share nodes, and a node in several pairs is pulled
  // several ways by the stop: two spheres meeting head on at alpha = 0 left faster than they
  // came until the rebound was bounded by what the stop took.
  const double allowed = std::max(0.0, energy_before - answered_energy(model, state, scratch));  // J
  const std::array<double, 2> added = rebound(model, state, scratch, 1.0);
  if (!(added[0] + added[1] > allowed)) return;
  // The scale s in [0, 1] at which A s + B s^2 = allowed; the rebound is taken back to it.
  const double A = added[0], B = added[1];
  double s = 0.0;
  if (B > 0.0) s = std::clamp((-A + std::sqrt(std::max(0.0, A * A + 4.0 * B * allowed))) / (2.0 * B), 0.0, 1.0);
  rebound(model, state, scratch, s - 1.0);
}

// The rigid part of an object's motion: centre and its velocity, inertia about it, spin (I^-1 L).
void measure_motion(const Model& model, const State& state, Index object, SolverMemory::ObjectMotion& s) {
  const ObjectModel& obj = model.objects[object];
  const Vec3 centre = centre_of_mass(model, state.x, object);
  double mass = 0.0;
  Vec3 momentum = Vec3::Zero(), linear = Vec3::Zero();
  Mat3 inertia = Mat3::Zero();
  for (Index n = obj.node_begin; n < obj.node_end; ++n) {
    const Vec3 r = state.x[n] - centre;
    mass += model.node_mass[n];
    linear += model.node_mass[n] * state.v[n];
    momentum += model.node_mass[n] * r.cross(state.v[n]);
    inertia += model.node_mass[n] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
  }
  s.centre = centre;
  s.velocity = linear / mass;
  s.mass = mass;
  s.inertia = inertia;
  const Eigen::FullPivLU<Mat3> lu(inertia);
  s.omega = lu.isInvertible() ? Vec3(lu.solve(momentum)) : Vec3::Zero();
}

// `change` cut so that `motion + change` is no larger than `motion`: the supports' own motion
// is measured from their nodes, deformation and all, and following it would make a resting
// object creep until it slipped off its rest.
Vec3 never_faster(const Vec3& motion, const Vec3& change) {
  const double along = change.dot(motion), size_sq = change.squaredNorm();
  if (!(size_sq > 0.0)) return change;
  return std::clamp(-2.0 * along / size_sq, 0.0, 1.0) * change;
}

// What a resting object's supports do to its rigid motion, after the velocity pass. Two
// bounded corrections, each measured against the supports' own motion (the load-weighted
// mean over the partners of its active contacts; a plane is still) and capped by the
// contacts' normal force, Coulomb-like, so that they stop small motions within a few steps
// and barely slow large ones:
// - rolling resistance: the object's spin relative to its supports', slowed by at most
//   rolling_resistance x (normal force) x (radius of gyration) of torque, as Box2D's rolling
//   resistance (a contact alone cannot stop an object rolling on a curved support: the upper
//   teapot rocked on the lower one's knob for seconds), turned about the contacts' load
//   centre, so that the velocities the contacts left there stay (about its own centre the
//   contact points slid and the upper teapot slid off the knob). It stands for the grip of
//   the contact patch, so a frictionless contact (beta = 0) has none: a frictionless ball
//   resting off centre on a box, its spin slowed, pushed itself and the box sideways;
// - support damping: the object's velocity along its resting contacts' mean normal relative
//   to its supports', taken away at alpha's share, by at most the contacts' normal force:
//   alpha is the contact's damping, for a resting object as for an impact (the upper teapot
//   bobbed on the lower one for seconds; damping its deformation did nothing, the motion is
//   its centre's).
// Neither ever makes the object move or spin faster than it does. Everything is measured
// before anything changes, so the objects' order does not matter.
void damp_on_supports(const Model& model, State& state, StepMemory& scratch, double beta) {
  const double resistance = beta > 0.0 ? model.settings.rolling_resistance : 0.0, alpha = state.params.alpha;
  if (!(resistance > 0.0) && !(alpha > 0.0)) return;
  const Bodies bodies{model, state, scratch};
  for (SolverMemory::ObjectMotion& s : scratch.object_motion) s.touched = false;
  auto object_of = [&](const ContactSide& side) -> Index {
    if (side.count == 0 || side.cell == kNoIndex) return kNoIndex;  // a plane, the probe
    const Index o = model.cell_object[side.cell];
    return scratch.object_solving[o] ? o : kNoIndex;
  };
  auto is_probe = [](const ContactSide& side) { return side.count > 0 && side.cell == kNoIndex; };
  for (Index i = 0; i < scratch.constraint_count; ++i) {
    const ContactConstraint& c = scratch.constraints[i];
    if (!(c.lambda > 0.0)) continue;
    for (const Index o : {object_of(c.a), object_of(c.b)})
      if (o != kNoIndex && !scratch.object_motion[o].touched) {
        scratch.object_motion[o] = SolverMemory::ObjectMotion{};
        measure_motion(model, state, o, scratch.object_motion[o]);
        scratch.object_motion[o].touched = true;
      }
  }
  for (Index i = 0; i < scratch.constraint_count; ++i) {
    const ContactConstraint& c = scratch.constraints[i];
    if (!(c.lambda > 0.0) || is_probe(c.a) || is_probe(c.b)) continue;  // the hand is no support
    const Index a = object_of(c.a), b = object_of(c.b);
    if (a == b) continue;  // within one object: nothing relative
    const Vec3 where = bodies.point(c.b);
    const bool resting = c.approach > -kRestingApproach;
    // Each side's support is the other; side b is pushed along +n, side a along -n.
    for (int side = 0; side < 2; ++side) {
      const Index self = side == 0 ? a : b, other = side == 0 ? b : a;
      if (self == kNoIndex) continue;
      SolverMemory::ObjectMotion& s = scratch.object_motion[self];
      const SolverMemory::ObjectMotion* support = other != kNoIndex ? &scratch.object_motion[other] : nullptr;
      s.load += c.lambda;
      s.pivot += c.lambda * where;
      if (support) s.support_spin += c.lambda * support->omega;
      if (!resting) continue;
      s.resting_load += c.lambda;
      s.up += (side == 0 ? -c.lambda : c.lambda) * c.normal;
      if (support) s.support_velocity += c.lambda * support->velocity;
    }
  }
  // A multiplier is an impulse times the time it acted over, h (the step, or the substep:
  // the load then sums the substeps'), so the step's normal force is load / (h dt). Both
  // caps below are what that force gives in h, load / dt: a step's worth without substeps,
  // one substep's with them. A step's worth with substeps made both act too hard: the
  // support damping pressed two stacked slabs into each other and correcting that depth
  // gave energy back, and the rolling resistance left random piles of thin parts crossed.
  const double dt = model.settings.dt;  // s
  for (std::size_t o = 0; o < scratch.object_motion.size(); ++o) {
    const SolverMemory::ObjectMotion& s = scratch.object_motion[o];
    if (!s.touched || !(s.load > 0.0)) continue;
    const ObjectModel& obj = model.objects[o];
    // Rolling resistance: the angular impulse that stops the relative spin, capped at
    // resistance x (load / dt) x radius of gyration.
    const Eigen::FullPivLU<Mat3> lu(s.inertia);  // 3 x 3: cheaper to redo than to keep
    const double radius = std::sqrt(0.5 * s.inertia.trace() / s.mass);
    const Vec3 relative_spin = s.omega - s.support_spin / s.load;
    if (resistance > 0.0 && lu.isInvertible() && relative_spin.norm() * radius > kSpinNoise) {
      const Vec3 stop = -(s.inertia * relative_spin);  // N m s
      const double most = resistance * (s.load / dt) * radius, size = stop.norm();
      const Vec3 change = never_faster(s.omega, lu.solve(size > most ? Vec3(stop * (most / size)) : stop));  // rad/s
      const Vec3 pivot = s.pivot / s.load;
      for (Index n = obj.node_begin; n < obj.node_end; ++n) state.v[n] += change.cross(state.x[n] - pivot);
    }
    // Support damping: alpha of the relative normal velocity, capped at what the resting
    // contacts' share of the load changes (resting_load / dt / m).
    const double up_size = s.up.norm();
    if (alpha > 0.0 && s.resting_load > 0.0 && up_size > 0.0) {
      const Vec3 up = s.up / up_size;
      const Vec3 support = s.support_velocity / s.resting_load;
      const double relative = up.dot(s.velocity - support);  // m/s
      const double most = s.resting_load / dt / s.mass;
      Vec3 change = -alpha * std::clamp(relative, -most, most) * up;
      // Supports moving slower than this are still: their nodes' noise is not followed.
      if (std::fabs(up.dot(support)) < kRestingApproach) change = never_faster(s.velocity.dot(up) * up, change);
      for (Index n = obj.node_begin; n < obj.node_end; ++n) state.v[n] += change;
    }
  }
}

// The contacts that pushed and stuck keep what their friction held as their anchors for the
// next step; the others let go (a contact that slid starts again from where it ends the step).
void keep_anchors(const Model& model, State& state, StepMemory& scratch, double mu) {
  const Bodies bodies{model, state, scratch};
  const BoxSet* boxes = box_level(model, state.params.accuracy).boxes;
  std::size_t count = 0;
  for (Index i = 0; i < scratch.constraint_count && mu > 0.0; ++i) {
    const ContactConstraint& c = scratch.constraints[i];
    if (c.key == 0 || !(c.lambda > 0.0) || !sticks(c, mu)) continue;
    scratch.next_anchors[count++] = ContactAnchor{c.key, Vec3(anchor_frame(bodies, boxes, c).transpose() * c.hold)};
  }
  const auto begin = scratch.next_anchors.begin();
  std::sort(begin, begin + static_cast<std::ptrdiff_t>(count),
            [](const ContactAnchor& a, const ContactAnchor& b) { return a.key < b.key; });
  state.anchor_count = std::min(count, state.anchors.size());  // beyond the room: not anchored
  std::copy(begin, begin + static_cast<std::ptrdiff_t>(state.anchor_count), state.anchors.begin());
}

// The edge contacts whose points end the step near each other are held into the next
// (State::edge_holds); the others let go.
void keep_edge_holds(const Model& model, State& state, StepMemory& scratch) {
  const Bodies bodies{model, state, scratch};
  std::size_t count = 0;
  const Index end = std::min(scratch.edge_contact_end, scratch.constraint_count);
  for (Index i = scratch.edge_contact_begin; i < end; ++i) {
    const ContactConstraint& c = scratch.constraints[i];
    if (c.key != 0 && edge_points_near(c.normal, bodies.point(c.b) - bodies.point(c.a)))
      scratch.next_edge_holds[count++] = scratch.edge_sources[i - scratch.edge_contact_begin];
  }
  const auto begin = scratch.next_edge_holds.begin();
  const auto by_key = [](const EdgeHold& a, const EdgeHold& b) { return a.key < b.key; };
  std::sort(begin, begin + static_cast<std::ptrdiff_t>(count), by_key);
  const auto kept = std::unique(begin, begin + static_cast<std::ptrdiff_t>(count),
                                [](const EdgeHold& a, const EdgeHold& b) { return a.key == b.key; });
  state.edge_hold_count = std::min(static_cast<std::size_t>(kept - begin), state.edge_holds.size());
  std::copy(begin, begin + static_cast<std::ptrdiff_t>(state.edge_hold_count), state.edge_holds.begin());
}

// Substep k of the solve (solver_substeps): the objects' and the probe's predictions over
// h = dt / substeps from where the substep before left them; each contact's normal correction
// so far moved to `pushed`, so that a later substep never pulls back what an earlier one
// pushed (its multiplier restarts at 0, its load stays for friction); the grab's force
// restarts with its own integration over h.
void begin_solver_substep(const Model& model, int k, State& state, StepMemory& scratch) {
  begin_substep(model, k, state, scratch, scratch.pool);
  if (has(model.settings.effects, Effect::Probe)) {
    const double h = model.settings.dt / scratch.substeps;  // s
    const Vec3 u = k == 0 ? state.probe.v : Vec3((state.probe.x - scratch.probe_x_sub) / h);  // m/s
    scratch.probe_x_sub = k == 0 ? scratch.probe_x_prev : state.probe.x;
    state.probe.x = scratch.probe_x_sub + h * u;
  }
  if (k > 0)
    for (Index i = 0; i < scratch.constraint_count; ++i) {
      ContactConstraint& c = scratch.constraints[i];
      c.pushed += c.lambda;
      c.lambda = 0.0;
    }
  scratch.grab_force = Vec3::Zero();
}

}  // namespace

void solve_contacts(const Model& model, State& state, StepMemory& scratch) {
  const Bodies bodies{model, state, scratch};
  for (Index i = 0; i < scratch.constraint_count; ++i) {
    ContactConstraint& c = scratch.constraints[i];
    c.inv_mass = bodies.weighted_inv_mass(c.a) + bodies.weighted_inv_mass(c.b);
    bodies.prepare(c.a);
    bodies.prepare(c.b);
  }
  const double beta = has(model.settings.effects, Effect::Friction) ? state.params.beta : 0.0;
  const bool grabbing = has(model.settings.effects, Effect::Grab) && state.grab.active;
  if (grabbing) wake(state, model.cell_object[state.grab.cell]);  // solved from the next step if asleep now
  // Where level 5's vertex contacts are answered at once, eq. 9 moves whole cells as under the
  // paper's response and a cell inside out comes back by itself; restoring cells there left
  // the hard bunnies' surfaces crossed at level 5.
  const bool keep_upright = !box_level(model, state.params.accuracy).vertex_contacts_at_once();
  const int iterations = dynamics_iterations(model);
  const int friction_passes = beta > 0.0 ? kFrictionPasses : 0;
  const bool substeps = scratch.substeps > 1;
  for (int it = 0; it < iterations; ++it) {
    if (substeps) begin_solver_substep(model, it, state, scratch);
    sweep_dynamics(model, it, state, scratch, scratch.pool);
    project_contacts(bodies, scratch, beta, ContactPass::All);  // Coulomb, mu = beta
    if (friction_passes > 0) gather_friction_contacts(scratch, beta);
    for (int pass = 0; pass < friction_passes; ++pass) project_resting_friction(bodies, scratch, beta);
    // The edge contacts have the last word over the friction passes: a resting box contact's
    // friction holds its points at their anchor, and where an edge's way out is oblique to
    // the box faces the passes take back most of what the contact pass pushed it out, so
    // that the edge ends each solve crossed again.
    if (friction_passes > 0) project_contacts(bodies, scratch, beta, ContactPass::Edges);
    if (it == iterations - 1)  // kEdgePasses says why
      for (int pass = 0; pass < kEdgePasses; ++pass)
        if (!(project_contacts(bodies, scratch, beta, ContactPass::Edges) >= kEdgeConverged)) break;
    if (grabbing) project_grab(model, bodies, scratch);
    // The contacts move the nodes that carry their points, and in a sweep or few a hard
    // lattice gives way around them: a node pushed through its cell's opposite face leaves
    // the cell inside out, which the next sweep's springs would keep.
    if (keep_upright) restore_inverted_cells(model, state, scratch, scratch.pool);
    // Each substep's velocities answered as the step's are (XPBD with small steps, Macklin et
    // al. 2019, has a velocity pass per substep): a correction within a substep otherwise
    // leaves as depth / h into the next one's prediction, a bounce that no rest damps out.
    // The rebound stays once a step, at its end.
    if (substeps && it + 1 < iterations) {
      end_substep(model, state, scratch, scratch.pool);
      answer_velocities(model, state, scratch, beta, Rebound::No);
    }
  }
  // The planes have the last word: a node the sweeps left below a plane is put back on it.
  // Without this pass the last contacts of a pass (the probe's) pushed a box's nodes through
  // the floor (the `probe_force` hard case).
  project_contacts(bodies, scratch, beta, ContactPass::Planes);
  if (substeps)  // the step's whole normal correction, as the velocity pass reads it
    for (Index i = 0; i < scratch.constraint_count; ++i) {
      ContactConstraint& c = scratch.constraints[i];
      c.lambda += c.pushed;
      c.pushed = 0.0;
    }
  keep_anchors(model, state, scratch, beta);
  keep_edge_holds(model, state, scratch);
  finish_dynamics(model, state, scratch, scratch.pool);
  const double dt = model.settings.dt;
  if (has(model.settings.effects, Effect::Probe)) {
    ProbeState& probe = state.probe;
    probe.v = (probe.x - scratch.probe_x_prev) / dt;
    answer_velocities(model, state, scratch, beta, Rebound::Yes);
    damp_on_supports(model, state, scratch, beta);
    probe.force = probe_force(model, state, scratch.probe_device_velocity);
  } else {
    answer_velocities(model, state, scratch, beta, Rebound::Yes);
    damp_on_supports(model, state, scratch, beta);
  }
  if (grabbing) state.grab.force = scratch.grab_force;
}

}  // namespace ffd
