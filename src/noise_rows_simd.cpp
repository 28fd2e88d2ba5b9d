// Block-of-rows noise kernels (issue 17) behind Noise::row and Noise::rows (noise.cpp) for the
// Perlin and Cellular bases without domain warp: per-row lattice tables and per-strip x
// terms instead of per-sample lattice work.
//
// Sources: the definitions are those of noise.cpp (Perlin 2002 with a seeded permutation; Worley
// 1996); this file only reorganises the work. Google
// Highway for the per-target compilation and run-time dispatch (the kernels themselves are AVX2
// intrinsics, compiled for the AVX2 target and for the AVX-512 targets, which run them at 256 bits
// except Perlin's row loop, which has a 512-bit form there: on a Zen 4 they beat noise_simd.cpp's
// 512-bit per-sample kernels for Perlin 3.5× and for cellular 2.6×, see `relief bench --cases
// noise`; other targets keep noise_simd.cpp's kernels, with the same values).
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
// Cellular. The feature points of the cells of a lattice row (three rows of them) are hashed once
// per row of cells, not nine times per sample; per sample row, the squared row distances; per cell
// the candidates that can win anywhere in it (CellLists); vectors inside one cell broadcast them.
//
// (Simplex's blocks of rows take noise_simd.cpp's columns path since its lattice rows run along x.)
//
// Exactness. Every value is computed by the operations of Noise::row_reference in the same order:
// positions double(i0 + i)·dx (the index formed in double, exact below 2⁵², checked), the lattice
// split with the same clamp, floor and wrap, the same products and sums. tests/test_noise_simd.cpp
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

// Per octave and lattice row j (cached while j stays), for the cells X = base + e, e in [0, R), of
// the block's columns (one cell of margin each side): the feature point terms of rows j − 1, j, j + 1
// (b = 0, 1, 2) exactly as cellular_core() computes them, px(a) = (a − 1 + ½) + jitter·ux for the
// three column offsets a it is seen from, py = (b − 1 + ½) + jitter·uy, and the cell value; per row
// (fy) the squared row distance (py − fy)². A sample in cell X visits the nine entries X + a − 1:
// dist = (px − fx)² + dy², the reference's operations. When the four lanes of a vector share their
// cell (every vector but the few that straddle a cell edge, at a few samples per cell and more),
// the entries are broadcast; otherwise they are gathered per lane.
struct CellTables {
  const double* px[3][3];  // [b][a]
  const double* dy2[3];    // [b]
  const double* cv[3];     // [b]
};

constexpr double kK21 = kCell2m21;

// One candidate feature point seen from kN vectors: dist = (p − fx)² + dy², folded into the
// running F1 (d1), F2 (d2) or owner's cell value (h1) as the reference folds it.
template <int kRet, int kN>
HWY_INLINE void CellFold(const __m256d* p, const __m256d* dy2, const __m256d* cv, const __m256d* fx, __m256d* d1,
                         __m256d* d2, __m256d* h1) {
  for (int u = 0; u < kN; ++u) {
    const __m256d ddx = _mm256_sub_pd(p[u], fx[u]);
    const __m256d dist = _mm256_add_pd(_mm256_mul_pd(ddx, ddx), dy2[u]);
    if constexpr (kRet == int(CellularReturn::F1)) {
      d1[u] = _mm256_min_pd(dist, d1[u]);  // dist < d1 ? dist : d1 (NaN keeps d1, as the reference)
    } else if constexpr (kRet == int(CellularReturn::CellValue)) {
      const __m256d lt = _mm256_cmp_pd(dist, d1[u], _CMP_LT_OQ);
      d1[u] = _mm256_blendv_pd(d1[u], dist, lt);
      h1[u] = _mm256_blendv_pd(h1[u], cv[u], lt);
    } else {
      // The reference's "if (d < d1) {d2 = d1; d1 = d;} else if (d < d2) d2 = d;" as
      // d2 = min(max(d, d1), d2), d1 = min(d, d1) (NaN d leaves both).
      d2[u] = _mm256_min_pd(_mm256_max_pd(dist, d1[u]), d2[u]);
      d1[u] = _mm256_min_pd(dist, d1[u]);
    }
  }
}
template <int kRet, int kN>
HWY_INLINE void CellFinish(const __m256d* d1, const __m256d* d2, const __m256d* h1, __m256d* res) {
  const __m256d one = _mm256_set1_pd(1.0), two = _mm256_set1_pd(2.0);
  auto min1 = [&](__m256d v) { return _mm256_blendv_pd(v, one, _mm256_cmp_pd(one, v, _CMP_LT_OQ)); };  // std::min(v, 1.0)
  for (int u = 0; u < kN; ++u) {
    if constexpr (kRet == int(CellularReturn::F1)) {
      res[u] = _mm256_sub_pd(_mm256_mul_pd(two, min1(_mm256_sqrt_pd(d1[u]))), one);
    } else if constexpr (kRet == int(CellularReturn::F2)) {
      res[u] = _mm256_sub_pd(_mm256_mul_pd(two, min1(_mm256_mul_pd(_mm256_sqrt_pd(d2[u]), _mm256_set1_pd(1.0 / 1.5)))), one);
    } else if constexpr (kRet == int(CellularReturn::F2MinusF1)) {
      res[u] = _mm256_sub_pd(_mm256_mul_pd(two, min1(_mm256_sub_pd(_mm256_sqrt_pd(d2[u]), _mm256_sqrt_pd(d1[u])))), one);
    } else {
      res[u] = h1[u];
    }
  }
}

