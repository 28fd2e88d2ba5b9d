// The vectorised row kernels (src/pointwise.cpp): every compiled Highway target against the scalar
// target, independence of a sample's position in the row, single-precision results against the
// double-precision formulas, and the colour stage's rock blend (the atan path).
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <functional>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include "surface.hpp"
#include "pointwise.hpp"
#include "relief/stage.hpp"
#include "relief/terrain.hpp"
#include "stages.hpp"

using relief::json;
using relief::Terrain;
namespace st = relief::stages;

namespace {

// A world_m × (world_m·(nz−1)/(nx−1)) world sampled with nx × nz samples.
relief::Frame frame(int nx, int nz, double world_m = 4000.0) {
  relief::Frame f;
  f.spacing_m = world_m / (nx - 1);
  f.world_width_m = world_m;
  f.world_depth_m = f.spacing_m * (nz - 1);
  f.nx = nx;
  f.nz = nz;
  f.height_m = 600.0;
  f.sea_level = 0.4;
  return f;
}

// Heights that cover [0, 1] with structure at several scales, plus exact 0, 1 and sea level.
Terrain field(const relief::Frame& f) {
  Terrain t;
  t.frame = f;
  auto& l = t.layer("height", 1);
  for (int j = 0; j < f.nz; ++j)
    for (int i = 0; i < f.nx; ++i) {
      const double x = f.x_m(i), z = f.z_m(j);
      double e = 0.5 + 0.3 * std::sin(x / 310.0) * std::cos(z / 470.0 + 0.3) + 0.25 * std::sin(x / 37.0 + z / 53.0);
      if ((i + 3 * j) % 17 == 0) e = 0.0;
      if ((i + 5 * j) % 19 == 0) e = 1.0;
      if ((2 * i + j) % 23 == 0) e = 0.4;
      l.data[std::size_t(j) * f.nx + i] = float(std::clamp(e, 0.0, 1.0));
    }
  return t;
}

void run(const std::string& stage, json params, Terrain& t, std::uint64_t seed = 3) {
  params["stage"] = stage;
  auto s = relief::find_stage(stage)->parse(params, "stages[0]");
  relief::Context ctx;
  ctx.seed = seed;
  s->apply(t, ctx);
}

struct Case {
  std::string stage;
  json params;
  std::vector<std::string> layers;  // outputs to compare
  bool exact;                       // bit-identical on every target (no transcendental function)
};

std::vector<Case> cases() {
  std::vector<Case> c = {
      {"redistribute", {{"exponent", 1.7}, {"modifier", 1.2}}, {"height"}, true},
      {"redistribute", {{"exponent", 0.3}, {"land_only", true}}, {"height"}, true},
      {"redistribute", {{"exponent", 8.0}}, {"height"}, true},
      {"redistribute", {{"exponent", 1.0}, {"modifier", 1.3}, {"land_only", true}}, {"height"}, true},
      {"terrace", {{"levels", 7}}, {"height"}, true},
      {"terrace", {{"levels", 5}, {"mode", "smooth"}, {"wall", 0.4}, {"land_only", true}}, {"height"}, true},
      {"curve", {{"points", {{0.0, 0.1}, {0.2, 0.15}, {0.45, 0.8}, {0.8, 0.85}, {1.0, 1.0}}}}, {"height"}, true},
      // 6 and 11 segments: the lane-permutation lookup on targets with at least that many lanes
      // (AVX2: 8, AVX-512: 16), the select chain on narrower ones (curve_row).
      {"curve", {{"points", {{0.05, 0.0}, {0.1, 0.3}, {0.3, 0.35}, {0.5, 0.7}, {0.6, 0.6}, {0.75, 0.9}, {0.95, 1.0}}}}, {"height"}, true},
      {"curve",
       {{"points",
         {{0.0, 0.0}, {0.1, 0.2}, {0.2, 0.1}, {0.3, 0.4}, {0.4, 0.35}, {0.5, 0.6}, {0.6, 0.5}, {0.7, 0.8}, {0.8, 0.7}, {0.9, 0.95}, {0.95, 0.9}, {1.0, 1.0}}}},
       {"height"},
       true},
      {"color", {{"variation", 0.1}, {"rock_blend_deg", 8.0}, {"rock_slope_deg", 20.0}}, {"albedo"}, false},
      {"color", {{"mode", "gradient"}, {"relative_to_max", true}, {"rock_blend_deg", 0.0}}, {"albedo"}, true},
      {"hillshade", {{"z_factor", 3.0}}, {"shade", "color"}, true},
  };
  for (const char* d : {"square_bump", "euclidean2", "hyperboloid", "trig_product", "squircle", "circular"})
    for (const char* s : {"lerp", "multiply", "subtract"})
      c.push_back({"island", {{"distance", d}, {"shaping", s}, {"mix", 0.8}, {"falloff_rate", 0.7}}, {"height"}, true});
  return c;
}

// Restores Highway's normal target choice when a test ends.
struct ForcedTarget {
  explicit ForcedTarget(std::int64_t target) { hwy::SetSupportedTargetsForTest(target); }
  ~ForcedTarget() { hwy::SetSupportedTargetsForTest(0); }
};

// Runs every case on a 67 × 45 field (67 = 4·16 + 3: every vector width leaves a tail) with the
// given target forced; returns the outputs by case and layer.
std::map<std::string, std::vector<float>> run_all(std::int64_t target) {
  ForcedTarget force(target);
  EXPECT_STREQ(relief::detail::pointwise_target(), hwy::TargetName(target)) << "dispatch did not switch";
  std::map<std::string, std::vector<float>> out;
  const auto all = cases();
  for (std::size_t k = 0; k < all.size(); ++k) {
    Terrain t = field(frame(67, 45));
    // An albedo to shade (without the rock blend, whose atan may differ in the last bit).
    if (all[k].stage == "hillshade") run("color", {{"rock_blend_deg", 0.0}}, t);
    run(all[k].stage, all[k].params, t);
    for (auto& l : all[k].layers) out[std::to_string(k) + " " + l] = t.get(l).data;
  }
  return out;
}

}  // namespace

