// Highway row kernels for Noise3 (3D gradient and simplex noise), with run-time dispatch.
//
// Sources: the algorithms of noise3.cpp (Perlin 2002, Perlin 2001 / Gustavson 2005 simplex,
// Musgrave's fractals); Google Highway's foreach_target and HWY_DYNAMIC_DISPATCH; arithmetic
// lattice hashing as FastNoise2 does it.
//
// Structure. Noise3::row computes each octave's (y, z) terms once per row (noise3_row_terms, in
// scalar code: the same for every target); the kernels here walk the row a float vector at a time
// (two double vectors' worth: 8 samples on AVX2, 16 on AVX-512) through all octaves with the
// accumulator in a register.
//   Gradient  per sample and octave only the x split (in double) and the eight corners: hash
//             (xor, multiply, shift), G_x·d_x (one product per sample for the four corners on
//             each side: |G_x| is the same for all 16 gradients) plus the row's precomputed
//             G_y·d_y + G_z·d_z for that corner (an 8-entry table per (y, z) corner, looked up by
//             one in-register permute on AVX2 and AVX-512, a gather on SSE4 and the fallbacks),
//             the sign flipped by the hash's top bit (G[k + 8] = −G[k]), then seven lerps. (The
//             first version, 12 cube edges + 4 tetrahedral directions, needed a G_x permute and
//             two permutes and a blend for the row table: 2.8x the 2D cost here, this one about 2.)
//             Noise3::rows precomputes the x terms per strip of columns and reuses them per row.
//   Simplex   (body-centred cubic lattice in rows along x, noise3.hpp) per sample and octave the x
//             split in double (floor, fraction) and, in float, the second phase (the rows of
//             Z³ + ½); then eight vertices, two on each of the row's four lattice rows: hash, one
//             table lookup (the row's G_y·d_y + G_z·d_z), G_x·d_x, sign flip, the kernel from the
//             row's ½ − (d_y² + d_z²) minus d_x². Noise3::rows precomputes the x terms (for both
//             phases: X·Pₓ, G_x·d, G_x·(d − 1), d², (d − 1)²) per strip of columns, as Gradient does.
//
// Exactness: the same IEEE operations in the same order as the scalar reference, no FMA (the
// preamble turns contraction off), integer work exact; so every target gives the reference's
// bits (tests/test_noise3.cpp forces each one).
#include <cstdint>
#include <cstring>

#include "noise3_simd.hpp"
#include "noise_simd.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "noise3_simd.cpp"
#include "hwy_kernels.hpp"

