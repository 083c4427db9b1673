#pragma once
// Basic numeric types. All lengths in metres, times in seconds, masses in kilograms.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdint>

namespace ffd {

using Vec3 = Eigen::Vector3d;
using Vec3i = Eigen::Vector3i;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;
using Index = std::uint32_t;

inline constexpr Index kNoIndex = 0xFFFFFFFFu;

// Component by component: Eigen's allFinite() computes x - x, which raises FE_INVALID on an
// infinity (and the tests trap floating-point exceptions).
inline bool is_finite(const Vec3& p) { return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()); }

}  // namespace ffd
