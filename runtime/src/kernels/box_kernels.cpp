#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/box_kernels.cpp"
#include <hwy/foreach_target.h>  // must come before highway.h
#include <hwy/highway.h>

#include "kernels/box_kernels.h"

HWY_BEFORE_NAMESPACE();
namespace ffd {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// One group of lanes starting at box `first` (a multiple of the lane count within its block).
template <class D>
HWY_INLINE void update_lanes(D d, const BoxSet& set, std::size_t first, const double* HWY_RESTRICT x,
                             const BoxOutput& out, std::size_t boxes) {
  using V = hn::Vec<D>;
  const hn::RebindToSigned<D> di;
  const std::size_t block = first / kBoxLanes, lane = first % kBoxLanes;
  const double* local = set.kernel_local.data() + block * 9 * kBoxLanes + lane;
  const std::int64_t* corner = set.kernel_corner.data() + block * 8 * kBoxLanes + lane;
  V cell[8][3];
  for (int j = 0; j < 8; ++j) {
    const auto offset = hn::LoadU(di, corner + j * kBoxLanes);
    for (int axis = 0; axis < 3; ++axis) cell[j][axis] = hn::GatherIndex(d, x + axis, offset);
  }
  constexpr std::size_t kMaxLanes = kBoxLanes;
  HWY_ALIGN double values[27 * kMaxLanes];
  // Eq. 2 for each of the 9 nodes, exactly as trilinear_map computes it for one point: the
  // 8 products of the linear Bernstein functions, then the weighted corners summed in order.
  const V one = hn::Set(d, 1.0);
  for (int k = 0; k < 9; ++k) {
    // Node k's local coordinates: the box's lo or hi per axis (corner k = (k & 1, k >> 1 & 1,
    // k >> 2 & 1)), or its centre of mass.
    V stu[3];
    for (int axis = 0; axis < 3; ++axis) {
      const int row = k == 8 ? 6 + axis : ((k >> axis) & 1 ? 3 + axis : axis);
      stu[axis] = hn::LoadU(d, local + row * kBoxLanes);
    }
    const V s = stu[0], t = stu[1], u = stu[2];
    const V s0 = hn::Sub(one, s), t0 = hn::Sub(one, t), u0 = hn::Sub(one, u);
    const V w[8] = {hn::Mul(hn::Mul(s0, t0), u0), hn::Mul(hn::Mul(s, t0), u0), hn::Mul(hn::Mul(s0, t), u0),
                    hn::Mul(hn::Mul(s, t), u0),   hn::Mul(hn::Mul(s0, t0), u), hn::Mul(hn::Mul(s, t0), u),
                    hn::Mul(hn::Mul(s0, t), u),   hn::Mul(hn::Mul(s, t), u)};
    for (int axis = 0; axis < 3; ++axis) {
      V p = hn::Mul(w[0], cell[0][axis]);
      for (int j = 1; j < 8; ++j) p = hn::Add(p, hn::Mul(w[j], cell[j][axis]));
      hn::Store(p, d, values + (3 * k + axis) * kMaxLanes);
    }
  }
  const std::size_t lanes = hn::Lanes(d);
  for (std::size_t l = 0; l < lanes && first + l < boxes; ++l) {
    std::array<Vec3, 9>& nodes = out.nodes[first + l];
    for (int k = 0; k < 9; ++k)
      nodes[k] = Vec3(values[(3 * k) * kMaxLanes + l], values[(3 * k + 1) * kMaxLanes + l], values[(3 * k + 2) * kMaxLanes + l]);
    out.valid[first + l] = 1;
  }
  if (out.lo[0]) {
    for (int axis = 0; axis < 3; ++axis) {
      V lo = hn::Load(d, values + axis * kMaxLanes), hi = lo;
      for (int k = 1; k < 9; ++k) {
        const V v = hn::Load(d, values + (3 * k + axis) * kMaxLanes);
        lo = hn::Min(lo, v);
        hi = hn::Max(hi, v);
      }
      if (first + lanes <= boxes) {
        hn::StoreU(lo, d, out.lo[axis] + first);
        hn::StoreU(hi, d, out.hi[axis] + first);
      } else {
        HWY_ALIGN double l_values[kMaxLanes], h_values[kMaxLanes];
        hn::Store(lo, d, l_values);
        hn::Store(hi, d, h_values);
        for (std::size_t l = 0; first + l < boxes; ++l) {
          out.lo[axis][first + l] = l_values[l];
          out.hi[axis][first + l] = h_values[l];
        }
      }
    }
  }
}

void UpdateBoxBlocks(const BoxSet& set, Index first_block, Index last_block, const double* HWY_RESTRICT x,
                     const BoxOutput& out) {
  const hn::CappedTag<double, kBoxLanes> d;
  const std::size_t lanes = hn::Lanes(d);
  const std::size_t end = std::min<std::size_t>(static_cast<std::size_t>(last_block) * kBoxLanes, set.size());
  for (std::size_t b = static_cast<std::size_t>(first_block) * kBoxLanes; b < end; b += lanes)
    update_lanes(d, set, b, x, out, set.size());
}

void UpdateOneBox(const BoxSet& set, Index box, const double* HWY_RESTRICT x, const BoxOutput& out) {
  update_lanes(hn::CappedTag<double, 1>(), set, box, x, out, box + 1);
}

}  // namespace HWY_NAMESPACE
}  // namespace ffd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace ffd {

HWY_EXPORT(UpdateBoxBlocks);
HWY_EXPORT(UpdateOneBox);

void update_box_blocks(const BoxSet& set, Index first_block, Index last_block, const double* x, const BoxOutput& out) {
  HWY_DYNAMIC_DISPATCH(UpdateBoxBlocks)(set, first_block, last_block, x, out);
}

void update_one_box(const BoxSet& set, Index box, const double* x, const BoxOutput& out) {
  HWY_DYNAMIC_DISPATCH(UpdateOneBox)(set, box, x, out);
}

}  // namespace ffd
#endif
