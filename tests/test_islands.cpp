// Island systems: Voronoi regions and their biome assignment, blending, climate biomes, the
// volcano, craters and peaks, vertex jiggle, props, the island writers and the step pictures.
#include <gtest/gtest.h>
#include <spng.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "biomes.hpp"
#include "climate.hpp"
#include "features.hpp"
#include "surface.hpp"
#include "relief/error.hpp"
#include "relief/output.hpp"
#include "relief/pipeline.hpp"
#include "relief/random.hpp"
#include "relief/recipe.hpp"
#include "relief/stage.hpp"
#include "relief/steps.hpp"
#include "relief/terrain.hpp"
#include "stages.hpp"
#include "support.hpp"

using relief::json;
using relief::Terrain;
namespace st = relief::stages;
namespace fs = std::filesystem;

namespace {

relief::Frame square(int n, double world_m, double height_m = 100.0, double sea = 0.2) {
  return relief::test::square_frame(n, world_m, height_m, sea);
}

// A Terrain whose height is h(x_m, z_m), in world metres.
Terrain grid(const relief::Frame& f, const std::function<double(double, double)>& h) {
  return relief::test::grid_terrain(f, [&](int i, int j) { return h(f.x_m(i), f.z_m(j)); });
}

// A round island: elevation 0.8 at the centre falling to 0 at `radius_m` and beyond.
Terrain round_island(const relief::Frame& f, double radius_m) {
  const double cx = 0.5 * f.world_width_m, cz = 0.5 * f.world_depth_m;
  return grid(f, [&](double x, double z) { return 0.8 * std::max(0.0, 1.0 - std::hypot(x - cx, z - cz) / radius_m); });
}

void run(const relief::StageDef& def, json params, Terrain& t, std::uint64_t seed = 11, int index = 0) {
  params["stage"] = def.name;
  auto stage = def.parse(params, "stages[" + std::to_string(index) + "]");
  relief::Context ctx;
  ctx.seed = seed;
  ctx.stage_index = index;
  stage->apply(t, ctx);
}

std::uint64_t stage_seed(std::uint64_t seed, int index = 0) {
  relief::Context ctx;
  ctx.seed = seed;
  ctx.stage_index = index;
  return ctx.stage_seed();
}

float at(const Terrain& t, const char* layer, int i, int j, int c = 0) {
  const auto& l = t.get(layer);
  return l.data[(std::size_t(j) * t.frame.nx + i) * l.channels + c];
}

double slope_deg(const Terrain& t, int i, int j) {
  const auto g = relief::detail::gradient_at(t.frame, t.get("height"), i, j);
  return std::atan(std::hypot(g.dx, g.dz)) * 180.0 / 3.14159265358979323846;
}

// A biome type with a constant lift (flat terrain of one colour).
json flat_type(const std::string& name, double lift, double protect = 1.0, json avoid = json::array()) {
  return {{"name", name},   {"curve", json::array({json::array({0.0, lift}), json::array({1.0, lift})})},
          {"avoid", avoid}, {"protect_above", protect},
          {"colors", json::array({{{"at", 0.5}, {"color", "#808080"}}})}};
}

// The steepest slope (degrees) where the land ends above 0.3, after biomes of one flat type `lift`
// high (and `params`) over a round island 1500 m across on f.
double steepest_flat_biome(const relief::Frame& f, double lift, json params) {
  Terrain t = round_island(f, 1500.0);
  params["types"] = json::array({flat_type("cliffy", lift)});
  params["bridge"] = "cliffy";
  params["beach_lift"] = 0.0;
  run(st::biomes(), params, t);
  double worst = 0;
  for (int j = 1; j + 1 < f.nz; ++j)
    for (int i = 1; i + 1 < f.nx; ++i)
      if (double(at(t, "height", i, j)) > 0.3) worst = std::max(worst, slope_deg(t, i, j));
  return worst;
}

relief::detail::BiomesParams parse_biomes(const json& params) {
  // The RegionMap needs the parsed params; parse them with the stage's own table through a recipe.
  json doc = {{"world", {{"size", 3}}}, {"stages", json::array({params})}};
  doc["stages"][0]["stage"] = "biomes";
  relief::Recipe r = relief::parse_recipe(doc);
  const json resolved = r.stages[0].stage->params();
  relief::detail::BiomesParams p;
  p.region_size_m = resolved["region_size_m"];
  p.jitter = resolved["jitter"];
  p.climate_wavelength_m = resolved["climate_wavelength_m"];
  p.variety = resolved["variety"];
  p.bridge = resolved["bridge"];
  using Blend = relief::detail::BiomesParams::Blend;
  const std::string blend = resolved["blend"];
  p.blend = blend == "interpolate" ? Blend::Interpolate : blend == "selective" ? Blend::Selective : Blend::None;
  p.border_m = resolved["border_m"];
  p.types.clear();
  for (auto& tj : resolved["types"]) {
    relief::detail::BiomeType bt;
    bt.name = tj["name"];
    bt.aridity = tj["aridity"];
    bt.ruggedness = tj["ruggedness"];
    bt.weight = tj["weight"];
    for (auto& a : tj["avoid"]) bt.avoid.push_back(a);
    p.types.push_back(bt);
  }
  return p;
}

}  // namespace

// ---- Voronoi regions -------------------------------------------------------------------------

