// Noise bases, fractals, periodicity and domain warp, evaluated a row at a time.
//
// Sources (implemented from the papers' descriptions, not from anyone's code):
//   * Ken Perlin, "Improving Noise", SIGGRAPH 2002, and his Java reference ImprovedNoise
//     (https://mrl.cs.nyu.edu/~perlin/noise/): quintic fade, 12 gradient directions picked by
//     the low 4 bits of a permutation hash, published permutation table.
//   * Ken Perlin, simplex noise (2001), as explained by Stefan Gustavson, "Simplex noise
//     demystified" (2005): triangular lattice, three vertices per point, kernel
//     max(0, r² − |d|²)⁴ with r the triangles' height (simplex_cell; here the lattice's rows run
//     along x instead of being skewed along the diagonal).
//   * Steven Worley, "A Cellular Texture Basis Function", SIGGRAPH 1996: F1, F2, cell identity.
//   * F. K. Musgrave, in Ebert et al., "Texturing and Modeling: A Procedural Approach", ch. 16:
//     fBm, ridged multifractal, billow. Normalised by the analytic amplitude sum Σ aₖ.
//   * Inigo Quilez, "Domain warping" (2002): p' = p + w·(n₁(p), n₂(p)).
//   * D. Lemire, "Fast random integer generation in an interval" (2019): the multiply-shift
//     reduction used to draw Fisher–Yates indices and gradient indices from 64-bit hashes.
//
// Structure. Perlin: Noise::run() walks a row in chunks of kChunk samples. For each chunk it computes the
// world positions (from the integer sample index, in double), optionally displaces them by the
// two warp noises, then evaluates each octave into a scratch buffer with a basis kernel and folds
// it into an accumulator with the fractal's shaping function. Kernels are templates over whether z
// is the same for the whole chunk (no warp): then everything that depends only on z (lattice row,
// fade) is computed once per octave per chunk. No virtual calls, no allocation. Its arithmetic is
// plain double (floor via truncation, table lookups). Gradient, Value, Simplex and Cellular are
// float after a double lattice split with 32-bit hashing (run_gradient, run_simplex_reference,
// run_cellular_reference), the definitions the SIMD kernels reproduce bit for bit.
//
// Floating point: every result is a fixed sequence of IEEE double operations, so values are
// reproducible across compilers and machines as long as a·b + c is not contracted to an FMA. GCC
// contracts by default (even with -std=c++20) once the target has FMA (-march=native, x86-64-v3),
// so the pragmas below turn contraction off for this file. perlin_reference's exact Java values
// and the golden hashes in tests/test_noise.cpp depend on it. A SIMD port that wants FMA must
// state and test its tolerance against this scalar path.
#include "relief/noise.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <string>
#include <utility>

#include "noise_rows_simd.hpp"
#include "noise_simd.hpp"
#include "relief/error.hpp"
#include "relief/random.hpp"

