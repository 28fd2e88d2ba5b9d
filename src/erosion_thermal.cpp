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
//   * Google Highway (github.com/google/highway): foreach_target multi-target compilation and
//     HWY_DYNAMIC_DISPATCH, once per block of rows.
//
// The threshold is an angle: T = tan(talus_deg)·cell_m in metres, so previews and builds settle to
// the same slopes. The update is a Jacobi step. It is fused into one pass over the map: blocks of
// rows run in parallel, and each block keeps the outflow and share rows (pass 1 below) of the last
// three rows in a small ring, computing a row's gather (pass 2) as soon as the row below has its
// outflow. A block recomputes the outflow of the rows just above and below it (its halo), so each
// elevation is read from memory about once and each new elevation written once.
//
// Exactness across Highway targets: every cell is computed by the same float operations in the
// same order (lane-wise compare, select, add in the fixed order d0, d1, d2, d3; IEEE division),
// whether in a vector lane or in the scalar code used at the row ends and the tail; the build uses
// -ffp-contract=off. Results are therefore bit-identical for every target and every thread count
// (tests/test_erosion.cpp forces each compiled target).

// The shared part below is compiled once; foreach_target re-includes this file per target.
#ifndef RELIEF_EROSION_THERMAL_SHARED
#define RELIEF_EROSION_THERMAL_SHARED
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <memory>
#include <numbers>

#include "relief/erosion.hpp"

namespace relief::erosion::thermal_kernel {

struct Args {
  const float* e = nullptr;
  float* next = nullptr;
  int nx = 0, nz = 0;
  float T = 0, c = 0;
};

// Pass 1 for one cell: outflow o = c·(d_max − T) and share q = o / Σ_{d_k > T} d_k.
inline void outflow_cell(float h, float l, float r, float u, float d, float T, float c, float& o, float& q) {
  const float d0 = h - l, d1 = h - r, d2 = h - u, d3 = h - d;
  const float dmax = std::max(std::max(d0, d1), std::max(d2, d3));
  const float tot = (d0 > T ? d0 : 0.0f) + (d1 > T ? d1 : 0.0f) + (d2 > T ? d2 : 0.0f) + (d3 > T ? d3 : 0.0f);
  o = dmax > T ? c * (dmax - T) : 0.0f;
  q = tot > 0.0f ? o / tot : 0.0f;
}

// Pass 2 for one cell: new = h − o + Σ_k [h_k − h > T] · q_k · (h_k − h).
inline float gather_cell(float h, float o, float l, float r, float u, float d, float ql, float qr, float qu, float qd,
                         float T) {
  const float a0 = l - h, a1 = r - h, a2 = u - h, a3 = d - h;
  const float gain = (a0 > T ? ql * a0 : 0.0f) + (a1 > T ? qr * a1 : 0.0f) + (a2 > T ? qu * a2 : 0.0f) +
                     (a3 > T ? qd * a3 : 0.0f);
  return h - o + gain;
}

}  // namespace relief::erosion::thermal_kernel
#endif  // RELIEF_EROSION_THERMAL_SHARED

// ---- the per-target row kernels ------------------------------------------------------------------
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "erosion_thermal.cpp"
#include "hwy_kernels.hpp"  // the target list, foreach_target.h, highway.h, no FP contraction