TEST(Regions, EveryCellBelongsToItsNearestPoint) {
  const relief::Frame f = square(97, 2000.0);
  const json params = {{"region_size_m", 180.0}, {"jitter", 1.0}};
  const auto p = parse_biomes(params);
  const relief::detail::RegionMap map(p, stage_seed(11), f.x_m(0), f.z_m(0), f.x_m(f.nx - 1), f.z_m(f.nz - 1));
  const auto pts = map.points();
  ASSERT_GT(pts.size(), 121u);
  // The stage on all-land, hard borders, no beach: each sample's biome is its nearest point's type.
  Terrain t = grid(f, [](double, double) { return 1.0; });
  json sp = params;
  sp["blend"] = "none";
  sp["beach_lift"] = 0.0;
  run(st::biomes(), sp, t);
  for (int j = 0; j < f.nz; ++j)
    for (int i = 0; i < f.nx; ++i) {
      const double x = f.x_m(i), z = f.z_m(j);
      std::size_t best = 0;
      double bd = 1e300;
      for (std::size_t k = 0; k < pts.size(); ++k) {
        const double d = std::hypot(pts[k].x_m - x, pts[k].z_m - z);
        if (d < bd) bd = d, best = k;
      }
      const auto& n = map.nearest(x, z);
      ASSERT_EQ(n.cx, pts[best].cx) << i << "," << j;
      ASSERT_EQ(n.cz, pts[best].cz) << i << "," << j;
      ASSERT_EQ(at(t, "biome", i, j), float(2 + pts[best].type)) << i << "," << j;
    }
}

TEST(Regions, PointsAreTheSameInEveryWindow) {
  const auto p = parse_biomes({{"region_size_m", 150.0}});
  const relief::detail::RegionMap whole(p, 5, 0, 0, 3000, 3000), part(p, 5, 1200, 900, 1800, 1500);
  for (auto& q : part.points()) {
    const auto& w = whole.at(q.cx, q.cz);
    EXPECT_EQ(w.x_m, q.x_m);
    EXPECT_EQ(w.z_m, q.z_m);
  }
  // Final types agree where both maps see the full repair neighbourhood (the part's inner cells).
  const auto& c = part.nearest(1500, 1200);
  EXPECT_EQ(whole.at(c.cx, c.cz).type, c.type);
}

TEST(Regions, NoNeighbouringRegionsBreakTheAdjacencyRules) {
  // Many small regions, lots of variety: the climate choice alone puts avoided types side by side.
  const relief::Frame f = square(161, 4000.0);
  const json params = {{"region_size_m", 200.0}, {"variety", 3.0}, {"blend", "none"}, {"beach_lift", 0.0}};
  const auto p = parse_biomes(params);
  const relief::detail::RegionMap map(p, stage_seed(11), f.x_m(0), f.z_m(0), f.x_m(f.nx - 1), f.z_m(f.nz - 1));
  Terrain t = grid(f, [](double, double) { return 1.0; });
  run(st::biomes(), params, t);
  int borders = 0, initial_conflicts = 0, bridged = 0;
  for (int j = 0; j < f.nz; ++j)
    for (int i = 0; i < f.nx; ++i)
      for (auto [di, dj] : {std::pair{1, 0}, std::pair{0, 1}}) {
        if (i + di >= f.nx || j + dj >= f.nz) continue;
        const int a = int(at(t, "biome", i, j)) - 2, b = int(at(t, "biome", i + di, j + dj)) - 2;
        ASSERT_GE(a, 0);
        ASSERT_GE(b, 0);
        if (a == b) continue;
        ++borders;
        EXPECT_FALSE(map.conflict(a, b)) << p.types[std::size_t(a)].name << " beside " << p.types[std::size_t(b)].name
                                         << " at " << i << "," << j;
        const auto& na = map.nearest(f.x_m(i), f.z_m(j));
        const auto& nb = map.nearest(f.x_m(i + di), f.z_m(j + dj));
        initial_conflicts += map.conflict(na.initial, nb.initial);
      }
  for (auto& q : map.points()) bridged += q.type != q.initial;
  EXPECT_GT(borders, 500);
  EXPECT_GT(initial_conflicts, 0) << "the test needs conflicts for the repair to remove";
  EXPECT_GT(bridged, 0);
}

TEST(Regions, AssignmentFollowsTheClimatePreferences) {
  // Without variety every region takes the type nearest its climate: with two types at opposite
  // aridity, both appear, in coherent zones (most neighbours share the type).
  const relief::Frame f = square(129, 8000.0);
  json types = json::array({flat_type("wet", 0.1), flat_type("dry", 0.2)});
  types[0]["aridity"] = 0.0;
  types[1]["aridity"] = 1.0;
  Terrain t = grid(f, [](double, double) { return 1.0; });
  run(st::biomes(), {{"types", types}, {"bridge", "wet"}, {"variety", 0.0}, {"region_size_m", 250.0},
                     {"climate_wavelength_m", 4000.0}, {"blend", "none"}, {"beach_lift", 0.0}}, t);
  int same = 0, diff = 0, wet = 0;
  for (int j = 0; j + 1 < f.nz; ++j)
    for (int i = 0; i + 1 < f.nx; ++i) {
      (at(t, "biome", i, j) == at(t, "biome", i + 1, j) ? same : diff)++;
      wet += at(t, "biome", i, j) == 2.0f;
    }
  EXPECT_GT(wet, 500);
  EXPECT_LT(wet, (f.nx - 1) * (f.nz - 1) - 500);
  EXPECT_GT(same, 20 * diff);
}

// ---- blending --------------------------------------------------------------------------------

