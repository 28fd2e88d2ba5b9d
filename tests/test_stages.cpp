// Tests of the shaping and colour stages: redistribute, terrace, island, curve, slope, color,
// hillshade. Terrains are built by hand; stages are parsed from JSON exactly as a recipe would.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <set>
#include <string>
#include <vector>

#include "relief/error.hpp"
#include "relief/stage.hpp"
#include "relief/terrain.hpp"
#include "stages.hpp"
#include "support.hpp"

using relief::json;
using relief::Terrain;
namespace st = relief::stages;

namespace {

constexpr double kPi = std::numbers::pi;

relief::Frame square(int n, double world_m = 4000.0, double height_m = 600.0, double sea = 0.4) {
  return relief::test::square_frame(n, world_m, height_m, sea);
}

// A Terrain whose height is h(i, j).
Terrain grid(const relief::Frame& f, const std::function<double(int, int)>& h) { return relief::test::grid_terrain(f, h); }

// A Terrain whose height is a smooth function of world position (so windows and resolutions agree).
Terrain world_field(const relief::Frame& f) {
  return grid(f, [&](int i, int j) {
    const double x = f.x_m(i), z = f.z_m(j);
    return 0.5 + 0.45 * std::sin(x / 310.0) * std::cos(z / 470.0 + 0.3);
  });
}

void run(const relief::StageDef& def, json params, Terrain& t, std::uint64_t seed = 7) {
  params["stage"] = def.name;
  auto stage = def.parse(params, "stages[0]");
  relief::Context ctx;
  ctx.seed = seed;
  stage->apply(t, ctx);
}

float H(const Terrain& t, int i, int j) { return t.get("height").data[std::size_t(j) * t.frame.nx + i]; }
float L(const Terrain& t, const char* name, int i, int j, int c = 0) {
  const auto& l = t.get(name);
  return l.data[(std::size_t(j) * t.frame.nx + i) * l.channels + c];
}

// A 1-D ramp: nx samples with height i/(nx−1), two rows.
Terrain ramp(int nx) {
  relief::Frame f;
  f.world_width_m = double(nx - 1);
  f.world_depth_m = 1.0;
  f.spacing_m = 1.0;
  f.nx = nx;
  f.nz = 2;
  return grid(f, [&](int i, int) { return double(i) / (nx - 1); });
}

// Expects the stage to throw relief::Error with exactly this path (and `hint` in the message).
void expect_error(const relief::StageDef& def, json params, const std::string& path, const std::string& hint = "") {
  params["stage"] = def.name;
  try {
    def.parse(params, "stages[0]");
    ADD_FAILURE() << "expected relief::Error at " << path;
  } catch (const relief::Error& e) {
    EXPECT_EQ(e.path(), path) << e.what();
    if (!hint.empty()) {
      EXPECT_NE(std::string(e.what()).find(hint), std::string::npos) << e.what();
    }
  }
}

}  // namespace

// ============================================================================ registry basics

TEST(Stages, ParamsResolveDefaults) {
  auto s = st::redistribute().parse(json{{"stage", "redistribute"}, {"exponent", 2.5}}, "stages[0]");
  EXPECT_EQ(s->params(), (json{{"exponent", 2.5}, {"modifier", 1.0}, {"land_only", false}}));
}

TEST(Stages, ColourParamsAreRecolourOnly) {
  for (auto& def : {st::colorize(), st::hillshade()})
    for (auto& p : def.params)
      EXPECT_EQ(p.effect, relief::Effect::Recolour) << def.name << "." << p.name;
}

// ============================================================================== redistribute

TEST(Redistribute, ReferenceValues) {
  Terrain t = grid(square(2), [](int i, int j) { return std::vector<double>{0.0, 0.25, 0.5, 1.0}[j * 2 + i]; });
  run(st::redistribute(), {{"exponent", 2.0}, {"modifier", 1.5}}, t);
  EXPECT_FLOAT_EQ(H(t, 0, 0), 0.0f);
  EXPECT_FLOAT_EQ(H(t, 1, 0), 0.09375f);  // 1.5 · 0.25²
  EXPECT_FLOAT_EQ(H(t, 0, 1), 0.375f);    // 1.5 · 0.5²
  EXPECT_FLOAT_EQ(H(t, 1, 1), 1.0f);      // 1.5 clamped
}

TEST(Redistribute, ExponentBelowOneLiftsMiddle) {
  Terrain t = grid(square(2), [](int, int) { return 0.25; });
  run(st::redistribute(), {{"exponent", 0.5}}, t);
  EXPECT_FLOAT_EQ(H(t, 1, 1), 0.5f);
}

TEST(Redistribute, LandOnlyKeepsSeaFloorAndCoast) {
  Terrain t = grid(square(2, 4000, 600, 0.5), [](int i, int j) { return std::vector<double>{0.25, 0.5, 0.75, 1.0}[j * 2 + i]; });
  run(st::redistribute(), {{"exponent", 2.0}, {"land_only", true}}, t);
  EXPECT_FLOAT_EQ(H(t, 0, 0), 0.25f);   // sea floor untouched
  EXPECT_FLOAT_EQ(H(t, 1, 0), 0.5f);    // coastline stays at sea level
  EXPECT_FLOAT_EQ(H(t, 0, 1), 0.625f);  // 0.5 + 0.5 · 0.5²
  EXPECT_FLOAT_EQ(H(t, 1, 1), 1.0f);
}

// =================================================================================== terrace

TEST(Terrace, RoundGivesNPlusOneLevelsOnRamp) {
  Terrain t = ramp(1001);
  run(st::terrace(), {{"levels", 4}}, t);
  std::set<float> seen(t.get("height").data.begin(), t.get("height").data.end());
  EXPECT_EQ(seen, (std::set<float>{0.0f, 0.25f, 0.5f, 0.75f, 1.0f}));
}

TEST(Terrace, RoundMatchesSeedFormula) {
  Terrain t = grid(square(2), [](int i, int j) { return std::vector<double>{0.3, 0.375, 0.1, 0.9}[j * 2 + i]; });
  run(st::terrace(), {{"levels", 4}}, t);
  EXPECT_FLOAT_EQ(H(t, 0, 0), 0.25f);  // round(1.2)/4
  EXPECT_FLOAT_EQ(H(t, 1, 0), 0.5f);   // round(1.5)/4: ties round up
  EXPECT_FLOAT_EQ(H(t, 0, 1), 0.0f);   // round(0.4)/4
  EXPECT_FLOAT_EQ(H(t, 1, 1), 1.0f);   // round(3.6)/4
}

