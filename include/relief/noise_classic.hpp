#pragma once
// Classic noise with a fixed permutation: the functions of the Python `noise` package (Casey
// Duncan's "noise" 1.2.3, Debian python3-noise), implemented here from the published algorithms so
// that code written against that package (seed 001's heightmap blog post: `noise.snoise2(…)`) gives
// the same values through relief.compat — and runs over whole arrays.
//
// Sources:
//   * Ken Perlin, "Noise hardware", SIGGRAPH 2001 course notes (simplex noise), as explained and
//     coded by Stefan Gustavson, "Simplex noise demystified" (2005): skewed simplex lattice,
//     radial kernel max(0, r² − d²)⁴ (r² = 0.5 in 2D, 0.6 in 3D and 4D), the 12 cube-edge gradients
//     in 2D/3D and 32 gradients in 4D, Perlin's published permutation of 0..255.
//   * Ken Perlin, "Improving Noise", SIGGRAPH 2002 (improved gradient noise, quintic fade).
//
// Values, to the bit, as the package computes them (but the sign of an exact zero, see
// noise_classic.cpp): float32 arithmetic in the package's order of operations (no FMA), the
// package's scale factors (70 in 2D, 32 in 3D, 27 in 4D), and its choices where they differ from
// the textbook:
//   * snoise2's `base` is added to x and y of every octave (after scaling by the octave's
//     frequency); with repeatx/repeaty, x (and/or y) is wrapped onto a circle of circumference
//     `repeat` with the package's fast sine approximation and 3D or 4D simplex noise is sampled on
//     it (so tiled snoise2 is a different function from untiled snoise2; base then shifts z/w);
//   * pnoise's lattice wraps every `repeat` cells (fmod), then every 256 cells (the table), and
//     `base` shifts table indices. Where the package would index past its 512-entry table
//     (base ≥ 2, in a few cells; negative base) we use the table's own period (index & 511), so
//     those cells may differ from the package, whose value there depends on memory past its table.
// Ranges: simplex2/3/4 stay within about ±1 (the package's scale factors are not exact bounds;
// tests/python record the observed extremes); improved2/3 within ±1.
//
// Every function is pure, thread-safe and deterministic. Fractal sums are Σ aₖ·n(freqₖ·p) / Σ aₖ
// with aₖ = persistenceᵏ, freqₖ = lacunarityᵏ, accumulated in float as the package does.
// Arguments are float (the package converts Python floats to C float first).
#include <cstddef>
#include <limits>

namespace relief::classic {

// No repeat (the package's default for snoise2, FLT_MAX).
constexpr float kNoRepeat = std::numeric_limits<float>::max();

// Single octaves.
float simplex2(float x, float y);
float simplex3(float x, float y, float z);
float simplex4(float x, float y, float z, float w);
float improved2(float x, float y, float repeatx, float repeaty, int base);
float improved3(float x, float y, float z, int repeatx, int repeaty, int repeatz, int base);

// The package's Python-level functions (octaves ≥ 1; the caller refuses octaves ≤ 0 as the package
// does). repeatx/repeaty = kNoRepeat: not tiled.
float snoise2(float x, float y, int octaves, float persistence, float lacunarity, float repeatx, float repeaty, float base);
float snoise3(float x, float y, float z, int octaves, float persistence, float lacunarity);
float pnoise2(float x, float y, int octaves, float persistence, float lacunarity, float repeatx, float repeaty, int base);
float pnoise3(float x, float y, float z, int octaves, float persistence, float lacunarity, int repeatx, int repeaty, int repeatz,
              int base);

// Arrays: out[k] = f(x[k], y[k] (, z[k])) for k in [0, n), the same values as the scalar functions
// above, bit for bit, computed in blocks with the octave loop outside the point loop (vectorised
// where the CPU allows: AVX-512, AVX2 or SSE2, chosen at run time). Not thread-parallel: callers
// split the range (results do not depend on how).
struct ClassicFractal {
  int octaves = 1;
  float persistence = 0.5f, lacunarity = 2.0f;
};
void snoise2(const float* x, const float* y, std::size_t n, const ClassicFractal& f, float repeatx, float repeaty, float base, float* out);
void snoise3(const float* x, const float* y, const float* z, std::size_t n, const ClassicFractal& f, float* out);
void pnoise2(const float* x, const float* y, std::size_t n, const ClassicFractal& f, float repeatx, float repeaty, int base, float* out);
void pnoise3(const float* x, const float* y, const float* z, std::size_t n, const ClassicFractal& f, int repeatx, int repeaty,
             int repeatz, int base, float* out);

}  // namespace relief::classic
