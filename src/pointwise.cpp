// Vectorised row kernels of the pointwise and colour stages (see pointwise.hpp for the contract).
//
// Google Highway (https://github.com/google/highway), runtime dispatch: this file is compiled once
// per target by foreach_target.h and each entry point dispatches through HWY_DYNAMIC_DISPATCH.
// The formulas are the stages' own (stage_shape.cpp and stage_color.cpp name their sources);
// pow is exp(y·log x) with Highway's Exp and Log (contrib/math).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "pointwise.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep

#include <hwy/contrib/math/math-inl.h>
#include <hwy/highway.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "pointwise.hpp"

HWY_BEFORE_NAMESPACE();
namespace relief::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using D = hn::ScalableTag<float>;
using V = hn::Vec<D>;
using DI = hn::RebindToSigned<D>;

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

void RedistributeRowImpl(const RedistributeRow& k, float* HWY_RESTRICT row, int n) {
  const D d;
  const V y = hn::Set(d, k.exponent), mod = hn::Set(d, k.modifier), one = hn::Set(d, 1.0f);
  // Below e^−87 (1.6e-38, the smallest normal floats) pow flushes to 0: denormal results would
  // cost a microcode assist per vector and change nothing visible.
  const V min_arg = hn::Set(d, -87.0f);
  auto g = [&](V u) {
    V p = u;
    if (k.power) {
      const auto pos = hn::Gt(u, hn::Zero(d));
      const V arg = hn::Mul(y, hn::Log(d, hn::IfThenElse(pos, u, one)));
      p = hn::IfThenElseZero(hn::And(pos, hn::Gt(arg, min_arg)), hn::Exp(d, hn::Max(arg, min_arg)));
    }
    return Clamp01(d, hn::Mul(mod, p));
  };
  InPlace(d, row, n, [&](V v, int) { return Clamp01(d, WithLand(d, k.land, Clamp01(d, v), g)); });
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
    const V s = Clamp01(d, hn::Div(hn::Sub(x, x0), h));
    V y = hn::Add(c0, hn::Mul(s, hn::Add(c1, hn::Mul(s, hn::Add(c2, hn::Mul(s, c3))))));
    y = hn::Min(hn::Max(y, lo), hi);  // exact no-overshoot guarantee
    y = hn::IfThenElse(hn::Le(x, first_x), first_y, y);
    y = hn::IfThenElse(hn::Ge(x, last_x), last_y, y);
    return Clamp01(d, y);
  });
}

