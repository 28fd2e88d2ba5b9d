// Tilemaps: tile indices (seed 002's base-k corner numbers), tile shapes, the generated atlas,
// classification at the tile grid's vertices, and the Tiled export read back by Tiled itself
// (tmxrasterizer renders our TMX and TMJ; `tiled --export-tileset` reads our Wang set).
#include <gtest/gtest.h>
#include <spng.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "relief/error.hpp"
#include "relief/output.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "relief/stage.hpp"
#include "relief/tilemap.hpp"
#include "support.hpp"

namespace fs = std::filesystem;
using namespace relief;

namespace {

// ---- fixtures --------------------------------------------------------------------------------

using relief::test::relief_cli;
using relief::test::slurp;
using relief::test::TempDir;
using Proc = relief::test::Shell;
constexpr auto shell = relief::test::sh;

// Qt tools headless: offscreen platform and a private runtime directory (mode 0700).
std::string qt_env(const TempDir& d) {
  const std::string rt = d / "xdg-runtime";
  fs::create_directories(rt);
  ::chmod(rt.c_str(), 0700);
  return "QT_QPA_PLATFORM=offscreen XDG_RUNTIME_DIR='" + rt + "' ";
}

struct Rgba {
  int w = 0, h = 0;
  std::vector<std::uint8_t> px;  // 4 bytes per pixel
  const std::uint8_t* at(int x, int y) const { return px.data() + (std::size_t(y) * w + x) * 4; }
};
Rgba decode_png(const std::string& png) {
  test::Png d = test::decode_png(png, SPNG_FMT_RGBA8);
  return {d.width(), d.height(), std::move(d.bytes)};
}

// The first k default types (deep water, water, sand, grass, forest, rock), plus snow and lava
// for k = 7, 8.
TileStyle style_k(int k, int px = 16) {
  TileStyle s;
  s.tile_px = px;
  auto lv = default_tile_types();
  lv.push_back({1.0, Rgb{0.95f, 0.95f, 0.97f}, "snow"});
  lv.push_back({1.0, Rgb{0.85f, 0.25f, 0.1f}, "lava"});
  for (int t = 0; t < k; ++t) s.types.push_back({lv[std::size_t(t)].name, lv[std::size_t(t)].color, lv[std::size_t(t)].at});
  s.seed = 99;
  return s;
}

// Rotates corners a quarter turn clockwise: the old bottom-left becomes the top-left, and so on.
TileCorners rotate(const TileCorners& c) { return {c.bl, c.tl, c.br, c.tr}; }
// The same quarter turn of an S × S image: new(X, Y) = old(Y, S − 1 − X).
std::vector<std::uint8_t> rotate(const std::vector<std::uint8_t>& m, int S) {
  std::vector<std::uint8_t> r(m.size());
  for (int Y = 0; Y < S; ++Y)
    for (int X = 0; X < S; ++X) r[std::size_t(Y) * S + X] = m[std::size_t(S - 1 - X) * S + Y];
  return r;
}

TileShape shape_of(const TileCorners& c, int k) { return tile_shape(tile_index(c, k), k, Precedence::Lower); }

// A terrain with height(i, j) on an nx × nz grid over a 4000 m wide world.
Terrain terrain(int nx, int nz, double sea, const std::function<double(int, int)>& h) {
  Terrain t;
  t.frame.nx = nx;
  t.frame.nz = nz;
  t.frame.world_width_m = 4000;
  t.frame.spacing_m = 4000.0 / (nx - 1);
  t.frame.world_depth_m = t.frame.spacing_m * (nz - 1);
  t.frame.sea_level = sea;
  auto& l = t.layer("height", 1);
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) l.data[std::size_t(j) * nx + i] = float(h(i, j));
  return t;
}

void apply_tilemap(Terrain& t, json params, std::uint64_t seed = 5) {
  params["stage"] = "tilemap";
  auto st = find_stage("tilemap")->parse(params, "stages[0]");
  Context ctx;
  ctx.seed = seed;
  st->apply(t, ctx);
}

json types_json(int k) {
  json a = json::array();
  const TileStyle s = style_k(k);
  for (int t = 0; t < k; ++t)
    a.push_back({{"at", s.types[std::size_t(t)].max_elevation}, {"color", write_color(s.types[std::size_t(t)].color)},
                 {"name", s.types[std::size_t(t)].name}});
  return a;
}

}  // namespace

// ---- indices -----------------------------------------------------------------------------------

TEST(TileIndex, SeedExamples) {
  EXPECT_EQ(tile_index({1, 0, 0, 0}, 2), 8);   // land at the top-left alone: binary 1000
  EXPECT_EQ(tile_index({2, 0, 1, 0}, 3), 57);  // the seed's base-3 "2010"
  EXPECT_EQ(tile_index({0, 0, 0, 1}, 2), 1);
  EXPECT_EQ(tile_index({1, 1, 1, 1}, 2), 15);
}

