// Droplet hydraulic erosion.
//
// Sources:
//   * H. T. Beyer, "Implementation of a method for hydraulic erosion", Bachelor's thesis, TU
//     München, 2015 — the droplet model: inertia-blended direction, sediment capacity from slope,
//     speed and water, erosion with a radius brush, deposition, evaporation.
//   * S. Lague, "Hydraulic Erosion" (2019, github.com/SebLague/Hydraulic-Erosion) — the parameter
//     set (inertia, capacity, minimum capacity, erode, deposit, evaporate, gravity, lifetime, brush
//     radius) and the (r − d) brush weights. Two departures, both deliberate: speed grows when the
//     droplet descends (v² − Δy·g; Lague's v² + Δy·g slows droplets going downhill), and erosion is
//     bounded by elevation 0 instead of by "positive height", which creates spikes below sea level.
//
// World units: positions and the brush are in metres, heights in metres, sediment in m³, so a
// droplet moves, erodes and deposits the same volume at any sample spacing.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "erosion.hpp"
#include "relief/error.hpp"
#include "relief/random.hpp"

namespace relief::erosion {
namespace {

struct BrushCell {
  int di, dj;
  double w;  // weight, Σ w = 1 over the full brush
};

class Droplets {
 public:
  Droplets(float* e, const Frame& f, const HydraulicSettings& s)
      : e_(e), nx_(f.nx), nz_(f.nz), s_(s), cell_(f.cell_m()), H_(f.height_m), sea_(float(f.sea_level)) {
    area_ = std::numbers::pi * s.brush_radius_m * s.brush_radius_m;
    to_norm_ = 1.0 / (H_ * cell_ * cell_);
    step_c_ = s.step_m / cell_;
    // The brush covers at least the 3×3 cells around the droplet, so that on a coarse grid (cells
    // larger than the brush) a droplet's volume is not piled onto one cell.
    const double r = std::max(s.brush_radius_m, 1.5 * cell_);
    radius_c_ = int(std::ceil(r / cell_));
    double sum = 0;
    for (int dj = -radius_c_; dj <= radius_c_; ++dj)
      for (int di = -radius_c_; di <= radius_c_; ++di) {
        const double d = std::hypot(double(di), double(dj)) * cell_;
        if (d >= r) continue;
        const double w = r - d;
        brush_.push_back({di, dj, w});
        sum += w;
      }
    for (auto& b : brush_) b.w /= sum;
    for (auto& b : brush_) {
      delta_.push_back(std::ptrdiff_t(b.dj) * nx_ + b.di);
      wn_.push_back(float(b.w * to_norm_));
    }
  }

  int radius_cells() const { return radius_c_; }

  // Runs one droplet starting at (px, pz) in cell units; adds to `st`.
  void run(double px, double pz, HydraulicStats& st) const {
    const double gs = H_ / cell_;  // normalised difference per cell → metres per metre
    double dirx = 0, dirz = 0, speed = 1, water = 1, sed = 0;
    if (height(px, pz) < sea_) return;
    ++st.droplets;
    for (int life = 0; life < s_.lifetime; ++life) {
      const int ix = int(px), iz = int(pz);
      const double fx = px - ix, fz = pz - iz;
      const float* p = e_ + std::size_t(iz) * nx_ + ix;
      const double a = p[0], b = p[1], c = p[nx_], d = p[nx_ + 1];
      const double gx = ((b - a) * (1 - fz) + (d - c) * fz) * gs;
      const double gz = ((c - a) * (1 - fx) + (d - b) * fx) * gs;
      const double h_old = a * (1 - fx) * (1 - fz) + b * fx * (1 - fz) + c * (1 - fx) * fz + d * fx * fz;
      dirx = dirx * s_.inertia - gx * (1 - s_.inertia);
      dirz = dirz * s_.inertia - gz * (1 - s_.inertia);
      const double len = std::sqrt(dirx * dirx + dirz * dirz);
      if (len < 1e-12) break;  // no slope, no momentum: the droplet dies here
      dirx /= len;
      dirz /= len;
      const double npx = px + dirx * step_c_, npz = pz + dirz * step_c_;
      if (!(npx >= 0 && npz >= 0 && npx < nx_ - 1 && npz < nz_ - 1)) {
        st.off_map_m3 += sed;
        return;
      }
      const double h_new = height(npx, npz);
      const double dy = (h_new - h_old) * H_;  // metres, negative downhill
      const double cap = std::max(-dy * speed * water * s_.capacity, s_.min_capacity) * area_;
      if (dy > 0 || sed > cap) {
        const double want = dy > 0 ? std::min(dy * cell_ * cell_, sed) : (sed - cap) * s_.deposit;
        const double got = dy > 0 ? deposit_bilinear(ix, iz, fx, fz, want) : deposit_brush(ix, iz, want);
        sed -= got;
        st.deposited_m3 += got;
      } else {
        const double want = std::min((cap - sed) * s_.erode, -dy * area_);
        const double got = erode_brush(ix, iz, want);
        sed += got;
        st.eroded_m3 += got;
      }
      speed = std::sqrt(std::max(0.0, speed * speed - dy * s_.gravity));
      water *= 1 - s_.evaporate;
      px = npx;
      pz = npz;
      if (h_new < sea_) {
        st.to_sea_m3 += sed;
        return;
      }
    }
    if (sed > 0) {
      const double got = deposit_brush(int(px), int(pz), sed);
      st.deposited_m3 += got;
      st.stranded_m3 += sed - got;
    }
  }