// The acceptance rule of the SIMD port: every compiled target agrees with the scalar target within
// 1e-5; stages without transcendental functions agree bit for bit (pointwise.hpp).
TEST(Targets, EveryTargetAgreesWithScalar) {
  const auto targets = hwy::SupportedAndGeneratedTargets();
  ASSERT_NE(std::find(targets.begin(), targets.end(), HWY_SCALAR), targets.end()) << "the reference target is missing";
  const auto reference = run_all(HWY_SCALAR);
  const auto all = cases();
  for (std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    if (target == HWY_SCALAR) continue;
    const auto got = run_all(target);
    for (auto& [key, want] : reference) {
      const auto& have = got.at(key);
      ASSERT_EQ(have.size(), want.size());
      const Case& c = all[std::size_t(std::stoul(key))];
      double worst = 0;
      std::size_t differ = 0;
      for (std::size_t i = 0; i < want.size(); ++i) {
        worst = std::max(worst, std::fabs(double(have[i]) - double(want[i])));
        differ += have[i] != want[i];
      }
      EXPECT_LE(worst, 1e-5) << hwy::TargetName(target) << ": " << c.stage << " " << c.params.dump() << " " << key;
      if (c.exact) {
        EXPECT_EQ(differ, 0u) << hwy::TargetName(target) << ": " << c.stage << " " << c.params.dump() << " " << key;
      }
    }
  }
}

