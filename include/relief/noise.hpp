#pragma once
// Noise: our own implementations, evaluated a whole row per call (no per-sample virtual dispatch).
//
// Sources:
//   * Ken Perlin, "Improving Noise", SIGGRAPH 2002 (improved gradient noise, quintic fade).
//     With Perlin's published permutation, perlin_reference(x, y, z) reproduces his Java
//     ImprovedNoise.noise exactly (double precision).
//   * Simplex noise (Ken Perlin, 2001), as explained by Stefan Gustavson, "Simplex noise
//     demystified" (2005): gradient noise on a triangular lattice, three vertices per point.
//   * Steven Worley, "A Cellular Texture Basis Function", SIGGRAPH 1996 (F1, F2, cell id).
//   * Gradient: our arithmetic-hash gradient noise (Perlin's construction, with the permutation
//     table replaced by an integer hash of the lattice coordinates as in FastNoise2 and
//     FastNoise Lite, and eight evenly spaced gradients), evaluated in float, SIMD-friendly.
//   * Fractals: fBm, ridged multifractal and billow (Musgrave, "Texturing and Modeling", ch. 16),
//     normalised by the analytic sum of octave amplitudes, never by a map's own min/max.
//
// Coordinates are world metres. `frequency` is in cycles per metre of the first octave; the x and
// z axes are additionally multiplied by `scale_x`, `scale_z` (anisotropy). Everything is a pure
// function of (settings, seed, x, z): any window of the world gives the same values.
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace relief {

enum class NoiseBasis { Perlin, Simplex, Value, Cellular, Gradient };
enum class Fractal { None, Fbm, Ridged, Billow };

// Most octaves a fractal sums (Noise's constructor refuses more; the parameter tables' limit).
constexpr int kMaxOctaves = 16;
enum class CellularReturn { F1, F2, F2MinusF1, CellValue };

struct NoiseSettings {
  NoiseBasis basis = NoiseBasis::Perlin;
  Fractal fractal = Fractal::Fbm;
  int octaves = 6;             // 1..kMaxOctaves
  double frequency = 1.0 / 1000.0;  // cycles per metre (first octave)
  double lacunarity = 2.0;     // frequency ratio between octaves
  double persistence = 0.5;    // amplitude ratio between octaves (gain)
  double scale_x = 1.0, scale_z = 1.0;  // anisotropy: multiply x and z frequency
  CellularReturn cellular = CellularReturn::F1;
  double jitter = 1.0;         // cellular feature point jitter, 0..1
  // Periodicity: when > 0 the noise repeats every period_x metres along x (likewise z).
  // Each octave's frequency is rounded so that a whole number of lattice cells fits the period.
  // Supported for Perlin, Gradient, Value and Cellular; Simplex with a period makes the constructor throw
  // relief::Error("period_x_m" / "period_z_m"). Rounding: octave k has nominal frequency
  // fₖ = frequency·lacunarityᵏ·scale_x; it uses Nₖ/period_x_m with Nₖ = max(1, round(fₖ·period_x_m))
  // whole lattice cells per period, and lattice indices wrap modulo Nₖ (likewise z).
  double period_x_m = 0.0, period_z_m = 0.0;
  // Domain warp (Quilez): x += warp_m · n1(x, z), z += warp_m · n2(x, z), n1, n2 single-octave
  // noise of the same basis (and cellular return) at warp_frequency, isotropic (scale_x/z do not
  // apply), periodic like the main noise when a period is set. 0 disables it.
  double warp_m = 0.0;
  double warp_frequency = 1.0 / 1000.0;
  std::uint64_t seed = 0;
};

class Noise;

// The terms of a window of columns that depend only on x (per octave: the lattice cells' hash
// terms i0·Pₓ and i1·Pₓ, the fraction fx, fx − 1 and its fade; Simplex: the left vertex of an even
// and of an odd lattice row), computed once by Noise::columns() and reused for every row:
// Noise::row(z_m, columns, out) then only does the per-row work. Only the Gradient, Value and Simplex bases
// without domain warp have such terms (warp moves x per row); for every other
// setting the object just remembers the window and row() falls back to the plain row kernel. The
// values are the same, bit for bit, either way. Memory: 20 bytes per column per octave.
class NoiseColumns {
 public:
  std::int64_t i0() const { return i0_; }
  double dx_m() const { return dx_; }
  int size() const { return n_; }
  bool precomputed() const { return data_ != nullptr; }

 private:
  friend class Noise;
  const Noise* owner_ = nullptr;  // used only with the Noise that built it (else: plain rows)
  std::int64_t i0_ = 0;
  double dx_ = 0.0;
  int n_ = 0;
  int stride_ = 0;                   // entries per array: n rounded up to 16
  int count_ = 0;                    // octaves
  // Per octave 5 arrays (i0·Pₓ, i1·Pₓ, fx, fx − 1, fade(fx)), 64-byte aligned; immutable, so
  // copies share it. Null when not precomputed.
  std::shared_ptr<const std::uint32_t> data_;
};

// A compiled noise generator. Construction validates the settings (throwing relief::Error naming
// the field: "octaves", "frequency", "lacunarity", "persistence", "scale_x", "scale_z", "jitter",
// "period_x_m", "period_z_m", "warp_m", "warp_frequency", "basis", "fractal", "cellular") and
// builds one seeded permutation table per octave for Perlin (a Fisher–Yates shuffle driven by mix64,
// as seed 002 describes) plus a seeded lattice offset per octave, so octaves are decorrelated and
// their lattices do not line up (no common zeros at the first octave's lattice points).
// Evaluation is const and thread-safe.
//
// Bases (single octave, in lattice units of that octave):
//   Gradient  2D gradient noise with quintic fade; the gradient of lattice point (X, Z) is one of
//             8 directions at 22.5° + 45°·k picked by hash32((X·Pₓ) ⊕ (Z·P_z ⊕ keyₖ)), scaled so
//             that its statistics match Perlin's (range, mean, spread, spectrum: see
//             tests/test_noise_simd.cpp). Cell indices are taken modulo 2³² (exact while
//             |lattice coordinate| < 2⁵¹), so one octave repeats every 2³² cells. The lattice split
//             (floor, fraction) is done in double, everything after it in float, so its precision
//             is float's (~6e-8 relative), independent of the distance from the origin.
//             Dyadic lattice: with lacunarity exactly 2 and no period, octave k ≥ 1 is evaluated at
//             2ᵏ·u₀ + ½ of its own cells (u₀: octave 0's lattice position, which keeps its seeded
//             offset) instead of at a seeded offset of its own, carried from octave 0 exactly in
//             32.32 fixed point: no per-octave double split, positions quantised to 2⁻³² of an
//             octave-0 cell (octave k keeps 32 − k bits of its fraction). The ½ keeps every
//             octave's lattice points off every other octave's; the per-octave hash keys
//             decorrelate them (tests/test_noise_simd.cpp compares the statistics).
//   Perlin    improved Perlin 2D (exactly perlin2 with the octave's table); one octave repeats
//             every 256 of its own cells (the table's period), the per-octave tables and offsets
//             keep the octaves of a sum from repeating together.
//   Simplex   2D simplex on a triangular lattice whose rows run along x (edge 2√2/3 cycles):
//             x is split into lattice columns and z into lattice rows in double, as Gradient's
//             axes, then in float Σ over the two nearest vertices of each of the two lattice rows
//             around the point (the one not in its triangle adds 0) of max(0, ¾ − |d|²)⁴ · (g·d)
//             in edge units, g one of Gradient's 8 directions picked by Gradient's hash, times
//             10.564: |n| ≤ 0.768, with the standard deviation (0.417) and derivative variance of
//             the skewed classic simplex and the OpenSimplex2S-style basis before it (whose look
//             `hills` keeps). Indices modulo 2³² as Gradient's; no period.
//   Value     hashed lattice values in [−1, 1) with quintic interpolation, on Gradient's lattice (the
//             same split in double, float after it, the same period support and, at lacunarity 2
//             without a period, the same dyadic lattice): the value of lattice point (X, Z) is the
//             top 24 bits of hash32((X·Pₓ) ⊕ (Z·P_z ⊕ keyₖ)) as a signed integer times 2⁻²³.
//   Cellular  Worley on Gradient's lattice (the same split in double, float after it, the same
//             period support): one feature point per cell at its centre + jitter·(U − ½, V − ½),
//             U and V the top and low 16 bits of h = mix32(s) times 2⁻¹⁶, s = X·Pₓ + (Z·P_z ⊕ keyₖ)
//             modulo 2³² (a sum: Value's ⊕ made a third of the cells repeat their point
//             reflection about the lattice origin; mix32: Gradient's multiply, then lowbias32's
//             xor-shift, multiply, xor-shift), the distances in float over the 3×3 block; F1, F2
//             the two smallest; the owner (whose CellValue is returned) is, on equal distances,
//             the first of the block in row-major order (offset b = −1, 0, 1 outer along z,
//             a = −1, 0, 1 inner along x). F1 is exact after clamping to 1 cell. F2, F2−F1 and (only where F1 ≥ 1 cell) CellValue can differ
//             from an exhaustive search in the rare cases where the point they need lies outside
//             the 3×3 block. CellValue: the top 24 bits of mix32(s ⊕ 0x5BD1E995) (s the owning
//             cell's pre-hash) as a signed integer times 2⁻²³. Continuous to float rounding:
//             a point seen from two neighbouring cells is rounded at different offsets, so F1
//             can step by about 1e-6 at a cell edge.
//
// Precision: positions are doubles; Perlin does the lattice work in double and rounds the result to
// float once, clamping lattice coordinates to ±2⁵¹ cells; Gradient, Value, Simplex and Cellular work
// in float after the lattice split and take the split's integer part modulo 2³² unclamped (beyond
// 2⁵¹ cells a double no longer holds the fraction, so the pattern degrades there, the same bits on
// every path; the float offsets keep float precision within the cell below about 2²⁸ cells). Coordinates must be finite
// (non-finite ones give unspecified values, never UB). No contraction of a product into a sum (see
// noise.cpp): the few fused multiply-adds in src/noise_rows_simd.cpp multiply by ±1 or 2, exactly,
// so they round as the plain add or subtract they replace.
//
// Evaluation is vectorised with Google Highway, dispatched at run time to the best target this CPU
// supports (AVX-512, AVX2, SSE4 or a portable scalar emulation): per-sample kernels in
// src/noise_simd.cpp (src/noise3_simd.cpp in 3D), and on the AVX2 and AVX-512 targets block-of-rows
// kernels for Perlin and cellular in src/noise_rows_simd.cpp. Every target gives
// bit-identical results to row_reference(), the plain scalar implementation.
class Noise {
 public:
  explicit Noise(const NoiseSettings& s);

  // out[i] = value at (x, z_m) with x = double(i0 + i) · dx_m, for i in [0, n): positions come from
  // the integer sample index so that any window of the same grid gives bit-identical values.
  // n ≤ 0 writes nothing. Values are in [−1, 1], with aₖ = persistenceᵏ:
  //   fBm: Σ aₖ·nₖ / Σ aₖ;  billow: Σ aₖ·(2|nₖ|−1) / Σ aₖ;  ridged: 2·Σ aₖ·(1−|nₖ|)² / Σ aₖ − 1;
  //   None: n₀ (only the first octave is evaluated; octaves is ignored).
  //   Cellular F1/F2 are mapped from distance d (in cells) as 2·min(d,1)−1 (F2: d/1.5, F2−F1: d),
  //   CellValue is a hash of the owning cell in [−1, 1), all in float; ridged cellular takes octave
  //   k's value as sₖ·nₖ (sₖ = float(√aₖ)) and sums (sₖ − |sₖ·nₖ|)², as Gradient and Value do.
  void row(double z_m, std::int64_t i0, double dx_m, int n, float* out) const;
  // Precomputes the x-only terms of the window x = double(i0 + i) · dx_m, i in [0, n) (NoiseColumns).
  NoiseColumns columns(std::int64_t i0, double dx_m, int n) const;
  // The same values as row(z_m, c.i0(), c.dx_m(), c.size(), out), bit for bit, reusing c's terms.
  void row(double z_m, const NoiseColumns& c, float* out) const;
  // A block of rows: row r (0 ≤ r < nrows) at z_m[r] goes to out + r·stride, with the same values
  // as row(z_m[r], i0, dx_m, n, out + r·stride), bit for bit. The x-only terms are computed once
  // per strip of columns (small enough to stay in L1) and reused for every row of the block.
  void rows(const double* z_m, int nrows, std::int64_t i0, double dx_m, int n, float* out,
            std::ptrdiff_t stride) const;
  // The same values as row(), bit for bit, computed by the scalar reference implementation (no
  // SIMD, no dispatch): the definition the vector kernels are tested against. Several times slower.
  void row_reference(double z_m, std::int64_t i0, double dx_m, int n, float* out) const;
  // One value; bit-identical to row() at the same (x_m, z_m).
  float at(double x_m, double z_m) const;
  const NoiseSettings& settings() const { return s_; }

 private:
  template <class XAt>
  void run(double z_m, XAt x_at, int n, float* out) const;
  template <class XAt>
  void run_gradient(double z_m, XAt x_at, int n, float* out) const;

  NoiseSettings s_;
  // The octaves' precomputed lattice terms and tables (src/noise.cpp): built by the constructor,
  // immutable after it, so copies of a Noise share them.
  struct State;
  std::shared_ptr<const State> state_;
};

// ---- single-octave bases (for tests and reference; values nominally in [−1, 1]) -------------
// Ken Perlin's ImprovedNoise with his published permutation table, in double precision.
double perlin_reference(double x, double y, double z);
// Improved Perlin 2D with a given doubled permutation table. Equal to perlin_reference(x, y, 0)
// when `perm` is Perlin's table.
double perlin2(const std::uint8_t* perm512, double x, double y);
// Perlin's published permutation, doubled to 512 entries.
const std::array<std::uint8_t, 512>& perlin_permutation();
// A seeded permutation (Fisher–Yates with mix64), doubled to 512 entries.
std::array<std::uint8_t, 512> seeded_permutation(std::uint64_t seed);

// The name of the Highway target Noise's row kernels dispatch to on this machine (e.g. "AVX2"),
// for benchmark tables and reports. Thread-safe; the same for the life of the process unless a
// test forces a target.
std::string noise_simd_target();

}  // namespace relief
