// Block-of-rows noise kernels (issue 17) behind Noise::row and Noise::rows (noise.cpp) for the
// Perlin and Cellular bases without domain warp: per-row lattice tables and per-strip x
// terms instead of per-sample lattice work.
//
// Sources: the definitions are those of noise.cpp (Perlin 2002 with a seeded permutation; Worley
// 1996); this file only reorganises the work. Google
// Highway for the per-target compilation and run-time dispatch (the kernels themselves are AVX2
// intrinsics, compiled for the AVX2 target and for the AVX-512 targets, which run them at 256 bits
// except Perlin's and cellular's row loops, which have 512-bit forms there: on a Zen 4 they beat
// noise_simd.cpp's 512-bit per-sample kernels for Perlin 3.5× and for cellular 2.6× (in double,
// before cellular's 512-bit form and column terms; in float, cellular F1 is about 1.3× gradient
// 1 octave and F2 − F1 about 1.6–1.8×), see `relief bench --cases noise`; other targets keep
// noise_simd.cpp's kernels, with the same values).
//
// Perlin. In a row, the lattice row (y0, y1) of an octave is fixed, so the four corner hashes
// p[p[A + y]] & 15 of lattice column c (A = p[c], B = p[c + 1]) depend on c alone: once per
// lattice row and octave, a table of 256 entries (257 with a period along x: the last cell's right
// neighbour wraps to 0) holds them, each corner's two gradient coefficients (−1, +1, +0 or −0, the
// reference's kGrad2 entries) packed as 3-bit permute indices. The entries of a strip's columns
// are looked up in it once per table and strip (not gathered per row: an octave's lattice row
// spans many sample rows). Per 4 samples: one load of the packed entries, then per corner two
// in-register permutes (vpermps) give grad.x and
// grad.y·fy (the latter from a 4-entry table of the products, computed once per row), one
// multiply and one add. The x-only terms (cell index, fx, fx − 1, fade(fx)) are computed once per
// strip of columns for the whole block of rows. Same IEEE operations as the reference (the
// products are exact: coefficients ±1, ±0), so the same bits.
//
// Cellular (float after the lattice split, as noise.cpp's cellular_cell). The feature points of the
// cells of a lattice row (three rows of them) are hashed once per row of cells, not nine times per
// sample; per sample row, the squared row distances; per cell the candidates that can win anywhere
// in it (CellLists, by float bounds computed with the kernel's own roundings); vectors inside one
// cell broadcast them, up to 32 samples through one list; the x-only terms once per block of rows
// (CellColumns). 8 float lanes per vector on AVX2, 16 on the AVX-512 targets.
//
// (Simplex's blocks of rows take noise_simd.cpp's columns path since its lattice rows run along x.)
//
// Exactness. Every value is computed by the operations of Noise::row_reference in the same order:
// positions double(i0 + i)·dx (the index formed in double, exact below 2⁵², checked), the lattice
// split with the same clamp, floor and wrap (cellular: gaxis's floor, wrap and 32-bit labels), the
// same products and sums. tests/test_noise_simd.cpp
// and tests/test_noise_rows.cpp compare each target with the scalar reference.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <vector>

#include "noise_rows_simd.hpp"
#include "relief/random.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "noise_rows_simd.cpp"
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

#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX2  // AVX2 and every AVX-512 target (lower is better)

// ---- scalar helpers: noise.cpp's, operation for operation ---------------------------------------

inline std::int64_t FloorI64(double u) {
  constexpr double kBig = 2251799813685248.0;  // 2⁵¹
  double c = u > -kBig ? u : -kBig;
  c = c < kBig ? c : kBig;
  const std::int64_t i = std::int64_t(c);
  return i - std::int64_t(c < double(i));
}
inline std::int64_t WrapI(std::int64_t i, std::int64_t period) {
  if (period == 0) return i;
  const std::int64_t r = i % period;
  return r < 0 ? r + period : r;
}
inline double FadeD(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }

// ---- vector helpers --------------------------------------------------------------------------------

HWY_INLINE __m256d FadeV(__m256d t) {
  const __m256d t3 = _mm256_mul_pd(_mm256_mul_pd(t, t), t);
  return _mm256_mul_pd(
      t3, _mm256_add_pd(_mm256_mul_pd(t, _mm256_sub_pd(_mm256_mul_pd(t, _mm256_set1_pd(6.0)), _mm256_set1_pd(15.0))),
                        _mm256_set1_pd(10.0)));
}
HWY_INLINE __m256d LerpV(__m256d t, __m256d a, __m256d b) { return _mm256_add_pd(a, _mm256_mul_pd(t, _mm256_sub_pd(b, a))); }
// floor of u clamped to ±2⁵¹ (NaN → −2⁵¹), −0 → +0: FloorClamped of noise_simd.cpp.
HWY_INLINE __m256d FloorClampedV(__m256d u) {
  __m256d c = _mm256_max_pd(u, _mm256_set1_pd(-2251799813685248.0));  // (u > −k) ? u : −k
  c = _mm256_min_pd(c, _mm256_set1_pd(2251799813685248.0));           // (c < k) ? c : k
  return _mm256_add_pd(_mm256_round_pd(c, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC), _mm256_setzero_pd());
}
// The low 32 bits of the int64 held by 4 integer-valued doubles (|x| ≤ 2⁵¹).
HWY_INLINE __m128i Low32V(__m256d x) {
  const __m256i b = _mm256_castpd_si256(_mm256_add_pd(x, _mm256_set1_pd(kMagicInt)));
  return _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(b, _mm256_setr_epi32(0, 2, 4, 6, 0, 0, 0, 0)));
}
// fl mod period, exact (WrapD of noise_simd.cpp).
HWY_INLINE __m256d WrapV(__m256d fl, __m256d period, __m256d inv_period) {
  __m256d w = _mm256_sub_pd(fl, _mm256_mul_pd(_mm256_round_pd(_mm256_mul_pd(fl, inv_period), _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC), period));
  w = _mm256_blendv_pd(w, _mm256_add_pd(w, period), _mm256_cmp_pd(w, _mm256_setzero_pd(), _CMP_LT_OQ));
  return _mm256_blendv_pd(w, _mm256_sub_pd(w, period), _mm256_cmp_pd(w, period, _CMP_GE_OQ));
}
// 4 lanes of a 4-entry double table t, picked by the 3-bit fields at bit 0 of each 32-bit half of
// the 64-bit lanes of idx (2·k in the low half, 2·k + 1 in the high half).
HWY_INLINE __m256d Pick4(__m256 t, __m256i idx) { return _mm256_castps_pd(_mm256_permutevar8x32_ps(t, idx)); }

template <int kFr>
HWY_INLINE __m256d FoldV(__m256d acc, __m256d amp, __m256d n) {
  if constexpr (kFr == 0) {
    return _mm256_add_pd(acc, _mm256_mul_pd(amp, n));
  } else if constexpr (kFr == 1) {
    const __m256d an = _mm256_andnot_pd(_mm256_set1_pd(-0.0), n);
    const __m256d r = _mm256_sub_pd(_mm256_set1_pd(1.0), an);
    return _mm256_add_pd(acc, _mm256_mul_pd(amp, _mm256_mul_pd(r, r)));
  } else {
    const __m256d an = _mm256_andnot_pd(_mm256_set1_pd(-0.0), n);
    return _mm256_add_pd(acc, _mm256_mul_pd(amp, _mm256_sub_pd(_mm256_mul_pd(_mm256_set1_pd(2.0), an), _mm256_set1_pd(1.0))));
  }
}
template <int kFr>
HWY_INLINE __m128 FinishV(__m256d acc, __m256d inv) {
  if constexpr (kFr == 1)
    return _mm256_cvtpd_ps(_mm256_sub_pd(_mm256_mul_pd(_mm256_set1_pd(2.0), _mm256_mul_pd(acc, inv)), _mm256_set1_pd(1.0)));
  return _mm256_cvtpd_ps(_mm256_mul_pd(acc, inv));
}
HWY_INLINE void Store4(__m128 v, float* out, int count) {
  if (count >= 4) {
    _mm_storeu_ps(out, v);
  } else {
    alignas(16) float t[4];
    _mm_store_ps(t, v);
    std::memcpy(out, t, std::size_t(count) * sizeof(float));
  }
}