namespace {

// Two flat types 0.05 and 0.5 (the "plateau", protected) over all land; returns the terrain and the
// maximum slope among samples within `band_m` of a border between different types.
struct BlendRun {
  Terrain t;
  double max_border_slope = 0;
  int plateau_interior = 0, plateau_interior_flat = 0;
};

BlendRun blend_run(const std::string& blend, double band_m) {
  BlendRun r;
  const relief::Frame f = square(201, 2000.0, 100.0, 0.2);
  r.t = grid(f, [](double, double) { return 1.0; });
  const json types = json::array({flat_type("low", 0.05), flat_type("plateau", 0.5, 0.0)});
  const json params = {{"types", types},       {"bridge", "low"},      {"region_size_m", 300.0}, {"variety", 5.0},
                       {"border_m", 150.0},   {"blend", blend},       {"flatten_keep", 0.0},    {"beach_lift", 0.0},
                       {"selective_radius_m", 60.0}};
  run(st::biomes(), params, r.t);
  const auto p = parse_biomes(params);
  const relief::detail::RegionMap map(p, stage_seed(11), f.x_m(0), f.z_m(0), f.x_m(f.nx - 1), f.z_m(f.nz - 1));
  const float plateau = float(0.2 + 0.8 * 0.5);
  for (int j = 1; j + 1 < f.nz; ++j)
    for (int i = 1; i + 1 < f.nx; ++i) {
      const double x = f.x_m(i), z = f.z_m(j);
      // Distance to the nearest point of another type, minus the distance to the nearest point.
      const auto& n = map.nearest(x, z);
      double other = 1e300;
      for (auto& q : map.points())
        if (q.type != n.type) other = std::min(other, std::hypot(q.x_m - x, q.z_m - z));
      const double gap = other - std::hypot(n.x_m - x, n.z_m - z);  // ≈ twice the distance to the border
      if (gap < band_m) r.max_border_slope = std::max(r.max_border_slope, slope_deg(r.t, i, j));
      if (n.type == 1 && gap > 160.0) {
        ++r.plateau_interior;
        r.plateau_interior_flat += at(r.t, "height", i, j) == plateau;
      }
    }
  return r;
}

}  // namespace

TEST(Blend, InterpolationRemovesBorderCliffsAndKeepsPlateauTopsFlat) {
  constexpr double kBound = 45.0;  // degrees
  const BlendRun hard = blend_run("none", 40.0);
  const BlendRun soft = blend_run("interpolate", 160.0);
  EXPECT_GT(hard.max_border_slope, kBound);  // a 36 m step over one sample: a cliff
  EXPECT_LE(soft.max_border_slope, kBound);
  ASSERT_GT(soft.plateau_interior, 200);
  EXPECT_EQ(soft.plateau_interior_flat, soft.plateau_interior);
}

TEST(Blend, SelectiveAveragingSmoothsOpenBordersAndProtectsThePlateau) {
  // Seed 003's method: three types, the middle one open to averaging, the plateau protected.
  const relief::Frame f = square(201, 2000.0, 100.0, 0.2);
  const json types = json::array({flat_type("low", 0.05), flat_type("mid", 0.3), flat_type("plateau", 0.5, 0.0)});
  auto make = [&](const std::string& blend) {
    Terrain t = grid(f, [](double, double) { return 1.0; });
    run(st::biomes(), {{"types", types}, {"bridge", "low"}, {"region_size_m", 300.0}, {"variety", 5.0},
                       {"blend", blend}, {"flatten_keep", 0.0}, {"beach_lift", 0.0}, {"selective_radius_m", 60.0}},
        t);
    return t;
  };
  const Terrain hard = make("none"), soft = make("selective");
  double before = 0, after = 0;
  int plateau = 0;
  for (int j = 1; j + 1 < f.nz; ++j)
    for (int i = 1; i + 1 < f.nx; ++i) {
      bool touches_plateau = false;
      for (int b = j - 1; b <= j + 1; ++b)
        for (int a = i - 1; a <= i + 1; ++a) touches_plateau = touches_plateau || at(hard, "biome", a, b) == 4.0f;
      if (at(hard, "biome", i, j) == 4.0f) {
        ++plateau;
        ASSERT_EQ(at(soft, "height", i, j), at(hard, "height", i, j));  // protected: untouched, still flat
        ASSERT_EQ(at(soft, "height", i, j), float(0.2 + 0.8 * 0.5));
      }
      if (touches_plateau) continue;  // the plateau keeps its cliff walls on purpose
      before = std::max(before, slope_deg(hard, i, j));
      after = std::max(after, slope_deg(soft, i, j));
    }
  EXPECT_GT(plateau, 1000);
  EXPECT_GT(before, 40.0);
  EXPECT_LT(after, 20.0);
}

TEST(Blend, NoSeaCliffs) {
  // A 105 m high flat biome right at the coast. The relief fades in over coast_m = 150 m from the
  // sea: the steepest slope on land is about 1.5 · 105 / 150 (smoothstep's steepest) ≈ 46°, not a
  // cliff; without the fade the land jumps 105 m within a sample.
  const relief::Frame f = square(257, 4000.0, 500.0, 0.3);
  auto worst_slope = [&](double coast_m) { return steepest_flat_biome(f, 0.3, {{"coast_m", coast_m}}); };
  EXPECT_GT(worst_slope(0.0), 70.0);
  EXPECT_LT(worst_slope(150.0), 48.0);
}

TEST(Blend, CoastSlopeBoundsTheFadeIn) {
  // The same 105 m biome: over coast_m = 150 m it rises at ~46°, a sea cliff to a walker (issue 16:
  // the volcanic-island plateau met the sea at 44–60°). coast_slope_deg lengthens the fade-in where
  // the lift is tall, to 1.5 · 105 / tan 25° ≈ 338 m here, and leaves low biomes at coast_m.
  const relief::Frame f = square(257, 4000.0, 500.0, 0.3);
  auto worst_slope = [&](double lift, double coast_slope_deg) {
    return steepest_flat_biome(f, lift, {{"coast_m", 150.0}, {"coast_slope_deg", coast_slope_deg}});
  };
  EXPECT_GT(worst_slope(0.3, 0.0), 40.0);
  EXPECT_LT(worst_slope(0.3, 25.0), 26.0);
  // A low biome (10.5 m: 1.5 · 10.5 / 150 ≈ 6°) already rises gently: unchanged.
  EXPECT_EQ(worst_slope(0.03, 0.0), worst_slope(0.03, 25.0));
}

