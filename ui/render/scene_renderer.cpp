#include "render/scene_renderer.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

#include "ffd/trilinear.h"

namespace ffd::ui {

namespace {

// Eq. 2 on the GPU: each surface vertex carries the 8 lattice nodes of its cell and its local
// coordinates (s, t, u); the node positions come from a texture buffer updated every frame.
// The normal is the rest normal carried through the deformation's cofactor matrix
// (cof J = det J * J^-T), whose columns are cross products of the trilinear map's
// derivatives; the lattice is axis-aligned with cubic cells at rest, so the rest normal in
// world axes is also the normal in (s, t, u) axes up to a scale.
constexpr const char* kSurfaceVertexShader = R"(#version 330 core
layout(location = 0) in ivec4 corners_low;   // lattice nodes of cell corners 0..3 (x fastest)
layout(location = 1) in ivec4 corners_high;  // corners 4..7
layout(location = 2) in vec3 local;          // (s, t, u) in [0, 1]^3
layout(location = 3) in vec3 rest_normal;
uniform samplerBuffer nodes;                 // world positions, m
uniform mat4 view_projection;
out vec3 world_position;
out vec3 world_normal;
vec3 node(int i) { return texelFetch(nodes, i).xyz; }
void main() {
  vec3 p0 = node(corners_low.x), p1 = node(corners_low.y), p2 = node(corners_low.z), p3 = node(corners_low.w);
  vec3 p4 = node(corners_high.x), p5 = node(corners_high.y), p6 = node(corners_high.z), p7 = node(corners_high.w);
  float s = local.x, t = local.y, u = local.z;
  vec3 x = (1.0 - u) * ((1.0 - t) * ((1.0 - s) * p0 + s * p1) + t * ((1.0 - s) * p2 + s * p3)) +
           u * ((1.0 - t) * ((1.0 - s) * p4 + s * p5) + t * ((1.0 - s) * p6 + s * p7));
  vec3 ds = (1.0 - t) * (1.0 - u) * (p1 - p0) + t * (1.0 - u) * (p3 - p2) + (1.0 - t) * u * (p5 - p4) + t * u * (p7 - p6);
  vec3 dt = (1.0 - s) * (1.0 - u) * (p2 - p0) + s * (1.0 - u) * (p3 - p1) + (1.0 - s) * u * (p6 - p4) + s * u * (p7 - p5);
  vec3 du = (1.0 - s) * (1.0 - t) * (p4 - p0) + s * (1.0 - t) * (p5 - p1) + (1.0 - s) * t * (p6 - p2) + s * t * (p7 - p3);
  world_normal = cross(dt, du) * rest_normal.x + cross(du, ds) * rest_normal.y + cross(ds, dt) * rest_normal.z;
  world_position = x;
  gl_Position = view_projection * vec4(x, 1.0);
}
)";

constexpr const char* kSolidVertexShader = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
uniform mat4 view_projection;
uniform mat4 model;
out vec3 world_position;
out vec3 world_normal;
void main() {
  vec4 p = model * vec4(position, 1.0);
  world_position = p.xyz;
  world_normal = mat3(model) * normal;
  gl_Position = view_projection * p;
}
)";

// Two-sided Blinn-Phong with a sky/ground ambient term; planes get a 10 cm checker.
constexpr const char* kLitFragmentShader = R"(#version 330 core
in vec3 world_position;
in vec3 world_normal;
uniform vec3 albedo;
uniform vec3 eye;
uniform int checker;           // 1: 10 cm checker along plane_u, plane_v
uniform vec3 plane_u, plane_v;
out vec4 colour;
void main() {
  vec3 n = normalize(world_normal);
  vec3 v = normalize(eye - world_position);
  if (dot(n, v) < 0.0) n = -n;
  vec3 base = albedo;
  if (checker == 1) {
    vec2 g = floor(vec2(dot(world_position, plane_u), dot(world_position, plane_v)) / 0.1);
    base *= mod(g.x + g.y, 2.0) < 1.0 ? 1.0 : 0.82;
  }
  vec3 l = normalize(vec3(0.35, 0.9, 0.45));
  vec3 h = normalize(l + v);
  float diffuse = max(dot(n, l), 0.0);
  float ambient = 0.22 + 0.12 * n.y;
  float specular = 0.22 * pow(max(dot(n, h), 0.0), 40.0);
  vec3 c = base * (ambient + 0.75 * diffuse) + vec3(specular);
  colour = vec4(pow(c, vec3(1.0 / 1.4)), 1.0);
}
)";