#if HWY_TARGET <= HWY_AVX3
// The 512-bit forms of the helpers above (same operations, 8 lanes).
HWY_INLINE __m512d LerpV8(__m512d t, __m512d a, __m512d b) { return _mm512_add_pd(a, _mm512_mul_pd(t, _mm512_sub_pd(b, a))); }
// A Pick4 table (8 floats) in both 256-bit halves.
HWY_INLINE __m512 Table16(__m256 t) { return _mm512_insertf32x8(_mm512_castps256_ps512(t), t, 1); }
// 8 lanes of Pick4's table t (Table16), picked as Pick4 picks them: the permute reads 4 index
// bits, and both halves of t hold the same 8 entries, so bit 3 does not matter.
HWY_INLINE __m512d Pick8(__m512 t, __m512i idx) { return _mm512_castps_pd(_mm512_permutexvar_ps(idx, t)); }
template <int kFr>
HWY_INLINE __m512d FoldV8(__m512d acc, __m512d amp, __m512d n) {
  if constexpr (kFr == 0) {
    return _mm512_add_pd(acc, _mm512_mul_pd(amp, n));
  } else if constexpr (kFr == 1) {
    const __m512d an = _mm512_abs_pd(n);
    const __m512d r = _mm512_sub_pd(_mm512_set1_pd(1.0), an);
    return _mm512_add_pd(acc, _mm512_mul_pd(amp, _mm512_mul_pd(r, r)));
  } else {
    const __m512d an = _mm512_abs_pd(n);
    return _mm512_add_pd(acc, _mm512_mul_pd(amp, _mm512_sub_pd(_mm512_mul_pd(_mm512_set1_pd(2.0), an), _mm512_set1_pd(1.0))));
  }
}
template <int kFr>
HWY_INLINE __m256 FinishV8(__m512d acc, __m512d inv) {
  if constexpr (kFr == 1)
    return _mm512_cvtpd_ps(_mm512_sub_pd(_mm512_mul_pd(_mm512_set1_pd(2.0), _mm512_mul_pd(acc, inv)), _mm512_set1_pd(1.0)));
  return _mm512_cvtpd_ps(_mm512_mul_pd(acc, inv));
}
#endif

// Scratch memory per thread, grown on demand (no allocation once warm).
template <class T>
T* Grow(std::vector<T>& v, std::size_t n) {
  if (v.size() < n) v.resize(n);
  return v.data();
}
struct Scratch {
  std::vector<double> d;
  std::vector<float> f;
  std::vector<std::int32_t> i;
  std::vector<std::uint64_t> q;
};
thread_local Scratch tls;

// ---- Perlin ----------------------------------------------------------------------------------------

// grad3(h, x, y, 0) = X[h]·x + Y[h]·y (noise.cpp's kGrad2), each coefficient coded 0..3 for
// +1, −1, +0, −0.
int CoefCode(double g) {
  if (g == 1.0) return 0;
  if (g == -1.0) return 1;
  return std::signbit(g) ? 3 : 2;
}
// kCornerBits[c][h]: corner c's (00, 10, 01, 11) two coefficient codes k as fields 3·(2c) (x) and
// 3·(2c + 1) (y): 2k in the low 32 bits, 2k + 1 in the high 32 bits (Pick4's indices).
struct CornerBits {
  std::uint64_t v[4][16];
  CornerBits() {
    for (int c = 0; c < 4; ++c)
      for (int h = 0; h < 16; ++h) {
        const int kx = CoefCode(kPerlinGradX[h]), ky = CoefCode(kPerlinGradY[h]);
        auto field = [](int code, int k) {
          return (std::uint64_t(2 * code) << (3 * k)) | (std::uint64_t(2 * code + 1) << (32 + 3 * k));
        };
        v[c][h] = field(kx, 2 * c) | field(ky, 2 * c + 1);
      }
  }
};
const CornerBits& corner_bits() {
  static const CornerBits b;
  return b;
}

constexpr int kPerlinStrip = 1024;  // columns whose x terms are computed together

// The x terms of columns first + i, i in [0, m4) (m4 a multiple of 4), for one octave: the table
// index (cell & 255, or 256 for the last cell of a period), fx, fx − 1, fade(fx).
void PerlinColumns(const NoiseOctave& o, std::int64_t first, double dx, int m4, std::int32_t* ci, double* fx,
                   double* fx1, double* sx) {
  const __m256d iota = _mm256_setr_pd(0.0, 1.0, 2.0, 3.0), vdx = _mm256_set1_pd(dx);
  const __m256d f = _mm256_set1_pd(o.freq_x), off = _mm256_set1_pd(o.offset_x), one = _mm256_set1_pd(1.0);
  const __m128i m255 = _mm_set1_epi32(255);
  const bool periodic = o.period_x != 0;
  const __m256d per = _mm256_set1_pd(double(o.period_x)), inv = _mm256_set1_pd(o.inv_period_x);
  const __m256d last = _mm256_set1_pd(double(o.period_x - 1));
  for (int i = 0; i < m4; i += 4) {
    const __m256d x = _mm256_mul_pd(_mm256_add_pd(_mm256_set1_pd(double(first + i)), iota), vdx);
    const __m256d u = _mm256_add_pd(_mm256_mul_pd(x, f), off);
    const __m256d fl = FloorClampedV(u);
    const __m256d fr = _mm256_sub_pd(u, fl);
    _mm256_storeu_pd(fx + i, fr);
    _mm256_storeu_pd(fx1 + i, _mm256_sub_pd(fr, one));
    _mm256_storeu_pd(sx + i, FadeV(fr));
    __m128i c;
    if (periodic) {
      const __m256d w = WrapV(fl, per, inv);
      c = _mm_and_si128(Low32V(w), m255);
      const __m256d is_last = _mm256_cmp_pd(w, last, _CMP_EQ_OQ);
      const __m128i lm = _mm256_castsi256_si128(
          _mm256_permutevar8x32_epi32(_mm256_castpd_si256(is_last), _mm256_setr_epi32(0, 2, 4, 6, 0, 0, 0, 0)));
      c = _mm_blendv_epi8(c, _mm_set1_epi32(256), lm);
    } else {
      c = _mm_and_si128(Low32V(fl), m255);
    }
    _mm_storeu_si128(reinterpret_cast<__m128i*>(ci + i), c);
  }
}

// The row terms of one octave (noise.cpp's axis() and perlin_row()).
struct PerlinRowTerms {
  int y0, y1;
  double fy, fy1, sy;
};
PerlinRowTerms PerlinRow(const NoiseOctave& o, double z) {
  const double v = z * o.freq_z + o.offset_z;
  const std::int64_t i = FloorI64(v);
  PerlinRowTerms r;
  r.fy = v - double(i);
  std::int64_t i0 = i, i1 = i + 1;
  if (o.period_z != 0) {
    i0 = WrapI(i, o.period_z);
    i1 = i0 + 1 == o.period_z ? 0 : i0 + 1;
  }
  r.y0 = int(i0 & 255);
  r.y1 = int(i1 & 255);
  r.fy1 = r.fy - 1;
  r.sy = FadeD(r.fy);
  return r;
}

