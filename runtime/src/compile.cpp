// SceneSpec -> Model: every validation and every derived constant happens here, so that
// step() never validates or derives.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "ffd/measure.h"
#include "ffd/model.h"
#include "ffd/box_test.h"
#include "lattice.h"

namespace ffd {

static_assert(kBoxSampleCount == kSupportDirectionCount);

namespace {

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

void require(bool ok, const std::string& where, const std::string& what) {
  if (!ok) throw CompileError(where + ": " + what);
}

// Level 0's box: the whole lattice cell, its centre node at the cell centre.
std::array<Vec3, 9> grid_cell_box() {
  std::array<Vec3, 9> box;
  for (int k = 0; k < 8; ++k) box[k] = Vec3(k & 1, (k >> 1) & 1, (k >> 2) & 1);
  box[8] = Vec3::Constant(0.5);
  return box;
}

// Level 5's flat arrays of every object's surface, and per cell (CSR) the vertices bound to
// it and the triangles crossing it (`lattice_triangles`: per object, per cell of the object).
// Contacts are seen up to a quarter of the finest cell size deep.
void build_exact_surfaces(Model& model, const std::vector<std::vector<std::vector<Index>>>& lattice_triangles) {
  double finest_cell = INFINITY;
  std::vector<std::vector<Index>> cell_vertices(model.cell_count()), cell_triangles(model.cell_count());
  for (std::size_t object = 0; object < model.objects.size(); ++object) {
    const ObjectModel& o = model.objects[object];
    const Index first_vertex = static_cast<Index>(model.surface_vertex_cell.size());
    for (std::size_t v = 0; v < o.vertex_cell.size(); ++v) {
      cell_vertices[o.vertex_cell[v]].push_back(static_cast<Index>(model.surface_vertex_cell.size()));
      model.surface_vertex_cell.push_back(o.vertex_cell[v]);
      model.surface_vertex_local.push_back(o.vertex_local[v]);
      model.surface_vertex_rest.push_back(o.surface.vertices[v]);
    }
    const Index first_triangle = static_cast<Index>(model.surface_triangles.size());
    for (const auto& t : o.surface.triangles)
      model.surface_triangles.push_back({first_vertex + t[0], first_vertex + t[1], first_vertex + t[2]});
    for (std::size_t c = 0; c < lattice_triangles[object].size(); ++c)
      for (Index t : lattice_triangles[object][c]) cell_triangles[o.cell_begin + c].push_back(first_triangle + t);
    finest_cell = std::min(finest_cell, o.cell_size);
  }
  auto flatten = [](const std::vector<std::vector<Index>>& rows, std::vector<Index>& begin, std::vector<Index>& items) {
    begin.push_back(0);
    for (const auto& row : rows) {
      items.insert(items.end(), row.begin(), row.end());
      begin.push_back(static_cast<Index>(items.size()));
    }
  };
  flatten(cell_vertices, model.cell_vertex_begin, model.cell_vertices);
  flatten(cell_triangles, model.cell_triangle_begin, model.cell_triangles);
  std::vector<std::vector<Index>> sources(model.cell_count());
  for (std::size_t c = 0; c < cell_triangles.size(); ++c) {
    for (Index t : cell_triangles[c])
      for (Index v : model.surface_triangles[t]) sources[c].push_back(model.surface_vertex_cell[v]);
    std::sort(sources[c].begin(), sources[c].end());
    sources[c].erase(std::unique(sources[c].begin(), sources[c].end()), sources[c].end());
  }
  flatten(sources, model.cell_triangle_source_begin, model.cell_triangle_sources);
  // Per cell of `rows` (its triangles), the edges of its triangles, each once.
  const auto flatten_edges = [&](const std::vector<std::vector<Index>>& rows, std::vector<Index>& begin,
                                 std::vector<std::array<Index, 2>>& items) {
    begin.push_back(0);
    std::vector<std::array<Index, 2>> edges;
    for (const auto& row : rows) {
      edges.clear();
      for (Index t : row) {
        const std::array<Index, 3>& tri = model.surface_triangles[t];
        for (int k = 0; k < 3; ++k)
          edges.push_back({std::min(tri[k], tri[(k + 1) % 3]), std::max(tri[k], tri[(k + 1) % 3])});
      }
      std::sort(edges.begin(), edges.end());
      edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
      items.insert(items.end(), edges.begin(), edges.end());
      begin.push_back(static_cast<Index>(items.size()));
    }
  };
  // An edge crossing another surface inside a cell is tested when the cell's box meets that
  // surface's (level 4).
  flatten_edges(cell_triangles, model.cell_edge_begin, model.cell_edges);
  // Each triangle owned by the cell its first corner is bound to (the next corner's if that
  // cell has no box: a vertex on a cell's face), and the owned triangles' edges (levels 0-3).
  const auto has_boxes = [&](Index c) {
    return model.boxes.cell_box_begin[c + 1] > model.boxes.cell_box_begin[c] &&
           model.grid_boxes.cell_box_begin[c + 1] > model.grid_boxes.cell_box_begin[c];
  };
  std::vector<std::vector<Index>> owned(model.cell_count());
  for (std::size_t t = 0; t < model.surface_triangles.size(); ++t) {
    const std::array<Index, 3>& tri = model.surface_triangles[t];
    Index owner = model.surface_vertex_cell[tri[0]];
    for (int k = 2; k >= 0; --k)
      if (has_boxes(model.surface_vertex_cell[tri[k]])) owner = model.surface_vertex_cell[tri[k]];
    owned[owner].push_back(static_cast<Index>(t));
  }
  flatten(owned, model.cell_owned_triangle_begin, model.cell_owned_triangles);
  flatten_edges(owned, model.cell_owned_edge_begin, model.cell_owned_edges);
  model.surface_contact_radius = std::isfinite(finest_cell) ? 0.25 * finest_cell : 0.0;
  model.surface_skin = std::isfinite(finest_cell) ? 0.01 * finest_cell : 0.0;  // as box_skin
  model.sub_box_skin = std::isfinite(finest_cell) ? kSubBoxSkinShare * finest_cell : 0.0;
}

void validate(const SceneSpec& spec) {
  const SimulationSettings& s = spec.settings;
  require(std::isfinite(s.dt) && s.dt > 0.0 && s.dt <= 0.01, "simulation.dt", "must be in (0, 0.01] s (got " + fmt(s.dt) + ")");
  require(is_finite(s.gravity), "simulation.gravity", "must be finite");
  require(s.alpha >= 0.0 && s.alpha <= 1.0, "simulation.alpha", "must be in [0, 1] (got " + fmt(s.alpha) + ")");
  require(s.beta >= 0.0 && s.beta <= 1.0, "simulation.beta", "must be in [0, 1] (got " + fmt(s.beta) + ")");
  require(std::isfinite(s.hash_cell_size) && s.hash_cell_size >= 0.0, "simulation.hash_cell_size", "must be >= 0 m");
  require(s.min_box_thickness >= 0.0 && s.min_box_thickness <= 1.0, "simulation.min_box_thickness", "must be in [0, 1]");
  require(static_cast<int>(s.accuracy) < kAccuracyLevels, "simulation.accuracy", "must be in 0..5");
  require(s.sub_box_split >= 2 && s.sub_box_split <= 4, "simulation.sub_box_split", "must be in 2..4");
  require(std::isfinite(s.sleep_radius) && s.sleep_radius > 0.0 && s.sleep_radius <= 1.0, "simulation.sleep_radius",
          "must be in (0, 1] m (got " + fmt(s.sleep_radius) + ")");
  require(std::isfinite(s.sleep_time) && s.sleep_time > 0.0 && s.sleep_time <= 60.0, "simulation.sleep_time",
          "must be in (0, 60] s (got " + fmt(s.sleep_time) + ")");
  for (std::size_t i = 0; i < spec.objects.size(); ++i) {
    const ObjectSpec& o = spec.objects[i];
    const std::string w = "object '" + o.name + "'";
    require(std::isfinite(o.cell_size) && o.cell_size > 0.0, w + ".cell_size", "must be > 0 m (got " + fmt(o.cell_size) + ")");
    require(std::isfinite(o.mass) && o.mass > 0.0, w + ".mass", "must be > 0 kg (got " + fmt(o.mass) + ")");
    require(is_finite(o.position) && is_finite(o.rotation_deg) && is_finite(o.velocity) && is_finite(o.angular_velocity), w,
            "position, rotation, velocity and angular velocity must be finite");
    require(o.subdivisions >= 0 && o.subdivisions <= 3, w + ".subdivide", "must be in 0..3");
    require(!o.mesh.triangles.empty(), w + ".mesh", "has no triangles");
    if (o.dynamics == DynamicsKind::MassSpring) {
      require(std::isfinite(o.mass_spring.stiffness) && o.mass_spring.stiffness > 0.0, w + ".mass_spring.stiffness", "must be > 0 N/m");
      require(std::isfinite(o.mass_spring.damping) && o.mass_spring.damping >= 0.0, w + ".mass_spring.damping", "must be >= 0 N*s/m");
      require(std::isfinite(o.mass_spring.bulk_modulus) && o.mass_spring.bulk_modulus >= 0.0, w + ".mass_spring.bulk_modulus", "must be >= 0 Pa");
      require(std::isfinite(o.mass_spring.shape_stiffness) && o.mass_spring.shape_stiffness >= 0.0, w + ".mass_spring.shape_stiffness", "must be >= 0 N/m");
      require(o.mass_spring.iterations >= 1 && o.mass_spring.iterations <= 100, w + ".mass_spring.iterations", "must be in 1..100");
    } else {
      require(o.shape_matching.stiffness > 0.0 && o.shape_matching.stiffness <= 1.0, w + ".shape_matching.stiffness", "must be in (0, 1]");
      require(o.shape_matching.region_half_width >= 1 && o.shape_matching.region_half_width <= 4, w + ".shape_matching.region_half_width", "must be in 1..4");
      require(std::isfinite(o.shape_matching.damping) && o.shape_matching.damping >= 0.0, w + ".shape_matching.damping", "must be >= 0 1/s");
    }
    for (std::size_t j = 0; j < i; ++j) require(spec.objects[j].name != o.name, w, "name used twice");
  }
  for (const PlaneSpec& p : spec.planes) {
    require(is_finite(p.normal) && p.normal.norm() > 1e-12, "plane '" + p.name + "'.normal", "must be a non-zero vector");
    require(std::isfinite(p.offset), "plane '" + p.name + "'.offset", "must be finite");
  }
  const ProbeSettings& probe = s.probe;
  require(std::isfinite(probe.radius) && probe.radius > 0.0, "probe.radius", "must be > 0 m");
  require(std::isfinite(probe.mass) && probe.mass > 0.0, "probe.mass", "must be > 0 kg");
  require(std::isfinite(probe.coupling_stiffness) && probe.coupling_stiffness >= 0.0, "probe.coupling_stiffness", "must be >= 0 N/m");
  require(std::isfinite(probe.coupling_damping) && probe.coupling_damping >= 0.0, "probe.coupling_damping", "must be >= 0 N*s/m");
  require(is_finite(probe.start), "probe.start", "must be finite");
  require(std::isfinite(s.grab.stiffness) && s.grab.stiffness >= 0.0, "grab.stiffness", "must be >= 0 N/m");
  require(std::isfinite(s.grab.damping) && s.grab.damping >= 0.0, "grab.damping", "must be >= 0 N*s/m");
  require(spec.planes.empty() || has(s.effects, Effect::Planes), "simulation.effects",
          "the scene declares planes but does not list the \"planes\" effect");
}

// The 28 node pairs of a cell's springs: 12 edges, 12 face diagonals, 4 body diagonals.
std::vector<std::pair<int, int>> cell_spring_pairs() {
  std::vector<std::pair<int, int>> pairs;
  for (int a = 0; a < 8; ++a)
    for (int b = a + 1; b < 8; ++b) pairs.emplace_back(a, b);  // every pair of corners is one of the three kinds
  return pairs;
}

// BoxSet::kernel_local and kernel_corner from box_local and the cells' nodes.
void fill_kernel_layout(const Model& model, BoxSet& set) {
  const std::size_t blocks = set.block_count();
  set.kernel_local.assign(blocks * 9 * kBoxLanes, 0.0);
  set.kernel_corner.assign(blocks * 8 * kBoxLanes, 0);
  set.box_lattice.resize(set.size());
  for (std::size_t b = 0; b < set.size(); ++b) set.box_lattice[b] = model.cell_coord[set.box_cell[b]];
  for (std::size_t block = 0; block < blocks; ++block)
    for (Index lane = 0; lane < kBoxLanes; ++lane) {
      const std::size_t b = std::min(block * kBoxLanes + lane, set.size() - 1);
      const std::array<Vec3, 9>& local = set.box_local[b];
      for (int axis = 0; axis < 3; ++axis) {
        set.kernel_local[(block * 9 + axis) * kBoxLanes + lane] = local[0][axis];
        set.kernel_local[(block * 9 + 3 + axis) * kBoxLanes + lane] = local[7][axis];
        set.kernel_local[(block * 9 + 6 + axis) * kBoxLanes + lane] = local[8][axis];
      }
      for (int j = 0; j < 8; ++j)
        set.kernel_corner[(block * 8 + j) * kBoxLanes + lane] = 3 * static_cast<std::int64_t>(model.cell_nodes[set.box_cell[b]][j]);
    }
}

// Gauss-Seidel order for the springs: greedy colouring so that springs of one colour share
// no node, then colour by colour. Consecutive projections are then independent and the CPU
// overlaps them (a node-sorted order chains every projection on the previous one). The
// order is a pure function of the lattice, so runs stay deterministic.
// Appends the springs of `pairs` to model.springs in that order, and their colours to
// model.spring_colours.
void order_springs_by_colour(Model& model, const std::vector<std::pair<Index, Index>>& pairs, std::size_t node_count) {
  std::vector<std::uint64_t> used(node_count, 0);  // bit c: node already in colour c (c < 64)
  std::vector<int> colour(pairs.size());
  int colours = 0;
  for (std::size_t s = 0; s < pairs.size(); ++s) {
    const std::uint64_t busy = used[pairs[s].first] | used[pairs[s].second];
    int c = 0;
    while (c < 63 && (busy >> c) & 1u) ++c;  // colour 63 takes whatever is left
    colour[s] = c;
    used[pairs[s].first] |= std::uint64_t{1} << c;
    used[pairs[s].second] |= std::uint64_t{1} << c;
    colours = std::max(colours, c + 1);
  }
  for (int c = 0; c < colours; ++c) {
    SpringColour range{static_cast<Index>(model.springs.size()), 0, c < 63};
    for (std::size_t s = 0; s < pairs.size(); ++s)
      if (colour[s] == c) {
        const auto [a, b] = pairs[s];
        model.springs.push_back({a, b, (model.node_rest[a] - model.node_rest[b]).norm()});
      }
    range.end = static_cast<Index>(model.springs.size());
    if (range.end > range.begin) model.spring_colours.push_back(range);
  }
}

Mat3 rotation_from_degrees(const Vec3& deg) {
  const double k = M_PI / 180.0;
  // About x first, then y, then z.
  return (Eigen::AngleAxisd(deg.z() * k, Vec3::UnitZ()) * Eigen::AngleAxisd(deg.y() * k, Vec3::UnitY()) *
          Eigen::AngleAxisd(deg.x() * k, Vec3::UnitX()))
      .toRotationMatrix();
}

}  // namespace

namespace {
// Objects that start inside each other (or below a plane) are simulated as they are, already
// crossed: say so, with the pair and the depth on the exact surfaces. A [[group]] whose
// spacing is smaller than its objects does this easily.
void warn_about_start_overlaps(const Model& model, std::vector<std::string>& log) {
  constexpr double kReportedDepth = 1e-6;  // m; below this, touching rather than overlapping
  const SurfaceContactReport start = measure_surface_contacts(model, initial_state(model));
  for (const SurfaceContact& c : start.contacts) {
    if (!(c.penetration_m > kReportedDepth)) continue;
    const bool plane = std::none_of(model.objects.begin(), model.objects.end(),
                                    [&](const ObjectModel& o) { return o.name == c.b; });
    std::ostringstream line;
    line.precision(3);
    if (plane)
      line << "warning: object '" << c.a << "' starts " << c.penetration_m * 1e3 << " mm below the plane '" << c.b
           << "' (" << c.penetrating_vertices << " surface vertices below it)";
    else
      line << "warning: objects '" << c.a << "' and '" << c.b << "' overlap at the start by " << c.penetration_m * 1e3
           << " mm (" << c.penetrating_vertices << " surface vertices inside the other); they are simulated as they "
           << "are, already crossed: move them apart (a [[group]]'s spacing smaller than its objects does this)";
    log.push_back(line.str());
  }
}
}  // namespace

Tetrahedron kuhn_tetrahedron(const Model& model, Index cell, int k) {
  constexpr int kAxes[6][2] = {{1, 2}, {1, 4}, {2, 1}, {2, 4}, {4, 1}, {4, 2}};  // corner bits: x 1, y 2, z 4
  const auto [first, second] = kAxes[k];
  const std::array<Index, 8>& corner = model.cell_nodes[cell];
  Tetrahedron t{{corner[0], corner[first], corner[first | second], corner[7]}, 0.0, 0.0};
  const Vec3& x0 = model.node_rest[t.nodes[0]];
  double volume = (model.node_rest[t.nodes[1]] - x0).dot((model.node_rest[t.nodes[2]] - x0).cross(model.node_rest[t.nodes[3]] - x0)) / 6.0;
  if (volume < 0.0) {  // the odd permutations: swap two corners
    std::swap(t.nodes[1], t.nodes[2]);
    volume = -volume;
  }
  t.rest_volume = volume;
  return t;
}

Model compile(const SceneSpec& spec, std::vector<std::string>& log) {
  validate(spec);
  Model model;
  std::vector<std::vector<std::vector<Index>>> lattice_triangles;  // per object, per cell: triangles crossing it
  model.settings = spec.settings;
  const EffectSet effects = spec.settings.effects;
  const std::vector<std::pair<int, int>> spring_pairs = cell_spring_pairs();

  for (const ObjectSpec& o : spec.objects) {
    ObjectModel obj;
    obj.name = o.name;
    obj.dynamics = o.dynamics;
    obj.mass_spring = o.mass_spring;
    obj.shape_matching = o.shape_matching;
    obj.cell_size = o.cell_size;
    obj.initial_rotation = rotation_from_degrees(o.rotation_deg);
    obj.initial_translation = o.position;
    obj.initial_velocity = o.velocity;
    obj.initial_angular_velocity = o.angular_velocity;

    MeshCleanReport clean_report;
    try {
      obj.surface = clean_mesh(o.mesh, o.clean, clean_report);
    } catch (const std::invalid_argument& e) {
      throw CompileError("object '" + o.name + "' (" + o.source + "): " + e.what());
    }
    log.push_back("object '" + o.name + "' (" + o.source + "): " + std::to_string(clean_report.input_vertices) +
                  " vertices, " + std::to_string(clean_report.input_triangles) + " triangles; " +
                  clean_report.summary());
    if (o.subdivisions > 0) {
      obj.surface = subdivide_mesh(obj.surface, o.subdivisions);
      log.push_back("object '" + o.name + "': subdivided 1-to-4 " + std::to_string(o.subdivisions) + "x: " +
                    std::to_string(obj.surface.vertices.size()) + " vertices, " +
                    std::to_string(obj.surface.triangles.size()) + " triangles");
    }

    LatticeBuild lattice;
    try {
      lattice = build_lattice(obj.surface, o.cell_size, o.fill_interior, spec.settings.min_box_thickness,
                              spec.settings.sub_box_split);
    } catch (const std::invalid_argument& e) {
      throw CompileError("object '" + o.name + "'.cell_size: " + e.what());
    }
    obj.lattice_origin = lattice.origin;
    obj.lattice_dims = lattice.dims;
    const Index object_index = static_cast<Index>(model.objects.size());
    const double h = o.cell_size;

    // Nodes: the distinct corners of the kept cells, in linear order of the node grid.
    const Vec3i nd = lattice.dims + Vec3i::Ones();
    auto node_linear = [&](const Vec3i& c) {
      return static_cast<std::size_t>(c.x()) + static_cast<std::size_t>(nd.x()) * (c.y() + static_cast<std::size_t>(nd.y()) * c.z());
    };
    std::vector<Index> node_of(static_cast<std::size_t>(nd.x()) * nd.y() * nd.z(), kNoIndex);
    for (const Vec3i& c : lattice.cells)
      for (int j = 0; j < 8; ++j) node_of[node_linear(c + Vec3i(j & 1, (j >> 1) & 1, (j >> 2) & 1))] = 0;
    obj.node_begin = static_cast<Index>(model.node_rest.size());
    std::vector<Vec3i> node_coord;
    for (int k = 0; k < nd.z(); ++k)
      for (int j = 0; j < nd.y(); ++j)
        for (int i = 0; i < nd.x(); ++i) {
          const Vec3i c(i, j, k);
          std::size_t li = node_linear(c);
          if (node_of[li] == kNoIndex) continue;
          node_of[li] = static_cast<Index>(model.node_rest.size());
          model.node_rest.push_back(lattice.origin + h * c.cast<double>());
          model.node_mass.push_back(0.0);
          model.node_object.push_back(object_index);
          node_coord.push_back(c);
        }
    obj.node_end = static_cast<Index>(model.node_rest.size());

    // Cells, their masses (the object's mass shared equally by its cells, each cell's share
    // split over its 8 nodes) and boxes.
    obj.cell_begin = static_cast<Index>(model.cell_nodes.size());
    obj.box_begin = static_cast<Index>(model.boxes.size());
    const double cell_mass = o.mass / static_cast<double>(lattice.cells.size());
    for (std::size_t c = 0; c < lattice.cells.size(); ++c) {
      std::array<Index, 8> nodes;
      for (int j = 0; j < 8; ++j) {
        nodes[j] = node_of[node_linear(lattice.cells[c] + Vec3i(j & 1, (j >> 1) & 1, (j >> 2) & 1))];
        model.node_mass[nodes[j]] += cell_mass / 8.0;
      }
      const Index cell_index = static_cast<Index>(model.cell_nodes.size());
      model.cell_nodes.push_back(nodes);
      model.cell_coord.push_back(lattice.cells[c]);
      model.cell_object.push_back(object_index);
      model.cell_inv_mass.push_back(1.0 / cell_mass);
      model.boxes.cell_box_begin.push_back(static_cast<Index>(model.boxes.size()));
      model.grid_boxes.cell_box_begin.push_back(static_cast<Index>(model.grid_boxes.size()));
      model.sub_boxes.cell_box_begin.push_back(static_cast<Index>(model.sub_boxes.size()));
      if (lattice.cell_has_surface[c]) {
        const std::array<Vec3, 9>& box = lattice.box_local[c];
        model.boxes.box_cell.push_back(cell_index);
        model.boxes.box_local.push_back(box);
        model.box_samples.push_back(lattice.support_local[c]);
        model.grid_boxes.box_cell.push_back(cell_index);
        model.grid_boxes.box_local.push_back(grid_cell_box());
        for (const std::array<Vec3, 9>& part : lattice.sub_box_local[c]) {
          model.sub_boxes.box_cell.push_back(cell_index);
          model.sub_boxes.box_local.push_back(part);
        }
      }
    }
    obj.cell_end = static_cast<Index>(model.cell_nodes.size());
    // Each cell's 8 nodes' summed mass and their mass-weighted centre at rest (the shape
    // constraints of dynamics.cpp), once every cell has given its nodes their share.
    for (Index c = obj.cell_begin; c < obj.cell_end; ++c) {
      double mass = 0.0;
      Vec3 centre = Vec3::Zero();
      for (Index n : model.cell_nodes[c]) {
        mass += model.node_mass[n];
        centre += model.node_mass[n] * model.node_rest[n];
      }
      model.cell_node_mass.push_back(mass);
      model.cell_rest_centre.push_back(centre / mass);
    }
    obj.box_end = static_cast<Index>(model.boxes.size());
    obj.vertex_cell.resize(lattice.vertex_cell.size());
    for (std::size_t v = 0; v < lattice.vertex_cell.size(); ++v) obj.vertex_cell[v] = obj.cell_begin + lattice.vertex_cell[v];
    obj.vertex_local = std::move(lattice.vertex_local);
    lattice_triangles.push_back(std::move(lattice.cell_triangles));

    // Springs (mass-spring objects): every corner pair of every cell, once per node pair.
    obj.spring_begin = static_cast<Index>(model.springs.size());
    obj.colour_begin = static_cast<Index>(model.spring_colours.size());
    if (o.dynamics == DynamicsKind::MassSpring) {
      std::vector<std::pair<Index, Index>> pairs;
      for (Index c = obj.cell_begin; c < obj.cell_end; ++c)
        for (const auto& [a, b] : spring_pairs) {
          const Index na = model.cell_nodes[c][a], nb = model.cell_nodes[c][b];
          pairs.emplace_back(std::min(na, nb), std::max(na, nb));
        }
      std::sort(pairs.begin(), pairs.end());
      pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
      order_springs_by_colour(model, pairs, model.node_rest.size());
    }
    obj.spring_end = static_cast<Index>(model.springs.size());
    obj.colour_end = static_cast<Index>(model.spring_colours.size());

    // Volume constraints (mass-spring objects with a bulk modulus): the six tetrahedra of
    // each cell's Kuhn split, around its diagonal from corner 0 to corner 7.
    obj.tetrahedron_begin = static_cast<Index>(model.tetrahedra.size());
    if (o.dynamics == DynamicsKind::MassSpring && o.mass_spring.bulk_modulus > 0.0)
      for (Index c = obj.cell_begin; c < obj.cell_end; ++c)
        for (int k = 0; k < 6; ++k) {
          Tetrahedron t = kuhn_tetrahedron(model, c, k);
          t.compliance = t.rest_volume / o.mass_spring.bulk_modulus;
          model.tetrahedra.push_back(t);
        }
    obj.tetrahedron_end = static_cast<Index>(model.tetrahedra.size());

    // Shape-matching regions (FastLSM): around every node, the nodes within half-width w
    // (max-norm in lattice steps) reachable through cells of the object.
    obj.region_begin = static_cast<Index>(model.regions.size());
    if (o.dynamics == DynamicsKind::ShapeMatching) {
      const int w = o.shape_matching.region_half_width;
      std::vector<std::vector<Index>> node_cells(obj.node_end - obj.node_begin);
      for (Index c = obj.cell_begin; c < obj.cell_end; ++c)
        for (Index n : model.cell_nodes[c]) node_cells[n - obj.node_begin].push_back(c);
      std::vector<Index> seen_stamp(obj.node_end - obj.node_begin, kNoIndex);
      for (Index centre = obj.node_begin; centre < obj.node_end; ++centre) {
        const Vec3i cc = node_coord[centre - obj.node_begin];
        std::vector<Index> members{centre};
        seen_stamp[centre - obj.node_begin] = centre;
        for (std::size_t q = 0; q < members.size(); ++q) {
          for (Index c : node_cells[members[q] - obj.node_begin])
            for (Index n : model.cell_nodes[c]) {
              if (seen_stamp[n - obj.node_begin] == centre) continue;
              if ((node_coord[n - obj.node_begin] - cc).cwiseAbs().maxCoeff() > w) continue;
              seen_stamp[n - obj.node_begin] = centre;
              members.push_back(n);
            }
        }
        std::sort(members.begin(), members.end());
        Region region;
        region.member_begin = static_cast<Index>(model.region_members.size());
        region.mass = 0.0;
        region.rest_centroid = Vec3::Zero();
        for (Index n : members) {
          model.region_members.push_back(n);
          region.mass += model.node_mass[n];
          region.rest_centroid += model.node_mass[n] * model.node_rest[n];
        }
        region.rest_centroid /= region.mass;
        region.member_end = static_cast<Index>(model.region_members.size());
        model.regions.push_back(region);
      }
    }
    obj.region_end = static_cast<Index>(model.regions.size());

    std::size_t surface_cells = obj.box_end - obj.box_begin;
    log.push_back("object '" + o.name + "': lattice " + std::to_string(lattice.dims.x()) + "x" +
                  std::to_string(lattice.dims.y()) + "x" + std::to_string(lattice.dims.z()) + " of " + fmt(h) +
                  " m cells; " + std::to_string(obj.cell_end - obj.cell_begin) + " cells kept (" +
                  std::to_string(surface_cells) + " with surface = FFD AABBs), " +
                  std::to_string(obj.node_end - obj.node_begin) + " nodes, " +
                  (o.dynamics == DynamicsKind::MassSpring ? std::to_string(obj.spring_end - obj.spring_begin) + " springs"
                                                          : std::to_string(obj.region_end - obj.region_begin) + " regions"));
    model.objects.push_back(std::move(obj));
  }

  for (BoxSet* set : {&model.boxes, &model.grid_boxes, &model.sub_boxes}) {
    set->cell_box_begin.push_back(static_cast<Index>(set->size()));
    fill_kernel_layout(model, *set);
  }
  build_exact_surfaces(model, lattice_triangles);

  model.node_inv_mass.resize(model.node_mass.size());
  for (std::size_t n = 0; n < model.node_mass.size(); ++n) model.node_inv_mass[n] = 1.0 / model.node_mass[n];
  for (const Spring& spring : model.springs) {
    model.spring_node_a.push_back(spring.a);
    model.spring_node_b.push_back(spring.b);
    model.spring_rest_length.push_back(spring.rest_length);
  }
  model.node_region_count.assign(model.node_rest.size(), 0);
  for (Index m : model.region_members) ++model.node_region_count[m];

  // Cells sharing a node with each cell (CSR), in increasing order.
  {
    std::vector<std::vector<Index>> node_cells(model.node_count());
    for (Index c = 0; c < model.cell_count(); ++c)
      for (Index n : model.cell_nodes[c]) node_cells[n].push_back(c);
    model.cell_neighbour_begin.push_back(0);
    std::vector<Index> row;
    for (Index c = 0; c < model.cell_count(); ++c) {
      row.clear();
      for (Index n : model.cell_nodes[c]) row.insert(row.end(), node_cells[n].begin(), node_cells[n].end());
      std::sort(row.begin(), row.end());
      row.erase(std::unique(row.begin(), row.end()), row.end());
      model.cell_neighbours.insert(model.cell_neighbours.end(), row.begin(), row.end());
      model.cell_neighbour_begin.push_back(static_cast<Index>(model.cell_neighbours.size()));
    }
  }

  for (const PlaneSpec& p : spec.planes) {
    const double len = p.normal.norm();
    model.planes.push_back({p.name, p.normal / len, p.offset / len});
  }

  // The pipeline: only the stages the effects ask for (section "Effects on demand").
  const bool box_box = has(effects, Effect::InterCollision) || has(effects, Effect::SelfCollision);
  const bool planes = has(effects, Effect::Planes) && !model.planes.empty();
  if (has(effects, Effect::Gravity)) model.pipeline.push_back(Stage::Gravity);
  model.pipeline.push_back(Stage::Dynamics);
  const bool probe = has(effects, Effect::Probe);
  if (box_box || planes || probe) model.pipeline.push_back(Stage::BoxUpdate);
  if (box_box) {
    model.pipeline.push_back(Stage::BroadPhase);
    model.pipeline.push_back(Stage::NarrowPhase);
    model.collides = true;
  }
  if (planes) model.pipeline.push_back(Stage::Planes);
  if (probe || has(effects, Effect::Grab)) model.pipeline.push_back(Stage::Interaction);
  // Runs only while the response is "solver" (a command may switch it): then the stages
  // above find the contacts on the predicted positions and this one answers them.
  if (box_box || planes || probe || has(effects, Effect::Grab)) model.pipeline.push_back(Stage::ContactSolve);
  if (has(effects, Effect::Sleeping)) model.pipeline.push_back(Stage::Sleep);
  // Clamped: sleep_time / dt is finite for a valid scene, but need not fit 32 bits.
  model.sleep_steps = static_cast<std::uint32_t>(
      std::clamp(std::ceil(model.settings.sleep_time / model.settings.dt), 1.0, 4.0e9));
  if (model.settings.box_overlap) {
    double finest = INFINITY;
    for (const ObjectModel& object : model.objects) finest = std::min(finest, object.cell_size);
    model.box_skin = std::isfinite(finest) ? kBoxSkinShare * finest : 0.0;
  }
  warn_about_start_overlaps(model, log);
  return model;
}

State initial_state(const Model& model) {
  State state;
  state.params.gravity = model.settings.gravity;
  state.params.alpha = model.settings.alpha;
  state.params.response = model.settings.response;
  state.params.beta = model.settings.beta;
  state.params.probe_stiffness = model.settings.probe.coupling_stiffness;
  state.params.accuracy = model.settings.accuracy;
  state.params.stiffness.resize(model.objects.size());
  for (std::size_t i = 0; i < model.objects.size(); ++i) {
    const ObjectModel& o = model.objects[i];
    state.params.stiffness[i] =
        o.dynamics == DynamicsKind::MassSpring ? o.mass_spring.stiffness : o.shape_matching.stiffness;
  }
  state.probe.device = state.probe.device_previous = state.probe.x = model.settings.probe.start;
  state.x.resize(model.node_count());
  state.v.resize(model.node_count());
  for (const ObjectModel& o : model.objects) {
    Vec3 centre = Vec3::Zero();  // m, the placed lattice's centre of mass: the spin's axis passes through it
    double mass = 0.0;
    for (Index n = o.node_begin; n < o.node_end; ++n) {
      state.x[n] = o.initial_rotation * model.node_rest[n] + o.initial_translation;
      centre += model.node_mass[n] * state.x[n];
      mass += model.node_mass[n];
    }
    centre /= mass;
    for (Index n = o.node_begin; n < o.node_end; ++n) {
      state.v[n] = o.initial_velocity;
      if (o.initial_angular_velocity != Vec3::Zero()) state.v[n] += o.initial_angular_velocity.cross(state.x[n] - centre);
    }
  }
  state.spring_force.assign(model.springs.size(), 0.0);  // every spring starts at its rest length
  state.asleep.assign(model.objects.size(), 0);
  state.still_steps.assign(model.objects.size(), 0);
  state.moving.assign(model.objects.size(), 0);
  state.rest_anchor.assign(model.objects.size(), Vec3::Constant(INFINITY));  // moves at the first step
  state.volume_pressure.assign(model.tetrahedra.size(), 0.0);  // and every tetrahedron at its volume
  // Room for 4 sticking contacts a cell, at least 4,096 (the solver's friction anchors); more
  // are not anchored.
  state.anchors.resize(std::max<std::size_t>(4096, 4 * model.cell_count()));
  state.edge_holds.resize(state.anchors.size());  // likewise for the held edge contacts
  // Shape matching measures rotations from the rest frame, so a rotated object starts there.
  state.cell_rotation.assign(model.cell_count(), Quat::Identity());
  state.cell_shape_force.assign(model.cell_count(), 0.0);
  for (const ObjectModel& o : model.objects)
    for (Index c = o.cell_begin; c < o.cell_end; ++c) state.cell_rotation[c] = Quat(o.initial_rotation);
  state.region_rotation.assign(model.regions.size(), Quat::Identity());
  for (const ObjectModel& o : model.objects)
    for (Index r = o.region_begin; r < o.region_end; ++r) state.region_rotation[r] = Quat(o.initial_rotation);
  return state;
}

}  // namespace ffd