TEST(Biomes, SeaIsUntouchedAndLegendNamesTheTypes) {
  const relief::Frame f = square(129, 4000.0, 500.0, 0.3);
  Terrain t = round_island(f, 1500.0);
  const Terrain before = t;
  run(st::biomes(), json::object(), t);
  int sea = 0;
  for (std::size_t k = 0; k < f.count(); ++k)
    if (double(before.get("height").data[k]) <= 0.3) {
      ++sea;
      ASSERT_EQ(t.get("height").data[k], before.get("height").data[k]);
      ASSERT_EQ(t.get("biome").data[k], 0.0f);
    } else {
      ASSERT_GT(double(t.get("height").data[k]), 0.3);  // land stays land
    }
  EXPECT_GT(sea, 1000);
  std::vector<std::string> names;
  for (auto& b : t.biomes) names.push_back(b.name);
  EXPECT_EQ(names, (std::vector<std::string>{"ocean", "beach", "plains", "hills", "mountains", "spiky_mountains",
                                             "plateau", "desert", "forest"}));
}

TEST(Biomes, TextureReplacesTheColourAndAMissingFileNamesTheField) {
  const relief::test::TempDir tmp("relief-tex");
  const fs::path& dir = tmp.path;
  relief::Layer px;
  px.channels = 3;
  px.data = {0.2f, 0.4f, 0.6f, 0.2f, 0.4f, 0.6f, 0.2f, 0.4f, 0.6f, 0.2f, 0.4f, 0.6f};
  const std::string file = (dir / "moss.png").string();
  relief::write_file_atomic(file, relief::encode_png_rgb8(px, 2, 2));
  const relief::Frame f = square(33, 1000.0);
  Terrain t = grid(f, [](double, double) { return 1.0; });
  json ty = flat_type("moss", 0.1);
  ty["texture"] = file;
  run(st::biomes(), {{"types", json::array({ty})}, {"bridge", "moss"}, {"beach_lift", 0.0}}, t);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(at(t, "albedo", 7, 9, c), 0.2f + 0.2f * c, 1e-6);
  ty["texture"] = (dir / "missing.png").string();
  try {
    run(st::biomes(), {{"types", json::array({ty})}, {"bridge", "moss"}}, t, 11, 2);
    FAIL() << "expected an error";
  } catch (const relief::Error& e) {
    EXPECT_EQ(e.path(), "stages[2].types[0].texture");
    EXPECT_NE(std::string(e.what()).find("missing.png"), std::string::npos);
  }
  // A colour level of the `color` stage may name a texture too.
  json levels = json::array({{{"at", 1.0}, {"color", "#000000"}, {"texture", file}, {"tile_m", 10.0}}});
  run(st::colorize(), {{"levels", levels}, {"variation", 0.0}, {"rock_slope_deg", 90.0}}, t);
  EXPECT_NEAR(at(t, "albedo", 3, 4, 2), 0.6f, 1e-6);
  levels[0]["texture"] = "nope.png";
  EXPECT_THROW(st::colorize().parse({{"stage", "color"}, {"levels", levels}}, "stages[1]"), relief::Error);
}

TEST(Biomes, BadParametersNameTheField) {
  auto expect = [](json p, const std::string& path) {
    p["stage"] = "biomes";
    try {
      st::biomes().parse(p, "stages[2]");
      ADD_FAILURE() << "no error for " << p.dump();
    } catch (const relief::Error& e) {
      EXPECT_EQ(e.path(), path) << e.what();
    }
  };
  expect({{"types", json::array({{{"name", "a"}, {"octaves", 40}}})}, {"bridge", "a"}}, "stages[2].types[0].octaves");
  expect({{"types", json::array({flat_type("a", 0.1), flat_type("a", 0.2)})}, {"bridge", "a"}}, "stages[2].types[1].name");
  expect({{"types", json::array({flat_type("a", 0.1, 1.0, {"zz"})})}, {"bridge", "a"}}, "stages[2].types[0].avoid[0]");
  expect({{"bridge", "desert"}}, "stages[2].bridge");  // desert avoids forest and mountains
  expect({{"border_m", 2000.0}}, "stages[2].border_m");
  expect({{"blend", "average"}}, "stages[2].blend");
  expect({{"types", json::array()}}, "stages[2].types");
}

// ---- climate -----------------------------------------------------------------------------------

TEST(Climate, TableGivesTheExpectedBiome) {
  const auto table = relief::detail::whittaker_table();
  // (temperature, moisture) → biome, the corners included.
  const struct {
    double t, m;
    const char* name;
  } cases[] = {
      {0.9, 0.9, "tropical rainforest"},
      {0.9, 0.05, "subtropical desert"},
      {0.8, 0.5, "tropical seasonal forest"},
      {0.6, 0.3, "grassland"},
      {0.6, 0.7, "temperate forest"},
      {0.6, 0.95, "temperate rainforest"},
      {0.4, 0.2, "temperate desert"},
      {0.4, 0.5, "shrubland"},
      {0.4, 0.9, "taiga"},
      {0.1, 0.05, "scorched"},
      {0.1, 0.25, "bare rock"},
      {0.1, 0.4, "tundra"},
      {0.1, 0.9, "snow"},
      {1.0, 1.0, "tropical rainforest"},  // the upper edge is included
      {0.0, 0.0, "scorched"},
  };
  for (const auto& c : cases)
    EXPECT_EQ(table[std::size_t(relief::detail::classify(table, c.t, c.m))].name, c.name) << c.t << ", " << c.m;
}

TEST(Climate, DistanceTransformIsExact) {
  const int nx = 41, nz = 29;
  std::vector<unsigned char> src(nx * nz, 0);
  for (int k = 0; k < 9; ++k) src[std::size_t(relief::mix64(k) % (nx * nz))] = 1;
  const auto d = relief::detail::distance_transform(src, nx, nz);
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      double best = 1e300;
      for (int b = 0; b < nz; ++b)
        for (int a = 0; a < nx; ++a)
          if (src[std::size_t(b) * nx + a]) best = std::min(best, std::hypot(a - i, b - j));
      ASSERT_NEAR(d[std::size_t(j) * nx + i], best, 1e-4) << i << "," << j;
    }
  const auto none = relief::detail::distance_transform(std::vector<unsigned char>(12, 0), 4, 3);
  EXPECT_TRUE(std::isinf(none[5]));
}

