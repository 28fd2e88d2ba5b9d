#pragma once
// Noise3: 3D gradient and simplex noise for volumes (caves, overhangs), evaluated a row at a time
// along x with the same structure, SIMD dispatch and bit-identity rules as the 2D Noise.
//
// Sources (implementation in src/noise3.cpp, src/noise3_simd.cpp):
//   * Ken Perlin, "Improving Noise", SIGGRAPH 2002: gradient noise with quintic fade and a small
//     fixed set of gradients instead of random ones (his 12 cube edges; here 16 cube corners).
//   * Ken Perlin, "Noise hardware", SIGGRAPH 2001 course notes, and Stefan Gustavson, "Simplex
//     noise demystified" (2005): simplex noise's radial kernels max(0, r² − |d|²)⁴·(g·d) on the
//     lattice of the skewed cubic grid, which is body-centred cubic (here evaluated in rows along x).
//   * Arithmetic lattice hashing as in the 2D Gradient basis (noise.hpp) and FastNoise2.
//   * F. K. Musgrave, "Texturing and Modeling" ch. 16: fBm, ridged, billow (as Noise).
//
// Coordinates are world metres: x along a row, y (up) and z per row. The lattice frequency of
// octave k is fₖ = frequency·lacunarityᵏ cycles per metre along y, fₖ·scale_x along x and
// fₖ·scale_z along z (y is not scaled: callers pass a scaled y). Everything is a pure function of
// (settings, seed, x, y, z): any window of the world gives the same values, so volume chunks that
// share a boundary layer of samples agree on it bit for bit.
//
// Bases (single octave, in lattice units u = x·fₓ + oₓ, v = y·f_y + o_y, w = z·f_z + o_z, with
// per-octave seeded offsets oₓ, o_y, o_z in [0, 256) cells so octaves do not share lattice points):
//
//   Gradient  3D gradient noise (Perlin's construction). The lattice split (floor, fraction) is
//             done in double, everything after it in float. Corner (X, Y, Z) (cell indices modulo
//             2³²) gets gradient G[k], k = the top 4 bits of
//                 h = ((X·Pₓ) ⊕ (Y·P_y) ⊕ (Z·P_z ⊕ keyₖ))·M   (32-bit, Pₓ = 0x9E3779B1,
//                 P_y = 0x85EBCA6B, P_z = 0xC2B2AE35, M = 0x27D4EB2F),
//             and contributes G·d = G_x·d_x + (G_y·d_y + G_z·d_z) (that association, in float),
//             d the offset from the corner. The eight contributions are blended with the quintic
//             fade 6t⁵ − 15t⁴ + 10t³: first along x, then y, then z (lerp(t, a, b) = a + t·(b − a)).
//             The 16 gradients, all of length L = 1.3247: the 8 corners of a cube, (±1, ±1, ±1)·L/√3,
//             and of the same cube turned 45° about the x axis, (±1, ±√2, 0)·L/√3 and
//             (±1, 0, ±√2)·L/√3, indexed so that G[k + 8] = −G[k] (evaluated as −(G[k]·d)). The set
//             has isotropic second moments (Σ G·Gᵀ ∝ I: the derivative variance is the same along
//             x, y and z), vanishing odd moments, and is unchanged by turns of 45° about x (y and z
//             alike). Every gradient has |G_x| = L/√3, which the row kernel exploits (one G_x·d_x
//             per sample, one table lookup per corner); x thereby differs from y and z in the
//             fourth moments of the gradients (the x derivative's distribution is a little less
//             heavy-tailed), not in variance. (Perlin 2002's 12 cube edges plus 4 tetrahedral
//             directions are isotropic too, but cost two more permutes and a blend per corner:
//             2.8× the 2D Gradient's time instead of about 2×.)
//             L makes the variance equal to the 2D Gradient basis's (σ ≈ 0.253:
//             Var = (L²/3)·∫ Σ w²|d|² = (1.375/2)·∫₂ Σ w²|d|², tests/test_noise3.cpp).
//             Bound: |n| < 1.15, beyond 1 only where nearly all eight corners draw their best
//             gradient (probability ~16⁻⁸ per cell); results are clamped to [−1, 1].
//             No dyadic lattice: every octave splits its own position in double (each octave
//             has its own offsets), at any lacunarity.
//   Simplex   3D simplex noise on the body-centred cubic lattice Z³ ∪ (Z³ + ½(1, 1, 1)) (the
//             lattice of Gustavson's skewed simplex grid, turned so that its rows run along x;
//             redefined in session 16, issue 17; the skewed form of earlier versions has the same
//             lattice density, kernel, gradients and so the same spectrum, tests/test_noise3.cpp).
//             Every vertex p within r² = ½ of the position contributes max(0, ½ − |d|²)⁴·(G·d),
//             d = position − p, G from the same 16 gradients and hash as Gradient: the vertices of
//             Z³ by their (X, Y, Z) with the octave's key, those of Z³ + ½ by (X, Y, Z) (their lower
//             corner) with a second key. The sum, scaled by 81.2, is continuous (the kernel and its
//             derivative reach 0 at r) and reaches at most 4 vertices (a Delaunay tetrahedron's).
//             Evaluation: the lattice's rows along x sit on the centred square lattice
//             Z² ∪ (Z² + (½, ½)) of (v, w); only the four rows at the corners of the square cell
//             (side √½) holding (v, w) can be within r, and on each row only the two vertices that
//             bracket u. Per row (once per (y, z), in double then float): the four rows, their
//             hash terms, offsets d_y, d_z and ½ − (d_y² + d_z²) and the table of G_y·d_y + G_z·d_z.
//             Per sample: x split in double into X = floor(u) and d = float(u − X) (rows of Z³:
//             vertices X, X + 1), and for the rows of Z³ + ½, d' = d − ½, X' = X if d ≥ ½, else
//             d' = d + ½, X' = X − 1 (vertices X' + ½, X' + 3⁄2), in float; each of the 8 terms
//             is ±(G_x·d_x + table[k & 7])·max(0, (½ − (d_y² + d_z²)) − d_x²)⁴, summed as
//             ((t₀ + t₁) + (t₂ + t₃)) + ((t₄ + t₅) + (t₆ + t₇)) (rows 0, 1 of Z³, then 2, 3 of Z³ + ½,
//             lower vertex first) and scaled. Large world coordinates stay exact: all offsets are
//             relative to the cell. Sup over positions and gradient draws of the unscaled sum
//             0.0123052 (on the diagonal at 0.356·(1, 1, 1)), so |n| ≤ 0.9992; σ ≈ 0.39 at one
//             octave. Like Gradient's, the lattice is aligned with the axes: a slice parallel to
//             them cuts it at one phase (its spectrum varies a little with that phase).

