// D8 steepest descent (O'Callaghan and Mark 1984) as direction codes, one row at a time, and the
// donor masks derived from them: the row kernels behind hydro::d8_directions, d8_receivers and
// donor_masks.
//
// Sources:
//   * J. F. O'Callaghan, D. M. Mark, "The extraction of drainage networks from digital elevation
//     data", CVGIP 28, 1984 — D8 steepest descent.
//   * Google Highway (github.com/google/highway): foreach_target multi-target compilation and
//     HWY_DYNAMIC_DISPATCH, once per row.
//
// Exactness across Highway targets: each lane does what the scalar code does for its cell (drops
// z_c − z_n, diagonal ones times 1/√2, a strict comparison against the best so far in the order
// E, SE, S, SW, W, NW, N, NE), with -ffp-contract=off, so every target picks the same receivers.

// The shared part below is compiled once; foreach_target re-includes this file per target.
#ifndef RELIEF_HYDROLOGY_D8_SHARED
#define RELIEF_HYDROLOGY_D8_SHARED
#include <cstddef>
#include <cstdint>

#include "relief/hydrology.hpp"
#include "parallel.hpp"

namespace relief::hydro::d8_kernel {

// The scalar rule for one interior cell c: the direction code, or kNoReceiver.
template <class T>
inline std::uint8_t direction(const T* z, std::size_t c, const std::ptrdiff_t* off, T inv_diag) {
  const T zc = z[c];
  T best = 0;
  int bk = kNoReceiver;
  for (int k = 0; k < 8; ++k) {
    T drop = zc - z[std::ptrdiff_t(c) + off[k]];
    if (k & 1) drop *= inv_diag;
    const bool better = drop > best;
    best = better ? drop : best;
    bk = better ? k : bk;
  }
  return std::uint8_t(bk);
}

}  // namespace relief::hydro::d8_kernel
#endif  // RELIEF_HYDROLOGY_D8_SHARED

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "hydrology_d8.cpp"
#include "hwy_kernels.hpp"  // the target list, foreach_target.h, highway.h, no FP contraction

HWY_BEFORE_NAMESPACE();
namespace relief::hydro::d8_kernel {
namespace HWY_NAMESPACE {

namespace hn = hwy::HWY_NAMESPACE;

// Direction codes of row j (0 < j < nz − 1) into dir (nx bytes); returns the row's pits (cells
// at or above `sea`, not on the border, without a lower neighbour).
template <class T>
HWY_INLINE std::size_t RowImpl(const T* HWY_RESTRICT z, int nx, int j, T sea, std::uint8_t* HWY_RESTRICT dir) {
  std::ptrdiff_t off[8];
  for (int k = 0; k < 8; ++k) off[k] = std::ptrdiff_t(kDj[k]) * nx + kDi[k];
  const T inv_diag = T(1.0 / kDist[1]);
  const std::size_t row = std::size_t(j) * nx;
  std::size_t pits = 0;
  dir[0] = dir[nx - 1] = kNoReceiver;
  const hn::ScalableTag<T> d;
  const int N = int(hn::Lanes(d));
  HWY_ALIGN T codes[hn::MaxLanes(d)];
  const auto zero = hn::Zero(d), none = hn::Set(d, T(kNoReceiver)), vsea = hn::Set(d, sea),
             vdiag = hn::Set(d, inv_diag);
  int i = 1;
  for (; i + N <= nx - 1; i += N) {
    const T* zc_p = z + row + i;
    const auto zc = hn::LoadU(d, zc_p);
    auto best = zero, bk = none;
    for (int k = 0; k < 8; ++k) {
      auto drop = hn::Sub(zc, hn::LoadU(d, zc_p + off[k]));
      if (k & 1) drop = hn::Mul(drop, vdiag);
      const auto better = hn::Gt(drop, best);
      best = hn::IfThenElse(better, drop, best);
      bk = hn::IfThenElse(better, hn::Set(d, T(k)), bk);
    }
    const auto sea_cell = hn::Lt(zc, vsea);
    bk = hn::IfThenElse(sea_cell, none, bk);
    pits += hn::CountTrue(d, hn::AndNot(sea_cell, hn::Eq(best, zero)));
    hn::Store(bk, d, codes);
    for (int l = 0; l < N; ++l) dir[i + l] = std::uint8_t(codes[l]);
  }
  for (; i < nx - 1; ++i) {
    const std::size_t c = row + i;
    if (z[c] < sea) {
      dir[i] = kNoReceiver;
      continue;
    }
    dir[i] = direction(z, c, off, inv_diag);
    pits += dir[i] == kNoReceiver;
  }
  return pits;
}

std::size_t RowF(const float* z, int nx, int j, float sea, std::uint8_t* dir) { return RowImpl(z, nx, j, sea, dir); }

// Donor masks of the interior cells [1, nx − 1) of row j (0 < j < nz − 1): byte lanes.
void MaskRow(const std::uint8_t* HWY_RESTRICT dir, int nx, int j, std::uint8_t* HWY_RESTRICT mask) {
  std::ptrdiff_t off[8];
  for (int k = 0; k < 8; ++k) off[k] = std::ptrdiff_t(kDj[k]) * nx + kDi[k];
  const std::uint8_t* HWY_RESTRICT c = dir + std::size_t(j) * nx;
  const hn::ScalableTag<std::uint8_t> d;
  const int N = int(hn::Lanes(d));
  int i = 1;
  for (; i + N <= nx - 1; i += N) {
    auto m = hn::Zero(d);
    for (int k = 0; k < 8; ++k) {
      const auto from = hn::Eq(hn::LoadU(d, c + i + off[k]), hn::Set(d, std::uint8_t((k + 4) & 7)));
      m = hn::Or(m, hn::IfThenElseZero(from, hn::Set(d, std::uint8_t(1u << k))));
    }
    hn::StoreU(m, d, mask + i);
  }
  for (; i < nx - 1; ++i) {
    std::uint8_t m = 0;
    for (int k = 0; k < 8; ++k) m |= std::uint8_t((c[i + off[k]] == ((k + 4) & 7)) << k);
    mask[i] = m;
  }
}
std::size_t RowD(const double* z, int nx, int j, double sea, std::uint8_t* dir) { return RowImpl(z, nx, j, sea, dir); }

}  // namespace HWY_NAMESPACE
}  // namespace relief::hydro::d8_kernel
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <vector>

