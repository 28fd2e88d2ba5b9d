// Shaping stages: redistribute, terrace, island, curve.
//
// All four are pointwise: the new elevation of a sample is a pure function of its old elevation,
// its world position (frame.x_m(i), frame.z_m(j)), the world extent (world_width_m/world_depth_m),
// sea_level and the stage's params — never of the window, the sample count or the map's min/max.
// A 257² preview therefore equals every other sample of the 513² build, and neighbouring tiles
// agree on their shared border. Every stage reads and writes the "height" layer and clamps its
// output to [0, 1] (input heights are clamped to [0, 1] before use too).
//
// Sources:
//   * Amit Patel, "Making maps with noise functions", Red Blob Games (2015–2022): redistribution
//     e^exponent, terraces round(e·n)/n, island distance functions (square bump, Euclidean²,
//     hyperboloid, trig product, squircle) and the linear shaping e' = lerp(e, 1 − d, mix).
//   * A. Saparov, "A Maya Terrain Generator Based on Perlin Noise" (2021, seed 000): the height
//     modifier and exponent, "round levels", the island modifier.
//   * O. Feldmann, "Island Generator" (2022, seed 003): smooth terraces with sloped walls, the
//     circular gradient with a falloff rate (0 → plain, negative → crater), animation-curve remap.
//   * F. N. Fritsch, R. E. Carlson, "Monotone Piecewise Cubic Interpolation",
//     SIAM J. Numer. Anal. 17(2), 1980: the monotone tangents used by `curve`.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "curve.hpp"
#include "parallel.hpp"
#include "relief/error.hpp"
#include "stages.hpp"