// kN vectors (fx[u]; lanes' entries e[u], or all e0 when broadcast) through the nine visits in the
// reference's order, their chains interleaved.
template <int kRet, bool kGather, int kN>
HWY_INLINE void CellVisitAll(const CellTables& t, std::int64_t e0, const __m128i* e, const __m256d* fx, __m256d* res) {
  const __m256d inf = _mm256_set1_pd(HUGE_VAL);
  __m256d d1[kN], d2[kN], h1[kN];
  for (int u = 0; u < kN; ++u) d1[u] = d2[u] = inf, h1[u] = _mm256_set1_pd(-1.0);
  for (int b = 0; b < 3; ++b)
    for (int a = 0; a < 3; ++a) {
      __m256d p[kN], dy2[kN], cv[kN];
      for (int u = 0; u < kN; ++u) {
        if constexpr (kGather) {
          const __m128i ea = _mm_add_epi32(e[u], _mm_set1_epi32(a - 1));
          p[u] = _mm256_i32gather_pd(t.px[b][a], ea, 8);
          dy2[u] = _mm256_i32gather_pd(t.dy2[b], ea, 8);
          if constexpr (kRet == int(CellularReturn::CellValue)) cv[u] = _mm256_i32gather_pd(t.cv[b], ea, 8);
        } else {
          p[u] = _mm256_broadcast_sd(t.px[b][a] + e0 + a - 1);
          dy2[u] = _mm256_broadcast_sd(t.dy2[b] + e0 + a - 1);
          if constexpr (kRet == int(CellularReturn::CellValue)) cv[u] = _mm256_broadcast_sd(t.cv[b] + e0 + a - 1);
        }
      }
      CellFold<kRet, kN>(p, dy2, cv, fx, d1, d2, h1);
    }
  CellFinish<kRet, kN>(d1, d2, h1, res);
}

// The same for vectors whose lanes all lie in cell e, through that cell's list of candidates that
// can win somewhere in it (CellLists), in the reference's order.
template <int kRet, int kN>
HWY_INLINE void CellVisitList(const double* lp, const double* ld, const double* lc, int count, const __m256d* fx,
                              __m256d* res) {
  const __m256d inf = _mm256_set1_pd(HUGE_VAL);
  __m256d d1[kN], d2[kN], h1[kN];
  for (int u = 0; u < kN; ++u) d1[u] = d2[u] = inf, h1[u] = _mm256_set1_pd(-1.0);
  for (int t = 0; t < count; ++t) {
    __m256d p[kN], dy2[kN], cv[kN];
    for (int u = 0; u < kN; ++u) {
      p[u] = _mm256_broadcast_sd(lp + t);
      dy2[u] = _mm256_broadcast_sd(ld + t);
      if constexpr (kRet == int(CellularReturn::CellValue)) cv[u] = _mm256_broadcast_sd(lc + t);
    }
    CellFold<kRet, kN>(p, dy2, cv, fx, d1, d2, h1);
  }
  CellFinish<kRet, kN>(d1, d2, h1, res);
}

