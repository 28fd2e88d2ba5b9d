// The slope stage's row kernel (slope_kernel.hpp for the contract).
//
// Google Highway (https://github.com/google/highway), runtime dispatch: this file is compiled once
// per target by foreach_target.h (hwy_kernels.hpp: contraction off, so every target rounds as the
// scalar code does).
//
// The angle atan(h), h = |∇y| ≥ 0, without a libm call per sample: one division folds h into
// |x| ≤ tan(π/8) (x = h; x = (h − 1)/(h + 1) and π/4 added; or x = −1/h and π/2 added: the
// classical argument reduction of atan, e.g. Muller, "Elementary Functions", ch. 11), then
// atan(x) = x + x·x²·R(x²) with R our degree-9 Chebyshev fit of (atan(√z)/√z − 1)/z on
// z ∈ [0, 0.4143²] (fitted with mpmath's chebyfit at 40 digits; fit error 8.7e-16, i.e. below
// 2e-16 relative in atan). The result is then rounded to float only where the rounding is
// certain (an interval test), else recomputed with std::atan: the bits stay the scalar ones.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "slope_kernel.cpp"
#include "hwy_kernels.hpp"

#include <cmath>
#include <limits>
#include <numbers>

#include "slope_kernel.hpp"

HWY_BEFORE_NAMESPACE();
namespace relief::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// R(z) = Σ kAtanR[9 − m]·z^m (highest degree first).
constexpr double kAtanR[10] = {
    0.0227439026560555219259,  -0.044828504497084691245, 0.0573618518532764205725, -0.0664958972018556174233,
    0.0769105288838124721505,  -0.0909085243150548744883, 0.111111096326469550692, -0.142857142660367513757,
    0.199999999998980557391,   -0.333333333333332459112,
};

// The scalar definition of slope[i] (slope_kernel.hpp).
HWY_INLINE float MeanAbsDifference(const float* up, const float* mid, const float* down, int i) {
  const double e = mid[i];
  double sum = std::fabs(e - double(up[i - 1]));
  sum += std::fabs(e - double(up[i]));
  sum += std::fabs(e - double(up[i + 1]));
  sum += std::fabs(e - double(mid[i - 1]));
  sum += std::fabs(e - double(mid[i + 1]));
  sum += std::fabs(e - double(down[i - 1]));
  sum += std::fabs(e - double(down[i]));
  sum += std::fabs(e - double(down[i + 1]));
  return float(sum / 8.0);
}

