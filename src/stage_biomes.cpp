// The `biomes` stage: Voronoi biome regions, each with its own generation rules, and their blending.
//
// Sources:
//   * O. Feldmann, "Island Generator" (2022, seed 003): §2.2.1 Voronoi noise for discrete biome
//     regions; §3.1 land flattened to sea level before biomes raise it again (the island shape then
//     decides what is land), per-biome noise layers remapped by an animation curve and coloured by
//     a gradient; §3.2.1 the selective averaging blend (skips the sea, protects plateaus and spiky
//     peaks) and, as future work, interpolation between the two nearest region points' terrains.
//   * S. Worley, "A Cellular Texture Basis Function", SIGGRAPH 1996: jittered-grid feature points
//     and the nearest-point search over neighbouring cells.
//   * E. J. Gumbel (1954): the Gumbel-max trick, used to mix climate preference with variety.
//
// blend = interpolate (default) generalises seed 003's proposal so that it stays continuous where
// three regions meet: with d₁ the distance to the nearest region point and d_k to the others,
// region k weighs ω_k = smoothstep(1 − (d_k − d₁) / border_m) (ω = 1 for the nearest), normalised.
// (d_k − d₁)/2 approximates the distance to the border between the two regions, so a region fades
// out border_m / 2 beyond its border and two regions weigh ½ each on it. Every region type's
// terrain and colour are evaluated at the sample and mixed by these weights. The seed notes the
// method alone leaves sea cliffs; here the biome lift is multiplied by a taper that rises from 0 at
// the coast (smoothstep of the island shape's own land height over coast_rise), so the land meets
// the sea at sea level everywhere. It also rises with the distance to the sea over coast_m; a
// smoothstep rise of H metres over D is at most 1.5·H/D steep, so a tall biome (a plateau lifted
// 270 m) still rose at up to 60° over the default 150 m. coast_slope_deg bounds that: D becomes
// max(coast_m, 1.5·H/tan(coast_slope_deg)) with H the sample's own lift (stages after this one,
// such as terraces, can steepen it again).
//
// Reach (issue 18): a neighbourhood stage. The coast taper reads the distance to the sea only where
// it is below the longest fade-in D_max = max(coast_m, 1.5 · L · (1 − sea) · height_m /
// tan(coast_slope_deg)) (coast_m alone without coast_slope_deg), L the highest point of any type's
// curve (a monotone curve never overshoots its points, so no lift exceeds L; the per-sample D is
// also clamped to D_max so that a lift rounded an ulp above L cannot reach further): beyond D the
// taper is exactly 1. So the distance is detail::distance_transform_within(D_max / cell) (the exact
// integer squared distance tested before rounding), and the halo is within_halo(D_max / cell)
// samples; every other term depends on the sample's world position, its incoming elevation, the
// seed and the parameters (region points live on a jittered grid of world cells). blend = selective
// adds a neighbourhood pass of selective_radius_m (rounded to samples, at least 1) repeated
// selective_passes times: radius × passes more samples. Whole-map bytes are those of the old
// global definition (a farther sea never changed the taper).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "biomes.hpp"
#include "climate.hpp"
#include "curve.hpp"
#include "parallel.hpp"
#include "relief/error.hpp"
#include "relief/noise.hpp"
#include "relief/random.hpp"
#include "stages.hpp"
#include "texture.hpp"