namespace relief::hydro {
namespace d8_kernel {
HWY_EXPORT(RowF);
HWY_EXPORT(RowD);
HWY_EXPORT(MaskRow);
inline std::size_t row(const float* z, int nx, int j, float sea, std::uint8_t* dir) {
  return HWY_DYNAMIC_DISPATCH(RowF)(z, nx, j, sea, dir);
}
inline std::size_t row(const double* z, int nx, int j, double sea, std::uint8_t* dir) {
  return HWY_DYNAMIC_DISPATCH(RowD)(z, nx, j, sea, dir);
}
}  // namespace d8_kernel

template <class T>
std::size_t d8_directions(const T* z, int nx, int nz, T sea, std::uint8_t* dir) {
  // Pit counts are summed per fixed block of rows, then over the blocks in order: any schedule
  // gives the same (integer) total.
  return tbb::parallel_reduce(
      tbb::blocked_range<int>(0, nz, 16), std::size_t(0),
      [&](const tbb::blocked_range<int>& r, std::size_t acc) {
        for (int j = r.begin(); j < r.end(); ++j) {
          std::uint8_t* d = dir + std::size_t(j) * nx;
          if (j == 0 || j == nz - 1 || nx < 3) {
            for (int i = 0; i < nx; ++i) d[i] = kNoReceiver;
            continue;
          }
          acc += d8_kernel::row(z, nx, j, sea, d);
        }
        return acc;
      },
      [](std::size_t a, std::size_t b) { return a + b; });
}

template <class T>
void d8_receivers(const T* z, int nx, int nz, T sea, std::uint32_t* rec) {
  std::ptrdiff_t off[8];
  for (int k = 0; k < 8; ++k) off[k] = std::ptrdiff_t(kDj[k]) * nx + kDi[k];
  tbb::parallel_for(tbb::blocked_range<int>(0, nz, 16), [&](const tbb::blocked_range<int>& r) {
    std::vector<std::uint8_t> d(static_cast<std::size_t>(nx));
    for (int j = r.begin(); j < r.end(); ++j) {
      const std::size_t row = std::size_t(j) * nx;
      if (j == 0 || j == nz - 1 || nx < 3) {
        for (int i = 0; i < nx; ++i) rec[row + i] = std::uint32_t(row + i);
        continue;
      }
      d8_kernel::row(z, nx, j, sea, d.data());
      for (int i = 0; i < nx; ++i)
        rec[row + i] = std::uint32_t(d[i] == kNoReceiver ? std::ptrdiff_t(row + i) : std::ptrdiff_t(row + i) + off[d[i]]);
    }
  });
}

void donor_masks(const std::uint8_t* dir, int nx, int nz, std::uint8_t* mask) {
  detail::parallel_rows(nz, [&](int j) {
    const std::size_t row = std::size_t(j) * nx;
    auto checked = [&](int i) {
      std::uint8_t m = 0;
      for (int k = 0; k < 8; ++k) {
        const int a = i + kDi[k], b = j + kDj[k];
        if (a >= 0 && b >= 0 && a < nx && b < nz && dir[std::size_t(b) * nx + a] == ((k + 4) & 7)) m |= std::uint8_t(1u << k);
      }
      mask[row + i] = m;
    };
    if (j == 0 || j == nz - 1 || nx < 3) {
      for (int i = 0; i < nx; ++i) checked(i);
      return;
    }
    checked(0);
    HWY_DYNAMIC_DISPATCH(d8_kernel::MaskRow)(dir, nx, j, mask + row);
    checked(nx - 1);
  }, 16);
}

template std::size_t d8_directions<float>(const float*, int, int, float, std::uint8_t*);
template std::size_t d8_directions<double>(const double*, int, int, double, std::uint8_t*);
template void d8_receivers<float>(const float*, int, int, float, std::uint32_t*);
template void d8_receivers<double>(const double*, int, int, double, std::uint32_t*);

}  // namespace relief::hydro
#endif  // HWY_ONCE