TEST(TileIndex, RoundTripForKTwoToEight) {
  for (int k = 2; k <= 8; ++k) {
    std::set<int> seen;
    for (int a = 0; a < k; ++a)
      for (int b = 0; b < k; ++b)
        for (int c = 0; c < k; ++c)
          for (int d = 0; d < k; ++d) {
            const TileCorners tc{a, b, c, d};
            const int i = tile_index(tc, k);
            ASSERT_EQ(tile_corners(i, k), tc) << "k=" << k << " index " << i;
            ASSERT_EQ(i, ((a * k + b) * k + c) * k + d);
            seen.insert(i);
          }
    EXPECT_EQ(int(seen.size()), base_tile_count(k));
    EXPECT_EQ(*seen.rbegin(), base_tile_count(k) - 1);
  }
}

TEST(TileIndex, TwoTypesGiveSixteenBaseTilesAndThreeGiveEightyOne) {
  EXPECT_EQ(base_tile_count(2), 16);
  EXPECT_EQ(base_tile_count(3), 81);
  // Plus k(k−1) saddle variants and k solid variants: k² columns × (k² + 1) rows exactly.
  EXPECT_EQ(tile_count(2), 20);
  EXPECT_EQ(tile_count(3), 90);
  for (int k = 2; k <= 8; ++k) EXPECT_EQ(tile_count(k), atlas_columns(k) * atlas_rows(k));
}

TEST(TileIndex, VariantsFollowTheBaseTiles) {
  for (int k = 2; k <= 6; ++k) {
    std::set<int> saddles;
    for (int a = 0; a < k; ++a)
      for (int b = 0; b < k; ++b) {
        if (a == b) continue;
        const TileCorners c{a, b, b, a};
        ASSERT_TRUE(is_saddle(c));
        const int v = saddle_variant_index(c, k);
        EXPECT_GE(v, base_tile_count(k));
        EXPECT_LT(v, base_tile_count(k) + saddle_variant_count(k));
        EXPECT_EQ(tile_corners(v, k), c);
        saddles.insert(v);
      }
    EXPECT_EQ(int(saddles.size()), saddle_variant_count(k));
    for (int t = 0; t < k; ++t) {
      EXPECT_EQ(solid_variant_index(t, k), base_tile_count(k) + saddle_variant_count(k) + t);
      EXPECT_EQ(tile_corners(solid_variant_index(t, k), k), (TileCorners{t, t, t, t}));
    }
  }
  // k = 2: the two saddles 0110 (6) and 1001 (9) get variants 16 and 17, in base index order.
  EXPECT_EQ(saddle_variant_index({0, 1, 1, 0}, 2), 16);
  EXPECT_EQ(saddle_variant_index({1, 0, 0, 1}, 2), 17);
  EXPECT_FALSE(is_saddle({0, 1, 0, 1}));
}

TEST(TileIndex, OutOfRangeThrows) {
  EXPECT_THROW(tile_index({2, 0, 0, 0}, 2), Error);
  EXPECT_THROW(tile_index({0, 0, 0, -1}, 3), Error);
  EXPECT_THROW(tile_corners(20, 2), Error);
  EXPECT_THROW(tile_corners(-1, 2), Error);
  EXPECT_THROW(tile_corners(0, 9), Error);
  EXPECT_THROW(saddle_variant_index({0, 0, 1, 1}, 2), Error);
}

// ---- shapes ------------------------------------------------------------------------------------

TEST(TileShape, SixUniqueTwoTypeShapesUpToRotation) {
  const int S = 16;
  // Orbits of the 16 corner patterns under quarter turns.
  std::set<std::set<int>> orbits;
  for (int i = 0; i < 16; ++i) {
    std::set<int> orbit;
    TileCorners c = tile_corners(i, 2);
    for (int r = 0; r < 4; ++r, c = rotate(c)) orbit.insert(tile_index(c, 2));
    orbits.insert(orbit);
  }
  EXPECT_EQ(orbits.size(), 6u);  // all water, all land, one corner, half, three corners, saddle
  // Rotating the corners rotates the drawn shape exactly.
  for (int i = 0; i < 16; ++i) {
    const TileCorners c = tile_corners(i, 2);
    EXPECT_EQ(tile_type_map(shape_of(rotate(c), 2), S), rotate(tile_type_map(shape_of(c, 2), S), S)) << "tile " << i;
  }
  // The six orbit shapes differ from each other under every rotation.
  std::vector<std::vector<std::uint8_t>> reps;
  for (auto& o : orbits) reps.push_back(tile_type_map(shape_of(tile_corners(*o.begin(), 2), 2), S));
  for (std::size_t a = 0; a < reps.size(); ++a)
    for (std::size_t b = a + 1; b < reps.size(); ++b) {
      auto r = reps[b];
      for (int q = 0; q < 4; ++q, r = rotate(r, S)) EXPECT_NE(reps[a], r) << a << " vs " << b;
    }
}

