// Highway compiles this file once per target (foreach_target.h) and dispatches at run time.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/spring_kernels.cpp"
#include <hwy/foreach_target.h>  // must come before highway.h
#include <hwy/highway.h>

#include "kernels/spring_kernels.h"

HWY_BEFORE_NAMESPACE();
namespace ffd {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Springs `first` .. first + Lanes(d), one per lane, their nodes' records (kNodeRecord)
// gathered and scattered back. Per lane, the XPBD update of a distance constraint with
// compliance and damping (Macklin et al. 2016), exactly as written for one spring:
//   d = xa - xb, l = |d| = sqrt((dx dx + dy dy) + dz dz); nothing if l <= 1e-12 m (no direction)
//   g = d (1 / l), C = l - l0
//   dlambda = (-C - alpha~ lambda - gamma g . ((xa - xa_prev) - (xb - xb_prev))) inv_denominator
//   lambda += dlambda, xa += (wa dlambda) g, xb -= (wb dlambda) g
// `Nodes` reads the lanes' records into x, y, z, w rows and writes rows back.
template <class D, class Nodes>
HWY_INLINE void project_lanes(D d, const SpringSolve& s, std::size_t first, const Nodes& nodes) {
  using V = hn::Vec<D>;
  V xa, ya, za, wa, xb, yb, zb, wb, pxa, pya, pza, pxb, pyb, pzb, unused;
  nodes.read(d, s.node, s.node_a + first, xa, ya, za, wa);
  nodes.read(d, s.node, s.node_b + first, xb, yb, zb, wb);
  nodes.read(d, s.start, s.node_a + first, pxa, pya, pza, unused);
  nodes.read(d, s.start, s.node_b + first, pxb, pyb, pzb, unused);
  const V dx = hn::Sub(xa, xb), dy = hn::Sub(ya, yb), dz = hn::Sub(za, zb);
  const V length = hn::Sqrt(hn::Add(hn::Add(hn::Mul(dx, dx), hn::Mul(dy, dy)), hn::Mul(dz, dz)));
  const auto active = hn::Gt(length, hn::Set(d, 1e-12));
  // Inactive lanes divide by 1 instead (no exception, no effect: dlambda is 0 there).
  const V inv_length = hn::Div(hn::Set(d, 1.0), hn::IfThenElse(active, length, hn::Set(d, 1.0)));
  const V gx = hn::Mul(dx, inv_length), gy = hn::Mul(dy, inv_length), gz = hn::Mul(dz, inv_length);
  const V ux = hn::Sub(hn::Sub(xa, pxa), hn::Sub(xb, pxb));
  const V uy = hn::Sub(hn::Sub(ya, pya), hn::Sub(yb, pyb));
  const V uz = hn::Sub(hn::Sub(za, pza), hn::Sub(zb, pzb));
  const V damping = hn::Mul(hn::Set(d, s.gamma), hn::Add(hn::Add(hn::Mul(gx, ux), hn::Mul(gy, uy)), hn::Mul(gz, uz)));
  const V C = hn::Sub(length, hn::LoadU(d, s.rest_length + first));
  const V lam = hn::LoadU(d, s.lambda + first);
  const V dlambda = hn::Mul(hn::Sub(hn::Sub(hn::Neg(C), hn::Mul(hn::Set(d, s.alpha_tilde), lam)), damping),
                            hn::LoadU(d, s.inv_denominator + first));
  hn::StoreU(hn::IfThenElse(active, hn::Add(lam, dlambda), lam), d, s.lambda + first);
  const V ka = hn::Mul(wa, dlambda);
  const V kb = hn::Mul(wb, dlambda);
  // Inactive lanes write back what they read.
  nodes.write(d, s.node, s.node_a + first, hn::IfThenElse(active, hn::Add(xa, hn::Mul(ka, gx)), xa),
              hn::IfThenElse(active, hn::Add(ya, hn::Mul(ka, gy)), ya),
              hn::IfThenElse(active, hn::Add(za, hn::Mul(ka, gz)), za), wa);
  nodes.write(d, s.node, s.node_b + first, hn::IfThenElse(active, hn::Sub(xb, hn::Mul(kb, gx)), xb),
              hn::IfThenElse(active, hn::Sub(yb, hn::Mul(kb, gy)), yb),
              hn::IfThenElse(active, hn::Sub(zb, hn::Mul(kb, gz)), zb), wb);
}

// Any lane count: each lane's record read into and written from rows one value at a time.
struct RowsByLane {
  template <class D, class V = hn::Vec<D>>
  HWY_INLINE void read(D d, const double* records, const Index* index, V& x, V& y, V& z, V& w) const {
    constexpr std::size_t kLanesMax = 4;
    HWY_ALIGN double row[4][kLanesMax];
    for (std::size_t l = 0; l < hn::Lanes(d); ++l)
      for (std::size_t k = 0; k < 4; ++k) row[k][l] = records[kNodeRecord * static_cast<std::size_t>(index[l]) + k];
    x = hn::Load(d, row[0]), y = hn::Load(d, row[1]), z = hn::Load(d, row[2]), w = hn::Load(d, row[3]);
  }
  template <class D, class V = hn::Vec<D>>
  HWY_INLINE void write(D d, double* records, const Index* index, V x, V y, V z, V w) const {
    constexpr std::size_t kLanesMax = 4;
    HWY_ALIGN double row[4][kLanesMax];
    hn::Store(x, d, row[0]), hn::Store(y, d, row[1]), hn::Store(z, d, row[2]), hn::Store(w, d, row[3]);
    for (std::size_t l = 0; l < hn::Lanes(d); ++l)
      for (std::size_t k = 0; k < 4; ++k) records[kNodeRecord * static_cast<std::size_t>(index[l]) + k] = row[k][l];
  }
};

#if HWY_TARGET <= HWY_AVX2 && HWY_ARCH_X86
// Four lanes of 256 bits: a record per lane by one aligned load, the four transposed into
// rows in registers (Box2D v3 gathers its body states so) and back.
struct RowsByTranspose {
  using D = hn::Full256<double>;
  using V = hn::Vec<D>;
  HWY_INLINE void read(D d, const double* records, const Index* index, V& x, V& y, V& z, V& w) const {
    const V r0 = hn::Load(d, records + kNodeRecord * index[0]), r1 = hn::Load(d, records + kNodeRecord * index[1]);
    const V r2 = hn::Load(d, records + kNodeRecord * index[2]), r3 = hn::Load(d, records + kNodeRecord * index[3]);
    const V xz01 = hn::InterleaveLower(r0, r1), yw01 = hn::InterleaveUpper(d, r0, r1);  // x0 x1 z0 z1, y0 y1 w0 w1
    const V xz23 = hn::InterleaveLower(r2, r3), yw23 = hn::InterleaveUpper(d, r2, r3);
    x = hn::ConcatLowerLower(d, xz23, xz01), z = hn::ConcatUpperUpper(d, xz23, xz01);
    y = hn::ConcatLowerLower(d, yw23, yw01), w = hn::ConcatUpperUpper(d, yw23, yw01);
  }
  HWY_INLINE void write(D d, double* records, const Index* index, V x, V y, V z, V w) const {
    const V xz01 = hn::ConcatLowerLower(d, z, x), xz23 = hn::ConcatUpperUpper(d, z, x);
    const V yw01 = hn::ConcatLowerLower(d, w, y), yw23 = hn::ConcatUpperUpper(d, w, y);
    hn::Store(hn::InterleaveLower(xz01, yw01), d, records + kNodeRecord * index[0]);
    hn::Store(hn::InterleaveUpper(d, xz01, yw01), d, records + kNodeRecord * index[1]);
    hn::Store(hn::InterleaveLower(xz23, yw23), d, records + kNodeRecord * index[2]);
    hn::Store(hn::InterleaveUpper(d, xz23, yw23), d, records + kNodeRecord * index[3]);
  }
};
#endif

void ProjectSprings(const SpringSolve& s, Index begin, Index end, bool independent) {
  const hn::CappedTag<double, 1> one;
  std::size_t i = begin;
  if (independent) {
#if HWY_TARGET <= HWY_AVX2 && HWY_ARCH_X86
    const hn::Full256<double> d;
    for (; i + 4 <= end; i += 4) project_lanes(d, s, i, RowsByTranspose{});
#else
    const hn::CappedTag<double, 4> d;
    const std::size_t lanes = hn::Lanes(d);
    for (; i + lanes <= end; i += lanes) project_lanes(d, s, i, RowsByLane{});
#endif
  }
  for (; i < end; ++i) project_lanes(one, s, i, RowsByLane{});
}

const char* TargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace HWY_NAMESPACE
}  // namespace ffd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace ffd {

HWY_EXPORT(ProjectSprings);
HWY_EXPORT(TargetName);

void project_springs(const SpringSolve& solve, Index begin, Index end, bool independent) {
  HWY_DYNAMIC_DISPATCH(ProjectSprings)(solve, begin, end, independent);
}

const char* simd_target_name() { return HWY_DYNAMIC_DISPATCH(TargetName)(); }

}  // namespace ffd
#endif