TEST(Climate, MoistureRisesNearTheSeaAndTemperatureFallsWithHeight) {
  // West half sea, east half a ramp rising eastwards; noise off so the formulas are exact.
  const relief::Frame f = square(101, 2000.0, 500.0, 0.3);
  Terrain t = grid(f, [](double x, double) { return x < 1000.0 ? 0.1 : 0.31 + 0.6 * (x - 1000.0) / 1000.0; });
  run(st::climate(), {{"temperature_noise", 0.0}, {"moisture_noise", 0.0}, {"temperature_base", 0.8}, {"lapse", 1.0},
                      {"moisture_base", 0.2}, {"sea_moisture", 0.5}, {"coast_m", 200.0}},
      t);
  for (int i : {51, 60, 75, 100}) {
    const double x = f.x_m(i), e = at(t, "height", i, 50);
    const double d = x - f.x_m(50);  // the last sea column is i = 49 (x < 1000); 50 is at x = 1000 → land
    const double dsea = x - f.x_m(49);
    EXPECT_NEAR(at(t, "temperature", i, 50), std::max(0.0, 0.8 - (e - 0.3) / 0.7), 1e-5) << i;
    // The sea's share is cut at 8 · coast_m and lowered to meet 0 there (stage_climate.cpp, issue 18).
    const double share = std::max(0.0, (std::exp(-dsea / 200.0) - std::exp(-8.0)) / (1.0 - std::exp(-8.0)));
    EXPECT_NEAR(at(t, "moisture", i, 50), 0.2 + 0.5 * share, 1e-5) << i << " " << d;
  }
  EXPECT_GT(at(t, "moisture", 51, 50), at(t, "moisture", 90, 50));
  EXPECT_EQ(at(t, "biome", 10, 50), 0.0f);
  ASSERT_EQ(t.biomes[0].name, "ocean");
  // The high east is cold and dry enough for bare rock or tundra; the low coast is warm and wet.
  const std::string high = t.biomes[std::size_t(at(t, "biome", 100, 50))].name;
  const std::string low = t.biomes[std::size_t(at(t, "biome", 52, 50))].name;
  EXPECT_TRUE(high == "bare rock" || high == "scorched" || high == "tundra" || high == "temperate desert") << high;
  EXPECT_TRUE(low == "tropical seasonal forest" || low == "tropical rainforest") << low;
}

TEST(Climate, TableMustCoverEveryClimate) {
  json table = json::array({{{"name", "hot"}, {"temperature_min", 0.5}}});
  try {
    st::climate().parse({{"stage", "climate"}, {"table", table}}, "stages[4]");
    FAIL();
  } catch (const relief::Error& e) {
    EXPECT_EQ(e.path(), "stages[4].table");
    EXPECT_NE(std::string(e.what()).find("temperature 0.00"), std::string::npos) << e.what();
  }
}

// ---- volcano, features, jiggle --------------------------------------------------------------

TEST(Volcano, RimStandsHigherThanTheCentreAndLavaFillsTheCrater) {
  const relief::Frame f = square(201, 4000.0, 500.0, 0.3);
  Terrain t = grid(f, [](double, double) { return 0.45; });
  run(st::biomes(), {{"beach_lift", 0.0}}, t);
  run(st::volcano(), {{"placement", "fixed"}, {"x_m", 2000.0}, {"z_m", 2000.0}}, t, 11, 1);
  const auto& h = t.get("height");
  double rim = 0;
  for (int k = 0; k < 64; ++k)
    rim += relief::detail::sample_bilinear(f, h, 2000 + 200 * std::cos(k * 0.09817477), 2000 + 200 * std::sin(k * 0.09817477));
  rim /= 64;
  const double centre = relief::detail::sample_bilinear(f, h, 2000, 2000);
  EXPECT_GT(rim, centre + 0.05);
  EXPECT_GT(rim, 0.3 + 0.3 * 0.7);  // about `height` (0.5 of the land range) above the sea
  const int lava = relief::detail::legend_id(t, "lava", 0, 0, 0);
  EXPECT_EQ(at(t, "biome", 100, 100), float(lava));
  EXPECT_EQ(at(t, "volcano", 100, 100), 1.0f);
  EXPECT_EQ(at(t, "volcano", 10, 10), 0.0f);
  ASSERT_FALSE(t.points.empty());
  EXPECT_EQ(t.points.back().kind, "volcano");
  EXPECT_DOUBLE_EQ(t.points.back().x_m, 2000.0);
}

TEST(Volcano, PlacedOnLandByDefault) {
  // Land only in the east third: the volcano must stand there.
  const relief::Frame f = square(161, 6000.0, 500.0, 0.3);
  Terrain t = grid(f, [](double x, double) { return x > 4000.0 ? 0.5 : 0.1; });
  run(st::volcano(), {{"radius_m", 500.0}, {"rim_radius_m", 150.0}}, t);
  ASSERT_EQ(t.points.size(), 1u);
  EXPECT_GT(t.points[0].x_m, 4000.0 + 400.0);
}