TEST(TileShape, EveryBaseTileOfThreeTypesHasItsOwnShape) {
  std::set<std::string> shapes;
  for (int i = 0; i < 81; ++i) {
    const auto m = tile_type_map(tile_shape(i, 3, Precedence::Lower), 16);
    shapes.insert(std::string(m.begin(), m.end()));
  }
  EXPECT_EQ(shapes.size(), 81u);
}

TEST(TileShape, CornersAndEdgeMidpointsOfTwoTypeTiles) {
  const int S = 32;
  for (int i = 0; i < 16; ++i) {
    const TileCorners c = tile_corners(i, 2);
    const auto m = tile_type_map(shape_of(c, 2), S);
    EXPECT_EQ(m[0], c.tl) << i;
    EXPECT_EQ(m[S - 1], c.tr) << i;
    EXPECT_EQ(m[std::size_t(S - 1) * S], c.bl) << i;
    EXPECT_EQ(m[std::size_t(S) * S - 1], c.br) << i;
    // Marching squares with 0/1 corners: a mixed edge changes type at its midpoint.
    if (c.tl != c.tr) {
      EXPECT_EQ(m[S / 2 - 1], c.tl) << i;
      EXPECT_EQ(m[S / 2], c.tr) << i;
    }
  }
}

TEST(TileShape, PrecedenceConnectsTheFavouredTypeThroughSaddles) {
  const int S = 32;
  auto centre = [&](const TileShape& sh) {
    const auto m = tile_type_map(sh, S);
    return std::array<int, 4>{m[std::size_t(S / 2 - 1) * S + S / 2 - 1], m[std::size_t(S / 2 - 1) * S + S / 2],
                              m[std::size_t(S / 2) * S + S / 2 - 1], m[std::size_t(S / 2) * S + S / 2]};
  };
  for (const TileCorners c : {TileCorners{0, 1, 1, 0}, TileCorners{1, 0, 0, 1}}) {
    const int base = tile_index(c, 2), variant = saddle_variant_index(c, 2);
    EXPECT_EQ(centre(tile_shape(base, 2, Precedence::Lower)), (std::array<int, 4>{0, 0, 0, 0}));  // water wins
    EXPECT_EQ(centre(tile_shape(variant, 2, Precedence::Lower)), (std::array<int, 4>{1, 1, 1, 1}));
    EXPECT_EQ(centre(tile_shape(base, 2, Precedence::Higher)), (std::array<int, 4>{1, 1, 1, 1}));
    EXPECT_EQ(centre(tile_shape(variant, 2, Precedence::Higher)), (std::array<int, 4>{0, 0, 0, 0}));
  }
}

// Seams: an edge column of a tile depends only on the two corners of that edge, so any two tiles
// that share an edge join without a step.
TEST(TileShape, EdgePixelsDependOnlyOnTheEdgeCorners) {
  const int k = 3;
  for (int S : {16, 32}) {
    std::map<std::pair<int, int>, std::vector<std::uint8_t>> right, top;
    for (int i = 0; i < tile_count(k); ++i) {
      const TileShape sh = tile_shape(i, k, Precedence::Lower);
      const auto m = tile_type_map(sh, S);
      std::vector<std::uint8_t> col, row(m.begin(), m.begin() + S);
      for (int y = 0; y < S; ++y) col.push_back(m[std::size_t(y) * S + S - 1]);
      auto [it, fresh] = right.try_emplace({sh.corners.tr, sh.corners.br}, col);
      EXPECT_TRUE(fresh || it->second == col) << "tile " << i << " S " << S;
      auto [jt, fresh2] = top.try_emplace({sh.corners.tl, sh.corners.tr}, row);
      EXPECT_TRUE(fresh2 || jt->second == row) << "tile " << i << " S " << S;
    }
  }
}

// ---- atlas -------------------------------------------------------------------------------------

