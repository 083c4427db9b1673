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
    // Separated on some axis: the edge's box wholly below the triangle's, or wholly above.
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

}  // namespace HWY_NAMESPACE
}  // namespace ffd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace ffd {

HWY_EXPORT(BoxesMeeting);

Index boxes_meeting(const BoxColumns& boxes, Index count, const Vec3& lo, const Vec3& hi, Index* hits) {
  return HWY_DYNAMIC_DISPATCH(BoxesMeeting)(boxes, count, lo, hi, hits);
}

}  // namespace ffd
#endif