TEST(Terrace, SmoothIsMonotoneContinuousWithPlateaus) {
  Terrain t = ramp(10001);
  run(st::terrace(), {{"levels", 5}, {"mode", "smooth"}, {"wall", 0.4}}, t);
  float max_jump = 0;
  for (int i = 1; i < 10001; ++i) {
    ASSERT_GE(H(t, i, 0), H(t, i - 1, 0)) << "at sample " << i;
    max_jump = std::max(max_jump, H(t, i, 0) - H(t, i - 1, 0));
  }
  EXPECT_LT(max_jump, 5e-4f);  // wall slope ≤ 1.5/0.4 per unit e: no vertical step
  EXPECT_NEAR(H(t, 2000, 0), 0.2, 1e-6);   // plateau centre keeps its level
  EXPECT_NEAR(H(t, 2500, 0), 0.2, 1e-6);   // f = 0.25 < 0.3: still on the plateau
  EXPECT_NEAR(H(t, 3000, 0), 0.3, 1e-5);   // wall midpoint (k + ½)/n
  EXPECT_NEAR(H(t, 10000, 0), 1.0, 1e-6);
}

TEST(Terrace, SmoothWithZeroWallEqualsRound) {
  Terrain a = ramp(1001), b = ramp(1001);
  run(st::terrace(), {{"levels", 7}}, a);
  run(st::terrace(), {{"levels", 7}, {"mode", "smooth"}, {"wall", 0.0}}, b);
  EXPECT_EQ(a.get("height").data, b.get("height").data);
}

// Terrace aliasing. A cone terraced is rotationally symmetric, and so is anything a viewer sees
// of it, such as its slope (what a hillshade draws) averaged over a few samples. Sampled on the
// grid, steps near the sample spacing beat against it: the local mean slope then changes with
// the direction around the cone at a fixed radius (the moiré rings on the volcanic-island
// volcano at 513²). moire() is that change: within each one-sample ring of radius, the standard
// deviation of the 5×5 mean of |∇out| divided by its mean, averaged over the rings.
namespace {
Terrain cone(int n, double rise_per_sample) {
  return grid(square(n, 4000.0, 600.0, 0.0), [=](int i, int j) {
    const double c = (n - 1) / 2.0;
    return std::clamp(0.95 - rise_per_sample * std::hypot(i - c, j - c), 0.0, 1.0);
  });
}
double moire(const Terrain& out) {
  const int n = out.frame.nx, r = 2;
  const double c = (n - 1) / 2.0;
  std::vector<double> g(std::size_t(n) * n, 0.0);
  for (int j = 1; j + 1 < n; ++j)
    for (int i = 1; i + 1 < n; ++i)
      g[std::size_t(j) * n + i] = std::hypot(H(out, i + 1, j) - H(out, i - 1, j), H(out, i, j + 1) - H(out, i, j - 1));
  std::map<int, std::vector<double>> rings;
  for (int j = r + 1; j < n - r - 1; ++j)
    for (int i = r + 1; i < n - r - 1; ++i) {
      const double radius = std::hypot(i - c, j - c);
      if (radius < 12 || radius > c - 6) continue;
      double m = 0;
      for (int b = -r; b <= r; ++b)
        for (int a = -r; a <= r; ++a) m += g[std::size_t(j + b) * n + (i + a)];
      rings[int(radius)].push_back(m);
    }
  double sum = 0;
  for (const auto& [k, v] : rings) {
    double mean = 0, var = 0;
    for (double x : v) mean += x;
    mean /= v.size();
    for (double x : v) var += (x - mean) * (x - mean);
    sum += std::sqrt(var / v.size()) / mean;
  }
  return sum / rings.size();
}
}  // namespace

TEST(Terrace, FilteredStepsDoNotAliasIntoMoire) {
  const int levels = 40;
  // Steps 2.2 samples wide on the cone's flanks (rise 1/(40·2.2) per sample).
  const Terrain in = cone(129, 1.0 / (levels * 2.2));
  for (const char* mode : {"smooth", "round"}) {
    Terrain raw = in, filtered = in;
    run(st::terrace(), {{"levels", levels}, {"mode", mode}, {"wall", 0.7}}, raw);
    run(st::terrace(), {{"levels", levels}, {"mode", mode}, {"wall", 0.7}, {"filter_samples", 2.0}}, filtered);
    const double m_raw = moire(raw), m_filtered = moire(filtered), m_cone = moire(in);
    std::printf("%s: moiré %.4f unfiltered, %.4f filtered, %.4f the cone itself\n", mode, m_raw, m_filtered, m_cone);
    EXPECT_GT(m_raw, 50 * m_cone) << mode << ": unfiltered steps at 2.2 samples alias";
    EXPECT_LT(m_filtered, 0.15 * m_raw) << mode;
  }
}

TEST(Terrace, FilteredKeepsWideStepsAndFlatGround) {
  // Steps 40 samples wide: the filter (2 samples) barely touches them; flat ground is exact.
  const Terrain in = cone(129, 1.0 / (8 * 40.0));
  Terrain raw = in, filtered = in;
  run(st::terrace(), {{"levels", 8}, {"mode", "smooth"}, {"wall", 0.5}}, raw);
  run(st::terrace(), {{"levels", 8}, {"mode", "smooth"}, {"wall", 0.5}, {"filter_samples", 2.0}}, filtered);
  double worst = 0;
  for (std::size_t k = 0; k < raw.get("height").data.size(); ++k)
    worst = std::max(worst, double(std::abs(raw.get("height").data[k] - filtered.get("height").data[k])));
  EXPECT_LT(worst * 8, 0.01);  // under 1 % of a step
  Terrain flat = grid(square(5), [](int, int) { return 0.43; }), flat_raw = flat;
  run(st::terrace(), {{"levels", 4}, {"mode", "smooth"}, {"wall", 0.3}}, flat_raw);
  run(st::terrace(), {{"levels", 4}, {"mode", "smooth"}, {"wall", 0.3}, {"filter_samples", 2.0}}, flat);
  EXPECT_NEAR(H(flat, 2, 2), H(flat_raw, 2, 2), 1e-6);
}

TEST(Terrace, FilteredIsANeighbourhoodStageAndOffIsPointwise) {
  json p = {{"stage", "terrace"}, {"levels", 8}};
  EXPECT_EQ(st::terrace().parse(p, "s")->reach(square(3)).locality, relief::Locality::Pointwise);
  EXPECT_TRUE(st::terrace().parse(p, "s")->fusable());
  p["filter_samples"] = 2.0;
  const auto s = st::terrace().parse(p, "s");
  EXPECT_EQ(s->reach(square(3)).locality, relief::Locality::Neighbourhood);
  EXPECT_EQ(s->reach(square(3)).halo, 1);
  EXPECT_FALSE(s->fusable());
  EXPECT_EQ(s->params().at("filter_samples"), 2.0);
}