HWY_BEFORE_NAMESPACE();
namespace relief::erosion::thermal_kernel {
namespace HWY_NAMESPACE {
namespace {

namespace hn = hwy::HWY_NAMESPACE;

// Pass 1 over row `mid` (with the rows above and below, clamped at the map's edge by the caller).
HWY_INLINE void OutflowRow(const float* HWY_RESTRICT up, const float* HWY_RESTRICT mid, const float* HWY_RESTRICT dn,
                           int nx, float T, float c, float* HWY_RESTRICT out, float* HWY_RESTRICT q) {
  if (nx == 1) {
    outflow_cell(mid[0], mid[0], mid[0], up[0], dn[0], T, c, out[0], q[0]);
    return;
  }
  outflow_cell(mid[0], mid[0], mid[1], up[0], dn[0], T, c, out[0], q[0]);
  const hn::ScalableTag<float> d;
  const int N = int(hn::Lanes(d));
  const auto vT = hn::Set(d, T), vc = hn::Set(d, c), zero = hn::Zero(d);
  int i = 1;
  for (; i + N <= nx - 1; i += N) {
    const auto h = hn::LoadU(d, mid + i);
    const auto d0 = hn::Sub(h, hn::LoadU(d, mid + i - 1)), d1 = hn::Sub(h, hn::LoadU(d, mid + i + 1));
    const auto d2 = hn::Sub(h, hn::LoadU(d, up + i)), d3 = hn::Sub(h, hn::LoadU(d, dn + i));
    const auto dmax = hn::Max(hn::Max(d0, d1), hn::Max(d2, d3));
    auto tot = hn::Add(hn::IfThenElseZero(hn::Gt(d0, vT), d0), hn::IfThenElseZero(hn::Gt(d1, vT), d1));
    tot = hn::Add(tot, hn::IfThenElseZero(hn::Gt(d2, vT), d2));
    tot = hn::Add(tot, hn::IfThenElseZero(hn::Gt(d3, vT), d3));
    const auto o = hn::IfThenElseZero(hn::Gt(dmax, vT), hn::Mul(vc, hn::Sub(dmax, vT)));
    hn::StoreU(o, d, out + i);
    hn::StoreU(hn::IfThenElseZero(hn::Gt(tot, zero), hn::Div(o, tot)), d, q + i);
  }
  for (; i < nx - 1; ++i) outflow_cell(mid[i], mid[i - 1], mid[i + 1], up[i], dn[i], T, c, out[i], q[i]);
  outflow_cell(mid[nx - 1], mid[nx - 2], mid[nx - 1], up[nx - 1], dn[nx - 1], T, c, out[nx - 1], q[nx - 1]);
}

// Pass 2 over row `mid`: o is its outflow row, qu/qm/qd the share rows of up/mid/dn.
HWY_INLINE void GatherRow(const float* HWY_RESTRICT up, const float* HWY_RESTRICT mid, const float* HWY_RESTRICT dn,
                          const float* HWY_RESTRICT o, const float* HWY_RESTRICT qu, const float* HWY_RESTRICT qm,
                          const float* HWY_RESTRICT qd, int nx, float T, float* HWY_RESTRICT res) {
  if (nx == 1) {
    res[0] = gather_cell(mid[0], o[0], mid[0], mid[0], up[0], dn[0], qm[0], qm[0], qu[0], qd[0], T);
    return;
  }
  res[0] = gather_cell(mid[0], o[0], mid[0], mid[1], up[0], dn[0], qm[0], qm[1], qu[0], qd[0], T);
  const hn::ScalableTag<float> d;
  const int N = int(hn::Lanes(d));
  const auto vT = hn::Set(d, T);
  int i = 1;
  for (; i + N <= nx - 1; i += N) {
    const auto h = hn::LoadU(d, mid + i);
    const auto a0 = hn::Sub(hn::LoadU(d, mid + i - 1), h), a1 = hn::Sub(hn::LoadU(d, mid + i + 1), h);
    const auto a2 = hn::Sub(hn::LoadU(d, up + i), h), a3 = hn::Sub(hn::LoadU(d, dn + i), h);
    auto gain = hn::Add(hn::IfThenElseZero(hn::Gt(a0, vT), hn::Mul(hn::LoadU(d, qm + i - 1), a0)),
                        hn::IfThenElseZero(hn::Gt(a1, vT), hn::Mul(hn::LoadU(d, qm + i + 1), a1)));
    gain = hn::Add(gain, hn::IfThenElseZero(hn::Gt(a2, vT), hn::Mul(hn::LoadU(d, qu + i), a2)));
    gain = hn::Add(gain, hn::IfThenElseZero(hn::Gt(a3, vT), hn::Mul(hn::LoadU(d, qd + i), a3)));
    hn::StoreU(hn::Add(hn::Sub(h, hn::LoadU(d, o + i)), gain), d, res + i);
  }
  for (; i < nx - 1; ++i)
    res[i] = gather_cell(mid[i], o[i], mid[i - 1], mid[i + 1], up[i], dn[i], qm[i - 1], qm[i + 1], qu[i], qd[i], T);
  const int l = nx - 1;
  res[l] = gather_cell(mid[l], o[l], mid[l - 1], mid[l], up[l], dn[l], qm[l - 1], qm[l], qu[l], qd[l], T);
}

}  // namespace

// Rows [j0, j1) of the new map. ring: 6·nx floats (outflow and share rows of three rows).
void ThermalRows(const Args& a, int j0, int j1, float* HWY_RESTRICT ring) {
  const int nx = a.nx, nz = a.nz;
  auto row = [&](int j) { return a.e + std::size_t(j) * nx; };
  auto out_row = [&](int j) { return ring + std::size_t(j % 3) * nx; };
  auto q_row = [&](int j) { return ring + std::size_t(3 + j % 3) * nx; };
  int next_row = std::max(j0 - 1, 0);  // the next row whose outflow is still to compute
  for (int j = j0; j < j1; ++j) {
    const int need = std::min(j + 1, nz - 1);
    for (; next_row <= need; ++next_row) {
      const int r = next_row;
      OutflowRow(row(std::max(r - 1, 0)), row(r), row(std::min(r + 1, nz - 1)), nx, a.T, a.c, out_row(r), q_row(r));
    }
    const int u = std::max(j - 1, 0), dn = std::min(j + 1, nz - 1);
    GatherRow(row(u), row(j), row(dn), out_row(j), q_row(u), q_row(j), q_row(dn), nx, a.T,
              a.next + std::size_t(j) * nx);
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace relief::erosion::thermal_kernel
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace relief::erosion {
namespace thermal_kernel {
HWY_EXPORT(ThermalRows);
}  // namespace thermal_kernel

void thermal_iteration(const float* e, float* next, const Frame& f, double talus_deg, double rate) {
  thermal_kernel::Args a;
  a.e = e;
  a.next = next;
  a.nx = f.nx;
  a.nz = f.nz;
  a.T = float(std::tan(talus_deg * std::numbers::pi / 180.0) * f.cell_m() / f.height_m);
  a.c = float(rate);
  // Fixed blocks of rows: each row's value is computed by the same code whatever the schedule.
  constexpr int kBlock = 16;
  const int blocks = (a.nz + kBlock - 1) / kBlock;
  tbb::parallel_for(tbb::blocked_range<int>(0, blocks, 1), [&](const tbb::blocked_range<int>& r) {
    const std::unique_ptr<float[]> ring(new float[std::size_t(6) * a.nx]);
    for (int b = r.begin(); b < r.end(); ++b)
      HWY_DYNAMIC_DISPATCH(thermal_kernel::ThermalRows)(a, b * kBlock, std::min(a.nz, (b + 1) * kBlock), ring.get());
  });
}

}  // namespace relief::erosion
#endif  // HWY_ONCE
