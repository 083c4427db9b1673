#pragma once
// An orbit camera around a target point: yaw and pitch in radians, distance in metres.
// Pixel coordinates have their origin at the top-left of the framebuffer (as mouse input does).
#include <Eigen/Core>

namespace ffd::ui {

using Vec2f = Eigen::Vector2f;
using Vec3f = Eigen::Vector3f;
using Mat4f = Eigen::Matrix4f;

struct Ray {
  Vec3f origin;
  Vec3f direction;  // unit
};

struct OrbitCamera {
  Vec3f target{0.0f, 0.12f, 0.0f};  // m
  float yaw = 0.7f;                  // rad, about +y
  float pitch = 0.45f;               // rad, above the horizon
  float distance = 0.9f;             // m
  float fov_y = 0.7854f;             // rad (45 degrees)

  Vec3f eye() const;
  Vec3f forward() const;  // unit, from the eye towards the target
  Mat4f view() const;
  Mat4f projection(float aspect) const;
  Mat4f view_projection(int width, int height) const;

  // Right-drag: turn around the target. Middle-drag: move the target in the view plane.
  // Wheel: move closer (positive clicks) or away.
  void orbit(float dx_px, float dy_px);
  void pan(float dx_px, float dy_px, int height_px);
  void zoom(float clicks);
  // Place the camera so that the box [lo, hi] fills the view.
  void frame(const Vec3f& lo, const Vec3f& hi);

  Ray ray(float x_px, float y_px, int width, int height) const;
  // Pixel position of a world point; false when it is behind the camera.
  bool project(const Vec3f& p, int width, int height, Vec2f& pixel) const;
};

// The point where a ray meets the plane through `point` with normal `normal`; false when the
// ray is parallel to the plane or the plane is behind it.
bool intersect_plane(const Ray& ray, const Vec3f& point, const Vec3f& normal, Vec3f& hit);

}  // namespace ffd::ui
