#pragma once
// Internal: the per-row table kernels of src/noise_rows_simd.cpp, behind Noise::row and Noise::rows
// (src/noise.cpp). Not installed, not an API.
#include <cstddef>
#include <cstdint>

#include "noise_simd.hpp"

namespace relief::detail {

// Rows r in [0, nrows) at z_m[r] into out + r·stride, each out[i], i in [0, n), the value of
// noise_row_simd(a, z_m[r], i0, dx, n, ·) bit for bit, by the block kernels of
// src/noise_rows_simd.cpp (Perlin: the corner hashes of a lattice row looked up once per cell;
// Cellular: the feature points of a lattice row computed once per cell; Simplex: x terms once per
// strip of columns for the whole block). Returns false, having
// written nothing, when the dispatched target has no such kernel (AVX2 and the AVX-512 targets have them), for other
// bases, with domain warp, for sample indices of 2⁵² and more, and for cellular windows of more than
// about a cell per sample or positions beyond 2⁵⁰ cells: the caller then uses noise_row_simd. Scratch memory: per thread, reused;
// at most about 150 bytes per sample of n (cellular) and 30 bytes per column and octave of a strip
// of up to 1024 columns (perlin).
bool noise_rows_tables_simd(const NoiseKernelArgs& a, const double* z_m, int nrows, std::int64_t i0, double dx, int n,
                            float* out, std::ptrdiff_t stride);

}  // namespace relief::detail