// No FMA contraction in this file, whatever -march says (see the note at the top).
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace relief {
namespace {

// ---- Perlin's reference --------------------------------------------------------------------------

constexpr std::array<std::uint8_t, 256> kPerlinTable = {
    151, 160, 137, 91,  90,  15,  131, 13,  201, 95,  96,  53,  194, 233, 7,   225, 140, 36,  103, 30,
    69,  142, 8,   99,  37,  240, 21,  10,  23,  190, 6,   148, 247, 120, 234, 75,  0,   26,  197, 62,
    94,  252, 219, 203, 117, 35,  11,  32,  57,  177, 33,  88,  237, 149, 56,  87,  174, 20,  125, 136,
    171, 168, 68,  175, 74,  165, 71,  134, 139, 48,  27,  166, 77,  146, 158, 231, 83,  111, 229, 122,
    60,  211, 133, 230, 220, 105, 92,  41,  55,  46,  245, 40,  244, 102, 143, 54,  65,  25,  63,  161,
    1,   216, 80,  73,  209, 76,  132, 187, 208, 89,  18,  169, 200, 196, 135, 130, 116, 188, 159, 86,
    164, 100, 109, 198, 173, 186, 3,   64,  52,  217, 226, 250, 124, 123, 5,   202, 38,  147, 118, 126,
    255, 82,  85,  212, 207, 206, 59,  227, 47,  16,  58,  17,  182, 189, 28,  42,  223, 183, 170, 213,
    119, 248, 152, 2,   44,  154, 163, 70,  221, 153, 101, 155, 167, 43,  172, 9,   129, 22,  39,  253,
    19,  98,  108, 110, 79,  113, 224, 232, 178, 185, 112, 104, 218, 246, 97,  228, 251, 34,  242, 193,
    238, 210, 144, 12,  191, 179, 162, 241, 81,  51,  145, 235, 249, 14,  239, 107, 49,  192, 214, 31,
    181, 199, 106, 157, 184, 84,  204, 176, 115, 121, 50,  45,  127, 4,   150, 254, 138, 236, 205, 93,
    222, 114, 67,  29,  24,  72,  243, 141, 128, 195, 78,  66,  215, 61,  156, 180};

constexpr std::array<std::uint8_t, 512> doubled(const std::array<std::uint8_t, 256>& t) {
  std::array<std::uint8_t, 512> p{};
  for (int i = 0; i < 256; ++i) p[std::size_t(i)] = p[std::size_t(i) + 256] = t[std::size_t(i)];
  return p;
}
constexpr std::array<std::uint8_t, 512> kPerlinPerm = doubled(kPerlinTable);

// Perlin's fade 6t⁵ − 15t⁴ + 10t³ and lerp, written with his operation order (bit-exactness).
inline double fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }
inline double lerp(double t, double a, double b) { return a + t * (b - a); }

// Perlin's grad(): the low 4 bits of the hash pick one of 12 edge directions of the cube (4 twice).
constexpr double grad3(int hash, double x, double y, double z) {
  const int h = hash & 15;
  const double u = h < 8 ? x : y;
  const double v = h < 4 ? y : (h == 12 || h == 14) ? x : z;
  return ((h & 1) == 0 ? u : -u) + ((h & 2) == 0 ? v : -v);
}

// Java's (int) cast of a double: NaN → 0, saturating at the int range.
inline int java_int(double v) {
  if (v != v) return 0;
  if (v >= 2147483647.0) return 2147483647;
  if (v <= -2147483648.0) return -2147483647 - 1;
  return int(v);
}

// ---- 2D improved Perlin ---------------------------------------------------------------------------

// grad3(h, x, y, 0) as gx·x + gy·y. The coefficients are −1, 0 or 1, so every product is exact and
// the sum equals Perlin's value bit for bit (up to the sign of a zero).
struct Grad2Table {
  double x[16], y[16];
};
constexpr Grad2Table make_grad2() {
  Grad2Table t{};
  for (int h = 0; h < 16; ++h) {
    t.x[h] = grad3(h, 1.0, 0.0, 0.0);
    t.y[h] = grad3(h, 0.0, 1.0, 0.0);
  }
  return t;
}
constexpr Grad2Table kGrad2 = make_grad2();

// floor(u) as an integer. Clamped to ±2⁵¹ first so that the conversion is always defined (NaN
// becomes −2⁵¹) and so that the SIMD kernels can do the same integer work exactly in double
// (x + 1.5·2⁵² holds x's two's complement in its mantissa for |x| ≤ 2⁵¹; a period wrap by a
// multiply with 1/period is off by at most one and corrected). Plain truncation plus a correction.
inline std::int64_t floor_i64(double u) {
  constexpr double kBig = 2251799813685248.0;  // 2⁵¹
  double c = u > -kBig ? u : -kBig;
  c = c < kBig ? c : kBig;
  const std::int64_t i = std::int64_t(c);
  return i - std::int64_t(c < double(i));
}

inline std::int64_t wrap(std::int64_t i, std::int64_t period) {
  if (period == 0) return i;
  const std::int64_t r = i % period;
  return r < 0 ? r + period : r;
}

// A lattice coordinate split into the cell index, the next cell's index (both wrapped by the
// period when there is one) and the fractional position in the cell.
struct Axis {
  std::int64_t i0, i1;
  double f;
};
inline Axis axis(double u, std::int64_t period) {
  const std::int64_t i = floor_i64(u);
  Axis a;
  a.f = u - double(i);
  if (period == 0) {
    a.i0 = i;
    a.i1 = i + 1;
  } else {
    a.i0 = wrap(i, period);
    a.i1 = a.i0 + 1 == period ? 0 : a.i0 + 1;
  }
  return a;
}

// The z-only part of a 2D Perlin evaluation.
struct PerlinRow {
  int y0, y1;  // lattice rows & 255
  double fy, sy;
};
inline PerlinRow perlin_row(const Axis& az) {
  return {int(az.i0 & 255), int(az.i1 & 255), az.f, fade(az.f)};
}

// Perlin's noise(x, y, 0) with Z = 0: the hash of corner (X, Y) is p[p[p[X] + Y]]. Using (Y+1)&255
// for the upper row instead of Java's unmasked A+1 is the same entry of the doubled table.
inline double perlin_core(const std::uint8_t* p, const Axis& ax, const PerlinRow& r) {
  const int A = p[ax.i0 & 255], B = p[ax.i1 & 255];
  const int h00 = p[p[A + r.y0]] & 15, h10 = p[p[B + r.y0]] & 15;
  const int h01 = p[p[A + r.y1]] & 15, h11 = p[p[B + r.y1]] & 15;
  const double fx = ax.f, fx1 = fx - 1, fy1 = r.fy - 1;
  const double g00 = kGrad2.x[h00] * fx + kGrad2.y[h00] * r.fy;
  const double g10 = kGrad2.x[h10] * fx1 + kGrad2.y[h10] * r.fy;
  const double g01 = kGrad2.x[h01] * fx + kGrad2.y[h01] * fy1;
  const double g11 = kGrad2.x[h11] * fx1 + kGrad2.y[h11] * fy1;
  const double sx = fade(fx);
  return lerp(r.sy, lerp(sx, g00, g10), lerp(sx, g01, g11));
}

// ---- arithmetic-hash gradient noise (Gradient) -----------------------------------------------------
//
// The definition the SIMD kernel (noise_simd.cpp, GradientBasis) reproduces bit for bit: the same
// IEEE operations in the same order, float after the lattice split, no FMA.

// Lattice split of u: floor in double, the fraction rounded to float, the cell index modulo 2³²
// from the mantissa of floor(u) + 1.5·2⁵² (exact for |floor(u)| ≤ 2⁵¹; beyond that, some fixed
// index). With a period the index is wrapped into [0, period) first (exactly, see wrap_double).
struct GAxis {
  std::uint32_t i0, i1;
  float f;
};
inline double wrap_double(double fl, double period, double inv_period) {
  double w = fl - std::floor(fl * inv_period) * period;
  w = w < 0.0 ? w + period : w;
  return w >= period ? w - period : w;
}
inline std::uint32_t low32(double integral) {
  const double m = integral + detail::kMagicInt;
  std::uint64_t bits;
  std::memcpy(&bits, &m, 8);
  return std::uint32_t(bits);
}
inline GAxis gaxis(double u, std::int64_t period, double inv_period) {
  double fl = std::floor(u);
  GAxis a;
  a.f = float(u - fl);
  if (period == 0) {
    a.i0 = low32(fl);
    a.i1 = a.i0 + 1u;
  } else {
    fl = wrap_double(fl, double(period), inv_period);
    a.i0 = low32(fl);
    a.i1 = a.i0 + 1u == std::uint32_t(period) ? 0u : a.i0 + 1u;
  }
  return a;
}
inline float gfade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
inline float glerp(float t, float a, float b) { return a + t * (b - a); }
// Gradient dot product at one corner: h = (X·Pₓ ⊕ Z·P_z ⊕ key)·M; its top 3 bits pick the gradient.
inline float gcorner(std::uint32_t xp, std::uint32_t zp, float ax, float ay) {
  const std::uint32_t k = ((xp ^ zp) * detail::kGradM) >> 29;
  return detail::kGradDirX[k] * ax + detail::kGradDirY[k] * ay;
}
struct GRow {
  std::uint32_t zp0, zp1;  // Z·P_z ⊕ key of the lattice rows below and above
  float fy, fy1, sy;
};
inline GRow grow_axis(const detail::NoiseOctave& o, const GAxis& a) {
  GRow r;
  r.zp0 = (a.i0 * detail::kGradPz) ^ o.key32;
  r.zp1 = (a.i1 * detail::kGradPz) ^ o.key32;
  r.fy = a.f;
  r.fy1 = a.f - 1.0f;
  r.sy = gfade(a.f);
  return r;
}
inline GRow grow(const detail::NoiseOctave& o, double v) { return grow_axis(o, gaxis(v, o.period_z, o.inv_period_z)); }
inline float gradient_axis(const GRow& r, const GAxis& a) {
  const std::uint32_t xp0 = a.i0 * detail::kGradPx, xp1 = a.i1 * detail::kGradPx;
  const float fx = a.f, fx1 = a.f - 1.0f;
  const float g00 = gcorner(xp0, r.zp0, fx, r.fy);
  const float g10 = gcorner(xp1, r.zp0, fx1, r.fy);
  const float g01 = gcorner(xp0, r.zp1, fx, r.fy1);
  const float g11 = gcorner(xp1, r.zp1, fx1, r.fy1);
  const float sx = gfade(fx);
  return glerp(r.sy, glerp(sx, g00, g10), glerp(sx, g01, g11));
}
// Ridged (noise_simd.hpp, ridged_scale): the corner offsets scaled by s, the fades not.
inline GRow scale_row(GRow r, float s) {
  r.fy = s * r.fy;
  r.fy1 = r.fy - s;
  return r;
}
inline float gradient_axis_scaled(const GRow& r, const GAxis& a, float s) {
  const std::uint32_t xp0 = a.i0 * detail::kGradPx, xp1 = a.i1 * detail::kGradPx;
  const float fx = s * a.f, fx1 = fx - s;
  const float g00 = gcorner(xp0, r.zp0, fx, r.fy);
  const float g10 = gcorner(xp1, r.zp0, fx1, r.fy);
  const float g01 = gcorner(xp0, r.zp1, fx, r.fy1);
  const float g11 = gcorner(xp1, r.zp1, fx1, r.fy1);
  const float sx = gfade(a.f);
  return glerp(r.sy, glerp(sx, g00, g10), glerp(sx, g01, g11));
}
// Value basis (float, on the Gradient basis's lattice split and rows): the lattice value of corner
// (X, Z) is the top 24 bits of h = (X·Pₓ ⊕ Z·P_z ⊕ key)·M read as a signed integer v in [−2²³, 2²³)
// (exact in float); the corners are blended by the quintic fade and the result scaled by
// c = 2⁻²³ (a value in [−1, 1)), or by s·2⁻²³ for ridged (the octave's value is then s·n, as
// Gradient's ridged_scale).
inline float vcorner(std::uint32_t xp, std::uint32_t zp) {
  return float(std::int32_t((xp ^ zp) * detail::kGradM) >> 8);
}
inline float value_axis(const GRow& r, const GAxis& a, float c) {
  const std::uint32_t xp0 = a.i0 * detail::kGradPx, xp1 = a.i1 * detail::kGradPx;
  const float v00 = vcorner(xp0, r.zp0), v10 = vcorner(xp1, r.zp0);
  const float v01 = vcorner(xp0, r.zp1), v11 = vcorner(xp1, r.zp1);
  const float sx = gfade(a.f);
  return glerp(r.sy, glerp(sx, v00, v10), glerp(sx, v01, v11)) * c;
}
inline float gradient_core(const detail::NoiseOctave& o, const GRow& r, double u) {
  return gradient_axis(r, gaxis(u, o.period_x, o.inv_period_x));
}

// Simplex basis (issue 17: float after the lattice split, Gradient's 32-bit hash and gradient set):
// 2D simplex noise (Perlin 2001; kernel and three-vertex sum as described by Gustavson 2005) on a
// triangular lattice of unit edge whose rows run along x, so that the column work depends on x
// alone and the row work on z alone (as Gradient's lattice split). Lattice row J lies at height
// J·h (h = √3/2); its vertices are at x = C (J even) or C + ½ (J odd), labelled (C, J). Positions
// are in lattice units: u = x·f·Lx + offset (edges), v = z·f·Lz + offset (row heights), the
// factors kSimplexLx, kSimplexLz folded into each octave's frequency and offset.
//   Row (simplex_row): v split in double as gaxis, J = ⌊v⌋ modulo 2³², fr = float(v − ⌊v⌋); the
//   row offsets dyL = fr·h, dyU = dyL − h of rows J and J + 1, and cL = ¾ − dyL², cU = ¾ − dyU².
//   Column (simplex_col): u split in double as gaxis, i = ⌊u⌋, f = float(u − ⌊u⌋); the left
//   vertex of an even row is C = i at offset dE = f, of an odd row C = i − 1, dO = f + ½ when
//   f < ½, else C = i, dO = f − ½ (both in [0, 1]).
//   Sample (simplex_cell): rows J and J + 1 each contribute their left vertex (offset d) and right
//   vertex (d − 1, label C + 1), with row J's (dE, ·) or (dO, ·) by the parity of J and row J + 1
//   the other: four terms max(0, c − d²)²·²·(g·(d, dy)) (c = the row's cL or cU, g = Gradient's
//   direction picked by the top 3 bits of (C·Pₓ ⊕ J·P_z ⊕ key)·M, 8 directions at 22.5° + 45°·k,
//   length √1.375), summed as (left J + right J) + (left J+1 + right J+1), times kSimplexScale
//   (ridged: kSimplexScale·s, s = ridge_scale). The kernel radius is the triangles' height, so
//   the vertex of the four that is not the containing triangle's is at least a radius away and
//   adds 0: the classic three-vertex sum, without choosing the triangle.
// All of u and v's size stays in the double split and the 32-bit labels: the float offsets are
// within a cell whatever the distance from the origin. The supremum of the unscaled sum over
// positions and gradient choices is 0.0726755 (grid over a triangle, then local refinement), so
// |n| ≤ 10.564·0.0726755 = 0.768; the scale gives the standard deviation 0.417 (and the edge
// length 2√2/3 cycles, the RMS derivative) of the skewed-square classic simplex it replaced
// (before that, an OpenSimplex2S-style basis); the `hills` and `desert` presets rely on it.
struct SRow {
  std::uint32_t zpL, zpU;  // J·P_z ⊕ key, (J + 1)·P_z ⊕ key
  float dyL, dyU, cL, cU;
  bool odd;  // J odd
};
struct SCol {
  std::uint32_t xpE, xpO;  // C·Pₓ of the even and odd rows' left vertices
  float dE, dO;
};
inline SRow simplex_row(std::uint32_t key32, double v) {
  const double fl = std::floor(v);
  const std::uint32_t j = low32(fl);
  SRow r;
  r.dyL = float(v - fl) * detail::kSimplexHf;
  r.dyU = r.dyL - detail::kSimplexHf;
  r.cL = detail::kSimplexR2f - r.dyL * r.dyL;
  r.cU = detail::kSimplexR2f - r.dyU * r.dyU;
  r.zpL = (j * detail::kGradPz) ^ key32;
  r.zpU = (j * detail::kGradPz + detail::kGradPz) ^ key32;
  r.odd = (j & 1u) != 0;
  return r;
}
inline SCol simplex_col(double u) {
  const double fl = std::floor(u);
  SCol c;
  c.dE = float(u - fl);
  c.xpE = low32(fl) * detail::kGradPx;
  const bool lo = c.dE < 0.5f;
  c.xpO = lo ? c.xpE - detail::kGradPx : c.xpE;
  c.dO = lo ? c.dE + 0.5f : c.dE - 0.5f;
  return c;
}
inline float simplex_term(std::uint32_t xp, std::uint32_t zp, float dx, float dy, float c) {
  float a = c - dx * dx;
  a = a > 0.0f ? a : 0.0f;
  const float a2 = a * a;
  return (a2 * a2) * gcorner(xp, zp, dx, dy);
}
inline float simplex_cell(const SRow& r, const SCol& c, float sc) {
  const std::uint32_t xL = r.odd ? c.xpO : c.xpE, xU = r.odd ? c.xpE : c.xpO;
  const float dL = r.odd ? c.dO : c.dE, dU = r.odd ? c.dE : c.dO;
  const float lower = simplex_term(xL, r.zpL, dL, r.dyL, r.cL) +
                      simplex_term(xL + detail::kGradPx, r.zpL, dL - 1.0f, r.dyL, r.cL);
  const float upper = simplex_term(xU, r.zpU, dU, r.dyU, r.cU) +
                      simplex_term(xU + detail::kGradPx, r.zpU, dU - 1.0f, r.dyU, r.cU);
  return (lower + upper) * sc;
}

// Cellular basis (Worley 1996; issue 17: float after the lattice split, on Gradient's lattice and
// 32-bit labels). Per octave, u = x·fₓ + offₓ and v = z·f_z + off_z are split in double as gaxis:
// X = ⌊u⌋ modulo 2³² (wrapped into [0, P) with a period; neighbours X ± 1 modulo 2³², or modulo P),
// fx = float(u − ⌊u⌋) ∈ [0, 1] (1.0f just below an integer), the same for v → (Z, fy).
//   Hash of cell (X′, Z′): s = X′·Pₓ + (Z′·P_z ⊕ key32) modulo 2³² (the z part hoisted per row; a sum,
//   not Gradient's ⊕: with ⊕, s(−X′, −Z′) = s(X′, Z′) whenever X′ and Z′ have as many trailing zero
//   bits, since −a = a ⊕ (ones above a's lowest set bit), and a third of the cells copied their
//   point reflection about the lattice origin; issue 17), the point's
//   h = cell_mix32(s), the cell value's c = cell_mix32(s ⊕ kCellCvKey) (noise_simd.hpp).
//   Feature point, one per cell: ox = J·(float(h >> 16)·2⁻¹⁶ − ½), oy = J·(float(h & 0xFFFF)·2⁻¹⁶
//   − ½) (J = float(jitter); only the product rounds), seen from the sample's cell at offsets
//   a, b ∈ {−1, 0, 1} as px = (a + ½) + ox, py = (b + ½) + oy: inside [X′, X′ + 1) × [Z′, Z′ + 1).
//   Distance (float, no FMA): dx = px − fx, dy = py − fy, d = dx·dx + dy·dy over the 3×3 block,
//   b outer, a inner; d1, d2 the two smallest (strict <), the owner the first with the smallest.
//   Outputs: F1 2·min(√d1, 1) − 1, F2 2·min(√d2·kCellF2Scale, 1) − 1, F2 − F1 2·min(√d2 − √d1, 1)
//   − 1, CellValue float(int32(c_owner) >> 8)·2⁻²³ ∈ [−1, 1).
// A point two or more cells away along x or z is at |dx| ≥ 1 or |dy| ≥ 1 (1 is representable and
// rounding is monotone), so its d ≥ 1 while the own cell's point has d ≤ 2: F1 (clamped at 1) is
// exact against an exhaustive search; F2, F2 − F1 and CellValue are defined over the 3×3 block.
// All of u and v's size stays in the double split and the labels: the offsets have float
// precision within the cell whatever the distance from the origin (|u| < 2²⁸ cells for 24
// fraction bits); one octave repeats every 2³² cells.
struct CRow {
  std::uint32_t zp[3];  // Z′·P_z ⊕ key32 of the lattice rows Z − 1, Z, Z + 1 (wrapped)
  float fy;
};
struct CCol {
  std::uint32_t xp[3];  // X′·Pₓ of the columns X − 1, X, X + 1 (wrapped)
  float fx;
};
inline std::uint32_t cprev(std::uint32_t i, std::int64_t period) {
  return period != 0 && i == 0u ? std::uint32_t(period - 1) : i - 1u;
}
inline CRow crow(const detail::NoiseOctave& o, double v) {
  const GAxis a = gaxis(v, o.period_z, o.inv_period_z);
  CRow r;
  r.zp[0] = (cprev(a.i0, o.period_z) * detail::kGradPz) ^ o.key32;
  r.zp[1] = (a.i0 * detail::kGradPz) ^ o.key32;
  r.zp[2] = (a.i1 * detail::kGradPz) ^ o.key32;
  r.fy = a.f;
  return r;
}
inline CCol ccol(const detail::NoiseOctave& o, double u) {
  const GAxis a = gaxis(u, o.period_x, o.inv_period_x);
  CCol c;
  c.xp[0] = cprev(a.i0, o.period_x) * detail::kGradPx;
  c.xp[1] = a.i0 * detail::kGradPx;
  c.xp[2] = a.i1 * detail::kGradPx;
  c.fx = a.f;
  return c;
}
// The feature point's offsets (ox, oy) from the cell's centre, from its hash h.
inline float coff_x(std::uint32_t h, float J) { return J * (float(h >> 16) * detail::kCell2m16 - 0.5f); }
inline float coff_y(std::uint32_t h, float J) { return J * (float(h & 0xFFFFu) * detail::kCell2m16 - 0.5f); }
inline float cell_value(std::uint32_t s) {
  return float(std::int32_t(detail::cell_mix32(s ^ detail::kCellCvKey)) >> 8) * detail::kValueScale;
}
inline float cellular_cell(const CRow& r, const CCol& c, float J, CellularReturn ret) {
  float d1 = std::numeric_limits<float>::infinity(), d2 = d1;  // squared distances, F1 ≤ F2
  std::uint32_t s1 = 0;
  for (int b = 0; b < 3; ++b) {
    for (int a = 0; a < 3; ++a) {
      const std::uint32_t s = c.xp[a] + r.zp[b];
      const std::uint32_t h = detail::cell_mix32(s);
      const float px = (float(a - 1) + 0.5f) + coff_x(h, J);
      const float py = (float(b - 1) + 0.5f) + coff_y(h, J);
      const float dx = px - c.fx, dy = py - r.fy;
      const float d = dx * dx + dy * dy;
      if (d < d1) {
        d2 = d1;
        d1 = d;
        s1 = s;
      } else if (d < d2) {
        d2 = d;
      }
    }
  }
  switch (ret) {
    case CellularReturn::F1: return 2.0f * std::min(std::sqrt(d1), 1.0f) - 1.0f;
    case CellularReturn::F2: return 2.0f * std::min(std::sqrt(d2) * detail::kCellF2Scale, 1.0f) - 1.0f;
    case CellularReturn::F2MinusF1: return 2.0f * std::min(std::sqrt(d2) - std::sqrt(d1), 1.0f) - 1.0f;
    case CellularReturn::CellValue: break;
  }
  return cell_value(s1);
}

// Dyadic lattice (Gradient, lacunarity exactly 2, no period). Octave 0 is split in double as
// above (u₀ = x·f₀ + offset₀); octave k ≥ 1 is evaluated at u_k = 2ᵏ·u₀ + ½ in its own cells.
// B_k = 2ᵏ·u₀ is carried in 32.32 fixed point: cell c (modulo 2³², as the hash uses it) and
// fraction q/2³², with q₀ = ⌊frac(u₀)·2³²⌋; doubling is exact (c ← 2c + top bit of q, q ← 2q).
// Adding ½ flips q's top bit and carries it into the cell. No rounding anywhere after octave 0:
// the float fraction is q ⊕ 2³¹'s top 23 bits. Positions are thereby quantised to 2⁻³² of an
// octave-0 cell, the same resolution in metres for every octave (octave k keeps 32 − k bits of
// its own fraction, ≥ 17 at the 16th octave), independent of the distance from the origin.
// The ½ replaces the seeded per-octave offsets of the general path: it keeps every octave's
// lattice points off every other octave's (a point of octave j lands on half-integer coordinates
// of octave k), which was the offsets' purpose; the per-octave hash keys decorrelate the octaves.
// (With one octave there is nothing to step: octave 0 is the same in both paths, so count ≥ 2
// only picks the kernel.)
inline bool dyadic(const NoiseSettings& s, std::size_t count) {
  return (s.basis == NoiseBasis::Gradient || s.basis == NoiseBasis::Value) && count >= 2 && s.lacunarity == 2.0 && s.period_x_m == 0.0 &&
         s.period_z_m == 0.0;
}
struct DyAxis {
  std::uint32_t c, q, t;  // B_k's cell and fraction; t = q >> 31
};
inline GAxis dy_start(double u, DyAxis& s) {
  const double fl = std::floor(u);
  GAxis a;
  a.f = float(u - fl);
  a.i0 = low32(fl);
  a.i1 = a.i0 + 1u;
  s.c = a.i0;
  s.q = low32(std::floor((u - fl) * detail::kTwo32));
  s.t = s.q >> 31;
  return a;
}
inline GAxis dy_step(DyAxis& s) {
  s.c = s.c + s.c + s.t;
  s.q = s.q + s.q;
  s.t = s.q >> 31;
  GAxis a;
  a.i0 = s.c + s.t;
  a.i1 = a.i0 + 1u;
  const std::uint32_t bits = (s.q >> 9) ^ detail::kDyadicOne;
  float m;
  std::memcpy(&m, &bits, 4);
  a.f = m - 1.0f;
  return a;
}

// ---- one octave over a chunk ----------------------------------------------------------------------

// out[i] = basis value at lattice position (x[i]·fx + ox, z·fz + oz), z = zc when kUniformZ, else
// z[i]. Only the x work is inside the loop when z is uniform.
template <bool kUniformZ, class Oct>
void octave_chunk(NoiseBasis basis, const Oct& o, const double* x,
                  const double* z, double zc, int m, double* out) {
  auto vz = [&](int i) { return (kUniformZ ? zc : z[i]) * o.freq_z + o.offset_z; };
  auto ux = [&](int i) { return x[i] * o.freq_x + o.offset_x; };
  switch (basis) {
    case NoiseBasis::Perlin: {
      const std::uint8_t* p = o.perm.data();
      if constexpr (kUniformZ) {
        const PerlinRow r = perlin_row(axis(vz(0), o.period_z));
        for (int i = 0; i < m; ++i) out[i] = perlin_core(p, axis(ux(i), o.period_x), r);
      } else {
        for (int i = 0; i < m; ++i)
          out[i] = perlin_core(p, axis(ux(i), o.period_x), perlin_row(axis(vz(i), o.period_z)));
      }
      break;
    }
    case NoiseBasis::Gradient:
    case NoiseBasis::Value:
    case NoiseBasis::Simplex: break;  // float pipeline: Noise::run_gradient
    case NoiseBasis::Cellular: break;  // float pipeline: run_cellular_reference
  }
}

// ---- construction helpers -------------------------------------------------------------------------

// Stream tags for hash64(seed, tag, index): independent values for independent purposes.
constexpr std::uint64_t kTagTable = 0x7461626c65ull;   // "table": per-octave permutation / hash key
constexpr std::uint64_t kTagOffset = 0x6f6666736574ull;  // "offset": per-octave lattice offsets
constexpr std::uint64_t kWarpIndex = 1000;             // octave index of warp noise n1 (n2: 1001)

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

void require_positive(const char* field, double v) {
  if (!std::isfinite(v) || v <= 0.0) throw Error(field, "expected a finite number > 0, got " + num(v));
}

// Cells per period for a frequency, or 0 without a period.
std::int64_t period_cells(const char* field, double freq, double period_m) {
  if (period_m == 0.0) return 0;
  const double cells = std::max(1.0, std::round(freq * period_m));
  if (!(cells <= 2147483648.0))
    throw Error(field, "period of " + num(period_m) + " m holds " + num(cells) +
                           " lattice cells at the highest octave's frequency; at most 2^31 are supported");
  return std::int64_t(cells);
}

detail::NoiseOctave make_octave(const NoiseSettings& s, std::uint64_t index, double fx, double fz, double amp) {
  detail::NoiseOctave o;
  o.period_x = period_cells("period_x_m", fx, s.period_x_m);
  o.period_z = period_cells("period_z_m", fz, s.period_z_m);
  o.inv_period_x = o.period_x ? 1.0 / double(o.period_x) : 0.0;
  o.inv_period_z = o.period_z ? 1.0 / double(o.period_z) : 0.0;
  o.freq_x = o.period_x ? double(o.period_x) / s.period_x_m : fx;
  o.freq_z = o.period_z ? double(o.period_z) / s.period_z_m : fz;
  o.offset_x = 256.0 * unit_double(hash64(s.seed, kTagOffset, 2 * index));
  o.offset_z = 256.0 * unit_double(hash64(s.seed, kTagOffset, 2 * index + 1));
  if (s.basis == NoiseBasis::Simplex) {  // lattice units: edges along x, row heights along z
    o.freq_x *= detail::kSimplexLx;
    o.freq_z *= detail::kSimplexLz;
    o.offset_x *= detail::kSimplexLx;
    o.offset_z *= detail::kSimplexLz;
  }
  o.amp = amp;
  o.ridge_scale = detail::ridged_scale(amp);
  o.key = hash64(s.seed, kTagTable, index);
  o.key32 = std::uint32_t(o.key ^ (o.key >> 32));
  if (s.basis == NoiseBasis::Perlin) {
    o.perm = seeded_permutation(o.key);
    for (std::size_t i = 0; i < 512; ++i) o.perm32[i] = o.perm[i];
  }
  return o;
}

}  // namespace