constexpr const char* kLineVertexShader = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec4 colour_in;
uniform mat4 view_projection;
out vec4 line_colour;
void main() {
  line_colour = colour_in;
  gl_Position = view_projection * vec4(position, 1.0);
}
)";

constexpr const char* kLineFragmentShader = R"(#version 330 core
in vec4 line_colour;
out vec4 colour;
void main() { colour = line_colour; }
)";

GLuint compile_shader(GLenum type, const char* source) {
  const GLuint shader = glCreateShader(type);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    glDeleteShader(shader);
    throw std::runtime_error(std::string("OpenGL shader does not compile: ") + log);
  }
  return shader;
}

GLuint link_program(const char* vertex_source, const char* fragment_source) {
  const GLuint vertex = compile_shader(GL_VERTEX_SHADER, vertex_source);
  const GLuint fragment = compile_shader(GL_FRAGMENT_SHADER, fragment_source);
  const GLuint program = glCreateProgram();
  glAttachShader(program, vertex);
  glAttachShader(program, fragment);
  glLinkProgram(program);
  glDeleteShader(vertex);
  glDeleteShader(fragment);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetProgramInfoLog(program, sizeof log, nullptr, log);
    glDeleteProgram(program);
    throw std::runtime_error(std::string("OpenGL program does not link: ") + log);
  }
  return program;
}

void set_matrix(GLuint program, const char* name, const Mat4f& m) {
  glUniformMatrix4fv(glGetUniformLocation(program, name), 1, GL_FALSE, m.data());  // column-major, as GL wants
}
void set_vec3(GLuint program, const char* name, const Vec3f& v) {
  glUniform3f(glGetUniformLocation(program, name), v.x(), v.y(), v.z());
}

Vec3f to_float(const Vec3& v) { return v.cast<float>(); }

// Per-vertex layout of an embedded surface.
struct SurfaceVertex {
  GLint corners[8];
  float local[3];
  float rest_normal[3];
};

// Area-weighted vertex normals of the rest surface, in world axes.
std::vector<Vec3> rest_normals(const ObjectModel& object) {
  std::vector<Vec3> normals(object.surface.vertices.size(), Vec3::Zero());
  for (const auto& t : object.surface.triangles) {
    const Vec3& a = object.surface.vertices[t[0]];
    const Vec3 n = (object.surface.vertices[t[1]] - a).cross(object.surface.vertices[t[2]] - a);
    for (Index v : t) normals[v] += n;
  }
  for (Vec3& n : normals) {
    const double length = n.norm();
    n = length > 0.0 ? Vec3(object.initial_rotation * n / length) : Vec3::UnitY();
  }
  return normals;
}

constexpr std::array<std::array<int, 2>, 12> kCellEdges = {{{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                                            {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}}};

}  // namespace

Vec3f object_colour(std::size_t index) {
  static const std::array<Vec3f, 6> palette = {Vec3f(0.85f, 0.55f, 0.30f), Vec3f(0.35f, 0.62f, 0.85f),
                                               Vec3f(0.50f, 0.78f, 0.42f), Vec3f(0.80f, 0.45f, 0.70f),
                                               Vec3f(0.85f, 0.78f, 0.35f), Vec3f(0.45f, 0.75f, 0.75f)};
  return palette[index % palette.size()];
}

