// World builds at the size (label `slow`): a 2049² world built in tiles of 257, 513 and
// 1025 equals the whole-map build byte for byte, for a recipe whose every stage is exact in world
// builds: the river-island kind with fill, flow and rivers (noise, island, redistribute, fill,
// flow, color, hillshade), and the volcanic-island preset as shipped (a volcano placed on land,
// features, props naming biomes).
#include <gtest/gtest.h>

#include <cmath>

#include "relief/world.hpp"
#include "support.hpp"
#include "world_support.hpp"

using namespace relief;
using namespace relief::test::world;
using relief::test::TempDir;

TEST(WorldExactAtScale, RiverWorld2049InTilesOf257_513_1025EqualsTheWholeMap) {
  const Recipe r = recipe_of(river_world_doc(), 5);
  const int n = 2049;
  const Terrain whole = whole_map(r, n, n);
  ASSERT_TRUE(whole.has("flow"));
  ASSERT_GT(whole.rivers.size(), 10u);
  // The whole map's rivers.json and lakes.json, written by `relief generate`.
  TempDir g("world-exact-generate");
  relief::test::write_text(g.path / "recipe.json", river_world_doc().dump());
  const auto gen = relief::test::relief_cli("generate " + (g / "recipe.json") + " --size " + std::to_string(n) + " --seed 5 -q -f rivers,lakes -o " + g.path.string());
  ASSERT_EQ(gen.code, 0) << gen.out;
  for (int tile : {257, 513, 1025}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    TempDir d("world-exact-" + std::to_string(tile));
    const WorldReport rep = build_world(settings(r, n, n, tile, d / "w"));
    EXPECT_EQ(rep.grid.tiles_x, (n - 1) / (tile - 1));
    expect_same_layers(whole, read_world_window(d / "w", 0, 0, n, n));
    const json m = read_world_manifest(d / "w");
    for (const json& st : m["stages"]) EXPECT_EQ(st.value("world", ""), "exact") << st.dump();
    // The world's rivers and lakes: whole polylines and lakes, the bytes of the whole map's files.
    for (const char* f : {"rivers.json", "lakes.json"})
      EXPECT_TRUE(relief::test::slurp(d.path / "w" / f) == relief::test::slurp(g.path / f)) << f << " differs from the whole map's";
  }
}

// The same river world with lakes: no fill stage, so flow keeps its deep, large depressions as lakes
// (at their spill level) and fills the rest; lakes cross tiles of 257 (the test above fills every
// depression first and so has no lake).
TEST(WorldExactAtScale, RiverWorldWithLakes2049InTilesOf257_513_1025EqualsTheWholeMap) {
  json doc = river_world_doc();
  json stages = json::array();
  for (json st : doc["stages"]) {
    if (st["stage"] == "fill") continue;
    if (st["stage"] == "flow") st["depressions"] = "lakes", st["lake_min_depth_m"] = 0.5, st["lake_min_area_m2"] = 2000.0;
    stages.push_back(st);
  }
  doc["stages"] = stages;
  const Recipe r = recipe_of(doc, 5);
  const int n = 2049;
  const Terrain whole = whole_map(r, n, n);
  ASSERT_GE(whole.lakes.size(), 5u);
  ASSERT_GT(whole.rivers.size(), 10u);
  // Lakes that cross a seam of the tiles of 257 (sample positions i · cell, seams every 256).
  int crossing = 0;
  const double seam_m = 256 * whole.frame.cell_m();
  auto crosses = [&](double a, double b) { return (std::floor(a / seam_m) + 1) * seam_m < b; };  // a seam strictly inside (a, b)
  for (const Lake& l : whole.lakes)
    if (crosses(l.x0_m, l.x1_m) || crosses(l.z0_m, l.z1_m)) ++crossing;
  EXPECT_GE(crossing, 1) << whole.lakes.size() << " lakes";
  TempDir g("world-exact-lakes-generate");
  relief::test::write_text(g.path / "recipe.json", doc.dump());
  const auto gen = relief::test::relief_cli("generate " + (g / "recipe.json") + " --size " + std::to_string(n) + " --seed 5 -q -f rivers,lakes -o " + g.path.string());
  ASSERT_EQ(gen.code, 0) << gen.out;
  ASSERT_GT(relief::test::slurp(g.path / "lakes.json").size(), 1000u);
  for (int tile : {257, 513, 1025}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    TempDir d("world-exact-lakes-" + std::to_string(tile));
    build_world(settings(r, n, n, tile, d / "w"));
    expect_same_layers(whole, read_world_window(d / "w", 0, 0, n, n));
    for (const char* f : {"rivers.json", "lakes.json"})
      EXPECT_TRUE(relief::test::slurp(d.path / "w" / f) == relief::test::slurp(g.path / f)) << f << " differs from the whole map's";
  }
}

TEST(WorldExactAtScale, VolcanicIsland2049InTilesOf257_513_1025EqualsTheWholeMap) {
  const Recipe r = recipe_of(preset_doc("volcanic-island"), 5);
  const int n = 2049;
  const Terrain whole = whole_map(r, n, n);
  ASSERT_TRUE(whole.has("volcano"));
  TempDir g("world-exact-volcanic-generate");
  const auto gen = relief::test::relief_cli("generate volcanic-island --size " + std::to_string(n) +
                                            " --seed 5 -q -f features,props -o " + g.path.string());
  ASSERT_EQ(gen.code, 0) << gen.out;
  for (int tile : {257, 513, 1025}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    TempDir d("world-exact-volcanic-" + std::to_string(tile));
    build_world(settings(r, n, n, tile, d / "w"));
    expect_same_layers(whole, read_world_window(d / "w", 0, 0, n, n));
    const json m = read_world_manifest(d / "w");
    for (const json& st : m["stages"]) EXPECT_EQ(st.value("world", ""), "exact") << st.dump();
    // The volcano's and the features' points (world algorithms) and the props (per tile), merged.
    for (const char* f : {"features.json", "props.json", "props.csv"})
      EXPECT_TRUE(relief::test::slurp(d.path / "w" / f) == relief::test::slurp(g.path / f)) << f << " differs from the whole map's";
  }
}

// The CLI names the world files it wrote, the rivers and lakes among them.
TEST(WorldExactAtScale, TheCliWritesAndNamesTheWorldsRiversAndLakes) {
  TempDir d("world-exact-cli");
  relief::test::write_text(d.path / "recipe.json", river_world_doc().dump());
  const auto r = relief::test::relief_cli("world " + (d / "recipe.json") + " --size 257 --tile 129 --seed 2 -o " + (d / "w"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("(world.json, overview.png, report.json, rivers.json, lakes.json)"), std::string::npos) << r.out;
  EXPECT_TRUE(std::filesystem::exists(d.path / "w" / "rivers.json"));
  EXPECT_TRUE(std::filesystem::exists(d.path / "w" / "lakes.json"));
}