// A sample's result must not depend on where it falls in a vector (full vector or padded tail):
// the same world samples computed as part of a 67-wide window and of a 19-wide window starting at
// column 5 are identical, on every target.
TEST(Targets, ResultDoesNotDependOnPositionInRow) {
  for (std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    ForcedTarget force(target);
    for (const Case& c : cases()) {
      if (c.stage == "color" || c.stage == "hillshade") continue;  // neighbourhood stages: borders differ
      Terrain whole = field(frame(67, 45));
      Terrain part;
      part.frame = whole.frame.window(5, 0, 19, 45);
      auto& ph = part.layer("height", 1);
      for (int j = 0; j < 45; ++j)
        for (int i = 0; i < 19; ++i) ph.data[std::size_t(j) * 19 + i] = whole.get("height").data[std::size_t(j) * 67 + 5 + i];
      run(c.stage, c.params, whole);
      run(c.stage, c.params, part);
      for (int j = 0; j < 45; ++j)
        for (int i = 0; i < 19; ++i)
          ASSERT_EQ(part.get("height").data[std::size_t(j) * 19 + i], whole.get("height").data[std::size_t(j) * 67 + 5 + i])
              << hwy::TargetName(target) << " " << c.stage << " " << c.params.dump() << " at " << i << "," << j;
    }
  }
}

// ---- single precision against the double formulas ------------------------------------------

namespace {
Terrain ramp(int n) {
  Terrain t;
  t.frame = frame(n, 2, double(n - 1));
  auto& l = t.layer("height", 1);
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < n; ++i) l.data[std::size_t(j) * n + i] = float(double(i) / (n - 1));
  return t;
}
}  // namespace

TEST(Redistribute, PowWithinOneMillionthOfDouble) {
  for (double y : {0.1, 0.5, 1.2, 2.0, 3.7, 8.0}) {
    Terrain t = ramp(10001);
    const std::vector<float> in = t.get("height").data;
    run("redistribute", {{"exponent", y}}, t);
    double worst = 0;
    for (std::size_t i = 0; i < in.size(); ++i)
      worst = std::max(worst, std::fabs(double(t.get("height").data[i]) - std::pow(double(in[i]), y)));
    EXPECT_LE(worst, 1e-6) << "exponent " << y;
  }
}

TEST(Redistribute, ExponentOneIsExact) {
  Terrain t = field(frame(67, 45));
  const std::vector<float> before = t.get("height").data;
  run("redistribute", {{"exponent", 1.0}}, t);
  EXPECT_EQ(t.get("height").data, before);
}

TEST(Redistribute, ZeroStaysZeroAndTinyPowersFlushToZero) {
  Terrain t = ramp(3);
  auto& h = t.get("height").data;
  h[0] = 0.0f, h[1] = 1e-20f, h[2] = 1e-30f;  // 1e-20^8 = 1e-160: far below the float range
  run("redistribute", {{"exponent", 8.0}}, t);
  EXPECT_EQ(h[0], 0.0f);
  EXPECT_EQ(h[1], 0.0f);
  EXPECT_EQ(h[2], 0.0f);
}

TEST(Terrace, SmoothWithinOneMillionthOfDouble) {
  Terrain t = ramp(10001);
  const std::vector<float> in = t.get("height").data;
  run("terrace", {{"levels", 6}, {"mode", "smooth"}, {"wall", 0.35}}, t);
  double worst = 0;
  for (std::size_t i = 0; i < in.size(); ++i) {
    const double tt = double(in[i]) * 6, k = std::floor(tt), f = tt - k;
    const double s = std::clamp((f - 0.5 * (1 - 0.35)) / 0.35, 0.0, 1.0);
    worst = std::max(worst, std::fabs(double(t.get("height").data[i]) - (k + s * s * (3 - 2 * s)) / 6));
  }
  EXPECT_LE(worst, 1e-6);
}

TEST(Curve, KnotsCompareAsInDouble) {
  // 0.1 is not a float: the sample 0.1f (> 0.1) lies right of the knot, the float below it left.
  Terrain t = ramp(2);
  auto& h = t.get("height").data;
  h[0] = 0.1f, h[1] = std::nextafter(0.1f, 0.0f);
  run("curve", {{"points", {{0.0, 0.0}, {0.1, 0.5}, {1.0, 0.5}}}}, t);
  EXPECT_EQ(h[0], 0.5f);  // on the flat segment right of the knot
  EXPECT_LT(h[1], 0.5f);  // still rising towards it
  EXPECT_GT(h[1], 0.49f);
}