SceneRenderer::SceneRenderer(const Model& model) : model_(model) {
  surface_program_ = link_program(kSurfaceVertexShader, kLitFragmentShader);
  solid_program_ = link_program(kSolidVertexShader, kLitFragmentShader);
  line_program_ = link_program(kLineVertexShader, kLineFragmentShader);

  glGenBuffers(1, &node_buffer_);
  glBindBuffer(GL_TEXTURE_BUFFER, node_buffer_);
  glBufferData(GL_TEXTURE_BUFFER, static_cast<GLsizeiptr>(model.node_rest.size() * 4 * sizeof(float)), nullptr,
               GL_STREAM_DRAW);
  glGenTextures(1, &node_texture_);
  glBindTexture(GL_TEXTURE_BUFFER, node_texture_);
  glTexBuffer(GL_TEXTURE_BUFFER, GL_RGBA32F, node_buffer_);  // RGB32F buffers need GL 4.0
  node_upload_.assign(model.node_rest.size() * 4, 0.0f);

  for (std::size_t o = 0; o < model.objects.size(); ++o) {
    const ObjectModel& object = model.objects[o];
    const std::vector<Vec3> normals = rest_normals(object);
    std::vector<SurfaceVertex> vertices(object.surface.vertices.size());
    for (std::size_t v = 0; v < vertices.size(); ++v) {
      const std::array<Index, 8>& corners = model.cell_nodes[object.vertex_cell[v]];
      for (int j = 0; j < 8; ++j) vertices[v].corners[j] = static_cast<GLint>(corners[j]);
      for (int k = 0; k < 3; ++k) {
        vertices[v].local[k] = static_cast<float>(object.vertex_local[v][k]);
        vertices[v].rest_normal[k] = static_cast<float>(normals[v][k]);
      }
    }
    SurfaceBatch batch;
    batch.colour = object_colour(o);
    batch.index_count = static_cast<GLsizei>(object.surface.triangles.size() * 3);
    glGenVertexArrays(1, &batch.vao);
    glBindVertexArray(batch.vao);
    glGenBuffers(1, &batch.vertex_buffer);
    glBindBuffer(GL_ARRAY_BUFFER, batch.vertex_buffer);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(SurfaceVertex)), vertices.data(),
                 GL_STATIC_DRAW);
    const GLsizei stride = sizeof(SurfaceVertex);
    glEnableVertexAttribArray(0);
    glVertexAttribIPointer(0, 4, GL_INT, stride, reinterpret_cast<void*>(offsetof(SurfaceVertex, corners)));
    glEnableVertexAttribArray(1);
    glVertexAttribIPointer(1, 4, GL_INT, stride, reinterpret_cast<void*>(offsetof(SurfaceVertex, corners) + 4 * sizeof(GLint)));
    glEnableVertexAttribArray(2);
    glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(offsetof(SurfaceVertex, local)));
    glEnableVertexAttribArray(3);
    glVertexAttribPointer(3, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(offsetof(SurfaceVertex, rest_normal)));
    glGenBuffers(1, &batch.index_buffer);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, batch.index_buffer);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(object.surface.triangles.size() * sizeof(std::array<Index, 3>)),
                 object.surface.triangles.data(), GL_STATIC_DRAW);
    surfaces_.push_back(batch);
  }

  // A unit quad in the xz plane (normal +y), scaled and turned onto each plane when drawn.
  const float quad[] = {-1, 0, -1, 0, 1, 0, 1, 0, -1, 0, 1, 0, 1, 0, 1, 0, 1, 0,
                        -1, 0, -1, 0, 1, 0, 1, 0, 1,  0, 1, 0, -1, 0, 1, 0, 1, 0};
  glGenVertexArrays(1, &quad_vao_);
  glBindVertexArray(quad_vao_);
  glGenBuffers(1, &quad_buffer_);
  glBindBuffer(GL_ARRAY_BUFFER, quad_buffer_);
  glBufferData(GL_ARRAY_BUFFER, sizeof quad, quad, GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), reinterpret_cast<void*>(3 * sizeof(float)));

  // A unit sphere (16 rings x 24 segments): position = normal.
  std::vector<float> sphere;
  std::vector<GLuint> sphere_indices;
  constexpr int kRings = 16, kSegments = 24;
  for (int r = 0; r <= kRings; ++r) {
    const float phi = 3.14159265f * static_cast<float>(r) / kRings;
    for (int s = 0; s <= kSegments; ++s) {
      const float theta = 2.0f * 3.14159265f * static_cast<float>(s) / kSegments;
      const float p[3] = {std::sin(phi) * std::cos(theta), std::cos(phi), std::sin(phi) * std::sin(theta)};
      sphere.insert(sphere.end(), {p[0], p[1], p[2], p[0], p[1], p[2]});
    }
  }
  for (int r = 0; r < kRings; ++r)
    for (int s = 0; s < kSegments; ++s) {
      const GLuint a = static_cast<GLuint>(r * (kSegments + 1) + s), b = a + kSegments + 1;
      sphere_indices.insert(sphere_indices.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
  sphere_index_count_ = static_cast<GLsizei>(sphere_indices.size());
  glGenVertexArrays(1, &sphere_vao_);
  glBindVertexArray(sphere_vao_);
  glGenBuffers(1, &sphere_buffer_);
  glBindBuffer(GL_ARRAY_BUFFER, sphere_buffer_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(sphere.size() * sizeof(float)), sphere.data(), GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), reinterpret_cast<void*>(3 * sizeof(float)));
  glGenBuffers(1, &sphere_index_buffer_);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, sphere_index_buffer_);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(sphere_indices.size() * sizeof(GLuint)),
               sphere_indices.data(), GL_STATIC_DRAW);

  glGenVertexArrays(1, &line_vao_);
  glBindVertexArray(line_vao_);
  glGenBuffers(1, &line_buffer_);
  glBindBuffer(GL_ARRAY_BUFFER, line_buffer_);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(LineVertex), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, sizeof(LineVertex), reinterpret_cast<void*>(3 * sizeof(float)));
  glBindVertexArray(0);
}