TEST(Terrace, LandOnlyStepsAboveSea) {
  Terrain t = grid(square(2, 4000, 600, 0.4), [](int i, int j) { return std::vector<double>{0.2, 0.4, 0.75, 1.0}[j * 2 + i]; });
  run(st::terrace(), {{"levels", 2}, {"land_only", true}}, t);
  EXPECT_FLOAT_EQ(H(t, 0, 0), 0.2f);  // sea floor unchanged
  EXPECT_FLOAT_EQ(H(t, 1, 0), 0.4f);
  EXPECT_FLOAT_EQ(H(t, 0, 1), 0.7f);  // u = 0.583 → ½ → 0.4 + 0.6·½
  EXPECT_FLOAT_EQ(H(t, 1, 1), 1.0f);
}

// ==================================================================================== island

namespace {
// Flat height 1 with shaping lerp and mix 1 gives e' = 1 − d, so the output reads the distance.
// A 5×5 frame samples nx, nz ∈ {−1, −½, 0, ½, 1}.
void expect_distance(const std::string& name, double edge, double corner, double half, double diag,
                     json extra = json::object()) {
  Terrain t = grid(square(5), [](int, int) { return 1.0; });
  json p = {{"distance", name}, {"shaping", "lerp"}, {"mix", 1.0}};
  p.update(extra);
  run(st::island(), p, t);
  EXPECT_NEAR(1 - H(t, 2, 2), 0.0, 1e-7) << name << " centre";
  for (auto [i, j] : {std::pair{0, 2}, {4, 2}, {2, 0}, {2, 4}}) EXPECT_NEAR(1 - H(t, i, j), edge, 1e-6) << name << " edge";
  for (auto [i, j] : {std::pair{0, 0}, {4, 0}, {0, 4}, {4, 4}}) EXPECT_NEAR(1 - H(t, i, j), corner, 1e-6) << name << " corner";
  EXPECT_NEAR(1 - H(t, 3, 2), half, 1e-6) << name << " at nx = ½";
  EXPECT_NEAR(1 - H(t, 2, 1), half, 1e-6) << name << " at nz = −½";
  EXPECT_NEAR(1 - H(t, 3, 3), diag, 1e-6) << name << " at nx = nz = ½";
  EXPECT_NEAR(1 - H(t, 1, 1), diag, 1e-6) << name << " at nx = nz = −½";
}
}  // namespace

TEST(Island, SquareBumpDistance) { expect_distance("square_bump", 1.0, 1.0, 0.25, 1 - 0.75 * 0.75); }
TEST(Island, Euclidean2Distance) {
  // min(1, (nx² + nz²)/√2): only the corners reach 1.
  expect_distance("euclidean2", 1.0 / std::sqrt(2.0), 1.0, 0.25 / std::sqrt(2.0), 0.5 / std::sqrt(2.0));
}
TEST(Island, HyperboloidDistance) {
  const double a = 0.2;
  const double norm = std::sqrt(1 + a * a) - a;
  expect_distance("hyperboloid", 1.0, 1.0, (std::sqrt(0.25 + a * a) - a) / norm, (std::sqrt(0.5 + a * a) - a) / norm,
                  {{"hyperboloid_a", a}});
}
TEST(Island, TrigProductDistance) { expect_distance("trig_product", 1.0, 1.0, 1.0 - std::cos(kPi / 4), 0.5); }
TEST(Island, SquircleDistance) { expect_distance("squircle", 1.0, 1.0, 0.25, std::sqrt(0.125)); }
TEST(Island, CircularDistance) { expect_distance("circular", 1.0, 1.0, 0.5, std::sqrt(0.5)); }
TEST(Island, CircularRadiusScalesDistance) { expect_distance("circular", 1.0, 1.0, 1.0, 1.0, {{"radius", 0.5}}); }

TEST(Island, MixZeroLeavesTerrainUnchanged) {
  Terrain t = world_field(square(33));
  const auto before = t.get("height").data;
  run(st::island(), {{"mix", 0.0}}, t);
  EXPECT_EQ(t.get("height").data, before);
}

TEST(Island, MixOneSinksTheBorderBelowSea) {
  for (const char* shaping : {"lerp", "multiply"}) {
    Terrain t = world_field(square(33));
    run(st::island(), {{"mix", 1.0}, {"shaping", shaping}}, t);
    for (int k = 0; k < 33; ++k)
      for (auto [i, j] : {std::pair{k, 0}, {k, 32}, {0, k}, {32, k}}) ASSERT_EQ(H(t, i, j), 0.0f) << shaping;
  }
}

TEST(Island, CircularFalloffRateZeroIsPlain) {
  Terrain t = world_field(square(33));
  const auto before = t.get("height").data;
  run(st::island(), {{"distance", "circular"}, {"shaping", "subtract"}, {"falloff_rate", 0.0}, {"mix", 1.0}}, t);
  EXPECT_EQ(t.get("height").data, before);
}

TEST(Island, CircularPositiveRateLowersBorder) {
  Terrain t = grid(square(5), [](int, int) { return 0.5; });
  run(st::island(), {{"distance", "circular"}, {"shaping", "subtract"}, {"falloff_rate", 0.5}, {"mix", 1.0}}, t);
  EXPECT_FLOAT_EQ(H(t, 2, 2), 0.5f);
  EXPECT_FLOAT_EQ(H(t, 3, 2), 0.25f);  // r = radius/2
  EXPECT_FLOAT_EQ(H(t, 4, 2), 0.0f);
}

TEST(Island, CircularNegativeRateMakesCrater) {
  Terrain t = grid(square(5), [](int, int) { return 0.5; });
  run(st::island(), {{"distance", "circular"}, {"shaping", "subtract"}, {"falloff_rate", -0.4}, {"mix", 1.0}}, t);
  EXPECT_FLOAT_EQ(H(t, 2, 2), 0.5f);
  EXPECT_FLOAT_EQ(H(t, 3, 2), 0.7f);
  EXPECT_FLOAT_EQ(H(t, 4, 2), 0.9f);
  EXPECT_LT(H(t, 2, 2), H(t, 0, 0));  // centre below the rim: a valley
}

TEST(Island, UsesWorldNotWindowCoordinates) {
  // The right half of the world as its own window: its left edge is the world centre line.
  const relief::Frame f = square(5).window(2, 0, 3, 5);  // cells of 1000 m, x from 2000 to 4000
  Terrain t = grid(f, [](int, int) { return 1.0; });
  run(st::island(), {{"mix", 1.0}}, t);
  EXPECT_FLOAT_EQ(H(t, 0, 2), 1.0f);  // world centre
  EXPECT_FLOAT_EQ(H(t, 2, 2), 0.0f);  // world border
}

// ===================================================================================== curve