// The packed corner codes of table entries 0..255 (and 256 with a period along x) for lattice rows
// y0, y1.
void PerlinTable(const NoiseOctave& o, int y0, int y1, std::uint64_t* t) {
  const std::uint8_t* p = o.perm.data();
  const CornerBits& cb = corner_bits();
  auto entry = [&](int A, int B) {
    return cb.v[0][p[p[A + y0]] & 15] | cb.v[1][p[p[B + y0]] & 15] | cb.v[2][p[p[A + y1]] & 15] |
           cb.v[3][p[p[B + y1]] & 15];
  };
  for (int c = 0; c < 256; ++c) t[c] = entry(p[c], p[c + 1]);
  if (o.period_x != 0) t[256] = entry(p[(o.period_x - 1) & 255], p[0]);
}

template <int kFr>
void PerlinRows(const NoiseKernelArgs& a, const double* z, int nrows, std::int64_t i0, double dx, int n, float* out,
                std::ptrdiff_t stride) {
  const int count = a.count;
  const int strip = std::min(kPerlinStrip, (n + 3) & ~3);
  // Per octave: column terms (ci as int32; fx, fx1, sx as double), a 257-entry table and the lattice
  // row it was built for.
  std::int32_t* ci = Grow(tls.i, std::size_t(count) * strip);
  double* cd = Grow(tls.d, std::size_t(count) * strip * 3);
  // Per octave the 257-entry table, then the strip's columns' entries looked up in it (tab[ci]):
  // these change only when the table does (a new lattice row) or the strip does, so the row loop
  // loads them instead of gathering them for every row (at 64 samples per first-octave cell, the
  // first octave's table changes once per 64 rows).
  std::uint64_t* tab = Grow(tls.q, std::size_t(count) * (257 + strip));
  std::uint64_t* qcol = tab + std::size_t(count) * 257;
  int built[kMaxOctaves][2];
  for (int k = 0; k < count; ++k) built[k][0] = -1;
  const __m256 tx = _mm256_castpd_ps(_mm256_setr_pd(1.0, -1.0, 0.0, -0.0));
  const __m256d inv = _mm256_set1_pd(a.inv_amp_sum);
#if HWY_TARGET <= HWY_AVX3
  const __m512 tx16 = Table16(tx);
  const __m512d inv8 = _mm512_set1_pd(a.inv_amp_sum);
#endif
  for (int c0 = 0; c0 < n; c0 += strip) {
    const int m = std::min(strip, n - c0), m4 = (m + 3) & ~3;
    for (int k = 0; k < count; ++k) {
      double* d = cd + std::size_t(k) * strip * 3;
      PerlinColumns(a.octaves[k], i0 + c0, dx, m4, ci + std::size_t(k) * strip, d, d + strip, d + 2 * strip);
    }
    bool looked_up[kMaxOctaves] = {};  // qcol holds this strip's entries of octave k's table
    for (int r = 0; r < nrows; ++r) {
      __m256 ty0[kMaxOctaves], ty1[kMaxOctaves];
      __m256d sy[kMaxOctaves], amp[kMaxOctaves];
      for (int k = 0; k < count; ++k) {
        const NoiseOctave& o = a.octaves[k];
        const PerlinRowTerms rt = PerlinRow(o, z[r]);
        if (built[k][0] != rt.y0 || built[k][1] != rt.y1) {
          PerlinTable(o, rt.y0, rt.y1, tab + std::size_t(k) * 257);
          built[k][0] = rt.y0;
          built[k][1] = rt.y1;
          looked_up[k] = false;
        }
        if (!looked_up[k]) {
          const std::uint64_t* tk = tab + std::size_t(k) * 257;
          const std::int32_t* cik = ci + std::size_t(k) * strip;
          std::uint64_t* qk = qcol + std::size_t(k) * strip;
          for (int c = 0; c < m4; ++c) qk[c] = tk[cik[c]];
          looked_up[k] = true;
        }
        // grad.y · fy for the four coefficient codes, by the reference's multiplies.
        ty0[k] = _mm256_castpd_ps(_mm256_setr_pd(1.0 * rt.fy, -1.0 * rt.fy, 0.0 * rt.fy, -0.0 * rt.fy));
        ty1[k] = _mm256_castpd_ps(_mm256_setr_pd(1.0 * rt.fy1, -1.0 * rt.fy1, 0.0 * rt.fy1, -0.0 * rt.fy1));
        sy[k] = _mm256_set1_pd(rt.sy);
        amp[k] = _mm256_set1_pd(o.amp);
      }
      float* dst = out + r * stride + c0;
      // kU vectors per step, octave by octave: each vector is one long dependency chain (load,
      // permutes, three lerps, fold) and the core overlaps the independent chains; written vector
      // after vector, their temporaries fit the 16 registers (interleaved by hand, they spilled).
      constexpr int kU = 4;
      int i = 0;
      auto step = [&](auto U, int i) {
        constexpr int kN = decltype(U)::value;
        __m256d acc[kN];
        for (int u = 0; u < kN; ++u) acc[u] = _mm256_setzero_pd();
        for (int k = 0; k < count; ++k) {
          const double* d = cd + std::size_t(k) * strip * 3 + i;
          const std::uint64_t* qk = qcol + std::size_t(k) * strip + i;
          for (int u = 0; u < kN; ++u) {
            const __m256i q = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(qk + 4 * u));
            const __m256d fx = _mm256_loadu_pd(d + 4 * u), fx1 = _mm256_loadu_pd(d + strip + 4 * u);
            const __m256d g00 = _mm256_add_pd(_mm256_mul_pd(Pick4(tx, q), fx), Pick4(ty0[k], _mm256_srli_epi64(q, 3)));
            const __m256d g10 = _mm256_add_pd(_mm256_mul_pd(Pick4(tx, _mm256_srli_epi64(q, 6)), fx1), Pick4(ty0[k], _mm256_srli_epi64(q, 9)));
            const __m256d g01 = _mm256_add_pd(_mm256_mul_pd(Pick4(tx, _mm256_srli_epi64(q, 12)), fx), Pick4(ty1[k], _mm256_srli_epi64(q, 15)));
            const __m256d g11 = _mm256_add_pd(_mm256_mul_pd(Pick4(tx, _mm256_srli_epi64(q, 18)), fx1), Pick4(ty1[k], _mm256_srli_epi64(q, 21)));
            const __m256d sx = _mm256_loadu_pd(d + 2 * strip + 4 * u);
            acc[u] = FoldV<kFr>(acc[u], amp[k], LerpV(sy[k], LerpV(sx, g00, g10), LerpV(sx, g01, g11)));
          }
        }
        for (int u = 0; u < kN; ++u) Store4(FinishV<kFr>(acc[u], inv), dst + i + 4 * u, m - i - 4 * u);
      };
#if HWY_TARGET <= HWY_AVX3
      // AVX-512: the same chain on 8 samples per vector (one 512-bit permute per coefficient: the
      // table's 8 floats in both halves, so the permute's fourth index bit, the next field's
      // lowest, picks the same entry); the 4-sample step takes the rest.
      auto step8 = [&](auto U, int i) {
        constexpr int kN = decltype(U)::value;
        __m512d acc[kN];
        for (int u = 0; u < kN; ++u) acc[u] = _mm512_setzero_pd();
        for (int k = 0; k < count; ++k) {
          const double* d = cd + std::size_t(k) * strip * 3 + i;
          const std::uint64_t* qk = qcol + std::size_t(k) * strip + i;
          const __m512 y0 = Table16(ty0[k]), y1 = Table16(ty1[k]);
          const __m512d sy8 = _mm512_set1_pd(_mm256_cvtsd_f64(sy[k])), amp8 = _mm512_set1_pd(_mm256_cvtsd_f64(amp[k]));
          for (int u = 0; u < kN; ++u) {
            const __m512i q = _mm512_loadu_si512(qk + 8 * u);
            const __m512d fx = _mm512_loadu_pd(d + 8 * u), fx1 = _mm512_loadu_pd(d + strip + 8 * u);
            const __m512d g00 = _mm512_add_pd(_mm512_mul_pd(Pick8(tx16, q), fx), Pick8(y0, _mm512_srli_epi64(q, 3)));
            const __m512d g10 = _mm512_add_pd(_mm512_mul_pd(Pick8(tx16, _mm512_srli_epi64(q, 6)), fx1), Pick8(y0, _mm512_srli_epi64(q, 9)));
            const __m512d g01 = _mm512_add_pd(_mm512_mul_pd(Pick8(tx16, _mm512_srli_epi64(q, 12)), fx), Pick8(y1, _mm512_srli_epi64(q, 15)));
            const __m512d g11 = _mm512_add_pd(_mm512_mul_pd(Pick8(tx16, _mm512_srli_epi64(q, 18)), fx1), Pick8(y1, _mm512_srli_epi64(q, 21)));
            const __m512d sx = _mm512_loadu_pd(d + 2 * strip + 8 * u);
            acc[u] = FoldV8<kFr>(acc[u], amp8, LerpV8(sy8, LerpV8(sx, g00, g10), LerpV8(sx, g01, g11)));
          }
        }
        for (int u = 0; u < kN; ++u) _mm256_storeu_ps(dst + i + 8 * u, FinishV8<kFr>(acc[u], inv8));
      };
      for (; i + 8 * kU <= m; i += 8 * kU) step8(std::integral_constant<int, kU>(), i);
      for (; i + 8 <= m; i += 8) step8(std::integral_constant<int, 1>(), i);
#endif
      for (; i + 4 * kU <= m; i += 4 * kU) step(std::integral_constant<int, kU>(), i);
      for (; i < m; i += 4) step(std::integral_constant<int, 1>(), i);
    }
  }
}