// The tables the SIMD kernels gather from: exactly the scalar ones.
namespace detail {
#define RELIEF_TABLE16(t) {t[0], t[1], t[2], t[3], t[4], t[5], t[6], t[7], t[8], t[9], t[10], t[11], t[12], t[13], t[14], t[15]}
const double kPerlinGradX[16] = RELIEF_TABLE16(kGrad2.x);
const double kPerlinGradY[16] = RELIEF_TABLE16(kGrad2.y);
#undef RELIEF_TABLE16
}  // namespace detail

// ---- public single-octave functions ---------------------------------------------------------------

const std::array<std::uint8_t, 512>& perlin_permutation() { return kPerlinPerm; }

double perlin_reference(double x, double y, double z) {
  const std::uint8_t* p = kPerlinPerm.data();
  const int X = java_int(std::floor(x)) & 255, Y = java_int(std::floor(y)) & 255,
            Z = java_int(std::floor(z)) & 255;
  x -= std::floor(x);
  y -= std::floor(y);
  z -= std::floor(z);
  const double u = fade(x), v = fade(y), w = fade(z);
  const int A = p[X] + Y, AA = p[A] + Z, AB = p[A + 1] + Z;
  const int B = p[X + 1] + Y, BA = p[B] + Z, BB = p[B + 1] + Z;
  return lerp(w,
              lerp(v, lerp(u, grad3(p[AA], x, y, z), grad3(p[BA], x - 1, y, z)),
                   lerp(u, grad3(p[AB], x, y - 1, z), grad3(p[BB], x - 1, y - 1, z))),
              lerp(v, lerp(u, grad3(p[AA + 1], x, y, z - 1), grad3(p[BA + 1], x - 1, y, z - 1)),
                   lerp(u, grad3(p[AB + 1], x, y - 1, z - 1), grad3(p[BB + 1], x - 1, y - 1, z - 1))));
}