TEST(Curve, DefaultIsIdentity) {
  Terrain t = ramp(101);
  const auto before = t.get("height").data;
  run(st::curve(), json::object(), t);
  EXPECT_EQ(t.get("height").data, before);
}

TEST(Curve, PassesThroughControlPoints) {
  Terrain t = grid(square(2), [](int i, int j) { return std::vector<double>{0.0, 0.25, 0.5, 1.0}[j * 2 + i]; });
  run(st::curve(), {{"points", {{0.0, 0.1}, {0.25, 0.6}, {0.5, 0.4}, {1.0, 0.9}}}}, t);
  EXPECT_FLOAT_EQ(H(t, 0, 0), 0.1f);
  EXPECT_FLOAT_EQ(H(t, 1, 0), 0.6f);
  EXPECT_FLOAT_EQ(H(t, 0, 1), 0.4f);
  EXPECT_FLOAT_EQ(H(t, 1, 1), 0.9f);
}

TEST(Curve, StepLikeDataIsMonotoneWithoutOvershoot) {
  // A steep middle segment between two shallow ones: a plain cubic spline overshoots here.
  const std::vector<std::pair<double, double>> pts = {{0.0, 0.0}, {0.3, 0.05}, {0.5, 0.95}, {1.0, 1.0}};
  Terrain t = ramp(2001);
  json jp = json::array();
  for (auto [x, y] : pts) jp.push_back({x, y});
  run(st::curve(), {{"points", jp}}, t);
  for (int i = 0; i < 2001; ++i) {
    const double x = double(float(double(i) / 2000)), y = H(t, i, 0);  // the stored input
    if (i > 0) {
      ASSERT_GE(H(t, i, 0), H(t, i - 1, 0)) << "x = " << x;
    }
    for (std::size_t k = 0; k + 1 < pts.size(); ++k)
      if (x >= pts[k].first && x <= pts[k + 1].first) {
        ASSERT_GE(y, float(pts[k].second)) << "x = " << x;
        ASSERT_LE(y, float(pts[k + 1].second)) << "x = " << x;
      }
  }
}

TEST(Curve, FlatSegmentStaysFlat) {
  Terrain t = ramp(1001);
  run(st::curve(), {{"points", {{0.0, 0.0}, {0.4, 0.2}, {0.6, 0.2}, {1.0, 1.0}}}}, t);
  for (int i = 400; i <= 600; ++i) ASSERT_FLOAT_EQ(H(t, i, 0), 0.2f) << i;
}

TEST(Curve, OutsideThePointsClamps) {
  Terrain t = grid(square(2), [](int i, int j) { return std::vector<double>{0.0, 0.1, 0.5, 1.0}[j * 2 + i]; });
  run(st::curve(), {{"points", {{0.2, 0.1}, {0.8, 0.9}}}}, t);
  EXPECT_FLOAT_EQ(H(t, 0, 0), 0.1f);
  EXPECT_FLOAT_EQ(H(t, 1, 0), 0.1f);
  EXPECT_NEAR(H(t, 0, 1), 0.5f, 1e-6);  // two points: a straight line
  EXPECT_FLOAT_EQ(H(t, 1, 1), 0.9f);
}

// ===================================================================================== slope

namespace {
// 9×9 samples, 8 m cells, 64 m between elevation 0 and 1.
relief::Frame small_metric(double height_m = 64.0) {
  relief::Frame f = square(9, 64.0, height_m, 0.0);
  return f;
}
}  // namespace

TEST(Slope, FortyFiveDegreePlane) {
  Terrain t = grid(small_metric(), [](int i, int) { return i / 8.0; });  // y = 8 m per 8 m cell
  run(st::slope(), json::object(), t);
  for (int j = 0; j < 9; ++j)
    for (int i = 0; i < 9; ++i) ASSERT_FLOAT_EQ(L(t, "slope_deg", i, j), 45.0f) << i << "," << j;
}

TEST(Slope, ObliquePlaneThreeFourFive) {
  Terrain t = grid(small_metric(), [](int i, int j) { return (3.0 * i + 4.0 * j) / 64.0; });
  run(st::slope(), json::object(), t);
  const float want = float(std::atan(5.0 / 8.0) * 180.0 / kPi);
  for (auto [i, j] : {std::pair{0, 0}, {4, 4}, {8, 3}, {2, 8}}) EXPECT_FLOAT_EQ(L(t, "slope_deg", i, j), want);
}

TEST(Slope, DegreesScaleWithHeight) {
  Terrain t = grid(small_metric(64.0 * std::sqrt(3.0)), [](int i, int) { return i / 8.0; });
  run(st::slope(), json::object(), t);
  EXPECT_NEAR(L(t, "slope_deg", 4, 4), 60.0, 1e-4);
}

TEST(Slope, FlatIsZero) {
  Terrain t = grid(small_metric(), [](int, int) { return 0.3; });
  run(st::slope(), json::object(), t);
  EXPECT_EQ(L(t, "slope_deg", 4, 4), 0.0f);
  EXPECT_EQ(L(t, "slope", 0, 0), 0.0f);
}

namespace {
// 0    .5  .25
// .25  .5  1
// 0    0   .75
Terrain seed001_grid() {
  const double v[9] = {0, 0.5, 0.25, 0.25, 0.5, 1.0, 0, 0, 0.75};
  return grid(square(3, 2.0), [&](int i, int j) { return v[j * 3 + i]; });
}
}  // namespace

TEST(Slope, Seed001MeanAbsoluteDifference) {
  Terrain t = seed001_grid();
  run(st::slope(), json::object(), t);
  EXPECT_FLOAT_EQ(L(t, "slope", 1, 1), 0.34375f);     // (.5+0+.25+.25+.5+.5+.5+.25)/8
  EXPECT_FLOAT_EQ(L(t, "slope", 0, 0), 1.25f / 3);    // three neighbours: .5, .25, .5
  EXPECT_FLOAT_EQ(L(t, "slope", 1, 0), 0.3f);         // five neighbours: .5+.25+.25+0+.5
}

TEST(Slope, Seed001DivideByEightAtBorder) {
  Terrain t = seed001_grid();
  run(st::slope(), {{"border", "eight"}}, t);
  EXPECT_FLOAT_EQ(L(t, "slope", 1, 1), 0.34375f);
  EXPECT_FLOAT_EQ(L(t, "slope", 0, 0), 0.15625f);
  EXPECT_FLOAT_EQ(L(t, "slope", 1, 0), 0.1875f);
}

