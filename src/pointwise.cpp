// Vectorised row kernels of the pointwise and colour stages (see pointwise.hpp for the contract).
//
// Google Highway (https://github.com/google/highway), runtime dispatch: this file is compiled once
// per target by foreach_target.h and each entry point dispatches through HWY_DYNAMIC_DISPATCH.
// The formulas are the stages' own (stage_shape.cpp and stage_color.cpp name their sources);
// pow is our own exp2(y·log2 x) (Pow01 below); the colour stage's atan is Highway's (contrib/math).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "pointwise.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep

#include <hwy/contrib/math/math-inl.h>
#include <hwy/cache_control.h>
#include <hwy/highway.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <type_traits>

#include "pointwise.hpp"

HWY_BEFORE_NAMESPACE();
namespace relief::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using D = hn::ScalableTag<float>;
using V = hn::Vec<D>;
using DI = hn::RebindToSigned<D>;

// Pow01's 2^g = (P + Q)/(P − Q), P = 1 + kExp2R[1]·g², Q = kExp2R[0]·g, |g| ≤ ½ + 2^−14: a [2/2]
// rational of the symmetric form exp itself has (R(−g) = 1/R(g)), minimax relative error 5.6e-7
// among those with R(½) = √2 (so 2^n·R(½) = 2^(n+1)·R(−½): the result is continuous where n steps).
// Three operations fewer than the degree-5 polynomial it replaces. Its log2 polynomial is kPowLog2
// (pointwise.hpp).
constexpr float kExp2R[2] = {0.3465709434903669f, 0.03992697537626633f};

HWY_INLINE V Clamp01(D d, V v) { return hn::Min(hn::Max(v, hn::Zero(d)), hn::Set(d, 1.0f)); }

// Runs f(v, i) → v on row[0, n) in place: full vectors straight from the row, the last partial
// vector through a zero-padded buffer and the same code (so no sample depends on its position).
template <class F>
HWY_INLINE void InPlace(D d, float* HWY_RESTRICT row, int n, F&& f) {
  const int N = int(hn::Lanes(d));
  int i = 0;
  for (; i + N <= n; i += N) hn::StoreU(f(hn::LoadU(d, row + i), i), d, row + i);
  if (i < n) {
    HWY_ALIGN float buf[kRowPad] = {};
    std::copy(row + i, row + n, buf);
    hn::Store(f(hn::Load(d, buf), i), d, buf);
    std::copy(buf, buf + (n - i), row + i);
  }
}

// g(u) of the land-only stages, applied to all samples or only above sea level.
template <class G>
HWY_INLINE V WithLand(D d, const LandOnly& land, V e, G&& g) {
  if (!land.enabled) return g(e);
  const V sea = hn::Set(d, land.sea), span = hn::Set(d, land.land);
  const V u = hn::Div(hn::Sub(e, sea), span);
  const V mapped = hn::Add(sea, hn::Mul(span, Clamp01(d, g(u))));
  return hn::IfThenElse(hn::Le(e, hn::Set(d, land.sea_floor_max)), e, mapped);
}

// x^y for x ∈ [0, 1] and a positive exponent, as exp2(y·log2 x) with our own polynomials, in
// exactly rounded operations only (no MulAdd, no target-specific rounding), so every target gives
// the same bits:
//   x = 2^k·m, m ∈ [√½, √2) from the float's bits (kTiny: x·2^24 first, an exact scaling that makes
//   subnormal x normal; only needed when such inputs are kept, i.e. x_min < 2^−126);
//   y·log2 m = t·Py(t²), t = (m − 1)/(m + 1), Py = y·P (RedistributeRow::log2_y), P the degree-2
//   fit of kPowLog2 (relative error 1.5e-7, exact at m = √½ and √2);
//   y·log2 x = y_hi·k + (y_lo·k + y·log2 m), y_hi = y with 12 significant bits, so y_hi·k is exact
//   and the float error is that of a number below ~5 in magnitude — the result's relative error
//   does not grow for small x;
//   2^f = 2^n·2^g, n = round(f), g ∈ [−½, ½] (+ 2^−14), 2^g a [2/2] rational (kExp2R, relative
//   error 5.6e-7); the product with 2^n is an integer add to the exponent bits.
// x = 1 gives exactly 1 (t = 0, f = 0, 2^0 = 1). x < x_min (x^y < 2^−125, and x = 0) gives 0:
// no subnormal results. Rounding to an integer uses the 1.5·2^23 trick (valid for |f| < 2^22),
// which every target evaluates with the same two IEEE additions.
// log2 x = kf + log2 m (kf an integer, |log2 m| ≤ ½), both exact functions of x's bits; kf is
// offset by −k_offset (an integer) at no cost. Returns kf and y·log2 m.
template <bool kTiny>
HWY_INLINE void Log2Parts(D d, const RedistributeRow& k, V x, V& kf, V& ylog2m, int k_offset = 0) {
  const DI di;
  const V one = hn::Set(d, 1.0f);
  const V xs = kTiny ? hn::Mul(x, hn::Set(d, 16777216.0f)) : x;
  // Offsetting the bits by 1 − √½ (in the mantissa) moves the split point from 2 to √2.
  const auto bits = hn::Add(hn::BitCast(di, xs), hn::Set(di, 0x004afb0d));
  kf = hn::ConvertTo(d, hn::Sub(hn::ShiftRight<23>(bits), hn::Set(di, 127 + (kTiny ? 24 : 0) + k_offset)));
  const V m = hn::BitCast(d, hn::Add(hn::And(bits, hn::Set(di, 0x007fffff)), hn::Set(di, 0x3f3504f3)));
  const V t = hn::Div(hn::Sub(m, one), hn::Add(m, one));
  const V s = hn::Mul(t, t);
  const V p = hn::Add(hn::Set(d, k.log2_y[0]), hn::Mul(s, hn::Add(hn::Set(d, k.log2_y[1]), hn::Mul(s, hn::Set(d, k.log2_y[2])))));
  ylog2m = hn::Mul(t, p);
}