// ---- redistribute's own pow (pointwise.cpp: Pow01) against std::pow --------------------------

namespace {
float from_bits(std::uint32_t u) {
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}
std::uint32_t to_bits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}
// redistribute_row over xs with exponent y (modifier 1), on the process's own target.
std::vector<float> pow_row(double y, std::vector<float> xs, bool land_only = false, double sea = 0.4) {
  relief::detail::RedistributeRow k;
  k.land = relief::detail::LandOnly::make(land_only, sea);
  k.set_exponent(y);
  relief::detail::redistribute_row(k, xs.data(), int(xs.size()));
  return xs;
}
// Every 1021st float from the smallest subnormal to 1, and 1 itself.
std::vector<float> float_sweep() {
  std::vector<float> xs;
  for (std::uint32_t u = 1; u < 0x3f800000u; u += 1021) xs.push_back(from_bits(u));
  xs.push_back(1.0f);
  return xs;
}
const double kExponents[] = {0.1, 0.3, 0.5, 1.4, 2.0, 3.7, 8.0};
}  // namespace

// The contract of pointwise.hpp: relative error ≤ 1.5e-6 against the double pow of the same float
// input and exponent (measured: 1.27e-6 at exponent 8 over every float in [0, 1], 6.5e-7 to 9.6e-7
// for exponents 0.1 to 3.7) wherever the result is ≥ 2^−125, and 0 only below that. (A 16-bit
// height step is 1.5e-5.)
TEST(Redistribute, PowRelativeErrorBoundOverEveryBinade) {
  const std::vector<float> xs = float_sweep();
  const double tiny = std::ldexp(1.0, -125);
  for (double y : kExponents) {
    const std::vector<float> got = pow_row(y, xs);
    const double yf = double(float(y));
    double worst = 0;
    for (std::size_t i = 0; i < xs.size(); ++i) {
      const double want = std::pow(double(xs[i]), yf);
      if (got[i] == 0.0f) {
        ASSERT_LT(want, tiny * 1.0001) << "x " << xs[i] << " exponent " << y;
        continue;
      }
      worst = std::max(worst, std::fabs(double(got[i]) - want) / want);
    }
    EXPECT_LE(worst, 1.5e-6) << "exponent " << y;
  }
}

// Land only: e' = sea + land·u^y, u = (e − sea)/land, computed without the division (the
// logarithm of land is subtracted). Against the double formula on the same floats the heights
// agree within 5e-7: the power's relative error times land plus the final rounding.
TEST(Redistribute, LandOnlyPowWithinBoundOfDouble) {
  std::vector<float> es;
  for (int i = 0; i <= 100000; ++i) es.push_back(float(0.4 + 0.6 * i / 100000.0));
  const double sea = double(0.4f), land = double(1.0f - 0.4f);
  for (double y : kExponents) {
    const std::vector<float> got = pow_row(y, es, true, 0.4);
    double worst = 0;
    for (std::size_t i = 0; i < es.size(); ++i) {
      const double u = es[i] > 0.4f ? double(es[i] - 0.4f) / land : 0.0;
      const double want = es[i] > 0.4f ? sea + land * std::pow(u, double(float(y))) : double(es[i]);
      worst = std::max(worst, std::fabs(double(got[i]) - want));
    }
    EXPECT_LE(worst, 5e-7) << "exponent " << y;
  }
}

TEST(Redistribute, EndpointsAreExact) {
  for (double y : kExponents) {
    const auto plain = pow_row(y, {0.0f, 1.0f, -0.5f, 1.5f});
    EXPECT_EQ(plain[0], 0.0f) << y;
    EXPECT_EQ(plain[1], 1.0f) << y;
    EXPECT_EQ(plain[2], 0.0f) << y;  // negative heights clamp to 0 first
    EXPECT_EQ(plain[3], 1.0f) << y;  // and heights above 1 to 1
    // Land only: the sea floor and the coastline stay, the highest point stays at 1.
    const auto land = pow_row(y, {0.0f, 0.2f, 0.4f, 1.0f, -1.0f}, true, 0.4);
    EXPECT_EQ(land[0], 0.0f) << y;
    EXPECT_EQ(land[1], 0.2f) << y;
    EXPECT_EQ(land[2], 0.4f) << y;
    EXPECT_EQ(land[3], 1.0f) << y;
    EXPECT_EQ(land[4], 0.0f) << y;
  }
}

