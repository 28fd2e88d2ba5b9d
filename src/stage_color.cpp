// Colour stages: slope, color (colorize), hillshade.
//
// Sources:
//   * LoaDy, "Generating terrain mesh in Python" (2019, seed 001): the slope map as the mean
//     absolute elevation difference to the 8 neighbours, and the colour rule "rock where the slope
//     is steep between two elevations, elevation bands elsewhere".
//   * A. Saparov, "A Maya Terrain Generator Based on Perlin Noise" (2021, seed 000): colour levels
//     (threshold + colour), thresholds optionally relative to the map's highest point.
//   * Lambertian hillshade (surface.hpp): Burrough & McDonnell 1998, GDAL gdaldem hillshade.
//
// Slopes and shading are metric: elevation differences are converted to metres with
// frame.height_m and divided by the cell size in metres, so a 257² preview and a 513² build of
// the same world agree on slope_deg and shade up to discretisation (not bit for bit: these are
// neighbourhood stages whose finite differences depend on the cell size).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "surface.hpp"
#include "parallel.hpp"
#include "pointwise.hpp"
#include "relief/error.hpp"
#include "relief/random.hpp"
#include "shared_tables.hpp"
#include "slope_kernel.hpp"
#include "stages.hpp"
#include "texture.hpp"

namespace relief::stages {
namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;

double smoothstep01(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * (3.0 - 2.0 * s);
}

double slope_deg_at(const Frame& fr, const Layer& h, int i, int j) {
  return detail::slope_deg_of(detail::gradient_at(fr, h, i, j));
}

void require_nonempty(const Terrain& t, const Layer& h, const char* name) {
  if (h.data.size() < t.frame.count() * std::size_t(h.channels))
    throw Error("", std::string("layer '") + name + "' does not match the frame's sample count");
}

// ======================================================================================= slope

enum class SlopeBorder { Mean, Eight };

struct SlopeParams {
  SlopeBorder border = SlopeBorder::Mean;
};

void apply_slope(Terrain& t, const SlopeParams& p, const Context&) {
  const Frame& fr = t.frame;
  const Layer& h = t.get("height");
  require_nonempty(t, h, "height");
  // Every sample of both layers is written below: no zero fill first.
  Layer& s = t.layer_for_overwrite("slope", 1);
  Layer& sd = t.layer_for_overwrite("slope_deg", 1);
  const bool eight = p.border == SlopeBorder::Eight;
  // Any sample: the mean absolute difference to the neighbours that exist (or /8 with border
  // `eight`) and the slope in degrees with one-sided differences at the border.
  auto edge_sample = [&](int i, int j, float* srow, float* sdrow) {
    const double e = h.data[(std::size_t(j) * fr.nx + i) * h.channels];
    double sum = 0;
    int count = 0;
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        const int a = i + di, b = j + dj;
        if ((di == 0 && dj == 0) || a < 0 || b < 0 || a >= fr.nx || b >= fr.nz) continue;
        sum += std::fabs(e - double(h.data[(std::size_t(b) * fr.nx + a) * h.channels]));
        ++count;
      }
    srow[i] = float(eight ? sum / 8.0 : sum / count);
    sdrow[i] = float(slope_deg_at(fr, h, i, j));
  };
  detail::SlopeRow k;
  k.sea_level = fr.sea_level;
  k.height_m = fr.height_m;
  k.cell2_m = 2.0 * fr.cell_m();
  detail::parallel_rows(fr.nz, [&](int j) {
    float* srow = s.data.data() + std::size_t(j) * fr.nx;
    float* sdrow = sd.data.data() + std::size_t(j) * fr.nx;
    if (h.channels == 1 && j > 0 && j + 1 < fr.nz && fr.nx >= 3) {
      // Interior samples of an interior row: the row kernel (slope_kernel.hpp), the same bits as
      // edge_sample's sums and differences without its bounds checks; the two border columns apart.
      detail::slope_row(k, h.row(j - 1, fr.nx), h.row(j, fr.nx), h.row(j + 1, fr.nx), srow, sdrow, fr.nx);
      for (int i : {0, fr.nx - 1}) edge_sample(i, j, srow, sdrow);
      return;
    }
    for (int i = 0; i < fr.nx; ++i) edge_sample(i, j, srow, sdrow);
  });
}


// ======================================================================================= color