SceneRenderer::~SceneRenderer() {
  for (const SurfaceBatch& b : surfaces_) {
    glDeleteVertexArrays(1, &b.vao);
    glDeleteBuffers(1, &b.vertex_buffer);
    glDeleteBuffers(1, &b.index_buffer);
  }
  const GLuint arrays[] = {quad_vao_, sphere_vao_, line_vao_};
  glDeleteVertexArrays(3, arrays);
  const GLuint buffers[] = {node_buffer_, quad_buffer_, sphere_buffer_, sphere_index_buffer_, line_buffer_};
  glDeleteBuffers(5, buffers);
  glDeleteTextures(1, &node_texture_);
  glDeleteProgram(surface_program_);
  glDeleteProgram(solid_program_);
  glDeleteProgram(line_program_);
}

void SceneRenderer::draw(const Frame& frame, const OrbitCamera& camera, int width, int height,
                         const RenderOptions& options, SurfacePick* pick) {
  glViewport(0, 0, width, height);
  glClearColor(options.background.x(), options.background.y(), options.background.z(), 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);  // meshes may be open or inconsistently wound: shade both sides
  glDisable(GL_BLEND);
  const Mat4f view_projection = camera.view_projection(width, height);
  const Vec3f eye = camera.eye();

  // Lattice positions up, as floats: the only per-frame data the surfaces need.
  const std::size_t n = std::min(frame.nodes.size(), model_.node_rest.size());
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) node_upload_[4 * i + static_cast<std::size_t>(k)] = static_cast<float>(frame.nodes[i][k]);
  glBindBuffer(GL_TEXTURE_BUFFER, node_buffer_);
  glBufferSubData(GL_TEXTURE_BUFFER, 0, static_cast<GLsizeiptr>(node_upload_.size() * sizeof(float)), node_upload_.data());

  glUseProgram(surface_program_);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_BUFFER, node_texture_);
  glUniform1i(glGetUniformLocation(surface_program_, "nodes"), 0);
  set_matrix(surface_program_, "view_projection", view_projection);
  set_vec3(surface_program_, "eye", eye);
  glUniform1i(glGetUniformLocation(surface_program_, "checker"), 0);
  for (std::size_t o = 0; o < surfaces_.size(); ++o) {
    const SurfaceBatch& b = surfaces_[o];
    // An object asleep is drawn greyed, half its colour: frozen until something wakes it.
    const bool asleep = o < frame.asleep.size() && frame.asleep[o];
    set_vec3(surface_program_, "albedo", asleep ? Vec3f(0.5f * b.colour + Vec3f::Constant(0.2f)) : b.colour);
    glBindVertexArray(b.vao);
    glDrawElements(GL_TRIANGLES, b.index_count, GL_UNSIGNED_INT, nullptr);
  }

  if (pick && pick->requested) {
    // Depth under the cursor, before planes and probe are drawn: 1.0 means no object there.
    const int x = static_cast<int>(pick->x_px), y = height - 1 - static_cast<int>(pick->y_px);
    float depth = 1.0f;
    if (x >= 0 && x < width && y >= 0 && y < height) glReadPixels(x, y, 1, 1, GL_DEPTH_COMPONENT, GL_FLOAT, &depth);
    pick->hit = depth < 1.0f;
    if (pick->hit) {
      const Eigen::Vector4f ndc(2.0f * (static_cast<float>(x) + 0.5f) / static_cast<float>(width) - 1.0f,
                                2.0f * (static_cast<float>(y) + 0.5f) / static_cast<float>(height) - 1.0f,
                                2.0f * depth - 1.0f, 1.0f);
      const Eigen::Vector4f w = view_projection.inverse() * ndc;
      pick->point = w.head<3>() / w.w();
    }
  }

  if (options.planes) draw_planes(view_projection, camera);
  if (options.probe && has(model_.settings.effects, Effect::Probe))
    draw_sphere(view_projection, eye, to_float(frame.probe.x), static_cast<float>(model_.settings.probe.radius),
                Vec3f(0.85f, 0.85f, 0.9f));

  // Overlays on top of everything (the lattice and boxes sit inside the surfaces).
  build_overlay_lines(frame, options);
  if (!lines_.empty()) {
    glDisable(GL_DEPTH_TEST);
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(line_program_);
    set_matrix(line_program_, "view_projection", view_projection);
    glBindVertexArray(line_vao_);
    glBindBuffer(GL_ARRAY_BUFFER, line_buffer_);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(lines_.size() * sizeof(LineVertex)), lines_.data(), GL_STREAM_DRAW);
    glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(lines_.size()));
  }
  glBindVertexArray(0);
  glUseProgram(0);
  glDisable(GL_DEPTH_TEST);
  glEnable(GL_BLEND);
}

