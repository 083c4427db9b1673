#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/aabb_kernels.cpp"
#include <hwy/foreach_target.h>  // must come before highway.h
#include <hwy/highway.h>

#include "kernels/aabb_kernels.h"

HWY_BEFORE_NAMESPACE();
namespace ffd {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// An axis-aligned box [lo, hi] in every lane.
template <class D>
struct BoxLanes {
  using V = hn::Vec<D>;
  BoxLanes(D d, const Vec3& lo, const Vec3& hi)
      : lo{hn::Set(d, lo.x()), hn::Set(d, lo.y()), hn::Set(d, lo.z())},
        hi{hn::Set(d, hi.x()), hn::Set(d, hi.y()), hn::Set(d, hi.z())} {}
  V lo[3], hi[3];
};

// Lanes i.. of `boxes` separated from [lo, hi] on some axis: [lo, hi] wholly below the box,
// or wholly above (a NaN separates nothing).
template <class D>
hn::Mask<D> Apart(D d, const BoxColumns& boxes, Index i, const BoxLanes<D>& b) {
  return hn::Or(hn::Or(hn::Or(hn::Lt(b.hi[0], hn::LoadU(d, boxes.lo[0] + i)), hn::Gt(b.lo[0], hn::LoadU(d, boxes.hi[0] + i))),
                       hn::Or(hn::Lt(b.hi[1], hn::LoadU(d, boxes.lo[1] + i)), hn::Gt(b.lo[1], hn::LoadU(d, boxes.hi[1] + i)))),
                hn::Or(hn::Lt(b.hi[2], hn::LoadU(d, boxes.lo[2] + i)), hn::Gt(b.lo[2], hn::LoadU(d, boxes.hi[2] + i))));
}
// The same for box i alone (the tail a vector does not fill).
bool apart(const BoxColumns& boxes, Index i, const Vec3& lo, const Vec3& hi) {
  return hi.x() < boxes.lo[0][i] || lo.x() > boxes.hi[0][i] || hi.y() < boxes.lo[1][i] || lo.y() > boxes.hi[1][i] ||
         hi.z() < boxes.lo[2][i] || lo.z() > boxes.hi[2][i];
}

// Writes to `hits`, in increasing order, every i < count kept: by `keep_lanes(i)` (a mask,
// for lanes i..) a vector at a time, by `keep_one(i)` in the tail. Returns how many.
template <class D, class KeepLanes, class KeepOne>
Index Keep(D d, Index count, const KeepLanes& keep_lanes, const KeepOne& keep_one, Index* HWY_RESTRICT hits) {
  const Index lanes = static_cast<Index>(hn::Lanes(d));
  Index found = 0;
  Index i = 0;
  for (; i + lanes <= count; i += lanes) {
    const auto kept = keep_lanes(i);
    if (hn::AllFalse(d, kept)) continue;
    uint8_t bits[HWY_MAX_BYTES / sizeof(double) / 8 + 1] = {};
    hn::StoreMaskBits(d, kept, bits);
    for (Index k = 0; k < lanes; ++k) {
      hits[found] = i + k;
      found += static_cast<Index>((bits[k / 8] >> (k % 8)) & 1u);
    }
  }
  for (; i < count; ++i) {
    hits[found] = i;
    found += static_cast<Index>(keep_one(i));
  }
  return found;
}

Index BoxesMeeting(const BoxColumns& boxes, Index count, const Vec3& lo, const Vec3& hi, Index* HWY_RESTRICT hits) {
  using D = hn::ScalableTag<double>;
  const D d;
  const BoxLanes<D> box(d, lo, hi);
  return Keep(
      d, count, [&](Index i) { return hn::Not(Apart(d, boxes, i, box)); },
      [&](Index i) { return !apart(boxes, i, lo, hi); }, hits);
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
  using D = hn::ScalableTag<double>;
  const D d;
  const BoxLanes<D> box(d, lo, hi);
  const auto p_x = hn::Set(d, p.x()), p_y = hn::Set(d, p.y()), p_z = hn::Set(d, p.z());
  const auto q_x = hn::Set(d, q.x()), q_y = hn::Set(d, q.y()), q_z = hn::Set(d, q.z());
  const auto zero = hn::Zero(d);
  const auto keep_lanes = [&](Index i) {
    const auto separated = Apart(d, t.boxes, i, box);
    if (hn::AllTrue(d, separated)) return hn::Not(separated);  // the planes need not be computed
    const auto hp = PlaneHeights(d, t, i, p_x, p_y, p_z), hq = PlaneHeights(d, t, i, q_x, q_y, q_z);
    const auto straddled =
        hn::Or(hn::And(hn::Gt(hp, zero), hn::Lt(hq, zero)), hn::And(hn::Lt(hp, zero), hn::Gt(hq, zero)));
    return hn::AndNot(separated, straddled);
  };
  const auto keep_one = [&](Index i) {
    const Vec3 face(t.face[0][i], t.face[1][i], t.face[2][i]), corner(t.corner[0][i], t.corner[1][i], t.corner[2][i]);
    const double hp = plane_height(face, corner, p), hq = plane_height(face, corner, q);
    return !apart(t.boxes, i, lo, hi) && ((hp > 0.0 && hq < 0.0) || (hp < 0.0 && hq > 0.0));
  };
  return Keep(d, count, keep_lanes, keep_one, hits);
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
