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
// tile cannot know the choice without every other tile's heights. Their world algorithms
// (relief/world_features.hpp, src/world_features.cpp) score the candidates from the stored tiles and
// then apply the effects tile by tile, exactly: the decisions and per-sample effects live here once,
// in detail::VolcanoPlan and detail::FeaturesPlan, which both the whole-map stages below and the
// world algorithms run (positions in world metres, reads by world-grid index). A volcano with
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
#include "relief/world_features.hpp"
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
BilinearCell bilinear_cell(const Frame& fr, double x, double z) {
  const double fx = std::clamp(x / fr.cell_m() - double(fr.ix0), 0.0, double(fr.nx - 1));
  const double fz = std::clamp(z / fr.cell_m() - double(fr.iz0), 0.0, double(fr.nz - 1));
  const int i0 = std::min(int(fx), fr.nx - 2), j0 = std::min(int(fz), fr.nz - 2);
  return {i0, j0, fx - i0, fz - j0};
}

double bilinear_mix(const BilinearCell& c, double v00, double v10, double v01, double v11) {
  const double a = v00 + (v10 - v00) * c.tx;
  const double b = v01 + (v11 - v01) * c.tx;
  return a + (b - a) * c.tz;
}

double sample_bilinear(const Frame& fr, const Layer& l, double x, double z) {
  const BilinearCell c = bilinear_cell(fr, x, z);
  auto at = [&](int i, int j) { return double(l.data[(std::size_t(j) * fr.nx + i) * l.channels]); };
  return bilinear_mix(c, at(c.i0, c.j0), at(c.i0 + 1, c.j0), at(c.i0, c.j0 + 1), at(c.i0 + 1, c.j0 + 1));
}

NearestSample nearest_sample(const Frame& fr, double x, double z) {
  const std::int64_t gi = std::llround(x / fr.cell_m()) - fr.ix0, gj = std::llround(z / fr.cell_m()) - fr.iz0;
  return {int(std::clamp<std::int64_t>(gi, 0, fr.nx - 1)), int(std::clamp<std::int64_t>(gj, 0, fr.nz - 1))};
}