void SceneRenderer::draw_planes(const Mat4f& view_projection, const OrbitCamera& camera) {
  glUseProgram(solid_program_);
  set_matrix(solid_program_, "view_projection", view_projection);
  set_vec3(solid_program_, "eye", camera.eye());
  set_vec3(solid_program_, "albedo", Vec3f(0.55f, 0.56f, 0.58f));
  glUniform1i(glGetUniformLocation(solid_program_, "checker"), 1);
  glBindVertexArray(quad_vao_);
  const Vec3f eye = camera.eye();
  for (const PlaneModel& plane : model_.planes) {
    const Vec3f n = to_float(plane.normal);
    // A plane bounds a solid half-space below it: seen from inside that solid (a bin's near
    // wall, from a camera outside the bin) it would hide everything, so it is not drawn.
    if (eye.dot(n) < static_cast<float>(plane.offset)) continue;
    // A square around the point of the plane nearest the camera's target, large enough to
    // reach the horizon at this zoom.
    const Vec3f u = (std::abs(n.x()) < 0.9f ? Vec3f::UnitX() : Vec3f::UnitY()).cross(n).normalized();
    const Vec3f v = n.cross(u);
    const Vec3f centre = camera.target - (camera.target.dot(n) - static_cast<float>(plane.offset)) * n;
    const float half = std::max(2.0f, camera.distance * 20.0f);
    Mat4f m = Mat4f::Identity();
    m.block<3, 1>(0, 0) = u * half;
    m.block<3, 1>(0, 1) = n;
    m.block<3, 1>(0, 2) = v * half;
    m.block<3, 1>(0, 3) = centre;
    set_matrix(solid_program_, "model", m);
    // The checker follows world coordinates along the plane, so it does not slide with the camera.
    set_vec3(solid_program_, "plane_u", u);
    set_vec3(solid_program_, "plane_v", v);
    glDrawArrays(GL_TRIANGLES, 0, 6);
  }
  glUniform1i(glGetUniformLocation(solid_program_, "checker"), 0);
}

void SceneRenderer::draw_sphere(const Mat4f& view_projection, const Vec3f& eye, const Vec3f& centre, float radius,
                                const Vec3f& colour) {
  glUseProgram(solid_program_);
  set_matrix(solid_program_, "view_projection", view_projection);
  set_vec3(solid_program_, "eye", eye);
  set_vec3(solid_program_, "albedo", colour);
  glUniform1i(glGetUniformLocation(solid_program_, "checker"), 0);
  Mat4f m = Mat4f::Identity();
  m.block<3, 3>(0, 0) *= radius;
  m.block<3, 1>(0, 3) = centre;
  set_matrix(solid_program_, "model", m);
  glBindVertexArray(sphere_vao_);
  glDrawElements(GL_TRIANGLES, sphere_index_count_, GL_UNSIGNED_INT, nullptr);
}

void SceneRenderer::line(const Vec3f& a, const Vec3f& b, const std::array<float, 4>& c) {
  lines_.push_back({a.x(), a.y(), a.z(), c[0], c[1], c[2], c[3]});
  lines_.push_back({b.x(), b.y(), b.z(), c[0], c[1], c[2], c[3]});
}

