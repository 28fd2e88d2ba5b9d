// The density band over the heightfield (relief/volume.hpp), evaluated and meshed chunk by chunk.
//
// Sources:
//   * Inigo Quilez, "Domain warping" (2002/2012): the overhangs' 3D warp of the surface lookup.
//   * Minecraft 1.18 "noise caves" as described by Mojang's developers (2021): "cheese" caves where
//     one 3D noise exceeds a threshold, "spaghetti" and "noodle" tunnels where two 3D noises are both
//     near zero (|(n₁, n₂)| < r traces the intersection of two noise surfaces: a tube).
//   * The meshing is ours (src/marching_cubes.cpp, relief/volume_mesh.hpp).
//
// Purity: every density sample is a function of its voxel position, the terrain and the spec
// alone; the shortcuts below (rows without warp weight, rows where nothing can be carved, chunks
// classified as all air or all rock) give the same bits as the full computation or are never
// meshed, so two chunks sharing a sample layer always agree on it.
#include "relief/volume.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <optional>

#include "relief/error.hpp"
#include "relief/noise3.hpp"
#include "relief/pipeline.hpp"

namespace relief {
namespace {

double smoothstep(double a, double b, double x) {
  if (b <= a) return x < a ? 0.0 : 1.0;
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// Bilinear lookups on the terrain's sample grid, clamped at its edge.
struct Sampler {
  const Frame* f = nullptr;
  double inv_sp = 1.0;
  double clampu(double x) const { return std::clamp(x * inv_sp - double(f->ix0), 0.0, double(f->nx - 1)); }
  double clampv(double z) const { return std::clamp(z * inv_sp - double(f->iz0), 0.0, double(f->nz - 1)); }
  // Weights for (x, z): cell (i, k) and fractions.
  void cell(double x, double z, int& i, int& k, double& tu, double& tv) const {
    const double u = clampu(x), v = clampv(z);
    i = std::min(int(u), f->nx - 2);
    k = std::min(int(v), f->nz - 2);
    tu = u - i;
    tv = v - k;
  }
  double lerp_layer(const float* d, int channels, int c, double x, double z) const {
    int i, k;
    double tu, tv;
    cell(x, z, i, k, tu, tv);
    const std::size_t nx = std::size_t(f->nx);
    auto at = [&](int a, int b) { return double(d[(std::size_t(b) * nx + std::size_t(a)) * channels + c]); };
    const double top = at(i, k) + (at(i + 1, k) - at(i, k)) * tu;
    const double bot = at(i, k + 1) + (at(i + 1, k + 1) - at(i, k + 1)) * tu;
    return top + (bot - top) * tv;
  }
};

struct Prepared {
  const Terrain* t = nullptr;
  const VolumeSpec* spec = nullptr;
  const VolumeGrid* g = nullptr;
  Sampler s;
  const float* height = nullptr;
  std::vector<const float*> masks;  // per overhang spec (nullptr = none)
  struct Warp {
    std::optional<Noise3> n1, n2;
  };
  struct Cave {
    std::optional<Noise3> cheese, sp1, sp2, nd1, nd2;
    std::optional<Noise> entrance;
    double l_cheese = 1, l_sp = 1, l_nd = 1;
  };
  std::vector<Warp> warps;
  // Per overhang spec: the slope in degrees at each height sample, dilated (a square max filter)
  // by the warp's reach, so that the warp is on around a cliff, not only on its steep samples: the
  // ground in front of a cliff must move too for the cliff to lean out over it.
  std::vector<std::vector<float>> steep;
  std::vector<Cave> caves;
  double max_strength_m = 0, max_depth_m = 0;

  double H(double x, double z) const {
    return (s.lerp_layer(height, 1, 0, x, z) - t->frame.sea_level) * t->frame.height_m;
  }
};

double wavelength_of(const NoiseSettings& n) { return n.frequency > 0 ? 1.0 / n.frequency : 1.0; }

Prepared prepare(const Terrain& t, const VolumeSpec& spec, const VolumeGrid& g, std::uint64_t seed) {
  Prepared p;
  p.t = &t;
  p.spec = &spec;
  p.g = &g;
  p.s.f = &t.frame;
  p.s.inv_sp = 1.0 / t.frame.spacing_m;
  p.height = t.get("height").data.data();
  (void)seed;
  const Frame& fr = t.frame;
  std::vector<float> slope;
  if (!spec.overhangs.empty()) {
    // Slope in degrees from central differences in metres (one-sided at the border).
    slope.resize(fr.count());
    const float* e = p.height;
    const int nx = fr.nx, nz = fr.nz;
    const double sp = fr.spacing_m, hm = fr.height_m;
    for (int k = 0; k < nz; ++k)
      for (int i = 0; i < nx; ++i) {
        const int il = std::max(i - 1, 0), ir = std::min(i + 1, nx - 1), ku = std::max(k - 1, 0), kd = std::min(k + 1, nz - 1);
        const double gx = (double(e[std::size_t(k) * nx + ir]) - double(e[std::size_t(k) * nx + il])) * hm / (double(ir - il) * sp);
        const double gz = (double(e[std::size_t(kd) * nx + i]) - double(e[std::size_t(ku) * nx + i])) * hm / (double(kd - ku) * sp);
        slope[std::size_t(k) * nx + i] = float(std::atan(std::sqrt(gx * gx + gz * gz)) * (180.0 / 3.14159265358979323846));
      }
  }
  for (const OverhangSpec& o : spec.overhangs) {
    // Dilate by the warp's reach (separable max filter, radius r samples).
    const int nx = fr.nx, nz = fr.nz;
    const int r = int(std::ceil(o.strength_m / fr.spacing_m));
    std::vector<float> tmp(fr.count()), out(fr.count());
    for (int k = 0; k < nz; ++k)
      for (int i = 0; i < nx; ++i) {
        float m = 0;
        for (int a = std::max(0, i - r); a <= std::min(nx - 1, i + r); ++a) m = std::max(m, slope[std::size_t(k) * nx + a]);
        tmp[std::size_t(k) * nx + i] = m;
      }
    for (int k = 0; k < nz; ++k)
      for (int i = 0; i < nx; ++i) {
        float m = 0;
        for (int b = std::max(0, k - r); b <= std::min(nz - 1, k + r); ++b) m = std::max(m, tmp[std::size_t(b) * nx + i]);
        out[std::size_t(k) * nx + i] = m;
      }
    p.steep.push_back(std::move(out));
  }
  for (const OverhangSpec& o : spec.overhangs) {
    const float* m = nullptr;
    if (!o.mask.empty()) {
      const Layer& L = t.get(o.mask);
      if (L.channels != 1) throw Error("overhangs.mask", "expected a one-channel layer, got '" + o.mask + "' with " + std::to_string(L.channels) + " channels");
      m = L.data.data();
    }
    p.masks.push_back(m);
    Prepared::Warp w;
    NoiseSettings a = o.noise, b = o.noise;
    b.seed = a.seed + 1;
    w.n1.emplace(a);
    w.n2.emplace(b);
    p.warps.push_back(std::move(w));
    p.max_strength_m = std::max(p.max_strength_m, o.strength_m);
  }
  for (const CaveSpec& c : spec.caves) {
    Prepared::Cave cv;
    if (c.has_cheese) cv.cheese.emplace(c.cheese);
    if (c.has_spaghetti) {
      NoiseSettings b = c.spaghetti;
      b.seed += 1;
      cv.sp1.emplace(c.spaghetti);
      cv.sp2.emplace(b);
    }
    if (c.has_noodle) {
      NoiseSettings b = c.noodle;
      b.seed += 1;
      cv.nd1.emplace(c.noodle);
      cv.nd2.emplace(b);
    }
    if (c.entrances > 0) cv.entrance.emplace(c.entrance);
    constexpr double kTwoPi = 6.283185307179586;
    cv.l_cheese = wavelength_of(c.cheese) / kTwoPi;
    cv.l_sp = wavelength_of(c.spaghetti) / kTwoPi;
    cv.l_nd = wavelength_of(c.noodle) / kTwoPi;
    p.caves.push_back(std::move(cv));
    p.max_depth_m = std::max(p.max_depth_m, c.max_depth_m);
  }
  return p;
}

// Min and max surface height over the samples whose positions lie within [xa, xb] × [za, zb]
// (world metres), grown by one sample so bilinear values between them are bounded too.
void height_bounds(const Terrain& t, double xa, double xb, double za, double zb, double& lo, double& hi) {
  const Frame& f = t.frame;
  const double inv = 1.0 / f.spacing_m;
  // Clamped in double before the conversion (the whole-world call passes ±1e300).
  auto index = [](double u, int n) { return int(std::clamp(u, 0.0, double(n - 1))); };
  const int i0 = index(std::floor(xa * inv - double(f.ix0)) - 1, f.nx);
  const int i1 = index(std::ceil(xb * inv - double(f.ix0)) + 1, f.nx);
  const int k0 = index(std::floor(za * inv - double(f.iz0)) - 1, f.nz);
  const int k1 = index(std::ceil(zb * inv - double(f.iz0)) + 1, f.nz);
  const Layer& h = t.get("height");
  float mn = 1e30f, mx = -1e30f;
  for (int k = k0; k <= k1; ++k) {
    const float* r = h.data.data() + std::size_t(k) * std::size_t(f.nx);
    for (int i = i0; i <= i1; ++i) {
      mn = std::min(mn, r[i]);
      mx = std::max(mx, r[i]);
    }
  }
  lo = (double(mn) - f.sea_level) * f.height_m;
  hi = (double(mx) - f.sea_level) * f.height_m;
}

double voxel_of(const Terrain& t, const VolumeSpec& spec) { return spec.voxel_m > 0 ? spec.voxel_m : t.frame.spacing_m; }

// Per chunk column: the band's bounds (below lo every sample is rock, above hi every sample air).
struct ColumnBounds {
  std::vector<double> lo, hi;
};

ColumnBounds column_bounds(const Terrain& t, const VolumeSpec& spec, const VolumeGrid& g) {
  ColumnBounds b;
  double strength = 0, depth = 0;
  for (auto& o : spec.overhangs) strength = std::max(strength, o.strength_m);
  for (auto& c : spec.caves) depth = std::max(depth, c.max_depth_m);
  b.lo.resize(std::size_t(g.chunks_x) * g.chunks_z);
  b.hi.resize(b.lo.size());
  const double v = g.voxel_m;
  for (int cz = 0; cz < g.chunks_z; ++cz)
    for (int cx = 0; cx < g.chunks_x; ++cx) {
      const double xa = double(g.i0 + std::int64_t(cx) * g.chunk - 1) * v, xb = xa + double(g.chunk + 2) * v;
      const double za = double(g.k0 + std::int64_t(cz) * g.chunk - 1) * v, zb = za + double(g.chunk + 2) * v;
      double lo, hi;
      height_bounds(t, xa - strength, xb + strength, za - strength, zb + strength, lo, hi);
      b.lo[std::size_t(cz) * g.chunks_x + cx] = lo - depth - v;
      b.hi[std::size_t(cz) * g.chunks_x + cx] = hi + v;
    }
  return b;
}

ChunkKind classify(const VolumeSpec& spec, const VolumeGrid& g, const ColumnBounds& b, const Terrain& t, int cx, int cy,
                   int cz) {
  const double v = g.voxel_m;
  const std::int64_t bi = g.i0 + std::int64_t(cx) * g.chunk - 1, bj = g.j0 + std::int64_t(cy) * g.chunk - 1,
                     bk = g.k0 + std::int64_t(cz) * g.chunk - 1;
  const int n = g.chunk + 3;
  const double y_lo = double(bj) * v, y_hi = double(bj + n - 1) * v;
  const std::size_t c = std::size_t(cz) * g.chunks_x + cx;
  if (y_lo > b.hi[c]) return ChunkKind::Air;
  if (y_hi < b.lo[c]) {
    if (!spec.closed) return ChunkKind::Solid;
    const double W = t.frame.world_width_m, D = t.frame.world_depth_m;
    const bool walls = double(bi) * v <= 0.5 * v || double(bi + n - 1) * v >= W - 0.5 * v || double(bk) * v <= 0.5 * v ||
                       double(bk + n - 1) * v >= D - 0.5 * v || y_lo <= g.y_bottom_m + v;
    return walls ? ChunkKind::Surface : ChunkKind::Solid;
  }
  return ChunkKind::Surface;
}

DensityBlock evaluate(const Prepared& p, int cx, int cy, int cz) {
  const VolumeGrid& g = *p.g;
  const VolumeSpec& spec = *p.spec;
  const Frame& f = p.t->frame;
  const double v = g.voxel_m;
  const int n = g.chunk + 3;
  DensityBlock b;
  b.nx = b.ny = b.nz = n;
  b.cell_m = v;
  b.ix0 = g.i0 + std::int64_t(cx) * g.chunk - 1;
  b.iy0 = g.j0 + std::int64_t(cy) * g.chunk - 1;
  b.iz0 = g.k0 + std::int64_t(cz) * g.chunk - 1;
  b.d.resize(std::size_t(n) * n * n);
  const std::size_t cols = std::size_t(n) * n;

  // Per column (i, k): surface height, slope scale, warp weights, entrance masks.
  std::vector<double> h0(cols), cscale(cols);
  std::vector<float> wts(cols * p.warps.size());
  std::vector<float> entr(cols * p.caves.size());
  std::vector<char> row_warp(std::size_t(n) * (p.warps.size() ? 1 : 0), 0);
  const double sp = f.spacing_m;
  for (int k = 0; k < n; ++k) {
    const double z = double(b.iz0 + k) * v;
    for (int i = 0; i < n; ++i) {
      const double x = double(b.ix0 + i) * v;
      const std::size_t c = std::size_t(k) * n + i;
      h0[c] = p.H(x, z);
      const double gx = (p.H(x + sp, z) - p.H(x - sp, z)) / (2 * sp);
      const double gz = (p.H(x, z + sp) - p.H(x, z - sp)) / (2 * sp);
      const double g2 = gx * gx + gz * gz;
      cscale[c] = 1.0 / std::sqrt(1.0 + g2);
      if (!p.warps.empty()) {
        for (std::size_t s = 0; s < p.warps.size(); ++s) {
          const OverhangSpec& o = spec.overhangs[s];
          const double slope_deg = p.s.lerp_layer(p.steep[s].data(), 1, 0, x, z);
          double w = smoothstep(o.min_slope_deg, o.min_slope_deg + 20.0, slope_deg);
          if (p.masks[s]) w *= std::clamp(p.s.lerp_layer(p.masks[s], 1, 0, x, z), 0.0, 1.0);
          wts[s * cols + c] = float(w);
          if (w > 0) row_warp[std::size_t(k)] = 1;
        }
      }
      for (std::size_t s = 0; s < p.caves.size(); ++s) {
        const CaveSpec& cs = spec.caves[s];
        double e = 0;
        if (p.caves[s].entrance) {
          const double u = 0.5 + 0.5 * double(p.caves[s].entrance->at(x, z));
          const double th = 0.5 + 0.35 * (1.0 - 2.0 * std::clamp(cs.entrances, 0.0, 1.0));
          e = smoothstep(th - 0.05, th + 0.05, u);
        }
        entr[s * cols + c] = float(e);
      }
    }
  }

  const std::size_t nr = static_cast<std::size_t>(n);
  std::vector<float> n1(nr, 0.0f), n2(nr, 0.0f), n3(nr, 0.0f), n4(nr, 0.0f);
  std::vector<double> dx(nr, 0.0), dz(nr, 0.0), dens(nr, 0.0), gate(nr, 0.0), carve(nr, 0.0);
  const double W = f.world_width_m, Dm = f.world_depth_m;
  const double delta = 1e-3 * v;
  for (int j = 0; j < n; ++j) {
    const double y = double(b.iy0 + j) * v;
    for (int k = 0; k < n; ++k) {
      const double z = double(b.iz0 + k) * v;
      const std::size_t c0 = std::size_t(k) * n;
      // Base: the (warped) surface.
      bool warped = false;
      if (!p.warps.empty() && row_warp[std::size_t(k)]) {
        std::fill(dx.begin(), dx.end(), 0.0);
        std::fill(dz.begin(), dz.end(), 0.0);
        for (std::size_t s = 0; s < p.warps.size(); ++s) {
          const OverhangSpec& o = spec.overhangs[s];
          const float* w = wts.data() + s * cols + c0;
          bool any = false;
          for (int i = 0; i < n; ++i) any |= w[i] > 0;
          if (!any) continue;
          p.warps[s].n1->row(y * o.vertical, z, b.ix0, v, n, n1.data());
          p.warps[s].n2->row(y * o.vertical, z, b.ix0, v, n, n2.data());
          for (int i = 0; i < n; ++i) {
            if (w[i] <= 0) continue;
            dx[std::size_t(i)] += double(w[i]) * o.strength_m * double(n1[std::size_t(i)]);
            dz[std::size_t(i)] += double(w[i]) * o.strength_m * double(n2[std::size_t(i)]);
          }
        }
        warped = true;
      }
      for (int i = 0; i < n; ++i) {
        const std::size_t c = c0 + std::size_t(i);
        double h = h0[c];
        if (warped && (dx[std::size_t(i)] != 0.0 || dz[std::size_t(i)] != 0.0)) {
          const double x = double(b.ix0 + i) * v;
          h = p.H(x + dx[std::size_t(i)], z + dz[std::size_t(i)]);
        }
        dens[std::size_t(i)] = (h - y) * cscale[c];
      }
      // Caves: carve only where the density is positive and the gate is open.
      for (std::size_t s = 0; s < p.caves.size(); ++s) {
        const CaveSpec& cs = spec.caves[s];
        const Prepared::Cave& cv = p.caves[s];
        const double ramp_top = 2 * v, ramp_deep = std::max(2 * v, 0.2 * cs.max_depth_m);
        bool any = false;
        for (int i = 0; i < n; ++i) {
          const std::size_t c = c0 + std::size_t(i);
          double gt = 0;
          if (dens[std::size_t(i)] > 0) {
            const double depth = h0[c] - y;
            const double cover = cs.cover_m * (1.0 - double(entr[s * cols + c]));
            gt = smoothstep(cover - ramp_top, cover, depth) * (1.0 - smoothstep(cs.max_depth_m - ramp_deep, cs.max_depth_m, depth));
            if (!cs.flooded) gt *= smoothstep(0.0, ramp_top, y);
          }
          gate[std::size_t(i)] = gt;
          any |= gt > 0;
        }
        if (!any) continue;
        std::fill(carve.begin(), carve.end(), 1e30);
        if (cv.cheese) {
          cv.cheese->row(y * cs.cheese_stretch, z, b.ix0, v, n, n1.data());
          for (int i = 0; i < n; ++i)
            carve[std::size_t(i)] = std::min(carve[std::size_t(i)], (cs.cheese_threshold - double(n1[std::size_t(i)])) * cv.l_cheese);
        }
        if (cv.sp1) {
          cv.sp1->row(y, z, b.ix0, v, n, n1.data());
          cv.sp2->row(y, z, b.ix0, v, n, n2.data());
          for (int i = 0; i < n; ++i) {
            const double a = n1[std::size_t(i)], c2 = n2[std::size_t(i)];
            carve[std::size_t(i)] = std::min(carve[std::size_t(i)], (std::sqrt(a * a + c2 * c2) - cs.spaghetti_radius) * cv.l_sp);
          }
        }
        if (cv.nd1) {
          cv.nd1->row(y, z, b.ix0, v, n, n3.data());
          cv.nd2->row(y, z, b.ix0, v, n, n4.data());
          for (int i = 0; i < n; ++i) {
            const double a = n3[std::size_t(i)], c2 = n4[std::size_t(i)];
            carve[std::size_t(i)] = std::min(carve[std::size_t(i)], (std::sqrt(a * a + c2 * c2) - cs.noodle_radius) * cv.l_nd);
          }
        }
        for (int i = 0; i < n; ++i) {
          const double d = dens[std::size_t(i)], gt = gate[std::size_t(i)];
          if (gt > 0) dens[std::size_t(i)] = d - gt * std::max(0.0, d - carve[std::size_t(i)]);
        }
      }
      float* out = b.d.data() + (std::size_t(j) * n + std::size_t(k)) * n;
      for (int i = 0; i < n; ++i) {
        double d = dens[std::size_t(i)];
        if (spec.closed) {
          const double x = double(b.ix0 + i) * v;
          // Walls half a voxel beyond the world's edges and between sample layers at the base, so
          // no sample sits exactly on a wall (a 0 there would put several vertices on one point).
          const double h = 0.5 * v;
          const double box = std::min({x + h, W + h - x, z + h, Dm + h - z, y - g.y_bottom_m, g.y_top_m - y});
          d = std::min(d, box);
        }
        // Never within δ of 0 (a sample on the surface would put the vertices of all its crossed
        // edges on one point: zero-area triangles): the surface moves by at most δ = 10⁻³ voxel.
        if (std::fabs(d) < delta) d = d > 0 ? delta : -delta;
        out[i] = float(d);
      }
    }
  }
  return b;
}

}  // namespace

VolumeGrid volume_grid(const Terrain& t, const VolumeSpec& spec) {
  const Frame& f = t.frame;
  const Layer& h = t.get("height");
  if (h.channels != 1) throw Error("height", "the volume needs a one-channel height layer");
  const std::string at = spec.path.empty() ? std::string("volume") : spec.path;
  if (spec.chunk < 8 || spec.chunk > 128)
    throw Error(at + ".chunk", "expected 8..128 cells per chunk edge, got " + std::to_string(spec.chunk));
  VolumeGrid g;
  g.voxel_m = voxel_of(t, spec);
  if (!(g.voxel_m > 0) || !std::isfinite(g.voxel_m))
    throw Error(at + ".voxel_m", "expected a positive voxel size in metres, got " + std::to_string(g.voxel_m));
  g.chunk = spec.chunk;
  double lo, hi;
  height_bounds(t, -1e300, 1e300, -1e300, 1e300, lo, hi);
  double depth = 0;
  for (auto& c : spec.caves) depth = std::max(depth, c.max_depth_m);
  const double v = g.voxel_m;
  // The base and the top lie halfway between sample layers (never on a sample).
  g.y_bottom_m = (std::floor((lo - std::max(spec.closed ? spec.base_m : 0.0, depth)) / v) - 1.5) * v;
  g.y_top_m = (std::ceil(hi / v) + 2.5) * v;
  const double cells_x = std::round(f.world_width_m / v), cells_z = std::round(f.world_depth_m / v);
  const double ny_d = std::ceil(g.y_top_m / v) + 1 - (std::floor(g.y_bottom_m / v) - 1) + 1;
  const double chunks = std::ceil((cells_x + 2) / g.chunk) * std::ceil((cells_z + 2) / g.chunk) * std::ceil((ny_d - 1) / g.chunk);
  if (!(chunks <= double(spec.max_chunks)))
    throw Error(at + ".voxel_m", "a band of " + std::to_string(std::int64_t(cells_x)) + " x " + std::to_string(std::int64_t(ny_d)) + " x " +
                                      std::to_string(std::int64_t(cells_z)) + " voxels of " + std::to_string(v) +
                                      " m needs more than " + std::to_string(spec.max_chunks) +
                                      " chunks: expected a larger voxel_m or a thinner band");
  g.i0 = -1;
  g.k0 = -1;
  g.j0 = std::int64_t(std::floor(g.y_bottom_m / v)) - 1;
  g.ni = std::int64_t(cells_x) + 3;
  g.nk = std::int64_t(cells_z) + 3;
  g.nj = std::int64_t(ny_d);
  g.chunks_x = int((g.ni - 1 + g.chunk - 1) / g.chunk);
  g.chunks_z = int((g.nk - 1 + g.chunk - 1) / g.chunk);
  g.chunks_y = int((g.nj - 1 + g.chunk - 1) / g.chunk);
  const ColumnBounds b = column_bounds(t, spec, g);
  for (int cy = 0; cy < g.chunks_y; ++cy)
    for (int cz = 0; cz < g.chunks_z; ++cz)
      for (int cx = 0; cx < g.chunks_x; ++cx) g.surface_chunks += classify(spec, g, b, t, cx, cy, cz) == ChunkKind::Surface;
  return g;
}

DensityBlock evaluate_chunk(const Terrain& t, const VolumeSpec& spec, const VolumeGrid& g, int cx, int cy, int cz,
                            std::uint64_t seed) {
  const Prepared p = prepare(t, spec, g, seed);
  return evaluate(p, cx, cy, cz);
}

ChunkKind classify_chunk(const Terrain& t, const VolumeSpec& spec, const VolumeGrid& g, int cx, int cy, int cz) {
  const ColumnBounds b = column_bounds(t, spec, g);
  return classify(spec, g, b, t, cx, cy, cz);
}

namespace {

// Runs `work` on every Surface chunk in batches (parallel within a batch), then `emit` for each
// chunk of the batch in order on the calling thread.
template <class R>
VolumeStats for_chunks(const Terrain& t, const VolumeSpec& spec, const VolumeGrid& g, const Prepared& p,
                       const std::function<R(int, int, int, double&, double&)>& work,
                       const std::function<void(R&&, VolumeStats&)>& emit, const std::function<void(double)>& progress,
                       const std::function<bool()>& cancelled) {
  const ColumnBounds bounds = column_bounds(t, spec, g);
  (void)p;
  VolumeStats st;
  st.chunks = std::int64_t(g.chunks_x) * g.chunks_y * g.chunks_z;
  std::vector<std::array<int, 3>> todo;  // Surface chunks, in output order (y, then z, then x)
  for (int cy = 0; cy < g.chunks_y; ++cy)
    for (int cz = 0; cz < g.chunks_z; ++cz)
      for (int cx = 0; cx < g.chunks_x; ++cx) {
        const ChunkKind k = classify(spec, g, bounds, t, cx, cy, cz);
        if (k == ChunkKind::Air) ++st.air;
        else if (k == ChunkKind::Solid) ++st.solid;
        else todo.push_back({cx, cy, cz});
      }
  st.evaluated = std::int64_t(todo.size());
  const std::size_t batch = 64;
  std::vector<R> out;
  std::vector<double> eval_s, mesh_s;
  for (std::size_t start = 0; start < todo.size(); start += batch) {
    if (cancelled && cancelled()) throw Cancelled();
    const std::size_t m = std::min(batch, todo.size() - start);
    out.assign(m, R{});
    eval_s.assign(m, 0.0);
    mesh_s.assign(m, 0.0);
    tbb::parallel_for(std::size_t(0), m, [&](std::size_t q) {
      const auto [cx, cy, cz] = todo[start + q];
      out[q] = work(cx, cy, cz, eval_s[q], mesh_s[q]);
    });
    for (std::size_t q = 0; q < m; ++q) {
      st.evaluate_s += eval_s[q];
      st.mesh_s += mesh_s[q];
      st.voxels_evaluated += std::int64_t(g.chunk + 3) * (g.chunk + 3) * (g.chunk + 3);
      emit(std::move(out[q]), st);
    }
    if (progress) progress(double(start + m) / double(todo.size()));
  }
  return st;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

VolumeStats evaluate_volume(const Terrain& t, const VolumeSpec& spec, std::uint64_t seed,
                            const std::function<void(int cx, int cy, int cz, const DensityBlock&)>& sink,
                            const std::function<void(double)>& progress, const std::function<bool()>& cancelled) {
  const VolumeGrid g = volume_grid(t, spec);
  const Prepared p = prepare(t, spec, g, seed);
  struct R {
    int cx = 0, cy = 0, cz = 0;
    DensityBlock b;
  };
  return for_chunks<R>(
      t, spec, g, p,
      [&](int cx, int cy, int cz, double& es, double&) {
        const auto t0 = std::chrono::steady_clock::now();
        R r{cx, cy, cz, evaluate(p, cx, cy, cz)};
        es = seconds_since(t0);
        return r;
      },
      [&](R&& r, VolumeStats&) { sink(r.cx, r.cy, r.cz, r.b); }, progress, cancelled);
}

VolumeStats mesh_volume(const Terrain& t, const VolumeSpec& spec, std::uint64_t seed,
                        const std::function<void(VolumeChunkMesh&&)>& sink, const std::function<void(double)>& progress,
                        const std::function<bool()>& cancelled) {
  const VolumeGrid g = volume_grid(t, spec);
  const Prepared p = prepare(t, spec, g, seed);
  const Layer* albedo = t.has("albedo") && t.get("albedo").channels == 3 ? &t.get("albedo")
                        : t.has("color") && t.get("color").channels == 3 ? &t.get("color")
                                                                          : nullptr;
  const double v = g.voxel_m;
  return for_chunks<VolumeChunkMesh>(
      t, spec, g, p,
      [&](int cx, int cy, int cz, double& es, double& ms) {
        const auto t0 = std::chrono::steady_clock::now();
        const DensityBlock b = evaluate(p, cx, cy, cz);
        es = seconds_since(t0);
        const auto t1 = std::chrono::steady_clock::now();
        VolumeMesh vm = mesh_density(b, 1);
        ms = seconds_since(t1);
        VolumeChunkMesh r;
        r.cx = cx;
        r.cy = cy;
        r.cz = cz;
        r.mesh.positions = std::move(vm.positions);
        r.mesh.normals = std::move(vm.normals);
        r.mesh.indices = std::move(vm.indices);
        const std::size_t nv = r.mesh.vertex_count();
        r.mesh.colors.resize(nv * 3);
        for (std::size_t a = 0; a < nv; ++a) {
          const double x = r.mesh.positions[a * 3], y = r.mesh.positions[a * 3 + 1], z = r.mesh.positions[a * 3 + 2];
          double top = 0;
          if (albedo) {
            const double depth = p.H(x, z) - y;
            top = smoothstep(0.45, 0.75, double(r.mesh.normals[a * 3 + 1])) * (1.0 - smoothstep(1.0 * v, 3.0 * v, depth));
          }
          for (int ch = 0; ch < 3; ++ch) {
            const double rock = spec.rock_color[ch];
            const double al = top > 0 ? p.s.lerp_layer(albedo->data.data(), 3, ch, x, z) : rock;
            r.mesh.colors[a * 3 + ch] = float(rock + (al - rock) * top);
          }
        }
        return r;
      },
      [&](VolumeChunkMesh&& r, VolumeStats& st) {
        if (r.mesh.indices.empty()) return;
        ++st.meshed;
        st.triangles += std::int64_t(r.mesh.triangle_count());
        st.vertices += std::int64_t(r.mesh.vertex_count());
        sink(std::move(r));
      },
      progress, cancelled);
}

}  // namespace relief