// 2^(y_hi·kf + (y_lo·kf + ylog2m)) (see Pow01), for exponents below 2^22 in magnitude and results
// of at least 2^−126 (callers mask or lift the others).
HWY_INLINE V Exp2Times(D d, const RedistributeRow& k, V kf, V ylog2m) {
  const DI di;
  // v + 1.5·2^23 rounds v to an integer n (|v| < 2^22) and holds n in its low mantissa bits: the
  // bits of the sum are those of 1.5·2^23 plus n.
  const V magic = hn::Set(d, 12582912.0f);
  const V hi = hn::Mul(hn::Set(d, k.exponent_hi), kf);  // exact
  const V lo = hn::Add(hn::Mul(hn::Set(d, k.exponent_lo), kf), ylog2m);
  // n = round(hi + lo) (the rounded sum is close enough: any integer within ½ + 2^−14 of the
  // exponent will do), then g = (hi − n) + lo with hi − n exact: one rounding, |g| ≤ ½ + 2^−14.
  const V r = hn::Add(hn::Add(hi, lo), magic);
  const V g = hn::Add(hn::Sub(hi, hn::Sub(r, magic)), lo);
  // (P + Q)/(P − Q) as 1 + 2Q/(P − Q): the rounding errors scale with the small term.
  const V pe = hn::Add(hn::Set(d, 1.0f), hn::Mul(hn::Set(d, kExp2R[1]), hn::Mul(g, g)));
  const V qo = hn::Mul(hn::Set(d, kExp2R[0]), g), qo2 = hn::Mul(hn::Set(d, 2.0f * kExp2R[0]), g);
  const V frac = hn::Add(hn::Set(d, 1.0f), hn::Div(qo2, hn::Sub(pe, qo)));  // in [0.7, 1.42]
  // 2^n·frac by adding n to the exponent field: bits(r) << 23 equals n << 23 modulo 2^32, as the
  // low 9 bits of bits(1.5·2^23) are zero.
  const auto n_field = hn::ShiftLeft<23>(hn::BitCast(di, r));
  return hn::BitCast(d, hn::Add(hn::BitCast(di, frac), n_field));
}

// Lanes below x_min (where the exponent field could underflow) give 0.
template <bool kTiny>
HWY_INLINE V Pow01(D d, const RedistributeRow& k, V x, V x_min) {
  V kf, ylog2m;
  Log2Parts<kTiny>(d, k, x, kf, ylog2m);
  return hn::IfThenElseZero(hn::Ge(x, x_min), Exp2Times(d, k, kf, ylog2m));
}

template <bool kTiny>
void RedistributePow(const RedistributeRow& kr, float* HWY_RESTRICT row, int n) {
  const RedistributeRow k = kr;  // a local copy: its fields are not reloaded in the loops
  const D d;
  const V mod = hn::Set(d, k.modifier);
  const V one = hn::Set(d, 1.0f);
  if (!k.land.enabled) {
    // Pow01 gives 0 for x < x_min, so also for negative heights; the power is ≥ 0 and the modifier
    // too, so only the upper clamps remain.
    // With modifier 1 (the default) the power is ≤ 1 already (x ≤ 1 gives a non-positive exponent).
    const V x_min = hn::Set(d, k.x_min);
    if (k.modifier == 1.0f) InPlace(d, row, n, [&](V v, int) { return Pow01<kTiny>(d, k, hn::Min(v, one), x_min); });
    else InPlace(d, row, n, [&](V v, int) { return hn::Min(hn::Mul(mod, Pow01<kTiny>(d, k, hn::Min(v, one), x_min)), one); });
    return;
  }
  // ((e − sea)/land)^y without the division: log2(e − sea) − log2(land), with log2(land) split the
  // same way from the same float (1 − sea, which is e − sea at e = 1), so e = 1 still gives exactly
  // u^y = 1. The sea floor keeps its height, and so does e = sea (whose u^y = 0 maps back to sea).
  // Above it, e − sea ≥ one ulp of sea is lifted to land_x_min (u^y ≥ 2^−100) instead of masking
  // the power: sea + land·u^y is then the sea level itself, as with u^y = 0, for any sea level
  // ≥ 2^−70 (below that, such samples get a height under 2^−99), and land·u^y is never subnormal.
  const V sea = hn::Set(d, k.land.sea), span = hn::Set(d, k.land.land);
  const V floor_max = hn::Set(d, std::max(k.land.sea_floor_max, k.land.sea));
  V k_land, yl_land;
  Log2Parts<kTiny>(d, k, hn::Sub(one, sea), k_land, yl_land);
  const int k_offset = int(hn::GetLane(k_land));
  const V x_min = hn::Set(d, k.land_x_min);
  auto land = [&](V v, auto with_modifier) {
    const V e = Clamp01(d, v);
    const auto sea_floor = hn::Le(e, floor_max);
    // A vector wholly under the sea (common: seas are wide) keeps its heights; the same values as
    // the select below, without the power.
    if (hn::AllTrue(d, sea_floor)) return e;
    const V x = hn::Max(hn::Sub(e, sea), x_min);
    V kf, yl;
    Log2Parts<kTiny>(d, k, x, kf, yl, k_offset);
    V p = Exp2Times(d, k, kf, hn::Sub(yl, yl_land));
    if constexpr (decltype(with_modifier)::value) p = hn::Min(hn::Mul(mod, p), one);  // else p ≤ 1 already
    return hn::IfThenElse(sea_floor, e, hn::Min(hn::Add(sea, hn::Mul(span, p)), one));
  };
  if (k.modifier == 1.0f) InPlace(d, row, n, [&](V v, int) { return land(v, std::false_type()); });
  else InPlace(d, row, n, [&](V v, int) { return land(v, std::true_type()); });
}