struct CellOctaveState {
  std::int64_t base = 0;  // cell of entry 0
  int R = 0;              // entries
  std::int64_t j = 0;     // lattice row the cached terms are for
  bool built = false;
  double* px = nullptr;   // [b][a][R]
  double* py = nullptr;   // [b][R]
  double* cv = nullptr;   // [b][R]
  double* dy2 = nullptr;  // [b][R]
  // Culling (rows of at least kCullSamples samples per cell): per cell e, the candidates that can
  // give its F1 (or F2) somewhere in the cell, in visiting order: lp, ld, lc (px, dy², cell value)
  // at e·9 + t, t < count[e].
  bool cull = false;
  double* lp = nullptr;
  double* ld = nullptr;
  double* lc = nullptr;
  double* cg = nullptr;  // [b][a][R]: the bounds' terms of px (CellLists)
  double* cm = nullptr;
  std::int32_t* count = nullptr;
};

constexpr int kCullSamples = 8;

// The candidate lists of one row (after dy2). Candidate i is dist_i(fx) = (p_i − fx)² + dy²_i over
// the cell, fx in [0, 1): at least LB_i = dy²_i + gap(p_i, [0, 1])², at most UB_i = dy²_i +
// max(p_i², (p_i − 1)²). F1 is at most min UB everywhere in the cell, so a candidate with LB_i above
// it (by a margin far beyond the rounding of dist, about 1e-15 here) is never the minimum, nor ties
// it; F2 likewise with the second smallest UB (two candidates are below it everywhere). The kept
// candidates include the ones attaining those bounds, so the fold over the list gives the same
// d1, d2 and first owner as over all nine. A row at a non-finite fy keeps all nine.
template <int kRet>
void CellLists(CellOctaveState& s, double fy) {
  constexpr bool kSecond = kRet == int(CellularReturn::F2) || kRet == int(CellularReturn::F2MinusF1);
  constexpr double kMargin = 1e-9;
  const int R = s.R;
  const bool finite = std::isfinite(fy);  // then every dy² and bound is finite
  for (int e = 1; e + 1 < R; ++e) {
    double d[9], lb[9], ub[9];
    double m1 = HUGE_VAL, m2 = HUGE_VAL;
    for (int b = 0; b < 3; ++b)
      for (int a = 0; a < 3; ++a) {
        const int t = b * 3 + a, ee = e + a - 1;
        d[t] = s.dy2[b * R + ee];
        lb[t] = d[t] + s.cg[t * R + ee];
        ub[t] = d[t] + s.cm[t * R + ee];
        if (ub[t] < m1) {
          m2 = m1;
          m1 = ub[t];
        } else if (ub[t] < m2) {
          m2 = ub[t];
        }
      }
    const double thr = (kSecond ? m2 : m1) + kMargin;
    int k = 0;
    for (int t = 0; t < 9; ++t)
      if (!finite || lb[t] <= thr) {
        const int b = t / 3, ee = e + t % 3 - 1;
        s.lp[e * 9 + k] = s.px[t * R + ee];
        s.ld[e * 9 + k] = d[t];
        s.lc[e * 9 + k] = s.cv[b * R + ee];
        ++k;
      }
    s.count[e] = k;
  }
}

void CellBuild(const NoiseOctave& o, double jitter, std::int64_t j, CellOctaveState& s) {
  std::uint64_t rk[3];
  for (int b = 0; b < 3; ++b) rk[b] = o.key + std::uint64_t(WrapI(j + b - 1, o.period_z)) * kLatticePz;
  for (int e = 0; e < s.R; ++e) {
    const std::uint64_t xw = std::uint64_t(WrapI(s.base + e, o.period_x)) * kLatticePx;
    for (int b = 0; b < 3; ++b) {
      const std::uint64_t h = mix64(rk[b] + xw);
      const double ux = double(h >> 43) * kK21 - 0.5, uy = double((h >> 22) & 0x1FFFFF) * kK21 - 0.5;
      for (int a = 0; a < 3; ++a) {
        const double p = double(a - 1) + 0.5 + jitter * ux;
        s.px[(b * 3 + a) * s.R + e] = p;
        if (s.cull) {  // CellLists' bounds: gap(p, [0, 1])² and max(p², (p − 1)²)
          const double g = p < 0.0 ? -p : p > 1.0 ? p - 1.0 : 0.0;
          s.cg[(b * 3 + a) * s.R + e] = g * g;
          s.cm[(b * 3 + a) * s.R + e] = std::max(p * p, (p - 1.0) * (p - 1.0));
        }
      }
      s.py[b * s.R + e] = double(b - 1) + 0.5 + jitter * uy;
      s.cv[b * s.R + e] = double(h & 0x3FFFFF) * kK21 - 1.0;
    }
  }
  s.j = j;
  s.built = true;
}

