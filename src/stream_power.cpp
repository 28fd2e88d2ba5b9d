// Stream-power incision with tectonic uplift: dh/dt = U − K·A^m·S^n.
//
// Sources:
//   * J. Braun, S. D. Willett, "A very efficient O(n), implicit and parallel method to solve the
//     stream power equation governing fluvial incision and landscape evolution", Geomorphology
//     180–181, 2013 — receivers, the donor-ordered stack and the implicit update solved from base
//     level upwards (closed form for n = 1, Newton–Raphson otherwise).
//   * G. Cordonnier, J. Braun, M.-P. Cani, B. Benes, É. Galin, A. Peytavie, É. Guérin, "Large
//     Scale Terrain Generation from Tectonic Uplift and Fluvial Erosion", Computer Graphics Forum
//     35(2), 2016 — stream power with an uplift map as a terrain generator, lakes resolved at
//     every step. Here the uplift map is the input relief (or uniform), and lakes are resolved by
//     Priority-Flood+ε whenever a step leaves pits (see erosion.hpp).
//   * G. E. Tucker, G. R. Hancock, "Modelling landscape evolution", ESPL 35, 2010 — steady state
//     S = (U/K)^(1/n)·A^(−m/n): channel concavity θ = m/n, which the tests measure.
//
// Units: h in metres (sea surface at 0), A in m² (times `rainfall`), S in m/m, t in years.
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "relief/erosion.hpp"
#include "stream_power_detail.hpp"
#include "relief/hydrology.hpp"
#include "parallel.hpp"

