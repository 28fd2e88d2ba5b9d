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
#include <algorithm>
#include <cmath>
#include <vector>

#include "erosion.hpp"
#include "hydrology.hpp"
#include "parallel.hpp"

namespace relief::erosion {

StreamPowerStats stream_power(float* e, const Frame& f, const StreamPowerSettings& s) {
  StreamPowerStats stats;
  const int nx = f.nx, nz = f.nz;
  const std::size_t n = f.count();
  const double cell = f.cell_m(), H = f.height_m, sea = f.sea_level;
  // Start from a surface where every land cell drains.
  hydro::fill_depressions<float>(e, nx, nz, float(sea), 0.0f);
  std::vector<double> h(n), uplift(n);
  const double land_span = std::max(1.0 - sea, 1e-9);
  detail::parallel_rows(nz, [&](int j) {
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

  std::vector<std::uint32_t> rec(n), order, count(n);
  const bool linear = s.n == 1.0;
  const double max_rise_straight = std::tan(s.max_slope_deg * 3.14159265358979323846 / 180.0) * cell;
  const double max_rise_diag = max_rise_straight * std::sqrt(2.0);
  for (int step = 0; step < s.steps; ++step) {
    hydro::d8_receivers<double>(h.data(), nx, nz, 0.0, rec.data());
    bool pits = false;
    for (int j = 1; j + 1 < nz && !pits; ++j)
      for (int i = 1; i + 1 < nx; ++i) {
        const std::size_t c = std::size_t(j) * nx + i;
        if (rec[c] == c && h[c] >= 0.0) {
          pits = true;
          break;
        }
      }
    if (pits) {
      hydro::fill_depressions<double>(h.data(), nx, nz, 0.0, 1e-6);
      hydro::d8_receivers<double>(h.data(), nx, nz, 0.0, rec.data());
      ++stats.fills;
    }
    hydro::flow_order(rec.data(), n, order, count.data());
    // Receivers before donors: the reverse of the donor-first order.
    for (std::size_t q = n; q-- > 0;) {
      const std::uint32_t c = order[q], r = rec[c];
      if (r == c) continue;
      const std::uint32_t delta = c > r ? c - r : r - c;
      const bool straight = delta == 1 || delta == std::uint32_t(nx);
      const double F = (straight ? kdt_straight : kdt_diag) * pow_area(count[c]);
      const double hr = std::max(h[r], 0.0);  // the sea surface is the base level, not the sea floor
      const double h0 = h[c] + uplift[c] * dt;
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
      h[c] = x;
    }
  }
  detail::parallel_rows(nz, [&](int j) {
    for (int i = 0; i < nx; ++i) {
      const std::size_t c = std::size_t(j) * nx + i;
      e[c] = float(std::clamp(sea + h[c] / H, 0.0, 1.0));
    }
  });
  hydro::fill_depressions<float>(e, nx, nz, float(sea), 0.0f);
  return stats;
}

}  // namespace relief::erosion