// Each tile of the atlas (decoded from its PNG) shows, in each corner, the colour nearest to that
// corner's type — checked against tile_corners(index), for k = 2..6 and all tiles and variants.
TEST(Atlas, EveryTileShowsItsCornerTypesInTheRightCorners) {
  for (int k = 2; k <= 6; ++k) {
    const TileStyle s = style_k(k, 16);
    const RgbImage atlas = render_atlas(s);
    const Rgba img = decode_png(encode_png_rgb8(atlas.rgb.data(), atlas.width, atlas.height));
    ASSERT_EQ(img.w, atlas_columns(k) * 16);
    ASSERT_EQ(img.h, atlas_rows(k) * 16);
    auto nearest = [&](int x0, int y0) {  // mean of a 3×3 block, nearest type colour
      double c[3] = {0, 0, 0};
      for (int y = y0; y < y0 + 3; ++y)
        for (int x = x0; x < x0 + 3; ++x)
          for (int ch = 0; ch < 3; ++ch) c[ch] += img.at(x, y)[ch] / 9.0;
      int best = -1;
      double bd = 1e9;
      for (int t = 0; t < k; ++t) {
        const Rgb& r = s.types[std::size_t(t)].color;
        const double d = std::pow(c[0] - r.r * 255, 2) + std::pow(c[1] - r.g * 255, 2) + std::pow(c[2] - r.b * 255, 2);
        if (d < bd) bd = d, best = t;
      }
      return best;
    };
    for (int i = 0; i < tile_count(k); ++i) {
      const TileCorners c = tile_corners(i, k);
      const int x = (i % atlas_columns(k)) * 16, y = (i / atlas_columns(k)) * 16;
      ASSERT_EQ(nearest(x, y), c.tl) << "k " << k << " tile " << i;
      ASSERT_EQ(nearest(x + 13, y), c.tr) << "k " << k << " tile " << i;
      ASSERT_EQ(nearest(x, y + 13), c.bl) << "k " << k << " tile " << i;
      ASSERT_EQ(nearest(x + 13, y + 13), c.br) << "k " << k << " tile " << i;
    }
  }
}

TEST(Atlas, FlatColoursWithoutTextureOrEdges) {
  TileStyle s = style_k(3, 16);
  s.texture = 0;
  s.edges = 0;
  const RgbImage t = render_tile(tile_index({2, 2, 2, 2}, 3), s);
  for (std::size_t p = 0; p < t.rgb.size(); p += 3) {
    ASSERT_EQ(t.rgb[p], std::uint8_t(std::lround(s.types[2].color.r * 255)));
    ASSERT_EQ(t.rgb[p + 2], std::uint8_t(std::lround(s.types[2].color.b * 255)));
  }
  s.texture = 1;
  const RgbImage u = render_tile(tile_index({2, 2, 2, 2}, 3), s);
  EXPECT_NE(u.rgb, t.rgb);  // the texture shows
}

TEST(Atlas, SameStyleSameBytes) {
  const TileStyle s = style_k(4, 16);
  const RgbImage a = render_atlas(s);
  RgbImage b;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    b = render_atlas(s);
  }
  EXPECT_EQ(a.rgb, b.rgb);
  TileStyle s2 = s;
  s2.seed = 100;
  EXPECT_NE(render_atlas(s2).rgb, a.rgb);  // the texture follows the seed
}

// ---- classification ------------------------------------------------------------------------------

TEST(Classify, VerticesOnSamplesTakeTheSampleType) {
  // 9 samples, 4 tiles: vertex u sits exactly on sample 2u.
  Terrain t = terrain(9, 9, 0.4, [](int i, int j) { return (i + 9 * j) / 81.0; });
  apply_tilemap(t, {{"tiles_x", 4}, {"tiles_z", 4}, {"tile_size", 8}, {"types", types_json(6)}});
  ASSERT_TRUE(t.tilemap);
  const TileMap& m = *t.tilemap;
  const auto th = style_k(6).types;
  for (int v = 0; v <= 4; ++v)
    for (int u = 0; u <= 4; ++u) {
      const float e = t.layers["height"].data[std::size_t(2 * v) * 9 + 2 * u];
      int want = 5;
      for (int c = 0; c < 6; ++c)
        if (e <= float(th[std::size_t(c)].max_elevation)) {
          want = c;
          break;
        }
      EXPECT_EQ(m.corner_v[std::size_t(v) * 5 + u], want) << u << "," << v;
    }
  for (int v = 0; v < 4; ++v)
    for (int u = 0; u < 4; ++u) EXPECT_EQ(tile_corners(int(m.tile_t[std::size_t(v) * 4 + u]), 6), m.corners(u, v));
}

TEST(Classify, VerticesBetweenSamplesInterpolateBilinearly) {
  // 3 × 3 samples, 2 × 2 tiles … and 3 tiles across: vertex 1 sits at sample 2/3.
  Terrain t = terrain(3, 3, 0.4, [](int i, int) { return i == 0 ? 0.0 : i == 1 ? 0.6 : 0.9; });
  json two = {{{"at", 0.39}, {"color", "#0000ff"}, {"name", "water"}}, {{"at", 1.0}, {"color", "#00ff00"}, {"name", "land"}}};
  apply_tilemap(t, {{"tiles_x", 3}, {"tiles_z", 1}, {"tile_size", 8}, {"types", two}});
  // Vertices at samples 0, 2/3, 4/3, 2: elevations 0, 0.4, 0.7, 0.9.
  EXPECT_EQ(std::vector<int>(t.tilemap->corner_v.begin(), t.tilemap->corner_v.begin() + 4), (std::vector<int>{0, 1, 1, 1}));
  two[0]["at"] = 0.41;  // 0.4 is now water
  apply_tilemap(t, {{"tiles_x", 3}, {"tiles_z", 1}, {"tile_size", 8}, {"types", two}});
  EXPECT_EQ(std::vector<int>(t.tilemap->corner_v.begin(), t.tilemap->corner_v.begin() + 4), (std::vector<int>{0, 0, 1, 1}));
}