TEST(Features, CratersAndPeaksAreFeaturePointsOnLand) {
  const relief::Frame f = square(201, 4000.0, 500.0, 0.3);
  Terrain t = round_island(f, 1900.0);
  const Terrain before = t;
  run(st::features(), {{"craters", 2}, {"peaks", 2}}, t);
  int craters = 0, peaks = 0;
  for (auto& p : t.points) {
    EXPECT_GT(relief::detail::sample_bilinear(f, before.get("height"), p.x_m, p.z_m), 0.3) << p.kind;
    const double e_now = relief::detail::sample_bilinear(f, t.get("height"), p.x_m, p.z_m);
    const double e_was = relief::detail::sample_bilinear(f, before.get("height"), p.x_m, p.z_m);
    if (p.kind == "crater") {
      ++craters;
      EXPECT_LT(e_now, e_was - 0.02);
    }
    if (p.kind == "peak") {
      ++peaks;
      EXPECT_GT(e_now, e_was + 0.1);
    }
  }
  EXPECT_EQ(craters, 2);
  EXPECT_EQ(peaks, 2);
}

TEST(Jiggle, OffsetsStayWithinTheFractionAndFollowTheWorldGrid) {
  const relief::Frame f = square(65, 640.0);
  Terrain whole = grid(f, [](double, double) { return 0.5; });
  run(st::jiggle(), {{"amount", 0.3}}, whole);
  const auto& o = whole.get("offset");
  ASSERT_EQ(o.channels, 2);
  double biggest = 0;
  for (float v : o.data) biggest = std::max(biggest, double(std::fabs(v)));
  EXPECT_LE(biggest, 0.3 * f.cell_m());
  EXPECT_GT(biggest, 0.25 * f.cell_m());
  Terrain part;
  part.frame = f.window(20, 30, 9, 7);
  part.layer("height", 1);
  run(st::jiggle(), {{"amount", 0.3}}, part);
  for (int j = 0; j < 7; ++j)
    for (int i = 0; i < 9; ++i)
      for (int c = 0; c < 2; ++c) ASSERT_EQ(at(part, "offset", i, j, c), at(whole, "offset", 20 + i, 30 + j, c));
}

TEST(Jiggle, ObjWriterMovesVerticesByTheOffset) {
  const relief::Frame f = square(6, 50.0);
  Terrain t = grid(f, [](double x, double) { return 0.3 + x / 1000.0; });
  run(st::jiggle(), {{"amount", 0.4}}, t);
  relief::MemoryOutput out;
  relief::find_writer("obj")->write(t, {}, out);
  std::istringstream in(out.files.at("terrain.obj"));
  std::string line;
  int k = 0;
  while (std::getline(in, line)) {
    if (line.rfind("v ", 0) != 0) continue;
    double x, y, z;
    ASSERT_EQ(std::sscanf(line.c_str(), "v %lf %lf %lf", &x, &y, &z), 3);
    const int i = k % f.nx, j = k / f.nx;
    EXPECT_NEAR(x, f.x_m(i) + at(t, "offset", i, j, 0), 1e-4) << k;
    EXPECT_NEAR(z, f.z_m(j) + at(t, "offset", i, j, 1), 1e-4) << k;
    EXPECT_NEAR(y, f.y_m(at(t, "height", i, j)), 1e-4) << k;
    ++k;
  }
  EXPECT_EQ(k, 36);
  t.layers["offset"].data.pop_back();
  EXPECT_THROW(relief::find_writer("obj")->write(t, {}, out), relief::Error);
}

// ---- props -------------------------------------------------------------------------------------

namespace {

Terrain props_island(std::uint64_t seed = 11) {
  const relief::Frame f = square(257, 3000.0, 400.0, 0.3);
  Terrain t = round_island(f, 1400.0);
  run(st::biomes(), json::object(), t, seed, 0);
  run(st::volcano(), {{"radius_m", 400.0}, {"rim_radius_m", 120.0}, {"spread_m", 90.0}, {"circle_m", 180.0}}, t, seed, 1);
  return t;
}

json one_prop(double spacing) {
  return json::array({{{"name", "shrub"}, {"biomes", json::array()}, {"wavelength_m", 250.0}, {"tolerance", 0.62},
                       {"spacing_m", spacing}}});
}

}  // namespace

TEST(Props, NeverInTheSeaOnTheVolcanoOrTooClose) {
  Terrain t = props_island();
  run(st::props(), {{"attempts", 30000}}, t, 11, 2);
  const auto& f = t.frame;
  std::vector<const relief::Point*> props;
  for (auto& p : t.points)
    if (p.kind == "prop") props.push_back(&p);
  ASSERT_GT(props.size(), 500u);
  std::map<std::string, double> spacing = {{"tree", 7}, {"pine", 6}, {"bush", 3}, {"rock", 5}, {"cactus", 8}, {"mushroom", 2.5}};
  std::set<std::string> types;
  for (auto* p : props) {
    types.insert(p->type);
    EXPECT_GT(relief::detail::sample_bilinear(f, t.get("height"), p->x_m, p->z_m), f.sea_level);
    EXPECT_GT(p->y_m, 0.0);
    EXPECT_EQ(relief::detail::sample_nearest(f, t.get("volcano"), p->x_m, p->z_m), 0.0f);
    EXPECT_GE(p->rotation_deg, 0.0);
    EXPECT_LT(p->rotation_deg, 360.0);
  }
  for (std::size_t a = 0; a < props.size(); ++a)
    for (std::size_t b = a + 1; b < props.size(); ++b) {
      const double need = std::max(spacing.at(props[a]->type), spacing.at(props[b]->type));
      ASSERT_GE(std::hypot(props[a]->x_m - props[b]->x_m, props[a]->z_m - props[b]->z_m), need)
          << props[a]->type << " and " << props[b]->type;
    }
  EXPECT_GE(types.size(), 4u);
}

