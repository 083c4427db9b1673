#include "paper_response.h"

#include "ffd/response.h"

namespace ffd {

Vec3 mean_velocity(const State& state, const std::array<Index, 8>& nodes) {
  Vec3 v = Vec3::Zero();
  for (Index n : nodes) v += state.v[n];
  return v * 0.125;
}

namespace {

// A side as eq. 8 sees it: its velocity, its mass and inverse mass, whether it is static.
struct Motion {
  Vec3 v = Vec3::Zero();  // m/s
  double inv_mass = 0.0;  // 1/kg (0: static)
  double mass = 0.0;      // kg
  bool fixed = true;
};

Motion motion_of(const Model& model, const State& state, const ResponseSide& side) {
  Motion m;
  switch (side.kind) {
    case ResponseSide::Kind::Plane: break;
    case ResponseSide::Kind::Cell:
      m.v = mean_velocity(state, model.cell_nodes[side.cell]);
      // An object asleep is static here: infinite mass, velocity zero (sleep.h).
      m.fixed = side.held || state.asleep[model.cell_object[side.cell]];
      if (!m.fixed) {
        m.inv_mass = model.cell_inv_mass[side.cell];
        m.mass = 1.0 / m.inv_mass;
      }
      break;
    case ResponseSide::Kind::Probe:
      m.v = state.probe.v;
      m.fixed = false;
      m.mass = model.settings.probe.mass;
      m.inv_mass = 1.0 / m.mass;
      break;
  }
  return m;
}

// Eq. 8 on a moving side's velocities, then its share of the rebound.
void set_velocity(const Model& model, State& state, const ResponseSide& side, const Vec3& v_ref, const Vec3& n,
                  double alpha, double beta, const Vec3& kick) {
  if (side.kind == ResponseSide::Kind::Probe) {
    state.probe.v = respond_velocity(state.probe.v, v_ref, n, alpha, beta) + kick;
  } else if (side.kind == ResponseSide::Kind::Cell) {
    for (Index i : model.cell_nodes[side.cell]) state.v[i] = respond_velocity(state.v[i], v_ref, n, alpha, beta) + kick;
  }
}

// Eq. 9 on a side's positions (a static cell's move is zero).
void move(const Model& model, State& state, const ResponseSide& side, const Vec3& by) {
  if (side.kind == ResponseSide::Kind::Probe) {
    state.probe.x += by;
  } else if (side.kind == ResponseSide::Kind::Cell) {
    for (Index i : model.cell_nodes[side.cell]) state.x[i] += by;
  }
}

}  // namespace

void answer_at_once(const Model& model, State& state, const ResponseSide& a, const ResponseSide& b, const Vec3& n,
                    double r, double beta, bool may_rebound) {
  const Motion ma = motion_of(model, state, a), mb = motion_of(model, state, b);
  const double u = (mb.v - ma.v).dot(n);
  const PositionShares share = position_shares(ma.inv_mass, mb.inv_mass);
  if (u < 0.0) {  // eq. 8 only while the sides approach
    Vec3 v_ref = ma.fixed ? ma.v : mb.v;  // a static side's velocity is the reference (zero asleep)
    if (!ma.fixed && !mb.fixed) v_ref = (ma.mass * ma.v + mb.mass * mb.v) / (ma.mass + mb.mass);
    const double alpha = state.params.alpha;
    const double bounce = may_rebound ? rebound(u, r, alpha, kRecentEntrySteps * model.settings.dt) : 0.0;
    if (!ma.fixed) set_velocity(model, state, a, v_ref, n, alpha, beta, -share.a * bounce * n);
    if (!mb.fixed) set_velocity(model, state, b, v_ref, n, alpha, beta, share.b * bounce * n);
  }
  move(model, state, a, -share.a * r * n);
  move(model, state, b, share.b * r * n);
}

}  // namespace ffd