TEST(Slope, InteriorFastPathGivesTheBitsOfTheGeneralFormula) {
  // A rough, non-square field: every sample's slope and slope_deg equal, bit for bit, the general
  // per-sample formula (mean absolute difference to the neighbours that exist; central
  // differences of metres, one-sided at the border; atan of the gradient's length).
  relief::Frame f = square(37, 700.0, 250.0, 0.3);
  f.nx = 37, f.nz = 23;
  Terrain t = grid(f, [](int i, int j) { return 0.5 + 0.4 * std::sin(0.9 * i + 0.31 * j * j) * std::cos(0.17 * i * j); });
  for (const char* border : {"mean", "eight"}) {
    Terrain u = t;
    run(st::slope(), {{"border", border}}, u);
    const bool eight = std::string(border) == "eight";
    const auto& h = u.get("height").data;
    auto y = [&](int a, int b) { return f.y_m(h[std::size_t(b) * f.nx + a]); };
    for (int j = 0; j < f.nz; ++j)
      for (int i = 0; i < f.nx; ++i) {
        const double e = h[std::size_t(j) * f.nx + i];
        double sum = 0;
        int count = 0;
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            const int a = i + di, b = j + dj;
            if ((di == 0 && dj == 0) || a < 0 || b < 0 || a >= f.nx || b >= f.nz) continue;
            sum += std::fabs(e - double(h[std::size_t(b) * f.nx + a]));
            ++count;
          }
        const int i0 = std::max(i - 1, 0), i1 = std::min(i + 1, f.nx - 1), j0 = std::max(j - 1, 0), j1 = std::min(j + 1, f.nz - 1);
        const double dx = (y(i1, j) - y(i0, j)) / ((i1 - i0) * f.cell_m()), dz = (y(i, j1) - y(i, j0)) / ((j1 - j0) * f.cell_m());
        ASSERT_EQ(L(u, "slope", i, j), float(eight ? sum / 8.0 : sum / count)) << border << " " << i << "," << j;
        ASSERT_EQ(L(u, "slope_deg", i, j), float(std::atan(std::hypot(dx, dz)) * (180.0 / kPi))) << i << "," << j;
      }
  }
}

// ===================================================================================== color

namespace {
const json kRgbLevels = json::array({{{"at", 0.25}, {"color", "#ff0000"}},
                                     {{"at", 0.5}, {"color", "#00ff00"}},
                                     {{"at", 1.0}, {"color", "#0000ff"}}});
relief::Rgb albedo(const Terrain& t, int i, int j) {
  return {L(t, "albedo", i, j, 0), L(t, "albedo", i, j, 1), L(t, "albedo", i, j, 2)};
}
const relief::Rgb kRed{1, 0, 0}, kGreen{0, 1, 0}, kBlue{0, 0, 1};
}  // namespace

TEST(Color, BandsPickFirstLevelAtOrAbove) {
  const double v[6] = {0.0, 0.25, std::nextafter(0.25f, 1.0f), 0.5, 0.75, 1.0};
  Terrain t = grid(square(6, 5.0), [&](int i, int) { return v[i]; });
  run(st::colorize(), {{"levels", kRgbLevels}, {"variation", 0.0}, {"rock_slope_deg", 90.0}}, t);
  EXPECT_EQ(albedo(t, 0, 0), kRed);
  EXPECT_EQ(albedo(t, 1, 0), kRed);  // exactly at the threshold: that level
  EXPECT_EQ(albedo(t, 2, 0), kGreen);
  EXPECT_EQ(albedo(t, 3, 0), kGreen);
  EXPECT_EQ(albedo(t, 4, 0), kBlue);
  EXPECT_EQ(albedo(t, 5, 0), kBlue);
}

// A band edge across a tilted plane, seen column by column: the amount of the upper colour in a
// column (Σ over rows of its weight) says where the edge crosses that column. Hard bands can only
// put it on whole samples (a staircase: off the true line by up to half a sample); smooth_edges
// box-filters the step over one sample's elevation change, so the edge lands between samples.
namespace {
double band_edge_error(bool smooth, double n_axis_step) {
  const int n = 65;
  // e rises along z, and along x at a small irrational rate: the edge is a gently tilted line.
  const double slope = 0.004;
  Terrain t = grid(square(n, 640.0, 600.0), [&](int i, int j) { return 0.3 + slope * (j + n_axis_step * i); });
  json lv = json::array({{{"at", 0.42}, {"color", "#ff0000"}}, {{"at", 1.0}, {"color", "#0000ff"}}});
  run(st::colorize(), {{"levels", lv}, {"variation", 0.0}, {"rock_slope_deg", 90.0}, {"smooth_edges", smooth}}, t);
  double worst = 0;
  for (int i = 0; i < n; ++i) {
    double blue = 0;
    for (int j = 0; j < n; ++j) blue += albedo(t, i, j).b;
    // Exact: the length of the column above the edge at j* = (0.42 − 0.3)/slope − step·i, each
    // sample standing for the cell [j − ½, j + ½].
    const double edge = (0.42 - 0.3) / slope - n_axis_step * i;
    worst = std::max(worst, std::abs(blue - ((n - 0.5) - edge)));
  }
  return worst;
}
}  // namespace

TEST(Color, SmoothEdgesPutBandEdgesBetweenSamples) {
  for (double step : {0.0913, 0.2371, 0.4142}) {
    EXPECT_GT(band_edge_error(false, step), 0.3) << step << ": hard bands are staircases";
    EXPECT_LT(band_edge_error(true, step), 0.1) << step;
  }
}

TEST(Color, SmoothEdgesOnFlatGroundAreTheHardBands) {
  const double v[6] = {0.0, 0.25, std::nextafter(0.25f, 1.0f), 0.5, 0.75, 1.0};
  for (int x = 0; x < 6; ++x) {
    Terrain t = grid(square(3, 5.0), [&](int, int) { return v[x]; });
    Terrain u = t;
    run(st::colorize(), {{"levels", kRgbLevels}, {"variation", 0.0}, {"rock_slope_deg", 90.0}}, t);
    run(st::colorize(), {{"levels", kRgbLevels}, {"variation", 0.0}, {"rock_slope_deg", 90.0}, {"smooth_edges", true}}, u);
    EXPECT_EQ(albedo(t, 1, 1), albedo(u, 1, 1)) << v[x];
  }
}

TEST(Color, BandsThresholdComparesInLayerPrecision) {
  Terrain t = grid(square(2), [](int, int) { return 0.3; });  // stored as 0.3f > 0.3
  json lv = json::array({{{"at", 0.3}, {"color", "#ff0000"}}, {{"at", 1.0}, {"color", "#0000ff"}}});
  run(st::colorize(), {{"levels", lv}, {"variation", 0.0}, {"rock_slope_deg", 90.0}}, t);
  EXPECT_EQ(albedo(t, 0, 0), kRed);
}

TEST(Color, LastLevelCoversTheRest) {
  Terrain t = grid(square(2), [](int, int) { return 0.9; });
  json lv = json::array({{{"at", 0.2}, {"color", "#ff0000"}}, {{"at", 0.5}, {"color", "#00ff00"}}});
  run(st::colorize(), {{"levels", lv}, {"variation", 0.0}, {"rock_slope_deg", 90.0}}, t);
  EXPECT_EQ(albedo(t, 1, 1), kGreen);
}