TEST(Classify, ThresholdsFollowTheSeaLevel) {
  // Sea level 0.2, elevation 0.21: just above the sea. Remapped: 0.4 + 0.01 · 0.6/0.8 = 0.4075,
  // sand (0.40 < e ≤ 0.43). Compared as is, 0.21 ≤ 0.30 is deep water.
  Terrain t = terrain(3, 3, 0.2, [](int, int) { return 0.21; });
  apply_tilemap(t, {{"tiles_x", 2}, {"tiles_z", 2}, {"tile_size", 8}});
  EXPECT_EQ(t.tilemap->corner_v[0], 2);
  apply_tilemap(t, {{"tiles_x", 2}, {"tiles_z", 2}, {"tile_size", 8}, {"sea_relative", false}});
  EXPECT_EQ(t.tilemap->corner_v[0], 0);
  // At the reference sea level the thresholds apply unchanged: 0.41 is sand, 0.40 water.
  Terrain u = terrain(3, 3, 0.4, [](int i, int) { return i == 0 ? 0.40 : 0.41; });
  apply_tilemap(u, {{"tiles_x", 2}, {"tiles_z", 2}, {"tile_size", 8}});
  EXPECT_EQ(u.tilemap->corner_v[0], 1);
  EXPECT_EQ(u.tilemap->corner_v[1], 2);
}

TEST(Classify, BiomeLayerThroughTheMapping) {
  // Biome ids 0..3 by column; mapping id → type [2, 0, 1, 1].
  Terrain t = terrain(5, 5, 0.4, [](int, int) { return 0.5; });
  auto& b = t.layer("biome", 1);
  for (int j = 0; j < 5; ++j)
    for (int i = 0; i < 5; ++i) b.data[std::size_t(j) * 5 + i] = float(std::min(i, 3));
  apply_tilemap(t, {{"tiles_x", 4}, {"tiles_z", 4}, {"tile_size", 8}, {"types", types_json(3)}, {"classify", "biome"},
                    {"biome_types", {2, 0, 1, 1}}});
  const TileMap& m = *t.tilemap;
  EXPECT_EQ(m.classify, TileMap::Classify::Biome);
  for (int v = 0; v <= 4; ++v)
    EXPECT_EQ(std::vector<int>(m.corner_v.begin() + v * 5, m.corner_v.begin() + v * 5 + 5), (std::vector<int>{2, 0, 1, 1, 1}));
  // Ids are not interpolated: 3 tiles over 5 samples put the vertices at samples 0, 4/3, 8/3, 4,
  // which take the nearest samples 0, 1, 3, 4 (ids 0, 1, 3, 3).
  apply_tilemap(t, {{"tiles_x", 3}, {"tiles_z", 1}, {"tile_size", 8}, {"types", types_json(4)}, {"classify", "biome"},
                    {"biome_types", {0, 1, 2, 3}}});
  EXPECT_EQ(std::vector<int>(t.tilemap->corner_v.begin(), t.tilemap->corner_v.begin() + 4), (std::vector<int>{0, 1, 3, 3}));
}

TEST(Classify, BiomeWithoutLayerOrMappingIsAnError) {
  Terrain t = terrain(5, 5, 0.4, [](int, int) { return 0.5; });
  try {
    apply_tilemap(t, {{"classify", "biome"}, {"biome_types", {0, 1}}, {"tiles_x", 4}, {"tiles_z", 4}});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no 'biome' layer"), std::string::npos) << e.what();
  }
  // A mapping is required, and its types must exist.
  EXPECT_THROW(apply_tilemap(t, {{"classify", "biome"}}), Error);
  try {
    apply_tilemap(t, {{"classify", "biome"}, {"biome_types", {0, 6}}, {"types", types_json(3)}});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[0].biome_types[1]");
  }
  // An id beyond the mapping.
  auto& b = t.layer("biome", 1);
  std::fill(b.data.begin(), b.data.end(), 5.0f);
  EXPECT_THROW(apply_tilemap(t, {{"classify", "biome"}, {"biome_types", {0, 1}}, {"tiles_x", 4}, {"tiles_z", 4}}), Error);
}

