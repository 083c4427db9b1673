#include "ffd/measure.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "ffd/surface_metrics.h"
#include "ffd/trilinear.h"

namespace ffd {

Energy compute_energy(const Model& model, const State& state) {
  Energy e;
  const Vec3 g = has(model.settings.effects, Effect::Gravity) ? state.params.gravity : Vec3::Zero();
  for (std::size_t n = 0; n < model.node_count(); ++n) {
    e.kinetic += 0.5 * model.node_mass[n] * state.v[n].squaredNorm();
    e.gravitational -= model.node_mass[n] * g.dot(state.x[n]);
  }
  for (std::size_t i = 0; i < model.objects.size(); ++i) {
    const ObjectModel& o = model.objects[i];
    if (o.dynamics != DynamicsKind::MassSpring) continue;
    // A spring's stored energy, 1/2 k (l - l0)^2, but never more than that of the force it
    // applied, f^2 / 2k. The force bounds it where a few sweeps leave very stiff springs
    // stretched by a residue they never push with
    // (docs/notes/2026-11-28-code-findings.md#elastic-energy); the length bounds it where the
    // force is mostly the springs' damping, a soft object landing (f holds both).
    const double stiffness = state.params.stiffness[i];
    for (Index s = o.spring_begin; s < o.spring_end; ++s) {
      const Spring& spring = model.springs[s];
      const double stretch_force = stiffness * ((state.x[spring.a] - state.x[spring.b]).norm() - spring.rest_length);  // N
      const double force = std::min(std::abs(state.spring_force[s]), std::abs(stretch_force));  // N
      e.elastic += 0.5 * force * force / stiffness;
    }
    // Likewise the volume constraints: p^2 V0 / 2K, K (V - V0)^2 / 2 V0 where converged.
    for (Index t = o.tetrahedron_begin; t < o.tetrahedron_end; ++t)
      e.elastic += 0.5 * state.volume_pressure[t] * state.volume_pressure[t] * model.tetrahedra[t].compliance;
    // And the cells' shape constraints: f^2 / 2k, k C^2 / 2 where converged.
    if (o.mass_spring.shape_stiffness > 0.0)
      for (Index c = o.cell_begin; c < o.cell_end; ++c)
        e.elastic += 0.5 * state.cell_shape_force[c] * state.cell_shape_force[c] / o.mass_spring.shape_stiffness;
  }
  return e;
}

SurfaceMesh deformed_surface(const Model& model, const State& state, Index object) {
  const ObjectModel& o = model.objects[object];
  SurfaceMesh mesh;
  mesh.triangles = o.surface.triangles;
  mesh.vertices.resize(o.surface.vertices.size());
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const std::array<Index, 8>& corner = model.cell_nodes[o.vertex_cell[v]];
    mesh.vertices[v] = trilinear_map(o.vertex_local[v], [&](int j) -> const Vec3& { return state.x[corner[j]]; });
  }
  return mesh;
}

SurfaceContactReport measure_surface_contacts(const Model& model, const State& state, double search_radius) {
  if (!(search_radius > 0.0))
    for (const ObjectModel& o : model.objects) search_radius = std::max(search_radius, o.cell_size);
  SurfaceContactReport report;
  report.search_radius_m = search_radius;
  std::vector<SurfaceMesh> surfaces;
  std::vector<std::pair<Vec3, Vec3>> bounds;
  for (Index i = 0; i < model.objects.size(); ++i) {
    surfaces.push_back(deformed_surface(model, state, i));
    bounds.push_back(mesh_bounds(surfaces.back()));
  }
  auto add = [&](SurfaceContact c) {
    report.max_penetration_m = std::max(report.max_penetration_m, c.penetration_m);
    report.max_gap_m = std::max(report.max_gap_m, c.gap_m);
    report.penetrating_vertices += c.penetrating_vertices;
    report.contacts.push_back(std::move(c));
  };
  const bool objects_collide = has(model.settings.effects, Effect::InterCollision);
  // Each surface's distance helper is built the first time a pair needs it, then shared.
  std::vector<std::optional<SurfaceDistance>> distance(surfaces.size());
  auto distance_to = [&](std::size_t i) -> const SurfaceDistance& {
    if (!distance[i]) distance[i].emplace(surfaces[i], search_radius);
    return *distance[i];
  };
  for (std::size_t i = 0; objects_collide && i < surfaces.size(); ++i) {
    for (std::size_t j = i + 1; j < surfaces.size(); ++j) {
      const Vec3 lo = bounds[i].first.cwiseMax(bounds[j].first) - Vec3::Constant(search_radius);
      const Vec3 hi = bounds[i].second.cwiseMin(bounds[j].second) + Vec3::Constant(search_radius);
      if ((lo.array() > hi.array()).any()) continue;
      const PairContactMetrics m = measure_pair(surfaces[i], distance_to(i), surfaces[j], distance_to(j), search_radius);
      if (!m.near) continue;
      add({model.objects[i].name, model.objects[j].name, m.penetration_m, m.gap_m, m.penetrating_vertices});
    }
  }
  if (has(model.settings.effects, Effect::Planes)) {
    for (const PlaneModel& plane : model.planes) {
      for (std::size_t i = 0; i < surfaces.size(); ++i) {
        double lowest = INFINITY;
        std::size_t below = 0;
        for (const Vec3& p : surfaces[i].vertices) {
          const double height = plane.normal.dot(p) - plane.offset;
          lowest = std::min(lowest, height);
          below += height < 0.0;
        }
        if (!(lowest < search_radius)) continue;
        add({model.objects[i].name, plane.name, std::max(0.0, -lowest), std::max(0.0, lowest), below});
      }
    }
  }
  return report;
}

}  // namespace ffd