TEST(Color, GradientInterpolatesBetweenLevels) {
  const double v[5] = {0.0, 0.25, 0.5, 0.75, 1.0};
  Terrain t = grid(square(5), [&](int i, int) { return v[i]; });
  json lv = json::array({{{"at", 0.25}, {"color", "#000000"}}, {{"at", 0.75}, {"color", "#ffffff"}}});
  run(st::colorize(), {{"levels", lv}, {"mode", "gradient"}, {"variation", 0.0}, {"rock_slope_deg", 90.0}}, t);
  EXPECT_EQ(albedo(t, 0, 0), (relief::Rgb{0, 0, 0}));
  EXPECT_EQ(albedo(t, 1, 0), (relief::Rgb{0, 0, 0}));
  EXPECT_FLOAT_EQ(albedo(t, 2, 0).g, 0.5f);
  EXPECT_EQ(albedo(t, 3, 0), (relief::Rgb{1, 1, 1}));
  EXPECT_EQ(albedo(t, 4, 0), (relief::Rgb{1, 1, 1}));
}

// Issue 15 §5: the default levels are written for sea level 0.4 and follow the world's sea level
// (sea_relative), so `--set world.sea_level=0.3` moves the beach with the coast.
TEST(Color, MovingTheSeaLevelMovesTheBeach) {
  auto hex = [](std::uint32_t v) {
    return relief::Rgb{float((v >> 16) & 255) / 255.0f, float((v >> 8) & 255) / 255.0f, float(v & 255) / 255.0f};
  };
  const relief::Rgb sand = hex(0xd8c88e), shallow = hex(0x3a7cb8);
  auto colour_at = [](double sea, double e, bool sea_relative) {
    Terrain t = grid(square(5, 4000.0, 600.0, sea), [&](int, int) { return e; });
    run(st::colorize(), {{"variation", 0.0}, {"rock_slope_deg", 90.0}, {"sea_relative", sea_relative}}, t);
    return albedo(t, 2, 2);
  };
  // Just above the coast: sand, wherever the coast is.
  EXPECT_EQ(colour_at(0.4, 0.41, true), sand);
  EXPECT_EQ(colour_at(0.3, 0.31, true), sand);
  EXPECT_EQ(colour_at(0.6, 0.61, true), sand);
  // Just below it: shallow water.
  EXPECT_EQ(colour_at(0.3, 0.29, true), shallow);
  EXPECT_EQ(colour_at(0.6, 0.59, true), shallow);
  // Pinned levels stay where they are written: 0.31 is in the 0.30..0.40 water band.
  EXPECT_EQ(colour_at(0.3, 0.31, false), shallow);
  EXPECT_EQ(colour_at(0.4, 0.41, false), sand);
}

namespace {
json rock_params(double slope_deg = 35.0) {
  return {{"levels", json::array({{{"at", 1.0}, {"color", "#00ff00"}}})},
          {"rock_color", "#808080"},
          {"rock_slope_deg", slope_deg},
          {"rock_blend_deg", 0.0},
          {"rock_min", 0.0},
          {"rock_max", 1.0},
          {"variation", 0.0},
          {"sea_relative", false}};  // rock_min/rock_max as written (these frames have sea level 0)
}
const relief::Rgb kRock{128 / 255.0f, 128 / 255.0f, 128 / 255.0f};
// A 60° plane: dy/dx = √3 with 8 m cells and 640 m per unit elevation.
Terrain steep_plane() {
  return grid(small_metric(640.0), [](int i, int) { return 0.4 + i * 8.0 * std::sqrt(3.0) / 640.0; });
}
}  // namespace

TEST(Color, RockOnSteepPlane) {
  Terrain t = steep_plane();
  run(st::colorize(), rock_params(), t);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(albedo(t, i, 4), kRock) << i;
}

TEST(Color, NoRockOnFlatGround) {
  Terrain t = grid(small_metric(640.0), [](int, int) { return 0.5; });
  run(st::colorize(), rock_params(), t);
  EXPECT_EQ(albedo(t, 4, 4), kGreen);
}

TEST(Color, RockSlopeNinetyDisablesRule) {
  Terrain t = steep_plane();
  run(st::colorize(), rock_params(90.0), t);
  EXPECT_EQ(albedo(t, 4, 4), kGreen);
}

TEST(Color, RockOnlyBetweenRockMinAndMax) {
  Terrain t = steep_plane();  // e from 0.4 to 0.573
  json p = rock_params();
  p["rock_max"] = 0.5;
  run(st::colorize(), p, t);
  EXPECT_EQ(albedo(t, 1, 4), kRock);   // e = 0.4217
  EXPECT_EQ(albedo(t, 8, 4), kGreen);  // e = 0.573 ≥ rock_max
}

TEST(Color, RockUsesExistingSlopeLayer) {
  Terrain t = grid(small_metric(640.0), [](int, int) { return 0.5; });
  auto& s = t.layer("slope_deg", 1);
  std::fill(s.data.begin(), s.data.end(), 80.0f);
  run(st::colorize(), rock_params(), t);
  EXPECT_EQ(albedo(t, 4, 4), kRock);
}

TEST(Color, RelativeToMaxChangesResult) {
  // Heights 0..0.5: relative to the map's highest point the top reaches 1.
  Terrain a = grid(square(5), [](int i, int) { return i / 8.0; });
  Terrain b = a;
  json lv = json::array({{{"at", 0.5}, {"color", "#ff0000"}}, {{"at", 1.0}, {"color", "#0000ff"}}});
  json p = {{"levels", lv}, {"variation", 0.0}, {"rock_slope_deg", 90.0}};
  run(st::colorize(), p, a);
  p["relative_to_max"] = true;
  run(st::colorize(), p, b);
  EXPECT_EQ(albedo(a, 4, 0), kRed);
  EXPECT_EQ(albedo(b, 4, 0), kBlue);
  EXPECT_EQ(albedo(b, 2, 0), kRed);  // 0.25/0.5 = 0.5: still the first level
}

TEST(Color, VariationIsBoundedAndVaries) {
  Terrain t = grid(square(65, 640.0), [](int, int) { return 0.5; });
  json lv = json::array({{{"at", 1.0}, {"color", "#808080"}}});
  run(st::colorize(), {{"levels", lv}, {"variation", 0.2}, {"variation_scale_m", 20.0}, {"rock_slope_deg", 90.0}}, t);
  const float base = 128 / 255.0f;
  float lo = 1, hi = 0;
  for (float v : t.get("albedo").data) lo = std::min(lo, v), hi = std::max(hi, v);
  EXPECT_GE(lo, base * 0.8f - 1e-6f);
  EXPECT_LE(hi, base * 1.2f + 1e-6f);
  EXPECT_GT(hi - lo, 0.05f);  // it does vary
}

