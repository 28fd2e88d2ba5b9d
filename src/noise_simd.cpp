// SIMD row kernels for every noise basis, with Google Highway and run-time dispatch.
//
// Sources:
//   * The algorithms are those of noise.cpp (Perlin 2002, classic 2D simplex, Worley 1996, Musgrave's
//     fractals, Quilez's domain warp); see the top of that file.
//   * Arithmetic lattice hashing in place of permutation tables, as FastNoise2 (Jordan Peck) and
//     FastNoise Lite do: hash = (X·Pₓ ⊕ Z·P_z ⊕ seed)·M, gradient picked from its top bits.
//   * Google Highway (github.com/google/highway), "foreach_target" multi-target compilation and
//     HWY_DYNAMIC_DISPATCH.
//
// Structure. noise_row_simd() dispatches once per row to a kernel specialised for (basis, fractal,
// warp, periodic x, periodic z, cellular return): no virtual calls and no branches on parameters in
// the loop over samples. Per row, everything that depends only on z (lattice row, fade, row hash
// keys) is computed once per octave into `rows[]`; then each vector of samples runs through all
// octaves (and both warp noises) with the accumulator in a register: octaves are fused.
//
//   Perlin                            in double, Lanes(double) samples per step. On AVX-512
//                                     Perlin's 256-byte table
//                                     sits in four registers (16-bit permutes, PermLookup) and
//                                     its gradient table in registers (vpermt2pd); elsewhere
//                                     they are gathers (int32 table).
//   Gradient                          lattice split in double, then float: 2·Lanes(double)
//                                     samples per step (16 on AVX-512); the gradient components
//                                     come from an in-register permute (vpermps), no gathers.
//                                     At lacunarity 2 (the dyadic lattice, noise.cpp) only
//                                     octave 0 is split in double; the others step a 32.32
//                                     fixed-point state with 8 integer/float operations per
//                                     vector. Fractal::None has its own loop (no octave loop,
//                                     no amplitude or 1/Σa multiplies, which are by 1).
//   Value                             the Gradient kernel's lattice, rows and column terms, with
//                                     a hashed 24-bit lattice value per corner (ValCorner)
//                                     instead of a gradient dot product.
//   Simplex                           lattice rows along x (noise.cpp): the column split in
//                                     double, then float with Gradient's hash and gradient set;
//                                     the row's terms and its gy·dy products once per row; four
//                                     vertices (two per lattice row, no triangle choice). Blocks
//                                     of rows take their column terms from Noise::columns as
//                                     Gradient does (RowSimplexColumns).
//   Cellular                          the column split in double as Gradient's, then float on
//                                     2·Lanes(double) lanes: Gradient's labels and pre-hash,
//                                     cell_mix32, nine candidates folded by selects (RowCellular);
//                                     the rows' z work once per octave without warp.
//
// Exactness. Every kernel performs the same IEEE operations in the same order as the scalar
// reference (Noise::row_reference in noise.cpp): no FMA, no reassociation, no approximate
// instructions; integer work is exact (floor via Floor on a value clamped to ±2⁵¹, int64 via the
// 1.5·2⁵² mantissa trick, period wraps corrected to exact). So every target's output is
// bit-identical to the scalar reference; tests/test_noise_simd.cpp checks this for each target.

#include <cmath>
#include <cstdint>
#include <cstring>

#include "noise_simd.hpp"

// SSSE3 adds nothing over SSE4 for these kernels and would only cost compile time.
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS HWY_SSSE3
#endif
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "noise_simd.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