template <int kRet, int kFr>
void CellularRows(const NoiseKernelArgs& a, const double* z, int nrows, std::int64_t i0, double dx, int n, float* out,
                  std::ptrdiff_t stride, CellOctaveState* mst) {
  const int count = a.count;
  const __m256d iota = _mm256_setr_pd(0.0, 1.0, 2.0, 3.0), vdx = _mm256_set1_pd(dx);
  const __m256d inv = _mm256_set1_pd(a.inv_amp_sum);
  for (int r = 0; r < nrows; ++r) {
    CellTables tabs[kMaxOctaves];
    __m256d amp[kMaxOctaves], f[kMaxOctaves], off[kMaxOctaves];
    std::int64_t base[kMaxOctaves];
    __m128i emax[kMaxOctaves];
    for (int k = 0; k < count; ++k) {
      const NoiseOctave& o = a.octaves[k];
      CellOctaveState& s = mst[k];
      const double v = z[r] * o.freq_z + o.offset_z;
      const std::int64_t j = FloorI64(v);
      const double fy = v - double(j);
      if (!s.built || s.j != j) CellBuild(o, a.jitter, j, s);
      for (int b = 0; b < 3; ++b) {
        const double* py = s.py + b * s.R;
        double* dy2 = s.dy2 + b * s.R;
        for (int e = 0; e < s.R; ++e) {
          const double dy = py[e] - fy;
          dy2[e] = dy * dy;
        }
        for (int aa = 0; aa < 3; ++aa) tabs[k].px[b][aa] = s.px + (b * 3 + aa) * s.R;
        tabs[k].dy2[b] = dy2;
        tabs[k].cv[b] = s.cv + b * s.R;
      }
      if (s.cull) CellLists<kRet>(s, fy);
      amp[k] = _mm256_set1_pd(o.amp);
      f[k] = _mm256_set1_pd(o.freq_x);
      off[k] = _mm256_set1_pd(o.offset_x);
      base[k] = s.base;
      emax[k] = _mm_set1_epi32(s.R - 2);
    }
    float* dst = out + r * stride;
    // Two vectors per step (independent chains side by side); broadcast when all 8 lanes share a cell.
    auto step = [&](auto U, int i) {
      constexpr int kN = decltype(U)::value;
      __m256d acc[kN];
      for (int u = 0; u < kN; ++u) acc[u] = _mm256_setzero_pd();
      for (int k = 0; k < count; ++k) {
        __m256d fx[kN], nk[kN];
        __m128i e[kN];
        __m128i same = _mm_set1_epi32(-1);
        int e0 = 0;
        for (int u = 0; u < kN; ++u) {
          const __m256d x = _mm256_mul_pd(_mm256_add_pd(_mm256_set1_pd(double(i0 + i + 4 * u)), iota), vdx);
          const __m256d uu = _mm256_add_pd(_mm256_mul_pd(x, f[k]), off[k]);
          const __m256d fl = FloorClampedV(uu);
          fx[u] = _mm256_sub_pd(uu, fl);
          // Entry of each lane's cell: its index modulo 2³² minus the base's (the range is small).
          // Lanes past the window's end are clamped into the table (their values are not stored).
          e[u] = _mm_sub_epi32(Low32V(fl), _mm_set1_epi32(std::int32_t(std::uint32_t(base[k]))));
          e[u] = _mm_max_epi32(_mm_min_epi32(e[u], emax[k]), _mm_set1_epi32(1));
          if (u == 0) e0 = _mm_cvtsi128_si32(e[0]);
          same = _mm_and_si128(same, _mm_cmpeq_epi32(e[u], _mm_set1_epi32(e0)));
        }
        const CellOctaveState& s = mst[k];
        if (s.cull) {
          // Every lane in cell e0, or in e0 and e0 + 1 (a vector across one cell edge: both cells'
          // lists, each lane taking its own cell's result), else gathered.
          __m128i next = _mm_set1_epi32(-1);
          for (int u = 0; u < kN; ++u) next = _mm_and_si128(next, _mm_or_si128(_mm_cmpeq_epi32(e[u], _mm_set1_epi32(e0)),
                                                                             _mm_cmpeq_epi32(e[u], _mm_set1_epi32(e0 + 1))));
          auto list = [&](int c, __m256d* res) {
            CellVisitList<kRet, kN>(s.lp + c * 9, s.ld + c * 9, s.lc + c * 9, s.count[c], fx, res);
          };
          if (_mm_movemask_epi8(same) == 0xFFFF) {
            list(e0, nk);
          } else if (_mm_movemask_epi8(next) == 0xFFFF) {
            __m256d n1[kN];
            list(e0, nk);
            list(e0 + 1, n1);
            for (int u = 0; u < kN; ++u) {
              const __m256d in1 = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm_cmpeq_epi32(e[u], _mm_set1_epi32(e0 + 1))));
              nk[u] = _mm256_blendv_pd(nk[u], n1[u], in1);
            }
          } else {
            CellVisitAll<kRet, true, kN>(tabs[k], e0, e, fx, nk);
          }
        } else if (_mm_movemask_epi8(same) == 0xFFFF) {
          CellVisitAll<kRet, false, kN>(tabs[k], e0, e, fx, nk);
        } else {
          CellVisitAll<kRet, true, kN>(tabs[k], e0, e, fx, nk);
        }
        for (int u = 0; u < kN; ++u) acc[u] = FoldV<kFr>(acc[u], amp[k], nk[u]);
      }
      for (int u = 0; u < kN; ++u) Store4(FinishV<kFr>(acc[u], inv), dst + i + 4 * u, n - i - 4 * u);
    };
    int i = 0;
    for (; i + 8 <= n; i += 8) step(std::integral_constant<int, 2>(), i);
    for (; i < n; i += 4) step(std::integral_constant<int, 1>(), i);
  }
}