// Just above the sea, u^y is far below one ulp of the sea level (with exponent 8 up to ~1.6e-5 above
// it, where the kernel lifts e − sea to a floor instead of masking the power): those heights become
// the sea level exactly, and with exponent 0.1 (no lift at all) the first float above it does not.
TEST(Redistribute, LandOnlyHeightsJustAboveTheSeaMapToIt) {
  std::vector<float> es;
  for (float e = std::nextafter(0.4f, 1.0f); e < 0.40001f; e = std::nextafter(e, 1.0f)) es.push_back(e);
  for (float v : pow_row(8.0, es, true, 0.4)) EXPECT_EQ(v, 0.4f);
  const auto low = pow_row(0.1, {std::nextafter(0.4f, 1.0f)}, true, 0.4);
  EXPECT_GT(low[0], 0.4f + 0.01f);  // ((ulp)/0.6)^0.1 ≈ 0.18 of the land span
}

// Vectors wholly under the sea skip the power: each height gets the same value whether its vector
// is all sea floor or mixed with land (the kernel is pointwise), and the sea floor keeps its
// (clamped) height.
TEST(Redistribute, LandOnlySeaFloorVectorsMatchMixedOnes) {
  std::vector<float> sea_first, mixed;
  for (int i = 0; i < 64; ++i) sea_first.push_back(i < 64 - 16 ? float(-0.1 + 0.5 * i / 48.0) : float(0.45 + i * 0.008));
  for (int i = 0; i < 64; ++i) mixed.push_back(sea_first[std::size_t(i % 2 ? 63 - i / 2 : i / 2)]);
  for (double y : {0.5, 2.2}) {
    const auto a = pow_row(y, sea_first, true, 0.4), b = pow_row(y, mixed, true, 0.4);
    for (int i = 0; i < 64; ++i) {
      const int src = i % 2 ? 63 - i / 2 : i / 2;
      EXPECT_EQ(to_bits(b[std::size_t(i)]), to_bits(a[std::size_t(src)])) << "height " << mixed[std::size_t(i)];
      if (sea_first[std::size_t(src)] <= 0.4f) {
        EXPECT_EQ(a[std::size_t(src)], std::max(sea_first[std::size_t(src)], 0.0f));
      }
    }
  }
}

// Consecutive floats around every place where the evaluation changes regime (the √½ mantissa
// split of each binade, powers of two, the flush threshold, just below 1): the result never
// falls by more than one ulp from one input to the next, and on a grid coarser than the error it
// never falls at all.
TEST(Redistribute, PowIsMonotoneUpToOneUlp) {
  std::vector<float> xs;
  auto window = [&](float centre) {
    const std::uint32_t c = to_bits(centre);
    for (std::uint32_t u = c - std::min<std::uint32_t>(c, 3000); u < c + 3000 && u <= 0x3f800000u; ++u) xs.push_back(from_bits(u));
  };
  for (int e = 0; e >= -40; --e) {
    window(float(std::ldexp(std::numbers::sqrt2 / 2, e)));
    window(float(std::ldexp(1.0, e)));
  }
  window(1.17549435e-38f);  // smallest normal
  for (double y : kExponents) {
    std::vector<float> in = xs;
    std::sort(in.begin(), in.end());
    relief::detail::RedistributeRow k;
    k.set_exponent(y);
    window(k.x_min);
    const auto got = pow_row(y, in);
    for (std::size_t i = 1; i < in.size(); ++i) {
      if (in[i] == in[i - 1]) continue;
      ASSERT_GE(to_bits(got[i]) + 1, to_bits(got[i - 1])) << "exponent " << y << " at x = " << in[i];
    }
    std::vector<float> grid;
    for (int i = 0; i <= 20000; ++i) grid.push_back(float(i / 20000.0));
    const auto g = pow_row(y, grid);
    for (std::size_t i = 1; i < g.size(); ++i) ASSERT_GE(g[i], g[i - 1]) << "exponent " << y << " at x = " << grid[i];
  }
}