namespace relief {
namespace detail {
namespace {

Level lv(double at, std::uint32_t color) {
  Level l;
  l.at = at;
  l.color = rgb_hex(color);
  return l;
}

double smoothstep01(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * (3.0 - 2.0 * s);
}

std::uint64_t name_hash(const std::string& s) {  // FNV-1a: a type's noise follows its name, not its position
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : s) h = (h ^ c) * 0x100000001b3ull;
  return h;
}

}  // namespace

std::vector<BiomeType> default_biome_types() {
  auto type = [](const char* name, double a, double r, std::vector<std::string> avoid, double protect,
                 Fractal fractal, int octaves, double wavelength, std::vector<CurvePoint> curve,
                 std::vector<Level> colors) {
    BiomeType t;
    t.name = name;
    t.aridity = a;
    t.ruggedness = r;
    t.avoid = std::move(avoid);
    t.protect_above = protect;
    t.noise.fractal = fractal;
    t.noise.octaves = octaves;
    t.noise.wavelength_m = wavelength;
    t.curve = std::move(curve);
    t.colors = std::move(colors);
    return t;
  };
  std::vector<BiomeType> v;
  v.push_back(type("plains", 0.45, 0.15, {}, 1.0, Fractal::Fbm, 4, 700, {{0.0, 0.015}, {1.0, 0.07}},
                   {lv(0.3, 0x8fba5a), lv(0.7, 0x6e9f45)}));
  v.push_back(type("hills", 0.4, 0.45, {}, 1.0, Fractal::Fbm, 5, 550, {{0.0, 0.03}, {0.5, 0.12}, {1.0, 0.28}},
                   {lv(0.3, 0x79a64c), lv(0.6, 0x5a8a3c), lv(0.9, 0x8c8a62)}));
  v.push_back(type("mountains", 0.3, 0.8, {"desert"}, 1.0, Fractal::Ridged, 6, 1000,
                   {{0.0, 0.06}, {0.4, 0.2}, {0.75, 0.55}, {1.0, 0.8}},
                   {lv(0.3, 0x5f8a42), lv(0.5, 0x7a7066), lv(0.8, 0x8d857c), lv(0.9, 0xf1f2f4)}));
  v.push_back(type("spiky_mountains", 0.6, 0.9, {}, 0.35, Fractal::Ridged, 4, 420,
                   {{0.0, 0.04}, {0.55, 0.09}, {0.8, 0.45}, {1.0, 0.85}},
                   {lv(0.4, 0x6e8f46), lv(0.6, 0x8c8378), lv(0.85, 0xc9c2ba)}));
  BiomeType plateau = type("plateau", 0.7, 0.6, {}, 0.0, Fractal::Fbm, 3, 800,
                           {{0.0, 0.05}, {0.47, 0.07}, {0.53, 0.3}, {1.0, 0.3}},
                           {lv(0.43, 0x7d9a4c), lv(0.49, 0xa4563c), lv(0.54, 0x94729f)});
  v.push_back(plateau);
  BiomeType desert = type("desert", 0.9, 0.2, {"forest", "mountains"}, 1.0, Fractal::Billow, 3, 260,
                          {{0.0, 0.02}, {1.0, 0.09}}, {lv(0.2, 0xe6cf96), lv(0.8, 0xcfae6c)});
  desert.noise.scale_x = 0.35;  // long dune ridges across x
  desert.noise.persistence = 0.4;
  v.push_back(desert);
  v.push_back(type("forest", 0.15, 0.35, {"desert"}, 1.0, Fractal::Fbm, 5, 450, {{0.0, 0.025}, {1.0, 0.14}},
                   {lv(0.3, 0x3f6f35), lv(0.7, 0x2d5628)}));
  return v;
}

int find_type(const std::vector<BiomeType>& types, const std::string& name) {
  for (std::size_t k = 0; k < types.size(); ++k)
    if (types[k].name == name) return int(k);
  return -1;
}

// ================================================================================== region map

std::int64_t RegionMap::cell(double v_m) const { return std::int64_t(std::floor(v_m / size_)); }

RegionMap::RegionMap(const BiomesParams& p, std::uint64_t seed, double x0_m, double z0_m, double x1_m, double z1_m) {
  size_ = p.region_size_m;
  const std::size_t nt = p.types.size();
  avoid_.assign(nt, 0);
  for (std::size_t a = 0; a < nt; ++a)
    for (auto& name : p.types[a].avoid) {
      const int b = find_type(p.types, name);
      if (b < 0) continue;  // validated at parse time
      avoid_[a] |= std::uint64_t(1) << b;
      avoid_[std::size_t(b)] |= std::uint64_t(1) << a;
    }
  bridge_ = std::max(0, find_type(p.types, p.bridge));
  // Queries search ±search cells; the repair of those looks ±4 further (3·size reaches 4 cells).
  // A point in a cell k cells away is at least (k − 1)·size from any position of the centre cell.
  search_ = std::max(2, int(std::ceil(std::sqrt(2.0) + (p.blend == BiomesParams::Blend::Interpolate ? p.border_m : 0.0) / size_)));
  margin_ = search_ + 4;
  cx0_ = cell(x0_m) - margin_;
  cz0_ = cell(z0_m) - margin_;
  ncx_ = int(cell(x1_m) - cell(x0_m)) + 1 + 2 * margin_;
  ncz_ = int(cell(z1_m) - cell(z0_m)) + 1 + 2 * margin_;
  const std::uint64_t s_points = hash64(seed, 0x706f696e74ull), s_prio = hash64(seed, 0x7072696full),
                      s_gumbel = hash64(seed, 0x67756d62ull);
  const Noise aridity(detail::gradient_fbm(p.climate_wavelength_m, 3, hash64(seed, 0x61726964ull)));
  const Noise rugged(detail::gradient_fbm(p.climate_wavelength_m, 3, hash64(seed, 0x72756767ull)));
  cells_.resize(std::size_t(ncx_) * std::size_t(ncz_));
  constexpr double kInvTwoSigma2 = 1.0 / (2.0 * 0.25 * 0.25);
  detail::parallel_rows(ncz_, [&](int b) {
    for (int a = 0; a < ncx_; ++a) {
      Point& pt = cells_[std::size_t(b) * ncx_ + a];
      pt.cx = cx0_ + a;
      pt.cz = cz0_ + b;
      const std::uint64_t h = hash64(s_points, std::uint64_t(pt.cx), std::uint64_t(pt.cz));
      const double u = unit_double(h), v = unit_double(mix64(h));
      pt.x_m = (double(pt.cx) + 0.5 + p.jitter * (u - 0.5)) * size_;
      pt.z_m = (double(pt.cz) + 0.5 + p.jitter * (v - 0.5)) * size_;
      pt.priority = hash64(s_prio, std::uint64_t(pt.cx), std::uint64_t(pt.cz));
      // fBm of 3 octaves rarely leaves ±0.5: stretch to use the whole 0..1 preference range.
      const double ar = std::clamp(0.5 + 1.2 * double(aridity.at(pt.x_m, pt.z_m)), 0.0, 1.0);
      const double ru = std::clamp(0.5 + 1.2 * double(rugged.at(pt.x_m, pt.z_m)), 0.0, 1.0);
      double best = -1e300;
      for (std::size_t k = 0; k < nt; ++k) {
        const BiomeType& t = p.types[k];
        if (t.weight <= 0.0) continue;
        const double g = unit_double(hash64(s_gumbel, hash64(std::uint64_t(pt.cx), std::uint64_t(pt.cz)), k));
        const double gumbel = -std::log(-std::log(std::clamp(g, 1e-12, 1.0 - 1e-12)));
        const double score = std::log(t.weight) -
                             ((ar - t.aridity) * (ar - t.aridity) + (ru - t.ruggedness) * (ru - t.ruggedness)) * kInvTwoSigma2 +
                             p.variety * gumbel;
        if (score > best) best = score, pt.initial = int(k);
      }
      pt.type = pt.initial;
    }
  });
  // Adjacency repair, reading initial types only (so the order of this loop does not matter).
  const double reach2 = 9.0 * size_ * size_;
  auto higher = [](const Point& q, const Point& c) {
    if (q.priority != c.priority) return q.priority > c.priority;
    return q.cz != c.cz ? q.cz > c.cz : q.cx > c.cx;
  };
  detail::parallel_rows(ncz_ - 8, [&](int bb) {
    const int b = bb + 4;
    for (int a = 4; a < ncx_ - 4; ++a) {
      Point& c = cells_[std::size_t(b) * ncx_ + a];
      for (int db = -4; db <= 4 && c.type != bridge_; ++db)
        for (int da = -4; da <= 4; ++da) {
          if (da == 0 && db == 0) continue;
          const Point& q = cells_[std::size_t(b + db) * ncx_ + (a + da)];
          const double dx = q.x_m - c.x_m, dz = q.z_m - c.z_m;
          if (dx * dx + dz * dz > reach2 || !conflict(c.initial, q.initial) || !higher(q, c)) continue;
          c.type = bridge_;
          break;
        }
    }
  });
}

const RegionMap::Point& RegionMap::at(std::int64_t cx, std::int64_t cz) const {
  return cells_[std::size_t(cz - cz0_) * std::size_t(ncx_) + std::size_t(cx - cx0_)];
}

const RegionMap::Point& RegionMap::nearest(double x_m, double z_m) const {
  const std::int64_t cx = cell(x_m), cz = cell(z_m);
  const Point* best = nullptr;
  double bd = 0;
  for (std::int64_t b = cz - search_; b <= cz + search_; ++b)
    for (std::int64_t a = cx - search_; a <= cx + search_; ++a) {
      const Point& q = at(a, b);
      const double d = (q.x_m - x_m) * (q.x_m - x_m) + (q.z_m - z_m) * (q.z_m - z_m);
      if (!best || d < bd) best = &q, bd = d;
    }
  return *best;
}

std::vector<RegionMap::Point> RegionMap::points() const {
  std::vector<Point> out;
  for (int b = 4; b < ncz_ - 4; ++b)
    for (int a = 4; a < ncx_ - 4; ++a) out.push_back(cells_[std::size_t(b) * ncx_ + a]);
  return out;
}

}  // namespace detail