void RedistributeRowImpl(const RedistributeRow& k, float* HWY_RESTRICT row, int n) {
  const D d;
  const V mod = hn::Set(d, k.modifier);
  if (!k.power) {
    auto g = [&](V u) { return Clamp01(d, hn::Mul(mod, u)); };
    InPlace(d, row, n, [&](V v, int) { return Clamp01(d, WithLand(d, k.land, Clamp01(d, v), g)); });
  } else if ((k.land.enabled ? k.land_x_min : k.x_min) < std::numeric_limits<float>::min()) {
    RedistributePow<true>(k, row, n);
  } else {
    RedistributePow<false>(k, row, n);
  }
}

void TerraceRowImpl(const TerraceRow& k, float* HWY_RESTRICT row, int n) {
  const D d;
  const V levels = hn::Set(d, k.levels), half = hn::Set(d, 0.5f), one = hn::Set(d, 1.0f);
  const V wall = hn::Set(d, k.wall), wall_lo = hn::Set(d, k.wall_lo), three = hn::Set(d, 3.0f), two = hn::Set(d, 2.0f);
  auto g = [&](V e) {
    const V t = hn::Mul(e, levels);
    const V kf = hn::Floor(t);
    const V f = hn::Sub(t, kf);  // exact for t ≥ 0
    V step;
    if (!k.smooth) {
      step = hn::IfThenElseZero(hn::Ge(f, half), one);  // std::round: halves away from zero
    } else {
      const V s = Clamp01(d, hn::Div(hn::Sub(f, wall_lo), wall));
      step = hn::Mul(hn::Mul(s, s), hn::Sub(three, hn::Mul(two, s)));
    }
    return hn::Div(hn::Add(kf, step), levels);
  };
  InPlace(d, row, n, [&](V v, int) { return Clamp01(d, WithLand(d, k.land, Clamp01(d, v), g)); });
}

template <IslandForm kForm, IslandShaping kShaping>
void IslandRowT(const IslandRow& k, float row_term, float* HWY_RESTRICT row, int n) {
  const D d;
  const V r = hn::Set(d, row_term), one = hn::Set(d, 1.0f), mix = hn::Set(d, k.mix), rate = hn::Set(d, k.rate);
  const V a = hn::Set(d, k.a), norm = hn::Set(d, k.norm);
  const float* HWY_RESTRICT col = k.col;
  InPlace(d, row, n, [&](V v, int i) {
    const V c = hn::LoadU(d, col + i);
    V dist;
    if constexpr (kForm == IslandForm::Product) dist = hn::Sub(one, hn::Mul(c, r));
    else if constexpr (kForm == IslandForm::Sum) dist = hn::Add(c, r);
    else if constexpr (kForm == IslandForm::Root) dist = hn::Sqrt(hn::Add(c, r));
    else dist = hn::Div(hn::Sub(hn::Sqrt(hn::Add(c, r)), a), norm);
    dist = Clamp01(d, dist);
    const V e = Clamp01(d, v);
    V target;
    if constexpr (kShaping == IslandShaping::Lerp) target = hn::Sub(one, dist);
    else if constexpr (kShaping == IslandShaping::Multiply) target = hn::Mul(e, hn::Sub(one, dist));
    else target = hn::Sub(e, hn::Mul(rate, dist));
    return Clamp01(d, hn::Add(e, hn::Mul(hn::Sub(target, e), mix)));
  });
}

template <IslandForm kForm>
void IslandRowForm(const IslandRow& k, float row_term, float* row, int n) {
  switch (k.shaping) {
    case IslandShaping::Lerp: return IslandRowT<kForm, IslandShaping::Lerp>(k, row_term, row, n);
    case IslandShaping::Multiply: return IslandRowT<kForm, IslandShaping::Multiply>(k, row_term, row, n);
    case IslandShaping::Subtract: return IslandRowT<kForm, IslandShaping::Subtract>(k, row_term, row, n);
  }
}

void IslandRowImpl(const IslandRow& k, float row_term, float* HWY_RESTRICT row, int n) {
  switch (k.form) {
    case IslandForm::Product: return IslandRowForm<IslandForm::Product>(k, row_term, row, n);
    case IslandForm::Sum: return IslandRowForm<IslandForm::Sum>(k, row_term, row, n);
    case IslandForm::Root: return IslandRowForm<IslandForm::Root>(k, row_term, row, n);
    case IslandForm::RootAffine: return IslandRowForm<IslandForm::RootAffine>(k, row_term, row, n);
  }
}