// ---- Cellular ---------------------------------------------------------------------------------------

// Float after the lattice split (noise.cpp, "Cellular basis"). Per octave and lattice row Z (cached
// while the row's label stays), for the cells X = base + e, e in [0, R), of the block's columns (one
// cell of margin each side): the feature point terms of rows Z − 1, Z, Z + 1 (b = 0, 1, 2) exactly as
// cellular_cell() computes them, px(a) = (a − 1 + ½) + ox for the three column offsets a it is seen
// from, py = (b − 1 + ½) + oy, and the cell value; per row (fy) the squared row distance
// (py − fy)². A sample in cell X visits the nine entries X + a − 1: dist = (px − fx)² + dy², the
// reference's operations. The x-only terms (fx, the entry of each sample's cell, and per vector of
// L samples whether they share one cell or two) are computed once per block of rows (CellColumns).
// When the L samples of a vector share their cell (every vector but the few that straddle a cell
// edge, at a few samples per cell and more), the entries are broadcast; otherwise they are gathered
// per lane. The vector code is written once over a lane type: 8 floats on AVX2, 16 on the AVX-512
// targets.
struct CellTables {
  const float* px[3][3];  // [b][a]
  const float* dy2[3];    // [b]
  const float* cv[3];     // [b]
};

// The scalar lattice split of noise.cpp (gaxis, wrap_double, low32, cprev, cell_value).
inline double WrapDouble(double fl, double period, double inv_period) {
  double w = fl - std::floor(fl * inv_period) * period;
  w = w < 0.0 ? w + period : w;
  return w >= period ? w - period : w;
}
inline std::uint32_t Low32D(double integral) {
  const double m = integral + kMagicInt;
  std::uint64_t bits;
  std::memcpy(&bits, &m, 8);
  return std::uint32_t(bits);
}
inline float CellValueS(std::uint32_t s) {
  return float(std::int32_t(cell_mix32(s ^ kCellCvKey)) >> 8) * kValueScale;
}

// 8 lanes (AVX2): floats in __m256, their int32 entries in __m256i.
struct CellF8 {
  using D = __m256;
  using I = __m256i;
  static constexpr int L = 8;
  static D Set1(float v) { return _mm256_set1_ps(v); }
  static D Bcast(const float* p) { return _mm256_broadcast_ss(p); }
  static D Load(const float* p) { return _mm256_loadu_ps(p); }
  static std::uint32_t LeBits(D a, D b) { return std::uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_LE_OQ))); }
  static I LoadI(const std::int32_t* p) { return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)); }
  static I AddI(I e, int c) { return _mm256_add_epi32(e, _mm256_set1_epi32(c)); }
  static D Gather(const float* t, I e) { return _mm256_i32gather_ps(t, e, 4); }
  static D Sub(D a, D b) { return _mm256_sub_ps(a, b); }
  static D Add(D a, D b) { return _mm256_add_ps(a, b); }
  static D Mul(D a, D b) { return _mm256_mul_ps(a, b); }
  static D Abs(D a) { return _mm256_andnot_ps(_mm256_set1_ps(-0.0f), a); }
  static D Min(D a, D b) { return _mm256_min_ps(a, b); }  // a < b ? a : b
  static D Max(D a, D b) { return _mm256_max_ps(a, b); }  // a > b ? a : b
  static D Sqrt(D a) { return _mm256_sqrt_ps(a); }
  static D SubF(D a, D b) { return _mm256_fmadd_ps(b, _mm256_set1_ps(-1.0f), a); }  // a − b, rounded once
  static D Fma(D a, D b, D c) { return _mm256_fmadd_ps(a, b, c); }
  static D AddF(D a, D b) { return _mm256_fmadd_ps(a, _mm256_set1_ps(1.0f), b); }   // a + b, rounded once
  // a < b ? x : y
  static D SelectLt(D a, D b, D x, D y) { return _mm256_blendv_ps(y, x, _mm256_cmp_ps(a, b, _CMP_LT_OQ)); }
  // e == c ? x : y, per lane
  static D SelectEq(I e, int c, D x, D y) {
    return _mm256_blendv_ps(y, x, _mm256_castsi256_ps(_mm256_cmpeq_epi32(e, _mm256_set1_epi32(c))));
  }
  static void Store(float* out, D v, int count) {
    if (count >= L) {
      _mm256_storeu_ps(out, v);
    } else {
      alignas(32) float t[L];
      _mm256_store_ps(t, v);
      std::memcpy(out, t, std::size_t(count) * sizeof(float));
    }
  }
};

#if HWY_TARGET <= HWY_AVX3
// 16 lanes (AVX-512): floats in __m512, their int32 entries in __m512i.
struct CellF16 {
  using D = __m512;
  using I = __m512i;
  static constexpr int L = 16;
  static D Set1(float v) { return _mm512_set1_ps(v); }
  static D Bcast(const float* p) { return _mm512_set1_ps(*p); }
  static D Load(const float* p) { return _mm512_loadu_ps(p); }
  static std::uint32_t LeBits(D a, D b) { return std::uint32_t(_mm512_cmp_ps_mask(a, b, _CMP_LE_OQ)); }
  static I LoadI(const std::int32_t* p) { return _mm512_loadu_si512(p); }
  static I AddI(I e, int c) { return _mm512_add_epi32(e, _mm512_set1_epi32(c)); }
  static D Gather(const float* t, I e) { return _mm512_i32gather_ps(e, t, 4); }
  static D Sub(D a, D b) { return _mm512_sub_ps(a, b); }
  static D Add(D a, D b) { return _mm512_add_ps(a, b); }
  static D Mul(D a, D b) { return _mm512_mul_ps(a, b); }
  static D Abs(D a) { return _mm512_abs_ps(a); }
  static D Min(D a, D b) { return _mm512_min_ps(a, b); }
  static D Max(D a, D b) { return _mm512_max_ps(a, b); }
  static D Sqrt(D a) { return _mm512_sqrt_ps(a); }
  static D SubF(D a, D b) { return _mm512_fmadd_ps(b, _mm512_set1_ps(-1.0f), a); }  // a − b, rounded once
  static D Fma(D a, D b, D c) { return _mm512_fmadd_ps(a, b, c); }
  static D AddF(D a, D b) { return _mm512_fmadd_ps(a, _mm512_set1_ps(1.0f), b); }   // a + b, rounded once
  static D SelectLt(D a, D b, D x, D y) { return _mm512_mask_blend_ps(_mm512_cmp_ps_mask(a, b, _CMP_LT_OQ), y, x); }
  static D SelectEq(I e, int c, D x, D y) {
    return _mm512_mask_blend_ps(_mm512_cmpeq_epi32_mask(e, _mm512_set1_epi32(c)), y, x);
  }
  static void Store(float* out, D v, int count) {
    if (count >= L) _mm512_storeu_ps(out, v);
    else _mm512_mask_storeu_ps(out, __mmask16((1u << count) - 1u), v);
  }
};
#endif