TEST(Classify, BadParametersNameTheField) {
  Terrain t = terrain(5, 5, 0.4, [](int, int) { return 0.5; });
  auto path_of = [&](json p) {
    try {
      apply_tilemap(t, p);
    } catch (const Error& e) {
      return e.path();
    }
    return std::string("no error");
  };
  EXPECT_EQ(path_of({{"tile_size", 4}}), "stages[0].tile_size");
  EXPECT_EQ(path_of({{"tiles_x", 0}}), "stages[0].tiles_x");
  EXPECT_EQ(path_of({{"tiles_x", 1024}, {"tile_size", 64}}), "stages[0].tiles_x");  // a 65536 px wide render
  EXPECT_EQ(path_of({{"types", json::array({{{"at", 1}, {"color", "#ffffff"}}})}}), "stages[0].types");  // k = 1
  json nine = json::array();
  for (int i = 0; i < 9; ++i) nine.push_back({{"at", (i + 1) / 9.0}, {"color", "#808080"}});
  EXPECT_EQ(path_of({{"types", nine}}), "stages[0].types");
  EXPECT_EQ(path_of({{"precedence", "middle"}}), "stages[0].precedence");
  EXPECT_EQ(path_of({{"saddle_variants", 1.5}}), "stages[0].saddle_variants");
  EXPECT_EQ(path_of({{"tile_sise", 32}}), "stages[0].tile_sise");
}

// ---- variants --------------------------------------------------------------------------------------

TEST(Variants, ChosenFromTheSeedAndTheShare) {
  // Vertices in a checkerboard: every tile is a saddle.
  Terrain t = terrain(33, 33, 0.4, [](int i, int j) { return ((i / 2 + j / 2) % 2) ? 0.9 : 0.1; });
  json two = {{{"at", 0.4}, {"color", "#0000ff"}, {"name", "water"}}, {{"at", 1.0}, {"color", "#00ff00"}, {"name", "land"}}};
  auto tiles = [&](double share, std::uint64_t seed) {
    apply_tilemap(t, {{"tiles_x", 16}, {"tiles_z", 16}, {"tile_size", 8}, {"types", two}, {"saddle_variants", share}}, seed);
    return t.tilemap->tile_t;
  };
  auto variants = [](const std::vector<std::uint32_t>& v) {
    return std::count_if(v.begin(), v.end(), [](auto i) { return i >= 16; });
  };
  const auto none = tiles(0.0, 1), all = tiles(1.0, 1), half = tiles(0.5, 1);
  for (auto i : none) ASSERT_TRUE(i == 6 || i == 9) << i;  // only saddles
  EXPECT_EQ(variants(none), 0);
  EXPECT_EQ(variants(all), 256);
  EXPECT_GT(variants(half), 128 - 40);
  EXPECT_LT(variants(half), 128 + 40);
  EXPECT_EQ(tiles(0.5, 1), half);  // deterministic
  EXPECT_NE(tiles(0.5, 2), half);  // and seeded
  for (std::size_t i = 0; i < half.size(); ++i) EXPECT_EQ(tile_corners(int(half[i]), 2), tile_corners(int(none[i]), 2));
}

// ---- Tiled ----------------------------------------------------------------------------------------

namespace {

// Runs the island preset with a small tilemap and writes the tilemap files into `dir`.
TileMap write_island_tilemap(const TempDir& dir, json tilemap_params, int size = 97) {
  json doc = load_preset("island");
  doc["world"]["size"] = size;
  doc["seed"] = 4;
  tilemap_params["stage"] = "tilemap";
  doc["stages"].push_back(tilemap_params);
  const RunResult r = run(parse_recipe(doc));
  FileOutput out(dir.path.string());
  WriteContext wc;
  wc.seed = r.seed;
  find_writer("tilemap")->write(r.terrain, wc, out);
  return *r.terrain.tilemap;
}

}  // namespace

// tmxrasterizer draws our TMX and TMJ pixel for pixel as each tile drawn on its own from its
// corner types; a wrong gid, column count or image path would show a wrong tile or Tiled's red X.
TEST(Tiled, RasterizerRendersTmxAndTmjLikeTheCornerTypes) {
  TempDir d;
  const int S = 16, W = 24, H = 18;
  const TileMap m = write_island_tilemap(d, {{"tiles_x", W}, {"tiles_z", H}, {"tile_size", S}, {"saddle_variants", 0.5},
                                             {"solid_variants", 0.5}});
  // The map uses many tiles, solid variants among them.
  std::set<std::uint32_t> used(m.tile_t.begin(), m.tile_t.end());
  EXPECT_GT(used.size(), 20u);
  EXPECT_TRUE(std::any_of(used.begin(), used.end(), [&](auto i) { return int(i) >= base_tile_count(m.style.k()); }));
  // Each tile drawn on its own from its corner types (and variant), keyed by index.
  std::map<std::uint32_t, RgbImage> own;
  for (auto i : used) own[i] = render_tile(int(i), m.style);
  for (const char* map : {"tilemap.tmx", "tilemap.tmj"}) {
    const std::string png = d / (std::string(map) + ".png");
    const Proc r = shell(qt_env(d) + "tmxrasterizer '" + (d / map) + "' '" + png + "'");
    ASSERT_EQ(r.code, 0) << map << ": " << r.out;
    const Rgba img = decode_png(slurp(png));
    ASSERT_EQ(img.w, W * S) << map;
    ASSERT_EQ(img.h, H * S) << map;
    int bad_tiles = 0;
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        const std::uint32_t id = m.tile_t[std::size_t(v) * W + u];
        EXPECT_EQ(tile_corners(int(id), m.style.k()), m.corners(u, v));
        const RgbImage& t = own[id];
        bool same = true;
        for (int y = 0; y < S && same; ++y)
          for (int x = 0; x < S && same; ++x) {
            const std::uint8_t* p = img.at(u * S + x, v * S + y);
            const std::uint8_t* q = t.rgb.data() + (std::size_t(y) * S + x) * 3;
            same = p[0] == q[0] && p[1] == q[1] && p[2] == q[2] && p[3] == 255;
          }
        bad_tiles += !same;
      }
    EXPECT_EQ(bad_tiles, 0) << map;
  }
  // Relief's own render is the same picture.
  const Rgba ours = decode_png(slurp(d / "tilemap.png"));
  const Rgba tiled = decode_png(slurp(d / "tilemap.tmx.png"));
  ASSERT_EQ(ours.px.size(), tiled.px.size());
  EXPECT_TRUE(ours.px == tiled.px);
}