void CurveRowImpl(const CurveRow& k, float* HWY_RESTRICT row, int n) {
  const D d;
  const V first_x = hn::Set(d, k.first_x), first_y = hn::Set(d, k.first_y);
  const V last_x = hn::Set(d, k.last_x), last_y = hn::Set(d, k.last_y);
  const int N = int(hn::Lanes(d));
  auto finish = [&](V x, V x0, V h, V c0, V c1, V c2, V c3, V lo, V hi) {
    const V s = Clamp01(d, hn::Div(hn::Sub(x, x0), h));
    V y = hn::Add(c0, hn::Mul(s, hn::Add(c1, hn::Mul(s, hn::Add(c2, hn::Mul(s, c3))))));
    y = hn::Min(hn::Max(y, lo), hi);  // exact no-overshoot guarantee
    y = hn::IfThenElse(hn::Le(x, first_x), first_y, y);
    y = hn::IfThenElse(hn::Ge(x, last_x), last_y, y);
    return Clamp01(d, y);
  };
  if (k.segments > 1 && k.segments <= N && k.readable >= N) {
    // Up to one vector of segments: the segment index is the number of interior knots ≤ x (the
    // knots are non-decreasing, so that is the last one, as the select chain below picks), and
    // each coefficient one lane permutation of its array: the same values, fewer operations.
    const DI di;
    const V tx0 = hn::LoadU(d, k.x0), th = hn::LoadU(d, k.h), tc0 = hn::LoadU(d, k.c0), tc1 = hn::LoadU(d, k.c1);
    const V tc2 = hn::LoadU(d, k.c2), tc3 = hn::LoadU(d, k.c3), tlo = hn::LoadU(d, k.lo), thi = hn::LoadU(d, k.hi);
    InPlace(d, row, n, [&](V v, int) {
      const V x = Clamp01(d, v);
      auto seg = hn::Zero(di);
      for (int m = 1; m < k.segments; ++m)
        seg = hn::Sub(seg, hn::BitCast(di, hn::VecFromMask(d, hn::Ge(x, hn::Set(d, k.x0[m])))));  // + 1 where x ≥ knot
      const auto idx = hn::IndicesFromVec(d, seg);
      return finish(x, hn::TableLookupLanes(tx0, idx), hn::TableLookupLanes(th, idx), hn::TableLookupLanes(tc0, idx),
                    hn::TableLookupLanes(tc1, idx), hn::TableLookupLanes(tc2, idx), hn::TableLookupLanes(tc3, idx),
                    hn::TableLookupLanes(tlo, idx), hn::TableLookupLanes(thi, idx));
    });
    return;
  }
  InPlace(d, row, n, [&](V v, int) {
    const V x = Clamp01(d, v);
    // Segment selection without branches: later knots override earlier ones.
    V x0 = hn::Set(d, k.x0[0]), h = hn::Set(d, k.h[0]), c0 = hn::Set(d, k.c0[0]), c1 = hn::Set(d, k.c1[0]);
    V c2 = hn::Set(d, k.c2[0]), c3 = hn::Set(d, k.c3[0]), lo = hn::Set(d, k.lo[0]), hi = hn::Set(d, k.hi[0]);
    for (int m = 1; m < k.segments; ++m) {
      const auto in = hn::Ge(x, hn::Set(d, k.x0[m]));
      x0 = hn::IfThenElse(in, hn::Set(d, k.x0[m]), x0);
      h = hn::IfThenElse(in, hn::Set(d, k.h[m]), h);
      c0 = hn::IfThenElse(in, hn::Set(d, k.c0[m]), c0);
      c1 = hn::IfThenElse(in, hn::Set(d, k.c1[m]), c1);
      c2 = hn::IfThenElse(in, hn::Set(d, k.c2[m]), c2);
      c3 = hn::IfThenElse(in, hn::Set(d, k.c3[m]), c3);
      lo = hn::IfThenElse(in, hn::Set(d, k.lo[m]), lo);
      hi = hn::IfThenElse(in, hn::Set(d, k.hi[m]), hi);
    }
    return finish(x, x0, h, c0, c1, c2, c3, lo, hi);
  });
}

// ---- rows with a halo: the first vector and the last (partial) one need the one-sided border
// differences, so they go through padded buffers with the gradient computed one column at a time
// by the same exactly rounded operations a vector lane uses; the vectors in between read the
// neighbouring columns directly. Either way a sample's result is the same.

HWY_INLINE float GradX(const GradientRows& r, int i, int n) {
  if (n < 2) return 0.0f;
  if (i == 0) return (r.mid[1] - r.mid[0]) * r.edge;
  if (i == n - 1) return (r.mid[n - 1] - r.mid[n - 2]) * r.edge;
  return (r.mid[i + 1] - r.mid[i - 1]) * r.central;
}
HWY_INLINE float GradZ(const GradientRows& r, int i) { return (r.down[i] - r.up[i]) * r.kz; }

// Calls padded(i, m) for the blocks of m ≤ N columns that touch a border column and inner(i) for
// the full vectors [i, i + N) with 1 ≤ i and i + N ≤ n − 1.
template <class Inner, class Padded>
HWY_INLINE void HaloBlocks(int N, int n, Inner&& inner, Padded&& padded) {
  if (n <= 0) return;
  padded(0, std::min(N, n));
  int i = N;
  for (; i + N < n; i += N) inner(i);
  for (; i < n; i += N) padded(i, std::min(N, n - i));
}