// Fractals, with aₖ = persistenceᵏ and the sum in float: fBm Σ aₖ·nₖ / Σ aₖ; billow
// Σ aₖ·(2|nₖ| − 1) / Σ aₖ; ridged 2·Σ aₖ·(1 − |nₖ|)² / Σ aₖ − 1 (evaluated as acc·(2·inv) − 1,
// inv = float(1/Σ aₖ)); None: n₀ (octaves ignored). Normalised by the analytic amplitude sum,
// never by a map's min/max; every result is clamped to [−1, 1] (NaN becomes −1).
//
// Precision: positions are doubles; the lattice split is exact for |lattice coordinate| < 2⁵¹
// and float-precise (~6e-8 of a cell) after it, independent of the distance from the origin. One
// octave repeats every 2³² cells. Non-finite coordinates give unspecified values, never UB.
//
// Evaluation is vectorised with Google Highway and dispatched at run time to the best target the
// CPU supports, like Noise (noise_simd_target() names it); every target gives row_reference()'s
// bits exactly (no FMA contraction, no reassociation; tests/test_noise3.cpp forces each target).
#include <cstddef>
#include <cstdint>
#include <memory>

#include "relief/noise.hpp"

namespace relief {

class Noise3 {
 public:
  // s.basis: Gradient or Simplex (anything else throws relief::Error("basis", ...)); s.fractal
  // None/Fbm/Ridged/Billow; octaves, frequency, lacunarity, persistence, scale_x, scale_z, seed as in
  // Noise. Periods, warp and cellular options are not supported: a non-zero period_x_m, period_z_m or
  // warp_m throws relief::Error naming that field. The other fields are validated exactly as Noise
  // validates them (same fields, same messages).
  explicit Noise3(const NoiseSettings& s);

  // out[i] = value at (x = double(i0 + i)·dx_m, y_m, z_m), i in [0, n); n ≤ 0 writes nothing.
  // Values in [−1, 1]. Thread-safe, const.
  void row(double y_m, double z_m, std::int64_t i0, double dx_m, int n, float* out) const;
  // Row r (0 ≤ r < nrows) at (y_m[r], z_m[r]) goes to out + r·stride: the same bits as
  // row(y_m[r], z_m[r], i0, dx_m, n, out + r·stride). The x-only terms are computed once per strip
  // of columns (kept within ~32 KiB) and reused by every row. The way to fill a volume chunk (all
  // its rows in one call): on AVX2, gradient costs ~1.9 ns per sample and octave in long rows,
  // ~3.3 ns in 32-sample rows (each row and octave has ~20 ns of (y, z) terms). On AVX-512 (Zen 4,
  // 2-core VM under load, blocks of 16 rows): gradient ~1.8 ns in 4096-sample rows, ~3.1 ns in
  // 34-sample rows; simplex ~1.3 / ~3.7 ns (~50 ns of (y, z) terms per row and octave). Allocates
  // (row terms and columns).
  void rows(const double* y_m, const double* z_m, int nrows, std::int64_t i0, double dx_m, int n, float* out,
            std::ptrdiff_t stride) const;
  // Same bits as row(), by the plain scalar reference (no SIMD, no dispatch).
  void row_reference(double y_m, double z_m, std::int64_t i0, double dx_m, int n, float* out) const;
  // One value, bit-identical to row() at that point.
  float at(double x_m, double y_m, double z_m) const;
  const NoiseSettings& settings() const { return s_; }

 private:
  NoiseSettings s_;
  struct State;  // per-octave lattice terms (src/noise3.cpp); immutable, shared by copies
  std::shared_ptr<const State> state_;
};

}  // namespace relief