void SceneRenderer::build_overlay_lines(const Frame& frame, const RenderOptions& options) {
  lines_.clear();
  const std::array<float, 4> lattice_colour{0.75f, 0.8f, 0.9f, 0.35f}, box_colour{1.0f, 0.85f, 0.2f, 0.3f},
      grab_colour{1.0f, 1.0f, 1.0f, 0.9f}, force_colour{1.0f, 0.3f, 0.25f, 1.0f};
  if (options.lattice && frame.nodes.size() >= model_.node_rest.size()) {
    for (const std::array<Index, 8>& corners : model_.cell_nodes)
      for (const auto& e : kCellEdges) line(to_float(frame.nodes[corners[e[0]]]), to_float(frame.nodes[corners[e[1]]]), lattice_colour);
  }
  if (options.boxes) {
    for (const std::array<Vec3, 9>& box : frame.boxes) {
      Vec3 lo = box[0], hi = box[0];
      for (const Vec3& p : box) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
      for (const auto& e : kCellEdges) {
        auto corner = [&](int j) { return Vec3f(static_cast<float>((j & 1) ? hi.x() : lo.x()), static_cast<float>((j & 2) ? hi.y() : lo.y()),
                                                static_cast<float>((j & 4) ? hi.z() : lo.z())); };
        line(corner(e[0]), corner(e[1]), box_colour);
      }
      // The centre-of-mass node: a small cross.
      const Vec3f c = to_float(box[8]);
      const float r = 0.1f * static_cast<float>((hi - lo).minCoeff()) + 1e-4f;
      for (int k = 0; k < 3; ++k) line(c - r * Vec3f::Unit(k), c + r * Vec3f::Unit(k), box_colour);
    }
  }
  if (options.contacts) {
    static const std::array<std::array<float, 4>, 4> kind_colour = {{{1.0f, 0.35f, 0.3f, 1.0f},    // inter
                                                                     {1.0f, 0.6f, 0.1f, 1.0f},     // self
                                                                     {0.3f, 0.85f, 1.0f, 1.0f},    // plane
                                                                     {0.9f, 0.4f, 1.0f, 1.0f}}};   // probe
    const std::uint32_t count = std::min<std::uint32_t>(frame.contact_count, static_cast<std::uint32_t>(frame.contacts.size()));
    for (std::uint32_t i = 0; i < count; ++i) {
      const Contact& c = frame.contacts[i];
      const Vec3f p = to_float(c.point), n = to_float(c.normal);
      const auto& colour = kind_colour[static_cast<std::size_t>(c.kind) % kind_colour.size()];
      line(p, p + 0.01f * n, colour);  // 1 cm along the push-out normal
      for (int k = 0; k < 3; ++k) line(p - 0.002f * Vec3f::Unit(k), p + 0.002f * Vec3f::Unit(k), colour);
    }
  }
  if (frame.grab.active && frame.grab.cell < model_.cell_count() && frame.nodes.size() >= model_.node_rest.size()) {
    const std::array<Index, 8>& corners = model_.cell_nodes[frame.grab.cell];
    const Vec3 point = trilinear_map(frame.grab.local, [&](int j) -> const Vec3& { return frame.nodes[corners[j]]; });
    const Vec3f a = to_float(point), b = to_float(frame.grab.target);
    line(a, b, grab_colour);
    for (int k = 0; k < 3; ++k) line(b - 0.004f * Vec3f::Unit(k), b + 0.004f * Vec3f::Unit(k), grab_colour);
  }
  if (options.probe_force && has(model_.settings.effects, Effect::Probe)) {
    // The force the device renders, drawn from the proxy: 2 cm per newton, at most 15 cm.
    const Vec3f origin = to_float(frame.probe.x), force = to_float(frame.probe.force);
    const float length = std::min(0.02f * force.norm(), 0.15f);
    if (length > 1e-4f) {
      const Vec3f d = force.normalized(), tip = origin + length * d;
      const Vec3f side = (std::abs(d.y()) < 0.9f ? Vec3f::UnitY() : Vec3f::UnitX()).cross(d).normalized();
      const Vec3f side2 = d.cross(side);
      line(origin, tip, force_colour);
      const float head = std::min(0.3f * length, 0.01f);
      const std::array<Vec3f, 4> fins = {side, -side, side2, -side2};
      for (const Vec3f& s : fins) line(tip, tip - head * d + 0.5f * head * s, force_colour);
    }
    const Vec3f device = to_float(frame.probe.device);
    for (int k = 0; k < 3; ++k) line(device - 0.005f * Vec3f::Unit(k), device + 0.005f * Vec3f::Unit(k), grab_colour);
  }
}

}  // namespace ffd::ui
