// The pipeline as a whole: determinism across thread counts, resolution independence (a 2^n+1
// preview equals every other sample of the 2^(n+1)+1 build), seamless windows of the world, and
// the claim each preset makes about itself, as numbers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "relief/stage.hpp"
#include "support.hpp"

using namespace relief;

namespace {

Recipe preset(const std::string& name, int size, std::uint64_t seed = 7) { return test::preset_recipe(name, size, seed); }

const std::vector<std::string> kCore = {"island", "hills", "mountains", "desert"};

std::uint64_t fnv1a(const std::vector<float>& v) {
  std::uint64_t h = 1469598103934665603ull;
  const unsigned char* p = reinterpret_cast<const unsigned char*>(v.data());
  for (std::size_t i = 0; i < v.size() * sizeof(float); ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

struct Stats {
  double water = 0, border_water = 0, centre_land = 0, relief = 0, mean_slope = 0, p95_slope = 0;
  double mean_sat = 0, mean_blue_excess = 0;
};

Stats stats(const RunResult& r) {
  const Terrain& t = r.terrain;
  const Frame& f = t.frame;
  const auto& h = t.get("height").data;
  Stats s;
  std::size_t border = 0, centre = 0;
  float lo = 1, hi = 0;
  std::vector<double> slopes;
  for (int j = 0; j < f.nz; ++j)
    for (int i = 0; i < f.nx; ++i) {
      const float e = h[std::size_t(j) * f.nx + i];
      const bool sea = e < f.sea_level;
      lo = std::min(lo, e), hi = std::max(hi, e);
      s.water += sea;
      if (i == 0 || j == 0 || i == f.nx - 1 || j == f.nz - 1) border++, s.border_water += sea;
      const double dx = (i - (f.nx - 1) / 2.0) / ((f.nx - 1) / 2.0), dz = (j - (f.nz - 1) / 2.0) / ((f.nz - 1) / 2.0);
      if (dx * dx + dz * dz < 0.3 * 0.3) centre++, s.centre_land += !sea;
      if (i > 0 && j > 0 && !sea) {
        const double gx = (e - h[std::size_t(j) * f.nx + i - 1]) * f.height_m / f.cell_m();
        const double gz = (e - h[std::size_t(j - 1) * f.nx + i]) * f.height_m / f.cell_m();
        slopes.push_back(std::atan(std::sqrt(gx * gx + gz * gz)) * 180 / M_PI);
      }
    }
  s.water /= double(f.count());
  s.border_water /= double(border);
  s.centre_land /= double(std::max<std::size_t>(centre, 1));
  s.relief = (hi - lo) * f.height_m;
  if (!slopes.empty()) {
    double sum = 0;
    for (double x : slopes) sum += x;
    s.mean_slope = sum / double(slopes.size());
    std::nth_element(slopes.begin(), slopes.begin() + slopes.size() * 95 / 100, slopes.end());
    s.p95_slope = slopes[slopes.size() * 95 / 100];
  }
  const auto& c = t.get("albedo").data;
  for (std::size_t k = 0; k < f.count(); ++k) {
    const float R = c[3 * k], G = c[3 * k + 1], B = c[3 * k + 2];
    s.mean_blue_excess += B - std::max(R, G);
  }
  s.mean_blue_excess /= double(f.count());
  return s;
}

}  // namespace

TEST(Pipeline, SameSeedSameBytesForAnyThreadCount) {
  for (const auto& name : kCore) {
    Recipe r = preset(name, 129);
    std::map<std::string, std::uint64_t> ref;
    for (int threads : {1, 2, 3, 7}) {
      RunOptions o;
      o.threads = threads;
      RunResult res = run(r, o);
      for (auto& [lname, layer] : res.terrain.layers) {
        auto h = fnv1a(layer.data);
        if (threads == 1) ref[lname] = h;
        else EXPECT_EQ(h, ref[lname]) << name << " layer " << lname << " threads " << threads;
      }
    }
    EXPECT_FALSE(ref.empty());
  }
}

// Long stages report their own progress; the run's listener sees one fraction that never goes
// back, stays within each stage's share, and ends at 1 ("done").
TEST(Pipeline, ProgressAdvancesWithinLongStagesAndNeverGoesBack) {
  Recipe r = preset("eroded-mountains", 129);
  std::vector<std::pair<std::string, double>> calls;
  RunOptions o;
  o.progress = [&](std::string_view stage, double f) { calls.emplace_back(std::string(stage), f); };
  run(r, o);
  ASSERT_FALSE(calls.empty());
  EXPECT_EQ(calls.back(), std::make_pair(std::string("done"), 1.0));
  const double n = double(r.stages.size());
  std::map<std::string, int> reports;
  for (std::size_t k = 0; k < calls.size(); ++k) {
    if (k > 0) {
      EXPECT_GE(calls[k].second, calls[k - 1].second) << k << ": " << calls[k].first;
    }
    ++reports[calls[k].first];
  }
  for (std::size_t i = 0; i < r.stages.size(); ++i) {
    const std::string name = r.stages[i].def->name;
    if (std::count_if(r.stages.begin(), r.stages.end(), [&](const RecipeStage& s) { return s.def->name == name; }) > 1)
      continue;  // two noise stages: the name does not say which share
    for (auto& [stage, f] : calls)
      if (stage == name) {
        EXPECT_GE(f, double(i) / n - 1e-12) << name;
        EXPECT_LE(f, double(i + 1) / n + 1e-12) << name;
      }
  }
  // stream_power: the start, then one report per step; hydraulic: 16 phases; thermal: one per
  // iteration (at least one); flow: two phases.
  const json sp = load_preset("eroded-mountains")["stages"][4];
  ASSERT_EQ(sp["stage"], "stream_power");
  EXPECT_EQ(reports["stream_power"], 1 + sp["steps"].get<int>());
  EXPECT_EQ(reports["hydraulic"], 1 + 16);
  EXPECT_GE(reports["thermal"], 2);
  EXPECT_EQ(reports["flow"], 1 + 2);  // after the fill and after the flow order
}

TEST(Pipeline, DifferentSeedsDiffer) {
  for (const auto& name : kCore) {
    auto a = run(preset(name, 65, 1)).terrain.get("height").data;
    auto b = run(preset(name, 65, 2)).terrain.get("height").data;
    EXPECT_NE(a, b) << name;
  }
}

TEST(Pipeline, NoSeedDrawsOneAndReportsIt) {
  json doc = load_preset("island");
  doc["world"]["size"] = 33;
  Recipe r = parse_recipe(doc);
  RunResult a = run(r);
  EXPECT_LE(a.seed, kMaxSeed);
  Recipe again = r;
  again.seed = a.seed;
  EXPECT_EQ(run(again).terrain.get("height").data, a.terrain.get("height").data);
}

TEST(Pipeline, PreviewEqualsEveryOtherSampleOfBuild) {
  for (const auto& name : kCore) {
    RunResult p = run(preset(name, 257)), b = run(preset(name, 513));
    const auto& hp = p.terrain.get("height").data;
    const auto& hb = b.terrain.get("height").data;
    std::size_t mismatches = 0;
    for (int j = 0; j < 257; ++j)
      for (int i = 0; i < 257; ++i)
        mismatches += hp[std::size_t(j) * 257 + i] != hb[std::size_t(2 * j) * 513 + 2 * i];
    EXPECT_EQ(mismatches, 0u) << name;
  }
}

TEST(Pipeline, NeighbouringWindowsAreSeamless) {
  for (const auto& name : kCore) {
    Recipe r = preset(name, 257);
    const Frame world = r.world.frame();
    RunResult whole = run(r);
    // Four windows of 129×129 samples sharing their borders.
    for (int wz = 0; wz < 2; ++wz)
      for (int wx = 0; wx < 2; ++wx) {
        RunOptions o;
        o.window = world.window(wx * 128, wz * 128, 129, 129);
        RunResult part = run(r, o);
        const auto& hp = part.terrain.get("height").data;
        const auto& hw = whole.terrain.get("height").data;
        std::size_t mismatches = 0;
        for (int j = 0; j < 129; ++j)
          for (int i = 0; i < 129; ++i)
            mismatches += hp[std::size_t(j) * 129 + i] != hw[std::size_t(wz * 128 + j) * 257 + (wx * 128 + i)];
        EXPECT_EQ(mismatches, 0u) << name << " window " << wx << "," << wz;
      }
  }
}

TEST(Pipeline, HeightsStayNormalised) {
  for (const auto& name : list_presets()) {
    if (name.origin != "built-in") continue;
    RunResult r = run(preset(name.name, 129));
    for (float e : r.terrain.get("height").data) {
      ASSERT_GE(e, 0.0f) << name.name;
      ASSERT_LE(e, 1.0f) << name.name;
    }
  }
}

// ---- each preset's claim, as a number (seeds 1..3, 257²) ----------------------------------

TEST(PresetClaims, IslandHasWaterAllRoundAndLandInTheMiddle) {
  for (std::uint64_t seed : {1, 2, 3}) {
    Stats s = stats(run(preset("island", 257, seed)));
    EXPECT_GE(s.border_water, 0.95) << "seed " << seed;
    EXPECT_GE(s.centre_land, 0.7) << "seed " << seed;
    EXPECT_GT(s.water, 0.3) << "seed " << seed;
  }
}

TEST(PresetClaims, HillsHaveLittleWaterAndGentleSlopes) {
  for (std::uint64_t seed : {1, 2, 3}) {
    Stats s = stats(run(preset("hills", 257, seed)));
    EXPECT_LE(s.water, 0.10) << "seed " << seed;
    EXPECT_LE(s.p95_slope, 20.0) << "seed " << seed;
    EXPECT_GE(s.mean_slope, 1.0) << "seed " << seed;  // not flat either
  }
}

TEST(PresetClaims, MountainsHaveTheWidestReliefAndSteepestSlopes) {
  for (std::uint64_t seed : {1, 2, 3}) {
    Stats m = stats(run(preset("mountains", 257, seed)));
    for (const char* other : {"island", "hills", "desert"}) {
      Stats o = stats(run(preset(other, 257, seed)));
      EXPECT_GT(m.relief, o.relief) << other << " seed " << seed;
      EXPECT_GT(m.mean_slope, o.mean_slope) << other << " seed " << seed;
      EXPECT_GT(m.p95_slope, o.p95_slope) << other << " seed " << seed;
    }
  }
}

TEST(PresetClaims, DesertIsDryAndHasAlmostNoWater) {
  for (std::uint64_t seed : {1, 2, 3}) {
    RunResult r = run(preset("desert", 257, seed));
    Stats s = stats(r);
    EXPECT_LE(s.water, 0.02) << "seed " << seed;
    // Dry colours: red exceeds blue and green stays below red on average (sand, ochre), no blue cast.
    const auto& c = r.terrain.get("albedo").data;
    double red = 0, green = 0, blue = 0;
    const std::size_t n = r.terrain.frame.count();
    for (std::size_t k = 0; k < n; ++k) red += c[3 * k], green += c[3 * k + 1], blue += c[3 * k + 2];
    EXPECT_GT(red / n, blue / n + 0.15) << "seed " << seed;
    EXPECT_GT(red / n, green / n) << "seed " << seed;
    EXPECT_LT(s.mean_blue_excess, 0.0);
  }
}

// ======================================================= locality: windows grow by the halo

namespace {

// Neighbourhood stages (slope, colour with its rock rule and speckle, hillshade, thermal erosion)
// after pointwise noise, on a 65² world of 62.5 m cells: steep enough for rock and for thermal
// erosion to move material.
Recipe neighbourhood_recipe(double thermal_m) {
  json doc = {{"seed", 11},
              {"world", {{"size", 65}, {"width_m", 4000}, {"height_m", 900}, {"sea_level", 0.35}}},
              {"stages",
               {{{"stage", "noise"}, {"octaves", 5}, {"frequency", 4.0}, {"amplitude", 1.0}},
                {{"stage", "thermal"}, {"talus_deg", 20.0}, {"distance_m", thermal_m}},
                {{"stage", "slope"}},
                {{"stage", "color"}, {"variation", 0.1}, {"rock_slope_deg", 25.0}, {"rock_blend_deg", 5.0}},
                {{"stage", "hillshade"}}}}};
  return parse_recipe(doc);
}

// Number of samples of every layer of `part` (a window at (ix0, iz0)) that differ from `whole`.
std::size_t window_mismatches(const Terrain& whole, const Terrain& part, const std::string& where) {
  const Frame &w = whole.frame, &p = part.frame;
  std::size_t bad = 0;
  EXPECT_EQ(part.layers.size(), whole.layers.size()) << where;
  for (const auto& [name, l] : part.layers) {
    const Layer& lw = whole.get(name);
    EXPECT_EQ(l.data.size(), p.count() * std::size_t(l.channels)) << where << " " << name;
    std::size_t here = 0;
    for (int j = 0; j < p.nz; ++j)
      for (int i = 0; i < p.nx; ++i)
        for (int c = 0; c < l.channels; ++c) {
          const std::size_t a = (std::size_t(j) * p.nx + i) * l.channels + c;
          const std::size_t b = (std::size_t(p.iz0 - w.iz0 + j) * w.nx + std::size_t(p.ix0 - w.ix0 + i)) * l.channels + c;
          here += std::memcmp(&l.data[a], &lw.data[b], sizeof(float)) != 0;
        }
    EXPECT_EQ(here, 0u) << where << " layer " << name;
    bad += here;
  }
  return bad;
}

}  // namespace

TEST(Locality, FourWindowsOfNeighbourhoodStagesEqualTheWholeMap) {
  const Recipe r = neighbourhood_recipe(150.0);  // 3 iterations: a halo of 6 samples
  const Frame world = r.world.frame();
  const RunResult whole = run(r);
  // The stages did something worth comparing: rock, thermal moves, shading.
  ASSERT_TRUE(whole.terrain.has("slope_deg") && whole.terrain.has("albedo") && whole.terrain.has("shade"));
  // Four windows sharing their borders (each touches two world edges), and one in the interior.
  for (int wz = 0; wz < 2; ++wz)
    for (int wx = 0; wx < 2; ++wx) {
      RunOptions o;
      o.window = world.window(wx * 32, wz * 32, 33, 33);
      const RunResult part = run(r, o);
      ASSERT_TRUE(part.terrain.frame.ix0 == wx * 32 && part.terrain.frame.nx == 33 && part.terrain.frame.nz == 33);
      window_mismatches(whole.terrain, part.terrain, "window " + std::to_string(wx) + "," + std::to_string(wz));
    }
  RunOptions o;
  o.window = world.window(21, 17, 19, 23);
  window_mismatches(whole.terrain, run(r, o).terrain, "interior window");
}

TEST(Locality, ThermalHaloGrowsWithItsDistance) {
  const Recipe r = neighbourhood_recipe(400.0);  // 7 iterations: 14 samples
  const Frame f = r.world.frame();
  EXPECT_EQ(r.stages[1].stage->reach(f).halo, 14);
  EXPECT_EQ(r.stages[1].stage->reach(f).locality, Locality::Neighbourhood);
  EXPECT_EQ(r.stages[2].stage->reach(f).halo, 1);
  RunOptions o;
  o.window = f.window(20, 24, 17, 9);
  window_mismatches(run(r).terrain, run(r, o).terrain, "thermal 400 m");
}

TEST(Locality, GlobalStageOnAWindowIsRefusedWithItsPath) {
  json doc = {{"seed", 3},
              {"world", {{"size", 33}}},
              {"stages", {{{"stage", "noise"}}, {{"stage", "slope"}}, {{"stage", "flow"}}, {{"stage", "hillshade"}}}}};
  const Recipe r = parse_recipe(doc);
  RunOptions o;
  o.window = r.world.frame().window(0, 0, 17, 17);
  try {
    run(r, o);
    FAIL() << "a global stage ran on a window";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[2]");
    EXPECT_NE(std::string(e.what()).find("'flow' needs the whole map"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("drainage"), std::string::npos) << e.what();
  }
  // The whole world given as a window is not a window.
  o.window = r.world.frame();
  EXPECT_NO_THROW(run(r, o));
  // Per-map normalisation is global too, whatever the stage's declared reach.
  doc["stages"] = {{{"stage", "noise"}}, {{"stage", "color"}, {"relative_to_max", true}}};
  o.window = r.world.frame().window(8, 8, 9, 9);
  try {
    run(parse_recipe(doc), o);
    FAIL() << "colour relative to the map's maximum ran on a window";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[1]");
    EXPECT_NE(std::string(e.what()).find("highest sample"), std::string::npos) << e.what();
  }
}