// One vector of the colour stage: e, slope (degrees or |∇y|²), a0, a1 at this vector's columns.
HWY_INLINE void ColorVec(D d, const ColorRow& k, const float* HWY_RESTRICT e_in, const float* HWY_RESTRICT slope_in,
                         const float* HWY_RESTRICT a0_in, const float* HWY_RESTRICT a1_in, float tz,
                         float* HWY_RESTRICT rgb) {
  V e = hn::LoadU(d, e_in);
  if (k.relative) e = hn::Div(e, hn::Set(d, k.max_height));
  V r, g, b;
  if (!k.gradient) {
    // First level with e ≤ at: walk down from the last so that lower levels win.
    const int last = k.levels - 1;
    r = hn::Set(d, k.r[last]), g = hn::Set(d, k.g[last]), b = hn::Set(d, k.b[last]);
    for (int m = last; m >= 0; --m) {
      const auto in = hn::Le(e, hn::Set(d, k.at[m]));
      r = hn::IfThenElse(in, hn::Set(d, k.r[m]), r);
      g = hn::IfThenElse(in, hn::Set(d, k.g[m]), g);
      b = hn::IfThenElse(in, hn::Set(d, k.b[m]), b);
    }
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
    const int last = k.levels - 1;
    const auto below = hn::Le(e, hn::Set(d, k.at[0])), above = hn::Ge(e, hn::Set(d, k.at[last]));
    r = hn::IfThenElse(below, hn::Set(d, k.r[0]), hn::IfThenElse(above, hn::Set(d, k.r[last]), r));
    g = hn::IfThenElse(below, hn::Set(d, k.g[0]), hn::IfThenElse(above, hn::Set(d, k.g[last]), g));
    b = hn::IfThenElse(below, hn::Set(d, k.b[0]), hn::IfThenElse(above, hn::Set(d, k.b[last]), b));
  }
  if (k.rock) {
    const V slope = hn::LoadU(d, slope_in);
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
  hn::StoreInterleaved3(Clamp01(d, r), Clamp01(d, g), Clamp01(d, b), d, rgb);
}

void ColorRowImpl(const ColorRow& k, const float* HWY_RESTRICT e, const float* HWY_RESTRICT slope,
                  const float* HWY_RESTRICT a0, const float* HWY_RESTRICT a1, float tz, float* HWY_RESTRICT rgb, int n) {
  const D d;
  const int N = int(hn::Lanes(d));
  int i = 0;
  for (; i + N <= n; i += N)
    ColorVec(d, k, e + i, k.rock ? slope + i : nullptr, k.speckle ? a0 + i : nullptr, k.speckle ? a1 + i : nullptr, tz,
             rgb + 3 * i);
  if (i < n) {
    HWY_ALIGN float eb[kRowPad] = {}, sb[kRowPad] = {}, out[3 * kRowPad];
    std::copy(e + i, e + n, eb);
    if (k.rock) std::copy(slope + i, slope + n, sb);
    // a0, a1 are padded by the caller.
    ColorVec(d, k, eb, sb, k.speckle ? a0 + i : nullptr, k.speckle ? a1 + i : nullptr, tz, out);
    std::copy(out, out + 3 * (n - i), rgb + 3 * i);
  }
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

HWY_INLINE void HillshadeVec(D d, const Spread& spread, const HillshadeRow& k, const float* HWY_RESTRICT e_in,
                             const float* HWY_RESTRICT fx_in, const float* HWY_RESTRICT fz_in,
                             const float* HWY_RESTRICT albedo, float* HWY_RESTRICT shade, float* HWY_RESTRICT rgb) {
  const V one = hn::Set(d, 1.0f);
  const V fx = hn::LoadU(d, fx_in), fz = hn::LoadU(d, fz_in);
  const V num = hn::Sub(hn::Add(hn::Mul(hn::Neg(fx), hn::Set(d, k.lx)), hn::Set(d, k.ly)), hn::Mul(fz, hn::Set(d, k.lz)));
  const V len = hn::Sqrt(hn::Add(hn::Add(one, hn::Mul(fx, fx)), hn::Mul(fz, fz)));
  const V ndotl = hn::Div(num, len);
  V s = hn::Add(hn::Set(d, k.ambient), hn::Mul(hn::Set(d, k.diffuse), hn::Max(hn::Zero(d), ndotl)));
  const V flat = hn::Set(d, k.flat);
  const V water = hn::Add(flat, hn::Mul(hn::Set(d, k.water_relief), hn::Sub(s, flat)));
  s = hn::IfThenElse(hn::Lt(hn::LoadU(d, e_in), hn::Set(d, k.sea_below)), water, s);
  hn::StoreU(s, d, shade);
  const std::size_t N = hn::Lanes(d);
  for (int c = 0; c < 3; ++c) {
    const V sc = hn::TableLookupLanes(s, spread.idx[c]);
    hn::StoreU(albedo ? hn::Mul(hn::LoadU(d, albedo + c * N), sc) : sc, d, rgb + c * N);
  }
}

void HillshadeRowImpl(const HillshadeRow& k, const float* HWY_RESTRICT e, const float* HWY_RESTRICT fx,
                      const float* HWY_RESTRICT fz, const float* HWY_RESTRICT albedo, float* HWY_RESTRICT shade,
                      float* HWY_RESTRICT rgb, int n) {
  const D d;
  const Spread spread(d);
  const int N = int(hn::Lanes(d));
  int i = 0;
  for (; i + N <= n; i += N)
    HillshadeVec(d, spread, k, e + i, fx + i, fz + i, albedo ? albedo + 3 * i : nullptr, shade + i, rgb + 3 * i);
  if (i < n) {
    const int m = n - i;
    HWY_ALIGN float eb[kRowPad] = {}, xb[kRowPad] = {}, zb[kRowPad] = {}, ab[3 * kRowPad] = {};
    HWY_ALIGN float sb[kRowPad], out[3 * kRowPad];
    std::copy(e + i, e + n, eb);
    std::copy(fx + i, fx + n, xb);
    std::copy(fz + i, fz + n, zb);
    if (albedo) std::copy(albedo + 3 * i, albedo + 3 * n, ab);
    HillshadeVec(d, spread, k, eb, xb, zb, albedo ? ab : nullptr, sb, out);
    std::copy(sb, sb + m, shade + i);
    std::copy(out, out + 3 * m, rgb + 3 * i);
  }
}

// The border columns and the columns after the last full vector are computed one by one with the
// same two exactly rounded operations, so they equal what a vector lane would give.
template <bool kSquare>
void GradientRowT(const float* HWY_RESTRICT up, const float* HWY_RESTRICT mid, const float* HWY_RESTRICT down,
                  float central, float edge, float kz, float* HWY_RESTRICT gx, float* HWY_RESTRICT gz, int n) {
  const D d;
  const int N = int(hn::Lanes(d));
  const V vc = hn::Set(d, central), vz = hn::Set(d, kz);
  auto one = [&](int i, float x) {
    const float z = (down[i] - up[i]) * kz;
    if constexpr (kSquare) gx[i] = x * x + z * z;
    else gx[i] = x, gz[i] = z;
  };
  one(0, (mid[1] - mid[0]) * edge);
  int i = 1;
  for (; i + N <= n - 1; i += N) {
    const V x = hn::Mul(hn::Sub(hn::LoadU(d, mid + i + 1), hn::LoadU(d, mid + i - 1)), vc);
    const V z = hn::Mul(hn::Sub(hn::LoadU(d, down + i), hn::LoadU(d, up + i)), vz);
    if constexpr (kSquare) {
      hn::StoreU(hn::Add(hn::Mul(x, x), hn::Mul(z, z)), d, gx + i);
    } else {
      hn::StoreU(x, d, gx + i);
      hn::StoreU(z, d, gz + i);
    }
  }
  for (; i < n - 1; ++i) one(i, (mid[i + 1] - mid[i - 1]) * central);
  one(n - 1, (mid[n - 1] - mid[n - 2]) * edge);
}

void GradientRowImpl(const float* up, const float* mid, const float* down, float central, float edge, float kz,
                     float* gx, float* gz, int n) {
  GradientRowT<false>(up, mid, down, central, edge, kz, gx, gz, n);
}
void Gradient2RowImpl(const float* up, const float* mid, const float* down, float central, float edge, float kz,
                      float* g2, int n) {
  GradientRowT<true>(up, mid, down, central, edge, kz, g2, nullptr, n);
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
HWY_EXPORT(GradientRowImpl);
HWY_EXPORT(Gradient2RowImpl);
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
void color_row(const ColorRow& k, const float* e, const float* slope, const float* a0, const float* a1, float tz,
               float* rgb, int n) {
  HWY_DYNAMIC_DISPATCH(ColorRowImpl)(k, e, slope, a0, a1, tz, rgb, n);
}
void lattice_row(const float* lat, const std::int32_t* ix, const float* tx, float* out, int n) {
  HWY_DYNAMIC_DISPATCH(LatticeRowImpl)(lat, ix, tx, out, n);
}
void hillshade_row(const HillshadeRow& k, const float* e, const float* fx, const float* fz, const float* albedo,
                   float* shade, float* rgb, int n) {
  HWY_DYNAMIC_DISPATCH(HillshadeRowImpl)(k, e, fx, fz, albedo, shade, rgb, n);
}
void gradient_row(const float* up, const float* mid, const float* down, float central, float edge, float kz, float* gx,
                  float* gz, int n) {
  HWY_DYNAMIC_DISPATCH(GradientRowImpl)(up, mid, down, central, edge, kz, gx, gz, n);
}
void gradient2_row(const float* up, const float* mid, const float* down, float central, float edge, float kz, float* g2,
                   int n) {
  HWY_DYNAMIC_DISPATCH(Gradient2RowImpl)(up, mid, down, central, edge, kz, g2, n);
}
const char* pointwise_target() { return HWY_DYNAMIC_DISPATCH(TargetImpl)(); }

}  // namespace relief::detail
#endif  // HWY_ONCE