 private:
  double height(double px, double pz) const {
    const int ix = int(px), iz = int(pz);
    const double fx = px - ix, fz = pz - iz;
    const float* p = e_ + std::size_t(iz) * nx_ + ix;
    return p[0] * (1 - fx) * (1 - fz) + p[1] * fx * (1 - fz) + p[nx_] * (1 - fx) * fz + p[nx_ + 1] * fx * fz;
  }
  bool brush_inside(int ix, int iz) const {
    return ix >= radius_c_ && iz >= radius_c_ && ix + radius_c_ < nx_ && iz + radius_c_ < nz_;
  }
  // Applies f(cell pointer, normalised amount) over the brush centred on (ix, iz); near the border
  // the weights are renormalised over the cells inside. Returns Σ f (normalised), times H·cell².
  template <class F>
  double brush(int ix, int iz, double vol, F&& f) const {
    float* base = e_ + std::size_t(iz) * nx_ + ix;
    double got = 0;
    if (brush_inside(ix, iz)) {
      // Single precision inside the brush (the layer's precision); four partial sums in a fixed
      // order keep the reduction short and deterministic.
      const float v = float(vol);
      const std::size_t m = delta_.size();
      float acc[4] = {0, 0, 0, 0};
      for (std::size_t k = 0; k < m; ++k) acc[k & 3] += f(base + delta_[k], v * wn_[k]);
      got = double((acc[0] + acc[1]) + (acc[2] + acc[3]));
    } else {
      double sum = 0;
      for (const auto& b : brush_) {
        const int a = ix + b.di, c = iz + b.dj;
        if (a >= 0 && c >= 0 && a < nx_ && c < nz_) sum += b.w;
      }
      for (const auto& b : brush_) {
        const int a = ix + b.di, c = iz + b.dj;
        if (a >= 0 && c >= 0 && a < nx_ && c < nz_)
          got += f(e_ + std::size_t(c) * nx_ + a, float(vol * b.w / sum * to_norm_));
      }
    }
    return got / to_norm_;
  }
  double erode_brush(int ix, int iz, double vol) const {
    return brush(ix, iz, vol, [](float* p, float want) {
      const float old = *p, now = std::max(old - want, 0.0f);
      *p = now;
      return old - now;
    });
  }
  double deposit_brush(int ix, int iz, double vol) const {
    return brush(ix, iz, vol, [](float* p, float want) {
      const float old = *p, now = std::min(old + want, 1.0f);
      *p = now;
      return now - old;
    });
  }
  double deposit_bilinear(int ix, int iz, double fx, double fz, double vol) const {
    float* p = e_ + std::size_t(iz) * nx_ + ix;
    const double v = vol * to_norm_;
    double got = 0;
    auto put = [&](float* q, double amount) {
      const float old = *q, now = std::min(old + float(amount), 1.0f);
      *q = now;
      got += double(now - old);
    };
    put(p, v * (1 - fx) * (1 - fz));
    put(p + 1, v * fx * (1 - fz));
    put(p + nx_, v * (1 - fx) * fz);
    put(p + nx_ + 1, v * fx * fz);
    return got / to_norm_;
  }