std::vector<Level> default_palette() {
  // Written for sea level 0.4 (detail::kReferenceSea): water below, beach just above it. With
  // sea_relative (the default) they follow the world's sea level.
  return {
      Level{0.30, rgb_hex(0x1d4877), "deep water"}, Level{0.40, rgb_hex(0x3a7cb8), "shallow water"},
      Level{0.43, rgb_hex(0xd8c88e), "sand"},       Level{0.58, rgb_hex(0x6b9b45), "grass"},
      Level{0.72, rgb_hex(0x3c6b32), "forest"},     Level{0.86, rgb_hex(0x7f746a), "rock"},
      Level{1.00, rgb_hex(0xf2f2f4), "snow"},
  };
}

enum class ColorMode { Bands, Gradient };

struct ColorParams {
  std::vector<Level> levels = default_palette();
  ColorMode mode = ColorMode::Bands;
  bool smooth_edges = false;
  bool relative_to_max = false;
  bool sea_relative = true;
  Rgb rock_color = rgb_hex(0x6f6861);
  double rock_slope_deg = 35.0;
  double rock_blend_deg = 5.0;
  double rock_min = 0.4;
  double rock_max = 0.9;
  double variation = 0.04;
  double variation_scale_m = 20.0;
  Rgb water_color = rgb_hex(0x3f7fb5);
};

// bands:    the colour of the first level with e ≤ at; above the last `at`, the last colour.
// gradient: each level's colour sits exactly at its `at`; linear in between; the first colour
//           below the first `at`, the last colour above the last `at`.
// Comparisons are made in single precision, the precision of the layers, so that a height of
// 0.3f counts as "at" a level written as 0.3.
//
// smooth_edges (bands only): a band edge is a step in elevation, and sampling a step draws it as a
// staircase of whole samples (the mountains preset at 513²). With smooth_edges each step is box
// filtered over the elevation change across one sample, Δ = |∇e|·cell (central differences, as
// the rock rule's): the weight of the upper level is clamp((e − at)/Δ + ½, 0, 1), the fraction of
// the sample's footprint above the edge for a locally planar surface. Δ follows the sample
// spacing, so the edge is one sample wide at every resolution and lands between samples where it
// lies; on flat ground (Δ = 0) the edge is the hard one. The rock rule's rock_min / rock_max
// cut-offs are filtered the same way. Off by default (the hard edges of seed 000's bands, and the
// bytes of the presets that use them); such rows take the scalar path of textured levels.
//
// sea_relative (default): the levels' `at` and rock_min/rock_max are written for sea level 0.4
// (detail::kReferenceSea) and placed in the world piecewise linearly, so that 0.4 lands on the
// world's sea level and 0 and 1 stay put (detail::from_reference_elevation; exactly the written
// values when the world's sea level is 0.4). `--set world.sea_level=0.3` thus moves the beach with
// the coast. false pins them to the elevations written.
//
// Rock: where rock_min < e < rock_max and the slope exceeds rock_slope_deg, the colour turns to
// rock_color with weight smoothstep((slope − rock_slope_deg)/rock_blend_deg). The slope is the
// slope_deg layer if present, else the gradient of the height in metres (central differences,
// one-sided at the window border); slope > threshold is decided as |∇y|² > tan²(threshold), and
// the angle itself (an atan) is only evaluated for vectors that hold rock.
//
// Speckle: colour × (1 + variation·(2v − 1)), v smooth value noise in [0, 1] on a lattice of
// variation_scale_m metres in world coordinates: hashed lattice values (relief/random.hpp),
// interpolated with smoothstep weights — along z once per row for the lattice columns the row
// needs (in double), along x per sample (in float). A pure function of (seed, x_m, z_m): every
// window and every resolution sees the same pattern.

double smoothstep_weight(double s) { return smoothstep01(s); }

void require_single(const Terrain& t, const Layer& h, const char* name) {
  if (h.channels != 1 || h.data.size() != t.frame.count())
    throw Error("", std::string("layer '") + name + "' must have one channel and one value per sample");
}