// ---- the colour stage's rock blend ----------------------------------------------------------

namespace {
// A plane rising eastwards at `deg` degrees: 8 m cells, 640 m per unit elevation.
Terrain plane(double deg) {
  Terrain t;
  t.frame = frame(9, 9, 64.0);
  t.frame.height_m = 640.0;
  auto& l = t.layer("height", 1);
  for (int j = 0; j < 9; ++j)
    for (int i = 0; i < 9; ++i) l.data[std::size_t(j) * 9 + i] = float(0.45 + i * 8.0 * std::tan(deg * std::numbers::pi / 180) / 640.0);
  return t;
}
json rock(double blend) {
  return {{"levels", json::array({{{"at", 1.0}, {"color", "#00ff00"}}})},
          {"rock_color", "#000000"},
          {"rock_slope_deg", 35.0},
          {"rock_blend_deg", blend},
          {"rock_min", 0.0},
          {"rock_max", 1.0},
          {"variation", 0.0}};
}
}  // namespace

TEST(Color, RockBlendFollowsSmoothstepOfTheAngle) {
  // 37.5° is halfway through a 5° blend above 35°: smoothstep(½) = ½ of the way to black.
  Terrain t = plane(37.5);
  run("color", rock(5.0), t);
  EXPECT_NEAR(t.get("albedo").data[(4 * 9 + 4) * 3 + 1], 0.5, 1e-5);
  // 36.25°: a quarter of the blend, smoothstep(¼) = 0.15625.
  Terrain q = plane(36.25);
  run("color", rock(5.0), q);
  EXPECT_NEAR(q.get("albedo").data[(4 * 9 + 4) * 3 + 1], 1.0 - 0.15625, 1e-5);
}

TEST(Color, RockAboveTheBlendBandIsExactlyRock) {
  Terrain t = plane(41.0);
  run("color", rock(5.0), t);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(t.get("albedo").data[(4 * 9 + i) * 3 + 1], 0.0f) << i;
}

TEST(Color, BelowTheRockSlopeIsUntouched) {
  Terrain t = plane(34.0);
  run("color", rock(5.0), t);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(t.get("albedo").data[(4 * 9 + i) * 3 + 1], 1.0f) << i;
}

TEST(Color, SlopeLayerAndGradientAgreeOnTheBlend) {
  // The same 37.5° plane with the angle given as a slope_deg layer.
  Terrain t = plane(37.5);
  auto& s = t.layer("slope_deg", 1);
  std::fill(s.data.begin(), s.data.end(), 37.5f);
  run("color", rock(5.0), t);
  EXPECT_NEAR(t.get("albedo").data[(4 * 9 + 4) * 3 + 1], 0.5, 1e-6);
}

TEST(Stages, MultiChannelHeightIsAnError) {
  Terrain t = field(frame(9, 9));
  t.layer("height", 2);
  try {
    run("island", json::object(), t);
    ADD_FAILURE() << "expected relief::Error";
  } catch (const relief::Error& e) {
    EXPECT_NE(std::string(e.what()).find("one channel"), std::string::npos) << e.what();
  }
}

// ---- colour level lookup and the hillshade halo ---------------------------------------------