TEST(Color, VariationIsSmoothInSpace) {
  // 1 m cells, 20 m speckle: value noise, not per-sample hash, so neighbours differ only a little.
  Terrain t = grid(square(101, 100.0), [](int, int) { return 0.5; });
  json lv = json::array({{{"at", 1.0}, {"color", "#808080"}}});
  run(st::colorize(), {{"levels", lv}, {"variation", 0.2}, {"variation_scale_m", 20.0}, {"rock_slope_deg", 90.0}}, t);
  float jump = 0;
  for (int j = 0; j < 101; ++j)
    for (int i = 1; i < 101; ++i) jump = std::max(jump, std::fabs(L(t, "albedo", i, j) - L(t, "albedo", i - 1, j)));
  EXPECT_LT(jump, 0.02f);  // ≤ 0.5 · 2 · 0.2 · 1.5/20 = 0.015
}

TEST(Color, VariationDependsOnSeed) {
  Terrain a = world_field(square(33)), b = a;
  run(st::colorize(), {{"variation", 0.1}}, a, 1);
  run(st::colorize(), {{"variation", 0.1}}, b, 2);
  EXPECT_NE(a.get("albedo").data, b.get("albedo").data);
}

TEST(Color, DefaultPaletteSeparatesSeaAndLand) {
  Terrain t = grid(square(2), [](int i, int) { return i == 0 ? 0.35 : 0.5; });
  run(st::colorize(), {{"variation", 0.0}}, t);
  const relief::Rgb sea = albedo(t, 0, 0), land = albedo(t, 1, 0);
  EXPECT_GT(sea.b, sea.r);    // water is blue
  EXPECT_GT(land.g, land.b);  // grass is green
}

// ================================================================================= hillshade

TEST(Hillshade, FlatShadeIsAmbientPlusCosZenith) {
  Terrain t = grid(small_metric(), [](int, int) { return 0.5; });
  run(st::hillshade(), {{"ambient", 0.2}, {"altitude_deg", 45.0}}, t);
  const double want = 0.2 + 0.8 * std::cos(45.0 * kPi / 180.0);
  EXPECT_NEAR(L(t, "shade", 4, 4), want, 1e-6);
  EXPECT_NEAR(L(t, "shade", 0, 8), want, 1e-6);
  EXPECT_NEAR(L(t, "color", 4, 4, 1), want, 1e-6);  // no albedo: white
}

TEST(Hillshade, OverheadLightOnFlatIsFull) {
  Terrain t = grid(small_metric(), [](int, int) { return 0.5; });
  run(st::hillshade(), {{"ambient", 0.3}, {"altitude_deg", 90.0}}, t);
  EXPECT_FLOAT_EQ(L(t, "shade", 4, 4), 1.0f);
}

TEST(Hillshade, SlopeFacingTheLightIsFullyLit) {
  // Light from the east at 45°; a 45° slope descending eastwards faces it exactly.
  Terrain t = grid(small_metric(), [](int i, int) { return 1.0 - i / 8.0; });
  run(st::hillshade(), {{"azimuth_deg", 90.0}, {"altitude_deg", 45.0}, {"ambient", 0.2}}, t);
  EXPECT_NEAR(L(t, "shade", 4, 4), 1.0, 1e-6);
}

TEST(Hillshade, AzimuthZeroIsNorth) {
  // Row 0 is the north (z-min) edge; a slope descending northwards faces light from azimuth 0.
  Terrain t = grid(small_metric(), [](int, int j) { return j / 8.0; });
  run(st::hillshade(), {{"azimuth_deg", 0.0}, {"altitude_deg", 45.0}}, t);
  EXPECT_NEAR(L(t, "shade", 4, 4), 1.0, 1e-6);
}

TEST(Hillshade, SlopeFacingLightIsBrighterThanFacingAway) {
  Terrain toward = grid(small_metric(), [](int i, int) { return 0.8 - i * 0.02; });
  Terrain away = grid(small_metric(), [](int i, int) { return 0.5 + i * 0.02; });
  json p = {{"azimuth_deg", 90.0}};
  run(st::hillshade(), p, toward);
  run(st::hillshade(), p, away);
  EXPECT_GT(L(toward, "shade", 4, 4), L(away, "shade", 4, 4));
}

TEST(Hillshade, SteepSlopeAwayFromLightGetsAmbient) {
  Terrain t = grid(small_metric(), [](int i, int) { return i * 0.5; });  // 76° rising eastwards
  run(st::hillshade(), {{"azimuth_deg", 90.0}, {"altitude_deg", 10.0}, {"ambient", 0.25}}, t);
  EXPECT_FLOAT_EQ(L(t, "shade", 4, 4), 0.25f);
}

TEST(Hillshade, ZFactorExaggeratesRelief) {
  Terrain a = grid(small_metric(), [](int i, int) { return 0.5 + i * 0.01; }), b = a;
  run(st::hillshade(), {{"azimuth_deg", 270.0}}, a);
  run(st::hillshade(), {{"azimuth_deg", 270.0}, {"z_factor", 3.0}}, b);
  EXPECT_GT(L(b, "shade", 4, 4), L(a, "shade", 4, 4));  // the slope faces west, towards the light
}

TEST(Hillshade, ColorIsAlbedoTimesShade) {
  Terrain t = grid(small_metric(), [](int i, int) { return 0.5 + i * 0.03; });
  auto& a = t.layer("albedo", 3);
  for (std::size_t k = 0; k < t.frame.count(); ++k) a.data[3 * k] = 0.5f, a.data[3 * k + 1] = 0.25f, a.data[3 * k + 2] = 1.0f;
  run(st::hillshade(), json::object(), t);
  const float s = L(t, "shade", 3, 3);
  EXPECT_FLOAT_EQ(L(t, "color", 3, 3, 0), 0.5f * s);
  EXPECT_FLOAT_EQ(L(t, "color", 3, 3, 1), 0.25f * s);
  EXPECT_FLOAT_EQ(L(t, "color", 3, 3, 2), s);
}