// The colour of one vector of heights e (relative scaling done) before rock, speckle and water.
HWY_INLINE void LevelColor(D d, const ColorRow& k, V e, V& r, V& g, V& b) {
  const int N = int(hn::Lanes(d));
  if (k.tables && k.levels <= N) {
    // Branch-free lookup: c = number of levels below e (sorted levels), then a lane permutation.
    const V one = hn::Set(d, 1.0f);
    V c = hn::Zero(d);
    for (int m = 0; m + 1 < k.levels; ++m) {
      // bands: !(e ≤ at) counts NaN as above every level, as the select chain does
      const auto below = k.gradient ? hn::Gt(e, hn::Set(d, k.at[m])) : hn::Not(hn::Le(e, hn::Set(d, k.at[m])));
      c = hn::Add(c, hn::IfThenElseZero(below, one));
    }
    const auto idx = hn::IndicesFromVec(d, hn::ConvertTo(DI(), c));
    auto row = [&](int t) { return hn::TableLookupLanes(hn::LoadU(d, k.tables + t * kLevelLanes), idx); };
    if (!k.gradient) {
      r = row(0), g = row(1), b = row(2);
      return;
    }
    const V s = hn::Div(hn::Sub(e, row(0)), row(1));
    r = hn::Add(row(2), hn::Mul(row(5), s)), g = hn::Add(row(3), hn::Mul(row(6), s)), b = hn::Add(row(4), hn::Mul(row(7), s));
  } else if (!k.gradient) {
    // First level with e ≤ at: walk down from the last so that lower levels win.
    const int last = k.levels - 1;
    r = hn::Set(d, k.r[last]), g = hn::Set(d, k.g[last]), b = hn::Set(d, k.b[last]);
    for (int m = last; m >= 0; --m) {
      const auto in = hn::Le(e, hn::Set(d, k.at[m]));
      r = hn::IfThenElse(in, hn::Set(d, k.r[m]), r);
      g = hn::IfThenElse(in, hn::Set(d, k.g[m]), g);
      b = hn::IfThenElse(in, hn::Set(d, k.b[m]), b);
    }
    return;
  } else {
    // Segment m with at[m] < e ≤ at[m + 1]: later segments override earlier ones.
    V a0 = hn::Set(d, k.at[0]), w = hn::Set(d, 1.0f);
    V r0 = hn::Set(d, k.r[0]), g0 = hn::Set(d, k.g[0]), b0 = hn::Set(d, k.b[0]);
    V dr = hn::Zero(d), dg = hn::Zero(d), db = hn::Zero(d);
    for (int m = 0; m + 1 < k.levels; ++m) {
      if (!(k.at[m + 1] > k.at[m])) continue;  // empty segment: never selected
      const auto in = hn::Gt(e, hn::Set(d, k.at[m]));
      a0 = hn::IfThenElse(in, hn::Set(d, k.at[m]), a0);
      w = hn::IfThenElse(in, hn::Set(d, float(double(k.at[m + 1]) - double(k.at[m]))), w);
      r0 = hn::IfThenElse(in, hn::Set(d, k.r[m]), r0);
      g0 = hn::IfThenElse(in, hn::Set(d, k.g[m]), g0);
      b0 = hn::IfThenElse(in, hn::Set(d, k.b[m]), b0);
      dr = hn::IfThenElse(in, hn::Set(d, k.r[m + 1] - k.r[m]), dr);
      dg = hn::IfThenElse(in, hn::Set(d, k.g[m + 1] - k.g[m]), dg);
      db = hn::IfThenElse(in, hn::Set(d, k.b[m + 1] - k.b[m]), db);
    }
    const V s = hn::Div(hn::Sub(e, a0), w);
    r = hn::Add(r0, hn::Mul(dr, s)), g = hn::Add(g0, hn::Mul(dg, s)), b = hn::Add(b0, hn::Mul(db, s));
  }
  // gradient: the first colour up to at[0], the last from at[K−1]
  const int last = k.levels - 1;
  const auto below = hn::Le(e, hn::Set(d, k.at[0])), above = hn::Ge(e, hn::Set(d, k.at[last]));
  r = hn::IfThenElse(below, hn::Set(d, k.r[0]), hn::IfThenElse(above, hn::Set(d, k.r[last]), r));
  g = hn::IfThenElse(below, hn::Set(d, k.g[0]), hn::IfThenElse(above, hn::Set(d, k.g[last]), g));
  b = hn::IfThenElse(below, hn::Set(d, k.b[0]), hn::IfThenElse(above, hn::Set(d, k.b[last]), b));
}