// The fractal fold and the end of a vector in float: noise_simd.cpp's FoldF and StoreGradient (x86
// min/max return their second operand when either is NaN: the reference's v > −1 ? v : −1 and
// v < 1 ? v : 1). Ridged: amp is s = ridge_scale and the octave's value s·n.
template <class V, int kFr>
HWY_INLINE typename V::D CellFoldF(typename V::D acc, typename V::D amp, typename V::D n) {
  if constexpr (kFr == 0) {
    return V::Add(acc, V::Mul(amp, n));
  } else if constexpr (kFr == 1) {
    const auto r = V::Sub(amp, V::Abs(V::Mul(amp, n)));
    return V::Add(acc, V::Mul(r, r));
  } else {
    return V::Add(acc, V::Mul(amp, V::Sub(V::Mul(V::Set1(2.0f), V::Abs(n)), V::Set1(1.0f))));
  }
}
template <class V, int kFr>
HWY_INLINE void CellStoreF(typename V::D acc, typename V::D inv, float* out, int count) {
  auto v = kFr == 1 ? V::Sub(V::Mul(acc, V::Add(inv, inv)), V::Set1(1.0f)) : V::Mul(acc, inv);
  v = V::Min(V::Max(v, V::Set1(-1.0f)), V::Set1(1.0f));
  V::Store(out, v, count);
}

// One candidate feature point seen from kN vectors: dist = (p − fx)² + dy², folded into the
// running F1 (d1), F2 (d2) or owner's cell value (h1) as the reference folds it.
template <class V, int kRet, int kN>
HWY_INLINE void CellFold(const typename V::D* p, const typename V::D* dy2, const typename V::D* cv,
                         const typename V::D* fx, typename V::D* d1, typename V::D* d2, typename V::D* h1) {
  for (int u = 0; u < kN; ++u) {
    // fx − p and m + dy² as fused multiply-adds by ∓1 and 1: the same single roundings as the
    // reference's p − fx (negated: the same square) and m + dy², on the multiply-add units.
    const auto ddx = V::SubF(fx[u], p[u]);
    const auto dist = V::AddF(V::Mul(ddx, ddx), dy2[u]);
    if constexpr (kRet == int(CellularReturn::F1)) {
      d1[u] = V::Min(dist, d1[u]);  // dist < d1 ? dist : d1 (NaN keeps d1, as the reference)
    } else if constexpr (kRet == int(CellularReturn::CellValue)) {
      h1[u] = V::SelectLt(dist, d1[u], cv[u], h1[u]);
      d1[u] = V::Min(dist, d1[u]);
    } else {
      // The reference's "if (d < d1) {d2 = d1; d1 = d;} else if (d < d2) d2 = d;" as
      // d2 = min(max(d, d1), d2), d1 = min(d, d1) (a row's distances are all NaN or none).
      d2[u] = V::Min(V::Max(dist, d1[u]), d2[u]);
      d1[u] = V::Min(dist, d1[u]);
    }
  }
}
template <class V, int kN>
HWY_INLINE void CellInit(typename V::D* d1, typename V::D* d2, typename V::D* h1) {
  // h1: the reference's owner s = 0 when no distance is below +inf (NaN rows).
  const auto inf = V::Set1(HUGE_VALF), h0 = V::Set1(CellValueS(0u));
  for (int u = 0; u < kN; ++u) d1[u] = d2[u] = inf, h1[u] = h0;
}
template <class V, int kRet, int kN>
HWY_INLINE void CellFinish(const typename V::D* d1, const typename V::D* d2, const typename V::D* h1,
                           typename V::D* res) {
  const auto one = V::Set1(1.0f), two = V::Set1(2.0f), mone = V::Set1(-1.0f);
  // std::min(v, 1.0f) = 1 < v ? 1 : v, the min instruction's operand order (NaN stays NaN).
  auto min1 = [&](typename V::D v) { return V::Min(one, v); };
  // 2·m − 1 as one fused multiply-add: 2·m is exact, so the same single rounding.
  auto out = [&](typename V::D m) { return V::Fma(two, m, mone); };
  for (int u = 0; u < kN; ++u) {
    if constexpr (kRet == int(CellularReturn::F1)) {
      res[u] = out(min1(V::Sqrt(d1[u])));
    } else if constexpr (kRet == int(CellularReturn::F2)) {
      res[u] = out(min1(V::Mul(V::Sqrt(d2[u]), V::Set1(kCellF2Scale))));
    } else if constexpr (kRet == int(CellularReturn::F2MinusF1)) {
      res[u] = out(min1(V::Sub(V::Sqrt(d2[u]), V::Sqrt(d1[u]))));
    } else {
      res[u] = h1[u];
    }
  }
}

// kN vectors (fx[u]; lanes' entries e[u], or all e0 when broadcast) through the nine visits in the
// reference's order, their chains interleaved.
template <class V, int kRet, bool kGather, int kN>
HWY_INLINE void CellVisitAll(const CellTables& t, std::int64_t e0, const typename V::I* e, const typename V::D* fx,
                             typename V::D* res) {
  using D = typename V::D;
  D d1[kN], d2[kN], h1[kN];
  CellInit<V, kN>(d1, d2, h1);
  for (int b = 0; b < 3; ++b)
    for (int a = 0; a < 3; ++a) {
      D p[kN], dy2[kN], cv[kN];
      for (int u = 0; u < kN; ++u) {
        if constexpr (kGather) {
          const auto ea = V::AddI(e[u], a - 1);
          p[u] = V::Gather(t.px[b][a], ea);
          dy2[u] = V::Gather(t.dy2[b], ea);
          if constexpr (kRet == int(CellularReturn::CellValue)) cv[u] = V::Gather(t.cv[b], ea);
        } else {
          p[u] = V::Bcast(t.px[b][a] + e0 + a - 1);
          dy2[u] = V::Bcast(t.dy2[b] + e0 + a - 1);
          if constexpr (kRet == int(CellularReturn::CellValue)) cv[u] = V::Bcast(t.cv[b] + e0 + a - 1);
        }
      }
      CellFold<V, kRet, kN>(p, dy2, cv, fx, d1, d2, h1);
    }
  CellFinish<V, kRet, kN>(d1, d2, h1, res);
}