double perlin2(const std::uint8_t* perm512, double x, double y) {
  return perlin_core(perm512, axis(x, 0), perlin_row(axis(y, 0)));
}

std::array<std::uint8_t, 512> seeded_permutation(std::uint64_t seed) {
  std::array<std::uint8_t, 256> t{};
  for (int i = 0; i < 256; ++i) t[std::size_t(i)] = std::uint8_t(i);
  // Fisher–Yates (Durstenfeld): swap entry i with a uniform j in [0, i], for i = 255 … 1.
  for (int i = 255; i > 0; --i) {
    const std::uint64_t h = hash64(seed, std::uint64_t(i));
    const std::size_t j = std::size_t(((h >> 32) * std::uint64_t(i + 1)) >> 32);
    std::swap(t[std::size_t(i)], t[j]);
  }
  return doubled(t);
}

// ---- Noise ----------------------------------------------------------------------------------------

struct Noise::State {
  std::vector<detail::NoiseOctave> octaves;   // 1 for Fractal::None, else s_.octaves
  std::array<detail::NoiseOctave, 2> warp{};  // n1 (x displacement), n2 (z displacement); if warp_m > 0
  double inv_amp_sum = 1.0;                   // 1 / Σ aₖ
  detail::NoiseKernelArgs args;               // the kernels' view of all this (pointers into it)
};