// The TSX, read by an XML parser: one corner Wang set whose wangids list each tile's corner types
// in Tiled's order (top, top-right, right, bottom-right, bottom, bottom-left, left, top-left;
// corners in the odd slots, colours 1-based).
TEST(Tiled, TsxWangIdsMatchTheCornerTypes) {
  TempDir d;
  const TileMap m = write_island_tilemap(d, {{"tiles_x", 8}, {"tiles_z", 8}, {"tile_size", 16}}, 33);
  const int k = m.style.k();
  std::ofstream(d / "read.py") << R"(
import sys, xml.etree.ElementTree as ET
ts = ET.parse(sys.argv[1]).getroot()
print("tileset", ts.get("tilecount"), ts.get("columns"), ts.get("tilewidth"))
ws = ts.find("wangsets").findall("wangset")
print("wangsets", len(ws), ws[0].get("type"), len(ws[0].findall("wangcolor")))
for t in ws[0].findall("wangtile"):
    print("tile", t.get("tileid"), t.get("wangid").replace(",", " "))
)";
  const Proc r = shell(std::string(RELIEF_SYSTEM_PYTHON) + " '" + (d / "read.py") + "' '" + (d / "tileset.tsx") + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  std::istringstream in(r.out);
  std::string line;
  int tiles = 0;
  std::set<int> ids;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "tileset") {
      int count = 0, cols = 0, w = 0;
      ls >> count >> cols >> w;
      EXPECT_EQ(count, tile_count(k));
      EXPECT_EQ(cols, k * k);
      EXPECT_EQ(w, 16);
    } else if (tag == "wangsets") {
      int n = 0, colors = 0;
      std::string type;
      ls >> n >> type >> colors;
      EXPECT_EQ(n, 1);
      EXPECT_EQ(type, "corner");
      EXPECT_EQ(colors, k);
    } else if (tag == "tile") {
      int id = -1;
      std::array<int, 8> w{};
      ls >> id;
      for (int& x : w) ls >> x;
      const TileCorners c = tile_corners(id, k);
      EXPECT_EQ(w, (std::array<int, 8>{0, c.tr + 1, 0, c.br + 1, 0, c.bl + 1, 0, c.tl + 1})) << "tile " << id;
      ids.insert(id);
      ++tiles;
    }
  }
  EXPECT_EQ(tiles, tile_count(k));
  EXPECT_EQ(int(ids.size()), tile_count(k));
}

