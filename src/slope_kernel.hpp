#pragma once
// Internal: the row kernel of the slope stage (stage_color.cpp), one Highway kernel per SIMD
// target (slope_kernel.cpp), runtime dispatch.
//
// For sample i of an interior row (1 ≤ i ≤ n − 2, rows up / mid / down = j − 1, j, j + 1) of a
// one-channel height layer it writes, bit for bit what the scalar definitions give:
//   slope[i]     = float((|e − up[i−1]| + |e − up[i]| + |e − up[i+1]| + |e − mid[i−1]|
//                         + |e − mid[i+1]| + |e − down[i−1]| + |e − down[i]| + |e − down[i+1]|) / 8)
//                  with e = mid[i], every term and sum in double, added in that order;
//   slope_deg[i] = float(atan(hypot(gx, gz)) · 180/π) in double (std::atan, std::hypot), with
//                  gx = (y(mid[i+1]) − y(mid[i−1])) / (2·cell), gz = (y(down[i]) − y(up[i])) / (2·cell),
//                  y(e) = (e − sea_level) · height_m (Frame::y_m), the differences of surface.hpp.
// slope_deg without an atan per sample: the angle is evaluated in double with a polynomial
// (relative error below 1e-14 from the scalar definition's double), and that value is rounded to
// float only when every double within 2^-40 of it (relative) rounds to the same float, which then
// is the scalar definition's float; otherwise (about 3 samples in 100 000, and any non-finite or
// extreme gradient) the sample is recomputed with the scalar definition. Hence the same bits on
// every target, as the scalar code. Columns 0 and n − 1 are not written.
namespace relief::detail {

struct SlopeRow {
  double sea_level = 0.4;  // Frame::sea_level
  double height_m = 600;   // Frame::height_m
  double cell2_m = 2;      // 2 · Frame::cell_m()
};

// Interior samples 1 … n − 2 of one row (n ≥ 3; the rows hold n values each).
void slope_row(const SlopeRow& k, const float* up, const float* mid, const float* down, float* slope,
               float* slope_deg, int n);

// The scalar definition of slope_deg[i] above (the reference and the kernel's fallback).
float slope_deg_reference(const SlopeRow& k, const float* up, const float* mid, const float* down, int i);

// Name of the Highway target slope_row dispatches to (tests).
const char* slope_target();

}  // namespace relief::detail