HWY_BEFORE_NAMESPACE();
namespace relief::detail {
namespace HWY_NAMESPACE {
namespace {

namespace hn = hwy::HWY_NAMESPACE;

using DD = hn::ScalableTag<double>;
using DI = hn::RebindToSigned<DD>;    // int64, one per double lane
using DU = hn::RebindToUnsigned<DD>;  // uint64
using DFh = hn::Rebind<float, DD>;    // float, one per double lane (half a vector)
using DI32h = hn::Rebind<std::int32_t, DD>;
// The Gradient kernel works on full float vectors: two double vectors' worth of samples. HWY_SCALAR
// (the fallback target; g++ < 12.3 builds no EMU128) has one-lane vectors only: one per step.
#if HWY_TARGET == HWY_SCALAR
constexpr int kHalves = 1;
using DF = DFh;
#else
constexpr int kHalves = 2;
using DF = hn::Twice<DFh>;  // float, two per double lane (a full vector)
#endif
using DU32 = hn::RebindToUnsigned<DF>;
using DI32 = hn::RebindToSigned<DF>;
using VD = hn::Vec<DD>;
using VI = hn::Vec<DI>;
using VU = hn::Vec<DU>;
using VI32h = hn::Vec<DI32h>;
using VF = hn::Vec<DF>;
using VU32 = hn::Vec<DU32>;

constexpr int kMaxOctaves = 16;

// ---- shared double helpers (mirror noise.cpp's floor_i64, axis, wrap, fade, lerp) --------------

// floor_i64(u) as a double: u clamped to ±2⁵¹ (NaN → −2⁵¹), floored; + 0 turns −0 into +0 like
// double(int64).
HWY_INLINE VD FloorClamped(VD u) {
  const DD d;
  const VD k = hn::Set(d, 2251799813685248.0), nk = hn::Set(d, -2251799813685248.0);
  VD c = hn::IfThenElse(u > nk, u, nk);
  c = hn::IfThenElse(c < k, c, k);
  return hn::Add(hn::Floor(c), hn::Zero(d));
}
// An integer-valued double with |x| ≤ 2⁵¹ as int64, exactly.
HWY_INLINE VI ToInt(VD x) {
  const DD d;
  const DI di;
  const VD m = hn::Set(d, kMagicInt);
  return hn::Sub(hn::BitCast(di, hn::Add(x, m)), hn::BitCast(di, m));
}
// fl mod period in [0, period), exact for integer |fl| ≤ 2⁵¹ and period ≤ 2³¹ (the quotient from
// the multiply by 1/period is off by at most one; the two selects correct it).
HWY_INLINE VD WrapD(VD fl, VD period, VD inv_period) {
  const DD d;
  VD w = hn::Sub(fl, hn::Mul(hn::Floor(hn::Mul(fl, inv_period)), period));
  w = hn::IfThenElse(w < hn::Zero(d), hn::Add(w, period), w);
  return hn::IfThenElse(w >= period, hn::Sub(w, period), w);
}
template <class V>
HWY_INLINE V Fade(V t) {
  const hn::DFromV<V> d;
  using T = hn::TFromD<decltype(d)>;
  const V t3 = hn::Mul(hn::Mul(t, t), t);
  return hn::Mul(t3, hn::Add(hn::Mul(t, hn::Sub(hn::Mul(t, hn::Set(d, T(6))), hn::Set(d, T(15)))), hn::Set(d, T(10))));
}
template <class V>
HWY_INLINE V Lerp(V t, V a, V b) {
  return hn::Add(a, hn::Mul(t, hn::Sub(b, a)));
}
// axis(u, period): cell index, next cell index (wrapped) and fraction.
struct VAxis {
  VI i0, i1;
  VD f;
};
template <bool kPeriodic>
HWY_INLINE VAxis Axis(VD u, std::int64_t period, double inv_period) {
  const DD d;
  const DI di;
  const VD fl = FloorClamped(u);
  VAxis a;
  a.f = hn::Sub(u, fl);
  if constexpr (!kPeriodic) {
    a.i0 = ToInt(fl);
    a.i1 = hn::Add(a.i0, hn::Set(di, 1));
  } else {
    a.i0 = ToInt(WrapD(fl, hn::Set(d, double(period)), hn::Set(d, inv_period)));
    const VI next = hn::Add(a.i0, hn::Set(di, 1));
    a.i1 = hn::IfThenZeroElse(next == hn::Set(di, period), next);
  }
  return a;
}
// ---- fractal folding (double) --------------------------------------------------------------------

// kNone: Fractal::None (one octave of amplitude 1, 1/Σa = 1); only the Gradient kernels and
// Simplex's columns kernel have their own instance, the others treat it as kFbm.
enum { kFbm = 0, kRidged = 1, kBillow = 2, kNone = 3 };

template <int kFr>
HWY_INLINE VD Fold(VD acc, VD amp, VD n) {
  const DD d;
  if constexpr (kFr == kFbm) {
    return hn::Add(acc, hn::Mul(amp, n));
  } else if constexpr (kFr == kRidged) {
    const VD r = hn::Sub(hn::Set(d, 1.0), hn::Abs(n));
    return hn::Add(acc, hn::Mul(amp, hn::Mul(r, r)));
  } else {
    return hn::Add(acc, hn::Mul(amp, hn::Sub(hn::Mul(hn::Set(d, 2.0), hn::Abs(n)), hn::Set(d, 1.0))));
  }
}
template <int kFr>
HWY_INLINE VD Finish(VD acc, VD inv) {
  const DD d;
  if constexpr (kFr == kRidged) return hn::Sub(hn::Mul(hn::Set(d, 2.0), hn::Mul(acc, inv)), hn::Set(d, 1.0));
  return hn::Mul(acc, inv);
}

// ---- Perlin (seeded permutation, gathers) ----------------------------------------------------------

// The low 32 bits of each int64 lane (here: values in 0..255).
HWY_INLINE VI32h Low32(VI v) {
  const hn::Rebind<std::uint32_t, DD> du32h;
  return hn::BitCast(DI32h(), hn::TruncateTo(du32h, hn::BitCast(DU(), v)));
}

struct PerlinRow {
  VI32h y0, y1;  // lattice rows & 255
  VD fy, sy;
};
template <bool kPZ>
HWY_INLINE PerlinRow PerlinMakeRow(const NoiseOctave& o, VD v) {
  const DI di;
  const VAxis az = Axis<kPZ>(v, o.period_z, o.inv_period_z);
  const VI m = hn::Set(di, 255);
  return {Low32(hn::And(az.i0, m)), Low32(hn::And(az.i1, m)), az.f, Fade(az.f)};
}
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
// p[i & 255] for 8 int32 indices i in [0, 512) (the doubled table repeats every 256), with the
// table's 256 bytes in t0..t3 read as 128 little-endian 16-bit words: vpermi2w fetches word i >> 1
// from t0:t1 (words 0..63) and from t2:t3 (64..127), bit 7 of i picks one, a shift by 8·(i & 1)
// and a mask leave the byte. Only the low 256 bits (8 lanes) of the 512-bit work are used.
HWY_INLINE VI32h PermLookup(__m512i t0, __m512i t1, __m512i t2, __m512i t3, VI32h idx) {
  const __m512i i = _mm512_castsi256_si512(idx.raw);
  const __m512i w = _mm512_srli_epi32(i, 1);
  const __m512i lo = _mm512_permutex2var_epi16(t0, w, t1), hi = _mm512_permutex2var_epi16(t2, w, t3);
  __m512i r = _mm512_mask_blend_epi32(_mm512_test_epi32_mask(i, _mm512_set1_epi32(128)), lo, hi);
  r = _mm512_srlv_epi32(r, _mm512_slli_epi32(_mm512_and_si512(i, _mm512_set1_epi32(1)), 3));
  return VI32h{_mm512_castsi512_si256(_mm512_and_si512(r, _mm512_set1_epi32(255)))};
}
#endif
template <bool kPX, bool kPZ>
struct Perlin {
  using Row = PerlinRow;
  static HWY_INLINE Row RowHoisted(const NoiseOctave& o, VD v) {
    return o.period_z ? PerlinMakeRow<true>(o, v) : PerlinMakeRow<false>(o, v);
  }
  static HWY_INLINE Row MakeRow(const NoiseOctave& o, VD v) { return PerlinMakeRow<kPZ>(o, v); }
  static HWY_INLINE VD Eval(const NoiseOctave& o, const Row& r, VD u) {
    const DD d;
    const DI di;
    const DI32h di32;
    const VAxis ax = Axis<kPX>(u, o.period_x, o.inv_period_x);
    const VI m = hn::Set(di, 255);
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
    // The 256-byte table in four registers, looked up by 16-bit permutes (PermLookup), no gathers.
    const std::uint8_t* pb = o.perm.data();
    const __m512i t0 = _mm512_loadu_si512(pb), t1 = _mm512_loadu_si512(pb + 64);
    const __m512i t2 = _mm512_loadu_si512(pb + 128), t3 = _mm512_loadu_si512(pb + 192);
    auto look = [&](VI32h i) { return PermLookup(t0, t1, t2, t3, i); };
#else
    const std::int32_t* p = o.perm32.data();
    auto look = [&](VI32h i) { return hn::GatherIndex(di32, p, i); };
#endif
    const VI32h A = look(Low32(hn::And(ax.i0, m)));
    const VI32h B = look(Low32(hn::And(ax.i1, m)));
    const VI32h m15 = hn::Set(di32, 15);
    auto hash = [&](VI32h base, VI32h row) { return hn::PromoteTo(di, hn::And(look(look(hn::Add(base, row))), m15)); };
    const VI h00 = hash(A, r.y0), h10 = hash(B, r.y0), h01 = hash(A, r.y1), h11 = hash(B, r.y1);
    const VD fx = ax.f, fx1 = hn::Sub(fx, hn::Set(d, 1.0)), fy1 = hn::Sub(r.fy, hn::Set(d, 1.0));
    auto grad = [&](VI h, VD x, VD y) {
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
      // The 16-entry tables in two registers each: one vpermt2pd per lookup instead of a gather.
      const VD gx{_mm512_permutex2var_pd(_mm512_loadu_pd(kPerlinGradX), h.raw, _mm512_loadu_pd(kPerlinGradX + 8))};
      const VD gy{_mm512_permutex2var_pd(_mm512_loadu_pd(kPerlinGradY), h.raw, _mm512_loadu_pd(kPerlinGradY + 8))};
      return hn::Add(hn::Mul(gx, x), hn::Mul(gy, y));
#else
      return hn::Add(hn::Mul(hn::GatherIndex(d, kPerlinGradX, h), x), hn::Mul(hn::GatherIndex(d, kPerlinGradY, h), y));
#endif
    };
    const VD g00 = grad(h00, fx, r.fy), g10 = grad(h10, fx1, r.fy);
    const VD g01 = grad(h01, fx, fy1), g11 = grad(h11, fx1, fy1);
    const VD sx = Fade(fx);
    return Lerp(r.sy, Lerp(sx, g00, g10), Lerp(sx, g01, g11));
  }
};

// Bases other than cellular ignore the jitter argument. (Tag dispatch: `int` prefers the
// four-argument Eval when it exists; clang rejects the overload set as ambiguous otherwise.)
template <class B>
HWY_INLINE auto EvalWithTag(const NoiseOctave& o, const typename B::Row& r, VD u, VD jitter, int)
    -> decltype(B::Eval(o, r, u, jitter)) {
  return B::Eval(o, r, u, jitter);
}
template <class B>
HWY_INLINE VD EvalWithTag(const NoiseOctave& o, const typename B::Row& r, VD u, VD, long) {
  return B::Eval(o, r, u);
}
template <class B>
HWY_INLINE VD EvalWith(const NoiseOctave& o, const typename B::Row& r, VD u, VD jitter) {
  return EvalWithTag<B>(o, r, u, jitter, 0);
}

// ---- the double-precision row driver ----------------------------------------------------------------

HWY_INLINE void StoreTail(hn::Vec<DFh> v, float* out, int count) {
  HWY_ALIGN float tmp[64];
  hn::Store(v, DFh(), tmp);
  std::memcpy(out, tmp, std::size_t(count) * sizeof(float));
}

template <class B, int kFr, bool kWarp>
HWY_NOINLINE void RowDouble(const NoiseKernelArgs& a, double z, std::int64_t i0, double dx, int n, float* out) {
  const DD d;
  const DI di;
  const DFh dfh;
  const int N = int(hn::Lanes(d));
  using Row = typename B::Row;
  Row rows[kMaxOctaves];
  Row wrows[2];
  const VD vz = hn::Set(d, z);
  auto lattice_v = [&](const NoiseOctave& o, VD zz) {
    return hn::Add(hn::Mul(zz, hn::Set(d, o.freq_z)), hn::Set(d, o.offset_z));
  };
  if constexpr (kWarp) {
    for (int w = 0; w < 2; ++w) wrows[w] = B::RowHoisted(a.warp_octaves[w], lattice_v(a.warp_octaves[w], vz));
  } else {
    for (int k = 0; k < a.count; ++k) rows[k] = B::RowHoisted(a.octaves[k], lattice_v(a.octaves[k], vz));
  }
  const VD vdx = hn::Set(d, dx), inv = hn::Set(d, a.inv_amp_sum), wm = hn::Set(d, a.warp_m);
  const VD jitter = hn::Set(d, a.jitter);
  const VI iota = hn::Iota(di, 0);
  for (int start = 0; start < n; start += N) {
    VD x = hn::Mul(hn::ConvertTo(d, hn::Add(iota, hn::Set(di, i0 + start))), vdx);
    VD zl = vz;
    if constexpr (kWarp) {
      const NoiseOctave &w0 = a.warp_octaves[0], &w1 = a.warp_octaves[1];
      const VD n1 = EvalWith<B>(w1, wrows[1], hn::Add(hn::Mul(x, hn::Set(d, w1.freq_x)), hn::Set(d, w1.offset_x)), jitter);
      const VD n0 = EvalWith<B>(w0, wrows[0], hn::Add(hn::Mul(x, hn::Set(d, w0.freq_x)), hn::Set(d, w0.offset_x)), jitter);
      zl = hn::Add(vz, hn::Mul(wm, n1));
      x = hn::Add(x, hn::Mul(wm, n0));
    }
    VD acc = hn::Zero(d);
    for (int k = 0; k < a.count; ++k) {
      const NoiseOctave& o = a.octaves[k];
      const VD u = hn::Add(hn::Mul(x, hn::Set(d, o.freq_x)), hn::Set(d, o.offset_x));
      VD nb;
      if constexpr (kWarp)
        nb = EvalWith<B>(o, B::MakeRow(o, lattice_v(o, zl)), u, jitter);
      else
        nb = EvalWith<B>(o, rows[k], u, jitter);
      acc = Fold<kFr>(acc, hn::Set(d, o.amp), nb);
    }
    const auto res = hn::DemoteTo(dfh, Finish<kFr>(acc, inv));
    if (start + N <= n)
      hn::StoreU(res, dfh, out + start);
    else
      StoreTail(res, out + start, n - start);
  }
}

// ---- Gradient (arithmetic hash, float) ----------------------------------------------------------------

// Float vector from kHalves double vectors (lanes of u[0] first), rounded to nearest.
HWY_INLINE VF JoinDemote(const VD (&u)[kHalves]) {
#if HWY_TARGET == HWY_SCALAR
  return hn::DemoteTo(DF(), u[0]);
#else
  const DFh dfh;
  return hn::Combine(DF(), hn::DemoteTo(dfh, u[1]), hn::DemoteTo(dfh, u[0]));
#endif
}
// The low 32 bits of the int64 held by (integer-valued, |x| ≤ 2⁵¹) doubles x.
HWY_INLINE VU32 JoinLow32(const VD (&x)[kHalves]) {
  const DD d;
  const VD m = hn::Set(d, kMagicInt);
#if HWY_TARGET == HWY_SCALAR
  return hn::TruncateTo(DU32(), hn::BitCast(DU(), hn::Add(x[0], m)));
#else
  const DU32 du32;
  return hn::ConcatEven(du32, hn::BitCast(du32, hn::Add(x[1], m)), hn::BitCast(du32, hn::Add(x[0], m)));
#endif
}
// Double vectors from the float vector's lanes (inverse of the join order).
HWY_INLINE void SplitPromote(VF v, VD (&out)[kHalves]) {
  const DD d;
#if HWY_TARGET == HWY_SCALAR
  out[0] = hn::PromoteTo(d, v);
#else
  const DFh dfh;
  out[0] = hn::PromoteTo(d, hn::LowerHalf(dfh, v));
  out[1] = hn::PromoteTo(d, hn::UpperHalf(dfh, v));
#endif
}

// Lattice split of a float vector's worth of positions, as gaxis() in noise.cpp.
struct GAxisV {
  VU32 i0, i1;
  VF f;
};
template <bool kPeriodic>
HWY_INLINE GAxisV GAxis(const VD (&u)[kHalves], std::int64_t period, double inv_period) {
  const DD d;
  const DU32 du32;
  VD fl[kHalves], fr[kHalves];
  for (int h = 0; h < kHalves; ++h) {
    fl[h] = hn::Floor(u[h]);
    fr[h] = hn::Sub(u[h], fl[h]);
  }
  GAxisV a;
  a.f = JoinDemote(fr);
  if constexpr (kPeriodic) {
    const VD p = hn::Set(d, double(period)), ip = hn::Set(d, inv_period);
    for (int h = 0; h < kHalves; ++h) fl[h] = WrapD(fl[h], p, ip);
  }
  a.i0 = JoinLow32(fl);
  const VU32 next = hn::Add(a.i0, hn::Set(du32, 1u));
  if constexpr (kPeriodic)
    a.i1 = hn::IfThenZeroElse(next == hn::Set(du32, std::uint32_t(period)), next);
  else
    a.i1 = next;
  return a;
}

struct GradRow {
  VU32 zp0, zp1;  // Z·P_z ⊕ key of the lattice rows below and above
  VF fy, fy1, sy;
};
HWY_INLINE GradRow GradRowFromAxis(const NoiseOctave& o, const GAxisV& az) {
  const DF df;
  const DU32 du32;
  const VU32 pz = hn::Set(du32, kGradPz), key = hn::Set(du32, o.key32);
  GradRow g;
  g.zp0 = hn::Xor(hn::Mul(az.i0, pz), key);
  g.zp1 = hn::Xor(hn::Mul(az.i1, pz), key);
  g.fy = az.f;
  g.fy1 = hn::Sub(az.f, hn::Set(df, 1.0f));
  g.sy = Fade(az.f);
  return g;
}

template <bool kPZ>
HWY_INLINE GradRow GradMakeRow(const NoiseOctave& o, const VD (&v)[kHalves]) {
  return GradRowFromAxis(o, GAxis<kPZ>(v, o.period_z, o.inv_period_z));
}
HWY_INLINE GradRow GradRowHoisted(const NoiseOctave& o, VD v) {
  VD vv[kHalves];
  for (int h = 0; h < kHalves; ++h) vv[h] = v;
  return o.period_z ? GradMakeRow<true>(o, vv) : GradMakeRow<false>(o, vv);
}

// table[idx] for idx in 0..7 (16-entry tables: the 8 repeated). AVX2 and AVX-512 use one
// in-register permute (vpermps); SSE4 and the scalar fallback read the table from memory.
HWY_INLINE VF Lookup8(const float* table, VU32 idx) {
  const DF df;
  const DI32 di32;
#if HWY_TARGET == HWY_SCALAR || HWY_TARGET == HWY_SSE4
  return hn::GatherIndex(df, table, hn::BitCast(di32, idx));
#else
  return hn::TableLookupLanes(hn::Load(df, table), hn::IndicesFromVec(df, hn::BitCast(di32, idx)));
#endif
}

// Dot product of corner (xp, zp)'s gradient with the offset (ax, ay) from it, as gcorner().
HWY_INLINE VF GradCorner(VU32 xp, VU32 zp, VF ax, VF ay) {
  const DU32 du32;
  const VU32 k = hn::ShiftRight<29>(hn::Mul(hn::Xor(xp, zp), hn::Set(du32, kGradM)));
  return hn::Add(hn::Mul(Lookup8(kGradDirX, k), ax), hn::Mul(Lookup8(kGradDirY, k), ay));
}

// Ridged: the corner offsets scaled by s (ridged_scale), fy' = s·fy, fy1' = fy' − s; sy unscaled.
HWY_INLINE GradRow ScaleRow(GradRow g, VF s) {
  g.fy = hn::Mul(s, g.fy);
  g.fy1 = hn::Sub(g.fy, s);
  return g;
}

// kScaled (ridged): fx' = s·fx, fx1' = fx' − s; the fade on the unscaled fx.
template <bool kPX, bool kScaled = false>
HWY_INLINE VF GradEvalAxis(const GradRow& r, const GAxisV& ax, VF s = hn::Zero(DF())) {
  const DF df;
  const DU32 du32;
  const VU32 px = hn::Set(du32, kGradPx);
  const VU32 xp0 = hn::Mul(ax.i0, px);
  // (i0 + 1)·Pₓ = i0·Pₓ + Pₓ modulo 2³²: the same bits as the scalar's multiply.
  const VU32 xp1 = kPX ? hn::Mul(ax.i1, px) : hn::Add(xp0, px);
  const VF fx = kScaled ? hn::Mul(s, ax.f) : ax.f;
  const VF fx1 = kScaled ? hn::Sub(fx, s) : hn::Sub(fx, hn::Set(df, 1.0f));
  const VF g00 = GradCorner(xp0, r.zp0, fx, r.fy);
  const VF g10 = GradCorner(xp1, r.zp0, fx1, r.fy);
  const VF g01 = GradCorner(xp0, r.zp1, fx, r.fy1);
  const VF g11 = GradCorner(xp1, r.zp1, fx1, r.fy1);
  const VF sx = Fade(ax.f);
  return Lerp(r.sy, Lerp(sx, g00, g10), Lerp(sx, g01, g11));
}
template <bool kPX, bool kScaled = false>
HWY_INLINE VF GradEval(const NoiseOctave& o, const GradRow& r, const VD (&u)[kHalves], VF s = hn::Zero(DF())) {
  return GradEvalAxis<kPX, kScaled>(r, GAxis<kPX>(u, o.period_x, o.inv_period_x), s);
}

// Value basis (noise.cpp, value_axis): corner values are the top 24 bits of the same hash as
// GradCorner's, as signed integers (exact in float), blended, then scaled by c (2⁻²³, ridged
// s·2⁻²³). The row's fy, fy1 are not used (nor scaled).
HWY_INLINE VF ValCorner(VU32 xp, VU32 zp) {
  const DF df;
  const DU32 du32;
  const DI32 di32;
  const VU32 h = hn::Mul(hn::Xor(xp, zp), hn::Set(du32, kGradM));
  return hn::ConvertTo(df, hn::ShiftRight<8>(hn::BitCast(di32, h)));
}
template <bool kPX>
HWY_INLINE VF ValEvalAxis(const GradRow& r, const GAxisV& ax, VF c) {
  const DU32 du32;
  const VU32 px = hn::Set(du32, kGradPx);
  const VU32 xp0 = hn::Mul(ax.i0, px);
  const VU32 xp1 = kPX ? hn::Mul(ax.i1, px) : hn::Add(xp0, px);
  const VF v00 = ValCorner(xp0, r.zp0), v10 = ValCorner(xp1, r.zp0);
  const VF v01 = ValCorner(xp0, r.zp1), v11 = ValCorner(xp1, r.zp1);
  const VF sx = Fade(ax.f);
  return hn::Mul(Lerp(r.sy, Lerp(sx, v00, v10), Lerp(sx, v01, v11)), c);
}
// Gradient (s: ridged scale) or Value (c: its scale) on the same lattice.
template <bool kVal, bool kPX, bool kScaled>
HWY_INLINE VF BasisEvalAxis(const GradRow& r, const GAxisV& ax, VF s, VF c) {
  if constexpr (kVal) {
    (void)s;
    return ValEvalAxis<kPX>(r, ax, c);
  } else {
    (void)c;
    return GradEvalAxis<kPX, kScaled>(r, ax, s);
  }
}
template <bool kVal, bool kPX, bool kScaled>
HWY_INLINE VF BasisEval(const NoiseOctave& o, const GradRow& r, const VD (&u)[kHalves], VF s, VF c) {
  return BasisEvalAxis<kVal, kPX, kScaled>(r, GAxis<kPX>(u, o.period_x, o.inv_period_x), s, c);
}

// The dyadic lattice (noise.cpp, dy_start / dy_step): octave 0 split in double, later octaves
// carried in 32.32 fixed point by exact doubling, u_k = 2ᵏ·u₀ + ½.
struct DyState {
  VU32 c, q, t;  // B_k's cell and fraction; t = q >> 31
};
HWY_INLINE GAxisV DyStart(const VD (&u)[kHalves], DyState& s) {
  const DD d;
  const DU32 du32;
  const VD two32 = hn::Set(d, kTwo32);
  VD fl[kHalves], fr[kHalves], fq[kHalves];
  for (int h = 0; h < kHalves; ++h) {
    fl[h] = hn::Floor(u[h]);
    fr[h] = hn::Sub(u[h], fl[h]);
    fq[h] = hn::Floor(hn::Mul(fr[h], two32));
  }
  GAxisV a;
  a.f = JoinDemote(fr);
  a.i0 = JoinLow32(fl);
  a.i1 = hn::Add(a.i0, hn::Set(du32, 1u));
  s.c = a.i0;
  s.q = JoinLow32(fq);
  s.t = hn::ShiftRight<31>(s.q);
  return a;
}
HWY_INLINE GAxisV DyStep(DyState& s) {
  const DF df;
  const DU32 du32;
  s.c = hn::Add(hn::Add(s.c, s.c), s.t);
  s.q = hn::Add(s.q, s.q);
  s.t = hn::ShiftRight<31>(s.q);
  GAxisV a;
  a.i0 = hn::Add(s.c, s.t);
  a.i1 = hn::Add(a.i0, hn::Set(du32, 1u));
  const VF m = hn::BitCast(df, hn::Xor(hn::ShiftRight<9>(s.q), hn::Set(du32, kDyadicOne)));
  a.f = hn::Sub(m, hn::Set(df, 1.0f));
  return a;
}
template <int kFr>
HWY_INLINE VF FoldF(VF acc, VF amp, VF n) {
  const DF df;
  if constexpr (kFr == kFbm) {
    return hn::Add(acc, hn::Mul(amp, n));
  } else if constexpr (kFr == kRidged) {
    // amp is s = √a and n ≈ s·n₀ (ridged_scale in noise_simd.hpp): (s − |n|)² ≈ a·(1 − |n₀|)².
    const VF r = hn::Sub(amp, hn::Abs(n));
    return hn::Add(acc, hn::Mul(r, r));
  } else {
    return hn::Add(acc, hn::Mul(amp, hn::Sub(hn::Mul(hn::Set(df, 2.0f), hn::Abs(n)), hn::Set(df, 1.0f))));
  }
}

// The end of a Gradient vector, shared by RowGradient and RowGradientColumns: normalise (ridged:
// acc·(2·inv) − 1; one octave: as is), clamp like the reference's v > −1 ? v : −1 and v < 1 ? v : 1
// (NaN → −1: x86 max/min return their second operand when either is NaN, Highway's scalar Max/Min
// the one that is not NaN), store, with a partial vector at the row's end.
template <int kFr>
HWY_INLINE void StoreGradient(VF acc, VF inv, int start, int NF, int n, float* HWY_RESTRICT out) {
  const DF df;
  const VF one = hn::Set(df, 1.0f), mone = hn::Set(df, -1.0f);
  VF v = kFr == kRidged ? hn::Sub(hn::Mul(acc, hn::Add(inv, inv)), one)  // 2·(acc·inv), ×2 exact
         : kFr == kNone ? acc
                        : hn::Mul(acc, inv);
  v = hn::Min(hn::Max(v, mone), one);
  if (start + NF <= n) {
    hn::StoreU(v, df, out + start);
  } else {
    HWY_ALIGN float tmp[64];
    hn::Store(v, df, tmp);
    std::memcpy(out + start, tmp, std::size_t(n - start) * sizeof(float));
  }
}

// kDy: the dyadic lattice (then kPX = kPZ = false): octave 0 is split in double, the later ones
// step the fixed-point state (x per sample; z once per row, or per sample when warped).
template <int kFr, bool kWarp, bool kPX, bool kPZ, bool kDy, bool kVal>
HWY_NOINLINE void RowGradient(const NoiseKernelArgs& a, double z, std::int64_t i0, double dx, int n, float* out) {
  static_assert(!kDy || (!kPX && !kPZ), "the dyadic lattice has no period");
  const DD d;
  const DI di;
  const DF df;
  const int N = int(hn::Lanes(d)), NF = kHalves * N;
  constexpr bool kSc = kFr == kRidged;  // √amplitude in the corner offsets (ridged_scale)
  float amp[kMaxOctaves];
  for (int k = 0; k < a.count; ++k) amp[k] = kSc ? a.octaves[k].ridge_scale : float(a.octaves[k].amp);
  auto scaled = [&](const GradRow& g, int k) { return kSc && !kVal ? ScaleRow(g, hn::Set(df, amp[k])) : g; };
  float vc[kMaxOctaves];  // Value: the octave's scale (value_axis in noise.cpp)
  for (int k = 0; k < a.count; ++k) vc[k] = kSc ? amp[k] * kValueScale : kValueScale;
  const VF zero = hn::Zero(df), vc1 = hn::Set(df, kValueScale);
  GradRow rows[kMaxOctaves];
  GradRow wrows[2];
  const VD vz = hn::Set(d, z);
  auto lattice = [&](double f, double off, const VD (&p)[kHalves], VD (&out_)[kHalves]) {
    for (int h = 0; h < kHalves; ++h) out_[h] = hn::Add(hn::Mul(p[h], hn::Set(d, f)), hn::Set(d, off));
  };
  auto lattice_v = [&](const NoiseOctave& o, VD zz) {
    return hn::Add(hn::Mul(zz, hn::Set(d, o.freq_z)), hn::Set(d, o.offset_z));
  };
  if constexpr (kWarp) {
    for (int w = 0; w < 2; ++w) wrows[w] = GradRowHoisted(a.warp_octaves[w], lattice_v(a.warp_octaves[w], vz));
  } else if constexpr (kDy) {
    VD v[kHalves];
    for (int h = 0; h < kHalves; ++h) v[h] = lattice_v(a.octaves[0], vz);
    DyState sz;
    rows[0] = scaled(GradRowFromAxis(a.octaves[0], DyStart(v, sz)), 0);
    for (int k = 1; k < a.count; ++k) rows[k] = scaled(GradRowFromAxis(a.octaves[k], DyStep(sz)), k);
  } else {
    for (int k = 0; k < a.count; ++k) rows[k] = scaled(GradRowHoisted(a.octaves[k], lattice_v(a.octaves[k], vz)), k);
  }
  const VD vdx = hn::Set(d, dx), wm = hn::Set(d, a.warp_m);
  const VF inv = hn::Set(df, float(a.inv_amp_sum));
  const VI iota = hn::Iota(di, 0);
  for (int start = 0; start < n; start += NF) {
    VD x[kHalves], zl[kHalves];
    for (int h = 0; h < kHalves; ++h) {
      x[h] = hn::Mul(hn::ConvertTo(d, hn::Add(iota, hn::Set(di, i0 + start + h * N))), vdx);
      zl[h] = vz;
    }
    if constexpr (kWarp) {
      const NoiseOctave &w0 = a.warp_octaves[0], &w1 = a.warp_octaves[1];
      VD u1[kHalves], u0[kHalves], n1d[kHalves], n0d[kHalves];
      lattice(w1.freq_x, w1.offset_x, x, u1);
      lattice(w0.freq_x, w0.offset_x, x, u0);
      SplitPromote(BasisEval<kVal, kPX, false>(w1, wrows[1], u1, zero, vc1), n1d);
      SplitPromote(BasisEval<kVal, kPX, false>(w0, wrows[0], u0, zero, vc1), n0d);
      for (int h = 0; h < kHalves; ++h) {
        zl[h] = hn::Add(vz, hn::Mul(wm, n1d[h]));
        x[h] = hn::Add(x[h], hn::Mul(wm, n0d[h]));
      }
    }
    VF acc = hn::Zero(df);
    if constexpr (kFr == kNone) {
      // One octave: the reference's 0 + 1·n is n (−0 becomes +0); its · 1/Σa = ·1 is skipped below.
      const NoiseOctave& o = a.octaves[0];
      VD u[kHalves];
      lattice(o.freq_x, o.offset_x, x, u);
      VF nb;
      if constexpr (kWarp) {
        VD v[kHalves];
        lattice(o.freq_z, o.offset_z, zl, v);
        nb = BasisEval<kVal, kPX, false>(o, GradMakeRow<kPZ>(o, v), u, zero, vc1);
      } else {
        nb = BasisEval<kVal, kPX, false>(o, rows[0], u, zero, vc1);
      }
      acc = hn::Add(nb, hn::Zero(df));
    } else if constexpr (kDy) {
      const NoiseOctave& o0 = a.octaves[0];
      VD u[kHalves];
      lattice(o0.freq_x, o0.offset_x, x, u);
      DyState sx, sz;
      const GAxisV ax0 = DyStart(u, sx);
      GradRow r0;
      if constexpr (kWarp) {
        VD v[kHalves];
        lattice(o0.freq_z, o0.offset_z, zl, v);
        r0 = scaled(GradRowFromAxis(o0, DyStart(v, sz)), 0);
      } else {
        r0 = rows[0];
      }
      acc = FoldF<kFr>(acc, hn::Set(df, amp[0]), BasisEvalAxis<kVal, false, kSc>(r0, ax0, hn::Set(df, amp[0]), hn::Set(df, vc[0])));
      for (int k = 1; k < a.count; ++k) {
        const GAxisV ax = DyStep(sx);
        const VF ak = hn::Set(df, amp[k]);
        VF nb;
        if constexpr (kWarp)
          nb = BasisEvalAxis<kVal, false, kSc>(scaled(GradRowFromAxis(a.octaves[k], DyStep(sz)), k), ax, ak, hn::Set(df, vc[k]));
        else
          nb = BasisEvalAxis<kVal, false, kSc>(rows[k], ax, ak, hn::Set(df, vc[k]));
        acc = FoldF<kFr>(acc, ak, nb);
      }
    } else {
      for (int k = 0; k < a.count; ++k) {
        const NoiseOctave& o = a.octaves[k];
        VD u[kHalves];
        lattice(o.freq_x, o.offset_x, x, u);
        const VF ak = hn::Set(df, amp[k]);
        VF nb;
        if constexpr (kWarp) {
          VD v[kHalves];
          lattice(o.freq_z, o.offset_z, zl, v);
          nb = BasisEval<kVal, kPX, kSc>(o, scaled(GradMakeRow<kPZ>(o, v), k), u, ak, hn::Set(df, vc[k]));
        } else {
          nb = BasisEval<kVal, kPX, kSc>(o, rows[k], u, ak, hn::Set(df, vc[k]));
        }
        acc = FoldF<kFr>(acc, ak, nb);
      }
    }
    StoreGradient<kFr>(acc, inv, start, NF, n, out);
  }
}

// ---- Simplex (float after the split, noise.cpp's simplex_row / simplex_col / simplex_cell) ---------

// A lattice row's terms (simplex_row), scalar: the same operations as noise.cpp's.
struct SimplexRowS {
  std::uint32_t zpL, zpU;
  float dyL, dyU, cL, cU;
  bool odd;
};
HWY_INLINE SimplexRowS SimplexRowScalar(std::uint32_t key32, double v) {
  const double fl = std::floor(v);
  const double m = fl + kMagicInt;
  std::uint64_t bits;
  std::memcpy(&bits, &m, 8);
  const std::uint32_t j = std::uint32_t(bits);
  SimplexRowS r;
  r.dyL = float(v - fl) * kSimplexHf;
  r.dyU = r.dyL - kSimplexHf;
  r.cL = kSimplexR2f - r.dyL * r.dyL;
  r.cU = kSimplexR2f - r.dyU * r.dyU;
  r.zpL = (j * kGradPz) ^ key32;
  r.zpU = (j * kGradPz + kGradPz) ^ key32;
  r.odd = (j & 1u) != 0;
  return r;
}
// Per lattice row and octave: the row's terms broadcast, and the products gy[k]·dy of the 16-entry
// gradient table (the same products gcorner forms per sample).
struct SimplexRowV {
  VU32 zpL, zpU;
  VF cL, cU;
  bool odd;
  HWY_ALIGN float gyL[16];
  HWY_ALIGN float gyU[16];
};
HWY_INLINE void SimplexMakeRow(std::uint32_t key32, double v, SimplexRowV& r) {
  const DF df;
  const DU32 du32;
  const SimplexRowS s = SimplexRowScalar(key32, v);
  r.zpL = hn::Set(du32, s.zpL);
  r.zpU = hn::Set(du32, s.zpU);
  r.cL = hn::Set(df, s.cL);
  r.cU = hn::Set(df, s.cU);
  r.odd = s.odd;
  for (int k = 0; k < 16; ++k) {
    r.gyL[k] = kGradDirY[k] * s.dyL;
    r.gyU[k] = kGradDirY[k] * s.dyU;
  }
}
// A column's terms (simplex_col) for a float vector's worth of positions u.
struct SimplexColV {
  VU32 xpE, xpO;
  VF dE, dO;
};
HWY_INLINE SimplexColV SimplexCol(const VD (&u)[kHalves]) {
  const DF df;
  const DU32 du32;
  VD fl[kHalves], fr[kHalves];
  for (int h = 0; h < kHalves; ++h) {
    fl[h] = hn::Floor(u[h]);
    fr[h] = hn::Sub(u[h], fl[h]);
  }
  const VU32 px = hn::Set(du32, kGradPx);
  const VF half = hn::Set(df, 0.5f);
  SimplexColV c;
  c.dE = JoinDemote(fr);
  c.xpE = hn::Mul(JoinLow32(fl), px);
  const auto lo = hn::Lt(c.dE, half);
  c.xpO = hn::IfThenElse(hn::RebindMask(du32, lo), hn::Sub(c.xpE, px), c.xpE);
  c.dO = hn::IfThenElse(lo, hn::Add(c.dE, half), hn::Sub(c.dE, half));
  return c;
}
// One vertex's term (simplex_term): max(0, c − dx²)⁴·(gx·dx + gy·dy), gy·dy from the row's table
// (gyt) or, per lane, from dy (kLaneDy: warped rows).
HWY_INLINE VF SimplexTermT(VU32 xp, VU32 zp, VF dx, VF c, const float* gyt) {
  const DF df;
  const DU32 du32;
  VF a = hn::Sub(c, hn::Mul(dx, dx));
  a = hn::Max(a, hn::Zero(df));  // a > 0 ? a : 0 (a = −0 → either zero: a² = +0)
  const VF a2 = hn::Mul(a, a);
  const VU32 k = hn::ShiftRight<29>(hn::Mul(hn::Xor(xp, zp), hn::Set(du32, kGradM)));
  const VF g = hn::Add(hn::Mul(Lookup8(kGradDirX, k), dx), Lookup8(gyt, k));
  return hn::Mul(hn::Mul(a2, a2), g);
}
HWY_INLINE VF SimplexTermV(VU32 xp, VU32 zp, VF dx, VF dy, VF c) {
  const DF df;
  VF a = hn::Sub(c, hn::Mul(dx, dx));
  a = hn::Max(a, hn::Zero(df));
  const VF a2 = hn::Mul(a, a);
  return hn::Mul(hn::Mul(a2, a2), GradCorner(xp, zp, dx, dy));
}
// simplex_cell from the lower and upper rows' left vertices (xL, dL), (xU, dU) and a row's terms.
HWY_INLINE VF SimplexCellRow(const SimplexRowV& r, VU32 xL, VF dL, VU32 xU, VF dU, VF c) {
  const DF df;
  const DU32 du32;
  const VU32 px = hn::Set(du32, kGradPx);
  const VF one = hn::Set(df, 1.0f);
  const VF lower = hn::Add(SimplexTermT(xL, r.zpL, dL, r.cL, r.gyL), SimplexTermT(hn::Add(xL, px), r.zpL, hn::Sub(dL, one), r.cL, r.gyL));
  const VF upper = hn::Add(SimplexTermT(xU, r.zpU, dU, r.cU, r.gyU), SimplexTermT(hn::Add(xU, px), r.zpU, hn::Sub(dU, one), r.cU, r.gyU));
  return hn::Mul(hn::Add(lower, upper), c);
}
HWY_INLINE VF SimplexCellFixedRow(const SimplexRowV& r, const SimplexColV& k, VF c) {
  return r.odd ? SimplexCellRow(r, k.xpO, k.dO, k.xpE, k.dE, c) : SimplexCellRow(r, k.xpE, k.dE, k.xpO, k.dO, c);
}
// simplex_cell with the row split per lane (warp).
HWY_INLINE VF SimplexCellLanes(std::uint32_t key32, const VD (&u)[kHalves], const VD (&v)[kHalves], VF c) {
  const DF df;
  const DU32 du32;
  const SimplexColV k = SimplexCol(u);
  VD fl[kHalves], fr[kHalves];
  for (int h = 0; h < kHalves; ++h) {
    fl[h] = hn::Floor(v[h]);
    fr[h] = hn::Sub(v[h], fl[h]);
  }
  const VF hgt = hn::Set(df, kSimplexHf), r2 = hn::Set(df, kSimplexR2f), one = hn::Set(df, 1.0f);
  const VF dyL = hn::Mul(JoinDemote(fr), hgt), dyU = hn::Sub(dyL, hgt);
  const VF cL = hn::Sub(r2, hn::Mul(dyL, dyL)), cU = hn::Sub(r2, hn::Mul(dyU, dyU));
  const VU32 j = JoinLow32(fl);
  const VU32 pz = hn::Set(du32, kGradPz), px = hn::Set(du32, kGradPx), key = hn::Set(du32, key32);
  const VU32 jp = hn::Mul(j, pz);
  const VU32 zpL = hn::Xor(jp, key), zpU = hn::Xor(hn::Add(jp, pz), key);
  const auto oddu = hn::Ne(hn::And(j, hn::Set(du32, 1u)), hn::Zero(du32));
  const auto odd = hn::RebindMask(df, oddu);
  const VU32 xL = hn::IfThenElse(oddu, k.xpO, k.xpE), xU = hn::IfThenElse(oddu, k.xpE, k.xpO);
  const VF dL = hn::IfThenElse(odd, k.dO, k.dE), dU = hn::IfThenElse(odd, k.dE, k.dO);
  const VF lower = hn::Add(SimplexTermV(xL, zpL, dL, dyL, cL), SimplexTermV(hn::Add(xL, px), zpL, hn::Sub(dL, one), dyL, cL));
  const VF upper = hn::Add(SimplexTermV(xU, zpU, dU, dyU, cU), SimplexTermV(hn::Add(xU, px), zpU, hn::Sub(dU, one), dyU, cU));
  return hn::Mul(hn::Add(lower, upper), c);
}

// Fractal::None is evaluated as fBm of one octave (amplitude 1, 1/Σa = 1: the same bits).
template <int kFr, bool kWarp>
HWY_NOINLINE void RowSimplex(const NoiseKernelArgs& a, double z, std::int64_t i0, double dx, int n, float* out) {
  const DD d;
  const DI di;
  const DF df;
  const int N = int(hn::Lanes(d)), NF = kHalves * N;
  constexpr bool kR = kFr == kRidged;
  const float scale = float(kSimplexScale);
  float amp[kMaxOctaves], cs[kMaxOctaves];
  SimplexRowV rows[kWarp ? 1 : kMaxOctaves];
  for (int k = 0; k < a.count; ++k) {
    const NoiseOctave& o = a.octaves[k];
    amp[k] = kR ? o.ridge_scale : float(o.amp);
    cs[k] = kR ? scale * o.ridge_scale : scale;
    if constexpr (!kWarp) SimplexMakeRow(o.key32, z * o.freq_z + o.offset_z, rows[k]);
  }
  const VD vz = hn::Set(d, z), vdx = hn::Set(d, dx), wm = hn::Set(d, a.warp_m);
  const VF inv = hn::Set(df, float(a.inv_amp_sum)), vscale = hn::Set(df, scale);
  const VI iota = hn::Iota(di, 0);
  auto lat = [&](const VD (&p)[kHalves], double f, double off, VD (&o_)[kHalves]) {
    for (int h = 0; h < kHalves; ++h) o_[h] = hn::Add(hn::Mul(p[h], hn::Set(d, f)), hn::Set(d, off));
  };
  for (int start = 0; start < n; start += NF) {
    VD x[kHalves], zl[kHalves];
    for (int h = 0; h < kHalves; ++h) {
      x[h] = hn::Mul(hn::ConvertTo(d, hn::Add(iota, hn::Set(di, i0 + start + h * N))), vdx);
      zl[h] = vz;
    }
    if constexpr (kWarp) {
      const NoiseOctave &w0 = a.warp_octaves[0], &w1 = a.warp_octaves[1];
      VD u1[kHalves], v1[kHalves], u0[kHalves], v0[kHalves], n1d[kHalves], n0d[kHalves];
      lat(x, w1.freq_x, w1.offset_x, u1);
      lat(zl, w1.freq_z, w1.offset_z, v1);
      lat(x, w0.freq_x, w0.offset_x, u0);
      lat(zl, w0.freq_z, w0.offset_z, v0);
      SplitPromote(SimplexCellLanes(w1.key32, u1, v1, vscale), n1d);
      SplitPromote(SimplexCellLanes(w0.key32, u0, v0, vscale), n0d);
      for (int h = 0; h < kHalves; ++h) {
        zl[h] = hn::Add(vz, hn::Mul(wm, n1d[h]));
        x[h] = hn::Add(x[h], hn::Mul(wm, n0d[h]));
      }
    }
    VF acc = hn::Zero(df);
    for (int k = 0; k < a.count; ++k) {
      const NoiseOctave& o = a.octaves[k];
      VD u[kHalves];
      lat(x, o.freq_x, o.offset_x, u);
      VF nk;
      if constexpr (kWarp) {
        VD v[kHalves];
        lat(zl, o.freq_z, o.offset_z, v);
        nk = SimplexCellLanes(o.key32, u, v, hn::Set(df, cs[k]));
      } else {
        nk = SimplexCellFixedRow(rows[k], SimplexCol(u), hn::Set(df, cs[k]));
      }
      acc = FoldF<kFr>(acc, hn::Set(df, amp[k]), nk);
    }
    StoreGradient<kFr>(acc, inv, start, NF, n, out);
  }
}

// ---- Cellular (Worley, 3×3 search; float after the lattice split) -----------------------------------

// noise.cpp's cellular_cell on 2·Lanes(double) samples: the lattice split of GAxis (x per sample; z
// per row when hoisted), Gradient's 32-bit labels, the pre-hash X′·Pₓ + (Z′·P_z ⊕ key32), cell_mix32,
// the feature points and the fold in float, the same operations in the same order.
struct CellRowV {
  VU32 zp[3];  // Z′·P_z ⊕ key32 of lattice rows Z − 1, Z, Z + 1 (wrapped)
  VF fy;
};
// The previous label: i − 1 modulo 2³², or modulo the period (noise.cpp, cprev).
template <bool kPeriodic>
HWY_INLINE VU32 PrevLabel(VU32 i, std::int64_t period) {
  const DU32 du32;
  const VU32 p = hn::Sub(i, hn::Set(du32, 1u));
  if constexpr (!kPeriodic) return p;
  return hn::IfThenElse(hn::Eq(i, hn::Zero(du32)), hn::Set(du32, std::uint32_t(period - 1)), p);
}
template <bool kPZ>
HWY_INLINE CellRowV CellMakeRowV(const NoiseOctave& o, const VD (&v)[kHalves]) {
  const DU32 du32;
  const GAxisV az = GAxis<kPZ>(v, o.period_z, o.inv_period_z);
  const VU32 pz = hn::Set(du32, kGradPz), key = hn::Set(du32, o.key32);
  CellRowV r;
  r.zp[0] = hn::Xor(hn::Mul(PrevLabel<kPZ>(az.i0, o.period_z), pz), key);
  r.zp[1] = hn::Xor(hn::Mul(az.i0, pz), key);
  r.zp[2] = hn::Xor(hn::Mul(az.i1, pz), key);
  r.fy = az.f;
  return r;
}
HWY_INLINE CellRowV CellRowHoisted(const NoiseOctave& o, VD v) {
  VD vv[kHalves];
  for (int h = 0; h < kHalves; ++h) vv[h] = v;
  return o.period_z ? CellMakeRowV<true>(o, vv) : CellMakeRowV<false>(o, vv);
}
HWY_INLINE VU32 CellMix32(VU32 t) {
  const DU32 du32;
  t = hn::Mul(t, hn::Set(du32, kGradM));
  t = hn::Xor(t, hn::ShiftRight<16>(t));
  t = hn::Mul(t, hn::Set(du32, kCellM));
  return hn::Xor(t, hn::ShiftRight<15>(t));
}
template <int kRet, bool kPX>
HWY_INLINE VF CellEval(const NoiseOctave& o, const CellRowV& r, const VD (&u)[kHalves], VF J) {
  const DF df;
  const DU32 du32;
  const DI32 di32;
  const GAxisV ax = GAxis<kPX>(u, o.period_x, o.inv_period_x);
  const VU32 px = hn::Set(du32, kGradPx);
  const VU32 xp[3] = {hn::Mul(PrevLabel<kPX>(ax.i0, o.period_x), px), hn::Mul(ax.i0, px), hn::Mul(ax.i1, px)};
  const VF fx = ax.f;
  const VF inf = hn::Set(df, HUGE_VALF), half = hn::Set(df, 0.5f), k16 = hn::Set(df, kCell2m16);
  const VU32 lo16 = hn::Set(du32, 0xFFFFu);
  VF d1 = inf, d2 = inf;
  VU32 s1 = hn::Zero(du32);
  auto visit = [&](int a, int b) {
    const VU32 s = hn::Add(xp[a], r.zp[b]);  // noise.cpp's pre-hash (a sum, modulo 2³²)
    const VU32 h = CellMix32(s);
    const VF hx = hn::ConvertTo(df, hn::BitCast(di32, hn::ShiftRight<16>(h)));
    const VF hy = hn::ConvertTo(df, hn::BitCast(di32, hn::And(h, lo16)));
    const VF ppx = hn::Add(hn::Set(df, float(a - 1) + 0.5f), hn::Mul(J, hn::Sub(hn::Mul(hx, k16), half)));
    const VF ppy = hn::Add(hn::Set(df, float(b - 1) + 0.5f), hn::Mul(J, hn::Sub(hn::Mul(hy, k16), half)));
    const VF ddx = hn::Sub(ppx, fx), ddy = hn::Sub(ppy, r.fy);
    const VF dist = hn::Add(hn::Mul(ddx, ddx), hn::Mul(ddy, ddy));
    // The reference's if (d < d1) … else if (d < d2) … by selects (NaN leaves both).
    const auto m1 = hn::Lt(dist, d1);
    const auto m2 = hn::AndNot(m1, hn::Lt(dist, d2));
    d2 = hn::IfThenElse(m1, d1, hn::IfThenElse(m2, dist, d2));
    d1 = hn::IfThenElse(m1, dist, d1);
    if constexpr (kRet == int(CellularReturn::CellValue)) s1 = hn::IfThenElse(hn::RebindMask(du32, m1), s, s1);
  };
  if constexpr (kRet != int(CellularReturn::F1)) {
    // CellValue's owner depends on the visiting order when distances tie, so the reference's order;
    // F2 and F2 − F1 visit all nine.
    for (int b = 0; b < 3; ++b)
      for (int a = 0; a < 3; ++a) visit(a, b);
  } else {
    // F1 is the smallest of the nine distances whatever the order: the own cell first, then a
    // neighbour only when, in some lane, one of its points can come closer than d1. Points of
    // column offset a − 1 lie within [a − ½ − J/2, a − ½ + J/2] (likewise rows), so their gap is
    // at least g below; the bound is shrunk by 2⁻¹⁸ (relative and absolute), far more than the
    // float rounding of the offsets, the gap and dist (a few 2⁻²⁴).
    const VF hj = hn::Mul(J, half), zero = hn::Zero(df);
    auto pos = [&](VF v) { return hn::IfThenElse(hn::Gt(v, zero), v, zero); };
    const VF c15 = hn::Sub(hn::Set(df, 1.5f), hj), c05 = hn::Sub(half, hj);
    const VF gx[3] = {pos(hn::Add(fx, c05)), zero, pos(hn::Sub(c15, fx))};
    const VF gy[3] = {pos(hn::Add(r.fy, c05)), zero, pos(hn::Sub(c15, r.fy))};
    const VF shrink = hn::Set(df, 1.0f - 0x1p-18f), eps = hn::Set(df, 0x1p-18f);
    auto maybe = [&](int a, int b) {
      const VF lb = hn::Sub(hn::Mul(hn::Add(hn::Mul(gx[a], gx[a]), hn::Mul(gy[b], gy[b])), shrink), eps);
      if (hn::AllTrue(df, hn::Ge(lb, d1))) return;
      visit(a, b);
    };
    visit(1, 1);
    maybe(0, 1);
    maybe(2, 1);
    maybe(1, 0);
    maybe(1, 2);
    maybe(0, 0);
    maybe(2, 0);
    maybe(0, 2);
    maybe(2, 2);
  }
  const VF one = hn::Set(df, 1.0f), two = hn::Set(df, 2.0f);
  auto min1 = [&](VF v) { return hn::IfThenElse(hn::Lt(one, v), one, v); };  // std::min(v, 1.0f)
  if constexpr (kRet == int(CellularReturn::F1)) {
    return hn::Sub(hn::Mul(two, min1(hn::Sqrt(d1))), one);
  } else if constexpr (kRet == int(CellularReturn::F2)) {
    return hn::Sub(hn::Mul(two, min1(hn::Mul(hn::Sqrt(d2), hn::Set(df, kCellF2Scale)))), one);
  } else if constexpr (kRet == int(CellularReturn::F2MinusF1)) {
    return hn::Sub(hn::Mul(two, min1(hn::Sub(hn::Sqrt(d2), hn::Sqrt(d1)))), one);
  } else {
    const VU32 c = CellMix32(hn::Xor(s1, hn::Set(du32, kCellCvKey)));
    return hn::Mul(hn::ConvertTo(df, hn::ShiftRight<8>(hn::BitCast(di32, c))), hn::Set(df, kValueScale));
  }
}

// Fractal::None is evaluated as fBm of one octave (amplitude 1, 1/Σa = 1: the same bits). Ridged:
// the octave's value s·n (s = ridge_scale) folded by FoldF as (s − |s·n|)².
template <int kRet, int kFr, bool kWarp, bool kPX, bool kPZ>
HWY_NOINLINE void RowCellular(const NoiseKernelArgs& a, double z, std::int64_t i0, double dx, int n, float* out) {
  const DD d;
  const DI di;
  const DF df;
  const int N = int(hn::Lanes(d)), NF = kHalves * N;
  constexpr bool kR = kFr == kRidged;
  float amp[kMaxOctaves];
  CellRowV rows[kWarp ? 1 : kMaxOctaves];
  CellRowV wrows[2];
  const VD vz = hn::Set(d, z);
  auto lattice_v = [&](const NoiseOctave& o, VD zz) {
    return hn::Add(hn::Mul(zz, hn::Set(d, o.freq_z)), hn::Set(d, o.offset_z));
  };
  for (int k = 0; k < a.count; ++k) {
    const NoiseOctave& o = a.octaves[k];
    amp[k] = kR ? o.ridge_scale : float(o.amp);
    if constexpr (!kWarp) rows[k] = CellRowHoisted(o, lattice_v(o, vz));
  }
  if constexpr (kWarp)
    for (int w = 0; w < 2; ++w) wrows[w] = CellRowHoisted(a.warp_octaves[w], lattice_v(a.warp_octaves[w], vz));
  const VD vdx = hn::Set(d, dx), wm = hn::Set(d, a.warp_m);
  const VF inv = hn::Set(df, float(a.inv_amp_sum)), J = hn::Set(df, float(a.jitter));
  const VI iota = hn::Iota(di, 0);
  auto lat = [&](const VD (&p)[kHalves], double f, double off, VD (&o_)[kHalves]) {
    for (int h = 0; h < kHalves; ++h) o_[h] = hn::Add(hn::Mul(p[h], hn::Set(d, f)), hn::Set(d, off));
  };
  for (int start = 0; start < n; start += NF) {
    VD x[kHalves], zl[kHalves];
    for (int h = 0; h < kHalves; ++h) {
      x[h] = hn::Mul(hn::ConvertTo(d, hn::Add(iota, hn::Set(di, i0 + start + h * N))), vdx);
      zl[h] = vz;
    }
    if constexpr (kWarp) {
      const NoiseOctave &w0 = a.warp_octaves[0], &w1 = a.warp_octaves[1];
      VD u1[kHalves], u0[kHalves], n1d[kHalves], n0d[kHalves];
      lat(x, w1.freq_x, w1.offset_x, u1);
      lat(x, w0.freq_x, w0.offset_x, u0);
      SplitPromote(CellEval<kRet, kPX>(w1, wrows[1], u1, J), n1d);
      SplitPromote(CellEval<kRet, kPX>(w0, wrows[0], u0, J), n0d);
      for (int h = 0; h < kHalves; ++h) {
        zl[h] = hn::Add(vz, hn::Mul(wm, n1d[h]));
        x[h] = hn::Add(x[h], hn::Mul(wm, n0d[h]));
      }
    }
    VF acc = hn::Zero(df);
    for (int k = 0; k < a.count; ++k) {
      const NoiseOctave& o = a.octaves[k];
      VD u[kHalves];
      lat(x, o.freq_x, o.offset_x, u);
      VF nk;
      if constexpr (kWarp) {
        VD v[kHalves];
        lat(zl, o.freq_z, o.offset_z, v);
        nk = CellEval<kRet, kPX>(o, CellMakeRowV<kPZ>(o, v), u, J);
      } else {
        nk = CellEval<kRet, kPX>(o, rows[k], u, J);
      }
      const VF ak = hn::Set(df, amp[k]);
      if constexpr (kR) nk = hn::Mul(ak, nk);
      acc = FoldF<kFr>(acc, ak, nk);
    }
    StoreGradient<kFr>(acc, inv, start, NF, n, out);
  }
}

// ---- Gradient from per-column terms (Noise::columns / rows: no warp) -------------------------------

// Fills the x-only terms, the values GradEvalAxis derives from each octave's x axis (GAxis, or
// DyStart / DyStep on the dyadic lattice), computed by exactly the same operations.
template <bool kPX>
HWY_NOINLINE void ColumnsGradient(const NoiseKernelArgs& a, std::int64_t i0, double dx, int npad,
                                  std::uint32_t* cols, int stride) {
  const DD d;
  const DI di;
  const DF df;
  const DU32 du32;
  const int N = int(hn::Lanes(d)), NF = kHalves * N;
  const VD vdx = hn::Set(d, dx);
  const VI iota = hn::Iota(di, 0);
  const VU32 px = hn::Set(du32, kGradPx);
  const std::size_t S = std::size_t(stride);
  // Ridged: fx and fx − 1 scaled as GradEvalAxis<·, true> scales them (ridged_scale).
  const bool ridged = a.fractal == Fractal::Ridged;
  float sc[kMaxOctaves];
  for (int k = 0; k < a.count; ++k) sc[k] = a.octaves[k].ridge_scale;
  auto put = [&](int k, int start, const GAxisV& ax, bool periodic_x) {
    std::uint32_t* c = cols + std::size_t(k) * kColumnArrays * S + std::size_t(start);
    const VU32 xp0 = hn::Mul(ax.i0, px);
    const VU32 xp1 = periodic_x ? hn::Mul(ax.i1, px) : hn::Add(xp0, px);
    const VF s = hn::Set(df, sc[k]);
    const VF fx = ridged ? hn::Mul(s, ax.f) : ax.f;
    const VF fx1 = ridged ? hn::Sub(fx, s) : hn::Sub(ax.f, hn::Set(df, 1.0f));
    hn::Store(xp0, du32, c);
    hn::Store(xp1, du32, c + S);
    hn::Store(hn::BitCast(du32, fx), du32, c + 2 * S);
    hn::Store(hn::BitCast(du32, fx1), du32, c + 3 * S);
    hn::Store(hn::BitCast(du32, Fade(ax.f)), du32, c + 4 * S);
  };
  for (int start = 0; start < npad; start += NF) {
    VD x[kHalves];
    for (int h = 0; h < kHalves; ++h)
      x[h] = hn::Mul(hn::ConvertTo(d, hn::Add(iota, hn::Set(di, i0 + start + h * N))), vdx);
    auto lattice = [&](const NoiseOctave& o, VD (&u)[kHalves]) {
      for (int h = 0; h < kHalves; ++h) u[h] = hn::Add(hn::Mul(x[h], hn::Set(d, o.freq_x)), hn::Set(d, o.offset_x));
    };
    if (a.dyadic) {
      VD u[kHalves];
      lattice(a.octaves[0], u);
      DyState sx;
      put(0, start, DyStart(u, sx), false);
      for (int k = 1; k < a.count; ++k) put(k, start, DyStep(sx), false);
    } else {
      for (int k = 0; k < a.count; ++k) {
        const NoiseOctave& o = a.octaves[k];
        VD u[kHalves];
        lattice(o, u);
        put(k, start, GAxis<kPX>(u, o.period_x, o.inv_period_x), kPX);
      }
    }
  }
}

// The octave sum of the columns kernels (RowGradientColumns, RowSimplexColumns): octave(k, start) is
// octave k's vector at sample `start`, folded with amplitude amp[k], normalised and stored by
// StoreGradient. kU vectors per pass over the octaves: kU independent dependency chains in flight (an
// octave's lerps and fold are a long chain; gradient 6-octave fBm on 4096²: 28.5 → 26.3 ms on one
// thread). The columns are padded to a multiple of 16 samples, so every vector that starts below n
// loads whole. One octave (kNone) takes one pass: the reference's 0 + 1·n is n + 0 (−0 becomes +0),
// its ·(1/Σa) = ·1 is skipped (StoreGradient<kNone>).
template <int kFr, class Octave>
HWY_INLINE void ColumnsOctaveSum(const Octave& octave, int count, const float* amp, VF inv, int NF, int n,
                                 float* HWY_RESTRICT out) {
  const DF df;
  constexpr int kU = 2;
  const int end = (n + NF - 1) / NF * NF;
  int start = 0;
  if constexpr (kFr != kNone) {
    for (; start + kU * NF <= end; start += kU * NF) {
      VF acc[kU];
      for (int u = 0; u < kU; ++u) acc[u] = hn::Zero(df);
      for (int k = 0; k < count; ++k) {
        const VF ak = hn::Set(df, amp[k]);
        for (int u = 0; u < kU; ++u) acc[u] = FoldF<kFr>(acc[u], ak, octave(k, start + u * NF));
      }
      for (int u = 0; u < kU; ++u) StoreGradient<kFr>(acc[u], inv, start + u * NF, NF, n, out);
    }
  }
  for (; start < n; start += NF) {
    VF acc;
    if constexpr (kFr == kNone) {
      acc = hn::Add(octave(0, start), hn::Zero(df));
    } else {
      acc = hn::Zero(df);
      for (int k = 0; k < count; ++k) acc = FoldF<kFr>(acc, hn::Set(df, amp[k]), octave(k, start));
    }
    StoreGradient<kFr>(acc, inv, start, NF, n, out);
  }
}

// RowGradient without warp, its per-sample x work replaced by loads of the columns' terms.
template <int kFr, bool kVal>
HWY_NOINLINE void RowGradientColumns(const NoiseKernelArgs& a, double z, const std::uint32_t* cols, int stride, int n,
                                     float* out) {
  const DD d;
  const DF df;
  const DU32 du32;
  const int NF = kHalves * int(hn::Lanes(d));
  const std::size_t S = std::size_t(stride);
  constexpr bool kSc = kFr == kRidged;  // √amplitude in the corner offsets (ridged_scale)
  float amp[kMaxOctaves];
  for (int k = 0; k < a.count; ++k) amp[k] = kSc ? a.octaves[k].ridge_scale : float(a.octaves[k].amp);
  auto scaled = [&](const GradRow& g, int k) { return kSc && !kVal ? ScaleRow(g, hn::Set(df, amp[k])) : g; };
  float vc[kMaxOctaves];  // Value: the octave's scale (value_axis in noise.cpp)
  for (int k = 0; k < a.count; ++k) vc[k] = kSc ? amp[k] * kValueScale : kValueScale;
  GradRow rows[kMaxOctaves];
  const VD vz = hn::Set(d, z);
  auto lattice_v = [&](const NoiseOctave& o) {
    return hn::Add(hn::Mul(vz, hn::Set(d, o.freq_z)), hn::Set(d, o.offset_z));
  };
  if (kFr != kNone && a.dyadic) {
    VD v[kHalves];
    for (int h = 0; h < kHalves; ++h) v[h] = lattice_v(a.octaves[0]);
    DyState sz;
    rows[0] = scaled(GradRowFromAxis(a.octaves[0], DyStart(v, sz)), 0);
    for (int k = 1; k < a.count; ++k) rows[k] = scaled(GradRowFromAxis(a.octaves[k], DyStep(sz)), k);
  } else {
    for (int k = 0; k < a.count; ++k) rows[k] = scaled(GradRowHoisted(a.octaves[k], lattice_v(a.octaves[k])), k);
  }
  const VF inv = hn::Set(df, float(a.inv_amp_sum));
  auto octave = [&](int k, int start) {
    const std::uint32_t* c = cols + std::size_t(k) * kColumnArrays * S + std::size_t(start);
    const GradRow& r = rows[k];
    const VU32 xp0 = hn::Load(du32, c), xp1 = hn::Load(du32, c + S);
    const VF fx = hn::BitCast(df, hn::Load(du32, c + 2 * S)), fx1 = hn::BitCast(df, hn::Load(du32, c + 3 * S));
    const VF sx = hn::BitCast(df, hn::Load(du32, c + 4 * S));
    if constexpr (kVal) {
      (void)fx;
      (void)fx1;
      const VF v00 = ValCorner(xp0, r.zp0), v10 = ValCorner(xp1, r.zp0);
      const VF v01 = ValCorner(xp0, r.zp1), v11 = ValCorner(xp1, r.zp1);
      return hn::Mul(Lerp(r.sy, Lerp(sx, v00, v10), Lerp(sx, v01, v11)), hn::Set(df, vc[k]));
    }
    const VF g00 = GradCorner(xp0, r.zp0, fx, r.fy);
    const VF g10 = GradCorner(xp1, r.zp0, fx1, r.fy);
    const VF g01 = GradCorner(xp0, r.zp1, fx, r.fy1);
    const VF g11 = GradCorner(xp1, r.zp1, fx1, r.fy1);
    return Lerp(r.sy, Lerp(sx, g00, g10), Lerp(sx, g01, g11));
  };
  ColumnsOctaveSum<kFr>(octave, a.count, amp, inv, NF, n, out);
}

// ---- Simplex from per-column terms (Noise::columns / rows: no warp) ---------------------------------

// Per octave: simplex_col's xpE, dE, xpO, dO (noise_simd.hpp, kColumnArrays), the same operations
// as SimplexCol.
HWY_NOINLINE void ColumnsSimplex(const NoiseKernelArgs& a, std::int64_t i0, double dx, int npad, std::uint32_t* cols,
                                 int stride) {
  const DD d;
  const DI di;
  const DF df;
  const DU32 du32;
  const int N = int(hn::Lanes(d)), NF = kHalves * N;
  const VD vdx = hn::Set(d, dx);
  const VI iota = hn::Iota(di, 0);
  const std::size_t S = std::size_t(stride);
  for (int start = 0; start < npad; start += NF) {
    VD x[kHalves];
    for (int h = 0; h < kHalves; ++h)
      x[h] = hn::Mul(hn::ConvertTo(d, hn::Add(iota, hn::Set(di, i0 + start + h * N))), vdx);
    for (int k = 0; k < a.count; ++k) {
      const NoiseOctave& o = a.octaves[k];
      VD u[kHalves];
      for (int h = 0; h < kHalves; ++h) u[h] = hn::Add(hn::Mul(x[h], hn::Set(d, o.freq_x)), hn::Set(d, o.offset_x));
      const SimplexColV c = SimplexCol(u);
      std::uint32_t* p = cols + std::size_t(k) * kColumnArrays * S + std::size_t(start);
      hn::Store(c.xpE, du32, p);
      hn::Store(hn::BitCast(du32, c.dE), du32, p + S);
      hn::Store(c.xpO, du32, p + 2 * S);
      hn::Store(hn::BitCast(du32, c.dO), du32, p + 3 * S);
      (void)df;
    }
  }
}

// RowSimplex without warp, its per-sample x work replaced by loads of the columns' terms: per
// octave, the lower lattice row's left vertices are the even (J even) or odd arrays, the upper
// row's the others.
template <int kFr>
HWY_NOINLINE void RowSimplexColumns(const NoiseKernelArgs& a, double z, const std::uint32_t* cols, int stride, int n,
                                    float* out) {
  const DD d;
  const DF df;
  const DU32 du32;
  const int NF = kHalves * int(hn::Lanes(d));
  const std::size_t S = std::size_t(stride);
  constexpr bool kR = kFr == kRidged;
  const float scale = float(kSimplexScale);
  float amp[kMaxOctaves], cs[kMaxOctaves];
  SimplexRowV rows[kMaxOctaves];
  const std::uint32_t* lo[kMaxOctaves];
  const std::uint32_t* up[kMaxOctaves];
  for (int k = 0; k < a.count; ++k) {
    const NoiseOctave& o = a.octaves[k];
    amp[k] = kR ? o.ridge_scale : float(o.amp);
    cs[k] = kR ? scale * o.ridge_scale : scale;
    SimplexMakeRow(o.key32, z * o.freq_z + o.offset_z, rows[k]);
    const std::uint32_t* c = cols + std::size_t(k) * kColumnArrays * S;
    lo[k] = rows[k].odd ? c + 2 * S : c;
    up[k] = rows[k].odd ? c : c + 2 * S;
  }
  const VF inv = hn::Set(df, float(a.inv_amp_sum));
  auto octave = [&](int k, int start) {
    const std::uint32_t* l = lo[k] + start;
    const std::uint32_t* u = up[k] + start;
    return SimplexCellRow(rows[k], hn::Load(du32, l), hn::BitCast(df, hn::Load(du32, l + S)), hn::Load(du32, u),
                          hn::BitCast(df, hn::Load(du32, u + S)), hn::Set(df, cs[k]));
  };
  ColumnsOctaveSum<kFr>(octave, a.count, amp, inv, NF, n, out);
}

// ---- dispatch on parameters, once per row ---------------------------------------------------------

using Fn = void (*)(const NoiseKernelArgs&, double, std::int64_t, double, int, float*);

template <template <bool, bool> class BT, int kFr>
Fn PickPeriodic(bool warp, bool px, bool pz) {
  if (!warp) return px ? &RowDouble<BT<true, false>, kFr, false> : &RowDouble<BT<false, false>, kFr, false>;
  if (px) return pz ? &RowDouble<BT<true, true>, kFr, true> : &RowDouble<BT<true, false>, kFr, true>;
  return pz ? &RowDouble<BT<false, true>, kFr, true> : &RowDouble<BT<false, false>, kFr, true>;
}
template <template <bool, bool> class BT>
Fn PickDouble(int fr, bool warp, bool px, bool pz) {
  switch (fr) {
    case kRidged: return PickPeriodic<BT, kRidged>(warp, px, pz);
    case kBillow: return PickPeriodic<BT, kBillow>(warp, px, pz);
    default: return PickPeriodic<BT, kFbm>(warp, px, pz);
  }
}
template <int kRet, int kFr>
Fn PickCellularP(bool warp, bool px, bool pz) {
  if (!warp) return px ? &RowCellular<kRet, kFr, false, true, false> : &RowCellular<kRet, kFr, false, false, false>;
  if (px) return pz ? &RowCellular<kRet, kFr, true, true, true> : &RowCellular<kRet, kFr, true, true, false>;
  return pz ? &RowCellular<kRet, kFr, true, false, true> : &RowCellular<kRet, kFr, true, false, false>;
}
template <int kRet>
Fn PickCellular(int fr, bool warp, bool px, bool pz) {
  switch (fr) {
    case kRidged: return PickCellularP<kRet, kRidged>(warp, px, pz);
    case kBillow: return PickCellularP<kRet, kBillow>(warp, px, pz);
    default: return PickCellularP<kRet, kFbm>(warp, px, pz);
  }
}
template <int kFr>
Fn PickSimplex(bool warp) {
  return warp ? &RowSimplex<kFr, true> : &RowSimplex<kFr, false>;
}template <int kFr, bool kV>
Fn PickGradient(bool warp, bool px, bool pz, bool dyadic) {
  if constexpr (kFr != kNone)  // one octave has nothing to step
    if (dyadic)
      return warp ? &RowGradient<kFr, true, false, false, true, kV> : &RowGradient<kFr, false, false, false, true, kV>;
  if (!warp) return px ? &RowGradient<kFr, false, true, false, false, kV> : &RowGradient<kFr, false, false, false, false, kV>;
  if (px) return pz ? &RowGradient<kFr, true, true, true, false, kV> : &RowGradient<kFr, true, true, false, false, kV>;
  return pz ? &RowGradient<kFr, true, false, true, false, kV> : &RowGradient<kFr, true, false, false, false, kV>;
}
template <bool kV>
Fn PickGradientFractal(const NoiseKernelArgs& a, int fr, bool px, bool pz) {
  return a.fractal == Fractal::None ? PickGradient<kNone, kV>(a.warp, px, pz, false)
         : fr == kRidged            ? PickGradient<kRidged, kV>(a.warp, px, pz, a.dyadic)
         : fr == kBillow            ? PickGradient<kBillow, kV>(a.warp, px, pz, a.dyadic)
                                    : PickGradient<kFbm, kV>(a.warp, px, pz, a.dyadic);
}

}  // namespace

void ColumnTerms(const NoiseKernelArgs& a, std::int64_t i0, double dx, int npad, std::uint32_t* cols, int stride) {
  if (a.basis == NoiseBasis::Simplex) {
    ColumnsSimplex(a, i0, dx, npad, cols, stride);
    return;
  }
  const bool px = a.periodic && a.octaves[0].period_x != 0;
  if (px)
    ColumnsGradient<true>(a, i0, dx, npad, cols, stride);
  else
    ColumnsGradient<false>(a, i0, dx, npad, cols, stride);
}

template <bool kV>
void RowFromColumnsB(const NoiseKernelArgs& a, double z, const std::uint32_t* cols, int stride, int n, float* out) {
  switch (a.fractal) {
    case Fractal::None: RowGradientColumns<kNone, kV>(a, z, cols, stride, n, out); break;
    case Fractal::Ridged: RowGradientColumns<kRidged, kV>(a, z, cols, stride, n, out); break;
    case Fractal::Billow: RowGradientColumns<kBillow, kV>(a, z, cols, stride, n, out); break;
    default: RowGradientColumns<kFbm, kV>(a, z, cols, stride, n, out); break;
  }
}

void RowFromColumns(const NoiseKernelArgs& a, double z, const std::uint32_t* cols, int stride, int n, float* out) {
  if (a.basis == NoiseBasis::Simplex) {
    if (a.fractal == Fractal::None) RowSimplexColumns<kNone>(a, z, cols, stride, n, out);
    else if (a.fractal == Fractal::Ridged) RowSimplexColumns<kRidged>(a, z, cols, stride, n, out);
    else if (a.fractal == Fractal::Billow) RowSimplexColumns<kBillow>(a, z, cols, stride, n, out);
    else RowSimplexColumns<kFbm>(a, z, cols, stride, n, out);
    return;
  }
  if (a.basis == NoiseBasis::Value)
    RowFromColumnsB<true>(a, z, cols, stride, n, out);
  else
    RowFromColumnsB<false>(a, z, cols, stride, n, out);
}

void NoiseRow(const NoiseKernelArgs& a, double z, std::int64_t i0, double dx, int n, float* out) {
  const int fr = a.fractal == Fractal::Ridged ? kRidged : a.fractal == Fractal::Billow ? kBillow : kFbm;
  const NoiseOctave& o0 = a.warp ? a.warp_octaves[0] : a.octaves[0];
  const bool px = a.periodic && o0.period_x != 0, pz = a.periodic && o0.period_z != 0;
  Fn fn = nullptr;
  switch (a.basis) {
    case NoiseBasis::Perlin: fn = PickDouble<Perlin>(fr, a.warp, px, pz); break;
    case NoiseBasis::Value: fn = PickGradientFractal<true>(a, fr, px, pz); break;
    case NoiseBasis::Simplex:
      fn = fr == kRidged ? PickSimplex<kRidged>(a.warp) : fr == kBillow ? PickSimplex<kBillow>(a.warp) : PickSimplex<kFbm>(a.warp);
      break;
    case NoiseBasis::Cellular:
      switch (a.cellular) {
        case CellularReturn::F1: fn = PickCellular<0>(fr, a.warp, px, pz); break;
        case CellularReturn::F2: fn = PickCellular<1>(fr, a.warp, px, pz); break;
        case CellularReturn::F2MinusF1: fn = PickCellular<2>(fr, a.warp, px, pz); break;
        case CellularReturn::CellValue: fn = PickCellular<3>(fr, a.warp, px, pz); break;
      }
      break;
    case NoiseBasis::Gradient: fn = PickGradientFractal<false>(a, fr, px, pz); break;
  }
  fn(a, z, i0, dx, n, out);
}

}  // namespace HWY_NAMESPACE
}  // namespace relief::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace relief::detail {