TEST(Props, ClusterMoreThanAUniformScatter) {
  Terrain t = props_island();
  run(st::props(), {{"attempts", 40000}, {"types", one_prop(1.0)}, {"max_slope_deg", 90.0}}, t, 11, 2);
  const auto& f = t.frame;
  std::vector<std::pair<double, double>> placed, uniform;
  for (auto& p : t.points)
    if (p.kind == "prop") placed.push_back({p.x_m, p.z_m});
  ASSERT_GT(placed.size(), 300u);
  // The reference: the same count of hashed uniform positions over the same valid area (land, off
  // the volcano), deterministic.
  for (std::uint64_t k = 0; uniform.size() < placed.size(); ++k) {
    const std::uint64_t h = relief::hash64(99, k);
    const double x = relief::unit_double(h) * f.world_width_m, z = relief::unit_double(relief::mix64(h)) * f.world_depth_m;
    if (relief::detail::sample_bilinear(f, t.get("height"), x, z) <= f.sea_level) continue;
    if (relief::detail::sample_nearest(f, t.get("volcano"), x, z) > 0.0f) continue;
    uniform.push_back({x, z});
  }
  auto mean_nn = [](const std::vector<std::pair<double, double>>& v) {
    double s = 0;
    for (std::size_t a = 0; a < v.size(); ++a) {
      double best = 1e300;
      for (std::size_t b = 0; b < v.size(); ++b)
        if (a != b) best = std::min(best, std::hypot(v[a].first - v[b].first, v[a].second - v[b].second));
      s += best;
    }
    return s / double(v.size());
  };
  EXPECT_LT(mean_nn(placed), 0.7 * mean_nn(uniform));
}

TEST(Props, UnknownBiomeNamesTheField) {
  Terrain t = props_island();
  json types = one_prop(2.0);
  types[0]["biomes"] = json::array({"plains", "swamp"});
  try {
    run(st::props(), {{"types", types}}, t, 11, 5);
    FAIL();
  } catch (const relief::Error& e) {
    EXPECT_EQ(e.path(), "stages[5].types[0].biomes[1]");
  }
}

// ---- the preset end to end ----------------------------------------------------------------------

namespace {

relief::RunResult run_preset(const std::string& name, int size, int threads, std::uint64_t seed = 4) {
  json doc = relief::load_preset(name);
  doc["world"]["size"] = size;
  doc["seed"] = seed;
  relief::RunOptions o;
  o.threads = threads;
  return relief::run(relief::parse_recipe(doc), o);
}

}  // namespace

TEST(Preset, SameSeedSamePropsAndBiomesForAnyThreadCount) {
  const auto one = run_preset("volcanic-island", 193, 1);
  std::size_t props = 0;
  for (auto& p : one.terrain.points) props += p.kind == "prop";
  ASSERT_GT(props, 200u);
  for (int threads : {2, 3, 7}) {
    const auto other = run_preset("volcanic-island", 193, threads);
    ASSERT_EQ(other.terrain.points.size(), one.terrain.points.size()) << threads;
    for (std::size_t k = 0; k < one.terrain.points.size(); ++k) {
      const auto &a = one.terrain.points[k], &b = other.terrain.points[k];
      ASSERT_EQ(a.type, b.type);
      ASSERT_EQ(a.x_m, b.x_m);
      ASSERT_EQ(a.y_m, b.y_m);
      ASSERT_EQ(a.z_m, b.z_m);
      ASSERT_EQ(a.rotation_deg, b.rotation_deg);
      ASSERT_EQ(a.scale, b.scale);
    }
    for (const char* l : {"height", "biome", "albedo", "offset"})
      ASSERT_EQ(other.terrain.get(l).data, one.terrain.get(l).data) << l << " " << threads;
  }
}

TEST(Preset, VolcanicIslandHasEverything) {
  const auto r = run_preset("volcanic-island", 257, 2);
  std::set<std::string> kinds, biomes;
  for (auto& p : r.terrain.points) kinds.insert(p.kind);
  EXPECT_TRUE(kinds.count("prop") && kinds.count("volcano") && kinds.count("crater") && kinds.count("peak"));
  for (float v : r.terrain.get("biome").data) biomes.insert(r.terrain.biomes[std::size_t(v)].name);
  for (const char* b : {"ocean", "beach", "volcano", "lava"}) EXPECT_TRUE(biomes.count(b)) << b;
  EXPECT_GE(biomes.size(), 7u);
  EXPECT_TRUE(r.terrain.has("offset"));
}

// ---- writers and pictures -------------------------------------------------------------------------

TEST(IslandWriters, BiomesJsonCountsEveryIdAndThePngUsesTheLegend) {
  const auto r = run_preset("archipelago", 97, 2);
  relief::MemoryOutput out;
  relief::find_writer("biomes")->write(r.terrain, {}, out);
  const json doc = json::parse(out.files.at("biomes.json"));
  double share = 0;
  std::uint64_t samples = 0;
  for (auto& b : doc["biomes"]) share += b["share"].get<double>(), samples += b["samples"].get<std::uint64_t>();
  EXPECT_NEAR(share, 1.0, 1e-12);
  EXPECT_EQ(samples, 97u * 97u);
  EXPECT_EQ(doc["biomes"][0]["name"], "ocean");
  // Decode biome.png and compare a pixel with its legend colour.
  const std::string& png = out.files.at("biome.png");
  spng_ctx* ctx = spng_ctx_new(0);
  spng_set_png_buffer(ctx, png.data(), png.size());
  std::size_t size = 0;
  spng_decoded_image_size(ctx, SPNG_FMT_RGB8, &size);
  std::vector<unsigned char> px(size);
  ASSERT_EQ(spng_decode_image(ctx, px.data(), size, SPNG_FMT_RGB8, 0), 0);
  spng_ctx_free(ctx);
  for (std::size_t k : {std::size_t(0), std::size_t(97 * 48 + 48), std::size_t(97 * 97 - 1)}) {
    const auto& b = r.terrain.biomes[std::size_t(r.terrain.get("biome").data[k])];
    EXPECT_EQ(px[3 * k], std::lround(b.r * 255));
    EXPECT_EQ(px[3 * k + 1], std::lround(b.g * 255));
  }
  // Every legend colour is "#rrggbb" (one format, as the header says), the colour biome.png paints
  // that id with. Before, colours not exact in 8 bits (the archipelago's ocean and beach) were
  // written as [63.75, 140.25…] arrays beside "#555555" strings.
  std::map<long, std::size_t> first;  // id → first sample with it
  const auto& ids = r.terrain.get("biome").data;
  for (std::size_t k = 0; k < ids.size(); ++k) first.emplace(std::lround(ids[k]), k);
  for (const auto& b : doc["biomes"]) {
    ASSERT_TRUE(b["color"].is_string()) << b.dump();
    const std::string c = b["color"].get<std::string>();
    ASSERT_EQ(c.size(), 7u) << c;
    EXPECT_EQ(c[0], '#') << c;
    EXPECT_EQ(c.find_first_not_of("0123456789abcdef", 1), std::string::npos) << c;
    auto it = first.find(b["id"].get<long>());
    if (it == first.end()) continue;
    char want[8];
    std::snprintf(want, sizeof want, "#%02x%02x%02x", px[3 * it->second], px[3 * it->second + 1], px[3 * it->second + 2]);
    EXPECT_EQ(c, want) << b["name"];
  }
}