Noise::Noise(const NoiseSettings& s) : s_(s) {
  if (unsigned(s.basis) > unsigned(NoiseBasis::Gradient)) throw Error("basis", "unknown noise basis");
  if (unsigned(s.fractal) > unsigned(Fractal::Billow)) throw Error("fractal", "unknown fractal mode");
  if (unsigned(s.cellular) > unsigned(CellularReturn::CellValue))
    throw Error("cellular", "unknown cellular return");
  if (s.octaves < 1 || s.octaves > kMaxOctaves)
    throw Error("octaves", "expected an integer in 1.." + std::to_string(kMaxOctaves) + ", got " + std::to_string(s.octaves));
  require_positive("frequency", s.frequency);
  require_positive("lacunarity", s.lacunarity);
  require_positive("persistence", s.persistence);
  require_positive("scale_x", s.scale_x);
  require_positive("scale_z", s.scale_z);
  if (!(s.jitter >= 0.0 && s.jitter <= 1.0)) throw Error("jitter", "expected 0..1, got " + num(s.jitter));
  for (auto [field, v] : {std::pair{"period_x_m", s.period_x_m}, std::pair{"period_z_m", s.period_z_m}}) {
    if (!std::isfinite(v) || v < 0.0)
      throw Error(field, "expected a finite period >= 0 m (0 = not periodic), got " + num(v));
    if (v > 0.0 && s.basis == NoiseBasis::Simplex)
      throw Error(field, "periodic noise needs basis perlin, gradient, value or cellular; simplex has no square lattice");
  }
  if (!std::isfinite(s.warp_m) || s.warp_m < 0.0)
    throw Error("warp_m", "expected a finite distance >= 0 m, got " + num(s.warp_m));
  require_positive("warp_frequency", s.warp_frequency);

  auto st = std::make_shared<State>();
  const int count = s.fractal == Fractal::None ? 1 : s.octaves;
  st->octaves.reserve(std::size_t(count));
  double f = s.frequency, amp = 1.0, amp_sum = 0.0;
  for (int k = 0; k < count; ++k) {
    const double fx = f * s.scale_x, fz = f * s.scale_z;
    if (!std::isfinite(fx) || !std::isfinite(fz) || !(fx > 0.0) || !(fz > 0.0) || !(amp > 0.0))
      throw Error(k == 0 ? "frequency" : "lacunarity",
                  "octave " + std::to_string(k) + " has frequency " + num(fx) + " x " + num(fz) +
                      " and amplitude " + num(amp) + "; expected finite and > 0");
    st->octaves.push_back(make_octave(s, std::uint64_t(k), fx, fz, amp));
    amp_sum += amp;
    f *= s.lacunarity;
    amp *= s.persistence;
  }
  if (!std::isfinite(amp_sum)) throw Error("persistence", "the octave amplitudes overflow: " + num(s.persistence));
  st->inv_amp_sum = 1.0 / amp_sum;
  if (s.warp_m > 0.0)
    for (int w = 0; w < 2; ++w)
      st->warp[std::size_t(w)] = make_octave(s, kWarpIndex + std::uint64_t(w), s.warp_frequency,
                                                  s.warp_frequency, 1.0);
  detail::NoiseKernelArgs& a = st->args;
  a.basis = s.basis;
  a.fractal = s.fractal;
  a.cellular = s.cellular;
  a.jitter = s.jitter;
  a.periodic = s.period_x_m > 0.0 || s.period_z_m > 0.0;
  a.warp = s.warp_m > 0.0;
  a.dyadic = dyadic(s, st->octaves.size());
  a.warp_m = s.warp_m;
  a.inv_amp_sum = st->inv_amp_sum;
  a.octaves = st->octaves.data();
  a.count = int(st->octaves.size());
  a.warp_octaves = st->warp.data();
  state_ = std::move(st);
}

