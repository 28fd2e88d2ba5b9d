// Thermal erosion: material slides down slopes steeper than the talus angle.
//
// Sources:
//   * F. K. Musgrave, C. E. Kolb, R. S. Mace, "The synthesis and rendering of eroded fractal
//     terrains", SIGGRAPH 1989 — thermal weathering: material moves to lower neighbours where the
//     height difference exceeds the talus threshold T.
//   * J. Olsen, "Realtime procedural terrain generation", University of Southern Denmark, 2004 —
//     the von Neumann neighbourhood (as good as Moore, half the work), the amount
//     c·(d_max − T) shared among the lower neighbours in proportion to d_k, and the erosion score
//     (standard deviation over mean of slope) used by the tests.
//
// The threshold is an angle: T = tan(talus_deg)·cell_m in metres, so previews and builds settle to
// the same slopes. The update is a Jacobi step in two row-parallel passes (outflow per cell, then
// gather from neighbours), written so that the inner loops vectorise.
#include <cmath>
#include <numbers>

#include "erosion.hpp"
#include "parallel.hpp"

namespace relief::erosion {

void thermal_iteration(const float* e, float* next, float* q, const Frame& f, double talus_deg, double rate) {
  const int nx = f.nx, nz = f.nz;
  const float T = float(std::tan(talus_deg * std::numbers::pi / 180.0) * f.cell_m() / f.height_m);
  const float c = float(rate);
  // Pass 1: outflow out = c·(d_max − T) stored in next[], and q = out / Σ_{d_k > T} d_k.
  detail::parallel_rows(nz, [&](int j) {
    const float* up = e + std::size_t(j > 0 ? j - 1 : j) * nx;
    const float* mid = e + std::size_t(j) * nx;
    const float* dn = e + std::size_t(j + 1 < nz ? j + 1 : j) * nx;
    float* out = next + std::size_t(j) * nx;
    float* qr = q + std::size_t(j) * nx;
    auto cell = [&](int i, int l, int r) {
      const float h = mid[i];
      const float d0 = h - mid[l], d1 = h - mid[r], d2 = h - up[i], d3 = h - dn[i];
      const float dmax = std::max(std::max(d0, d1), std::max(d2, d3));
      const float tot = (d0 > T ? d0 : 0.0f) + (d1 > T ? d1 : 0.0f) + (d2 > T ? d2 : 0.0f) + (d3 > T ? d3 : 0.0f);
      const float o = dmax > T ? c * (dmax - T) : 0.0f;
      out[i] = o;
      qr[i] = tot > 0.0f ? o / tot : 0.0f;
    };
    if (nx == 1) {
      cell(0, 0, 0);
      return;
    }
    cell(0, 0, 1);
    for (int i = 1; i + 1 < nx; ++i) cell(i, i - 1, i + 1);
    cell(nx - 1, nx - 2, nx - 1);
  }, 8);
  // Pass 2: new = h − out + Σ_k [h_k − h > T] · q_k · (h_k − h).
  detail::parallel_rows(nz, [&](int j) {
    const std::size_t ju = std::size_t(j > 0 ? j - 1 : j) * nx, jm = std::size_t(j) * nx,
                      jd = std::size_t(j + 1 < nz ? j + 1 : j) * nx;
    const float *up = e + ju, *mid = e + jm, *dn = e + jd;
    const float *qu = q + ju, *qm = q + jm, *qd = q + jd;
    float* out = next + jm;
    auto cell = [&](int i, int l, int r) {
      const float h = mid[i];
      const float a0 = mid[l] - h, a1 = mid[r] - h, a2 = up[i] - h, a3 = dn[i] - h;
      const float gain = (a0 > T ? qm[l] * a0 : 0.0f) + (a1 > T ? qm[r] * a1 : 0.0f) + (a2 > T ? qu[i] * a2 : 0.0f) +
                         (a3 > T ? qd[i] * a3 : 0.0f);
      out[i] = h - out[i] + gain;
    };
    if (nx == 1) {
      cell(0, 0, 0);
      return;
    }
    cell(0, 0, 1);
    for (int i = 1; i + 1 < nx; ++i) cell(i, i - 1, i + 1);
    cell(nx - 1, nx - 2, nx - 1);
  }, 8);
}

}  // namespace relief::erosion
