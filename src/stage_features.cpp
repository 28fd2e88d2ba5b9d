// Feature stages: volcano, craters and single mountains (peaks), vertex jiggle.
//
// Sources:
//   * O. Feldmann, "Island Generator" (2022, seed 003): §3.2.2 the volcano — a foundation made by
//     averaging the affected region with sea level a couple of times; a rim circle; each iteration
//     a spread circle centred at a random point of the rim and an iteration circle at a random point
//     of the spread circle, lifting the ground inside it a little; both radii shrink every iteration
//     so the early ones build a wide base that tapers towards the rim; lava colour inside the rim
//     below a height. §2.5 feature points; §3.1 vertex jiggle.
//   * K. R. Kamal, Y. S. Uddin, "Parametrically Controlled Terrain Generation", GRAPHITE 2007:
//     feature points built by iteratively layering small adjustments (our peaks: stacked shrinking
//     circles with a wandering centre).
//   * H. J. Melosh, "Impact Cratering: A Geologic Process", 1989, ch. 6: simple craters — a bowl
//     whose depth is about a fifth of the diameter, a raised rim, ejecta thinning as (R/r)³.
//
// Differences from seed 003, on purpose: circles lift with a smooth bump instead of a flat step
// (no terracing rings at high resolution); the lift is normalised so that the rim stands `height`
// above sea level on average whatever the iteration count; a crater bowl is carved inside the rim.
// The volcano (placement land) and the features need the whole map to choose a place on land:
// global stages — their candidates are scored on the incoming heights anywhere in the window, so a
// tile cannot know the choice without every other tile's heights (a world algorithm could: score
// the candidates from the stored tiles, then apply the disk; not written yet). A volcano with
// placement fixed is a neighbourhood stage: a sample within radius_m of the centre depends on the
// lava level, read from the heights at the rim (rim_radius_m from the centre) and the centre, so
// on the input within radius_m + rim_radius_m of it; volcano_reach gives ceil of that in samples
// + 2 (the bilinear reads' second sample and rounding).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "features.hpp"
#include "parallel.hpp"
#include "relief/error.hpp"
#include "relief/random.hpp"
#include "stages.hpp"