void apply_color(Terrain& t, const ColorParams& params, const Context& ctx) {
  const Frame& fr = t.frame;
  ColorParams p = params;
  if (p.sea_relative) {
    for (Level& l : p.levels) l.at = detail::from_reference_elevation(l.at, fr.sea_level);
    p.rock_min = detail::from_reference_elevation(p.rock_min, fr.sea_level);
    p.rock_max = detail::from_reference_elevation(p.rock_max, fr.sea_level);
  }
  const Layer& h = t.get("height");
  require_single(t, h, "height");
  const int nx = fr.nx;
  detail::ColorRow k;
  std::vector<float> at, r, g, b;
  for (const Level& l : p.levels) at.push_back(float(l.at)), r.push_back(l.color.r), g.push_back(l.color.g), b.push_back(l.color.b);
  k.levels = int(at.size());
  k.at = at.data(), k.r = r.data(), k.g = g.data(), k.b = b.data();
  k.gradient = p.mode == ColorMode::Gradient;
  const std::vector<float> level_tables = detail::color_level_tables(k);
  k.tables = level_tables.empty() ? nullptr : level_tables.data();
  // Per-map normalisation (seed 000): the only non-local step; off by default.
  if (p.relative_to_max) {
    float hmax = 0.0f;
    for (float v : h.data) hmax = std::max(hmax, v);
    k.relative = hmax > 0.0f;
    k.max_height = hmax;
  }
  k.rock = p.rock_slope_deg < 90.0 && p.rock_min < p.rock_max;
  const Layer* given_slope = nullptr;
  if (k.rock && t.has("slope_deg")) {
    const Layer& l = t.get("slope_deg");
    if (l.channels == 1 && l.data.size() == fr.count()) given_slope = &l;
  }
  k.slope_is_gradient2 = given_slope == nullptr;
  k.rock_min = float(p.rock_min);
  k.rock_max = float(p.rock_max);
  const double tan_t = std::tan(p.rock_slope_deg / kDeg);
  k.rock_gate = given_slope ? detail::float_at_most(p.rock_slope_deg) : float(tan_t * tan_t);
  k.rock_slope_deg = float(p.rock_slope_deg);
  k.rock_blend_deg = float(p.rock_blend_deg);
  k.rock_r = p.rock_color.r, k.rock_g = p.rock_color.g, k.rock_b = p.rock_color.b;
  if (k.rock && p.rock_blend_deg > 0.0) {
    const double full_deg = p.rock_slope_deg + p.rock_blend_deg;
    const double tan_f = full_deg < 90.0 ? std::tan(full_deg / kDeg) : std::numeric_limits<double>::infinity();
    k.rock_full_gate = given_slope ? detail::float_at_least(full_deg) : float(tan_f * tan_f);
  }
  k.speckle = p.variation > 0.0;
  k.variation = float(p.variation);

  // Speckle lattice: per column the lattice cell and the weight tx; `cols` lists the lattice
  // columns the rows need (every cell c and c + 1, ascending), `col_key` their hash keys, and
  // ix[i] the position of column i's cell in `cols`.
  // Salted by the recipe seed only (not the stage index), so inserting stages before `color`
  // does not change its speckle.
  const std::uint64_t vseed = hash64(ctx.seed, 0x636f6c6f72ull /* "color" */);
  const double cell = p.variation_scale_m;
  std::vector<std::int32_t> ix(std::size_t(nx) + detail::kRowPad, 0);
  std::vector<float> tx(std::size_t(nx) + detail::kRowPad, 0.0f);
  std::vector<std::int64_t> cols;
  if (k.speckle) {
    for (int i = 0; i < nx; ++i) {
      const double gx = fr.x_m(i) / cell, fx = std::floor(gx);
      const auto c = std::int64_t(fx);
      if (cols.empty() || cols.back() < c) cols.push_back(c);  // x increases with i: append only
      if (cols.back() < c + 1) cols.push_back(c + 1);
      ix[std::size_t(i)] = std::int32_t(std::lower_bound(cols.begin(), cols.end(), c) - cols.begin());
      tx[std::size_t(i)] = float(smoothstep_weight(gx - fx));
    }
  }
  std::vector<std::uint64_t> col_key(cols.size());
  for (std::size_t m = 0; m < cols.size(); ++m) col_key[m] = hash64(vseed, std::uint64_t(cols[m]));
  // The speckle of lattice row iz interpolated along x, for every column: a pure function of iz.
  // Rows between the same two lattice rows share it, so each thread keeps the last two it made
  // (tagged with this call's id); the result does not depend on what the cache holds.
  static std::atomic<std::uint64_t> next_call{1};
  const std::uint64_t call = next_call.fetch_add(1);
  struct LatticeCache {
    std::uint64_t call = 0;
    std::int64_t iz[2] = {0, 0};
    bool valid[2] = {false, false};
    std::vector<float> along_x[2];
    std::vector<float> lat;
  };
  auto make = [&](LatticeCache& c, int s, std::int64_t iz) {
    const std::uint64_t zkey = mix64(std::uint64_t(iz));
    c.lat.resize(cols.size() + 1);
    // hash64(hash64(vseed, x), z) = mix64(hash64(vseed, x) ^ mix64(z))
    for (std::size_t m = 0; m < cols.size(); ++m) c.lat[m] = float(unit_double(mix64(col_key[m] ^ zkey)));
    c.lat[cols.size()] = 0.0f;
    c.along_x[s].resize(std::size_t(nx) + detail::kRowPad, 0.0f);
    detail::lattice_row(c.lat.data(), ix.data(), tx.data(), c.along_x[s].data(), nx);
    c.iz[s] = iz;
    c.valid[s] = true;
  };
  // Lattice rows iz and iz + 1, along x.
  auto lattice_pair = [&](LatticeCache& c, std::int64_t iz) -> std::pair<const float*, const float*> {
    if (c.call != call) c.call = call, c.valid[0] = c.valid[1] = false;
    int slot[2] = {-1, -1};
    for (int s = 0; s < 2; ++s)
      for (int w = 0; w < 2; ++w)
        if (c.valid[s] && c.iz[s] == iz + w) slot[w] = s;
    for (int w = 0; w < 2; ++w)
      if (slot[w] < 0) {
        slot[w] = slot[1 - w] == 0 ? 1 : 0;  // the entry the other row does not use
        make(c, slot[w], iz + w);
      }
    return {c.along_x[slot[0]].data(), c.along_x[slot[1]].data()};
  };

  // Surface water from a "flow" stage (rivers and lakes, cover 0..1), painted over the result.
  const Layer* water = nullptr;
  if (t.has("water")) {
    const Layer& l = t.get("water");
    if (l.channels == 1 && l.data.size() == fr.count()) water = &l;
  }
  const float wr = p.water_color.r, wg = p.water_color.g, wb = p.water_color.b;
  k.water_r = wr, k.water_g = wg, k.water_b = wb;
  // Levels that tile an image instead of a flat colour: those rows take a scalar path that
  // samples the textures at world positions, then applies the same rock rule and speckle.
  const auto textures = detail::load_level_textures(p.levels, "stages[" + std::to_string(ctx.stage_index) + "].levels");
  bool textured = false;
  for (auto& tex : textures) textured = textured || tex != nullptr;
  const bool smooth = p.smooth_edges && !k.gradient;
  const bool scalar = textured || smooth;
  // Footprint of one sample in (possibly relative) elevation per unit of |∇y| in metres per metre.
  const double footprint = fr.cell_m() / fr.height_m / (k.relative ? double(k.max_height) : 1.0);
  // Fraction of a sample's footprint [v − Δ/2, v + Δ/2] above `at` (a hard step when Δ = 0).
  auto above = [](double v, double at, double delta) {
    if (!(delta > 0.0)) return v > at ? 1.0 : 0.0;
    return std::clamp((v - at) / delta + 0.5, 0.0, 1.0);
  };

  Layer& out = t.layer("albedo", 3);
  detail::parallel_rows(fr.nz, [&](int j) {
    thread_local LatticeCache cache;
    const float* slope_row = k.rock && given_slope ? given_slope->row(j, nx) : nullptr;
    const float *a0 = nullptr, *a1 = nullptr;
    float tz = 0.0f;
    if (k.speckle) {
      const double gzl = fr.z_m(j) / cell, fz = std::floor(gzl);
      const auto iz = std::int64_t(fz);
      tz = float(smoothstep_weight(gzl - fz));
      std::tie(a0, a1) = lattice_pair(cache, iz);
    }
    float* row = out.row(j, nx);
    const detail::GradientRows rows = detail::gradient_rows(fr, h, j, 1.0);
    // Water is blended inside the kernel, except on textured rows, which are recoloured below.
    const float* water_row = water && !scalar ? water->row(j, nx) : nullptr;
    if (!smooth) detail::color_row(k, rows, slope_row, a0, a1, tz, water_row, row, nx);
    if (scalar) {
      const float* e = h.row(j, nx);
      const double z = fr.z_m(j);
      for (int i = 0; i < nx; ++i) {
        const float v = k.relative ? e[i] / k.max_height : e[i];
        Rgb c;
        double gate = k.rock && v > k.rock_min && v < k.rock_max ? 1.0 : 0.0;
        if (smooth) {
          const double delta = std::sqrt(double(detail::gradient2_at(rows, i, nx))) * footprint;
          auto col = [&](std::size_t m) {
            const detail::Texture* tx = m < textures.size() ? textures[m].get() : nullptr;
            return tx ? tx->sample(fr.x_m(i), z, p.levels[m].tile_m) : p.levels[m].color;
          };
          c = col(0);
          for (std::size_t m = 0; m + 1 < p.levels.size(); ++m) {
            const double w = above(v, float(p.levels[m].at), delta);
            const Rgb up = col(m + 1);
            c = Rgb{float(c.r + (up.r - c.r) * w), float(c.g + (up.g - c.g) * w), float(c.b + (up.b - c.b) * w)};
          }
          if (k.rock) gate = above(v, k.rock_min, delta) * (1.0 - above(v, k.rock_max, delta));
        } else {
          c = detail::level_color(p.levels, textures, k.gradient, v, fr.x_m(i), z);
        }
        if (gate > 0.0) {
          const float g2 = given_slope ? 0.0f : detail::gradient2_at(rows, i, nx);
          const double sd = given_slope ? double(slope_row[i]) : std::atan(std::sqrt(double(g2))) * kDeg;
          if (sd > p.rock_slope_deg) {
            const double w = gate * (p.rock_blend_deg > 0.0 ? smoothstep_weight(std::min(1.0, (sd - p.rock_slope_deg) / p.rock_blend_deg)) : 1.0);
            c = Rgb{float(c.r + (p.rock_color.r - c.r) * w), float(c.g + (p.rock_color.g - c.g) * w),
                    float(c.b + (p.rock_color.b - c.b) * w)};
          }
        }
        const float f = k.speckle ? 1.0f + k.variation * (2.0f * (a0[i] + (a1[i] - a0[i]) * tz) - 1.0f) : 1.0f;
        row[3 * i + 0] = std::clamp(c.r * f, 0.0f, 1.0f);
        row[3 * i + 1] = std::clamp(c.g * f, 0.0f, 1.0f);
        row[3 * i + 2] = std::clamp(c.b * f, 0.0f, 1.0f);
      }
    }
    if (water && scalar) {
      const float* w = water->row(j, nx);
      for (int i = 0; i < nx; ++i) {
        if (!(w[i] > 0.0f)) continue;
        float* c = row + 3 * i;
        c[0] += (wr - c[0]) * w[i];
        c[1] += (wg - c[1]) * w[i];
        c[2] += (wb - c[2]) * w[i];
      }
    }
  });
}