// The fold of kN vectors whose lanes all lie in one cell through that cell's list of candidates
// that can win somewhere in it (CellLists), in the reference's order: px from lp, dy² and the cell
// value at lo in the row's dy2 and cv tables.
template <class V, int kRet, int kN>
HWY_INLINE void CellVisitFold(const float* lp, const std::int32_t* lo, const float* dy2t, const float* cvt, int count,
                              const typename V::D* fx, typename V::D* d1, typename V::D* d2, typename V::D* h1) {
  using D = typename V::D;
  CellInit<V, kN>(d1, d2, h1);
  for (int t = 0; t < count; ++t) {
    D p[kN], dy2[kN], cv[kN];
    const D pb = V::Bcast(lp + t), db = V::Bcast(dy2t + lo[t]);
    D cb = pb;
    if constexpr (kRet == int(CellularReturn::CellValue)) cb = V::Bcast(cvt + lo[t]);
    for (int u = 0; u < kN; ++u) p[u] = pb, dy2[u] = db, cv[u] = cb;
    CellFold<V, kRet, kN>(p, dy2, cv, fx, d1, d2, h1);
  }
}
template <class V, int kRet, int kN>
HWY_INLINE void CellVisitList(const float* lp, const std::int32_t* lo, const float* dy2t, const float* cvt, int count,
                              const typename V::D* fx, typename V::D* res) {
  using D = typename V::D;
  D d1[kN], d2[kN], h1[kN];
  CellVisitFold<V, kRet, kN>(lp, lo, dy2t, cvt, count, fx, d1, d2, h1);
  CellFinish<V, kRet, kN>(d1, d2, h1, res);
}

struct CellOctaveState {
  std::int64_t base = 0;   // cell of entry 0
  int R = 0;               // entries
  std::uint64_t zkey = 0;  // bits of the (wrapped) floor of v the cached terms are for
  bool built = false;
  float* px = nullptr;   // [b][a][R]
  float* py = nullptr;   // [b][R]
  float* cv = nullptr;   // [b][R]
  float* dy2 = nullptr;  // [b][R]
  // Culling (rows of at least kCullSamples samples per cell): per cell e, the candidates that can
  // give its F1 (or F2) somewhere in the cell, in visiting order: lp (px) and lo (the entry of its
  // dy² and cell value in dy2, cv: b·R + e + a − 1) at e·9 + t, t < count[e]. They change only when
  // the set of kept candidates does: CellLists compacts a cell again only then (or after CellBuild:
  // lists false), comparing each block of cells' keep bits with the previous row's (prev).
  bool cull = false;
  bool lists = false;
  float* lp = nullptr;
  std::int32_t* lo = nullptr;
  std::uint32_t* prev = nullptr;
  float* cg = nullptr;  // [b][a][R]: the bounds' terms of px (CellLists)
  float* cm = nullptr;
  std::int32_t* count = nullptr;
  // The block's columns (CellColumns), n rounded up to 32: each sample's fx and cell entry (clamped
  // into [1, R − 2]), and per vector of L samples code = 4·e0 + kind, e0 its first sample's entry,
  // kind 0 when all L are in e0, 1 when all are in e0 or e0 + 1, else 2.
  float* fx = nullptr;
  std::int32_t* e = nullptr;
  std::int32_t* code = nullptr;
};

constexpr int kCullSamples = 8;

// The x-only terms of octave o over the block's columns (np = n rounded up to 32; the lanes past n
// are computed the same way, clamped into the table, never stored): x = double(i0 + i)·dx,
// u = x·fₓ + offₓ, fx = float(u − ⌊u⌋) (|u| < 2⁵⁰: the clamp of FloorClampedV does nothing).
void CellColumns(const NoiseOctave& o, std::int64_t i0, double dx, int np, int L, CellOctaveState& s) {
  const __m256d iota = _mm256_setr_pd(0.0, 1.0, 2.0, 3.0), vdx = _mm256_set1_pd(dx);
  const __m256d f = _mm256_set1_pd(o.freq_x), off = _mm256_set1_pd(o.offset_x);
  const __m128i vb = _mm_set1_epi32(std::int32_t(std::uint32_t(s.base))), emax = _mm_set1_epi32(s.R - 2);
  for (int i = 0; i < np; i += 4) {
    const __m256d x = _mm256_mul_pd(_mm256_add_pd(_mm256_set1_pd(double(i0 + i)), iota), vdx);
    const __m256d uu = _mm256_add_pd(_mm256_mul_pd(x, f), off);
    const __m256d fl = FloorClampedV(uu);
    _mm_storeu_ps(s.fx + i, _mm256_cvtpd_ps(_mm256_sub_pd(uu, fl)));
    // Entry of each lane's cell: its index modulo 2³² minus the base's (the range is small).
    __m128i e = _mm_sub_epi32(Low32V(fl), vb);
    e = _mm_max_epi32(_mm_min_epi32(e, emax), _mm_set1_epi32(1));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(s.e + i), e);
  }
  for (int g = 0; g < np / L; ++g) {
    const std::int32_t* e = s.e + L * g;
    const std::int32_t e0 = e[0];
    int kind = 0;
    for (int l = 1; l < L; ++l) {
      if (e[l] == e0) continue;
      kind = std::max(kind, e[l] == e0 + 1 ? 1 : 2);
    }
    s.code[g] = 4 * e0 + kind;
  }
}

// The candidate lists of one row (after dy2). Candidate i's computed distance over the cell, fx in
// [0, 1] (1.0f included), is at least LB_i = dy²_i + g_i² (g = −p or p − 1 outside [0, 1], else 0:
// exact, and |fl(fx − p)| ≥ g since rounding is monotone and g representable) and at most UB_i =
// dy²_i + max(p², (p − 1)²) (the computed distance at fx = 0 or 1, |fl(p − 1)| = |fl(1 − p)|),
// each sum rounded as the kernel rounds it. F1 is at most min UB everywhere in the cell, so a
// candidate with LB_i above it is never the minimum, nor ties it; F2 likewise with the second
// smallest UB (two candidates are below it everywhere). A margin 0 would already be exact; 1e-6
// only keeps more. The kept candidates include the ones attaining those bounds, so the fold over
// the list gives the same d1, d2 and first owner as over all nine. A row at a non-finite fy keeps
// all nine. One lane (CellLists on windows of few cells):
struct CellF1 {
  using D = float;
  static constexpr int L = 1;
  static D Set1(float v) { return v; }
  static D Load(const float* p) { return *p; }
  static D Add(D a, D b) { return a + b; }
  static D Min(D a, D b) { return a < b ? a : b; }
  static D Max(D a, D b) { return a > b ? a : b; }
  static std::uint32_t LeBits(D a, D b) { return a <= b ? 1u : 0u; }
};

template <class V, int kRet>
void CellLists(CellOctaveState& s, float fy) {
  using D = typename V::D;
  constexpr int L = V::L;
  constexpr bool kSecond = kRet == int(CellularReturn::F2) || kRet == int(CellularReturn::F2MinusF1);
  const D margin = V::Set1(1e-6f);
  const int R = s.R;
  if (L > 1 && R < L + 2) {  // fewer than L cells: one at a time
    CellLists<CellF1, kRet>(s, fy);
    return;
  }
  auto compact = [&](int c, std::uint32_t bits) {  // cell c's list: the candidates t with bit t set
    int k = 0;
    for (int t = 0; t < 9; ++t) {
      const int ee = c + t % 3 - 1;
      s.lp[c * 9 + k] = s.px[t * R + ee];
      s.lo[c * 9 + k] = (t / 3) * R + ee;
      k += int((bits >> t) & 1u);
    }
    s.count[c] = k;
  };
  if (!std::isfinite(fy)) {  // keep all nine (else every dy² and bound is finite)
    for (int e = 1; e + 1 < R; ++e) compact(e, 0x1FFu);
    s.lists = false;
    return;
  }
  // L cells at a time (the last block overlaps the previous one: the same lists again). A cell is
  // compacted again only when its keep bits differ from the previous row's.
  int blk = 0;
  for (int e1 = 1; e1 + 1 < R; e1 += L, ++blk) {
    const int e = std::max(1, std::min(e1, R - 1 - L));
    std::uint32_t keep[9];
    D lb[9];
    D m1 = V::Set1(HUGE_VALF), m2 = m1;
    for (int t = 0; t < 9; ++t) {
      const int b = t / 3, ee = e + t % 3 - 1;
      const D dt = V::Load(s.dy2 + b * R + ee);
      lb[t] = V::Add(V::Load(s.cg + t * R + ee), dt);
      const D ub = V::Add(V::Load(s.cm + t * R + ee), dt);
      // The two smallest upper bounds: the reference's fold without branches (finite values).
      m2 = V::Min(V::Max(ub, m1), m2);
      m1 = V::Min(ub, m1);
    }
    const D thr = V::Add(kSecond ? m2 : m1, margin);
    std::uint32_t changed = s.lists ? 0u : ~0u;
    std::uint32_t* prev = s.prev + 9 * blk;
    for (int t = 0; t < 9; ++t) {
      keep[t] = V::LeBits(lb[t], thr);
      changed |= keep[t] ^ prev[t];
      prev[t] = keep[t];
    }
    changed &= (1u << L) - 1u;
    while (changed) {
      const int l = __builtin_ctz(changed);
      changed &= changed - 1u;
      std::uint32_t bits = 0;
      for (int t = 0; t < 9; ++t) bits |= ((keep[t] >> l) & 1u) << t;
      compact(e + l, bits);
    }
  }
  s.lists = true;
}

