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

// Springs `first` .. first + Lanes(d), one per lane, their nodes gathered from and scattered
// back to the positions. Per lane, the XPBD update of a distance constraint with compliance
// and damping (Macklin et al. 2016), exactly as written for one spring:
//   d = xa - xb, l = |d| = sqrt((dx dx + dy dy) + dz dz); nothing if l <= 1e-12 m (no direction)
//   g = d (1 / l), C = l - l0
//   dlambda = (-C - alpha~ lambda - gamma g . ((xa - xa_prev) - (xb - xb_prev))) inv_denominator
//   lambda += dlambda, xa += (wa dlambda) g, xb -= (wb dlambda) g
template <class D>
HWY_INLINE void project_lanes(D d, const SpringSolve& s, std::size_t first) {
  using V = hn::Vec<D>;
  // The lanes' nodes read one by one into rows (as fast as a hardware gather, and the same
  // code on every target).
  constexpr std::size_t kLanesMax = 8;
  HWY_ALIGN double in[14][kLanesMax];
  for (std::size_t l = 0; l < hn::Lanes(d); ++l) {
    const double* a = s.x + 3 * s.node_a[first + l];
    const double* b = s.x + 3 * s.node_b[first + l];
    const double* pa = s.x_prev + 3 * s.node_a[first + l];
    const double* pb = s.x_prev + 3 * s.node_b[first + l];
    in[0][l] = a[0], in[1][l] = a[1], in[2][l] = a[2];
    in[3][l] = b[0], in[4][l] = b[1], in[5][l] = b[2];
    in[6][l] = pa[0], in[7][l] = pa[1], in[8][l] = pa[2];
    in[9][l] = pb[0], in[10][l] = pb[1], in[11][l] = pb[2];
    in[12][l] = s.inv_mass[s.node_a[first + l]], in[13][l] = s.inv_mass[s.node_b[first + l]];
  }
  const V xa = hn::Load(d, in[0]), ya = hn::Load(d, in[1]), za = hn::Load(d, in[2]);
  const V xb = hn::Load(d, in[3]), yb = hn::Load(d, in[4]), zb = hn::Load(d, in[5]);
  const V dx = hn::Sub(xa, xb), dy = hn::Sub(ya, yb), dz = hn::Sub(za, zb);
  const V length = hn::Sqrt(hn::Add(hn::Add(hn::Mul(dx, dx), hn::Mul(dy, dy)), hn::Mul(dz, dz)));
  const auto active = hn::Gt(length, hn::Set(d, 1e-12));
  // Inactive lanes divide by 1 instead (no exception, no effect: dlambda is 0 there).
  const V inv_length = hn::Div(hn::Set(d, 1.0), hn::IfThenElse(active, length, hn::Set(d, 1.0)));
  const V gx = hn::Mul(dx, inv_length), gy = hn::Mul(dy, inv_length), gz = hn::Mul(dz, inv_length);
  const V ux = hn::Sub(hn::Sub(xa, hn::Load(d, in[6])), hn::Sub(xb, hn::Load(d, in[9])));
  const V uy = hn::Sub(hn::Sub(ya, hn::Load(d, in[7])), hn::Sub(yb, hn::Load(d, in[10])));
  const V uz = hn::Sub(hn::Sub(za, hn::Load(d, in[8])), hn::Sub(zb, hn::Load(d, in[11])));
  const V damping = hn::Mul(hn::Set(d, s.gamma), hn::Add(hn::Add(hn::Mul(gx, ux), hn::Mul(gy, uy)), hn::Mul(gz, uz)));
  const V C = hn::Sub(length, hn::LoadU(d, s.rest_length + first));
  const V lam = hn::LoadU(d, s.lambda + first);
  const V dlambda = hn::Mul(hn::Sub(hn::Sub(hn::Neg(C), hn::Mul(hn::Set(d, s.alpha_tilde), lam)), damping),
                            hn::LoadU(d, s.inv_denominator + first));
  hn::StoreU(hn::IfThenElse(active, hn::Add(lam, dlambda), lam), d, s.lambda + first);
  const V ka = hn::Mul(hn::Load(d, in[12]), dlambda);
  const V kb = hn::Mul(hn::Load(d, in[13]), dlambda);
  // Inactive lanes write back what they read. The lanes' nodes are written one by one: a
  // hardware scatter was slower than scalar stores
  // (docs/notes/2026-11-28-code-findings.md#spring-kernel).
  HWY_ALIGN double out[6][kLanesMax];
  hn::Store(hn::IfThenElse(active, hn::Add(xa, hn::Mul(ka, gx)), xa), d, out[0]);
  hn::Store(hn::IfThenElse(active, hn::Add(ya, hn::Mul(ka, gy)), ya), d, out[1]);
  hn::Store(hn::IfThenElse(active, hn::Add(za, hn::Mul(ka, gz)), za), d, out[2]);
  hn::Store(hn::IfThenElse(active, hn::Sub(xb, hn::Mul(kb, gx)), xb), d, out[3]);
  hn::Store(hn::IfThenElse(active, hn::Sub(yb, hn::Mul(kb, gy)), yb), d, out[4]);
  hn::Store(hn::IfThenElse(active, hn::Sub(zb, hn::Mul(kb, gz)), zb), d, out[5]);
  for (std::size_t l = 0; l < hn::Lanes(d); ++l) {
    double* a = s.x + 3 * s.node_a[first + l];
    double* b = s.x + 3 * s.node_b[first + l];
    a[0] = out[0][l], a[1] = out[1][l], a[2] = out[2][l];
    b[0] = out[3][l], b[1] = out[4][l], b[2] = out[5][l];
  }
}

void ProjectSprings(const SpringSolve& s, Index begin, Index end, bool independent) {
  const hn::CappedTag<double, 1> one;
  std::size_t i = begin;
  if (independent) {
    const hn::CappedTag<double, 4> d;
    const std::size_t lanes = hn::Lanes(d);
    for (; i + lanes <= end; i += lanes) project_lanes(d, s, i);
  }
  for (; i < end; ++i) project_lanes(one, s, i);
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
