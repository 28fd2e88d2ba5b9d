// World algorithms of the feature stages (relief/world_features.hpp, issue 18): a volcano placed on
// land and `features` over stored tiles equal, bit for bit, the whole-map stages — every layer, the
// biome legend and the points, in order — for several tile sizes and clipped worlds.
//
// Most cases run the algorithms on an in-memory tile store (the whole map's state before the stage,
// split into tiles: the input a world build's earlier phases store, which tests/test_world*.cpp
// show equal to the whole map) and compare with the stage applied to the whole map; that store also
// counts the stores per tile (every tile exactly once) and catches reads of tiles after they were
// stored.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "relief/error.hpp"
#include "relief/pipeline.hpp"
#include "relief/world.hpp"
#include "relief/world_features.hpp"
#include "world_support.hpp"

using namespace relief;
using namespace relief::test::world;

namespace {

void expect_same_legend(const std::vector<BiomeInfo>& a, const std::vector<BiomeInfo>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].name, b[k].name);
    EXPECT_EQ(std::memcmp(&a[k].r, &b[k].r, 4), 0);
    EXPECT_EQ(std::memcmp(&a[k].g, &b[k].g, 4), 0);
    EXPECT_EQ(std::memcmp(&a[k].b, &b[k].b, 4), 0);
  }
}

// An in-memory tile store: tiles cut from a whole-map Terrain, a WorldStageIO over them (no
// load_layers / update: the algorithms' fallbacks), and the result assembled back.
struct MemoryWorld {
  WorldGrid grid;
  Frame world;
  std::map<std::int64_t, WorldTile> in, out;
  std::map<std::int64_t, int> stores;
  std::vector<std::vector<Point>> points;  // one list per io.points call
  bool read_after_store = false;

  MemoryWorld(const Terrain& whole, int tile) {
    world = whole.frame;
    grid = world_grid(whole.frame.nx, whole.frame.nz, tile);
    for (std::int64_t Z = 0; Z < grid.tiles_z; ++Z)
      for (std::int64_t X = 0; X < grid.tiles_x; ++X) {
        WorldTile t;
        t.X = X;
        t.Z = Z;
        t.window = grid.window(X, Z);
        for (auto& [name, l] : whole.layers) {
          Layer c;
          c.channels = l.channels;
          for (int j = 0; j < t.window.nz; ++j) {
            const float* row = l.data.data() + ((std::size_t(t.window.iz0) + std::size_t(j)) * std::size_t(whole.frame.nx) + std::size_t(t.window.ix0)) *
                                                   std::size_t(l.channels);
            c.data.insert(c.data.end(), row, row + std::size_t(t.window.nx) * std::size_t(l.channels));
          }
          t.layers[name] = std::move(c);
        }
        in[Z * grid.tiles_x + X] = std::move(t);
      }
  }
  WorldStageIO io(std::uint64_t seed) {
    WorldStageIO io;
    io.grid = grid;
    io.world = world;
    io.seed = seed;
    io.load = [this](std::int64_t X, std::int64_t Z) {
      if (stores.count(Z * grid.tiles_x + X)) read_after_store = true;
      return in.at(Z * grid.tiles_x + X);
    };
    io.store = [this](std::int64_t X, std::int64_t Z, WorldTile t) {
      ++stores[Z * grid.tiles_x + X];
      out[Z * grid.tiles_x + X] = std::move(t);
    };
    io.points = [this](std::vector<Point> p) { points.push_back(std::move(p)); };
    return io;
  }
  // The stored tiles as one Terrain on the world frame; shared border samples must agree.
  Terrain assemble() const {
    Terrain t;
    t.frame = world;
    for (auto& [k, tile] : out) {
      const WorldGrid::Window& w = tile.window;
      for (auto& [name, l] : tile.layers) {
        Layer& d = t.layer(name, l.channels);
        const std::size_t c = std::size_t(l.channels);
        for (int j = 0; j < w.nz; ++j)
          for (int i = 0; i < w.nx; ++i)
            for (std::size_t q = 0; q < c; ++q) {
              const float v = l.data[(std::size_t(j) * std::size_t(w.nx) + std::size_t(i)) * c + q];
              float& dst = d.data[((std::size_t(w.iz0) + std::size_t(j)) * std::size_t(world.nx) + std::size_t(w.ix0) + std::size_t(i)) * c + q];
              if ((i == 0 && w.ix0 > 0) || (j == 0 && w.iz0 > 0)) {
                EXPECT_EQ(std::memcmp(&dst, &v, 4), 0) << "tiles disagree on a shared sample of " << name;
              }
              dst = v;
            }
      }
    }
    return t;
  }
  void expect_every_tile_stored_once() const {
    EXPECT_EQ(std::int64_t(stores.size()), grid.count());
    for (auto& [k, n] : stores) EXPECT_EQ(n, 1) << "tile " << k;
    EXPECT_FALSE(read_after_store);
  }
};