namespace {
// Runs color_row over heights e (one row, no rock, no speckle) with or without the lookup tables.
std::vector<float> level_colors(const std::vector<float>& at, bool gradient, const std::vector<float>& e, bool tables) {
  relief::detail::ColorRow k;
  std::vector<float> r, g, b;
  for (std::size_t m = 0; m < at.size(); ++m) r.push_back(float(m) / 16), g.push_back(1.0f - float(m) / 20), b.push_back(float(m % 3) / 2);
  k.levels = int(at.size());
  k.at = at.data(), k.r = r.data(), k.g = g.data(), k.b = b.data();
  k.gradient = gradient;
  const std::vector<float> t = relief::detail::color_level_tables(k);
  if (tables) {
    EXPECT_FALSE(t.empty());
    k.tables = t.data();
  }
  relief::detail::GradientRows rows;
  rows.up = rows.mid = rows.down = e.data();
  std::vector<float> rgb(3 * e.size());
  relief::detail::color_row(k, rows, nullptr, nullptr, nullptr, 0.0f, nullptr, rgb.data(), int(e.size()));
  return rgb;
}
}  // namespace

// The branch-free lookup (count of levels below e, lane permutation) picks the same colours as
// the chain of selects, bit for bit, on every target: bands and gradients, duplicate levels (empty
// segments), one level and as many levels as the table has lanes; heights on, between and beyond
// the levels.
TEST(Color, LevelLookupMatchesTheSelectChain) {
  const std::vector<std::vector<float>> palettes = {
      {0.3f, 0.4f, 0.43f, 0.58f, 0.72f, 0.86f, 1.0f},
      {0.5f},
      {0.2f, 0.2f, 0.5f, 0.5f, 0.9f},
      {0.0f, 0.05f, 0.1f, 0.15f, 0.2f, 0.3f, 0.35f, 0.4f, 0.5f, 0.55f, 0.6f, 0.7f, 0.8f, 0.85f, 0.9f, 1.0f},
  };
  std::vector<float> e;
  for (int i = 0; i <= 1000; ++i) e.push_back(float(-0.1 + 1.2 * i / 1000.0));
  for (auto& p : palettes)
    for (float a : p) e.push_back(a), e.push_back(std::nextafter(a, 2.0f)), e.push_back(std::nextafter(a, -2.0f));
  for (std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    ForcedTarget force(target);
    for (auto& p : palettes)
      for (bool gradient : {false, true}) {
        const auto chain = level_colors(p, gradient, e, false);
        const auto lookup = level_colors(p, gradient, e, true);
        ASSERT_EQ(lookup, chain) << hwy::TargetName(target) << " levels " << p.size() << (gradient ? " gradient" : " bands");
      }
  }
}

TEST(Color, UnsortedLevelsHaveNoLookupTables) {
  relief::detail::ColorRow k;
  const std::vector<float> at = {0.5f, 0.3f}, c = {0.0f, 1.0f};
  k.levels = 2, k.at = at.data(), k.r = k.g = k.b = c.data();
  EXPECT_TRUE(relief::detail::color_level_tables(k).empty());
}

// The former double-precision hillshade of the step pictures, kept as the reference: the one
// single-precision implementation (stage and pictures) agrees with it within 1e-5 at every sample,
// the window's border rows and columns included (the halo blocks of the kernel), on every target.
TEST(Hillshade, AgreesWithTheDoubleReferenceIncludingBorders) {
  const relief::detail::Light light{300.0, 40.0, 3.0, 0.2, 0.3};
  for (std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    ForcedTarget force(target);
    for (int nx : {2, 5, 17, 67}) {
      Terrain t = field(frame(nx, 45));
      run("color", {{"rock_blend_deg", 0.0}}, t);
      const relief::Frame& fr = t.frame;
      const relief::Layer& h = t.get("height");
      const relief::Layer& albedo = t.get("albedo");
      relief::Layer shade, color;
      relief::detail::hillshade(fr, h, &albedo, light, &shade, &color);
      const double az = light.azimuth_deg * std::numbers::pi / 180, alt = light.altitude_deg * std::numbers::pi / 180;
      const double lx = std::cos(alt) * std::sin(az), ly = std::sin(alt), lz = -std::cos(alt) * std::cos(az);
      const double flat = light.ambient + (1.0 - light.ambient) * ly;
      double worst = 0;
      for (int j = 0; j < fr.nz; ++j)
        for (int i = 0; i < fr.nx; ++i) {
          const std::size_t k = std::size_t(j) * fr.nx + i;
          const auto g = relief::detail::gradient_at(fr, h, i, j);
          const double fx = light.z_factor * g.dx, fz = light.z_factor * g.dz;
          double s = light.ambient + (1.0 - light.ambient) * std::max(0.0, (-fx * lx + ly - fz * lz) / std::sqrt(1.0 + fx * fx + fz * fz));
          if (double(h.data[k]) < fr.sea_level) s = flat + light.water_relief * (s - flat);
          worst = std::max(worst, std::fabs(double(shade.data[k]) - s));
          for (int c = 0; c < 3; ++c) worst = std::max(worst, std::fabs(double(color.data[3 * k + c]) - albedo.data[3 * k + c] * s));
        }
      EXPECT_LE(worst, 1e-5) << hwy::TargetName(target) << " nx " << nx;
    }
  }
}