// The float references' fractal fold (simplex, cellular; the vector kernels' FoldF): one octave's
// value `v` of amplitude `a` added to `acc` (ridged: `v` is the octave's value times its ridge scale
// `sc`, and the term is (sc − |v|)²), and the sum's end, normalised by `inv` and clamped to ±1.
static inline float fold_octave(float acc, Fractal f, float a, float sc, float v) {
  switch (f) {
    case Fractal::None:
    case Fractal::Fbm: return acc + a * v;
    case Fractal::Ridged: {
      const float r = sc - std::fabs(v);
      return acc + r * r;
    }
    case Fractal::Billow: return acc + a * (2.0f * std::fabs(v) - 1.0f);
  }
  return acc;
}
static inline float finish_octaves(float acc, float inv, bool ridged) {
  float v = ridged ? acc * (2.0f * inv) - 1.0f : acc * inv;
  v = v > -1.0f ? v : -1.0f;
  return v < 1.0f ? v : 1.0f;
}

// The Simplex basis (simplex_cell) with the fractals and warp of run_gradient, in float.
template <class St, class XAt>
void run_simplex_reference(const NoiseSettings& s, const St& st, double z_m, XAt x_at, int n, float* out) {
  const bool warp = s.warp_m > 0.0, ridged = s.fractal == Fractal::Ridged;
  const float inv = float(st.inv_amp_sum);
  const float scale = float(detail::kSimplexScale);
  auto at = [](const detail::NoiseOctave& o, double x, double z, float c) {
    return simplex_cell(simplex_row(o.key32, z * o.freq_z + o.offset_z), simplex_col(x * o.freq_x + o.offset_x), c);
  };
  for (int i = 0; i < n; ++i) {
    double x = x_at(i), z = z_m;
    if (warp) {
      const float n1 = at(st.warp[1], x, z, scale), n0 = at(st.warp[0], x, z, scale);
      z = z_m + s.warp_m * double(n1);
      x = x + s.warp_m * double(n0);
    }
    float acc = 0.0f;
    for (const detail::NoiseOctave& o : st.octaves) {
      const float sc = o.ridge_scale, a = float(o.amp);
      acc = fold_octave(acc, s.fractal, a, sc, at(o, x, z, ridged ? scale * sc : scale));
    }
    out[i] = finish_octaves(acc, inv, ridged);
  }
}

