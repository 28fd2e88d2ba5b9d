// The `climate` stage: moisture and temperature fields classified into biomes (seed 003 §2.2.2).
//
// Sources:
//   * O. Feldmann, "Island Generator" (2022, seed 003) §2.2.2: layered moisture and temperature
//     maps give smooth biome transitions that relate to their neighbours (snowy vs barren peaks).
//   * R. H. Whittaker, "Communities and Ecosystems" (1975): biomes by temperature and precipitation.
//   * A. Patel, "Polygonal Map Generation for Games" (Red Blob Games, 2010): the simplified
//     Whittaker table, moisture rising towards water, temperature falling with elevation.
//   * P. F. Felzenszwalb, D. P. Huttenlocher, "Distance Transforms of Sampled Functions" (2012).
//
// temperature = clamp(temperature_base + temperature_noise · nT − lapse · u − latitude · (1 − z/D))
// moisture    = clamp(moisture_base + moisture_noise · nM + sea_moisture · s(d_sea))
// with nT, nM fBm noise in about [−1, 1], u = (e − sea)/(1 − sea) the height above the sea as a
// fraction of the land range, z/D the position from the north (z-min) edge, d_sea the distance to
// the nearest sea sample in metres, and the sea's share
//     s(d) = (exp(−d / coast_m) − exp(−K)) / (1 − exp(−K))   for d < K · coast_m,  0 beyond,
// K = kSeaReachCoasts = 8: the exponential fall cut where it is below 3.4·10⁻⁴ and lowered by that
// much so that it meets 0 continuously (issue 18; before, s was exp(−d / coast_m) everywhere and
// d_sea a distance transform of the whole map: now the stage reads the sea only within
// K · coast_m, so it is a neighbourhood stage, exact on windows and in tiled worlds).
// Halo: within_halo(K · coast_m / cell) samples (climate.hpp): every sea sample nearer than the cut
// lies within it. Moisture moves by at most sea_moisture · 3.4·10⁻⁴ against the old definition.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "climate.hpp"
#include "parallel.hpp"
#include "relief/error.hpp"
#include "relief/noise.hpp"
#include "shared_tables.hpp"
#include "stages.hpp"
#include "texture.hpp"