// The feature points of lattice rows zl[0..2] (labels of Z − 1, Z, Z + 1) for every entry.
void CellBuild(const NoiseOctave& o, float J, const std::uint32_t (&zl)[3], CellOctaveState& s) {
  std::uint32_t zp[3];
  for (int b = 0; b < 3; ++b) zp[b] = (zl[b] * kGradPz) ^ o.key32;
  for (int e = 0; e < s.R; ++e) {
    const std::int64_t c = s.base + e;
    const std::uint32_t xp = std::uint32_t(o.period_x ? WrapI(c, o.period_x) : c) * kGradPx;
    for (int b = 0; b < 3; ++b) {
      const std::uint32_t sh = xp + zp[b];  // noise.cpp's pre-hash (a sum)
      const std::uint32_t h = cell_mix32(sh);
      const float ox = J * (float(h >> 16) * kCell2m16 - 0.5f), oy = J * (float(h & 0xFFFFu) * kCell2m16 - 0.5f);
      for (int a = 0; a < 3; ++a) {
        const float p = (float(a - 1) + 0.5f) + ox;
        s.px[(b * 3 + a) * s.R + e] = p;
        if (s.cull) {  // CellLists' bounds: gap(p, [0, 1])² and max(p², (p − 1)²)
          const float g = p < 0.0f ? -p : p > 1.0f ? p - 1.0f : 0.0f;
          s.cg[(b * 3 + a) * s.R + e] = g * g;
          const float q = p - 1.0f;
          s.cm[(b * 3 + a) * s.R + e] = std::max(p * p, q * q);
        }
      }
      s.py[b * s.R + e] = (float(b - 1) + 0.5f) + oy;
      s.cv[b * s.R + e] = CellValueS(sh);
    }
  }
  s.built = true;
  s.lists = false;
}

template <class V, int kRet, int kFr>
void CellularRows(const NoiseKernelArgs& a, const double* z, int nrows, int n, float* out, std::ptrdiff_t stride,
                  CellOctaveState* mst) {
  using D = typename V::D;
  using I = typename V::I;
  constexpr int L = V::L, kM = 32 / L;  // a step of 32 samples: kM vectors of L lanes
  const int count = a.count;
  const D inv = V::Set1(float(a.inv_amp_sum));
  const float J = float(a.jitter);
  for (int r = 0; r < nrows; ++r) {
    CellTables tabs[kMaxOctaves];
    D amp[kMaxOctaves];
    for (int k = 0; k < count; ++k) {
      const NoiseOctave& o = a.octaves[k];
      CellOctaveState& s = mst[k];
      // noise.cpp's crow(): gaxis of v, the previous and next labels.
      const double v = z[r] * o.freq_z + o.offset_z;
      double fl = std::floor(v);
      const float fy = float(v - fl);
      if (o.period_z) fl = WrapDouble(fl, double(o.period_z), o.inv_period_z);
      std::uint64_t key;
      std::memcpy(&key, &fl, 8);
      if (!s.built || s.zkey != key) {
        const std::uint32_t zc = Low32D(fl);
        std::uint32_t zl[3];
        if (o.period_z) {
          const std::uint32_t P = std::uint32_t(o.period_z);
          zl[0] = zc == 0u ? P - 1u : zc - 1u;
          zl[2] = zc + 1u == P ? 0u : zc + 1u;
        } else {
          zl[0] = zc - 1u;
          zl[2] = zc + 1u;
        }
        zl[1] = zc;
        CellBuild(o, J, zl, s);
        s.zkey = key;
      }
      for (int b = 0; b < 3; ++b) {
        const float* py = s.py + b * s.R;
        float* dy2 = s.dy2 + b * s.R;
        for (int e = 0; e < s.R; ++e) {
          const float dy = py[e] - fy;
          dy2[e] = dy * dy;
        }
        for (int aa = 0; aa < 3; ++aa) tabs[k].px[b][aa] = s.px + (b * 3 + aa) * s.R;
        tabs[k].dy2[b] = dy2;
        tabs[k].cv[b] = s.cv + b * s.R;
      }
      if (s.cull) CellLists<V, kRet>(s, fy);
      amp[k] = V::Set1(kFr == 1 ? o.ridge_scale : float(o.amp));
    }
    float* dst = out + r * stride;
    // One octave over one vector of L samples at i.
    auto group = [&](const CellOctaveState& s, const CellTables& tab, int i, D* nk) {
      D fx[1] = {V::Load(s.fx + i)};
      const std::int32_t code = s.code[i / L], e0 = code >> 2, kind = code & 3;
      const I e[1] = {V::LoadI(s.e + i)};
      if (s.cull) {
        // Every lane in cell e0, or in e0 and e0 + 1 (a vector across one cell edge: both cells'
        // lists, each lane taking its own cell's result), else gathered.
        if (kind == 0) {
          CellVisitList<V, kRet, 1>(s.lp + e0 * 9, s.lo + e0 * 9, s.dy2, s.cv, s.count[e0], fx, nk);
        } else if (kind == 1) {
          D d1[1], d2[1], h1[1], d1b[1], d2b[1], h1b[1];
          CellVisitFold<V, kRet, 1>(s.lp + e0 * 9, s.lo + e0 * 9, s.dy2, s.cv, s.count[e0], fx, d1, d2, h1);
          const int c1 = e0 + 1;
          CellVisitFold<V, kRet, 1>(s.lp + c1 * 9, s.lo + c1 * 9, s.dy2, s.cv, s.count[c1], fx, d1b, d2b, h1b);
          d1[0] = V::SelectEq(e[0], c1, d1b[0], d1[0]);
          d2[0] = V::SelectEq(e[0], c1, d2b[0], d2[0]);
          h1[0] = V::SelectEq(e[0], c1, h1b[0], h1[0]);
          CellFinish<V, kRet, 1>(d1, d2, h1, nk);
        } else {
          CellVisitAll<V, kRet, true, 1>(tab, e0, e, fx, nk);
        }
      } else if (kind == 0) {
        CellVisitAll<V, kRet, false, 1>(tab, e0, e, fx, nk);
      } else {
        CellVisitAll<V, kRet, true, 1>(tab, e0, e, fx, nk);
      }
    };
    // kG vectors at i (a power of two): when all lie in one cell, through its list together (kG
    // independent chains, the list's loads shared); else each half the same way, down to single
    // vectors (group). Offsets stay compile-time constants, so nk stays in registers.
    auto visit = [&](auto self, auto G, const CellOctaveState& s, const CellTables& tab, int i, D* nk) -> void {
      constexpr int kG = decltype(G)::value;
      if constexpr (kG == 1) {
        group(s, tab, i, nk);
      } else {
        const std::int32_t c0 = s.code[i / L];
        bool together = s.cull && (c0 & 3) == 0;
        for (int u = 1; u < kG; ++u) together = together && s.code[i / L + u] == c0;
        if (together) {
          D fx[kG];
          for (int u = 0; u < kG; ++u) fx[u] = V::Load(s.fx + i + L * u);
          const int c = c0 >> 2;
          CellVisitList<V, kRet, kG>(s.lp + c * 9, s.lo + c * 9, s.dy2, s.cv, s.count[c], fx, nk);
        } else {
          self(self, std::integral_constant<int, kG / 2>(), s, tab, i, nk);
          self(self, std::integral_constant<int, kG / 2>(), s, tab, i + L * (kG / 2), nk + kG / 2);
        }
      }
    };
    auto step = [&](auto G, int i) {
      constexpr int kG = decltype(G)::value;
      D acc[kG];
      for (int u = 0; u < kG; ++u) acc[u] = V::Set1(0.0f);
      for (int k = 0; k < count; ++k) {
        D nk[kG];
        visit(visit, G, mst[k], tabs[k], i, nk);
        for (int u = 0; u < kG; ++u) acc[u] = CellFoldF<V, kFr>(acc[u], amp[k], nk[u]);
      }
      for (int u = 0; u < kG; ++u)
        if (i + L * u < n) CellStoreF<V, kFr>(acc[u], inv, dst + i + L * u, n - i - L * u);
    };
    int i = 0;
    for (; i + 32 <= n; i += 32) step(std::integral_constant<int, kM>(), i);
    for (; i < n; i += L) step(std::integral_constant<int, 1>(), i);
  }
}