// The Cellular basis (cellular_cell) with the fractals and warp of run_gradient, in float: the
// rows hoisted per octave without warp; the warp noises promoted to double as Simplex's; ridged
// takes the octave's value as s·n (s = ridge_scale) and folds (s − |s·n|)², Value's convention.
// Fractal::None is fBm of one octave (amplitude 1, 1/Σa = 1).
template <class St, class XAt>
void run_cellular_reference(const NoiseSettings& s, const St& st, double z_m, XAt x_at, int n, float* out) {
  const bool warp = s.warp_m > 0.0, ridged = s.fractal == Fractal::Ridged;
  const float inv = float(st.inv_amp_sum), J = float(s.jitter);
  const CellularReturn ret = s.cellular;
  auto lat_u = [](const detail::NoiseOctave& o, double x) { return x * o.freq_x + o.offset_x; };
  auto lat_v = [](const detail::NoiseOctave& o, double z) { return z * o.freq_z + o.offset_z; };
  CRow rows[kMaxOctaves];
  if (!warp)
    for (std::size_t k = 0; k < st.octaves.size(); ++k) rows[k] = crow(st.octaves[k], lat_v(st.octaves[k], z_m));
  for (int i = 0; i < n; ++i) {
    double x = x_at(i), z = z_m;
    if (warp) {
      const detail::NoiseOctave &w0 = st.warp[0], &w1 = st.warp[1];
      const float n1 = cellular_cell(crow(w1, lat_v(w1, z)), ccol(w1, lat_u(w1, x)), J, ret);
      const float n0 = cellular_cell(crow(w0, lat_v(w0, z)), ccol(w0, lat_u(w0, x)), J, ret);
      z = z_m + s.warp_m * double(n1);
      x = x + s.warp_m * double(n0);
    }
    float acc = 0.0f;
    for (std::size_t k = 0; k < st.octaves.size(); ++k) {
      const detail::NoiseOctave& o = st.octaves[k];
      const float sc = o.ridge_scale, a = float(o.amp);
      const float nb = cellular_cell(warp ? crow(o, lat_v(o, z)) : rows[k], ccol(o, lat_u(o, x)), J, ret);
      acc = fold_octave(acc, s.fractal, a, sc, ridged ? sc * nb : nb);
    }
    out[i] = finish_octaves(acc, inv, ridged);
  }
}

template <class XAt>
void Noise::run(double z_m, XAt x_at, int n, float* out) const {
  constexpr int kChunk = 256;
  double xs[kChunk], zs[kChunk], nb[kChunk], acc[kChunk];
  const NoiseBasis basis = s_.basis;
  const bool warp = s_.warp_m > 0.0;
  for (int start = 0; start < n; start += kChunk) {
    const int m = std::min(kChunk, n - start);
    for (int i = 0; i < m; ++i) xs[i] = x_at(start + i);
    if (warp) {
      // Both displacements are sampled at the unwarped position, then applied together.
      octave_chunk<true>(basis, state_->warp[1], xs, nullptr, z_m, m, nb);
      for (int i = 0; i < m; ++i) zs[i] = z_m + s_.warp_m * nb[i];
      octave_chunk<true>(basis, state_->warp[0], xs, nullptr, z_m, m, nb);
      for (int i = 0; i < m; ++i) xs[i] = xs[i] + s_.warp_m * nb[i];
    }
    for (int i = 0; i < m; ++i) acc[i] = 0.0;
    for (const detail::NoiseOctave& o : state_->octaves) {
      if (warp)
        octave_chunk<false>(basis, o, xs, zs, 0.0, m, nb);
      else
        octave_chunk<true>(basis, o, xs, nullptr, z_m, m, nb);
      const double a = o.amp;
      switch (s_.fractal) {
        case Fractal::None:
        case Fractal::Fbm:
          for (int i = 0; i < m; ++i) acc[i] += a * nb[i];
          break;
        case Fractal::Ridged:
          for (int i = 0; i < m; ++i) {
            const double r = 1.0 - std::fabs(nb[i]);
            acc[i] += a * (r * r);
          }
          break;
        case Fractal::Billow:
          for (int i = 0; i < m; ++i) acc[i] += a * (2.0 * std::fabs(nb[i]) - 1.0);
          break;
      }
    }
    float* dst = out + start;
    if (s_.fractal == Fractal::Ridged) {
      for (int i = 0; i < m; ++i) dst[i] = float(2.0 * (acc[i] * state_->inv_amp_sum) - 1.0);
    } else {
      for (int i = 0; i < m; ++i) dst[i] = float(acc[i] * state_->inv_amp_sum);
    }
  }
}