namespace relief {
namespace detail {

namespace {
ClimateBiome row(const char* name, std::uint32_t color, double t0, double t1, double m0, double m1) {
  return {.name = name, .color = rgb_hex(color), .temperature_min = t0, .temperature_max = t1, .moisture_min = m0,
          .moisture_max = m1};
}

// 1-D squared distance transform of f (Felzenszwalb & Huttenlocher, Algorithm 1), in double
// (q² reaches 10⁹ on the largest grids). Infinite samples never contribute a parabola.
void dt1(const double* f, int n, double* d, int* v, double* z) {
  const double inf = std::numeric_limits<double>::infinity();
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (std::isinf(f[q])) continue;
    if (k < 0) {
      k = 0;
      v[0] = q;
      z[0] = -inf;
      z[1] = inf;
      continue;
    }
    double s;
    while (true) {
      const int p = v[k];
      s = ((f[q] + double(q) * q) - (f[p] + double(p) * p)) / (2.0 * double(q - p));
      if (s <= z[k]) --k;  // z[0] = −∞ stops this at k = 0
      else break;
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = inf;
  }
  if (k < 0) {
    for (int q = 0; q < n; ++q) d[q] = inf;
    return;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < double(q)) ++k;
    const double dq = double(q - v[k]);
    d[q] = dq * dq + f[v[k]];
  }
}
}  // namespace

std::vector<ClimateBiome> whittaker_table() {
  return {
      row("scorched", 0x555555, 0.0, 0.25, 0.0, 1.0 / 6),
      row("bare rock", 0x888888, 0.0, 0.25, 1.0 / 6, 2.0 / 6),
      row("tundra", 0xbbbbaa, 0.0, 0.25, 2.0 / 6, 3.0 / 6),
      row("snow", 0xf4f6f8, 0.0, 0.25, 3.0 / 6, 1.0),
      row("temperate desert", 0xc9d29b, 0.25, 0.5, 0.0, 2.0 / 6),
      row("shrubland", 0x889977, 0.25, 0.5, 2.0 / 6, 4.0 / 6),
      row("taiga", 0x99aa77, 0.25, 0.5, 4.0 / 6, 1.0),
      row("temperate desert", 0xc9d29b, 0.5, 0.75, 0.0, 1.0 / 6),
      row("grassland", 0x88aa55, 0.5, 0.75, 1.0 / 6, 3.0 / 6),
      row("temperate forest", 0x679459, 0.5, 0.75, 3.0 / 6, 5.0 / 6),
      row("temperate rainforest", 0x448855, 0.5, 0.75, 5.0 / 6, 1.0),
      row("subtropical desert", 0xd2b98b, 0.75, 1.0, 0.0, 1.0 / 6),
      row("grassland", 0x88aa55, 0.75, 1.0, 1.0 / 6, 2.0 / 6),
      row("tropical seasonal forest", 0x559944, 0.75, 1.0, 2.0 / 6, 4.0 / 6),
      row("tropical rainforest", 0x337755, 0.75, 1.0, 4.0 / 6, 1.0),
  };
}

int classify(const std::vector<ClimateBiome>& table, double t, double m) {
  auto in = [](double v, double lo, double hi) { return v >= lo && (v < hi || (hi >= 1.0 && v <= hi)); };
  for (std::size_t k = 0; k < table.size(); ++k)
    if (in(t, table[k].temperature_min, table[k].temperature_max) && in(m, table[k].moisture_min, table[k].moisture_max))
      return int(k);
  return -1;
}

namespace {
// Squared distances (exact integers in double: the lower envelope's minimum at integer q is
// dq² + f[v], sums of squares of integers far below 2⁵³) to the nearest source, +∞ with none.
std::vector<double> squared_distances(const std::vector<unsigned char>& source, int nx, int nz) {
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> g(std::size_t(nx) * std::size_t(nz));
  const std::size_t sx = std::size_t(nx), sz = std::size_t(nz);
  // Columns: f = 0 at sources, ∞ elsewhere.
  parallel_rows(nx, [&](int i) {
    std::vector<double> f(sz), d(sz), zz(sz + 1);
    std::vector<int> v(sz);
    for (std::size_t j = 0; j < sz; ++j) f[j] = source[j * sx + std::size_t(i)] ? 0.0 : inf;
    dt1(f.data(), nz, d.data(), v.data(), zz.data());
    for (std::size_t j = 0; j < sz; ++j) g[j * sx + std::size_t(i)] = d[j];
  }, 16);
  std::vector<double> out(g.size());
  parallel_rows(nz, [&](int j) {
    std::vector<double> zz(sx + 1);
    std::vector<int> v(sx);
    dt1(g.data() + std::size_t(j) * sx, nx, out.data() + std::size_t(j) * sx, v.data(), zz.data());
  }, 16);
  return out;
}
}  // namespace

std::vector<float> distance_transform(const std::vector<unsigned char>& source, int nx, int nz) {
  std::vector<double> d2 = squared_distances(source, nx, nz);
  std::vector<float> out(d2.size());
  for (std::size_t k = 0; k < d2.size(); ++k) out[k] = float(std::sqrt(d2[k]));
  return out;
}

double within_limit(double cap) { return cap > 0 ? std::ceil(cap * cap) - 1.0 : -1.0; }

int within_halo(double cap) {
  const double lim = within_limit(cap);
  if (lim < 0) return 0;
  auto h = std::int64_t(std::sqrt(lim));
  while (double(h) * double(h) > lim) --h;  // exact floor(√lim) whatever sqrt's rounding
  while (double(h + 1) * double(h + 1) <= lim) ++h;
  return int(std::min<std::int64_t>(h, std::numeric_limits<int>::max() / 4));
}

std::vector<float> distance_transform_within(const std::vector<unsigned char>& source, int nx, int nz, double cap) {
  const double lim = within_limit(cap);
  std::vector<double> d2 = squared_distances(source, nx, nz);
  std::vector<float> out(d2.size());
  for (std::size_t k = 0; k < d2.size(); ++k)
    out[k] = d2[k] <= lim ? float(std::sqrt(d2[k])) : std::numeric_limits<float>::infinity();
  return out;
}

}  // namespace detail