// One vector of the colour stage: heights e, slope (degrees or |∇y|²), speckle rows a0, a1 and
// water cover at this vector's columns (pointers: N readable lanes; a0, a1, water unused when off).
HWY_INLINE void ColorVec(D d, const ColorRow& k, V e, V slope, const float* HWY_RESTRICT a0_in,
                         const float* HWY_RESTRICT a1_in, float tz, const float* HWY_RESTRICT water,
                         float* HWY_RESTRICT rgb) {
  if (k.relative) e = hn::Div(e, hn::Set(d, k.max_height));
  V r, g, b;
  LevelColor(d, k, e, r, g, b);
  if (k.rock) {
    const auto rock = hn::And(hn::And(hn::Gt(e, hn::Set(d, k.rock_min)), hn::Lt(e, hn::Set(d, k.rock_max))),
                              hn::Gt(slope, hn::Set(d, k.rock_gate)));
    if (!hn::AllFalse(d, rock)) {  // skipping is exact: no lane of this vector turns to rock
      const V rr = hn::Set(d, k.rock_r), rg = hn::Set(d, k.rock_g), rb = hn::Set(d, k.rock_b);
      V mr = rr, mg = rg, mb = rb;
      if (k.rock_blend_deg > 0.0f) {
        const auto full = hn::Ge(slope, hn::Set(d, k.rock_full_gate));
        if (!hn::AllTrue(d, hn::Or(full, hn::Not(rock)))) {  // some rock lane is in the blend band
          const V deg =
              k.slope_is_gradient2 ? hn::Mul(hn::Atan(d, hn::Sqrt(slope)), hn::Set(d, float(180.0 / std::numbers::pi))) : slope;
          const V s = Clamp01(d, hn::Div(hn::Sub(deg, hn::Set(d, k.rock_slope_deg)), hn::Set(d, k.rock_blend_deg)));
          const V w = hn::Mul(hn::Mul(s, s), hn::Sub(hn::Set(d, 3.0f), hn::Mul(hn::Set(d, 2.0f), s)));
          const auto rock_only = hn::Or(full, hn::Ge(w, hn::Set(d, 1.0f)));
          mr = hn::IfThenElse(rock_only, rr, hn::Add(r, hn::Mul(hn::Sub(rr, r), w)));
          mg = hn::IfThenElse(rock_only, rg, hn::Add(g, hn::Mul(hn::Sub(rg, g), w)));
          mb = hn::IfThenElse(rock_only, rb, hn::Add(b, hn::Mul(hn::Sub(rb, b), w)));
        }
      }
      r = hn::IfThenElse(rock, mr, r), g = hn::IfThenElse(rock, mg, g), b = hn::IfThenElse(rock, mb, b);
    }
  }
  if (k.speckle) {
    const V a0 = hn::LoadU(d, a0_in), a1 = hn::LoadU(d, a1_in);
    const V v = hn::Add(a0, hn::Mul(hn::Sub(a1, a0), hn::Set(d, tz)));
    const V f = hn::Add(hn::Set(d, 1.0f), hn::Mul(hn::Set(d, k.variation), hn::Sub(hn::Add(v, v), hn::Set(d, 1.0f))));
    r = hn::Mul(r, f), g = hn::Mul(g, f), b = hn::Mul(b, f);
  }
  r = Clamp01(d, r), g = Clamp01(d, g), b = Clamp01(d, b);
  if (water) {
    const V w = hn::LoadU(d, water);
    const auto wet = hn::Gt(w, hn::Zero(d));
    if (!hn::AllFalse(d, wet)) {
      r = hn::IfThenElse(wet, hn::Add(r, hn::Mul(hn::Sub(hn::Set(d, k.water_r), r), w)), r);
      g = hn::IfThenElse(wet, hn::Add(g, hn::Mul(hn::Sub(hn::Set(d, k.water_g), g), w)), g);
      b = hn::IfThenElse(wet, hn::Add(b, hn::Mul(hn::Sub(hn::Set(d, k.water_b), b), w)), b);
    }
  }
  hn::StoreInterleaved3(r, g, b, d, rgb);
}

void ColorRowImpl(const ColorRow& k, const GradientRows& rows, const float* HWY_RESTRICT slope_in,
                  const float* HWY_RESTRICT a0, const float* HWY_RESTRICT a1, float tz, const float* HWY_RESTRICT water,
                  float* HWY_RESTRICT rgb, int n) {
  const D d;
  const int N = int(hn::Lanes(d));
  const bool grad2 = k.rock && !slope_in;  // |∇y|² from the rows
  const float* HWY_RESTRICT mid = rows.mid;
  const V central = hn::Set(d, rows.central), kz = hn::Set(d, rows.kz);
  HaloBlocks(
      N, n,
      [&](int i) {
        V slope = hn::Zero(d);
        if (grad2) {
          const V x = hn::Mul(hn::Sub(hn::LoadU(d, mid + i + 1), hn::LoadU(d, mid + i - 1)), central);
          const V z = hn::Mul(hn::Sub(hn::LoadU(d, rows.down + i), hn::LoadU(d, rows.up + i)), kz);
          slope = hn::Add(hn::Mul(x, x), hn::Mul(z, z));
        } else if (k.rock) {
          slope = hn::LoadU(d, slope_in + i);
        }
        ColorVec(d, k, hn::LoadU(d, mid + i), slope, k.speckle ? a0 + i : nullptr, k.speckle ? a1 + i : nullptr, tz,
                 water ? water + i : nullptr, rgb + 3 * i);
      },
      [&](int i, int m) {
        HWY_ALIGN float eb[kRowPad] = {}, sb[kRowPad] = {}, wb[kRowPad] = {}, out[3 * kRowPad];
        std::copy(mid + i, mid + i + m, eb);
        for (int c = 0; c < m; ++c) {
          if (grad2) {
            const float x = GradX(rows, i + c, n), z = GradZ(rows, i + c);
            sb[c] = x * x + z * z;
          } else if (k.rock) {
            sb[c] = slope_in[i + c];
          }
        }
        if (water) std::copy(water + i, water + i + m, wb);
        // a0, a1 are padded by the caller.
        ColorVec(d, k, hn::Load(d, eb), hn::Load(d, sb), k.speckle ? a0 + i : nullptr, k.speckle ? a1 + i : nullptr, tz,
                 water ? wb : nullptr, out);
        std::copy(out, out + 3 * m, rgb + 3 * i);
      });
}

void LatticeRowImpl(const float* HWY_RESTRICT lat, const std::int32_t* HWY_RESTRICT ix, const float* HWY_RESTRICT tx,
                    float* HWY_RESTRICT out, int n) {
  const D d;
  const DI di;
  const int N = int(hn::Lanes(d));
  auto at = [&](int i) {
    const auto idx = hn::LoadU(di, ix + i);
    const V v0 = hn::GatherIndex(d, lat, idx), v1 = hn::GatherIndex(d, lat + 1, idx);
    return hn::Add(v0, hn::Mul(hn::Sub(v1, v0), hn::LoadU(d, tx + i)));
  };
  int i = 0;
  for (; i + N <= n; i += N) hn::StoreU(at(i), d, out + i);
  if (i < n) {
    HWY_ALIGN float buf[kRowPad];
    hn::Store(at(i), d, buf);  // ix, tx are padded
    std::copy(buf, buf + (n - i), out + i);
  }
}

