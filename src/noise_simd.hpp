#pragma once
// Internal: the Highway row kernels behind Noise::row (src/noise_simd.cpp) and the constants they
// share with the scalar reference (src/noise.cpp). Not installed, not an API.
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "relief/noise.hpp"

namespace relief::detail {

// Everything the row kernels need for one octave (or one warp noise), precomputed by Noise's
// constructor (src/noise.cpp). Shared by the scalar and the SIMD kernels.
struct NoiseOctave {
  double freq_x = 0.0, freq_z = 0.0;        // lattice cells per metre (anisotropy, period rounding)
  double offset_x = 0.0, offset_z = 0.0;    // seeded lattice offset in [0, 256) cells
  std::int64_t period_x = 0, period_z = 0;  // lattice cells per period; 0 = not periodic
  double inv_period_x = 0.0, inv_period_z = 0.0;  // 1 / period (0 when not periodic)
  double amp = 1.0;                         // persistenceᵏ
  float ridge_scale = 1.0f;                 // float(√amp): ridged Gradient's corner-offset scale
  std::uint64_t key = 0;                    // lattice hash key (key32's source)
  std::uint32_t key32 = 0;                  // lattice hash key (Gradient, Value, Simplex, Cellular)
  std::array<std::uint8_t, 512> perm{};     // doubled permutation (Perlin)
  std::array<std::int32_t, 512> perm32{};   // the same, widened for SIMD gathers (Perlin)
};

// 1.5·2⁵²: for an integer-valued double |x| ≤ 2⁵¹, the bits of x + kMagicInt minus the bits of
// kMagicInt are x as a two's complement int64 (same exponent, mantissa linear in x).
constexpr double kMagicInt = 6755399441055744.0;

// Gradient basis: hash multipliers (odd 32-bit constants: 2³²/φ, murmur3's c2, xxHash's
// PRIME32_3). The top 3 bits of the hash pick one of 8 gradients at 22.5° + 45°·k (the 8 evenly
// spaced directions that avoid the axes and diagonals), all of length kGradLength = √1.375, the
// RMS length of the Perlin basis's gradients (grad3(h, x, y, 0): E[gx²] = 10/16, E[gy²] = 12/16),
// which gives both bases the same variance (tests/test_noise_simd.cpp checks it, the derivative
// variance and the spectrum). Bound: |value| ≤ kGradLength·√½ < 0.83 (a point is at most √½
// cells from the corners, whose weights sum to 1).
constexpr std::uint32_t kGradPx = 0x9E3779B1u;
constexpr std::uint32_t kGradPz = 0x85EBCA6Bu;
constexpr std::uint32_t kGradM = 0x27D4EB2Fu;
constexpr double kGradLength = 1.1726039399558574;  // √1.375
constexpr double kCos22_5 = 0.92387953251128674, kSin22_5 = 0.38268343236508978;
// Direction k (index = hash >> 29), x and y components, float. 16 entries: the 8 repeated, so
// that a 16-lane table lookup needs no masking.
alignas(64) constexpr float kGradDirX[16] = {
    float(kGradLength * kCos22_5),  float(kGradLength * kSin22_5),  float(-kGradLength * kSin22_5),
    float(-kGradLength * kCos22_5), float(-kGradLength * kCos22_5), float(-kGradLength * kSin22_5),
    float(kGradLength * kSin22_5),  float(kGradLength * kCos22_5),  float(kGradLength * kCos22_5),
    float(kGradLength * kSin22_5),  float(-kGradLength * kSin22_5), float(-kGradLength * kCos22_5),
    float(-kGradLength * kCos22_5), float(-kGradLength * kSin22_5), float(kGradLength * kSin22_5),
    float(kGradLength * kCos22_5)};
alignas(64) constexpr float kGradDirY[16] = {
    float(kGradLength * kSin22_5),  float(kGradLength * kCos22_5),  float(kGradLength * kCos22_5),
    float(kGradLength * kSin22_5),  float(-kGradLength * kSin22_5), float(-kGradLength * kCos22_5),
    float(-kGradLength * kCos22_5), float(-kGradLength * kSin22_5), float(kGradLength * kSin22_5),
    float(kGradLength * kCos22_5),  float(kGradLength * kCos22_5),  float(kGradLength * kSin22_5),
    float(-kGradLength * kSin22_5), float(-kGradLength * kCos22_5), float(-kGradLength * kCos22_5),
    float(-kGradLength * kSin22_5)};

// Gradient basis, dyadic lattice (lacunarity exactly 2, no period; see noise.cpp, "Dyadic
// lattice"): octave k ≥ 1 sits at u_k = 2ᵏ·u₀ + ½ in its own cells, carried from octave 0 in 32.32
// fixed point (cell c, fraction q/2³²) by exact integer doubling. Its float fraction is the top 23
// bits of u_k's fixed-point fraction q ⊕ 2³¹, read as the mantissa of a float in [1, 2)
// (bits (q >> 9) ⊕ kDyadicOne = 0x3F800000 | ((q ⊕ 2³¹) >> 9)) minus 1: exact, always < 1.
constexpr double kTwo32 = 4294967296.0;
constexpr std::uint32_t kDyadicOne = 0x3FC00000u;

// Gradient basis, ridged fractal: octave k's amplitude aₖ enters as sₖ = float(√aₖ) scaling the
// corner offsets (fx, fx − 1, fy, fy − 1 → s·fx, s·fx − s, s·fy, s·fy − s; the fades stay on the
// unscaled fractions), so the octave's value is n' ≈ s·n and the fold is acc += (s − |n'|)²
// ≈ aₖ·(1 − |n|)²: abs, sub, mul, add instead of abs, sub, mul, mul, add. The normalisation
// 2·(acc·inv) − 1 is evaluated as acc·(2·inv) − 1 (the same bits: ×2 is exact). Kept in
// NoiseOctave::ridge_scale (computed once per Noise).
inline float ridged_scale(double amp) { return float(std::sqrt(amp)); }

// Value basis (noise.cpp, value_axis): lattice values are 24-bit signed integers, scaled by 2⁻²³
// (ridged: by ridge_scale·2⁻²³, exact) after the blend.
constexpr float kValueScale = 0x1p-23f;

// Cellular (noise.cpp, "Cellular basis"): Gradient's lattice split; the pre-hash
// s = X·Pₓ + (Z·P_z ⊕ key32) modulo 2³² (a sum, not Gradient's ⊕: issue 17), finished by cell_mix32
// (lowbias32's second half after Gradient's multiply: two multiplies, two xor-shifts; a bijection of
// the 32-bit words). The feature point's offsets are its top and low 16 bits, ·2⁻¹⁶ − ½, ·jitter;
// the cell value is cell_mix32(s ⊕ kCellCvKey)'s top 24 bits as a signed integer ·2⁻²³, Value's
// lattice value.
constexpr std::uint32_t kCellM = 0x7FEB352Du;
constexpr std::uint32_t kCellCvKey = 0x5BD1E995u;
constexpr float kCell2m16 = 1.0f / 65536.0f;            // 2⁻¹⁶
constexpr float kCellF2Scale = float(1.0 / 1.5);         // F2's scale: the output reaches 1 at F2 = 1.5
inline std::uint32_t cell_mix32(std::uint32_t t) {
  t *= kGradM;
  t ^= t >> 16;
  t *= kCellM;
  return t ^ (t >> 15);
}
// Shared with noise.cpp, which defines the tables from its constexpr generators.
// Simplex (noise.cpp, "Simplex basis"): a triangular lattice of unit edge with rows along x. Each
// octave's x frequency and offset are multiplied by kSimplexLx, its z ones by kSimplexLz, giving
// the column coordinate in edges and the row coordinate in row heights (√3/2 edges): the edge is
// 2√2/3 cycles of the frequency, the size the skewed-square definitions before it had. The
// kernel is max(0, ¾ − |d|²)⁴ (radius = the triangle's height) and the sum is scaled by
// kSimplexScale (the standard deviation 0.417 of the definitions before it; the supremum of
// the unscaled sum with Gradient's gradients is 0.0726755, so |n| ≤ 0.768).
constexpr double kSimplexLx = 1.0606601717798212866;  // 3/(2√2)
constexpr double kSimplexLz = 1.2247448713915890491;  // √(3/2)
constexpr float kSimplexHf = float(0.86602540378443864676);  // row height √3/2, in edges
constexpr float kSimplexR2f = 0.75f;                          // kernel radius², edges²
constexpr double kSimplexScale = 10.564;
extern const double kPerlinGradX[16], kPerlinGradY[16];    // grad3(h, x, y, 0) = X[h]·x + Y[h]·y

// Everything a row kernel needs, gathered by Noise::row once per call.
struct NoiseKernelArgs {
  NoiseBasis basis = NoiseBasis::Gradient;
  Fractal fractal = Fractal::Fbm;
  CellularReturn cellular = CellularReturn::F1;
  double jitter = 1.0;
  bool periodic = false;  // any octave has period_x or period_z ≠ 0
  bool warp = false;
  bool dyadic = false;    // Gradient or Value, ≥ 2 octaves, lacunarity 2, no period: the dyadic lattice
  double warp_m = 0.0;
  double inv_amp_sum = 1.0;
  const NoiseOctave* octaves = nullptr;  // count entries, 1..16
  int count = 0;
  const NoiseOctave* warp_octaves = nullptr;  // 2 entries, used when warp
};

// out[i] for i in [0, n), n ≥ 1, at x = double(i0 + i)·dx: the contract of Noise::row, evaluated by
// the best Highway target this CPU supports (or the one forced below).
void noise_row_simd(const NoiseKernelArgs& a, double z_m, std::int64_t i0, double dx, int n, float* out);

// Per-column terms (Noise::columns): the Gradient, Value and Simplex bases without warp have x-only terms.
// Layout: for octave k and array f (kColumnArrays of them: i0·Pₓ, i1·Pₓ as uint32; fx, fx − 1 and
// fade(fx) as float bits; ridged: s·fx and s·fx − s, see ridged_scale), entry i is at
// cols[(k·kColumnArrays + f)·stride + i]; stride is a multiple of 16, cols 64-byte aligned.
// Simplex's arrays: the even and the odd lattice rows' left vertex, C·Pₓ as uint32 and the
// offset dX as float bits, then an unused one (noise.cpp, simplex_col).
// Target-independent (natural lane order, exact values).
constexpr int kColumnArrays = 5;
inline bool noise_columns_supported(const NoiseKernelArgs& a) {
  return (a.basis == NoiseBasis::Gradient || a.basis == NoiseBasis::Value || a.basis == NoiseBasis::Simplex) && !a.warp;
}
// Fills the arrays for x = double(i0 + i)·dx, i in [0, npad) (npad a multiple of 16).
void noise_columns_simd(const NoiseKernelArgs& a, std::int64_t i0, double dx, int npad, std::uint32_t* cols,
                        int stride);
// out[i], i in [0, n), from the columns' terms: bit-identical to noise_row_simd over the same window.
void noise_row_columns_simd(const NoiseKernelArgs& a, double z_m, const std::uint32_t* cols, int stride, int n,
                            float* out);
// For tests and benchmarks: the Highway targets compiled into noise_simd.cpp that this CPU can run
// (best first), with their names ("AVX3", "AVX2", "SSE4", "EMU128", …).
struct SimdTarget {
  std::int64_t bits;
  std::string name;
};
std::vector<SimdTarget> noise_simd_targets();
// Makes noise_row_simd use this target (one of noise_simd_targets()); 0 restores the automatic
// choice. Global state: for single-threaded tests and benchmarks only.
void noise_simd_force_target(std::int64_t bits);
// The target noise_row_simd currently dispatches to.
std::string noise_simd_current_target();

}  // namespace relief::detail