TEST(Hillshade, WaterIsShadedGently) {
  relief::Frame f = small_metric();
  f.sea_level = 0.9;  // everything is under water
  Terrain flat_water = grid(f, [](int i, int) { return 0.8 - i * 0.05; });
  Terrain some = flat_water, land_like = flat_water;
  run(st::hillshade(), {{"azimuth_deg", 90.0}, {"water_relief", 0.0}, {"ambient", 0.2}}, flat_water);
  run(st::hillshade(), {{"azimuth_deg", 90.0}, {"water_relief", 0.5}, {"ambient", 0.2}}, some);
  run(st::hillshade(), {{"azimuth_deg", 90.0}, {"water_relief", 1.0}, {"ambient", 0.2}}, land_like);
  const double flat = 0.2 + 0.8 * std::sin(kPi / 4);
  EXPECT_NEAR(L(flat_water, "shade", 4, 4), flat, 1e-6);
  EXPECT_NEAR(L(some, "shade", 4, 4), 0.5 * (flat + L(land_like, "shade", 4, 4)), 1e-6);
}

// ================================================== resolution and window independence

namespace {
// Runs the stage on the 257² and 513² samplings of the same 4 km world and checks every other
// sample of the build against the preview, bit for bit.
void expect_preview_equals_build(const relief::StageDef& def, const json& p, const char* layer = "height") {
  Terrain preview = world_field(square(257)), build = world_field(square(513));
  run(def, p, preview);
  run(def, p, build);
  const auto& a = preview.get(layer);
  const auto& b = build.get(layer);
  for (int j = 0; j < 257; ++j)
    for (int i = 0; i < 257; ++i)
      for (int c = 0; c < a.channels; ++c)
        ASSERT_EQ(a.data[(std::size_t(j) * 257 + i) * a.channels + c],
                  b.data[(std::size_t(2 * j) * 513 + 2 * i) * b.channels + c])
            << def.name << " at " << i << "," << j;
}
}  // namespace

TEST(Resolution, IslandPreviewEqualsBuild) {
  for (const char* d : {"square_bump", "euclidean2", "hyperboloid", "trig_product", "squircle", "circular"})
    expect_preview_equals_build(st::island(), {{"distance", d}, {"mix", 0.7}});
}
TEST(Resolution, RedistributePreviewEqualsBuild) {
  expect_preview_equals_build(st::redistribute(), {{"exponent", 1.7}, {"modifier", 1.2}, {"land_only", true}});
}
TEST(Resolution, TerracePreviewEqualsBuild) {
  expect_preview_equals_build(st::terrace(), {{"levels", 6}, {"mode", "smooth"}});
}
TEST(Resolution, CurvePreviewEqualsBuild) {
  expect_preview_equals_build(st::curve(), {{"points", {{0.0, 0.0}, {0.4, 0.1}, {0.6, 0.8}, {1.0, 1.0}}}});
}
TEST(Resolution, ColorWithoutRockPreviewEqualsBuild) {
  expect_preview_equals_build(st::colorize(), {{"variation", 0.1}, {"rock_slope_deg", 90.0}}, "albedo");
}

TEST(Resolution, NeighbouringWindowsAgreeWithWholeWorld) {
  // Right half of the world as a window of its own, at the same cell size as the full map.
  const relief::Frame win = square(513).window(256, 0, 257, 513);
  Terrain whole = world_field(square(513)), right = world_field(win);
  const json p = {{"distance", "trig_product"}, {"mix", 0.6}};
  run(st::island(), p, whole);
  run(st::island(), p, right);
  run(st::colorize(), {{"variation", 0.1}, {"rock_slope_deg", 90.0}}, whole);
  run(st::colorize(), {{"variation", 0.1}, {"rock_slope_deg", 90.0}}, right);
  for (int j = 0; j < 513; ++j)
    for (int i = 0; i < 257; ++i) {
      ASSERT_EQ(H(right, i, j), H(whole, 256 + i, j)) << i << "," << j;
      ASSERT_EQ(L(right, "albedo", i, j, 1), L(whole, "albedo", 256 + i, j, 1)) << i << "," << j;
    }
}

// ========================================================================= thread determinism

TEST(Determinism, ThreadCountDoesNotChangeResults) {
  auto build = [](int threads) {
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, threads);
    Terrain t = world_field(square(129));
    run(st::island(), json::object(), t);
    run(st::terrace(), {{"mode", "smooth"}}, t);
    run(st::slope(), json::object(), t);
    run(st::colorize(), json::object(), t);
    run(st::hillshade(), json::object(), t);
    return t;
  };
  Terrain a = build(1), b = build(4);
  for (const char* l : {"height", "slope", "slope_deg", "albedo", "shade", "color"})
    EXPECT_EQ(a.get(l).data, b.get(l).data) << l;
}

// ================================================================================ bad params

TEST(Errors, TerraceLevelsZero) { expect_error(st::terrace(), {{"levels", 0}}, "stages[0].levels"); }
TEST(Errors, TerraceUnknownMode) { expect_error(st::terrace(), {{"mode", "smoth"}}, "stages[0].mode", "did you mean 'smooth'"); }
TEST(Errors, RedistributeExponentOutOfRange) {
  expect_error(st::redistribute(), {{"exponent", 0.0}}, "stages[0].exponent", "0.1..8");
}
TEST(Errors, UnknownKeySuggestsNearestName) {
  expect_error(st::redistribute(), {{"exponnent", 2.0}}, "stages[0].exponnent", "did you mean 'exponent'");
}
TEST(Errors, IslandMixAboveOne) { expect_error(st::island(), {{"mix", 1.5}}, "stages[0].mix"); }
TEST(Errors, IslandUnknownDistance) {
  expect_error(st::island(), {{"distance", "squarebump"}}, "stages[0].distance", "did you mean 'square_bump'");
}
TEST(Errors, CurveXNotIncreasing) {
  expect_error(st::curve(), {{"points", {{0.0, 0.0}, {0.5, 0.5}, {0.5, 1.0}}}}, "stages[0].points[2][0]");
}
TEST(Errors, CurveNeedsTwoPoints) { expect_error(st::curve(), {{"points", json::array({json::array({0.0, 0.0})})}}, "stages[0].points"); }
TEST(Errors, ColorRockMinAboveMax) {
  expect_error(st::colorize(), {{"rock_min", 0.8}, {"rock_max", 0.5}}, "stages[0].rock_max");
}
TEST(Errors, ColorLevelsOutOfOrder) {
  json lv = json::array({{{"at", 0.5}, {"color", "#ff0000"}}, {{"at", 0.2}, {"color", "#00ff00"}}});
  expect_error(st::colorize(), {{"levels", lv}}, "stages[0].levels[1].at");
}
TEST(Errors, HillshadeAltitudeOutOfRange) {
  expect_error(st::hillshade(), {{"altitude_deg", 120.0}}, "stages[0].altitude_deg");
}
TEST(Errors, MissingHeightLayerNamesIt) {
  Terrain t;
  t.frame = square(3);
  try {
    run(st::slope(), json::object(), t);
    ADD_FAILURE() << "expected relief::Error";
  } catch (const relief::Error& e) {
    EXPECT_NE(std::string(e.what()).find("'height'"), std::string::npos) << e.what();
  }
}