const StageDef& def_of(const std::string& name) {
  for (const StageDef& d : stage_registry())
    if (d.name == name) return d;
  throw Error("stage", name);
}

RecipeStage stage_of(const std::string& name, json params, int index) {
  params["stage"] = name;
  const StageDef& d = def_of(name);
  return RecipeStage{&d, "", std::shared_ptr<const Stage>(d.parse(params, "stages[" + std::to_string(index) + "]"))};
}

// The whole map's state after each stage of `r` at nx × nz (index → Terrain).
std::map<int, Terrain> whole_states(Recipe r, int nx, int nz) {
  r.world.nx = nx;
  r.world.nz = nz;
  std::map<int, Terrain> states;
  RunOptions opt;
  opt.threads = 2;
  opt.after_stage = [&](const Terrain& t, const RecipeStage&, int i) { states[i] = t; };
  run(r, opt);
  return states;
}

// The algorithm `algo` of stage `st` (at `index`) on `before` split in tiles of `tile`, against
// `after` (the stage applied to the whole map); returns the points it handed over.
std::vector<Point> expect_world_stage_equals_whole(const WorldStageAlgorithm& algo, const RecipeStage& st, int index,
                                                   std::uint64_t seed, const Terrain& before, const Terrain& after, int tile) {
  MemoryWorld w(before, tile);
  algo(w.io(seed), st, index);
  w.expect_every_tile_stored_once();
  expect_same_layers(after, w.assemble());
  EXPECT_EQ(w.points.size(), 1u) << "io.points is called once";
  return w.points.empty() ? std::vector<Point>{} : w.points.front();
}

std::vector<Point> points_of_kind(const std::vector<Point>& all, std::initializer_list<const char*> kinds) {
  std::vector<Point> out;
  for (const Point& p : all)
    for (const char* k : kinds)
      if (p.kind == k) out.push_back(p);
  return out;
}

}  // namespace

// ---- the volcanic-island preset as shipped ------------------------------------------------------

TEST(WorldFeatures, VolcanicIslandVolcanoAndFeaturesOnTilesEqualTheWholeMap) {
  const Recipe r = recipe_of(preset_doc("volcanic-island"), 11);
  int iv = -1, ifeat = -1;
  for (std::size_t i = 0; i < r.stages.size(); ++i) {
    if (r.stages[i].def->name == "volcano") iv = int(i);
    if (r.stages[i].def->name == "features") ifeat = int(i);
  }
  ASSERT_EQ(iv + 1, ifeat);
  for (auto [nx, nz] : {std::pair{513, 513}, std::pair{500, 513}}) {
    const std::map<int, Terrain> whole = whole_states(r, nx, nz);
    const Terrain& before = whole.at(iv - 1);
    const Terrain& with_volcano = whole.at(iv);
    const Terrain& with_features = whole.at(ifeat);
    ASSERT_TRUE(before.has("biome"));
    const std::vector<Point> volcano_points = points_of_kind(with_volcano.points, {"volcano"});
    const std::vector<Point> feature_points = points_of_kind(with_features.points, {"crater", "peak"});
    ASSERT_EQ(volcano_points.size(), 1u);
    ASSERT_EQ(feature_points.size(), 2u);  // the preset's crater and peak
    for (int tile : {65, 129}) {
      SCOPED_TRACE(std::to_string(nx) + "x" + std::to_string(nz) + " tile " + std::to_string(tile));
      auto legend = std::make_shared<std::vector<BiomeInfo>>(before.biomes);
      expect_same_points(volcano_points, expect_world_stage_equals_whole(world_volcano(legend), r.stages[std::size_t(iv)], iv,
                                                                         *r.seed, before, with_volcano, tile));
      expect_same_legend(with_volcano.biomes, *legend);
      expect_same_points(feature_points, expect_world_stage_equals_whole(world_features(), r.stages[std::size_t(ifeat)], ifeat,
                                                                         *r.seed, with_volcano, with_features, tile));
    }
  }
}

