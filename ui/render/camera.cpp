#include "render/camera.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace ffd::ui {

namespace {
constexpr float kMaxPitch = 1.55f;         // rad: just short of straight down/up
constexpr float kRadiansPerPixel = 0.008f;
constexpr float kZoomPerClick = 0.88f;
}  // namespace

Vec3f OrbitCamera::forward() const {
  return Vec3f(-std::cos(pitch) * std::sin(yaw), -std::sin(pitch), -std::cos(pitch) * std::cos(yaw));
}

Vec3f OrbitCamera::eye() const { return target - distance * forward(); }

Mat4f OrbitCamera::view() const {
  const Vec3f f = forward();
  const Vec3f r = f.cross(Vec3f::UnitY()).normalized();
  const Vec3f u = r.cross(f);
  const Vec3f e = eye();
  Mat4f m = Mat4f::Identity();
  m.block<1, 3>(0, 0) = r.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -r.dot(e);
  m(1, 3) = -u.dot(e);
  m(2, 3) = f.dot(e);
  return m;
}

Mat4f OrbitCamera::projection(float aspect) const {
  // Near and far follow the distance, so depth precision stays useful from 1 cm to 100 m.
  const float n = std::max(1e-4f, distance * 0.01f), far = distance * 100.0f + 10.0f;
  const float t = 1.0f / std::tan(fov_y * 0.5f);
  Mat4f m = Mat4f::Zero();
  m(0, 0) = t / aspect;
  m(1, 1) = t;
  m(2, 2) = (far + n) / (n - far);
  m(2, 3) = 2.0f * far * n / (n - far);
  m(3, 2) = -1.0f;
  return m;
}

Mat4f OrbitCamera::view_projection(int width, int height) const {
  return projection(static_cast<float>(width) / static_cast<float>(std::max(height, 1))) * view();
}

void OrbitCamera::orbit(float dx_px, float dy_px) {
  yaw -= dx_px * kRadiansPerPixel;
  pitch = std::clamp(pitch + dy_px * kRadiansPerPixel, -kMaxPitch, kMaxPitch);
}

void OrbitCamera::pan(float dx_px, float dy_px, int height_px) {
  // One pixel moves the target by one pixel's worth of the view at the target's depth.
  const float metres_per_px = 2.0f * distance * std::tan(fov_y * 0.5f) / static_cast<float>(std::max(height_px, 1));
  const Vec3f f = forward();
  const Vec3f r = f.cross(Vec3f::UnitY()).normalized();
  const Vec3f u = r.cross(f);
  target += (-dx_px * r + dy_px * u) * metres_per_px;
}

void OrbitCamera::zoom(float clicks) { distance = std::clamp(distance * std::pow(kZoomPerClick, clicks), 0.01f, 1e4f); }

void OrbitCamera::frame(const Vec3f& lo, const Vec3f& hi) {
  target = 0.5f * (lo + hi);
  const float radius = std::max(0.5f * (hi - lo).norm(), 0.01f);
  distance = radius / std::sin(fov_y * 0.5f);
}

Ray OrbitCamera::ray(float x_px, float y_px, int width, int height) const {
  const Mat4f inverse = view_projection(width, height).inverse();
  const float x = 2.0f * (x_px + 0.5f) / static_cast<float>(width) - 1.0f;
  const float y = 1.0f - 2.0f * (y_px + 0.5f) / static_cast<float>(height);
  const Eigen::Vector4f a = inverse * Eigen::Vector4f(x, y, -1.0f, 1.0f);
  const Eigen::Vector4f b = inverse * Eigen::Vector4f(x, y, 1.0f, 1.0f);
  const Vec3f near_point = a.head<3>() / a.w(), far_point = b.head<3>() / b.w();
  return {near_point, (far_point - near_point).normalized()};
}

bool OrbitCamera::project(const Vec3f& p, int width, int height, Vec2f& pixel) const {
  const Eigen::Vector4f c = view_projection(width, height) * Eigen::Vector4f(p.x(), p.y(), p.z(), 1.0f);
  if (c.w() <= 0.0f) return false;
  pixel.x() = (c.x() / c.w() * 0.5f + 0.5f) * static_cast<float>(width) - 0.5f;
  pixel.y() = (0.5f - c.y() / c.w() * 0.5f) * static_cast<float>(height) - 0.5f;
  return true;
}

bool intersect_plane(const Ray& ray, const Vec3f& point, const Vec3f& normal, Vec3f& hit) {
  const float d = ray.direction.dot(normal);
  if (std::abs(d) < 1e-6f) return false;
  const float t = (point - ray.origin).dot(normal) / d;
  if (t < 0.0f) return false;
  hit = ray.origin + t * ray.direction;
  return true;
}

}  // namespace ffd::ui
