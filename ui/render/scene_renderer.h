#pragma once
// Draws a running scene with OpenGL 3.3 core: the embedded surfaces, deformed on the GPU
// from the frame's lattice node positions (eq. 2 in the vertex shader), the scene's planes,
// the probe, and optional overlays (FFD lattice, FFD AABBs, contacts, probe force).
// The same code draws into a GLFW window and into the headless EGL framebuffer.
#include <array>
#include <cstdint>
#include <vector>

#include <epoxy/gl.h>

#include "ffd/model.h"
#include "ffd/physics_loop.h"
#include "render/camera.h"

namespace ffd::ui {

struct RenderOptions {
  bool planes = true;
  bool probe = true;         // the probe's sphere proxy (scenes with the "probe" effect)
  bool lattice = false;      // lattice cell edges
  bool boxes = false;        // FFD AABBs (the box of each surface cell's 9 nodes)
  bool contacts = true;      // this step's contacts: point and normal
  bool probe_force = true;   // arrow along the force the device renders
  Vec3f background{0.17f, 0.19f, 0.23f};
};

// Colour of object `index`, shared by the renderer and the panels (linear RGB in [0, 1]).
Vec3f object_colour(std::size_t index);

// The world point under a pixel, read back from the depth buffer after the surfaces are drawn
// (before the planes, so only objects can be picked).
struct SurfacePick {
  bool requested = false;
  float x_px = 0.0f, y_px = 0.0f;  // from the top-left
  bool hit = false;
  Vec3f point = Vec3f::Zero();     // m
};

class SceneRenderer {
 public:
  explicit SceneRenderer(const Model& model);
  ~SceneRenderer();
  SceneRenderer(const SceneRenderer&) = delete;
  SceneRenderer& operator=(const SceneRenderer&) = delete;

  // Draws into the bound framebuffer (size width x height) and leaves depth testing off and
  // blending on, ready for ImGui on top.
  void draw(const Frame& frame, const OrbitCamera& camera, int width, int height, const RenderOptions& options,
            SurfacePick* pick = nullptr);

 private:
  struct SurfaceBatch {
    GLuint vao = 0, vertex_buffer = 0, index_buffer = 0;
    GLsizei index_count = 0;
    Vec3f colour;
  };
  struct LineVertex {
    float x, y, z, r, g, b, a;
  };

  void draw_planes(const Mat4f& view_projection, const OrbitCamera& camera);
  void draw_sphere(const Mat4f& view_projection, const Vec3f& eye, const Vec3f& centre, float radius,
                   const Vec3f& colour);
  void build_overlay_lines(const Frame& frame, const RenderOptions& options);
  void line(const Vec3f& a, const Vec3f& b, const std::array<float, 4>& colour);

  const Model& model_;
  GLuint surface_program_ = 0, solid_program_ = 0, line_program_ = 0;
  GLuint node_buffer_ = 0, node_texture_ = 0;
  std::vector<float> node_upload_;  // (N x 4) floats: xyz + padding, as the texture buffer wants
  std::vector<SurfaceBatch> surfaces_;
  GLuint quad_vao_ = 0, quad_buffer_ = 0;
  GLuint sphere_vao_ = 0, sphere_buffer_ = 0, sphere_index_buffer_ = 0;
  GLsizei sphere_index_count_ = 0;
  GLuint line_vao_ = 0, line_buffer_ = 0;
  std::vector<LineVertex> lines_;
};

}  // namespace ffd::ui