TEST(IslandWriters, PropsCsvAndJsonListTheSamePropsAsThePoints) {
  const auto r = run_preset("volcanic-island", 129, 2);
  relief::MemoryOutput out;
  relief::find_writer("props")->write(r.terrain, {}, out);
  relief::find_writer("features")->write(r.terrain, {}, out);
  const json doc = json::parse(out.files.at("props.json"));
  std::istringstream csv(out.files.at("props.csv"));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "type,x_m,y_m,z_m,rotation_deg,scale");
  std::size_t n = 0;
  for (auto& p : r.terrain.points) {
    if (p.kind != "prop") continue;
    ASSERT_TRUE(std::getline(csv, line));
    char type[64];
    double x, y, z, rot, sc;
    ASSERT_EQ(std::sscanf(line.c_str(), "%63[^,],%lf,%lf,%lf,%lf,%lf", type, &x, &y, &z, &rot, &sc), 6) << line;
    EXPECT_EQ(p.type, type);
    EXPECT_NEAR(x, p.x_m, 5e-4);
    EXPECT_NEAR(y, p.y_m, 5e-4);
    EXPECT_NEAR(sc, p.scale, 5e-4);
    EXPECT_NEAR(doc["props"][n]["z_m"].get<double>(), p.z_m, 5e-4);
    ++n;
  }
  EXPECT_EQ(doc["count"].get<std::size_t>(), n);
  EXPECT_FALSE(std::getline(csv, line));
  const json feats = json::parse(out.files.at("features.json"))["features"];
  ASSERT_GE(feats.size(), 2u);
  EXPECT_EQ(feats[0]["kind"], "volcano");
}

TEST(IslandWriters, SkippedByTheDefaultSetWhenThereIsNothingToWrite) {
  Terrain t = grid(square(9, 100.0), [](double, double) { return 0.5; });
  for (const char* w : {"biomes", "features", "props"}) {
    const auto* d = relief::find_writer(w);
    ASSERT_TRUE(d->applies) << w;
    EXPECT_FALSE(d->applies(t)) << w;
  }
  relief::MemoryOutput out;
  EXPECT_THROW(relief::find_writer("biomes")->write(t, {}, out), relief::Error);
}

TEST(Steps, PicturesFollowTheStagesAndTheSheetHasThemAll) {
  std::vector<relief::StepImage> steps;
  json doc = relief::load_preset("volcanic-island");
  doc["world"]["size"] = 129;
  doc["seed"] = 2;
  const relief::Recipe r = relief::parse_recipe(doc);
  relief::RunOptions o;
  o.after_stage = [&](const Terrain& t, const relief::RecipeStage& s, int index) {
    relief::StepImage im = relief::render_step(t, 64);
    im.file = relief::step_file_name(index, s.def->name);
    im.caption = s.def->name;
    steps.push_back(std::move(im));
  };
  relief::run(r, o);
  ASSERT_EQ(steps.size(), r.stages.size());
  EXPECT_EQ(steps[0].file, "01-noise.png");
  EXPECT_EQ(steps[3].file, "04-volcano.png");
  EXPECT_EQ(steps[0].width, 65);  // 129 samples, 2×2 area average
  // The biomes step changes the picture; the jiggle step (x/z offsets only) does not.
  EXPECT_NE(steps[1].rgb.data, steps[2].rgb.data);
  EXPECT_EQ(steps[5].rgb.data, steps[6].rgb.data);
  const std::string sheet = relief::contact_sheet_png(steps, "test", 4, 64);
  spng_ctx* ctx = spng_ctx_new(0);
  spng_set_png_buffer(ctx, sheet.data(), sheet.size());
  spng_ihdr ihdr{};
  ASSERT_EQ(spng_get_ihdr(ctx, &ihdr), 0);
  spng_ctx_free(ctx);
  EXPECT_EQ(ihdr.width, 14u + 4u * (64u + 14u));
  EXPECT_EQ(ihdr.height, 40u + 3u * (64u + 24u + 14u) + 7u);
  EXPECT_EQ(relief::step_file_name(11, "My Stage!"), "12-my-stage-.png");
}

TEST(Overrides, SetReachesIntoAStageParameterLeftAtItsDefault) {
  json doc = relief::load_preset("volcanic-island");
  ASSERT_FALSE(doc["stages"][2].contains("types"));
  relief::apply_override(doc, "stages[2].types[1].octaves=3");
  ASSERT_TRUE(doc["stages"][2].contains("types"));
  EXPECT_EQ(doc["stages"][2]["types"][1]["octaves"], 3);
  EXPECT_EQ(doc["stages"][2]["types"][1]["name"], "hills");  // the rest keeps its defaults
  const relief::Recipe r = relief::parse_recipe(doc);
  EXPECT_EQ(r.stages[2].stage->params()["types"][1]["octaves"], 3);
}