HWY_BEFORE_NAMESPACE();
namespace relief::detail {
namespace HWY_NAMESPACE {
namespace {

namespace hn = hwy::HWY_NAMESPACE;

using DD = hn::ScalableTag<double>;
using DI = hn::RebindToSigned<DD>;
using DU = hn::RebindToUnsigned<DD>;
using DFh = hn::Rebind<float, DD>;
#if HWY_TARGET == HWY_SCALAR
constexpr int kHalves = 1;
using DF = DFh;
#else
constexpr int kHalves = 2;
using DF = hn::Twice<DFh>;
#endif
using DU32 = hn::RebindToUnsigned<DF>;
using DI32 = hn::RebindToSigned<DF>;
using VD = hn::Vec<DD>;
using VF = hn::Vec<DF>;
using VU32 = hn::Vec<DU32>;
using MF = hn::Mask<DF>;

// kNone: one octave of amplitude 1 with 1/Σa = 1: the reference's (0 + 1·n)·1 is n + 0 (−0 → +0).
enum { kFbm = 0, kRidged = 1, kBillow = 2, kNone = 3 };

// ---- shared helpers (as noise_simd.cpp's) -------------------------------------------------------

// Float vector from kHalves double vectors (lanes of u[0] first), rounded to nearest.
HWY_INLINE VF JoinDemote(const VD (&u)[kHalves]) {
#if HWY_TARGET == HWY_SCALAR
  return hn::DemoteTo(DF(), u[0]);
#else
  const DFh dfh;
  return hn::Combine(DF(), hn::DemoteTo(dfh, u[1]), hn::DemoteTo(dfh, u[0]));
#endif
}
// The low 32 bits of the int64 held by integer-valued doubles (|x| ≤ 2⁵¹), as noise3.cpp's low32.
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
HWY_INLINE VF Fade(VF t) {
  const DF df;
  const VF t3 = hn::Mul(hn::Mul(t, t), t);
  return hn::Mul(t3, hn::Add(hn::Mul(t, hn::Sub(hn::Mul(t, hn::Set(df, 6.0f)), hn::Set(df, 15.0f))), hn::Set(df, 10.0f)));
}
HWY_INLINE VF Lerp(VF t, VF a, VF b) { return hn::Add(a, hn::Mul(t, hn::Sub(b, a))); }

// Sample positions x = double(first + i)·dx, i in [0, kHalves·Lanes), as kHalves double vectors.
// small: every index of the row is below 2⁵² in magnitude; then double(first) + i is double(first + i)
// exactly and the int64 → double conversion (emulated on AVX2) is done once, not per vector.
HWY_INLINE void Positions(std::int64_t first, double dx, bool small, VD (&x)[kHalves]) {
  const DD d;
  const DI di;
  const int N = int(hn::Lanes(d));
  for (int h = 0; h < kHalves; ++h) {
    const VD idx = small ? hn::Add(hn::Set(d, double(first)), hn::Iota(d, double(h * N)))
                         : hn::ConvertTo(d, hn::Add(hn::Iota(di, 0), hn::Set(di, first + std::int64_t(h) * N)));
    x[h] = hn::Mul(idx, hn::Set(d, dx));
  }
}
HWY_INLINE bool SmallIndices(std::int64_t i0, int n) {
  constexpr std::int64_t kLimit = std::int64_t(1) << 52;
  return i0 > -kLimit && i0 < kLimit - std::int64_t(n) - 64;
}

// ---- gradient table lookups --------------------------------------------------------------------------

// table[k & 7] for k = h >> 28 (tables of 16 entries, 8..15 repeating 0..7).
HWY_INLINE VF Lookup8(const float* table, VU32 k) {
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
  return VF{_mm512_permutexvar_ps(k.raw, _mm512_loadu_ps(table))};
#elif HWY_ARCH_X86 && HWY_TARGET == HWY_AVX2
  return VF{_mm256_permutevar8x32_ps(_mm256_loadu_ps(table), k.raw)};  // reads k's low 3 bits
#else
  return hn::GatherIndex(DF(), table, hn::BitCast(DI32(), k));
#endif
}
// −v where k ≥ 8, i.e. where the hash h's sign bit is set: G[k + 8] = −G[k] (the reference's −v).
HWY_INLINE VF FlipByHash(VF v, VU32 h) {
  const DU32 du32;
  return hn::Xor(v, hn::BitCast(DF(), hn::And(h, hn::Set(du32, 0x80000000u))));
}

// ---- fractal folding and the end of a vector -------------------------------------------------------

template <int kFr>
HWY_INLINE VF Fold(VF acc, VF amp, VF n) {
  const DF df;
  if constexpr (kFr == kFbm) {
    return hn::Add(acc, hn::Mul(amp, n));
  } else if constexpr (kFr == kRidged) {
    const VF r = hn::Sub(hn::Set(df, 1.0f), hn::Abs(n));
    return hn::Add(acc, hn::Mul(amp, hn::Mul(r, r)));
  } else {
    return hn::Add(acc, hn::Mul(amp, hn::Sub(hn::Mul(hn::Set(df, 2.0f), hn::Abs(n)), hn::Set(df, 1.0f))));
  }
}
// Normalise (ridged: acc·(2·inv) − 1), clamp as the reference's v > −1 ? v : −1, v < 1 ? v : 1,
// store (a partial vector at the row's end).
template <int kFr>
HWY_INLINE void Finish(VF acc, float inv, int start, int NF, int n, float* HWY_RESTRICT out) {
  const DF df;
  const VF one = hn::Set(df, 1.0f), mone = hn::Set(df, -1.0f);
  VF v = kFr == kRidged ? hn::Sub(hn::Mul(acc, hn::Set(df, inv + inv)), one)
         : kFr == kNone ? acc
                        : hn::Mul(acc, hn::Set(df, inv));
  v = hn::IfThenElse(v > mone, v, mone);
  v = hn::IfThenElse(v < one, v, one);
  if (start + NF <= n) {
    hn::StoreU(v, df, out + start);
  } else {
    HWY_ALIGN float tmp[64];
    hn::Store(v, df, tmp);
    std::memcpy(out + start, tmp, std::size_t(n - start) * sizeof(float));
  }
}

// ---- Gradient ----------------------------------------------------------------------------------------

struct XTerms {
  VU32 xp0;          // X·Pₓ
  VF gx0, gx1, sx;   // G_x·fx, G_x·(fx − 1) (G_x = kG3Xc, the same for every gradient up to sign), fade(fx)
};
HWY_INLINE XTerms XSplit(const VD (&x)[kHalves], const Noise3Octave& o) {
  const DD d;
  const DF df;
  const DU32 du32;
  VD fl[kHalves], fr[kHalves];
  for (int h = 0; h < kHalves; ++h) {
    const VD u = hn::Add(hn::Mul(x[h], hn::Set(d, o.freq_x)), hn::Set(d, o.offset_x));
    fl[h] = hn::Floor(u);
    fr[h] = hn::Sub(u, fl[h]);
  }
  XTerms t;
  const VF fx = JoinDemote(fr), gx = hn::Set(df, kG3Xc);
  t.xp0 = hn::Mul(JoinLow32(fl), hn::Set(du32, kG3Px));
  t.gx0 = hn::Mul(gx, fx);
  t.gx1 = hn::Mul(gx, hn::Sub(fx, hn::Set(df, 1.0f)));
  t.sx = Fade(fx);
  return t;
}
HWY_INLINE XTerms XLoad(const std::uint32_t* c, std::size_t S) {
  const DF df;
  const DU32 du32;
  XTerms t;
  t.xp0 = hn::Load(du32, c);
  t.gx0 = hn::BitCast(df, hn::Load(du32, c + S));
  t.gx1 = hn::BitCast(df, hn::Load(du32, c + 2 * S));
  t.sx = hn::BitCast(df, hn::Load(du32, c + 3 * S));
  return t;
}

// G·d at a corner: ±(G_x·d_x + t[k & 7]), gxd = G_x·d_x (the same for every k), t the row's
// G_y·d_y + G_z·d_z for this (y, z) corner.
HWY_INLINE VF Corner(VU32 xp, VU32 yz, VF gxd, const float* t) {
  const DU32 du32;
  const VU32 h = hn::Mul(hn::Xor(xp, yz), hn::Set(du32, kG3M));
  return FlipByHash(hn::Add(gxd, Lookup8(t, hn::ShiftRight<28>(h))), h);
}
HWY_INLINE VF Gradient3(const XTerms& x, const Noise3Row& r) {
  const DF df;
  const DU32 du32;
  const VU32 xp1 = hn::Add(x.xp0, hn::Set(du32, kG3Px));
  VF l[4];
  for (int c = 0; c < 4; ++c) {
    const VU32 yz = hn::Set(du32, r.yz[c]);
    l[c] = Lerp(x.sx, Corner(x.xp0, yz, x.gx0, r.t[c]), Corner(xp1, yz, x.gx1, r.t[c]));
  }
  const VF sy = hn::Set(df, r.sy);
  return Lerp(hn::Set(df, r.sz), Lerp(sy, l[0], l[1]), Lerp(sy, l[2], l[3]));
}

// ---- Simplex -----------------------------------------------------------------------------------------

// One phase of the x split (noise3.cpp's S3Phase) with the terms the vertices need: the lower vertex's
// X·Pₓ; G_x·d, G_x·(d − 1); d², (d − 1)².
struct SPhase {
  VU32 xp;
  VF g0, g1, q0, q1;
};
HWY_INLINE SPhase SPhaseOf(VU32 xp, VF dd) {
  const DF df;
  const VF gx = hn::Set(df, kG3Xc), d1 = hn::Sub(dd, hn::Set(df, 1.0f));
  SPhase p;
  p.xp = xp;
  p.g0 = hn::Mul(gx, dd);
  p.g1 = hn::Mul(gx, d1);
  p.q0 = hn::Mul(dd, dd);
  p.q1 = hn::Mul(d1, d1);
  return p;
}
HWY_INLINE void SXSplit(const VD (&x)[kHalves], const Noise3Octave& o, SPhase (&p)[2]) {
  const DD d;
  const DF df;
  const DU32 du32;
  VD fl[kHalves], fr[kHalves];
  for (int h = 0; h < kHalves; ++h) {
    const VD u = hn::Add(hn::Mul(x[h], hn::Set(d, o.freq_x)), hn::Set(d, o.offset_x));
    fl[h] = hn::Floor(u);
    fr[h] = hn::Sub(u, fl[h]);
  }
  const VF f = JoinDemote(fr), half = hn::Set(df, 0.5f);
  const VU32 px = hn::Set(du32, kG3Px), xp = hn::Mul(JoinLow32(fl), px);
  const MF hi = f >= half;
  p[0] = SPhaseOf(xp, f);
  p[1] = SPhaseOf(hn::IfThenElse(hn::RebindMask(du32, hi), xp, hn::Sub(xp, px)),
                  hn::IfThenElse(hi, hn::Sub(f, half), hn::Add(f, half)));
}
HWY_INLINE void SLoad(const std::uint32_t* c, std::size_t S, SPhase (&p)[2]) {
  const DF df;
  const DU32 du32;
  for (int q = 0; q < 2; ++q) {
    const std::uint32_t* b = c + std::size_t(5 * q) * S;
    p[q].xp = hn::Load(du32, b);
    p[q].g0 = hn::BitCast(df, hn::Load(du32, b + S));
    p[q].g1 = hn::BitCast(df, hn::Load(du32, b + 2 * S));
    p[q].q0 = hn::BitCast(df, hn::Load(du32, b + 3 * S));
    p[q].q1 = hn::BitCast(df, hn::Load(du32, b + 4 * S));
  }
}
// One vertex: max(0, rc − d_x²)⁴·±(G_x·d_x + t[k & 7]) (noise3.cpp's s3_term).
HWY_INLINE VF STerm(VU32 xp, VU32 yz, VF gxd, VF sq, VF rc, const float* t) {
  const DF df;
  const DU32 du32;
  VF att = hn::Sub(rc, sq);
  att = hn::IfThenElseZero(att > hn::Zero(df), att);
  const VU32 h = hn::Mul(hn::Xor(xp, yz), hn::Set(du32, kG3M));
  const VF dot = FlipByHash(hn::Add(gxd, Lookup8(t, hn::ShiftRight<28>(h))), h);
  const VF a2 = hn::Mul(att, att);
  return hn::Mul(hn::Mul(a2, a2), dot);
}
HWY_INLINE VF Simplex3(const SPhase (&p)[2], const Noise3Row& r) {
  const DF df;
  const DU32 du32;
  const VU32 px = hn::Set(du32, kG3Px);
  VF tm[8];
  for (int s = 0; s < 4; ++s) {
    const SPhase& q = p[s >> 1];
    const VU32 yz = hn::Set(du32, r.yz[s]);
    const VF rc = hn::Set(df, r.rc[s]);
    tm[2 * s] = STerm(q.xp, yz, q.g0, q.q0, rc, r.t[s]);
    tm[2 * s + 1] = STerm(hn::Add(q.xp, px), yz, q.g1, q.q1, rc, r.t[s]);
  }
  const VF sum = hn::Add(hn::Add(hn::Add(tm[0], tm[1]), hn::Add(tm[2], tm[3])),
                         hn::Add(hn::Add(tm[4], tm[5]), hn::Add(tm[6], tm[7])));
  return hn::Mul(sum, hn::Set(df, kS3Scale));
}

// ---- rows ---------------------------------------------------------------------------------------------

// One octave's value at a vector of samples: x terms from the positions, or (kCols) from Noise3::rows'
// column arrays.
template <bool kSimplex, bool kCols>
HWY_INLINE VF Octave3(const VD (&x)[kHalves], const Noise3Octave& o, const Noise3Row& r, const std::uint32_t* c,
                      std::size_t S) {
  if constexpr (kSimplex) {
    SPhase p[2];
    if constexpr (kCols)
      SLoad(c, S, p);
    else
      SXSplit(x, o, p);
    return Simplex3(p, r);
  } else {
    XTerms xt;
    if constexpr (kCols)
      xt = XLoad(c, S);
    else
      xt = XSplit(x, o);
    return Gradient3(xt, r);
  }
}

template <bool kSimplex, int kFr, bool kCols>
HWY_NOINLINE void Row3(const Noise3Args& a, const Noise3Row* rows, std::int64_t i0, double dx, const std::uint32_t* cols,
                       int stride, int n, float* out) {
  const DD d;
  const DF df;
  const int NF = kHalves * int(hn::Lanes(d));
  const std::size_t S = std::size_t(stride);
  constexpr std::size_t kArrays = kSimplex ? kS3ColumnArrays : kG3ColumnArrays;
  const bool small = SmallIndices(i0, n);
  for (int start = 0; start < n; start += NF) {
    VD x[kHalves];
    if constexpr (!kCols) Positions(i0 + start, dx, small, x);
    VF acc = hn::Zero(df);
    for (int k = 0; k < a.count; ++k) {
      const std::uint32_t* c = kCols ? cols + std::size_t(k) * kArrays * S + std::size_t(start) : nullptr;
      const VF v = Octave3<kSimplex, kCols>(x, a.octaves[k], rows[k], c, S);
      if constexpr (kFr == kNone)
        acc = hn::Add(v, acc);
      else
        acc = Fold<kFr>(acc, hn::Set(df, a.octaves[k].amp), v);
    }
    Finish<kFr>(acc, a.inv, start, NF, n, out);
  }
}

HWY_NOINLINE void ColumnsGradient3(const Noise3Args& a, std::int64_t i0, double dx, int npad, std::uint32_t* cols,
                                   int stride) {
  const DD d;
  const DU32 du32;
  const int NF = kHalves * int(hn::Lanes(d));
  const std::size_t S = std::size_t(stride);
  const bool small = SmallIndices(i0, npad);
  for (int start = 0; start < npad; start += NF) {
    VD x[kHalves];
    Positions(i0 + start, dx, small, x);
    for (int k = 0; k < a.count; ++k) {
      const XTerms t = XSplit(x, a.octaves[k]);
      std::uint32_t* c = cols + std::size_t(k) * kG3ColumnArrays * S + std::size_t(start);
      hn::Store(t.xp0, du32, c);
      hn::Store(hn::BitCast(du32, t.gx0), du32, c + S);
      hn::Store(hn::BitCast(du32, t.gx1), du32, c + 2 * S);
      hn::Store(hn::BitCast(du32, t.sx), du32, c + 3 * S);
    }
  }
}

HWY_NOINLINE void ColumnsSimplex3(const Noise3Args& a, std::int64_t i0, double dx, int npad, std::uint32_t* cols,
                                  int stride) {
  const DD d;
  const DU32 du32;
  const int NF = kHalves * int(hn::Lanes(d));
  const std::size_t S = std::size_t(stride);
  const bool small = SmallIndices(i0, npad);
  for (int start = 0; start < npad; start += NF) {
    VD x[kHalves];
    Positions(i0 + start, dx, small, x);
    for (int k = 0; k < a.count; ++k) {
      SPhase p[2];
      SXSplit(x, a.octaves[k], p);
      for (int q = 0; q < 2; ++q) {
        std::uint32_t* c = cols + (std::size_t(k) * kS3ColumnArrays + std::size_t(5 * q)) * S + std::size_t(start);
        hn::Store(p[q].xp, du32, c);
        hn::Store(hn::BitCast(du32, p[q].g0), du32, c + S);
        hn::Store(hn::BitCast(du32, p[q].g1), du32, c + 2 * S);
        hn::Store(hn::BitCast(du32, p[q].q0), du32, c + 3 * S);
        hn::Store(hn::BitCast(du32, p[q].q1), du32, c + 4 * S);
      }
    }
  }
}

// Fractal::None has one octave (Noise3's constructor), amplitude 1 and 1/Σa = 1.
int FractalKind(Fractal f) {
  return f == Fractal::None ? kNone : f == Fractal::Ridged ? kRidged : f == Fractal::Billow ? kBillow : kFbm;
}

template <bool kSimplex, bool kCols>
void Row3For(const Noise3Args& a, const Noise3Row* rows, std::int64_t i0, double dx, const std::uint32_t* cols,
             int stride, int n, float* out) {
  const int fr = FractalKind(a.fractal);
  if (fr == kNone) Row3<kSimplex, kNone, kCols>(a, rows, i0, dx, cols, stride, n, out);
  else if (fr == kRidged) Row3<kSimplex, kRidged, kCols>(a, rows, i0, dx, cols, stride, n, out);
  else if (fr == kBillow) Row3<kSimplex, kBillow, kCols>(a, rows, i0, dx, cols, stride, n, out);
  else Row3<kSimplex, kFbm, kCols>(a, rows, i0, dx, cols, stride, n, out);
}

}  // namespace

void Row3Kernel(const Noise3Args& a, const Noise3Row* rows, std::int64_t i0, double dx, int n, float* out) {
  if (a.basis == NoiseBasis::Gradient)
    Row3For<false, false>(a, rows, i0, dx, nullptr, 0, n, out);
  else
    Row3For<true, false>(a, rows, i0, dx, nullptr, 0, n, out);
}

void Columns3Kernel(const Noise3Args& a, std::int64_t i0, double dx, int npad, std::uint32_t* cols, int stride) {
  if (a.basis == NoiseBasis::Gradient)
    ColumnsGradient3(a, i0, dx, npad, cols, stride);
  else
    ColumnsSimplex3(a, i0, dx, npad, cols, stride);
}

void RowColumns3Kernel(const Noise3Args& a, const Noise3Row* rows, const std::uint32_t* cols, int stride, int n,
                       float* out) {
  if (a.basis == NoiseBasis::Gradient)
    Row3For<false, true>(a, rows, 0, 0.0, cols, stride, n, out);
  else
    Row3For<true, true>(a, rows, 0, 0.0, cols, stride, n, out);
}

}  // namespace HWY_NAMESPACE
}  // namespace relief::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace relief::detail {

HWY_EXPORT(Row3Kernel);
HWY_EXPORT(Columns3Kernel);
HWY_EXPORT(RowColumns3Kernel);

void noise3_row_simd(const Noise3Args& a, const Noise3Row* rows, std::int64_t i0, double dx, int n, float* out) {
  HWY_DYNAMIC_DISPATCH(Row3Kernel)(a, rows, i0, dx, n, out);
}

void noise3_columns_simd(const Noise3Args& a, std::int64_t i0, double dx, int npad, std::uint32_t* cols, int stride) {
  HWY_DYNAMIC_DISPATCH(Columns3Kernel)(a, i0, dx, npad, cols, stride);
}

void noise3_row_columns_simd(const Noise3Args& a, const Noise3Row* rows, const std::uint32_t* cols, int stride, int n,
                             float* out) {
  HWY_DYNAMIC_DISPATCH(RowColumns3Kernel)(a, rows, cols, stride, n, out);
}

}  // namespace relief::detail
#endif  // HWY_ONCE