// The cell range of every octave over the row window; false when a table would be much larger than
// the window (more than about a cell per sample: up to 144 bytes of tables per sample otherwise,
// for little gain over the per-sample kernel).
bool CellularPrepare(const NoiseKernelArgs& a, std::int64_t i0, double dx, int n, CellOctaveState* st) {
  std::size_t total = 0;
  for (int k = 0; k < a.count; ++k) {
    const NoiseOctave& o = a.octaves[k];
    const double u0 = double(i0) * dx * o.freq_x + o.offset_x, u1 = double(i0 + n - 1) * dx * o.freq_x + o.offset_x;
    const std::int64_t c0 = FloorI64(u0), c1 = FloorI64(u1);
    const std::int64_t lo = std::min(c0, c1), hi = std::max(c0, c1);
    if (hi - lo > std::int64_t(n) + 64) return false;
    // The culling bounds take fx in [0, 1): positions within ±2⁵⁰ cells (far beyond any terrain).
    if (!(std::fabs(u0) < 0x1p50 && std::fabs(u1) < 0x1p50)) return false;
    st[k].base = lo - 1;
    st[k].R = int(hi - lo + 3);
    st[k].built = false;
    st[k].cull = std::int64_t(st[k].R) * kCullSamples <= std::int64_t(n) + 2 * kCullSamples;
    total += std::size_t(st[k].R) * (st[k].cull ? 63 : 18);
  }
  double* p = Grow(tls.d, total);
  std::size_t ints = 0;
  for (int k = 0; k < a.count; ++k) ints += st[k].cull ? std::size_t(st[k].R) : 0;
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
      st[k].ld = p + 9 * R;
      st[k].lc = p + 18 * R;
      st[k].cg = p + 27 * R;
      st[k].cm = p + 36 * R;
      p += 45 * R;
      st[k].count = q;
      q += R;
    }
  }
  return true;
}

template <int kRet>
bool CellularRet(const NoiseKernelArgs& a, const double* z, int nrows, std::int64_t i0, double dx, int n, float* out,
                 std::ptrdiff_t stride, int fr) {
  CellOctaveState st[kMaxOctaves];
  if (!CellularPrepare(a, i0, dx, n, st)) return false;
  if (fr == 1) CellularRows<kRet, 1>(a, z, nrows, i0, dx, n, out, stride, st);
  else if (fr == 2) CellularRows<kRet, 2>(a, z, nrows, i0, dx, n, out, stride, st);
  else CellularRows<kRet, 0>(a, z, nrows, i0, dx, n, out, stride, st);
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
