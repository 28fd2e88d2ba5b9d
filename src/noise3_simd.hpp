#pragma once
// Internal: what Noise3's scalar reference (src/noise3.cpp) and its Highway row kernels
// (src/noise3_simd.cpp) share: the gradient set, hash constants, per-octave and per-row terms.
// Not installed, not an API.
#include <cstdint>

#include "relief/noise.hpp"

namespace relief::detail {

// Hash multipliers (odd 32-bit constants: 2³²/φ, murmur3's c1 and fmix32 constants, xxHash's
// PRIME32_4): h = ((X·Pₓ) ⊕ (Y·P_y) ⊕ (Z·P_z ⊕ key))·M, gradient k = h >> 28 (the top 4 bits).
constexpr std::uint32_t kG3Px = 0x9E3779B1u;
constexpr std::uint32_t kG3Py = 0x85EBCA6Bu;
constexpr std::uint32_t kG3Pz = 0xC2B2AE35u;
constexpr std::uint32_t kG3M = 0x27D4EB2Fu;

// Gradient length L: Var₃ = (L²/3)·I₃ equals Var₂ = (1.375/2)·I₂, the 2D Gradient basis's, with
// I₂ = ∫[0,1]² Σ_c w_c²|d_c|² = 0.0930623 and I₃ = ∫[0,1]³ Σ_c w_c²|d_c|² = 0.1093784 (quintic
// fade weights; midpoint quadrature): L = √(3·0.0639803/0.1093784) = 1.3247.
constexpr double kG3Length = 1.3247;
constexpr double kG3C = kG3Length * 0.57735026918962576;   // L/√3
constexpr double kG3R2C = kG3Length * 0.81649658092772603;  // L·√(2/3)
// The 16 gradients G[k], k = 0..15: G[k + 8] = −G[k], so a kernel looks up G[k & 7] in 8-entry
// tables (one in-register permute on AVX2) and flips the sign of the dot product by k's bit 3 (the
// hash's sign bit). The 8 representatives, all of length L, all with G_x = +L/√3:
//   k = 0..3  (1, ±1, ±1)·L/√3               the cube's body diagonals (cube A),
//   k = 4..7  (1, ±√2, 0), (1, 0, ±√2)·L/√3   the same cube turned 45° about the x axis (cube B).
// Each cube's 8 corners have isotropic second moments, so the union does (Σ G·Gᵀ = 16·(L²/3)·I), and
// the set is symmetric under turns of 45° about x (y and z alike) and under negation (all odd
// moments vanish). |G_x| being the same for all 16 is what the row kernel uses: G_x·d_x is
// ±(L/√3)·d_x, one product per sample shared by four corners, and the only per-corner lookup is the
// row's G_y·d_y + G_z·d_z. Entries 8..15 of the tables repeat 0..7 (16-lane permutes on AVX-512).
#define RELIEF_G3_C float(kG3C)
#define RELIEF_G3_R float(kG3R2C)
alignas(64) constexpr float kG3X[16] = {RELIEF_G3_C, RELIEF_G3_C, RELIEF_G3_C, RELIEF_G3_C,
                                        RELIEF_G3_C, RELIEF_G3_C, RELIEF_G3_C, RELIEF_G3_C,
                                        RELIEF_G3_C, RELIEF_G3_C, RELIEF_G3_C, RELIEF_G3_C,
                                        RELIEF_G3_C, RELIEF_G3_C, RELIEF_G3_C, RELIEF_G3_C};
alignas(64) constexpr float kG3Y[16] = {RELIEF_G3_C, RELIEF_G3_C, -RELIEF_G3_C, -RELIEF_G3_C,
                                        RELIEF_G3_R, -RELIEF_G3_R, 0.0f, 0.0f,
                                        RELIEF_G3_C, RELIEF_G3_C, -RELIEF_G3_C, -RELIEF_G3_C,
                                        RELIEF_G3_R, -RELIEF_G3_R, 0.0f, 0.0f};
alignas(64) constexpr float kG3Z[16] = {RELIEF_G3_C, -RELIEF_G3_C, RELIEF_G3_C, -RELIEF_G3_C,
                                        0.0f, 0.0f, RELIEF_G3_R, -RELIEF_G3_R,
                                        RELIEF_G3_C, -RELIEF_G3_C, RELIEF_G3_C, -RELIEF_G3_C,
                                        0.0f, 0.0f, RELIEF_G3_R, -RELIEF_G3_R};
#undef RELIEF_G3_C
#undef RELIEF_G3_R
constexpr float kG3Xc = kG3X[0];  // every representative's G_x (the kernels multiply by it)
constexpr bool g3_tables_ok() {
  for (int k = 0; k < 16; ++k)
    if (kG3X[k] != kG3Xc || kG3Y[k] != kG3Y[k & 7] || kG3Z[k] != kG3Z[k & 7]) return false;
  return true;
}
static_assert(g3_tables_ok());

// Simplex: kernel radius² and scale (see noise3.hpp). The lattice is the body-centred cubic one,
// Z³ ∪ (Z³ + ½(1, 1, 1)) in lattice units: its rows along x sit on the centred square lattice
// Z² ∪ (Z² + (½, ½)) of (y, z), and with r² = ½ a sample is reached only by the two vertices that
// bracket it on each of the four rows around it (the rows of its (y, z) cell of that lattice).
constexpr float kS3R2 = 0.5f;
constexpr float kS3Scale = 81.2f;

// Octave k's seeding (Noise3's constructor): offsets oₓ, o_y, o_z = 256·unit_double(hash64(seed,
// kTag3Offset, 3k + 0, 1, 2)) cells; key = h ⊕ (h >> 32) (low 32 bits), h = hash64(seed, kTag3Key, k);
// simplex's second key (the vertices of Z³ + ½) likewise from hash64(seed, kTag3KeyHalf, k).
constexpr std::uint64_t kTag3Key = 0x6b65793344ull;     // "key3D"
constexpr std::uint64_t kTag3Offset = 0x6f66667333ull;  // "offs3"
constexpr std::uint64_t kTag3KeyHalf = 0x6b65793348ull;  // "key3H"

// One octave: lattice frequencies (cells per metre), seeded offsets (cells), amplitude, hash key.
struct Noise3Octave {
  double freq_x = 0.0, freq_y = 0.0, freq_z = 0.0;
  double offset_x = 0.0, offset_y = 0.0, offset_z = 0.0;
  float amp = 1.0f;  // float(persistenceᵏ)
  std::uint32_t key = 0;
  std::uint32_t key_half = 0;  // simplex: the key of the vertices of Z³ + ½ (hashed by their lower corner)
};

// The terms of one octave that depend only on the row's (y, z), computed once per row by
// noise3_row_terms() (src/noise3.cpp) for the reference and the kernels alike.
struct Noise3Row {
  // The row's lattice positions v, w. No default initialisers: Noise3::row keeps 16 of these on the
  // stack and fills only `count`.
  double v, w;
  // Gradient: yz[c] = (Y·P_y) ⊕ (Z·P_z ⊕ key) for the four (y, z) corners c = b + 2·e (b: lower /
  // upper y, e: lower / upper z); ay[c], az[c] the offsets from them; fades sy, sz; and per corner
  // the values t[c][k] = G_y[k]·ay[c] + G_z[k]·az[c] (float), the row-constant half of G[k]·d
  // (k = 0..7; entries 8..15 repeat them, as the gradient tables do).
  // Simplex: the same for the four lattice rows s around (v, w) (noise3.cpp, simplex_rows): rows 0, 1
  // of Z³ (key), rows 2, 3 of Z³ + ½ (key_half, hashed by the lower corner (Y, Z) of (Y + ½, Z + ½));
  // ay, az the offsets from the row, and rc[s] = ½ − (ay² + az²) (float), the kernel's row part.
  std::uint32_t yz[4];
  float ay[4], az[4];
  float sy, sz;
  float rc[4];
  alignas(64) float t[4][16];
};
void noise3_row_terms(const Noise3Octave& o, NoiseBasis basis, double y_m, double z_m, Noise3Row& r);

// Everything a kernel needs, gathered by Noise3's constructor.
struct Noise3Args {
  NoiseBasis basis = NoiseBasis::Gradient;
  Fractal fractal = Fractal::Fbm;
  float inv = 1.0f;  // float(1 / Σ aₖ)
  const Noise3Octave* octaves = nullptr;
  int count = 0;  // 1..16
};

// out[i], i in [0, n), n ≥ 1, at x = double(i0 + i)·dx, rows[k] the row terms of octave k: the
// contract of Noise3::row, on the best Highway target (or the one forced with
// noise_simd_force_target, noise_simd.hpp).
void noise3_row_simd(const Noise3Args& a, const Noise3Row* rows, std::int64_t i0, double dx, int n, float* out);

// Gradient's x-only terms for x = double(i0 + i)·dx, i in [0, npad), npad a multiple of 16: per
// octave k, 4 arrays (X·Pₓ as uint32; G_x·fx, G_x·(fx − 1) and fade(fx) as float bits), entry i of
// array f at cols[(k·kG3ColumnArrays + f)·stride + i]; stride a multiple of 16, cols 64-byte aligned.
constexpr int kG3ColumnArrays = 4;
// Simplex's x-only terms, the same way: per octave k, for phase p = 0 (the vertices of Z³ along the
// row: lower vertex X = floor(u), d = u − X) and p = 1 (of Z³ + ½: lower vertex X' + ½, d' = d − ½ or
// d + ½), 5 arrays each: X·Pₓ (uint32), G_x·d, G_x·(d − 1), d², (d − 1)² (float bits), array
// f = 5p + j at cols[(k·kS3ColumnArrays + f)·stride + i].
constexpr int kS3ColumnArrays = 10;
void noise3_columns_simd(const Noise3Args& a, std::int64_t i0, double dx, int npad, std::uint32_t* cols, int stride);
// out[i], i in [0, n), from the columns' terms: bit-identical to noise3_row_simd over that window.
void noise3_row_columns_simd(const Noise3Args& a, const Noise3Row* rows, const std::uint32_t* cols, int stride, int n,
                             float* out);

}  // namespace relief::detail
