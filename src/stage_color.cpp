// Colour stages: slope, color (colorize), hillshade.
//
// Sources:
//   * LoaDy, "Generating terrain mesh in Python" (2019, seed 001): the slope map as the mean
//     absolute elevation difference to the 8 neighbours, and the colour rule "rock where the slope
//     is steep between two elevations, elevation bands elsewhere".
//   * A. Saparov, "A Maya Terrain Generator Based on Perlin Noise" (2021, seed 000): colour levels
//     (threshold + colour), thresholds optionally relative to the map's highest point.
//   * Lambertian hillshade (hillshade.hpp): Burrough & McDonnell 1998, GDAL gdaldem hillshade.
//
// Slopes and shading are metric: elevation differences are converted to metres with
// frame.height_m and divided by the cell size in metres, so a 257² preview and a 513² build of
// the same world agree on slope_deg and shade up to discretisation (not bit for bit: these are
// neighbourhood stages whose finite differences depend on the cell size).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "hillshade.hpp"
#include "parallel.hpp"
#include "relief/error.hpp"
#include "relief/random.hpp"
#include "stages.hpp"
#include "texture.hpp"

namespace relief::stages {
namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;

constexpr Rgb hex(std::uint32_t v) {
  return Rgb{float((v >> 16) & 255) / 255.0f, float((v >> 8) & 255) / 255.0f, float(v & 255) / 255.0f};
}

double smoothstep01(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * (3.0 - 2.0 * s);
}

using detail::Gradient;
using detail::gradient_at;

double slope_deg_at(const Frame& fr, const Layer& h, int i, int j) {
  const Gradient g = gradient_at(fr, h, i, j);
  return std::atan(std::hypot(g.dx, g.dz)) * kDeg;
}

void require_nonempty(const Terrain& t, const Layer& h, const char* name) {
  if (h.data.size() < t.frame.count() * std::size_t(h.channels))
    throw Error("", std::string("layer '") + name + "' does not match the frame's sample count");
}

// ======================================================================================= slope

struct SlopeParams {
  std::string border = "mean";
};

void apply_slope(Terrain& t, const SlopeParams& p, const Context&) {
  const Frame& fr = t.frame;
  const Layer& h = t.get("height");
  require_nonempty(t, h, "height");
  Layer& s = t.layer("slope", 1);
  Layer& sd = t.layer("slope_deg", 1);
  const bool eight = p.border == "eight";
  detail::parallel_rows(fr.nz, [&](int j) {
    for (int i = 0; i < fr.nx; ++i) {
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
      const std::size_t k = std::size_t(j) * fr.nx + i;
      s.data[k] = float(eight ? sum / 8.0 : sum / count);
      sd.data[k] = float(slope_deg_at(fr, h, i, j));
    }
  });
}

// ======================================================================================= color

Level level(double at, Rgb color, const char* name) {
  Level l;
  l.at = at;
  l.color = color;
  l.name = name;
  return l;
}

std::vector<Level> default_palette() {
  // For the default sea_level 0.4: water below, beach just above it.
  return {
      level(0.30, hex(0x1d4877), "deep water"), level(0.40, hex(0x3a7cb8), "shallow water"),
      level(0.43, hex(0xd8c88e), "sand"),       level(0.58, hex(0x6b9b45), "grass"),
      level(0.72, hex(0x3c6b32), "forest"),     level(0.86, hex(0x7f746a), "rock"),
      level(1.00, hex(0xf2f2f4), "snow"),
  };
}

struct ColorParams {
  std::vector<Level> levels = default_palette();
  std::string mode = "bands";
  bool relative_to_max = false;
  Rgb rock_color = hex(0x6f6861);
  double rock_slope_deg = 35.0;
  double rock_blend_deg = 5.0;
  double rock_min = 0.4;
  double rock_max = 0.9;
  double variation = 0.04;
  double variation_scale_m = 20.0;
};

// Smooth value noise in [0, 1] on a lattice of `cell_m` metres in world coordinates: a pure
// function of (seed, x_m, z_m), so every window and every resolution sees the same pattern.
double value_noise(std::uint64_t seed, double x_m, double z_m, double cell_m) {
  const double gx = x_m / cell_m, gz = z_m / cell_m;
  const double fx = std::floor(gx), fz = std::floor(gz);
  const auto ix = std::int64_t(fx), iz = std::int64_t(fz);
  auto v = [&](std::int64_t a, std::int64_t b) { return unit_double(hash64(seed, std::uint64_t(a), std::uint64_t(b))); };
  const double tx = smoothstep01(gx - fx), tz = smoothstep01(gz - fz);
  const double top = v(ix, iz) + (v(ix + 1, iz) - v(ix, iz)) * tx;
  const double bottom = v(ix, iz + 1) + (v(ix + 1, iz + 1) - v(ix, iz + 1)) * tx;
  return top + (bottom - top) * tz;
}

void apply_color(Terrain& t, const ColorParams& p, const Context& ctx) {
  const Frame& fr = t.frame;
  const Layer& h = t.get("height");
  require_nonempty(t, h, "height");
  // Per-map normalisation (seed 000): the only non-local step; off by default.
  double scale = 1.0;
  if (p.relative_to_max) {
    float hmax = 0.0f;
    for (std::size_t k = 0; k < fr.count(); ++k) hmax = std::max(hmax, h.data[k * h.channels]);
    if (hmax > 0.0f) scale = 1.0 / double(hmax);
  }
  const bool rock = p.rock_slope_deg < 90.0 && p.rock_min < p.rock_max;
  const Layer* given_slope = nullptr;
  if (rock && t.has("slope_deg")) {
    const Layer& l = t.get("slope_deg");
    if (l.channels == 1 && l.data.size() == fr.count()) given_slope = &l;
  }
  const bool gradient = p.mode == "gradient";
  const auto textures = detail::load_level_textures(p.levels, "stages[" + std::to_string(ctx.stage_index) + "].levels");
  // Salted by the recipe seed only (not the stage index), so inserting stages before `color`
  // does not change its speckle.
  const std::uint64_t vseed = hash64(ctx.seed, 0x636f6c6f72ull /* "color" */);
  Layer& out = t.layer("albedo", 3);
  detail::parallel_rows(fr.nz, [&](int j) {
    float* row = out.row(j, fr.nx);
    const double z = fr.z_m(j);
    for (int i = 0; i < fr.nx; ++i) {
      const std::size_t k = std::size_t(j) * fr.nx + i;
      const float e = float(double(h.data[k * h.channels]) * scale);
      Rgb c = detail::level_color(p.levels, textures, gradient, e, fr.x_m(i), z);
      if (rock && e > float(p.rock_min) && e < float(p.rock_max)) {
        const double s = given_slope ? double(given_slope->data[k]) : slope_deg_at(fr, h, i, j);
        if (s > p.rock_slope_deg) {
          const double w = p.rock_blend_deg > 0.0 ? smoothstep01((s - p.rock_slope_deg) / p.rock_blend_deg) : 1.0;
          c = w >= 1.0 ? p.rock_color
                       : Rgb{float(c.r + (p.rock_color.r - c.r) * w), float(c.g + (p.rock_color.g - c.g) * w),
                             float(c.b + (p.rock_color.b - c.b) * w)};
        }
      }
      double f = 1.0;
      if (p.variation > 0.0) f = 1.0 + p.variation * (2.0 * value_noise(vseed, fr.x_m(i), z, p.variation_scale_m) - 1.0);
      row[3 * i + 0] = float(std::clamp(c.r * f, 0.0, 1.0));
      row[3 * i + 1] = float(std::clamp(c.g * f, 0.0, 1.0));
      row[3 * i + 2] = float(std::clamp(c.b * f, 0.0, 1.0));
    }
  });
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
  require_nonempty(t, h, "height");
  const Layer* albedo = nullptr;
  if (t.has("albedo")) {
    const Layer& a = t.get("albedo");
    if (a.channels == 3 && a.data.size() == fr.count() * 3) albedo = &a;
  }
  detail::hillshade(fr, h, albedo, p, &t.layer("shade", 1), t.layer("color", 3));
}

}  // namespace