namespace relief {
namespace detail {

double circles_at(const std::vector<Circle>& cs, double x, double z) {
  double s = 0;
  for (const Circle& c : cs) {
    const double d2 = ((x - c.x_m) * (x - c.x_m) + (z - c.z_m) * (z - c.z_m)) / (c.r_m * c.r_m);
    if (d2 < 1.0) s += c.amp * (1.0 - d2) * (1.0 - d2);
  }
  return s;
}

void add_circles(const Frame& fr, const std::vector<Circle>& cs, std::vector<double>& acc) {
  parallel_rows(fr.nz, [&](int j) {
    const double z = fr.z_m(j);
    double* row = acc.data() + std::size_t(j) * fr.nx;
    for (const Circle& c : cs) {
      const double dz = z - c.z_m;
      if (std::fabs(dz) >= c.r_m) continue;
      const double half = std::sqrt(c.r_m * c.r_m - dz * dz);
      // One sample wider than the chord on each side: the d2 test below decides, so the rounding of
      // the range (which differs between windows) never drops a sample.
      const int i0 = int(std::max(0.0, std::floor((c.x_m - half) / fr.cell_m() - double(fr.ix0)) - 1.0));
      const int i1 = int(std::min(double(fr.nx - 1), std::ceil((c.x_m + half) / fr.cell_m() - double(fr.ix0)) + 1.0));
      for (int i = i0; i <= i1; ++i) {
        const double dx = fr.x_m(i) - c.x_m;
        const double d2 = (dx * dx + dz * dz) / (c.r_m * c.r_m);
        if (d2 < 1.0) row[i] += c.amp * (1.0 - d2) * (1.0 - d2);
      }
    }
  });
}

// Positions become world-grid coordinates first (x / cell), then the window's offset (an integer)
// is subtracted, exactly: so a window of the world reads the same samples with the same weights,
// bit for bit, as the whole map (x − x0 in metres would round differently per window).
double sample_bilinear(const Frame& fr, const Layer& l, double x, double z) {
  const double fx = std::clamp(x / fr.cell_m() - double(fr.ix0), 0.0, double(fr.nx - 1));
  const double fz = std::clamp(z / fr.cell_m() - double(fr.iz0), 0.0, double(fr.nz - 1));
  const int i0 = std::min(int(fx), fr.nx - 2), j0 = std::min(int(fz), fr.nz - 2);
  const double tx = fx - i0, tz = fz - j0;
  auto at = [&](int i, int j) { return double(l.data[(std::size_t(j) * fr.nx + i) * l.channels]); };
  const double a = at(i0, j0) + (at(i0 + 1, j0) - at(i0, j0)) * tx;
  const double b = at(i0, j0 + 1) + (at(i0 + 1, j0 + 1) - at(i0, j0 + 1)) * tx;
  return a + (b - a) * tz;
}

float sample_nearest(const Frame& fr, const Layer& l, double x, double z, int c) {
  const std::int64_t gi = std::llround(x / fr.cell_m()) - fr.ix0, gj = std::llround(z / fr.cell_m()) - fr.iz0;
  const int i = int(std::clamp<std::int64_t>(gi, 0, fr.nx - 1));
  const int j = int(std::clamp<std::int64_t>(gj, 0, fr.nz - 1));
  return l.data[(std::size_t(j) * fr.nx + i) * l.channels + c];
}

int legend_id(Terrain& t, const std::string& name, float r, float g, float b) {
  for (std::size_t k = 0; k < t.biomes.size(); ++k)
    if (t.biomes[k].name == name) return int(k);
  t.biomes.push_back({name, r, g, b});
  return int(t.biomes.size()) - 1;
}

}  // namespace detail

namespace stages {
namespace {

using detail::Circle;
constexpr double kTau = 2.0 * std::numbers::pi;

double smoothstep01(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * (3.0 - 2.0 * s);
}
Rgb mix(const Rgb& a, const Rgb& b, double w) {
  return Rgb{float(a.r + (b.r - a.r) * w), float(a.g + (b.g - a.g) * w), float(a.b + (b.b - a.b) * w)};
}
const Layer& need_height(const Terrain& t) {
  const Layer& h = t.get("height");
  if (h.channels != 1 || h.data.size() != t.frame.count()) throw Error("", "layer 'height' does not match the frame");
  return h;
}

// Fraction of land among probe points of a disk (centre and three rings), plus a small bonus for
// high ground, used to place features "on land".
double land_score(const Frame& fr, const Layer& h, double x, double z, double r) {
  int land = 0, n = 0;
  double up = 0;
  for (int ring = 0; ring <= 3; ++ring) {
    const int count = ring == 0 ? 1 : 8 * ring;
    for (int k = 0; k < count; ++k) {
      const double a = kTau * k / count, rr = r * ring / 3.0;
      const double e = detail::sample_bilinear(fr, h, x + rr * std::cos(a), z + rr * std::sin(a));
      land += e > fr.sea_level;
      up += std::max(0.0, e - fr.sea_level);
      ++n;
    }
  }
  return double(land) / n + 0.1 * up / n / std::max(1e-9, 1.0 - fr.sea_level);
}

// ===================================================================================== volcano

enum class VolcanoPlacement { Land, Fixed };

struct VolcanoParams {
  VolcanoPlacement placement = VolcanoPlacement::Land;
  double x_m = 2000, z_m = 2000;
  double radius_m = 650;
  double rim_radius_m = 200;
  double height = 0.5;
  int iterations = 400;
  double spread_m = 150;
  double circle_m = 300;
  double shrink = 0.2;
  int foundation_passes = 2;
  double crater_depth = 0.5;
  double lava_height = 0.35;
  Rgb foundation_color = rgb_hex(0x7a5b40);
  Rgb rock_color = rgb_hex(0x4f4540);
  Rgb ash_color = rgb_hex(0x77706a);
  Rgb lava_color = rgb_hex(0xff6a1a);
};

void apply_volcano(Terrain& t, const VolcanoParams& p, const Context& ctx) {
  const Frame& fr = t.frame;
  Layer& h = t.get("height");
  need_height(t);
  const double sea = fr.sea_level, land = 1.0 - sea;
  const std::uint64_t seed = ctx.stage_seed();
  // 1. Position: fixed, or the most "landy" of 96 hashed candidates inside the window.
  double cx = p.x_m, cz = p.z_m;
  if (p.placement == VolcanoPlacement::Land) {
    const double mx = std::min(p.radius_m, 0.45 * fr.width_m()), mz = std::min(p.radius_m, 0.45 * fr.depth_m());
    double best = -1;
    for (int k = 0; k < 96; ++k) {
      const std::uint64_t hk = hash64(seed, 0x706c6163ull, std::uint64_t(k));
      const double x = fr.x0_m() + mx + unit_double(hk) * (fr.width_m() - 2 * mx);
      const double z = fr.z0_m() + mz + unit_double(mix64(hk)) * (fr.depth_m() - 2 * mz);
      const double s = land_score(fr, h, x, z, p.radius_m);
      if (s > best) best = s, cx = x, cz = z;
    }
  }
  // 2. Circles: rim point → spread circle → iteration circle, radii shrinking linearly.
  std::vector<Circle> circles(std::size_t(p.iterations));
  for (int it = 0; it < p.iterations; ++it) {
    const double f = p.iterations > 1 ? double(it) / (p.iterations - 1) : 0.0;
    const double shrink = 1.0 + (p.shrink - 1.0) * f;
    const std::uint64_t hi = hash64(seed, 0x6974ull, std::uint64_t(it));
    const double a1 = kTau * unit_double(hi), a2 = kTau * unit_double(mix64(hi));
    const double rx = cx + p.rim_radius_m * std::cos(a1), rz = cz + p.rim_radius_m * std::sin(a1);
    const double spread = p.spread_m * shrink;
    circles[std::size_t(it)] = Circle{rx + spread * std::cos(a2), rz + spread * std::sin(a2), p.circle_m * shrink, 1.0};
  }
  // Normalise: the mean lift over 64 points of the rim circle becomes height · land.
  double rim = 0;
  for (int k = 0; k < 64; ++k)
    rim += detail::circles_at(circles, cx + p.rim_radius_m * std::cos(kTau * k / 64), cz + p.rim_radius_m * std::sin(kTau * k / 64));
  rim /= 64;
  const double scale = rim > 0 ? p.height * land / rim : 0.0;
  for (Circle& c : circles) c.amp = scale;
  std::vector<double> lift(fr.count(), 0.0);
  detail::add_circles(fr, circles, lift);

  // 3. Foundation, lift, crater.
  const double found = 1.0 - std::pow(0.5, p.foundation_passes);  // e → sea + (e − sea)/2^passes
  Layer& mask = t.layer("volcano", 1);
  detail::parallel_rows(fr.nz, [&](int j) {
    const double z = fr.z_m(j);
    for (int i = 0; i < fr.nx; ++i) {
      const std::size_t k = std::size_t(j) * fr.nx + i;
      const double d = std::hypot(fr.x_m(i) - cx, z - cz);
      if (d >= p.radius_m) continue;
      const double w = 1.0 - smoothstep01((d / p.radius_m - 0.7) / 0.3);
      double e = double(h.data[k]);
      e = e - (e - sea) * found * w;
      double crater = 0;
      if (d < p.rim_radius_m) {
        const double s = 1.0 - (d / p.rim_radius_m) * (d / p.rim_radius_m);
        crater = p.crater_depth * p.height * land * s * s;
      }
      h.data[k] = float(std::clamp(e + lift[k] - crater, 0.0, 1.0));
      mask.data[k] = float(w);
    }
  });
  // 4. Lava fills the crater from its floor up to lava_height of the way to the rim (seed 003:
  // inside the rim, below a height); colours where the volcano stands above the sea.
  double rim_e = 0;
  for (int k = 0; k < 64; ++k)
    rim_e += detail::sample_bilinear(fr, h, cx + p.rim_radius_m * std::cos(kTau * k / 64), cz + p.rim_radius_m * std::sin(kTau * k / 64));
  rim_e /= 64;
  const double floor_e = detail::sample_bilinear(fr, h, cx, cz);
  const double lava_level = std::max(sea, floor_e + p.lava_height * (rim_e - floor_e));
  Layer* albedo = t.has("albedo") && t.get("albedo").channels == 3 ? &t.get("albedo") : nullptr;
  Layer* biome = t.has("biome") && t.get("biome").channels == 1 ? &t.get("biome") : nullptr;
  int id_volcano = -1, id_lava = -1;
  if (biome) {
    id_volcano = detail::legend_id(t, "volcano", p.rock_color.r, p.rock_color.g, p.rock_color.b);
    id_lava = detail::legend_id(t, "lava", p.lava_color.r, p.lava_color.g, p.lava_color.b);
  }
  detail::parallel_rows(fr.nz, [&](int j) {
    const double z = fr.z_m(j);
    for (int i = 0; i < fr.nx; ++i) {
      const std::size_t k = std::size_t(j) * fr.nx + i;
      const double d = std::hypot(fr.x_m(i) - cx, z - cz);
      const double e = h.data[k];
      if (d >= p.radius_m || e <= sea) continue;  // the sea keeps its colour
      const double w = mask.data[k];
      const bool lava = d < p.rim_radius_m && e < lava_level;
      if (albedo) {
        const double q = lift[k] / std::max(1e-12, p.height * land);
        Rgb c = mix(p.foundation_color, p.rock_color, smoothstep01((q - 0.1) / 0.5));
        c = mix(c, p.ash_color, smoothstep01((q - 0.75) / 0.3));
        if (lava) c = p.lava_color;
        float* a = albedo->data.data() + 3 * k;
        const Rgb out = mix(Rgb{a[0], a[1], a[2]}, c, lava ? 1.0 : w * (0.35 + 0.65 * smoothstep01(q / 0.3)));
        a[0] = out.r, a[1] = out.g, a[2] = out.b;
      }
      if (biome && (w > 0.5 || lava)) biome->data[k] = float(lava ? id_lava : id_volcano);
    }
  });
  Point pt;
  pt.kind = "volcano";
  pt.type = "volcano";
  pt.x_m = cx;
  pt.z_m = cz;
  pt.y_m = fr.y_m(rim_e);  // the rim's mean height
  t.points.push_back(pt);
}

Reach volcano_reach(const VolcanoParams& p, const Frame& f) {
  if (p.placement == VolcanoPlacement::Land) return global("its place is chosen among candidates on the land of the whole map");
  return neighbourhood(int(std::min(double(1 << 28), std::ceil((p.radius_m + p.rim_radius_m) / f.cell_m()))) + 2);
}

void validate_volcano(const VolcanoParams& p, const std::string& path) {
  if (p.rim_radius_m >= p.radius_m)
    throw Error(path + ".rim_radius_m", "expected less than radius_m (" + std::to_string(p.radius_m) + "), got " +
                                            std::to_string(p.rim_radius_m));
}

// =================================================================================== features

enum class FeaturePlacement { Land, Anywhere };

struct FeaturesParams {
  FeaturePlacement placement = FeaturePlacement::Land;
  int craters = 2;
  double crater_radius_min_m = 60, crater_radius_max_m = 130;
  double crater_depth = 0.08;
  double crater_rim = 0.35;
  int peaks = 1;
  double peak_radius_m = 280;
  double peak_height = 0.3;
  int peak_iterations = 60;
  double clearance_m = 80;
  int attempts = 400;
  Rgb crater_color = rgb_hex(0x6b6055);
  Rgb peak_color = rgb_hex(0x857b70);
};

struct Feature {
  bool crater = true;
  double x = 0, z = 0, r = 0;
};

void apply_features(Terrain& t, const FeaturesParams& p, const Context& ctx) {
  const Frame& fr = t.frame;
  Layer& h = t.get("height");
  need_height(t);
  const double sea = fr.sea_level, land = 1.0 - sea;
  const std::uint64_t seed = ctx.stage_seed();
  const Layer* volcano = t.has("volcano") ? &t.get("volcano") : nullptr;
  // Sequential placement from a fixed list of hashed candidates: deterministic.
  std::vector<Feature> placed;
  int attempt = 0;
  auto place = [&](bool crater, int count) {
    for (int n = 0; n < count && attempt < p.attempts;) {
      for (; attempt < p.attempts; ++attempt) {
        const std::uint64_t hk = hash64(seed, 0x66656174ull, std::uint64_t(attempt));
        const double r = crater ? p.crater_radius_min_m + (p.crater_radius_max_m - p.crater_radius_min_m) * unit_double(mix64(mix64(hk)))
                                : p.peak_radius_m;
        const double x = fr.x0_m() + unit_double(hk) * fr.width_m(), z = fr.z0_m() + unit_double(mix64(hk)) * fr.depth_m();
        if (p.placement == FeaturePlacement::Land && land_score(fr, h, x, z, crater ? 1.5 * r : r) < 1.0) continue;
        bool clear = true;
        for (auto& f : placed) clear = clear && std::hypot(f.x - x, f.z - z) >= f.r + r + p.clearance_m;
        if (volcano)
          for (int k = 0; k < 16 && clear; ++k)
            clear = detail::sample_nearest(fr, *volcano, x + r * std::cos(kTau * k / 16), z + r * std::sin(kTau * k / 16)) <= 0.0f &&
                    detail::sample_nearest(fr, *volcano, x, z) <= 0.0f;
        if (!clear) continue;
        placed.push_back({crater, x, z, r});
        ++n;
        ++attempt;
        break;
      }
    }
  };
  place(true, p.craters);
  place(false, p.peaks);

  Layer* albedo = t.has("albedo") && t.get("albedo").channels == 3 ? &t.get("albedo") : nullptr;
  for (std::size_t f = 0; f < placed.size(); ++f) {
    const Feature& F = placed[f];
    Point pt;
    pt.kind = F.crater ? "crater" : "peak";
    pt.type = pt.kind;
    pt.x_m = F.x;
    pt.z_m = F.z;
    pt.scale = F.r;  // radius in metres
    if (F.crater) {
      // Melosh's simple crater: bowl −D + (D + H)(r/R)² inside, rim H, ejecta H(R/r)³ fading out by 3R.
      const double D = p.crater_depth * land, H = p.crater_rim * D;
      const double base = detail::sample_bilinear(fr, h, F.x, F.z);
      detail::parallel_rows(fr.nz, [&](int j) {
        const double z = fr.z_m(j);
        for (int i = 0; i < fr.nx; ++i) {
          const double d = std::hypot(fr.x_m(i) - F.x, z - F.z) / F.r;
          if (d >= 3.0) continue;
          const std::size_t k = std::size_t(j) * fr.nx + i;
          const double dh = d < 1.0 ? -D + (D + H) * d * d : H / (d * d * d) * (1.0 - smoothstep01(d - 2.0));
          h.data[k] = float(std::clamp(double(h.data[k]) + dh, 0.0, 1.0));
          if (albedo && d < 1.15) {
            float* a = albedo->data.data() + 3 * k;
            const Rgb c = mix(Rgb{a[0], a[1], a[2]}, p.crater_color, 0.8 * (1.0 - smoothstep01((d - 0.85) / 0.3)));
            a[0] = c.r, a[1] = c.g, a[2] = c.b;
          }
        }
      });
      pt.y_m = fr.y_m(std::clamp(base - D, 0.0, 1.0));
    } else {
      // Kamal & Uddin-style peak: circles shrinking from R to 0.15 R around a wandering centre.
      std::vector<Circle> cs(std::size_t(p.peak_iterations));
      for (int it = 0; it < p.peak_iterations; ++it) {
        const double s = p.peak_iterations > 1 ? double(it) / (p.peak_iterations - 1) : 0.0;
        const std::uint64_t hi = hash64(seed, 0x7065616bull + f, std::uint64_t(it));
        const double a = kTau * unit_double(hi), rr = 0.2 * F.r * (1.0 - s) * unit_double(mix64(hi));
        cs[std::size_t(it)] = Circle{F.x + rr * std::cos(a), F.z + rr * std::sin(a), F.r * (1.0 - 0.85 * s), 1.0};
      }
      const double top = detail::circles_at(cs, F.x, F.z);
      for (Circle& c : cs) c.amp = p.peak_height * land / top;
      std::vector<double> lift(fr.count(), 0.0);
      detail::add_circles(fr, cs, lift);
      const double base = detail::sample_bilinear(fr, h, F.x, F.z);
      detail::parallel_rows(fr.nz, [&](int j) {
        for (int i = 0; i < fr.nx; ++i) {
          const std::size_t k = std::size_t(j) * fr.nx + i;
          if (lift[k] <= 0.0) continue;
          h.data[k] = float(std::clamp(double(h.data[k]) + lift[k], 0.0, 1.0));
          if (albedo) {
            float* a = albedo->data.data() + 3 * k;
            const Rgb c = mix(Rgb{a[0], a[1], a[2]}, p.peak_color, smoothstep01((lift[k] / (p.peak_height * land) - 0.25) / 0.45));
            a[0] = c.r, a[1] = c.g, a[2] = c.b;
          }
        }
      });
      pt.y_m = fr.y_m(std::clamp(base + p.peak_height * land, 0.0, 1.0));
    }
    t.points.push_back(pt);
  }
}

void validate_features(const FeaturesParams& p, const std::string& path) {
  if (p.crater_radius_max_m < p.crater_radius_min_m)
    throw Error(path + ".crater_radius_max_m", "expected at least crater_radius_min_m (" +
                                                   std::to_string(p.crater_radius_min_m) + "), got " +
                                                   std::to_string(p.crater_radius_max_m));
}

// ===================================================================================== jiggle

struct JiggleParams {
  double amount = 0.3;
};

// offset(i, j) = amount · cell · (2u − 1, 2v − 1), u, v hashed from (recipe seed, world sample
// index): every window of the same grid gives the same offsets; |offset| ≤ amount · cell per axis.
void apply_jiggle(Terrain& t, const JiggleParams& p, const Context& ctx) {
  const Frame& fr = t.frame;
  Layer& off = t.layer("offset", 2);
  const std::uint64_t seed = hash64(ctx.seed, 0x6a6967676c65ull /* "jiggle" */);
  const double a = p.amount * fr.cell_m();
  detail::parallel_rows(fr.nz, [&](int j) {
    for (int i = 0; i < fr.nx; ++i) {
      const std::uint64_t hk = hash64(seed, std::uint64_t(fr.ix0 + i), std::uint64_t(fr.iz0 + j));
      float* o = off.data.data() + 2 * (std::size_t(j) * fr.nx + i);
      o[0] = float(a * (2.0 * unit_double(hk) - 1.0));
      o[1] = float(a * (2.0 * unit_double(mix64(hk)) - 1.0));
    }
  });
}

}  // namespace

StageDef volcano() {
  using P = VolcanoParams;
  constexpr Effect R = Effect::Recolour;
  Table<P> table{{
      choice(&P::placement, "placement", {{VolcanoPlacement::Land, "land"}, {VolcanoPlacement::Fixed, "fixed"}},
             "land: the most land-covered of 96 seeded candidates; fixed: at x_m, z_m"),
      param(&P::x_m, "x_m", -1e7, 1e7, "m", "fixed placement: centre x"),
      param(&P::z_m, "z_m", -1e7, 1e7, "m", "fixed placement: centre z"),
      param(&P::radius_m, "radius_m", 10.0, 1e6, "m", "Affected region: foundation and base of the volcano"),
      param(&P::rim_radius_m, "rim_radius_m", 1.0, 1e6, "m", "Rim circle (less than radius_m)"),
      param(&P::height, "height", 0.0, 1.0, "", "Mean rim lift above sea level, as a fraction of the land range"),
      param(&P::iterations, "iterations", 1, 100000, "", "Iteration circles stacked"),
      param(&P::spread_m, "spread_m", 0.0, 1e6, "m", "Radius of the first spread circle (around a rim point)"),
      param(&P::circle_m, "circle_m", 1.0, 1e6, "m", "Radius of the first iteration circle (lifted)"),
      param(&P::shrink, "shrink", 0.01, 1.0, "", "Radii of the last iteration relative to the first"),
      param(&P::foundation_passes, "foundation_passes", 0, 16, "", "Times the region is averaged with sea level first"),
      param(&P::crater_depth, "crater_depth", 0.0, 2.0, "", "Crater bowl carved inside the rim, as a fraction of height"),
      param(&P::lava_height, "lava_height", 0.0, 2.0, "", "Lava fills the crater this fraction of the way from its floor to the rim", R),
      color(&P::foundation_color, "foundation_color", "Colour of the foundation (volcanic soil)"),
      color(&P::rock_color, "rock_color", "Colour of the cone's flanks"),
      color(&P::ash_color, "ash_color", "Colour near the rim"),
      color(&P::lava_color, "lava_color", "Colour of lava"),
  }};
  StageDef d = make_stage<P>("volcano",
                       "Volcano (seed 003): foundation, stacked circles around a rim, crater and lava; writes height, "
                       "albedo, biome, the 'volcano' footprint layer and a feature point",
                       global("its place is chosen among candidates on the land of the whole map"), std::move(table),
                       apply_volcano, validate_volcano, volcano_reach,
                       "placement fixed: ceil((radius_m + rim_radius_m) / cell) + 2 samples; placement land: global");
  d.memory = {{{"volcano", 1}}, {}, 4, {}};
  return d;
}

StageDef features() {
  using P = FeaturesParams;
  Table<P> table{{
      choice(&P::placement, "placement", {{FeaturePlacement::Land, "land"}, {FeaturePlacement::Anywhere, "anywhere"}},
             "land: whole feature on land, off the volcano"),
      param(&P::craters, "craters", 0, 256, "", "Impact craters to place"),
      param(&P::crater_radius_min_m, "crater_radius_min_m", 1.0, 1e6, "m", "Smallest crater radius"),
      param(&P::crater_radius_max_m, "crater_radius_max_m", 1.0, 1e6, "m", "Largest crater radius"),
      param(&P::crater_depth, "crater_depth", 0.0, 1.0, "", "Bowl depth, as a fraction of the land range"),
      param(&P::crater_rim, "crater_rim", 0.0, 2.0, "", "Rim height as a fraction of the bowl depth"),
      param(&P::peaks, "peaks", 0, 256, "", "Single mountains to place"),
      param(&P::peak_radius_m, "peak_radius_m", 1.0, 1e6, "m", "Base radius of a peak"),
      param(&P::peak_height, "peak_height", 0.0, 1.0, "", "Peak lift, as a fraction of the land range"),
      param(&P::peak_iterations, "peak_iterations", 1, 10000, "", "Circles stacked per peak"),
      param(&P::clearance_m, "clearance_m", 0.0, 1e6, "m", "Free ground between features"),
      param(&P::attempts, "attempts", 1, 100000, "", "Candidate positions tried, in a fixed seeded order"),
      color(&P::crater_color, "crater_color", "Colour inside craters"),
      color(&P::peak_color, "peak_color", "Colour of the upper peak"),
  }};
  return make_stage<P>("features", "Craters and single mountains as feature points (seed 003 §2.5)",
                       global("their places are chosen among candidates on the land of the whole map"),
                       std::move(table), apply_features, validate_features);
}

StageDef jiggle() {
  using P = JiggleParams;
  Table<P> table{{
      param(&P::amount, "amount", 0.0, 0.45, "cells", "Largest move along x and along z, in cells (< 0.5: no folds)"),
  }};
  StageDef d = make_stage<P>("jiggle",
                       "Vertex jiggle (seed 003): deterministic x/z offsets within a fraction of a cell, written as the "
                       "2-channel layer 'offset' (dx_m, dz_m) that mesh writers apply",
                       pointwise(), std::move(table), apply_jiggle);
  d.memory = {{{"offset", 2}}, {}, 0, {}};
  return d;
}

}  // namespace stages
}  // namespace relief