// One sample of halo (the rock rule's central differences); per-map normalisation is global.
Reach color_reach(const ColorParams& p, const Frame&) {
  return p.relative_to_max ? global("relative_to_max divides by the highest sample of the whole map") : neighbourhood(1);
}

void validate_color(const ColorParams& p, const std::string& path) {
  detail::load_level_textures(p.levels, path + ".levels");  // a missing texture fails at parse time
  if (p.rock_min > p.rock_max) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "expected a number ≥ rock_min (%g), got %g", p.rock_min, p.rock_max);
    throw Error(path + ".rock_max", buf);
  }
}

// =================================================================================== hillshade

using HillshadeParams = detail::Light;

void apply_hillshade(Terrain& t, const HillshadeParams& p, const Context&) {
  const Frame& fr = t.frame;
  const Layer& h = t.get("height");
  require_single(t, h, "height");
  const Layer* albedo = nullptr;
  if (t.has("albedo")) {
    const Layer& a = t.get("albedo");
    if (a.channels == 3 && a.data.size() == fr.count() * 3) albedo = &a;
  }
  // Both outputs are written whole by the kernel: no zero fill first.
  detail::hillshade(fr, h, albedo, p, &t.layer_for_overwrite("shade", 1), &t.layer_for_overwrite("color", 3));
}

}  // namespace