HWY_EXPORT(NoiseRow);
HWY_EXPORT(ColumnTerms);
HWY_EXPORT(RowFromColumns);

void noise_columns_simd(const NoiseKernelArgs& a, std::int64_t i0, double dx, int npad, std::uint32_t* cols,
                        int stride) {
  HWY_DYNAMIC_DISPATCH(ColumnTerms)(a, i0, dx, npad, cols, stride);
}

void noise_row_columns_simd(const NoiseKernelArgs& a, double z_m, const std::uint32_t* cols, int stride, int n,
                            float* out) {
  HWY_DYNAMIC_DISPATCH(RowFromColumns)(a, z_m, cols, stride, n, out);
}

void noise_row_simd(const NoiseKernelArgs& a, double z_m, std::int64_t i0, double dx, int n, float* out) {
  HWY_DYNAMIC_DISPATCH(NoiseRow)(a, z_m, i0, dx, n, out);
}

std::vector<SimdTarget> noise_simd_targets() {
  std::vector<SimdTarget> out;
  for (std::int64_t t : hwy::SupportedAndGeneratedTargets()) out.push_back({t, hwy::TargetName(t)});
  return out;
}

void noise_simd_force_target(std::int64_t bits) { hwy::SetSupportedTargetsForTest(bits); }

std::string noise_simd_current_target() {
  // The best target of the current (possibly forced) supported set that was compiled in.
  const std::vector<std::int64_t> t = hwy::SupportedAndGeneratedTargets();
  return t.empty() ? "none" : hwy::TargetName(t.front());
}

}  // namespace relief::detail
#endif  // HWY_ONCE