// Lane l of the three vectors spread[0..2] holds lane (k·N + l)/3 of a vector: one value per
// interleaved RGB sample, so that a shade multiplies an RGB row without de-interleaving it.
struct Spread {
  using Idx = decltype(hn::SetTableIndices(D(), static_cast<const std::int32_t*>(nullptr)));
  Idx idx[3];
  explicit Spread(D d) {
    const int N = int(hn::Lanes(d));
    HWY_ALIGN std::int32_t lanes[kRowPad];
    for (int k = 0; k < 3; ++k) {
      for (int l = 0; l < N; ++l) lanes[l] = (k * N + l) / 3;
      idx[k] = hn::SetTableIndices(d, lanes);
    }
  }
};

// kStream: rgb is vector-aligned and written with non-temporal stores.
template <bool kStream = false>
HWY_INLINE void HillshadeVec(D d, const Spread& spread, const HillshadeRow& k, V e, V fx, V fz,
                             const float* HWY_RESTRICT albedo, float* HWY_RESTRICT shade, float* HWY_RESTRICT rgb) {
  const V one = hn::Set(d, 1.0f);
  const V num = hn::Sub(hn::Add(hn::Mul(hn::Neg(fx), hn::Set(d, k.lx)), hn::Set(d, k.ly)), hn::Mul(fz, hn::Set(d, k.lz)));
  const V len = hn::Sqrt(hn::Add(hn::Add(one, hn::Mul(fx, fx)), hn::Mul(fz, fz)));
  const V ndotl = hn::Div(num, len);
  V s = hn::Add(hn::Set(d, k.ambient), hn::Mul(hn::Set(d, k.diffuse), hn::Max(hn::Zero(d), ndotl)));
  const V flat = hn::Set(d, k.flat);
  const V water = hn::Add(flat, hn::Mul(hn::Set(d, k.water_relief), hn::Sub(s, flat)));
  s = hn::IfThenElse(hn::Lt(e, hn::Set(d, k.sea_below)), water, s);
  if (shade) hn::StoreU(s, d, shade);
  const std::size_t N = hn::Lanes(d);
  for (int c = 0; c < 3; ++c) {
    const V sc = hn::TableLookupLanes(s, spread.idx[c]);
    const V v = albedo ? hn::Mul(hn::LoadU(d, albedo + c * N), sc) : sc;
    if constexpr (kStream) hn::Stream(v, d, rgb + c * N);
    else hn::StoreU(v, d, rgb + c * N);
  }
}

void HillshadeRowImpl(const HillshadeRow& k, const GradientRows& rows, const float* HWY_RESTRICT albedo,
                      float* HWY_RESTRICT shade, float* HWY_RESTRICT rgb, int n) {
  const D d;
  const Spread spread(d);
  const int N = int(hn::Lanes(d));
  const float* HWY_RESTRICT mid = rows.mid;
  const V central = hn::Set(d, rows.central), kz = hn::Set(d, rows.kz);
  auto inner = [&](int i, auto stream) {
    const V fx = hn::Mul(hn::Sub(hn::LoadU(d, mid + i + 1), hn::LoadU(d, mid + i - 1)), central);
    const V fz = hn::Mul(hn::Sub(hn::LoadU(d, rows.down + i), hn::LoadU(d, rows.up + i)), kz);
    HillshadeVec<decltype(stream)::value>(d, spread, k, hn::LoadU(d, mid + i), fx, fz, albedo ? albedo + 3 * i : nullptr,
                                          shade ? shade + i : nullptr, rgb + 3 * i);
  };
  auto padded = [&](int i, int m) {
    HWY_ALIGN float eb[kRowPad] = {}, xb[kRowPad] = {}, zb[kRowPad] = {}, ab[3 * kRowPad] = {};
    HWY_ALIGN float sb[kRowPad], out[3 * kRowPad];
    for (int c = 0; c < m; ++c) eb[c] = mid[i + c], xb[c] = GradX(rows, i + c, n), zb[c] = GradZ(rows, i + c);
    if (albedo) std::copy(albedo + 3 * i, albedo + 3 * (i + m), ab);
    HillshadeVec(d, spread, k, hn::Load(d, eb), hn::Load(d, xb), hn::Load(d, zb), albedo ? ab : nullptr, sb, out);
    if (shade) std::copy(sb, sb + m, shade + i);
    std::copy(out, out + 3 * m, rgb + 3 * i);
  };
  // Streaming: as HaloBlocks, but the first block is p ∈ [1, N] samples long, the p that puts
  // rgb + 3p on a vector boundary (12 bytes per sample: one exists when rgb is 4-byte aligned, as
  // floats are), so that the full blocks can be streamed. Same values as the plain path.
  const std::size_t vb = sizeof(float) * std::size_t(N);
  int p = 0;
  if (k.stream && n > 2 * N + 1)
    for (int c = 1; c <= N && p == 0; ++c)
      if (reinterpret_cast<std::uintptr_t>(rgb + 3 * c) % vb == 0) p = c;
  if (p == 0) {
    HaloBlocks(N, n, [&](int i) { inner(i, std::false_type()); }, padded);
    return;
  }
  padded(0, p);
  int i = p;
  for (; i + N < n; i += N) inner(i, std::true_type());
  for (; i < n; i += N) padded(i, std::min(N, n - i));
  hwy::FlushStream();
}

const char* TargetImpl() { return hwy::TargetName(HWY_TARGET); }

}  // namespace HWY_NAMESPACE
}  // namespace relief::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace relief::detail {

HWY_EXPORT(RedistributeRowImpl);
HWY_EXPORT(TerraceRowImpl);
HWY_EXPORT(IslandRowImpl);
HWY_EXPORT(CurveRowImpl);
HWY_EXPORT(ColorRowImpl);
HWY_EXPORT(LatticeRowImpl);
HWY_EXPORT(HillshadeRowImpl);
HWY_EXPORT(TargetImpl);