void SlopeRowImpl(const SlopeRow& k, const float* HWY_RESTRICT up, const float* HWY_RESTRICT mid,
                  const float* HWY_RESTRICT down, float* HWY_RESTRICT slope, float* HWY_RESTRICT slope_deg, int n) {
  const hn::ScalableTag<double> d;
  const hn::Rebind<float, decltype(d)> df;
  using VD = hn::Vec<decltype(d)>;
  const int N = int(hn::Lanes(d));
  const VD sea = hn::Set(d, k.sea_level), height = hn::Set(d, k.height_m);
  const VD inv_cell2 = hn::Set(d, 1.0 / k.cell2_m), eighth = hn::Set(d, 0.125);
  const VD one = hn::Set(d, 1.0), minus_one = hn::Set(d, -1.0), zero = hn::Zero(d);
  const VD tan_pi8 = hn::Set(d, 0.41421356237309503), tan_3pi8 = hn::Set(d, 2.4142135623730949);
  const VD quarter_pi = hn::Set(d, std::numbers::pi / 4), half_pi = hn::Set(d, std::numbers::pi / 2);
  const VD deg = hn::Set(d, 180.0 / std::numbers::pi);
  const VD tiny = hn::Set(d, 1e-140), huge = hn::Set(d, 1e140);
  const VD margin = hn::Set(d, 0x1p-40);
  const VD float_max = hn::Set(d, double(std::numeric_limits<float>::max()));
  auto load = [&](const float* p) { return hn::PromoteTo(d, hn::LoadU(df, p)); };
  auto y = [&](VD e) { return hn::Mul(hn::Sub(e, sea), height); };  // Frame::y_m, same rounding
  int i = 1;
  for (; i + N <= n - 1; i += N) {
    const VD u0 = load(up + i - 1), u1 = load(up + i), u2 = load(up + i + 1);
    const VD m0 = load(mid + i - 1), e = load(mid + i), m2 = load(mid + i + 1);
    const VD d0 = load(down + i - 1), d1 = load(down + i), d2 = load(down + i + 1);
    // The mean absolute difference, in the scalar order.
    VD sum = hn::Abs(hn::Sub(e, u0));
    sum = hn::Add(sum, hn::Abs(hn::Sub(e, u1)));
    sum = hn::Add(sum, hn::Abs(hn::Sub(e, u2)));
    sum = hn::Add(sum, hn::Abs(hn::Sub(e, m0)));
    sum = hn::Add(sum, hn::Abs(hn::Sub(e, m2)));
    sum = hn::Add(sum, hn::Abs(hn::Sub(e, d0)));
    sum = hn::Add(sum, hn::Abs(hn::Sub(e, d1)));
    sum = hn::Add(sum, hn::Abs(hn::Sub(e, d2)));
    const VD mean = hn::Mul(sum, eighth);
    hn::StoreU(hn::DemoteTo(df, mean), df, slope + i);
    // Beyond float's range (or NaN) some targets' DemoteTo saturates where a cast gives ±inf.
    const bool mean_in_range = hn::AllTrue(d, hn::Le(mean, float_max));
    // The gradient: the metric differences exactly as the scalar code forms them (where they
    // cancel), then scaled by 1/(2·cell) instead of divided (≤ 1 ulp apart: inside the margin).
    const VD gx = hn::Mul(hn::Sub(y(m2), y(m0)), inv_cell2);
    const VD gz = hn::Mul(hn::Sub(y(d1), y(u1)), inv_cell2);
    const VD a = hn::Max(hn::Abs(gx), hn::Abs(gz));
    // Where squaring neither underflows nor overflows (NaN fails too).
    auto ok = hn::Or(hn::Eq(a, zero), hn::And(hn::Ge(a, tiny), hn::Le(a, huge)));
    const VD h = hn::Sqrt(hn::Add(hn::Mul(gx, gx), hn::Mul(gz, gz)));
    const auto mid_range = hn::Gt(h, tan_pi8), high = hn::Gt(h, tan_3pi8);
    const VD num = hn::IfThenElse(high, minus_one, hn::IfThenElse(mid_range, hn::Sub(h, one), h));
    const VD den = hn::IfThenElse(high, h, hn::IfThenElse(mid_range, hn::Add(h, one), one));
    const VD off = hn::IfThenElse(high, half_pi, hn::IfThenElse(mid_range, quarter_pi, zero));
    const VD x = hn::Div(num, den), z = hn::Mul(x, x);
    // R(z) by Estrin's scheme (4 multiplies deep instead of Horner's 9).
    const VD z2 = hn::Mul(z, z), z4 = hn::Mul(z2, z2), z8 = hn::Mul(z4, z4);
    auto pair = [&](int c) { return hn::Add(hn::Mul(hn::Set(d, kAtanR[c]), z), hn::Set(d, kAtanR[c + 1])); };
    const VD q0 = hn::Add(hn::Mul(pair(6), z2), pair(8));  // z^0 … z^3
    const VD q1 = hn::Add(hn::Mul(pair(2), z2), pair(4));  // z^4 … z^7
    const VD r = hn::Add(hn::Mul(pair(0), z8), hn::Add(hn::Mul(q1, z4), q0));
    const VD angle = hn::Add(off, hn::Add(x, hn::Mul(hn::Mul(x, z), r)));
    const VD w = hn::Mul(angle, deg);
    const VD slack = hn::Mul(w, margin);
    const auto lo = hn::DemoteTo(df, hn::Sub(w, slack)), hi = hn::DemoteTo(df, hn::Add(w, slack));
    ok = hn::And(ok, hn::Eq(hn::PromoteTo(d, lo), hn::PromoteTo(d, hi)));
    hn::StoreU(lo, df, slope_deg + i);
    if (!hn::AllTrue(d, ok))
      for (int l = 0; l < N; ++l) slope_deg[i + l] = slope_deg_reference(k, up, mid, down, i + l);
    if (!mean_in_range)
      for (int l = 0; l < N; ++l) slope[i + l] = MeanAbsDifference(up, mid, down, i + l);
  }
  for (; i + 1 < n; ++i) {
    slope[i] = MeanAbsDifference(up, mid, down, i);
    slope_deg[i] = slope_deg_reference(k, up, mid, down, i);
  }
}

const char* SlopeTargetImpl() { return hwy::TargetName(HWY_TARGET); }

}  // namespace HWY_NAMESPACE
}  // namespace relief::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace relief::detail {

HWY_EXPORT(SlopeRowImpl);
HWY_EXPORT(SlopeTargetImpl);

void slope_row(const SlopeRow& k, const float* up, const float* mid, const float* down, float* slope,
               float* slope_deg, int n) {
  HWY_DYNAMIC_DISPATCH(SlopeRowImpl)(k, up, mid, down, slope, slope_deg, n);
}

float slope_deg_reference(const SlopeRow& k, const float* up, const float* mid, const float* down, int i) {
  auto y = [&](float e) { return (double(e) - k.sea_level) * k.height_m; };
  const double gx = (y(mid[i + 1]) - y(mid[i - 1])) / k.cell2_m;
  const double gz = (y(down[i]) - y(up[i])) / k.cell2_m;
  return float(std::atan(std::hypot(gx, gz)) * (180.0 / std::numbers::pi));
}

const char* slope_target() { return HWY_DYNAMIC_DISPATCH(SlopeTargetImpl)(); }

}  // namespace relief::detail
#endif  // HWY_ONCE