// The Gradient basis in float: the same structure as run(), with float values and accumulator.
template <class XAt>
void Noise::run_gradient(double z_m, XAt x_at, int n, float* out) const {
  constexpr int kChunk = 256;
  double xs[kChunk], zs[kChunk];
  float acc[kChunk];
  DyAxis dx[kChunk], dz[kChunk];  // per-sample dyadic lattice state (x; z when warped)
  const bool warp = s_.warp_m > 0.0;
  const bool value = s_.basis == NoiseBasis::Value;  // the Value basis on the same lattice
  const float inv = float(state_->inv_amp_sum);
  if (s_.basis == NoiseBasis::Simplex) {
    run_simplex_reference(s_, *state_, z_m, x_at, n, out);
    return;
  }
  if (s_.basis == NoiseBasis::Cellular) {
    run_cellular_reference(s_, *state_, z_m, x_at, n, out);
    return;
  }
  for (int start = 0; start < n; start += kChunk) {
    const int m = std::min(kChunk, n - start);
    for (int i = 0; i < m; ++i) xs[i] = x_at(start + i);
    if (warp) {
      const detail::NoiseOctave &w0 = state_->warp[0], &w1 = state_->warp[1];
      const GRow r1 = grow(w1, z_m * w1.freq_z + w1.offset_z), r0 = grow(w0, z_m * w0.freq_z + w0.offset_z);
      for (int i = 0; i < m; ++i) {
        const double u1 = xs[i] * w1.freq_x + w1.offset_x, u0 = xs[i] * w0.freq_x + w0.offset_x;
        const float n1 = value ? value_axis(r1, gaxis(u1, w1.period_x, w1.inv_period_x), detail::kValueScale)
                               : gradient_core(w1, r1, u1);
        const float n0 = value ? value_axis(r0, gaxis(u0, w0.period_x, w0.inv_period_x), detail::kValueScale)
                               : gradient_core(w0, r0, u0);
        zs[i] = z_m + s_.warp_m * double(n1);
        xs[i] = xs[i] + s_.warp_m * double(n0);
      }
    }
    for (int i = 0; i < m; ++i) acc[i] = 0.0f;
    const bool dy = dyadic(s_, state_->octaves.size());
    const detail::NoiseOctave& o0 = state_->octaves[0];
    DyAxis dzr{};  // the row's z lattice state (dyadic, no warp)
    const GAxis az0 = dy_start(z_m * o0.freq_z + o0.offset_z, dzr);
    const bool ridged = s_.fractal == Fractal::Ridged;
    for (std::size_t k = 0; k < state_->octaves.size(); ++k) {
      const detail::NoiseOctave& o = state_->octaves[k];
      const float a = float(o.amp);
      const float sc = o.ridge_scale;  // ridged: √a folded into the corner offsets
      auto scaled = [&](const GRow& r) { return ridged && !value ? scale_row(r, sc) : r; };
      const float vc = ridged ? sc * detail::kValueScale : detail::kValueScale;
      auto eval = [&](const GRow& r, const GAxis& ax) {
        if (value) return value_axis(r, ax, vc);
        return ridged ? gradient_axis_scaled(r, ax, sc) : gradient_axis(r, ax);
      };
      GRow row;
      if (dy) row = scaled(grow_axis(o, k == 0 ? az0 : dy_step(dzr)));
      else row = scaled(grow(o, z_m * o.freq_z + o.offset_z));
      for (int i = 0; i < m; ++i) {
        float v;
        if (dy) {
          // Octave 0 starts each sample's state, later octaves step it.
          const GAxis ax = k == 0 ? dy_start(xs[i] * o.freq_x + o.offset_x, dx[i]) : dy_step(dx[i]);
          if (warp)
            row = scaled(grow_axis(o, k == 0 ? dy_start(zs[i] * o.freq_z + o.offset_z, dz[i]) : dy_step(dz[i])));
          v = eval(row, ax);
        } else {
          v = eval(warp ? scaled(grow(o, zs[i] * o.freq_z + o.offset_z)) : row,
                   gaxis(xs[i] * o.freq_x + o.offset_x, o.period_x, o.inv_period_x));
        }
        switch (s_.fractal) {
          case Fractal::None:
          case Fractal::Fbm: acc[i] = acc[i] + a * v; break;
          case Fractal::Ridged: {
            const float r = sc - std::fabs(v);  // v ≈ sc·n: r·r ≈ a·(1 − |n|)²
            acc[i] = acc[i] + r * r;
            break;
          }
          case Fractal::Billow: acc[i] = acc[i] + a * (2.0f * std::fabs(v) - 1.0f); break;
        }
      }
    }
    const float inv2 = 2.0f * inv;  // ridged: 2·(acc·inv) = acc·(2·inv), ×2 being exact
    for (int i = 0; i < m; ++i) {
      float v = ridged ? acc[i] * inv2 - 1.0f : acc[i] * inv;
      v = v > -1.0f ? v : -1.0f;  // float rounding of Σ aₖ could step past ±1 by an ulp
      out[start + i] = v < 1.0f ? v : 1.0f;
    }
  }
}

void Noise::row_reference(double z_m, std::int64_t i0, double dx_m, int n, float* out) const {
  if (s_.basis != NoiseBasis::Perlin)
    run_gradient(z_m, [=](int i) { return double(i0 + i) * dx_m; }, n, out);
  else
    run(z_m, [=](int i) { return double(i0 + i) * dx_m; }, n, out);
}

// Whether noise_rows_tables_simd is worth trying for `samples` samples: rows long enough to pay for
// its per-row tables (Perlin builds 256 entries per octave and lattice row; Cellular its lattice
// row's cells). Shorter ones, and whatever it declines, take noise_row_simd (Simplex always: its
// blocks of rows take the columns path, Noise::rows).
inline bool table_rows(const detail::NoiseKernelArgs& a, std::int64_t samples) {
  if (a.warp) return false;
  switch (a.basis) {
    case NoiseBasis::Perlin: return samples >= 128;
    case NoiseBasis::Cellular: return samples >= 32;
    default: return false;
  }
}

void Noise::row(double z_m, std::int64_t i0, double dx_m, int n, float* out) const {
  if (n <= 0) return;
  const detail::NoiseKernelArgs& a = state_->args;
  if (table_rows(a, n) && detail::noise_rows_tables_simd(a, &z_m, 1, i0, dx_m, n, out, n)) return;
  detail::noise_row_simd(a, z_m, i0, dx_m, n, out);
}

NoiseColumns Noise::columns(std::int64_t i0, double dx_m, int n) const {
  NoiseColumns c;
  c.owner_ = this;
  c.i0_ = i0;
  c.dx_ = dx_m;
  c.n_ = std::max(n, 0);
  const detail::NoiseKernelArgs a = state_->args;
  if (c.n_ == 0 || !detail::noise_columns_supported(a)) return c;
  c.stride_ = (c.n_ + 15) / 16 * 16;
  c.count_ = a.count;
  const std::size_t entries = std::size_t(detail::kColumnArrays) * std::size_t(a.count) * std::size_t(c.stride_);
  constexpr std::align_val_t kAlign{64};
  auto* p = static_cast<std::uint32_t*>(::operator new(entries * sizeof(std::uint32_t), kAlign));
  c.data_ = std::shared_ptr<const std::uint32_t>(
      p, [](const std::uint32_t* q) { ::operator delete(const_cast<std::uint32_t*>(q), std::align_val_t{64}); });
  detail::noise_columns_simd(a, i0, dx_m, c.stride_, p, c.stride_);
  return c;
}

void Noise::row(double z_m, const NoiseColumns& c, float* out) const {
  if (c.n_ <= 0) return;
  if (c.owner_ != this || !c.data_ || c.count_ != int(state_->octaves.size())) {
    row(z_m, c.i0_, c.dx_, c.n_, out);
    return;
  }
  detail::noise_row_columns_simd(state_->args, z_m, c.data_.get(), c.stride_, c.n_, out);
}

void Noise::rows(const double* z_m, int nrows, std::int64_t i0, double dx_m, int n, float* out,
                 std::ptrdiff_t stride) const {
  if (n <= 0 || nrows <= 0) return;
  const detail::NoiseKernelArgs a = state_->args;
  if (nrows == 1 || !detail::noise_columns_supported(a)) {
    if (table_rows(a, std::int64_t(n) * nrows) && detail::noise_rows_tables_simd(a, z_m, nrows, i0, dx_m, n, out, stride))
      return;
    for (int r = 0; r < nrows; ++r) row(z_m[r], i0, dx_m, n, out + r * stride);
    return;
  }
  // Strips of columns whose terms (20 bytes per column per octave) fit in about 32 KiB.
  const int strip = std::max(64, (32768 / (20 * a.count)) / 64 * 64);
  for (int c0 = 0; c0 < n; c0 += strip) {
    const NoiseColumns c = columns(i0 + c0, dx_m, std::min(strip, n - c0));
    for (int r = 0; r < nrows; ++r) row(z_m[r], c, out + r * stride + c0);
  }
}

// x = double(1)·x_m exactly: the row kernel at i0 = 1, dx = x_m evaluates at x_m.
float Noise::at(double x_m, double z_m) const {
  float v = 0.0f;
  row(z_m, 1, x_m, 1, &v);
  return v;
}

}  // namespace relief