// The cell range of every octave over the row window; false when a table would be much larger than
// the window (more than about a cell per sample: up to 72 bytes of tables per cell otherwise, for
// little gain over the per-sample kernel). Then the block's x-only terms (CellColumns).
bool CellularPrepare(const NoiseKernelArgs& a, std::int64_t i0, double dx, int n, int L, CellOctaveState* st) {
  // The tables are indexed in int (entries up to R ≤ n + 67, offsets up to 9·R, codes 4·e0): rows of
  // more than 2²⁶ samples (a 256 MB row; about 5 GB of tables) take the per-sample kernel instead of
  // overflowing them, as does n + 31 near INT_MAX.
  if (n > (1 << 26)) return false;
  const int np = int((std::int64_t(n) + 31) / 32 * 32);
  std::size_t total = 0;
  for (int k = 0; k < a.count; ++k) {
    const NoiseOctave& o = a.octaves[k];
    const double u0 = double(i0) * dx * o.freq_x + o.offset_x, u1 = double(i0 + n - 1) * dx * o.freq_x + o.offset_x;
    const std::int64_t c0 = FloorI64(u0), c1 = FloorI64(u1);
    const std::int64_t lo = std::min(c0, c1), hi = std::max(c0, c1);
    if (hi - lo > std::int64_t(n) + 64) return false;
    // Cell indices as int64 and the floors exact: positions within ±2⁵⁰ cells (far beyond any terrain).
    if (!(std::fabs(u0) < 0x1p50 && std::fabs(u1) < 0x1p50)) return false;
    st[k].base = lo - 1;
    st[k].R = int(hi - lo + 3);
    st[k].built = false;
    st[k].cull = std::int64_t(st[k].R) * kCullSamples <= std::int64_t(n) + 2 * kCullSamples;
    total += std::size_t(st[k].R) * (st[k].cull ? 45 : 18) + std::size_t(np);
  }
  float* p = Grow(tls.f, total);
  std::size_t ints = 0;
  for (int k = 0; k < a.count; ++k)
    ints += (st[k].cull ? 19 * std::size_t(st[k].R) + 9 : 0) + std::size_t(np + np / L);
  std::int32_t* q = Grow(tls.i, ints + 1);
  for (int k = 0; k < a.count; ++k) {
    const std::size_t R = std::size_t(st[k].R);
    st[k].px = p;
    st[k].py = p + 9 * R;
    st[k].cv = p + 12 * R;
    st[k].dy2 = p + 15 * R;
    p += 18 * R;
    if (st[k].cull) {
      st[k].lp = p;
      st[k].cg = p + 9 * R;
      st[k].cm = p + 18 * R;
      p += 27 * R;
      st[k].count = q;
      st[k].lo = q + R;
      st[k].prev = reinterpret_cast<std::uint32_t*>(q + 10 * R);  // 9 per block of cells: at most R + 1 blocks
      q += 19 * R + 9;
    }
    st[k].fx = p;
    p += np;
    st[k].e = q;
    st[k].code = q + np;
    q += np + np / L;
    CellColumns(a.octaves[k], i0, dx, np, L, st[k]);
  }
  return true;
}

template <int kRet>
bool CellularRet(const NoiseKernelArgs& a, const double* z, int nrows, std::int64_t i0, double dx, int n, float* out,
                 std::ptrdiff_t stride, int fr) {
#if HWY_TARGET <= HWY_AVX3
  using V = CellF16;
#else
  using V = CellF8;
#endif
  CellOctaveState st[kMaxOctaves];
  if (!CellularPrepare(a, i0, dx, n, V::L, st)) return false;
  if (fr == 1) CellularRows<V, kRet, 1>(a, z, nrows, n, out, stride, st);
  else if (fr == 2) CellularRows<V, kRet, 2>(a, z, nrows, n, out, stride, st);
  else CellularRows<V, kRet, 0>(a, z, nrows, n, out, stride, st);
  return true;
}


bool RowsTables(const NoiseKernelArgs& a, const double* z, int nrows, std::int64_t i0, double dx, int n, float* out,
                std::ptrdiff_t stride) {
  if (a.warp || n <= 0 || nrows <= 0) return false;
  // Positions double(i0 + i) formed in double must be exact.
  constexpr std::int64_t kExact = std::int64_t(1) << 52;
  if (i0 <= -kExact || i0 >= kExact || std::int64_t(n) >= kExact - (i0 < 0 ? -i0 : i0)) return false;
  const int fr = a.fractal == Fractal::Ridged ? 1 : a.fractal == Fractal::Billow ? 2 : 0;
  switch (a.basis) {
    case NoiseBasis::Perlin:
      if (fr == 1) PerlinRows<1>(a, z, nrows, i0, dx, n, out, stride);
      else if (fr == 2) PerlinRows<2>(a, z, nrows, i0, dx, n, out, stride);
      else PerlinRows<0>(a, z, nrows, i0, dx, n, out, stride);
      return true;
    case NoiseBasis::Cellular:
      switch (a.cellular) {
        case CellularReturn::F1: return CellularRet<0>(a, z, nrows, i0, dx, n, out, stride, fr);
        case CellularReturn::F2: return CellularRet<1>(a, z, nrows, i0, dx, n, out, stride, fr);
        case CellularReturn::F2MinusF1: return CellularRet<2>(a, z, nrows, i0, dx, n, out, stride, fr);
        case CellularReturn::CellValue: return CellularRet<3>(a, z, nrows, i0, dx, n, out, stride, fr);
      }
      return false;
    default: return false;
  }
}

#else  // other targets: noise_simd.cpp's kernels

bool RowsTables(const NoiseKernelArgs&, const double*, int, std::int64_t, double, int, float*, std::ptrdiff_t) {
  return false;
}

#endif

}  // namespace
}  // namespace HWY_NAMESPACE
}  // namespace relief::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace relief::detail {

HWY_EXPORT(RowsTables);

bool noise_rows_tables_simd(const NoiseKernelArgs& a, const double* z_m, int nrows, std::int64_t i0, double dx, int n,
                            float* out, std::ptrdiff_t stride) {
  return HWY_DYNAMIC_DISPATCH(RowsTables)(a, z_m, nrows, i0, dx, n, out, stride);
}

}  // namespace relief::detail
#endif  // HWY_ONCE