namespace stages {
namespace {

using detail::BiomesParams;
using detail::BiomeType;
using detail::smoothstep01;

// One biome type made ready to evaluate.
struct TypeEval {
  std::unique_ptr<Noise> noise;
  std::unique_ptr<detail::Curve> curve;
  std::vector<std::shared_ptr<const detail::Texture>> level_textures;
  std::shared_ptr<const detail::Texture> texture;
  const BiomeType* rules = nullptr;
  Rgb color(double n, double x, double z) const {
    return texture ? texture->sample(x, z, rules->tile_m) : detail::level_color(rules->colors, level_textures, true, float(n), x, z);
  }
};

// `world_width_m` gives `frequency` its meaning (cycles across the world) when wavelength_m is 0.
NoiseSettings type_noise(const BiomeType& t, double world_width_m, std::uint64_t seed) {
  return t.noise.settings(world_width_m, seed);
}

std::vector<TypeEval> prepare_types(const BiomesParams& p, double world_width_m, std::uint64_t seed, const std::string& path) {
  std::vector<TypeEval> out(p.types.size());
  for (std::size_t k = 0; k < p.types.size(); ++k) {
    const BiomeType& t = p.types[k];
    const std::string tp = path + ".types[" + std::to_string(k) + "]";
    out[k].rules = &t;
    out[k].noise = std::make_unique<Noise>(type_noise(t, world_width_m, hash64(seed, detail::name_hash(t.name))));
    out[k].curve = std::make_unique<detail::Curve>(t.curve);
    out[k].level_textures = detail::load_level_textures(t.colors, tp + ".colors");
    if (!t.texture.empty()) out[k].texture = detail::load_texture(t.texture, tp + ".texture");
  }
  return out;
}

// Masked box average (seed 003's selective averaging): every sample with mask = 1 takes the mean of
// the masked samples in the (2r+1)² square around it, for the height and the three albedo
// channels; samples with mask = 0 (sea, protected) neither change nor contribute. Separable sums
// in double, in a fixed order: identical for any thread count.
void masked_box(const Frame& fr, Layer& h, Layer& albedo, const std::vector<std::uint8_t>& mask, int r) {
  const int nx = fr.nx, nz = fr.nz;
  constexpr int C = 5;  // m·h, m·r, m·g, m·b, m
  std::vector<double> hs(fr.count() * C);
  auto value = [&](std::size_t k, int c) -> double {
    if (!mask[k]) return 0.0;
    return c == 0 ? double(h.data[k]) : c < 4 ? double(albedo.data[3 * k + std::size_t(c - 1)]) : 1.0;
  };
  detail::parallel_rows(nz, [&](int j) {
    const std::size_t row = std::size_t(j) * nx;
    for (int c = 0; c < C; ++c) {
      double s = 0;
      for (int i = 0; i <= std::min(r, nx - 1); ++i) s += value(row + i, c);
      for (int i = 0; i < nx; ++i) {
        hs[(row + i) * C + c] = s;
        if (i + r + 1 < nx) s += value(row + i + r + 1, c);
        if (i - r >= 0) s -= value(row + i - r, c);
      }
    }
  });
  std::vector<float> nh(h.data), na(albedo.data);
  detail::parallel_rows(nx, [&](int i) {
    double s[C] = {0, 0, 0, 0, 0};
    for (int j = 0; j <= std::min(r, nz - 1); ++j)
      for (int c = 0; c < C; ++c) s[c] += hs[(std::size_t(j) * nx + i) * C + c];
    for (int j = 0; j < nz; ++j) {
      const std::size_t k = std::size_t(j) * nx + i;
      if (mask[k] && s[4] > 0.5) {
        nh[k] = float(s[0] / s[4]);
        for (int c = 0; c < 3; ++c) na[3 * k + c] = float(s[c + 1] / s[4]);
      }
      for (int c = 0; c < C; ++c) {
        if (j + r + 1 < nz) s[c] += hs[(std::size_t(j + r + 1) * nx + i) * C + c];
        if (j - r >= 0) s[c] -= hs[(std::size_t(j - r) * nx + i) * C + c];
      }
    }
  }, 16);
  h.data.swap(nh);
  albedo.data.swap(na);
}

// D_max of the note at the top of the file, in metres (0 without coast_m).
double coast_reach_max_m(const BiomesParams& p, const Frame& fr) {
  if (!(p.coast_m > 0)) return 0.0;
  if (!(p.coast_slope_deg > 0)) return p.coast_m;
  double top = 0;
  for (const BiomeType& t : p.types)
    for (const CurvePoint& c : t.curve) top = std::max(top, c.y);
  const double tan_coast = std::tan(std::clamp(p.coast_slope_deg, 1e-3, 89.0) * std::numbers::pi / 180.0);
  return std::max(p.coast_m, 1.5 * top * (1.0 - fr.sea_level) * fr.height_m / tan_coast);
}

int selective_radius(const BiomesParams& p, const Frame& fr) {
  return std::max(1, int(std::lround(p.selective_radius_m / fr.cell_m())));
}

Reach biomes_reach(const BiomesParams& p, const Frame& fr) {
  const double reach_max = coast_reach_max_m(p, fr);
  std::int64_t halo = reach_max > 0 ? detail::within_halo(reach_max / fr.cell_m()) : 0;
  if (p.blend == BiomesParams::Blend::Selective) halo += std::int64_t(selective_radius(p, fr)) * p.selective_passes;
  return neighbourhood(int(std::min<std::int64_t>(halo, 1 << 28)));
}

void apply_biomes(Terrain& t, const BiomesParams& p, const Context& ctx) {
  const Frame& fr = t.frame;
  const std::string path = "stages[" + std::to_string(ctx.stage_index) + "]";
  Layer& h = t.get("height");
  if (h.channels != 1 || h.data.size() != fr.count()) throw Error("", "layer 'height' does not match the frame");
  const double sea = fr.sea_level, land = 1.0 - sea;
  const std::uint64_t seed = ctx.stage_seed();
  const std::vector<TypeEval> types = prepare_types(p, fr.world_width_m, seed, path);
  const detail::RegionMap map(p, seed, fr.x_m(0), fr.z_m(0), fr.x_m(fr.nx - 1), fr.z_m(fr.nz - 1));
  using Blend = BiomesParams::Blend;
  const int mode = p.blend == Blend::Interpolate ? 0 : p.blend == Blend::Selective ? 1 : 2;
  const double keep = p.flatten_land ? p.flatten_keep : 1.0;
  const std::size_t nt = types.size();

  const double tan_coast = std::tan(std::clamp(p.coast_slope_deg, 1e-3, 89.0) * std::numbers::pi / 180.0);
  // Distance from each land sample to the nearest sea sample of the incoming terrain, in metres.
  // +∞ at D_max and beyond (where the taper is 1 whatever the distance).
  std::vector<float> coast_dist;
  const double coast_reach_max = coast_reach_max_m(p, fr);
  if (p.coast_m > 0) {
    std::vector<unsigned char> sea_mask(fr.count());
    for (std::size_t k = 0; k < sea_mask.size(); ++k) sea_mask[k] = double(h.data[k]) <= sea;
    coast_dist = detail::distance_transform_within(sea_mask, fr.nx, fr.nz, coast_reach_max / fr.cell_m());
  }
  Layer& albedo = t.layer("albedo", 3);
  Layer& biome = t.layer("biome", 1);
  std::vector<std::uint8_t> movable(mode == 1 ? fr.count() : 0);
  constexpr int kMax = 8;  // regions mixed at one sample (more only in degenerate layouts: weakest dropped)
  constexpr int kSearchMax = 9 * 9;  // border_m ≤ 2 · region_size_m → search ≤ 4

  detail::parallel_rows(fr.nz, [&](int j) {
    const int nx = fr.nx;
    const double z = fr.z_m(j);
    struct Mix {
      int n = 0, nearest = 0;
      int type[kMax];
      double w[kMax];
    };
    thread_local std::vector<Mix> mixes;
    thread_local std::vector<std::vector<float>> rows;
    thread_local std::vector<int> uses;
    mixes.assign(std::size_t(nx), Mix{});
    uses.assign(nt, 0);
    rows.resize(nt);
    float* hrow = h.row(j, nx);
    for (int i = 0; i < nx; ++i) {
      if (double(hrow[i]) <= sea) continue;
      const double x = fr.x_m(i);
      Mix& m = mixes[std::size_t(i)];
      const std::int64_t cx = map.cell(x), cz = map.cell(z);
      double d[kSearchMax];
      int tp[kSearchMax];
      double d1 = 1e300;
      int k1 = 0, n = 0;
      const int sr = map.search();
      for (std::int64_t b = cz - sr; b <= cz + sr; ++b)
        for (std::int64_t a = cx - sr; a <= cx + sr; ++a, ++n) {
          const auto& q = map.at(a, b);
          d[n] = std::hypot(q.x_m - x, q.z_m - z);
          tp[n] = q.type;
          if (d[n] < d1) d1 = d[n], k1 = n;
        }
      m.nearest = tp[k1];
      auto add = [&](int type, double w) {
        for (int s = 0; s < m.n; ++s)
          if (m.type[s] == type) {
            m.w[s] += w;
            return;
          }
        if (m.n < kMax) {
          m.type[m.n] = type;
          m.w[m.n++] = w;
          return;
        }
        int weakest = 0;
        for (int s = 1; s < m.n; ++s)
          if (m.w[s] < m.w[weakest]) weakest = s;
        if (w > m.w[weakest]) m.type[weakest] = type, m.w[weakest] = w;
      };
      if (mode == 0) {
        for (int s = 0; s < n; ++s) {
          const double delta = d[s] - d1;
          if (s == k1 || delta < p.border_m) add(tp[s], s == k1 ? 1.0 : smoothstep01(1.0 - delta / p.border_m));
        }
      } else {
        add(tp[k1], 1.0);
      }
      double sum = 0;
      for (int s = 0; s < m.n; ++s) sum += m.w[s];
      for (int s = 0; s < m.n; ++s) {
        m.w[s] /= sum;
        ++uses[std::size_t(m.type[s])];
      }
    }
    // Whole-row noise for types used by many samples of the row (row() is faster per sample and
    // bit-identical to at()).
    for (std::size_t k = 0; k < nt; ++k)
      if (uses[k] * 8 >= nx) {
        rows[k].resize(std::size_t(nx));
        types[k].noise->row(z, fr.ix0, fr.cell_m(), nx, rows[k].data());
      }
    float* arow = albedo.row(j, nx);
    float* brow = biome.row(j, nx);
    for (int i = 0; i < nx; ++i) {
      const double x = fr.x_m(i);
      const double e0 = hrow[i];
      if (e0 <= sea) {
        const Rgb c = p.sea.sea_at(e0, sea);
        arow[3 * i + 0] = c.r;
        arow[3 * i + 1] = c.g;
        arow[3 * i + 2] = c.b;
        brow[i] = 0.0f;
        continue;
      }
      const Mix& m = mixes[std::size_t(i)];
      double lift = 0, r = 0, g = 0, b = 0;
      for (int s = 0; s < m.n; ++s) {
        const TypeEval& te = types[std::size_t(m.type[s])];
        const double nraw = rows[std::size_t(m.type[s])].size() == std::size_t(nx) && uses[std::size_t(m.type[s])] * 8 >= nx
                                ? double(rows[std::size_t(m.type[s])][std::size_t(i)])
                                : double(te.noise->at(x, z));
        const double n = std::clamp(0.5 + 0.5 * te.rules->contrast * nraw, 0.0, 1.0);
        const Rgb c = te.color(n, x, z);
        lift += m.w[s] * (*te.curve)(n);
        r += m.w[s] * c.r;
        g += m.w[s] * c.g;
        b += m.w[s] * c.b;
      }
      const double u0 = (e0 - sea) / land;
      double taper = p.coast_rise > 0 ? smoothstep01(u0 / p.coast_rise) : 1.0;
      if (p.coast_m > 0) {
        const double dm = double(coast_dist[std::size_t(j) * nx + i]) * fr.cell_m();
        // A smoothstep rise of H metres over D metres is at most 1.5·H/D steep: with
        // coast_slope_deg, D grows with this sample's lift so that the fade-in stays under it.
        const double reach_m = p.coast_slope_deg > 0
                                   ? std::min(coast_reach_max, std::max(p.coast_m, 1.5 * std::max(0.0, lift) * land * fr.height_m / tan_coast))
                                   : p.coast_m;
        if (std::isfinite(dm)) taper *= smoothstep01(dm / reach_m);
      }
      const double u = keep * u0 + lift * taper;
      const double e = std::clamp(sea + land * u, sea + 1e-5, 1.0);
      hrow[i] = float(e);
      const double bw = p.beach_lift > 0 ? 1.0 - smoothstep01((u - 0.5 * p.beach_lift) / (0.5 * p.beach_lift)) : 0.0;
      arow[3 * i + 0] = float(r + (p.sea.beach_color.r - r) * bw);
      arow[3 * i + 1] = float(g + (p.sea.beach_color.g - g) * bw);
      arow[3 * i + 2] = float(b + (p.sea.beach_color.b - b) * bw);
      brow[i] = bw > 0.5 ? 1.0f : float(2 + m.nearest);
      if (mode == 1) movable[std::size_t(j) * nx + i] = lift * taper < types[std::size_t(m.nearest)].rules->protect_above;
    }
  });

  if (mode == 1) {
    const int r = selective_radius(p, fr);
    for (int pass = 0; pass < p.selective_passes; ++pass) masked_box(fr, h, albedo, movable, r);
  }

  t.biomes.clear();
  t.biomes.push_back({"ocean", p.sea.sea_shallow.r, p.sea.sea_shallow.g, p.sea.sea_shallow.b});
  t.biomes.push_back({"beach", p.sea.beach_color.r, p.sea.beach_color.g, p.sea.beach_color.b});
  for (auto& te : types) {
    const Rgb c = te.texture ? Rgb{te.texture->rgb[0], te.texture->rgb[1], te.texture->rgb[2]}
                             : detail::level_color(te.rules->colors, {}, true, 0.5f, 0, 0);
    t.biomes.push_back({te.rules->name, c.r, c.g, c.b});
  }
}

void validate_biomes(const BiomesParams& p, const std::string& path) {
  if (p.types.size() > 60) throw Error(path + ".types", "expected at most 60 types, got " + std::to_string(p.types.size()));
  bool any = false;
  for (std::size_t k = 0; k < p.types.size(); ++k) {
    const BiomeType& t = p.types[k];
    const std::string tp = path + ".types[" + std::to_string(k) + "]";
    if (t.name.empty()) throw Error(tp + ".name", "expected a non-empty name");
    if (detail::find_type(p.types, t.name) != int(k)) throw Error(tp + ".name", "duplicate type name \"" + t.name + "\"");
    if (t.name == "ocean" || t.name == "beach") throw Error(tp + ".name", "\"" + t.name + "\" is reserved for the sea and the coast");
    for (std::size_t a = 0; a < t.avoid.size(); ++a)
      if (detail::find_type(p.types, t.avoid[a]) < 0)
        throw Error(tp + ".avoid[" + std::to_string(a) + "]", "unknown type \"" + t.avoid[a] + "\"");
    any = any || t.weight > 0;
    try {
      Noise n(type_noise(t, 1.0, 0));  // frequency checked as cycles per metre of a 1 m world
    } catch (const Error& e) {
      throw Error(e.path().empty() ? tp : tp + "." + e.path(), e.message());
    }
    detail::load_level_textures(t.colors, tp + ".colors");
    if (!t.texture.empty()) detail::load_texture(t.texture, tp + ".texture");
  }
  if (!any) throw Error(path + ".types", "expected at least one type with weight > 0");
  const int bridge = detail::find_type(p.types, p.bridge);
  if (bridge < 0) throw Error(path + ".bridge", "unknown type \"" + p.bridge + "\"");
  for (std::size_t k = 0; k < p.types.size(); ++k) {
    bool clash = false;
    for (auto& a : p.types[k].avoid) clash = clash || a == p.bridge;
    for (auto& a : p.types[std::size_t(bridge)].avoid) clash = clash || a == p.types[k].name;
    if (clash)
      throw Error(path + ".bridge", "the bridge type must be allowed beside every type, but \"" + p.bridge +
                                        "\" and \"" + p.types[k].name + "\" avoid each other");
  }
  if (p.border_m > 2.0 * p.region_size_m)
    throw Error(path + ".border_m", "expected at most twice region_size_m (" + std::to_string(2.0 * p.region_size_m) +
                                        "), got " + std::to_string(p.border_m));
}

Table<BiomeType> type_table() {
  using T = BiomeType;
  Table<T> t{{
      text(&T::name, "name", "Type name (shown in biomes.json; props name it)"),
      param(&T::aridity, "aridity", 0.0, 1.0, "", "Preferred aridity of the climate field (0 wet, 1 dry)"),
      param(&T::ruggedness, "ruggedness", 0.0, 1.0, "", "Preferred ruggedness of the climate field (0 flat, 1 rugged)"),
      param(&T::weight, "weight", 0.0, 100.0, "", "How often the type is chosen (0 = only as the bridge)"),
      names(&T::avoid, "avoid", "Types that must never border this one (symmetric)"),
      param(&T::protect_above, "protect_above", 0.0, 1.0, "",
            "Selective blending leaves samples with lift ≥ this untouched (0 = the whole biome, 1 = none)"),
  }};
  embed(t.fields, &T::noise, detail::noise_fields_table());
  for (auto& f : std::vector<Field<T>>{
      param(&T::contrast, "contrast", 0.1, 10.0, "", "n = clamp(0.5 + contrast · noise / 2): spreads the noise over 0..1"),
      relief::curve(&T::curve, "curve", 0.0, 1.0,
                    "Animation curve [[n, lift], …]: noise n (0..1) to lift above sea level as a fraction of the land "
                    "range; monotone cubic"),
      levels(&T::colors, "colors", 0.0, 1.0, "Colour gradient on the noise value n (levels may name a texture)"),
      text(&T::texture, "texture", "PNG file tiled over the whole biome instead of its colours (\"\" = none)", Effect::Recolour),
      param(&T::tile_m, "tile_m", 0.01, 1e6, "m", "Texture repeat", Effect::Recolour),
       })
    t.fields.push_back(std::move(f));
  return t;
}

}  // namespace

StageDef biomes() {
  using P = BiomesParams;
  Table<P> table{{
      param(&P::region_size_m, "region_size_m", 10.0, 1e6, "m", "Cell of the jittered grid of region points (mean region width)"),
      param(&P::jitter, "jitter", 0.0, 1.0, "", "How far region points stray from their cell centres"),
      records(&P::types, "types", type_table(), 1, 60, "Biome types and their generation rules"),
      param(&P::climate_wavelength_m, "climate_wavelength_m", 10.0, 1e7, "m",
            "Wavelength of the aridity and ruggedness fields that choose each region's type"),
      param(&P::variety, "variety", 0.0, 10.0, "", "Randomness of the choice (Gumbel noise on the climate score)"),
      text(&P::bridge, "bridge", "Type given to a region whose type would border one it avoids"),
      param(&P::flatten_land, "flatten_land", 0, 1, "",
            "Flatten land to sea level before the biomes raise it (seed 003): the island shape decides only what is land"),
      param(&P::flatten_keep, "flatten_keep", 0.0, 1.0, "",
            "Fraction of the island shape's land height kept when flattening (0 = flat like seed 003)"),
      param(&P::coast_m, "coast_m", 0.0, 1e6, "m",
            "Biome relief fades in over this distance from the sea (smoothstep): no sea cliffs; 0 = off"),
      param(&P::coast_slope_deg, "coast_slope_deg", 0.0, 60.0, "deg",
            "With coast_m: lengthen the fade-in where a biome lifts the land high, so that it rises no steeper than "
            "this (a plateau's 270 m over 150 m rose at up to 60°); 0 = coast_m everywhere"),
      param(&P::coast_rise, "coast_rise", 0.0, 1.0, "",
            "Also fade it in over this much of the island shape's own land height (0 = off)"),
      choice(&P::blend, "blend",
             {{P::Blend::Interpolate, "interpolate"}, {P::Blend::Selective, "selective"}, {P::Blend::None, "none"}},
             "interpolate: mix region terrains within border_m; selective: seed 003's masked averaging; none: hard borders"),
      param(&P::border_m, "border_m", 0.0, 1e6, "m", "interpolate: width of the transition between two regions"),
      param(&P::selective_radius_m, "selective_radius_m", 0.0, 1e5, "m",
            "selective: half-width of the averaging square (at least one sample)"),
      param(&P::selective_passes, "selective_passes", 1, 16, "", "selective: averaging passes"),
  }};
  embed(table.fields, &P::sea, detail::sea_colors_table());
  table.fields.push_back(
      param(&P::beach_lift, "beach_lift", 0.0, 1.0, "", "Land lower than this (fraction of the land range) is beach"));
  StageDef d = make_stage<P>("biomes",
                       "Voronoi biome regions with their own noise, curve and colours, blended; writes height, albedo, "
                       "biome",
                       neighbourhood(biomes_reach(P{}, Frame{}).halo), std::move(table), apply_biomes, validate_biomes,
                       biomes_reach,
                       "the coast fade-in's longest reach D_max (coast_m, longer with coast_slope_deg for the highest "
                       "curve point): floor of the largest distance below D_max / cell, in samples; selective blend adds "
                       "radius × passes");
  d.memory = {{{"albedo", 3}, {"biome", 1}}, {}, 12, {}};
  return d;
}

}  // namespace stages
}  // namespace relief