StageDef slope() {
  using P = SlopeParams;
  Table<P> table{{
      choice(&P::border, "border", {"mean", "eight"},
             "slope = Σ|e − neighbour| over the in-bounds neighbours, divided by their count (mean) or by 8 "
             "always (eight: seed 001, darker border)"),
  }};
  return make_stage<P>("slope",
                       "Slope layers: 'slope' = mean |Δe| to the 8 neighbours (elevation units), "
                       "'slope_deg' = gradient slope in degrees",
                       Locality::Neighbourhood, 1, std::move(table), apply_slope);
}

StageDef colorize() {
  using P = ColorParams;
  constexpr Effect R = Effect::Recolour;
  Table<P> table{{
      levels(&P::levels, "levels", 0.0, 1.0,
             "Colour levels [{at, color, name}] on normalised elevation; bands: first level with e ≤ at, the last "
             "level above all"),
      choice(&P::mode, "mode", {"bands", "gradient"}, "bands: flat colour per level; gradient: interpolate between levels",
             R),
      param(&P::relative_to_max, "relative_to_max", 0, 1, "",
            "Divide elevation by the map's highest sample first (seed 000); breaks preview = build and tiling", R),
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
  }};
  return make_stage<P>("color",
                       "Colour by elevation levels, with rock on steep ground; writes 'albedo' (3 channels)",
                       Locality::Neighbourhood, 1, std::move(table), apply_color, validate_color);
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
  return make_stage<P>("hillshade",
                       "Lambertian hillshade: writes 'shade' and 'color' = albedo × shade (white if no albedo)",
                       Locality::Neighbourhood, 1, std::move(table), apply_hillshade);
}

}  // namespace relief::stages