namespace relief::stages {
namespace {

double clamp01(double v) { return std::clamp(v, 0.0, 1.0); }

// Applies e' = f(e, x_m, z_m) to every sample of the "height" layer, row-parallel.
template <class F>
void map_height(Terrain& t, F&& f) {
  const Frame& fr = t.frame;
  Layer& h = t.get("height");
  detail::parallel_rows(fr.nz, [&](int j) {
    float* row = h.row(j, fr.nx);
    const double z = fr.z_m(j);
    for (int i = 0; i < fr.nx; ++i) row[i * h.channels] = float(clamp01(f(clamp01(double(row[i * h.channels])), fr.x_m(i), z)));
  });
}

// Land-only helper: maps e > sea to u = (e − sea)/(1 − sea) in (0, 1], applies g(u) ∈ [0, 1], maps
// back; the sea floor (e ≤ sea) is returned unchanged. With sea ≥ 1 there is no land: identity.
template <class G>
double above_sea(double e, double sea, G&& g) {
  if (e <= sea || sea >= 1.0) return e;
  const double u = (e - sea) / (1.0 - sea);
  return sea + (1.0 - sea) * clamp01(g(u));
}

// ================================================================================ redistribute

struct RedistributeParams {
  double exponent = 1.0;
  double modifier = 1.0;
  bool land_only = false;
};

void apply_redistribute(Terrain& t, const RedistributeParams& p, const Context&) {
  const double sea = t.frame.sea_level;
  auto g = [&](double e) { return clamp01(p.modifier * std::pow(e, p.exponent)); };
  map_height(t, [&](double e, double, double) { return p.land_only ? above_sea(e, sea, g) : g(e); });
}

// ===================================================================================== terrace

struct TerraceParams {
  int levels = 8;
  std::string mode = "round";
  double wall = 0.3;
  bool land_only = false;
};

// round:  round(e·n)/n (seed 000) — n+1 distinct levels 0, 1/n, …, 1 (ties round up).
// smooth: with t = e·n, k = floor(t), f = t − k, w = wall:
//           e' = (k + smoothstep(clamp((f − (1 − w)/2) / w, 0, 1))) / n.
//         Plateaus keep the round levels k/n; the wall between level k/n and (k+1)/n rises over
//         the central fraction w of the step, centred on (k + ½)/n, with zero slope where it meets
//         the plateaus. Continuous and non-decreasing in e; w = 0 is exactly `round`.
double terrace_value(double e, const TerraceParams& p) {
  const double n = p.levels;
  const double tt = e * n;
  if (p.mode == "round" || p.wall <= 0.0) return std::round(tt) / n;
  const double k = std::floor(tt);
  const double f = tt - k;
  const double s = std::clamp((f - 0.5 * (1.0 - p.wall)) / p.wall, 0.0, 1.0);
  return (k + s * s * (3.0 - 2.0 * s)) / n;
}

void apply_terrace(Terrain& t, const TerraceParams& p, const Context&) {
  const double sea = t.frame.sea_level;
  auto g = [&](double e) { return terrace_value(e, p); };
  map_height(t, [&](double e, double, double) { return p.land_only ? above_sea(e, sea, g) : g(e); });
}

// ====================================================================================== island

struct IslandParams {
  std::string distance = "square_bump";
  std::string shaping = "lerp";
  double mix = 0.5;
  double falloff_rate = 1.0;
  double radius = 1.0;
  double hyperboloid_a = 0.2;
};

// Distance d ∈ [0, 1]: 0 at the world centre, 1 at the border (and clamped to 1 beyond it).
// nx = 2x/W − 1, nz = 2z/D − 1 are world coordinates normalised to [−1, 1] over the whole world
// (not the window), so the rectangle-fitted functions follow the world's aspect ratio.
double island_distance(const IslandParams& p, double x_m, double z_m, double W, double D) {
  const double nx = 2.0 * x_m / W - 1.0, nz = 2.0 * z_m / D - 1.0;
  const double x2 = nx * nx, z2 = nz * nz;
  double d = 0;
  if (p.distance == "square_bump") {
    d = 1.0 - (1.0 - x2) * (1.0 - z2);
  } else if (p.distance == "euclidean2") {
    d = (x2 + z2) / std::numbers::sqrt2;  // 1/√2 at edge midpoints, 1 at the corners
  } else if (p.distance == "hyperboloid") {
    const double a = p.hyperboloid_a;
    d = (std::sqrt(x2 + z2 + a * a) - a) / (std::sqrt(1.0 + a * a) - a);  // 1 at edge midpoints
  } else if (p.distance == "trig_product") {
    d = 1.0 - std::cos(nx * std::numbers::pi / 2) * std::cos(nz * std::numbers::pi / 2);
  } else if (p.distance == "squircle") {
    d = std::sqrt(x2 * x2 + z2 * z2);
  } else {  // circular: true circle in metres, radius a fraction of half the shorter world side
    const double r = std::hypot(x_m - 0.5 * W, z_m - 0.5 * D);
    d = r / (p.radius * 0.5 * std::min(W, D));
  }
  return clamp01(d);
}

// e' = clamp(lerp(e, target, mix)) with
//   lerp     target = 1 − d        (Red Blob Games: the noise fades into a cone/dome shape)
//   multiply target = e · (1 − d)  (keeps the noise's detail, scaled down towards the border)
//   subtract target = e − rate · d (seed 003's falloff: rate 0 → no change; negative → crater)
// Sea-floor guarantee: with mix = 1, `lerp` and `multiply` give exactly 0 wherever d = 1, below any
// sea_level > 0; `subtract` gives e − rate there, below sea level for every e ≤ 1 when
// rate > 1 − sea_level.
void apply_island(Terrain& t, const IslandParams& p, const Context&) {
  const double W = t.frame.world_width_m, D = t.frame.world_depth_m;
  const int shaping = p.shaping == "lerp" ? 0 : p.shaping == "multiply" ? 1 : 2;
  map_height(t, [&](double e, double x, double z) {
    const double d = island_distance(p, x, z, W, D);
    const double target = shaping == 0 ? 1.0 - d : shaping == 1 ? e * (1.0 - d) : e - p.falloff_rate * d;
    return e + (target - e) * p.mix;
  });
}

// ======================================================================================= curve

struct CurveParams {
  std::vector<CurvePoint> points{{0.0, 0.0}, {1.0, 1.0}};
};

void apply_curve(Terrain& t, const CurveParams& p, const Context&) {
  const detail::Curve c(p.points);
  map_height(t, [&](double e, double, double) { return c(e); });
}

}  // namespace

StageDef redistribute() {
  using P = RedistributeParams;
  Table<P> table{{
      param(&P::exponent, "exponent", 0.1, 8.0, "",
            "Power applied to elevation: > 1 pushes middle elevations down into valleys, < 1 lifts them"),
      param(&P::modifier, "modifier", 0.0, 4.0, "", "Height modifier multiplied after the power (result clamped to 0..1)"),
      param(&P::land_only, "land_only", 0, 1, "",
            "Apply only above sea level, to (e − sea)/(1 − sea); the sea floor and coastline stay put"),
  }};
  return make_stage<P>("redistribute", "Redistribute elevation: e' = clamp(modifier · e^exponent)", Locality::Pointwise, 0,
                       std::move(table), apply_redistribute);
}

StageDef terrace() {
  using P = TerraceParams;
  Table<P> table{{
      param(&P::levels, "levels", 1, 256, "", "Number of terrace steps n: round gives the n + 1 levels 0, 1/n, …, 1"),
      choice(&P::mode, "mode", {"round", "smooth"},
             "round: round(e·n)/n with vertical walls; smooth: the same plateaus joined by sloped walls"),
      param(&P::wall, "wall", 0.0, 1.0, "",
            "Smooth mode: fraction of each step taken by the sloped wall (0 = vertical, 1 = no flat plateau)"),
      param(&P::land_only, "land_only", 0, 1, "",
            "Terrace only above sea level, in steps of (1 − sea)/n; the sea floor is unchanged"),
  }};
  return make_stage<P>("terrace", "Terraces: round(e·n)/n, or smooth terraces with sloped walls", Locality::Pointwise, 0,
                       std::move(table), apply_terrace);
}

StageDef island() {
  using P = IslandParams;
  Table<P> table{{
      choice(&P::distance, "distance", {"square_bump", "euclidean2", "hyperboloid", "trig_product", "squircle", "circular"},
             "Distance d from the world centre (0) to the border (1); circular uses `radius`"),
      choice(&P::shaping, "shaping", {"lerp", "multiply", "subtract"},
             "Target elevation: lerp 1 − d; multiply e·(1 − d); subtract e − falloff_rate·d (seed 003)"),
      param(&P::mix, "mix", 0.0, 1.0, "", "Island modifier: e' = lerp(e, target, mix); 0 leaves the terrain unchanged"),
      param(&P::falloff_rate, "falloff_rate", -4.0, 4.0, "",
            "Subtract shaping: elevation removed at d = 1; 0 gives a plain, negative raises the border (crater)"),
      param(&P::radius, "radius", 0.05, 4.0, "",
            "Circular distance: radius where d reaches 1, relative to half the shorter world side"),
      param(&P::hyperboloid_a, "hyperboloid_a", 0.01, 4.0, "",
            "Hyperboloid distance: rounding of the centre, d = (√(nx²+nz²+a²) − a)/(√(1+a²) − a)"),
  }};
  return make_stage<P>("island", "Island shaping: a distance from the world centre pulls the border down",
                       Locality::Pointwise, 0, std::move(table), apply_island);
}

StageDef curve() {
  using P = CurveParams;
  Table<P> table{{
      relief::curve(&P::points, "points", 0.0, 1.0,
                    "Control points [[e, e'], …] with increasing e; monotone cubic (Fritsch–Carlson), no overshoot; "
                    "elevations outside the first/last x take the first/last y"),
  }};
  return make_stage<P>("curve", "Remap elevation through a monotone curve (an animation-curve remap)",
                       Locality::Pointwise, 0, std::move(table), apply_curve);
}

}  // namespace relief::stages