float float_at_most(double v) {
  float f = float(v);
  if (double(f) > v) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}

float float_at_least(double v) {
  float f = float(v);
  if (double(f) < v) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

void RedistributeRow::set_exponent(double y) {
  exponent = float(y);
  power = exponent != 1.0f;
  int e = 0;
  std::frexp(double(exponent), &e);
  const double scale = std::ldexp(1.0, 12 - e);  // keep 12 significant bits
  exponent_hi = float(std::nearbyint(double(exponent) * scale) / scale);
  exponent_lo = exponent - exponent_hi;  // exact: the low bits of a float
  for (int c = 0; c < 3; ++c) log2_y[c] = float(double(exponent) * kPowLog2[c]);
  // x^y ≥ 2^−125 ⟺ x ≥ 2^(−125/y); 0 is below it for every y > 0.
  x_min = std::max(float_at_least(std::exp2(-125.0 / double(exponent))), std::numeric_limits<float>::denorm_min());
  // Land-only: x = e − sea, u = x/land; u^y ≥ 2^−100 ⟸ x ≥ 2^(−100/y)·land (with a margin for
  // the rounding of x/land). Smaller x are lifted to this (RedistributePow): land·u^y stays a
  // normal float, and sea + land·u^y rounds to the sea level for any sea level ≥ 2^−70.
  land_x_min = std::max(float_at_least(std::exp2(-100.0 / double(exponent)) * double(land.land) * (1.0 + 1e-6)),
                        std::numeric_limits<float>::denorm_min());
}

LandOnly LandOnly::make(bool enabled, double sea_level) {
  LandOnly l;
  l.enabled = enabled;
  if (!enabled) return l;
  if (sea_level >= 1.0) {
    l.sea_floor_max = 1.0f;  // every (clamped) sample is sea floor
    return l;
  }
  l.sea_floor_max = float_at_most(sea_level);
  l.sea = float(sea_level);
  l.land = float(1.0 - sea_level);
  return l;
}

void redistribute_row(const RedistributeRow& k, float* row, int n) { HWY_DYNAMIC_DISPATCH(RedistributeRowImpl)(k, row, n); }
void terrace_row(const TerraceRow& k, float* row, int n) { HWY_DYNAMIC_DISPATCH(TerraceRowImpl)(k, row, n); }
void island_row(const IslandRow& k, float row_term, float* row, int n) {
  HWY_DYNAMIC_DISPATCH(IslandRowImpl)(k, row_term, row, n);
}
void curve_row(const CurveRow& k, float* row, int n) { HWY_DYNAMIC_DISPATCH(CurveRowImpl)(k, row, n); }
void color_row(const ColorRow& k, const GradientRows& rows, const float* slope, const float* a0, const float* a1,
               float tz, const float* water, float* rgb, int n) {
  HWY_DYNAMIC_DISPATCH(ColorRowImpl)(k, rows, slope, a0, a1, tz, water, rgb, n);
}

std::vector<float> color_level_tables(const ColorRow& k) {
  const int L = k.levels;
  if (L < 1 || L > kLevelLanes) return {};
  for (int m = 0; m + 1 < L; ++m)
    if (!(k.at[m] <= k.at[m + 1])) return {};
  // Row t, lane c: the value for the vectors with c levels below e (the select chain's choice).
  std::vector<float> t(std::size_t(8) * kLevelLanes, 0.0f);
  auto put = [&](int row, int c, float v) { t[std::size_t(row) * kLevelLanes + c] = v; };
  for (int c = 0; c < L; ++c) {
    if (!k.gradient) {
      put(0, c, k.r[c]), put(1, c, k.g[c]), put(2, c, k.b[c]);
      continue;
    }
    // The last non-empty segment m < c, as the chain of selects picks it; defaults if none.
    float a0 = k.at[0], w = 1.0f, r0 = k.r[0], g0 = k.g[0], b0 = k.b[0], dr = 0, dg = 0, db = 0;
    for (int m = 0; m < c && m + 1 < L; ++m) {
      if (!(k.at[m + 1] > k.at[m])) continue;
      a0 = k.at[m], w = float(double(k.at[m + 1]) - double(k.at[m]));
      r0 = k.r[m], g0 = k.g[m], b0 = k.b[m];
      dr = k.r[m + 1] - k.r[m], dg = k.g[m + 1] - k.g[m], db = k.b[m + 1] - k.b[m];
    }
    put(0, c, a0), put(1, c, w), put(2, c, r0), put(3, c, g0), put(4, c, b0), put(5, c, dr), put(6, c, dg), put(7, c, db);
  }
  // Lanes past the last level are never selected; give them the last level's values anyway.
  for (int row = 0; row < 8; ++row)
    for (int c = L; c < kLevelLanes; ++c) put(row, c, t[std::size_t(row) * kLevelLanes + L - 1]);
  return t;
}

void lattice_row(const float* lat, const std::int32_t* ix, const float* tx, float* out, int n) {
  HWY_DYNAMIC_DISPATCH(LatticeRowImpl)(lat, ix, tx, out, n);
}
void hillshade_row(const HillshadeRow& k, const GradientRows& rows, const float* albedo, float* shade, float* rgb,
                   int n) {
  HWY_DYNAMIC_DISPATCH(HillshadeRowImpl)(k, rows, albedo, shade, rgb, n);
}
const char* pointwise_target() { return HWY_DYNAMIC_DISPATCH(TargetImpl)(); }

}  // namespace relief::detail
#endif  // HWY_ONCE