// The stage and the --steps pictures share the implementation: the stage's layers equal
// detail::hillshade's for the same light.
TEST(Hillshade, StageIsTheSharedImplementation) {
  Terrain t = field(frame(67, 45));
  run("color", json::object(), t);
  run("hillshade", {{"azimuth_deg", 315.0}, {"altitude_deg", 45.0}, {"z_factor", 1.0}, {"ambient", 0.2}, {"water_relief", 0.3}}, t);
  relief::Layer shade, color;
  relief::detail::hillshade(t.frame, t.get("height"), &t.get("albedo"), relief::detail::Light{}, &shade, &color);
  EXPECT_EQ(shade.data, t.get("shade").data);
  EXPECT_EQ(color.data, t.get("color").data);
}

// ---- hillshade's streaming stores -------------------------------------------------------------

// Layers far beyond the caches are written with non-temporal stores from the first vector-aligned
// colour sample on (HillshadeRow::stream): the same bytes as plain stores for every alignment of
// the colour row, with and without albedo and shade.
TEST(Hillshade, StreamingStoresWriteTheSameBytes) {
  const int n = 301;
  std::vector<float> up(n), mid(n), down(n), albedo(3 * n);
  for (int i = 0; i < n; ++i) {
    mid[i] = float(0.5 + 0.3 * std::sin(i * 0.37));
    up[i] = float(0.5 + 0.3 * std::sin(i * 0.29 + 1.0));
    down[i] = float(0.5 + 0.3 * std::cos(i * 0.41));
    for (int c = 0; c < 3; ++c) albedo[3 * i + c] = float(0.2 + 0.1 * c + 0.5 * std::fabs(std::sin(i * 0.13 + c)));
  }
  relief::detail::GradientRows rows;
  rows.up = up.data(), rows.mid = mid.data(), rows.down = down.data();
  rows.central = 3.0f, rows.edge = 6.0f, rows.kz = 3.0f;
  relief::detail::HillshadeRow k;
  k.sea_below = 0.45f;
  int streamed = 0;
  for (int offset = 0; offset < 16; ++offset)
    for (bool with_albedo : {true, false}) {
      std::vector<float> rgb0(3 * n + 16, -1.0f), rgb1(rgb0), shade0(n, -1.0f), shade1(shade0);
      k.stream = false;
      relief::detail::hillshade_row(k, rows, with_albedo ? albedo.data() : nullptr, shade0.data(), rgb0.data() + offset, n);
      k.stream = true;
      relief::detail::hillshade_row(k, rows, with_albedo ? albedo.data() : nullptr, with_albedo ? shade1.data() : nullptr,
                                    rgb1.data() + offset, n);
      EXPECT_EQ(0, std::memcmp(rgb0.data(), rgb1.data(), rgb0.size() * sizeof(float))) << "offset " << offset;
      if (with_albedo) EXPECT_EQ(shade0, shade1) << "offset " << offset;
      else EXPECT_EQ(shade1, std::vector<float>(n, -1.0f));  // no shade asked for: none written
      streamed += rgb0[offset + 3 * n - 1] != -1.0f;
    }
  EXPECT_EQ(streamed, 32);  // every row was written to its end
}