// Tiled itself loads the tileset and keeps the Wang set: `tiled --export-tileset` writes it back
// as JSON with the same colours and wangids.
TEST(Tiled, TiledReadsTheWangSet) {
  TempDir d;
  const TileMap m = write_island_tilemap(d, {{"tiles_x", 8}, {"tiles_z", 8}, {"tile_size", 16}}, 33);
  const int k = m.style.k();
  const Proc r = shell(qt_env(d) + "tiled --export-tileset json '" + (d / "tileset.tsx") + "' '" + (d / "tileset.tsj") + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  const json ts = json::parse(slurp(d / "tileset.tsj"));
  EXPECT_EQ(ts["tilecount"], tile_count(k));
  ASSERT_EQ(ts["wangsets"].size(), 1u);
  const json& ws = ts["wangsets"][0];
  EXPECT_EQ(ws["type"], "corner");
  ASSERT_EQ(ws["colors"].size(), std::size_t(k));
  for (int t = 0; t < k; ++t) {
    EXPECT_EQ(ws["colors"][t]["name"], m.style.types[std::size_t(t)].name);
    EXPECT_EQ(ws["colors"][t]["color"], write_color(m.style.types[std::size_t(t)].color));
  }
  ASSERT_EQ(ws["wangtiles"].size(), std::size_t(tile_count(k)));
  for (const json& wt : ws["wangtiles"]) {
    const TileCorners c = tile_corners(wt["tileid"].get<int>(), k);
    EXPECT_EQ(wt["wangid"], json({0, c.tr + 1, 0, c.br + 1, 0, c.bl + 1, 0, c.tl + 1}));
  }
}

TEST(Tiled, CsvHoldsTheTileIndicesRowByRow) {
  TempDir d;
  const TileMap m = write_island_tilemap(d, {{"tiles_x", 5}, {"tiles_z", 3}, {"tile_size", 8}}, 33);
  std::istringstream in(slurp(d / "tilemap.csv"));
  std::string line;
  std::vector<std::uint32_t> got;
  int rows = 0;
  while (std::getline(in, line)) {
    ++rows;
    std::istringstream ls(line);
    std::string cell;
    int cols = 0;
    while (std::getline(ls, cell, ',')) got.push_back(std::uint32_t(std::stoul(cell))), ++cols;
    EXPECT_EQ(cols, 5);
  }
  EXPECT_EQ(rows, 3);
  EXPECT_EQ(got, m.tile_t);
}

// ---- CLI ------------------------------------------------------------------------------------------

TEST(TilemapCli, FlagsAddTheStageAndWriteEveryFile) {
  TempDir d;
  const Proc r = relief_cli("generate --preset island --seed 2 --size 65 --formats tilemap --tile-size 16 --map-tiles 20x12 -o '" +
                           d.path.string() + "' --save-recipe '" + (d / "recipe.json") + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* f : {"tileset.png", "tileset.tsx", "tilemap.tmx", "tilemap.tmj", "tilemap.csv", "tilemap.png", "tilemap.json"})
    EXPECT_NE(r.out.find(f), std::string::npos) << f;
  const json recipe = json::parse(slurp(d / "recipe.json"));
  const json& last = recipe["stages"].back();
  EXPECT_EQ(last["stage"], "tilemap");
  EXPECT_EQ(last["tile_size"], 16);
  EXPECT_EQ(last["tiles_x"], 20);
  EXPECT_EQ(last["tiles_z"], 12);
  const Rgba map = decode_png(slurp(d / "tilemap.png"));
  EXPECT_EQ(map.w, 20 * 16);
  EXPECT_EQ(map.h, 12 * 16);
  const json side = json::parse(slurp(d / "tilemap.json"));
  EXPECT_EQ(side["tile_count"], tile_count(6));
  EXPECT_EQ(side["saddle_variants"].size(), 30u);
}

TEST(TilemapCli, SameBytesForAnyThreadCount) {
  TempDir a, b;
  const std::string args = "generate island --seed 9 --size 65 --formats tilemap --tile-size 16 --map-tiles 16 -q ";
  ASSERT_EQ(relief_cli(args + "--threads 1 -o '" + a.path.string() + "'").code, 0);
  ASSERT_EQ(relief_cli(args + "--threads 3 -o '" + b.path.string() + "'").code, 0);
  for (const char* f : {"tileset.png", "tileset.tsx", "tilemap.tmx", "tilemap.tmj", "tilemap.csv", "tilemap.png", "tilemap.json"})
    EXPECT_EQ(slurp(a / f), slurp(b / f)) << f;
}

TEST(TilemapCli, BadValuesExitTwoNamingTheField) {
  TempDir d;
  const std::string base = "generate --preset island --size 33 -o '" + (d / "out") + "' ";
  auto expect = [&](const std::string& args, const std::string& needle) {
    const Proc r = relief_cli(base + args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(needle), std::string::npos) << args << "\nexpected: " << needle << "\ngot: " << r.out;
  };
  expect("--formats tilemap --tile-size 4", "--tile-size (stages[5].tile_size): expected an integer in 8..128, got 4");
  expect("--tile-size 500", "--tile-size (stages[5].tile_size)");
  expect("--tile-size big", "--tile-size: expected a tile size in pixels");
  expect("--map-tiles 0x5", "--map-tiles (stages[5].tiles_x): expected an integer in 1..4096, got 0");
  expect("--map-tiles 12x", "--map-tiles: expected N or NxM tiles");
  expect("--map-tiles 2048 --tile-size 64", "--map-tiles (stages[5].tiles_x)");
  expect("--formats tilemap --set 'stages[5].precedence=middle'", "stages[5].precedence");
  expect("--formats tilemap --set 'stages[5].types=[{\"at\":1,\"color\":\"#ffffff\"}]'",
         "stages[5].types: expected 2..8 terrain types, got 1");
  expect("--formats tilemap --set 'stages[5].classify=biome' --set 'stages[5].biome_types=[0,1]'",
         "stages[5]: classify is \"biome\" but the terrain has no 'biome' layer");
  // Nothing was written by the failed runs.
  EXPECT_FALSE(fs::exists(d / "out") && !fs::is_empty(d / "out"));
}