float sample_nearest(const Frame& fr, const Layer& l, double x, double z, int c) {
  const NearestSample n = nearest_sample(fr, x, z);
  return l.data[(std::size_t(n.j) * fr.nx + n.i) * l.channels + c];
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
Rgb mix_rgb(const Rgb& a, const Rgb& b, double w) {
  return Rgb{float(a.r + (b.r - a.r) * w), float(a.g + (b.g - a.g) * w), float(a.b + (b.b - a.b) * w)};
}
const Layer& need_height(const Terrain& t) {
  const Layer& h = t.get("height");
  if (h.channels != 1 || h.data.size() != t.frame.count()) throw Error("", "layer 'height' does not match the frame");
  return h;
}

// Land probes of a disk: the centre and three rings of 8, 16 and 24 points (radius r/3, 2r/3, r),
// in the order land_score sums them.
constexpr int kLandProbes = 49;
void land_probes(double x, double z, double r, std::vector<detail::XZ>& out) {
  for (int ring = 0; ring <= 3; ++ring) {
    const int count = ring == 0 ? 1 : 8 * ring;
    for (int k = 0; k < count; ++k) {
      const double a = kTau * k / count, rr = r * ring / 3.0;
      out.push_back({x + rr * std::cos(a), z + rr * std::sin(a)});
    }
  }
}
// Fraction of land among the land probes of a disk (their bilinear heights `e`, kLandProbes of them),
// plus a small bonus for high ground, used to place features "on land".
double land_score(const Frame& fr, const double* e) {
  int land = 0, n = 0;
  double up = 0;
  for (int q = 0; q < kLandProbes; ++q) {
    land += e[q] > fr.sea_level;
    up += std::max(0.0, e[q] - fr.sea_level);
    ++n;
  }
  return double(land) / n + 0.1 * up / n / std::max(1e-9, 1.0 - fr.sea_level);
}
// The bilinear heights of `probes` on the terrain itself (the whole-map stages).
std::vector<double> heights_at(const Frame& fr, const Layer& h, const std::vector<detail::XZ>& probes) {
  std::vector<double> e(probes.size());
  for (std::size_t q = 0; q < probes.size(); ++q) e[q] = detail::sample_bilinear(fr, h, probes[q].x_m, probes[q].z_m);
  return e;
}

// The distance from (x, z) to the rectangle of a window's sample positions, in metres.
double distance_to_window(const Frame& w, double x, double z) {
  const double dx = std::max({0.0, w.x0_m() - x, x - w.x_m(w.nx - 1)});
  const double dz = std::max({0.0, w.z0_m() - z, z - w.z_m(w.nz - 1)});
  return std::hypot(dx, dz);
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

Table<VolcanoParams> volcano_table() {
  using P = VolcanoParams;
  constexpr Effect R = Effect::Recolour;
  return Table<P>{{
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
}

constexpr int kVolcanoCandidates = 96, kRimProbes = 64;

}  // namespace
}  // namespace stages

// The volcano's decisions and effects (relief/world_features.hpp: detail::VolcanoPlan); the
// whole-map stage (apply_volcano) and the world algorithm (src/world_features.cpp) both run them.
struct detail::VolcanoPlan::Impl {
  stages::VolcanoParams p;
  Frame fr;  // the whole-map stage's frame (candidates span it)
  std::uint64_t seed = 0;
  double sea = 0, land = 0;
  double cx = 0, cz = 0;
  std::vector<Circle> circles;
  double rim_e = 0, lava_level = 0;

  Impl(const stages::VolcanoParams& params, const Frame& frame, const Context& ctx)
      : p(params), fr(frame), seed(ctx.stage_seed()), sea(frame.sea_level), land(1.0 - frame.sea_level), cx(p.x_m), cz(p.z_m) {
    if (p.placement == stages::VolcanoPlacement::Fixed) make_circles();
  }
  // 1. Position: fixed, or the most "landy" of 96 hashed candidates inside the frame.
  XZ candidate(int k) const {
    const double mx = std::min(p.radius_m, 0.45 * fr.width_m()), mz = std::min(p.radius_m, 0.45 * fr.depth_m());
    const std::uint64_t hk = hash64(seed, 0x706c6163ull, std::uint64_t(k));
    return {fr.x0_m() + mx + unit_double(hk) * (fr.width_m() - 2 * mx), fr.z0_m() + mz + unit_double(mix64(hk)) * (fr.depth_m() - 2 * mz)};
  }
  std::vector<XZ> candidate_probes() const {
    std::vector<XZ> probes;
    if (p.placement != stages::VolcanoPlacement::Land) return probes;
    probes.reserve(std::size_t(stages::kVolcanoCandidates) * stages::kLandProbes);
    for (int k = 0; k < stages::kVolcanoCandidates; ++k) {
      const XZ c = candidate(k);
      stages::land_probes(c.x_m, c.z_m, p.radius_m, probes);
    }
    return probes;
  }
  void choose(const std::vector<double>& e) {
    if (e.size() != std::size_t(stages::kVolcanoCandidates) * stages::kLandProbes) throw Error("", "volcano: expected the candidates' land probes");
    double best = -1;
    for (int k = 0; k < stages::kVolcanoCandidates; ++k) {
      const double s = stages::land_score(fr, e.data() + std::size_t(k) * stages::kLandProbes);
      if (s > best) {
        best = s;
        const XZ c = candidate(k);
        cx = c.x_m, cz = c.z_m;
      }
    }
    make_circles();
  }
  // 2. Circles: rim point → spread circle → iteration circle, radii shrinking linearly; normalised
  // so that the mean lift over 64 points of the rim circle is height · land.
  void make_circles() {
    circles.assign(std::size_t(p.iterations), Circle{});
    for (int it = 0; it < p.iterations; ++it) {
      const double f = p.iterations > 1 ? double(it) / (p.iterations - 1) : 0.0;
      const double shrink = 1.0 + (p.shrink - 1.0) * f;
      const std::uint64_t hi = hash64(seed, 0x6974ull, std::uint64_t(it));
      const double a1 = stages::kTau * unit_double(hi), a2 = stages::kTau * unit_double(mix64(hi));
      const double rx = cx + p.rim_radius_m * std::cos(a1), rz = cz + p.rim_radius_m * std::sin(a1);
      const double spread = p.spread_m * shrink;
      circles[std::size_t(it)] = Circle{rx + spread * std::cos(a2), rz + spread * std::sin(a2), p.circle_m * shrink, 1.0};
    }
    double rim = 0;
    for (int k = 0; k < stages::kRimProbes; ++k)
      rim += circles_at(circles, cx + p.rim_radius_m * std::cos(stages::kTau * k / 64), cz + p.rim_radius_m * std::sin(stages::kTau * k / 64));
    rim /= 64;
    const double scale = rim > 0 ? p.height * land / rim : 0.0;
    for (Circle& c : circles) c.amp = scale;
  }
  // 3. Foundation, lift, crater, on any window; returns the lift per sample.
  std::vector<double> shape(Terrain& t) const {
    const Frame& w = t.frame;
    Layer& h = t.get("height");
    std::vector<double> lift(w.count(), 0.0);
    add_circles(w, circles, lift);
    const double found = 1.0 - std::pow(0.5, p.foundation_passes);  // e → sea + (e − sea)/2^passes
    Layer& mask = t.layer("volcano", 1);
    parallel_rows(w.nz, [&](int j) {
      const double z = w.z_m(j);
      for (int i = 0; i < w.nx; ++i) {
        const std::size_t k = std::size_t(j) * w.nx + i;
        const double d = std::hypot(w.x_m(i) - cx, z - cz);
        if (d >= p.radius_m) continue;
        const double wt = 1.0 - stages::smoothstep01((d / p.radius_m - 0.7) / 0.3);
        double e = double(h.data[k]);
        e = e - (e - sea) * found * wt;
        double crater = 0;
        if (d < p.rim_radius_m) {
          const double s = 1.0 - (d / p.rim_radius_m) * (d / p.rim_radius_m);
          crater = p.crater_depth * p.height * land * s * s;
        }
        h.data[k] = float(std::clamp(e + lift[k] - crater, 0.0, 1.0));
        mask.data[k] = float(wt);
      }
    });
    return lift;
  }
  // 4. Lava fills the crater from its floor up to lava_height of the way to the rim (seed 003:
  // inside the rim, below a height), read on the shaped heights at the rim and the centre.
  std::vector<XZ> lava_probes() const {
    std::vector<XZ> probes;
    for (int k = 0; k < stages::kRimProbes; ++k)
      probes.push_back({cx + p.rim_radius_m * std::cos(stages::kTau * k / 64), cz + p.rim_radius_m * std::sin(stages::kTau * k / 64)});
    probes.push_back({cx, cz});
    return probes;
  }
  void set_lava(const std::vector<double>& e) {
    if (e.size() != std::size_t(stages::kRimProbes) + 1) throw Error("", "volcano: expected the lava probes");
    rim_e = 0;
    for (int k = 0; k < stages::kRimProbes; ++k) rim_e += e[std::size_t(k)];
    rim_e /= 64;
    const double floor_e = e[std::size_t(stages::kRimProbes)];
    lava_level = std::max(sea, floor_e + p.lava_height * (rim_e - floor_e));
  }
  // Colours where the volcano stands above the sea, on any window already shaped (`lift` from shape).
  void colour(Terrain& t, const std::vector<double>& lift) const {
    const Frame& w = t.frame;
    const Layer& h = t.get("height");
    const Layer& mask = t.get("volcano");
    Layer* albedo = t.has("albedo") && t.get("albedo").channels == 3 ? &t.get("albedo") : nullptr;
    Layer* biome = t.has("biome") && t.get("biome").channels == 1 ? &t.get("biome") : nullptr;
    int id_volcano = -1, id_lava = -1;
    if (biome) {
      id_volcano = legend_id(t, "volcano", p.rock_color.r, p.rock_color.g, p.rock_color.b);
      id_lava = legend_id(t, "lava", p.lava_color.r, p.lava_color.g, p.lava_color.b);
    }
    parallel_rows(w.nz, [&](int j) {
      const double z = w.z_m(j);
      for (int i = 0; i < w.nx; ++i) {
        const std::size_t k = std::size_t(j) * w.nx + i;
        const double d = std::hypot(w.x_m(i) - cx, z - cz);
        const double e = h.data[k];
        if (d >= p.radius_m || e <= sea) continue;  // the sea keeps its colour
        const double wt = mask.data[k];
        const bool lava = d < p.rim_radius_m && e < lava_level;
        if (albedo) {
          const double q = lift[k] / std::max(1e-12, p.height * land);
          Rgb c = stages::mix_rgb(p.foundation_color, p.rock_color, stages::smoothstep01((q - 0.1) / 0.5));
          c = stages::mix_rgb(c, p.ash_color, stages::smoothstep01((q - 0.75) / 0.3));
          if (lava) c = p.lava_color;
          float* a = albedo->data.data() + 3 * k;
          const Rgb out = stages::mix_rgb(Rgb{a[0], a[1], a[2]}, c, lava ? 1.0 : wt * (0.35 + 0.65 * stages::smoothstep01(q / 0.3)));
          a[0] = out.r, a[1] = out.g, a[2] = out.b;
        }
        if (biome && (wt > 0.5 || lava)) biome->data[k] = float(lava ? id_lava : id_volcano);
      }
    });
  }
  Point point() const {
    Point pt;
    pt.kind = "volcano";
    pt.type = "volcano";
    pt.x_m = cx;
    pt.z_m = cz;
    pt.y_m = fr.y_m(rim_e);  // the rim's mean height
    return pt;
  }
};

namespace stages {
namespace {

void apply_volcano(Terrain& t, const VolcanoParams& p, const Context& ctx) {
  const Frame& fr = t.frame;
  const Layer& h = t.get("height");
  need_height(t);
  detail::VolcanoPlan::Impl plan(p, fr, ctx);
  if (p.placement == VolcanoPlacement::Land) plan.choose(heights_at(fr, h, plan.candidate_probes()));
  const std::vector<double> lift = plan.shape(t);
  plan.set_lava(heights_at(fr, h, plan.lava_probes()));
  plan.colour(t, lift);
  t.points.push_back(plan.point());
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

Table<FeaturesParams> features_table() {
  using P = FeaturesParams;
  return Table<P>{{
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
}

struct Feature {
  bool crater = true;
  double x = 0, z = 0, r = 0;
};

constexpr int kVolcanoProbes = 17;  // 16 on the feature's circle, then its centre

}  // namespace
}  // namespace stages

// The features' decisions and effects (relief/world_features.hpp: detail::FeaturesPlan).
struct detail::FeaturesPlan::Impl {
  stages::FeaturesParams p;
  Frame fr;  // the whole-map stage's frame (candidates span it)
  std::uint64_t seed = 0;
  double sea = 0, land = 0;
  bool volcano_layer = false;
  std::vector<stages::Feature> placed;
  std::vector<double> base;  // per feature: the height at its centre before its own effect

  Impl(const stages::FeaturesParams& params, const Frame& frame, const Context& ctx, bool volcano)
      : p(params), fr(frame), seed(ctx.stage_seed()), sea(frame.sea_level), land(1.0 - frame.sea_level), volcano_layer(volcano) {}
  // Attempt a's candidate (radius for a crater or a peak).
  stages::Feature candidate(int attempt, bool crater) const {
    const std::uint64_t hk = hash64(seed, 0x66656174ull, std::uint64_t(attempt));
    const double r = crater ? p.crater_radius_min_m + (p.crater_radius_max_m - p.crater_radius_min_m) * unit_double(mix64(mix64(hk)))
                            : p.peak_radius_m;
    return {crater, fr.x0_m() + unit_double(hk) * fr.width_m(), fr.z0_m() + unit_double(mix64(hk)) * fr.depth_m(), r};
  }
  std::vector<XZ> land_probes(int a, bool crater) const {
    const stages::Feature c = candidate(a, crater);
    std::vector<XZ> probes;
    probes.reserve(stages::kLandProbes);
    stages::land_probes(c.x, c.z, crater ? 1.5 * c.r : c.r, probes);
    return probes;
  }
  std::vector<XZ> volcano_probes(int a, bool crater) const {
    const stages::Feature c = candidate(a, crater);
    std::vector<XZ> probes;
    for (int k = 0; k < 16; ++k) probes.push_back({c.x + c.r * std::cos(stages::kTau * k / 16), c.z + c.r * std::sin(stages::kTau * k / 16)});
    probes.push_back({c.x, c.z});
    return probes;
  }
  bool land_ok(const std::vector<double>& e) const {
    if (e.size() != std::size_t(stages::kLandProbes)) throw Error("", "features: expected a candidate's land probes");
    return !(stages::land_score(fr, e.data()) < 1.0);
  }
  static bool off_volcano(const std::vector<float>& v) {
    if (v.size() != std::size_t(stages::kVolcanoProbes)) throw Error("", "features: expected a candidate's volcano probes");
    bool clear = true;
    for (int k = 0; k < 16 && clear; ++k) clear = v[std::size_t(k)] <= 0.0f && v[16] <= 0.0f;
    return clear;
  }
  // Sequential placement from a fixed list of hashed candidates: deterministic.
  void place(const std::function<bool(int, bool)>& on_land, const std::function<bool(int, bool)>& clear_of_volcano) {
    placed.clear();
    int attempt = 0;
    auto place_kind = [&](bool crater, int count) {
      for (int n = 0; n < count && attempt < p.attempts;) {
        for (; attempt < p.attempts; ++attempt) {
          const stages::Feature c = candidate(attempt, crater);
          if (p.placement == stages::FeaturePlacement::Land && !on_land(attempt, crater)) continue;
          bool clear = true;
          for (auto& f : placed) clear = clear && std::hypot(f.x - c.x, f.z - c.z) >= f.r + c.r + p.clearance_m;
          if (volcano_layer && clear) clear = clear_of_volcano(attempt, crater);
          if (!clear) continue;
          placed.push_back(c);
          ++n;
          ++attempt;
          break;
        }
      }
    };
    place_kind(true, p.craters);
    place_kind(false, p.peaks);
    base.assign(placed.size(), 0.0);
  }
  // Feature f's effect on any window.
  void apply(Terrain& t, int f) const {
    const Frame& w = t.frame;
    Layer& h = t.get("height");
    Layer* albedo = t.has("albedo") && t.get("albedo").channels == 3 ? &t.get("albedo") : nullptr;
    const stages::Feature& F = placed.at(std::size_t(f));
    if (F.crater) {
      // Melosh's simple crater: bowl −D + (D + H)(r/R)² inside, rim H, ejecta H(R/r)³ fading out by 3R.
      const double D = p.crater_depth * land, H = p.crater_rim * D;
      parallel_rows(w.nz, [&](int j) {
        const double z = w.z_m(j);
        for (int i = 0; i < w.nx; ++i) {
          const double d = std::hypot(w.x_m(i) - F.x, z - F.z) / F.r;
          if (d >= 3.0) continue;
          const std::size_t k = std::size_t(j) * w.nx + i;
          const double dh = d < 1.0 ? -D + (D + H) * d * d : H / (d * d * d) * (1.0 - stages::smoothstep01(d - 2.0));
          h.data[k] = float(std::clamp(double(h.data[k]) + dh, 0.0, 1.0));
          if (albedo && d < 1.15) {
            float* a = albedo->data.data() + 3 * k;
            const Rgb c = stages::mix_rgb(Rgb{a[0], a[1], a[2]}, p.crater_color, 0.8 * (1.0 - stages::smoothstep01((d - 0.85) / 0.3)));
            a[0] = c.r, a[1] = c.g, a[2] = c.b;
          }
        }
      });
    } else {
      // Kamal & Uddin-style peak: circles shrinking from R to 0.15 R around a wandering centre.
      std::vector<Circle> cs(std::size_t(p.peak_iterations));
      for (int it = 0; it < p.peak_iterations; ++it) {
        const double s = p.peak_iterations > 1 ? double(it) / (p.peak_iterations - 1) : 0.0;
        const std::uint64_t hi = hash64(seed, 0x7065616bull + std::uint64_t(f), std::uint64_t(it));
        const double a = stages::kTau * unit_double(hi), rr = 0.2 * F.r * (1.0 - s) * unit_double(mix64(hi));
        cs[std::size_t(it)] = Circle{F.x + rr * std::cos(a), F.z + rr * std::sin(a), F.r * (1.0 - 0.85 * s), 1.0};
      }
      const double top = circles_at(cs, F.x, F.z);
      for (Circle& c : cs) c.amp = p.peak_height * land / top;
      std::vector<double> lift(w.count(), 0.0);
      add_circles(w, cs, lift);
      parallel_rows(w.nz, [&](int j) {
        for (int i = 0; i < w.nx; ++i) {
          const std::size_t k = std::size_t(j) * w.nx + i;
          if (lift[k] <= 0.0) continue;
          h.data[k] = float(std::clamp(double(h.data[k]) + lift[k], 0.0, 1.0));
          if (albedo) {
            float* a = albedo->data.data() + 3 * k;
            const Rgb c = stages::mix_rgb(Rgb{a[0], a[1], a[2]}, p.peak_color, stages::smoothstep01((lift[k] / (p.peak_height * land) - 0.25) / 0.45));
            a[0] = c.r, a[1] = c.g, a[2] = c.b;
          }
        }
      });
    }
  }
  std::vector<Point> points() const {
    std::vector<Point> out;
    for (std::size_t f = 0; f < placed.size(); ++f) {
      const stages::Feature& F = placed[f];
      Point pt;
      pt.kind = F.crater ? "crater" : "peak";
      pt.type = pt.kind;
      pt.x_m = F.x;
      pt.z_m = F.z;
      pt.scale = F.r;  // radius in metres
      pt.y_m = F.crater ? fr.y_m(std::clamp(base[f] - p.crater_depth * land, 0.0, 1.0))
                        : fr.y_m(std::clamp(base[f] + p.peak_height * land, 0.0, 1.0));
      out.push_back(pt);
    }
    return out;
  }
};

namespace stages {
namespace {

void apply_features(Terrain& t, const FeaturesParams& p, const Context& ctx) {
  const Frame& fr = t.frame;
  const Layer& h = t.get("height");
  need_height(t);
  const Layer* volcano = t.has("volcano") ? &t.get("volcano") : nullptr;
  detail::FeaturesPlan::Impl plan(p, fr, ctx, volcano != nullptr);
  plan.place([&](int a, bool crater) { return plan.land_ok(heights_at(fr, h, plan.land_probes(a, crater))); },
             [&](int a, bool crater) {
               const std::vector<detail::XZ> probes = plan.volcano_probes(a, crater);
               std::vector<float> v(probes.size());
               for (std::size_t q = 0; q < probes.size(); ++q) v[q] = detail::sample_nearest(fr, *volcano, probes[q].x_m, probes[q].z_m);
               return plan.off_volcano(v);
             });
  for (int f = 0; f < int(plan.placed.size()); ++f) {
    plan.base[std::size_t(f)] = detail::sample_bilinear(fr, h, plan.placed[std::size_t(f)].x, plan.placed[std::size_t(f)].z);
    plan.apply(t, f);
  }
  const std::vector<Point> pts = plan.points();
  t.points.insert(t.points.end(), pts.begin(), pts.end());
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
  StageDef d = make_stage<VolcanoParams>("volcano",
                       "Volcano (seed 003): foundation, stacked circles around a rim, crater and lava; writes height, "
                       "albedo, biome, the 'volcano' footprint layer and a feature point",
                       global("its place is chosen among candidates on the land of the whole map"), volcano_table(),
                       apply_volcano, validate_volcano, volcano_reach,
                       "placement fixed: ceil((radius_m + rim_radius_m) / cell) + 2 samples; placement land: global");
  d.memory = {{{"volcano", 1}}, {}, 4, {}};
  return d;
}

StageDef features() {
  return make_stage<FeaturesParams>("features", "Craters and single mountains as feature points (seed 003 §2.5)",
                       global("their places are chosen among candidates on the land of the whole map"),
                       features_table(), apply_features, validate_features);
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

// ---- the plans' public faces (relief/world_features.hpp) ---------------------------------------

namespace detail {

VolcanoPlan::VolcanoPlan(const json& params, const Frame& frame, const Context& ctx, const std::string& path) {
  const stages::VolcanoParams p = stages::volcano_table().read(params, path, {"stage", "label"});
  stages::validate_volcano(p, path);
  impl_ = std::make_unique<Impl>(p, frame, ctx);
}
VolcanoPlan::~VolcanoPlan() = default;
VolcanoPlan::VolcanoPlan(VolcanoPlan&&) noexcept = default;
bool VolcanoPlan::on_land() const { return impl_->p.placement == stages::VolcanoPlacement::Land; }
std::vector<XZ> VolcanoPlan::candidate_probes() const { return impl_->candidate_probes(); }
void VolcanoPlan::choose(const std::vector<double>& heights) { impl_->choose(heights); }
std::vector<XZ> VolcanoPlan::lava_probes() const { return impl_->lava_probes(); }
void VolcanoPlan::shape(Terrain& window) const { impl_->shape(window); }
void VolcanoPlan::set_lava(const std::vector<double>& heights) { impl_->set_lava(heights); }
void VolcanoPlan::apply(Terrain& window) const { impl_->colour(window, impl_->shape(window)); }
bool VolcanoPlan::touches(const Frame& w) const {
  // shape and colour change samples with d < radius_m only.
  return stages::distance_to_window(w, impl_->cx, impl_->cz) <= impl_->p.radius_m + w.cell_m();
}
Point VolcanoPlan::point() const { return impl_->point(); }

FeaturesPlan::FeaturesPlan(const json& params, const Frame& frame, const Context& ctx, const std::string& path, bool volcano_layer) {
  const stages::FeaturesParams p = stages::features_table().read(params, path, {"stage", "label"});
  stages::validate_features(p, path);
  impl_ = std::make_unique<Impl>(p, frame, ctx, volcano_layer);
}
FeaturesPlan::~FeaturesPlan() = default;
FeaturesPlan::FeaturesPlan(FeaturesPlan&&) noexcept = default;
int FeaturesPlan::attempts() const { return impl_->p.attempts; }
bool FeaturesPlan::on_land() const { return impl_->p.placement == stages::FeaturePlacement::Land; }
std::vector<XZ> FeaturesPlan::land_probes(int a, bool crater) const { return impl_->land_probes(a, crater); }
std::vector<XZ> FeaturesPlan::volcano_probes(int a, bool crater) const { return impl_->volcano_probes(a, crater); }
bool FeaturesPlan::land_ok(const std::vector<double>& heights) const { return impl_->land_ok(heights); }
bool FeaturesPlan::off_volcano(const std::vector<float>& values) { return Impl::off_volcano(values); }
void FeaturesPlan::place(const std::function<bool(int, bool)>& land, const std::function<bool(int, bool)>& off_volcano) {
  impl_->place(land, off_volcano);
}
int FeaturesPlan::count() const { return int(impl_->placed.size()); }
XZ FeaturesPlan::base_probe(int f) const {
  const stages::Feature& F = impl_->placed.at(std::size_t(f));
  return {F.x, F.z};
}
void FeaturesPlan::set_base(int f, double height) { impl_->base.at(std::size_t(f)) = height; }
void FeaturesPlan::apply(Terrain& window, int f) const { impl_->apply(window, f); }
bool FeaturesPlan::touches(const Frame& w, int f) const {
  // A crater changes samples with d < 3 R; a peak's circles lie within 0.2 R of its centre with
  // radii ≤ R, so it lifts samples within 1.2 R only.
  const stages::Feature& F = impl_->placed.at(std::size_t(f));
  return stages::distance_to_window(w, F.x, F.z) <= (F.crater ? 3.0 : 1.2) * F.r + w.cell_m();
}
std::vector<Point> FeaturesPlan::points() const { return impl_->points(); }

}  // namespace detail
}  // namespace relief