  float* e_;
  int nx_, nz_;
  HydraulicSettings s_;
  double cell_, H_;
  float sea_;
  double area_ = 0, to_norm_ = 0, step_c_ = 0;
  int radius_c_ = 0;
  std::vector<BrushCell> brush_;
  std::vector<std::ptrdiff_t> delta_;  // brush cell offsets (index space)
  std::vector<float> wn_;              // weight / (H · cell²): normalised height per m³
};

}  // namespace

HydraulicStats hydraulic_erosion(float* e, const Frame& f, const HydraulicSettings& s, std::uint64_t seed) {
  HydraulicStats total;
  if (f.nx < 2 || f.nz < 2) return total;
  const Droplets drops(e, f, s);
  const double cell = f.cell_m();
  const double area_km2 = double(f.nx - 1) * double(f.nz - 1) * cell * cell * 1e-6;
  const double wanted = std::round(s.droplets_per_km2 * area_km2);
  if (wanted > 4e8)
    throw Error("droplets_per_km2", "this window would need " + std::to_string(std::uint64_t(wanted)) +
                                        " droplets (at most 400000000); lower the density");
  const std::uint32_t count = std::uint32_t(wanted);

  // Tiles of side 2·reach: a droplet never leaves reach cells around its start (it moves step_m
  // per step and erodes within the brush radius), so tiles of one checkerboard colour never touch
  // the same cells.
  const int reach = int(std::ceil(s.lifetime * s.step_m / cell)) + drops.radius_cells() + 2;
  const int tile = 2 * reach;
  const int ntx = (f.nx - 1 + tile - 1) / tile, ntz = (f.nz - 1 + tile - 1) / tile;
  const std::size_t ntiles = std::size_t(ntx) * ntz;
  const double wx = f.nx - 1, wz = f.nz - 1;
  auto start = [&](std::uint32_t k, double& px, double& pz) {
    px = unit_double(hash64(seed, k, 0x78)) * wx;
    pz = unit_double(hash64(seed, k, 0x7a)) * wz;
  };
  // Counting sort of the droplets by tile (index order is kept inside each tile).
  std::vector<std::uint32_t> tile_of(count), first(ntiles + 1, 0), ids(count);
  for (std::uint32_t k = 0; k < count; ++k) {
    double px, pz;
    start(k, px, pz);
    const int tx = std::min(int(px) / tile, ntx - 1), tz = std::min(int(pz) / tile, ntz - 1);
    tile_of[k] = std::uint32_t(tz * ntx + tx);
    ++first[tile_of[k] + 1];
  }
  for (std::size_t t = 0; t < ntiles; ++t) first[t + 1] += first[t];
  {
    std::vector<std::uint32_t> fill(first.begin(), first.end() - 1);
    for (std::uint32_t k = 0; k < count; ++k) ids[fill[tile_of[k]]++] = k;
  }
  std::vector<HydraulicStats> per_tile(ntiles);
  constexpr int kRounds = 4;
  std::vector<std::uint32_t> phase_tiles;
  for (int round = 0; round < kRounds; ++round)
    for (int phase = 0; phase < 4; ++phase) {
      phase_tiles.clear();
      for (int tz = phase / 2; tz < ntz; tz += 2)
        for (int tx = phase % 2; tx < ntx; tx += 2) phase_tiles.push_back(std::uint32_t(tz * ntx + tx));
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, phase_tiles.size(), 1), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t q = r.begin(); q < r.end(); ++q) {
          const std::uint32_t t = phase_tiles[q];
          const std::uint32_t n = first[t + 1] - first[t];
          const std::uint32_t lo = first[t] + std::uint32_t(std::uint64_t(n) * round / kRounds);
          const std::uint32_t hi = first[t] + std::uint32_t(std::uint64_t(n) * (round + 1) / kRounds);
          for (std::uint32_t a = lo; a < hi; ++a) {
            double px, pz;
            start(ids[a], px, pz);
            drops.run(px, pz, per_tile[t]);
          }
        }
      });
    }
  for (const auto& st : per_tile) {
    total.eroded_m3 += st.eroded_m3;
    total.deposited_m3 += st.deposited_m3;
    total.to_sea_m3 += st.to_sea_m3;
    total.off_map_m3 += st.off_map_m3;
    total.stranded_m3 += st.stranded_m3;
    total.droplets += st.droplets;
  }
  return total;
}

}  // namespace relief::erosion