namespace relief::erosion {
namespace {

// The solver; kWindow adds the window's ring levels, inflow and observers (stream_power_detail.hpp).
// stream_power is the instance without them: its code path is the one before the window existed.
template <bool kWindow>
StreamPowerStats run(float* e, const Frame& f, const StreamPowerSettings& s, const detail::StreamPowerWindow* win,
                     const std::function<void(double)>& progress) {
  StreamPowerStats stats;
  const int nx = f.nx, nz = f.nz;
  const std::size_t n = f.count();
  const double cell = f.cell_m(), H = f.height_m, sea = f.sea_level;
  // Start from a surface where every land cell drains.
  hydro::fill_depressions<float>(e, nx, nz, float(sea), 0.0f);
  std::vector<double> h(n), uplift(n);
  const double land_span = std::max(1.0 - sea, 1e-9);
  relief::detail::parallel_rows(nz, [&](int j) {
    for (int i = 0; i < nx; ++i) {
      const std::size_t c = std::size_t(j) * nx + i;
      h[c] = (double(e[c]) - sea) * H;
      const bool base = hydro::on_border(i, j, nx, nz) || e[c] < float(sea);
      const double shape = std::clamp((double(e[c]) - sea) / land_span, 0.0, 1.0);
      uplift[c] = base ? 0.0 : s.uplift_mm_per_year * 1e-3 * (s.uplift_follows_height ? shape : 1.0);
    }
  });
  const double dt = s.duration_years / std::max(1, s.steps);
  // K·dt / L^n for straight and diagonal receivers; A^m from a table indexed by the cell count.
  const double kdt_straight = s.k * dt / std::pow(cell, s.n), kdt_diag = s.k * dt / std::pow(cell * std::sqrt(2.0), s.n);
  const std::size_t table_size = std::min<std::size_t>(n, std::size_t(1) << 22) + 1;
  std::vector<double> area_m(table_size);
  const double cell_area = cell * cell * s.rainfall;
  for (std::size_t a = 0; a < table_size; ++a) area_m[a] = std::pow(double(a) * cell_area, s.m);
  auto pow_area = [&](std::uint32_t cnt) { return cnt < table_size ? area_m[cnt] : std::pow(double(cnt) * cell_area, s.m); };

  const bool linear = s.n == 1.0;
  const double max_rise_straight = std::tan(s.max_slope_deg * 3.14159265358979323846 / 180.0) * cell;
  const double max_rise_diag = max_rise_straight * std::sqrt(2.0);
  // The implicit update of one cell with uplifted height h0 = h + U·dt, receiver height hr (already
  // updated), F = K·dt·A^m / L^n and a straight or diagonal receiver (the linear case is inlined below).
  auto solve = [&](double h0, double hr, double F, bool straight) {
    double x;
    if (linear) {
      x = (h0 + F * hr) / (1.0 + F);
    } else {
      // Newton–Raphson on g(x) = x − h0 + F·(x − hr)^n, starting at h0 (g(h0) ≥ 0, g convex).
      x = h0;
      for (int it = 0; it < 30 && x > hr; ++it) {
        const double d = x - hr, pn = std::pow(d, s.n);
        const double g = x - h0 + F * pn, dg = 1.0 + F * s.n * pn / d;
        const double nxv = x - g / dg;
        if (std::fabs(nxv - x) < 1e-9) {
          x = nxv;
          break;
        }
        x = nxv;
      }
    }
    x = std::min(x, hr + (straight ? max_rise_straight : max_rise_diag));
    if (!(x > hr)) x = std::nextafter(hr, hr + 1.0);
    return x;
  };

  std::ptrdiff_t off[8];
  for (int k = 0; k < 8; ++k) off[k] = std::ptrdiff_t(hydro::kDj[k]) * nx + hydro::kDi[k];
  std::vector<std::uint8_t> dir(n), mask(n);
  // Per-thread buffers of one drainage basin in depth-first preorder:
  // cells, the position of each cell's receiver times 2 plus 1 for a diagonal receiver, the
  // uplifted heights h⁰ (gathered during the walk, while the cell's row is in cache), drainage
  // areas (cells), the factors F = K·dt·A^m / L^n and the updated heights; and the walk's stack.
  // They start small and grow with the largest basin met (not with the map).
  struct Basin {
    std::vector<std::uint32_t> cell, link, count, stack;
    std::vector<double> h0, f, h, area;  // area: kWindow's drainage area with inflow
    void grow_cells(std::size_t need) {
      const std::size_t size = std::max(need, 2 * cell.size());
      cell.resize(size), link.resize(size), h0.resize(size);
    }
  };
  tbb::enumerable_thread_specific<Basin> basins([] {
    Basin b;
    b.grow_cells(256);
    b.stack.resize(512);
    return b;
  });
  std::vector<double> extra;  // the window's inflow per cell (kWindow)
  std::vector<double> area_out;  // the drainage areas for win->routed (kWindow)
  if constexpr (kWindow) {
    extra.assign(win->inflow ? n : 0, 0.0);
    area_out.assign(win->routed ? n : 0, 0.0);
  }
  for (int step = 0; step < s.steps; ++step) {
    if constexpr (kWindow)
      if (win->ring) win->ring(step, false, h.data());
    if (hydro::d8_directions<double>(h.data(), nx, nz, 0.0, dir.data()) != 0) {
      hydro::fill_depressions<double>(h.data(), nx, nz, 0.0, 1e-6);
      hydro::d8_directions<double>(h.data(), nx, nz, 0.0, dir.data());
      ++stats.fills;
    }
    if constexpr (kWindow) {
      if (win->seen) win->seen(step, h.data());
      if (win->inflow) {
        std::fill(extra.begin(), extra.end(), 0.0);
        win->inflow(step, extra.data());
      }
    }
    hydro::donor_masks(dir.data(), nx, nz, mask.data());
    // Uplift first, in a streaming pass (h_c⁰ = h_c + U·dt for every cell that has a receiver), so
    // that the basin walks below read one array per cell; outlets stay at base level.
    relief::detail::parallel_rows(nz, [&](int j) {
      const std::size_t row = std::size_t(j) * nx;
      for (std::size_t c = row; c < row + std::size_t(nx); ++c)
        if (dir[c] != hydro::kNoReceiver) h[c] += uplift[c] * dt;
    }, 16);
    if constexpr (kWindow)
      if (win->ring) win->ring(step, true, h.data());
    // Every cell without a receiver (outlets) roots a drainage basin; basins are disjoint, so they
    // are solved in parallel, each by the same sequential code: the result does not depend on the
    // schedule. In a basin, the depth-first preorder from the root puts every receiver before its
    // donors (Braun & Willett's stack) and keeps neighbouring cells close in the order, which keeps
    // the random reads of h in cache; drainage areas are summed in the reverse order.
    tbb::parallel_for(tbb::blocked_range<int>(0, nz, 8), [&](const tbb::blocked_range<int>& rows) {
      Basin& b = basins.local();
      for (int j = rows.begin(); j < rows.end(); ++j)
        for (int i = 0; i < nx; ++i) {
          const std::size_t root = std::size_t(j) * nx + i;
          if (dir[root] != hydro::kNoReceiver || mask[root] == 0) continue;
          // Depth-first preorder: a cell is placed when popped, then its donors are pushed.
          std::uint32_t *cell = b.cell.data(), *link = b.link.data(), *stack = b.stack.data();
          double* hb0 = b.h0.data();
          std::size_t cells = 0, top = 0;
          stack[top++] = std::uint32_t(root);
          stack[top++] = 0;
          while (top != 0) {
            const std::uint32_t l = stack[--top], x = stack[--top];
            if (cells == b.cell.size()) [[unlikely]] {
              b.grow_cells(cells + 1);
              cell = b.cell.data(), link = b.link.data(), hb0 = b.h0.data();
            }
            if (top + 16 > b.stack.size()) [[unlikely]] {
              b.stack.resize(2 * b.stack.size());
              stack = b.stack.data();
            }
            const std::uint32_t q = std::uint32_t(cells++);
            cell[q] = x;
            link[q] = l;
            hb0[q] = h[x];
            for (unsigned m = mask[x]; m != 0; m &= m - 1) {
              const int k = __builtin_ctz(m);  // the donor drains to x in direction (k + 4) mod 8
              const std::ptrdiff_t donor = std::ptrdiff_t(x) + off[k];
              __builtin_prefetch(h.data() + donor);  // read when the donor is placed
              __builtin_prefetch(mask.data() + donor);
              stack[top++] = std::uint32_t(donor);
              stack[top++] = q * 2 + std::uint32_t(k & 1);
            }
          }
          if (b.count.size() < cells) b.count.resize(b.cell.size()), b.f.resize(b.cell.size()), b.h.resize(b.cell.size());
          std::uint32_t* const count = b.count.data();
          double *const fb = b.f.data(), *const hb = b.h.data();
          // Drainage areas in reverse preorder (a cell's count is final when it is reached).
          for (std::size_t q = 0; q < cells; ++q) count[q] = 1;
          for (std::size_t q = cells; q-- > 1;) count[link[q] >> 1] += count[q];
          constexpr std::size_t kAhead = 16;  // table rows of large areas are far apart: prefetch them
          for (std::size_t q = 1; q < std::min(cells, kAhead); ++q) __builtin_prefetch(area_m.data() + std::min<std::size_t>(count[q], table_size - 1));
          if constexpr (kWindow) {
            if (!extra.empty()) {
              // Areas with the inflow, in cells: sums of whole numbers stay exact, so a window given whole
              // cells of inflow computes the whole map's A^m (the table holds the same std::pow values).
              if (b.area.size() < cells) b.area.resize(b.cell.size());
              double* const a = b.area.data();
              for (std::size_t q = 0; q < cells; ++q) a[q] = 1.0 + extra[cell[q]];
              for (std::size_t q = cells; q-- > 1;) a[link[q] >> 1] += a[q];
              for (std::size_t q = 1; q < cells; ++q) {
                const double cnt = a[q];
                const double am = cnt < double(table_size) && cnt == std::floor(cnt) ? area_m[std::size_t(cnt)]
                                                                                     : std::pow(cnt * cell_area, s.m);
                fb[q] = ((link[q] & 1) == 0 ? kdt_straight : kdt_diag) * am;
              }
            }
          }
          if (!kWindow || extra.empty())
            for (std::size_t q = 1; q < cells; ++q) {
              if (q + kAhead < cells) __builtin_prefetch(area_m.data() + std::min<std::size_t>(count[q + kAhead], table_size - 1));
              fb[q] = ((link[q] & 1) == 0 ? kdt_straight : kdt_diag) * pow_area(count[q]);
            }
          if constexpr (kWindow)
            if (!area_out.empty())
              for (std::size_t q = 0; q < cells; ++q) area_out[cell[q]] = extra.empty() ? double(count[q]) : b.area[q];
          hb[0] = std::max(hb0[0], 0.0);  // the sea surface is the base level, not the sea floor
          if (linear) {
            // The receiver is usually the previous cell: keep its height in a register.
            double prev = hb[0];
            for (std::size_t q = 1; q < cells; ++q) {
              const std::uint32_t l = link[q];
              const double hr = (l >> 1) == q - 1 ? prev : hb[l >> 1];
              const double F = fb[q];
              double x = (hb0[q] + F * hr) / (1.0 + F);
              x = std::min(x, hr + ((l & 1) == 0 ? max_rise_straight : max_rise_diag));
              if (!(x > hr)) [[unlikely]] x = std::nextafter(hr, hr + 1.0);
              h[cell[q]] = x;
              prev = std::max(x, 0.0);
              hb[q] = prev;
            }
          } else {
            for (std::size_t q = 1; q < cells; ++q) {
              const std::uint32_t l = link[q];
              const double x = solve(hb0[q], hb[l >> 1], fb[q], (l & 1) == 0);
              h[cell[q]] = x;
              hb[q] = std::max(x, 0.0);
            }
          }
        }
    });
    if constexpr (kWindow) {
      if (win->solved) win->solved(step, h.data());
      if (win->routed) win->routed(step, dir.data(), area_out.data());
    }
    if (progress) progress(double(step + 1) / double(s.steps));
  }
  relief::detail::parallel_rows(nz, [&](int j) {
    for (int i = 0; i < nx; ++i) {
      const std::size_t c = std::size_t(j) * nx + i;
      e[c] = float(std::clamp(sea + h[c] / H, 0.0, 1.0));
    }
  });
  hydro::fill_depressions<float>(e, nx, nz, float(sea), 0.0f);
  return stats;
}

}  // namespace

StreamPowerStats stream_power(float* e, const Frame& f, const StreamPowerSettings& s,
                              const std::function<void(double)>& progress) {
  return run<false>(e, f, s, nullptr, progress);
}

namespace detail {
StreamPowerStats stream_power_window(float* e, const Frame& f, const StreamPowerSettings& s, const StreamPowerWindow& w,
                                     const std::function<void(double)>& progress) {
  return run<true>(e, f, s, &w, progress);
}
}  // namespace detail

}  // namespace relief::erosion