StageDef slope() {
  using P = SlopeParams;
  Table<P> table{{
      choice(&P::border, "border", {{SlopeBorder::Mean, "mean"}, {SlopeBorder::Eight, "eight"}},
             "slope = Σ|e − neighbour| over the in-bounds neighbours, divided by their count (mean) or by 8 "
             "always (eight: seed 001, darker border)"),
  }};
  StageDef d = make_stage<P>("slope",
                       "Slope layers: 'slope' = mean |Δe| to the 8 neighbours (elevation units), "
                       "'slope_deg' = gradient slope in degrees",
                       neighbourhood(1), std::move(table), apply_slope);
  d.memory = {{{"slope", 1}, {"slope_deg", 1}}, {}, 0, {}};
  return d;
}

StageDef colorize() {
  using P = ColorParams;
  constexpr Effect R = Effect::Recolour;
  Table<P> table{{
      levels(&P::levels, "levels", 0.0, 1.0,
             "Colour levels [{at, color, name}] on normalised elevation; bands: first level with e ≤ at, the last "
             "level above all"),
      choice(&P::mode, "mode", {{ColorMode::Bands, "bands"}, {ColorMode::Gradient, "gradient"}},
             "bands: flat colour per level; gradient: interpolate between levels", R),
      param(&P::smooth_edges, "smooth_edges", 0, 1, "",
            "Bands: blend each band edge (and the rock_min/rock_max cut-offs) over one sample's elevation change, "
            "an anti-aliased edge instead of a staircase of samples",
            R),
      param(&P::relative_to_max, "relative_to_max", 0, 1, "",
            "Divide elevation by the map's highest sample first (seed 000); breaks preview = build and tiling", R),
      param(&P::sea_relative, "sea_relative", 0, 1, "",
            "Levels and rock_min/rock_max are written for sea level 0.4 and follow the world's sea level (piecewise "
            "linear remap); false pins them",
            R),
      color(&P::rock_color, "rock_color", "Colour of steep ground (seed 001's rock rule)"),
      param(&P::rock_slope_deg, "rock_slope_deg", 0.0, 90.0, "deg",
            "Slope above which ground turns to rock (uses layer slope_deg if present); 90 disables the rule", R),
      param(&P::rock_blend_deg, "rock_blend_deg", 0.0, 45.0, "deg",
            "Rock fades in over this many degrees above rock_slope_deg; 0 gives seed 001's hard edge", R),
      param(&P::rock_min, "rock_min", 0.0, 1.0, "", "Rock rule applies only where rock_min < e < rock_max", R),
      param(&P::rock_max, "rock_max", 0.0, 1.0, "", "Upper elevation bound of the rock rule (snow above stays)", R),
      param(&P::variation, "variation", 0.0, 0.2, "",
            "Brightness speckle amplitude: colour × (1 ± variation) from world-space value noise", R),
      param(&P::variation_scale_m, "variation_scale_m", 1.0, 10000.0, "m", "Feature size of the speckle noise", R),
      color(&P::water_color, "water_color",
            "Colour of rivers and lakes from a 'flow' stage earlier in the recipe (layer 'water', blended by cover)"),
  }};
  StageDef d = make_stage<P>("color",
                       "Colour by elevation levels, with rock on steep ground; writes 'albedo' (3 channels)",
                       neighbourhood(1), std::move(table), apply_color, validate_color, color_reach,
                       "1 sample (the slope's central differences); global with relative_to_max");
  d.memory = {{{"albedo", 3}}, {}, 8, {}};
  return d;
}

StageDef hillshade() {
  using P = HillshadeParams;
  constexpr Effect R = Effect::Recolour;
  Table<P> table{{
      param(&P::azimuth_deg, "azimuth_deg", 0.0, 360.0, "deg",
            "Direction the light comes from, clockwise from north (−z); 315 = north-west", R),
      param(&P::altitude_deg, "altitude_deg", 0.0, 90.0, "deg", "Height of the light above the horizon", R),
      param(&P::z_factor, "z_factor", 0.0, 20.0, "", "Vertical exaggeration applied to the metric slopes", R),
      param(&P::ambient, "ambient", 0.0, 1.0, "", "Light reaching surfaces facing away from the sun", R),
      param(&P::water_relief, "water_relief", 0.0, 1.0, "",
            "Under the sea, fraction of the relief shading kept (0 = flat water, 1 = like land)", R),
  }};
  StageDef d = make_stage<P>("hillshade",
                       "Lambertian hillshade: writes 'shade' and 'color' = albedo × shade (white if no albedo)",
                       neighbourhood(1), std::move(table), apply_hillshade);
  d.memory = {{{"shade", 1}, {"color", 3}}, {}, 0, {}};
  return d;
}

}  // namespace relief::stages
