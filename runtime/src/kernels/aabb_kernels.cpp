#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/aabb_kernels.cpp"
#include <hwy/foreach_target.h>  // must come before highway.h
#include <hwy/highway.h>

#include "kernels/aabb_kernels.h"

HWY_BEFORE_NAMESPACE();
namespace ffd {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

Index BoxesMeeting(const BoxColumns& boxes, Index count, const Vec3& lo, const Vec3& hi, Index* HWY_RESTRICT hits) {
  const hn::ScalableTag<double> d;
  const Index lanes = static_cast<Index>(hn::Lanes(d));
  const auto lo_x = hn::Set(d, lo.x()), lo_y = hn::Set(d, lo.y()), lo_z = hn::Set(d, lo.z());
  const auto hi_x = hn::Set(d, hi.x()), hi_y = hn::Set(d, hi.y()), hi_z = hn::Set(d, hi.z());
  Index found = 0;
  Index i = 0;
  for (; i + lanes <= count; i += lanes) {
    // Separated on some axis: [lo, hi] wholly below the box, or wholly above.
    const auto apart = hn::Or(
        hn::Or(hn::Or(hn::Lt(hi_x, hn::LoadU(d, boxes.lo[0] + i)), hn::Gt(lo_x, hn::LoadU(d, boxes.hi[0] + i))),
               hn::Or(hn::Lt(hi_y, hn::LoadU(d, boxes.lo[1] + i)), hn::Gt(lo_y, hn::LoadU(d, boxes.hi[1] + i)))),
        hn::Or(hn::Lt(hi_z, hn::LoadU(d, boxes.lo[2] + i)), hn::Gt(lo_z, hn::LoadU(d, boxes.hi[2] + i))));
    if (hn::AllTrue(d, apart)) continue;
    uint8_t bits[HWY_MAX_BYTES / sizeof(double) / 8 + 1] = {};
    hn::StoreMaskBits(d, hn::Not(apart), bits);
    for (Index k = 0; k < lanes; ++k) {
      hits[found] = i + k;
      found += static_cast<Index>((bits[k / 8] >> (k % 8)) & 1u);
    }
  }
  for (; i < count; ++i) {
    const bool apart = hi.x() < boxes.lo[0][i] || lo.x() > boxes.hi[0][i] || hi.y() < boxes.lo[1][i] ||
                       lo.y() > boxes.hi[1][i] || hi.z() < boxes.lo[2][i] || lo.z() > boxes.hi[2][i];
    hits[found] = i;
    found += static_cast<Index>(!apart);
  }
  return found;
}

// plane_height of point (px, py, pz) over a vector of triangles' planes, lane by lane.
template <class D, class V>
V PlaneHeights(D d, const TriangleColumns& t, Index i, V px, V py, V pz) {
  const V dx = hn::Sub(px, hn::LoadU(d, t.corner[0] + i));
  const V dy = hn::Sub(py, hn::LoadU(d, t.corner[1] + i));
  const V dz = hn::Sub(pz, hn::LoadU(d, t.corner[2] + i));
  return hn::Add(hn::Add(hn::Mul(hn::LoadU(d, t.face[0] + i), dx), hn::Mul(hn::LoadU(d, t.face[1] + i), dy)),
                 hn::Mul(hn::LoadU(d, t.face[2] + i), dz));
}

Index TrianglesStraddled(const TriangleColumns& t, Index count, const Vec3& p, const Vec3& q, const Vec3& lo,
                         const Vec3& hi, Index* HWY_RESTRICT hits) {
  const hn::ScalableTag<double> d;
  const Index lanes = static_cast<Index>(hn::Lanes(d));
  const auto lo_x = hn::Set(d, lo.x()), lo_y = hn::Set(d, lo.y()), lo_z = hn::Set(d, lo.z());
  const auto hi_x = hn::Set(d, hi.x()), hi_y = hn::Set(d, hi.y()), hi_z = hn::Set(d, hi.z());
  const auto p_x = hn::Set(d, p.x()), p_y = hn::Set(d, p.y()), p_z = hn::Set(d, p.z());
  const auto q_x = hn::Set(d, q.x()), q_y = hn::Set(d, q.y()), q_z = hn::Set(d, q.z());
  const auto zero = hn::Zero(d);
  const BoxColumns& boxes = t.boxes;
  Index found = 0;
  Index i = 0;
  for (; i + lanes <= count; i += lanes) {
    // Separated on some axis: the edge's box wholly below the triangle's, or wholly above.
    const auto apart = hn::Or(
        hn::Or(hn::Or(hn::Lt(hi_x, hn::LoadU(d, boxes.lo[0] + i)), hn::Gt(lo_x, hn::LoadU(d, boxes.hi[0] + i))),
               hn::Or(hn::Lt(hi_y, hn::LoadU(d, boxes.lo[1] + i)), hn::Gt(lo_y, hn::LoadU(d, boxes.hi[1] + i)))),
        hn::Or(hn::Lt(hi_z, hn::LoadU(d, boxes.lo[2] + i)), hn::Gt(lo_z, hn::LoadU(d, boxes.hi[2] + i))));
    if (hn::AllTrue(d, apart)) continue;
    const auto hp = PlaneHeights(d, t, i, p_x, p_y, p_z), hq = PlaneHeights(d, t, i, q_x, q_y, q_z);
    const auto straddled =
        hn::Or(hn::And(hn::Gt(hp, zero), hn::Lt(hq, zero)), hn::And(hn::Lt(hp, zero), hn::Gt(hq, zero)));
    const auto candidate = hn::AndNot(apart, straddled);
    if (hn::AllFalse(d, candidate)) continue;
    uint8_t bits[HWY_MAX_BYTES / sizeof(double) / 8 + 1] = {};
    hn::StoreMaskBits(d, candidate, bits);
    for (Index k = 0; k < lanes; ++k) {
      hits[found] = i + k;
      found += static_cast<Index>((bits[k / 8] >> (k % 8)) & 1u);
    }
  }
  for (; i < count; ++i) {
    const bool apart = hi.x() < boxes.lo[0][i] || lo.x() > boxes.hi[0][i] || hi.y() < boxes.lo[1][i] ||
                       lo.y() > boxes.hi[1][i] || hi.z() < boxes.lo[2][i] || lo.z() > boxes.hi[2][i];
    const Vec3 face(t.face[0][i], t.face[1][i], t.face[2][i]), corner(t.corner[0][i], t.corner[1][i], t.corner[2][i]);
    const double hp = plane_height(face, corner, p), hq = plane_height(face, corner, q);
    hits[found] = i;
    found += static_cast<Index>(!apart && ((hp > 0.0 && hq < 0.0) || (hp < 0.0 && hq > 0.0)));
  }
  return found;
}

}  // namespace HWY_NAMESPACE
}  // namespace ffd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace ffd {

HWY_EXPORT(BoxesMeeting);
HWY_EXPORT(TrianglesStraddled);

Index boxes_meeting(const BoxColumns& boxes, Index count, const Vec3& lo, const Vec3& hi, Index* hits) {
  return HWY_DYNAMIC_DISPATCH(BoxesMeeting)(boxes, count, lo, hi, hits);
}

Index triangles_straddled(const TriangleColumns& triangles, Index count, const Vec3& p, const Vec3& q, const Vec3& lo,
                          const Vec3& hi, Index* hits) {
  return HWY_DYNAMIC_DISPATCH(TrianglesStraddled)(triangles, count, p, q, lo, hi, hits);
}

}  // namespace ffd
#endif