namespace stages {
namespace {

using detail::ClimateBiome;
constexpr double kSeaReachCoasts = 8.0;  // the sea's moisture is cut at this many coast_m

struct ClimateParams {
  double temperature_wavelength_m = 3000, moisture_wavelength_m = 1800;
  double temperature_base = 0.8, temperature_noise = 0.25, lapse = 0.9, latitude = 0.0;
  double moisture_base = 0.3, moisture_noise = 0.45, sea_moisture = 0.35, coast_m = 250;
  std::vector<ClimateBiome> table = detail::whittaker_table();
  detail::SeaColors sea;  // sea_shallow, sea_deep, sea_deep_depth, beach_color
  double beach_height = 0.006;
};

void apply_climate(Terrain& t, const ClimateParams& p, const Context& ctx) {
  const Frame& fr = t.frame;
  const std::string path = "stages[" + std::to_string(ctx.stage_index) + "]";
  const Layer& h = t.get("height");
  if (h.channels != 1 || h.data.size() != fr.count()) throw Error("", "layer 'height' does not match the frame");
  const double sea = fr.sea_level, land = std::max(1e-9, 1.0 - sea);
  // Legend: ocean, beach, then the table's names in order of first appearance.
  std::vector<int> id_of_row(p.table.size());
  t.biomes.clear();
  t.biomes.push_back({"ocean", p.sea.sea_shallow.r, p.sea.sea_shallow.g, p.sea.sea_shallow.b});
  t.biomes.push_back({"beach", p.sea.beach_color.r, p.sea.beach_color.g, p.sea.beach_color.b});
  for (std::size_t k = 0; k < p.table.size(); ++k) {
    int id = -1;
    for (std::size_t b = 0; b < t.biomes.size(); ++b)
      if (t.biomes[b].name == p.table[k].name) id = int(b);
    if (id < 0) {
      t.biomes.push_back({p.table[k].name, p.table[k].color.r, p.table[k].color.g, p.table[k].color.b});
      id = int(t.biomes.size()) - 1;
    }
    id_of_row[k] = id;
  }
  std::vector<std::shared_ptr<const detail::Texture>> tex(p.table.size());
  for (std::size_t k = 0; k < p.table.size(); ++k)
    if (!p.table[k].texture.empty())
      tex[k] = detail::load_texture(p.table[k].texture, path + ".table[" + std::to_string(k) + "].texture");

  std::vector<unsigned char> water(fr.count());
  for (std::size_t k = 0; k < water.size(); ++k) water[k] = double(h.data[k]) <= sea;
  const double cut_m = kSeaReachCoasts * p.coast_m;
  const std::vector<float> dist = detail::distance_transform_within(water, fr.nx, fr.nz, cut_m / fr.cell_m());
  const double tail = std::exp(-kSeaReachCoasts), share_scale = 1.0 / (1.0 - tail);
  const Noise nt(detail::gradient_fbm(p.temperature_wavelength_m, 4, ctx.stage_seed(1)));
  const Noise nm(detail::gradient_fbm(p.moisture_wavelength_m, 4, ctx.stage_seed(2)));
  Layer& temp = t.layer("temperature", 1);
  Layer& moist = t.layer("moisture", 1);
  Layer& biome = t.layer("biome", 1);
  Layer& albedo = t.layer("albedo", 3);
  detail::parallel_rows(fr.nz, [&](int j) {
    const int nx = fr.nx;
    thread_local std::vector<float> rt, rm;
    rt.resize(std::size_t(nx));
    rm.resize(std::size_t(nx));
    const double z = fr.z_m(j);
    nt.row(z, fr.ix0, fr.cell_m(), nx, rt.data());
    nm.row(z, fr.ix0, fr.cell_m(), nx, rm.data());
    const double north = 1.0 - z / std::max(1e-9, fr.world_depth_m);
    for (int i = 0; i < nx; ++i) {
      const std::size_t k = std::size_t(j) * nx + i;
      const double e = h.data[k];
      const double u = std::max(0.0, (e - sea) / land);
      const double T = std::clamp(p.temperature_base + p.temperature_noise * rt[std::size_t(i)] - p.lapse * u - p.latitude * north, 0.0, 1.0);
      const double dm = double(dist[k]) * fr.cell_m();
      const double M = std::clamp(p.moisture_base + p.moisture_noise * rm[std::size_t(i)] +
                                      (std::isfinite(dm) ? p.sea_moisture * std::max(0.0, (std::exp(-dm / p.coast_m) - tail) * share_scale) : 0.0),
                                  0.0, 1.0);
      temp.data[k] = float(T);
      moist.data[k] = float(M);
      Rgb c;
      int id;
      if (e <= sea) {
        c = p.sea.sea_at(e, sea);
        id = 0;
      } else if (e - sea < p.beach_height) {
        c = p.sea.beach_color;
        id = 1;
      } else {
        const int r = std::max(0, detail::classify(p.table, T, M));  // validated: every (t, m) is covered
        c = tex[std::size_t(r)] ? tex[std::size_t(r)]->sample(fr.x_m(i), z, p.table[std::size_t(r)].tile_m) : p.table[std::size_t(r)].color;
        id = id_of_row[std::size_t(r)];
      }
      albedo.data[3 * k] = c.r, albedo.data[3 * k + 1] = c.g, albedo.data[3 * k + 2] = c.b;
      biome.data[k] = float(id);
    }
  });
}

Reach climate_reach(const ClimateParams& p, const Frame& f) {
  return neighbourhood(detail::within_halo(kSeaReachCoasts * p.coast_m / f.cell_m()));
}

void validate_climate(const ClimateParams& p, const std::string& path) {
  for (std::size_t k = 0; k < p.table.size(); ++k) {
    const ClimateBiome& b = p.table[k];
    const std::string rp = path + ".table[" + std::to_string(k) + "]";
    if (b.name.empty()) throw Error(rp + ".name", "expected a non-empty name");
    if (b.name == "ocean" || b.name == "beach") throw Error(rp + ".name", "\"" + b.name + "\" is reserved");
    if (b.temperature_max <= b.temperature_min)
      throw Error(rp + ".temperature_max", "expected more than temperature_min (" + std::to_string(b.temperature_min) + ")");
    if (b.moisture_max <= b.moisture_min)
      throw Error(rp + ".moisture_max", "expected more than moisture_min (" + std::to_string(b.moisture_min) + ")");
    for (std::size_t q = 0; q < k; ++q)
      if (p.table[q].name == b.name && !(p.table[q].color == b.color))
        throw Error(rp + ".color", "rows named \"" + b.name + "\" must share one colour (row " + std::to_string(q) +
                                       " has " + write_color(p.table[q].color).get<std::string>() + ")");
    if (!b.texture.empty()) detail::load_texture(b.texture, rp + ".texture");
  }
  // Every climate must have a biome: checked on a 101 × 101 grid of (temperature, moisture).
  for (int a = 0; a <= 100; ++a)
    for (int b = 0; b <= 100; ++b)
      if (detail::classify(p.table, a / 100.0, b / 100.0) < 0) {
        char buf[128];
        std::snprintf(buf, sizeof buf, "no row covers temperature %.2f, moisture %.2f", a / 100.0, b / 100.0);
        throw Error(path + ".table", buf);
      }
}

Table<ClimateBiome> row_table() {
  using B = ClimateBiome;
  return {{
      text(&B::name, "name", "Biome name (rows may share a name and colour)"),
      color(&B::color, "color", "Colour"),
      text(&B::texture, "texture", "PNG tiled instead of the colour (\"\" = none)", Effect::Recolour),
      param(&B::tile_m, "tile_m", 0.01, 1e6, "m", "Texture repeat", Effect::Recolour),
      param(&B::temperature_min, "temperature_min", 0.0, 1.0, "", "Lowest temperature (inclusive)"),
      param(&B::temperature_max, "temperature_max", 0.0, 1.0, "", "Highest temperature (exclusive; 1 includes 1)"),
      param(&B::moisture_min, "moisture_min", 0.0, 1.0, "", "Lowest moisture (inclusive)"),
      param(&B::moisture_max, "moisture_max", 0.0, 1.0, "", "Highest moisture (exclusive; 1 includes 1)"),
  }};
}

}  // namespace

StageDef climate() {
  using P = ClimateParams;
  Table<P> table{{
      param(&P::temperature_wavelength_m, "temperature_wavelength_m", 1.0, 1e7, "m", "Wavelength of the temperature noise"),
      param(&P::moisture_wavelength_m, "moisture_wavelength_m", 1.0, 1e7, "m", "Wavelength of the moisture noise"),
      param(&P::temperature_base, "temperature_base", 0.0, 1.0, "", "Temperature at sea level before noise"),
      param(&P::temperature_noise, "temperature_noise", 0.0, 2.0, "", "Amplitude of the temperature noise"),
      param(&P::lapse, "lapse", 0.0, 4.0, "", "Cooling from sea level to the highest elevation"),
      param(&P::latitude, "latitude", 0.0, 2.0, "", "Extra cooling towards the north (z-min) edge"),
      param(&P::moisture_base, "moisture_base", 0.0, 1.0, "", "Moisture before noise and sea"),
      param(&P::moisture_noise, "moisture_noise", 0.0, 2.0, "", "Amplitude of the moisture noise"),
      param(&P::sea_moisture, "sea_moisture", 0.0, 2.0, "", "Moisture added at the coast, fading inland"),
      param(&P::coast_m, "coast_m", 1.0, 1e6, "m", "Distance over which the sea's moisture falls by e"),
      records(&P::table, "table", row_table(), 1, 62, "Whittaker-style table: rectangles of (temperature, moisture)"),
  }};
  embed(table.fields, &P::sea, detail::sea_colors_table());
  table.fields.push_back(
      param(&P::beach_height, "beach_height", 0.0, 1.0, "", "Land less than this above sea level (normalised) is beach"));
  StageDef d = make_stage<P>("climate",
                       "Climate biomes: moisture (rising near the sea) and temperature (cooling with height) classified "
                       "by a Whittaker table; writes temperature, moisture, biome, albedo",
                       neighbourhood(detail::within_halo(kSeaReachCoasts * 250.0 / (4000.0 / 512))), std::move(table),
                       apply_climate, validate_climate, climate_reach,
                       "the sea's moisture reaches 8 · coast_m: floor of the largest distance below 8 · coast_m / cell, "
                       "in samples");
  d.memory = {{{"temperature", 1}, {"moisture", 1}, {"biome", 1}, {"albedo", 3}}, {}, 8, {}};
  return d;
}

}  // namespace stages
}  // namespace relief