TEST(WorldFeatures, VolcanoWithoutTheLegendIsRefusedBeforeAnyTileIsStored) {
  const Recipe r = recipe_of(preset_doc("volcanic-island"), 11);
  const std::map<int, Terrain> whole = whole_states(r, 129, 129);
  MemoryWorld w(whole.at(2), 33);
  try {
    world_volcano()(w.io(11), r.stages[3], 3);
    ADD_FAILURE() << "not refused";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[3]");
    EXPECT_NE(e.message().find("legend"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(w.stores.empty());
}

// ---- constructed cases ---------------------------------------------------------------------------

namespace {

// An n² world whose heights are `f(ix, iz)` (normalised elevation), sea level 0.3, 4000 m wide,
// with an albedo layer (so the colour effects are compared too).
Terrain constructed(int n, const std::function<float(int, int)>& f) {
  Terrain t;
  World wd;
  wd.nx = wd.nz = n;
  wd.sea_level = 0.3;
  t.frame = wd.frame();
  Layer& h = t.layer("height", 1);
  Layer& a = t.layer("albedo", 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      h.data[std::size_t(j) * std::size_t(n) + std::size_t(i)] = f(i, j);
      for (int c = 0; c < 3; ++c) a.data[(std::size_t(j) * std::size_t(n) + std::size_t(i)) * 3 + std::size_t(c)] = 0.2f + 0.1f * float(c);
    }
  return t;
}

Terrain applied(const Terrain& before, const RecipeStage& st, int index, std::uint64_t seed) {
  Terrain t = before;
  Context ctx;
  ctx.seed = seed;
  ctx.stage_index = index;
  st.stage->apply(t, ctx);
  return t;
}

}  // namespace

TEST(WorldFeatures, FeaturesWhoseOnlyLandIsInTheLastTileArePlacedThere) {
  // Sea everywhere but a plateau in the far corner: every candidate in the earlier tiles fails, the
  // first on land comes late in attempt order and lies in the last tile (or across its borders).
  const int n = 257;
  const Terrain before = constructed(n, [](int i, int j) { return i >= 150 && j >= 160 ? 0.55f + 0.0004f * float(i - j) : 0.1f; });
  const RecipeStage st = stage_of("features", {{"craters", 3}, {"peaks", 2}, {"peak_radius_m", 150.0}, {"attempts", 3000}}, 4);
  const Terrain whole = applied(before, st, 4, 21);
  const std::vector<Point> expect = points_of_kind(whole.points, {"crater", "peak"});
  ASSERT_GE(expect.size(), 2u);
  for (const Point& p : expect) EXPECT_GE(p.x_m, 150 * before.frame.cell_m());  // on the plateau
  for (int tile : {33, 65, 129}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    expect_same_points(expect, expect_world_stage_equals_whole(world_features(), st, 4, 21, before, whole, tile));
  }
}

TEST(WorldFeatures, NoCandidateOnLandPlacesNothingAndLeavesEveryTileUnchanged) {
  const int n = 129;
  const Terrain before = constructed(n, [](int i, int j) { return 0.05f + 0.001f * float((i * 7 + j * 3) % 100); });
  const RecipeStage st = stage_of("features", {{"craters", 2}, {"peaks", 1}, {"attempts", 500}}, 1);
  const Terrain whole = applied(before, st, 1, 5);
  EXPECT_TRUE(whole.points.empty());
  expect_same_layers(before, whole);  // the whole map changes nothing
  for (int tile : {17, 65}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    EXPECT_TRUE(expect_world_stage_equals_whole(world_features(), st, 1, 5, before, whole, tile).empty());
  }
  // A volcano placed on land finds no land either: the whole map still places it (the best score
  // among sea candidates) and the world the same.
  const RecipeStage v = stage_of("volcano", {{"radius_m", 300.0}, {"rim_radius_m", 100.0}}, 1);
  const Terrain whole_v = applied(before, v, 1, 5);
  for (int tile : {17, 65}) {
    SCOPED_TRACE("volcano, tile " + std::to_string(tile));
    auto legend = std::make_shared<std::vector<BiomeInfo>>();
    expect_same_points(whole_v.points, expect_world_stage_equals_whole(world_volcano(legend), v, 1, 5, before, whole_v, tile));
  }
}

TEST(WorldFeatures, VolcanoCentredOnATileCornerReadsTheWholeMapsSamples) {
  // Placement fixed (a neighbourhood stage in builds; its world algorithm runs it the same way): the
  // centre and the rim's first point lie exactly on tile borders (integer grid positions where
  // tiles of 65 meet), so the lava level's bilinear reads have weights 0 and must read the samples
  // the whole map reads, not a clamped neighbour.
  const int n = 257;
  const Terrain before = constructed(n, [](int i, int j) { return 0.35f + 0.3f * float(std::sin(i * 0.05) * std::cos(j * 0.04)); });
  const double cell = before.frame.cell_m();
  const RecipeStage st = stage_of("volcano", {{"placement", "fixed"}, {"x_m", 128 * cell}, {"z_m", 64 * cell}, {"radius_m", 100 * cell},
                                              {"rim_radius_m", 64 * cell}},
                                  2);
  ASSERT_EQ(128 * cell / cell, 128.0);  // exactly on the grid
  const Terrain whole = applied(before, st, 2, 9);
  for (int tile : {33, 65, 129}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    auto legend = std::make_shared<std::vector<BiomeInfo>>();
    expect_same_points(whole.points, expect_world_stage_equals_whole(world_volcano(legend), st, 2, 9, before, whole, tile));
  }
}

TEST(WorldFeatures, VolcanoOnLandChosenInALaterTileAndFeaturesKeepClearOfIt) {
  // Land only in the east: the volcano's best candidate lies in a later tile; then features on the
  // rest of the land keep clear of its footprint layer (nearest reads of "volcano").
  const int n = 257;
  const Terrain before = constructed(n, [](int i, int j) { return i > 120 ? 0.5f + 0.2f * float(std::sin(j * 0.03)) : 0.1f; });
  const RecipeStage v = stage_of("volcano", {{"radius_m", 500.0}, {"rim_radius_m", 150.0}}, 2);
  const Terrain with_volcano = applied(before, v, 2, 17);
  ASSERT_EQ(with_volcano.points.size(), 1u);
  EXPECT_GT(with_volcano.points[0].x_m, 120 * before.frame.cell_m());
  const RecipeStage f = stage_of("features", {{"craters", 4}, {"peaks", 2}, {"attempts", 2000}}, 3);
  const Terrain with_features = applied(with_volcano, f, 3, 17);
  ASSERT_GE(with_features.points.size(), 3u);
  for (int tile : {33, 129}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    auto legend = std::make_shared<std::vector<BiomeInfo>>();
    expect_same_points(with_volcano.points, expect_world_stage_equals_whole(world_volcano(legend), v, 2, 17, before, with_volcano, tile));
    const std::vector<Point> feats(with_features.points.begin() + 1, with_features.points.end());
    expect_same_points(feats, expect_world_stage_equals_whole(world_features(), f, 3, 17, with_volcano, with_features, tile));
  }
  // Placement anywhere: no land probes, only the volcano's footprint keeps them off it.
  const RecipeStage g = stage_of("features", {{"placement", "anywhere"}, {"craters", 5}, {"peaks", 2}, {"attempts", 300}}, 3);
  const Terrain anywhere = applied(with_volcano, g, 3, 17);
  ASSERT_GE(anywhere.points.size(), 5u);
  const std::vector<Point> feats(anywhere.points.begin() + 1, anywhere.points.end());
  expect_same_points(feats, expect_world_stage_equals_whole(world_features(), g, 3, 17, with_volcano, anywhere, 65));
}

// ---- through build_world -------------------------------------------------------------------------

namespace {

// build_world of `r` at nx × nz in tiles of `tile` with the feature stages' world algorithms (the
// volcano given the legend of the stages before it: world_legend); their points are captured from
// io.points.
std::map<std::string, std::vector<Point>> build_with_features(const Recipe& r, int nx, int nz, int tile, const std::string& dir) {
  auto captured = std::make_shared<std::map<std::string, std::vector<Point>>>();
  std::size_t iv = 0;
  while (r.stages[iv].def->name != "volcano") ++iv;
  auto legend = std::make_shared<std::vector<BiomeInfo>>(world_legend(r, iv));
  auto capture = [captured](std::string name, WorldStageAlgorithm algo) -> WorldStageAlgorithm {
    return [captured, name, algo](const WorldStageIO& io, const RecipeStage& st, int index) {
      WorldStageIO mine = io;
      mine.points = [captured, name](std::vector<Point> p) { (*captured)[name] = std::move(p); };
      algo(mine, st, index);
    };
  };
  WorldSettings s = settings(r, nx, nz, tile, dir);
  s.algorithms["volcano"] = capture("volcano", world_volcano(legend));
  s.algorithms["features"] = capture("features", world_features());
  build_world(s);
  return *captured;
}

}  // namespace

static void expect_world_equals_whole_map(const Recipe& r) {
  for (auto [nx, nz, tile] : {std::tuple{513, 513, 65}, std::tuple{500, 513, 129}}) {
    SCOPED_TRACE(std::to_string(nx) + "x" + std::to_string(nz) + " tile " + std::to_string(tile));
    const Terrain whole = whole_map(r, nx, nz);
    relief::test::TempDir d("world-features");
    const auto points = build_with_features(r, nx, nz, tile, d / "w");
    expect_same_layers(whole, read_world_window(d / "w", 0, 0, nx, nz));
    ASSERT_TRUE(points.count("volcano") && points.count("features"));
    expect_same_points(points_of_kind(whole.points, {"volcano"}), points.at("volcano"));
    expect_same_points(points_of_kind(whole.points, {"crater", "peak"}), points.at("features"));
  }
}

// The preset without its props stage: the stages after the volcano and features (terrace, jiggle,
// hillshade) then read no biome legend, which build_world's phases do not carry yet.
TEST(WorldFeatures, VolcanicIslandWithoutPropsBuiltAsAWorldEqualsTheWholeMap) {
  json doc = preset_doc("volcanic-island");
  json stages = json::array();
  for (const json& s : doc["stages"])
    if (s["stage"] != "props") stages.push_back(s);
  doc["stages"] = stages;
  expect_world_equals_whole_map(recipe_of(doc, 11));
}

// The preset as shipped: the props stage after the volcano's and features' phases names biomes, so
// the resumed phase must start from the legend the stages before it leave (build_world gives it:
// world_legend), and the volcano numbers its biomes in the legend WorldStageIO::legend gives.
TEST(WorldFeatures, VolcanicIslandPresetBuiltAsAWorldEqualsTheWholeMap) {
  expect_world_equals_whole_map(recipe_of(preset_doc("volcanic-island"), 11));
}

// ---- the legend -------------------------------------------------------------------------------

TEST(WorldFeatures, WorldLegendEqualsTheWholeMapsAfterEveryStage) {
  for (const char* preset : {"volcanic-island", "archipelago"}) {
    SCOPED_TRACE(preset);
    const Recipe r = recipe_of(preset_doc(preset), 11);
    const std::map<int, Terrain> whole = whole_states(r, 257, 257);
    bool some = false;
    for (auto& [i, t] : whole) {
      SCOPED_TRACE("after stage " + std::to_string(i));
      expect_same_legend(t.biomes, world_legend(r, std::size_t(i) + 1));
      some = some || !t.biomes.empty();
    }
    EXPECT_TRUE(some);
    EXPECT_TRUE(world_legend(r, 0).empty());
  }
}
