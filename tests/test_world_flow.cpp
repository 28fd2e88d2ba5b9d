// The "flow" stage over a tiled world (relief/world_flow.hpp): the layers it writes equal, bit for
// bit, those of the flow stage run on the whole map, for several tile sizes (clipped last tiles
// included), rivers crossing tile corners, carving on and off; build_world with the algorithm
// registered equals the whole-map run.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cstring>
#include <filesystem>
#include <functional>
#include <tuple>
#include <chrono>
#include <cstdio>

#include <cmath>

#include "relief/error.hpp"
#include "relief/hydrology.hpp"
#include "relief/pipeline.hpp"
#include "relief/world.hpp"
#include "relief/world_flow.hpp"
#include "support.hpp"
#include "world_support.hpp"
#include "writer_defs.hpp"

using namespace relief;
using relief::test::TempDir;

namespace {

json flow_stage(double carve, double width_coeff = 300.0) {
  return {{"stage", "flow"},       {"river_area_km2", 0.02},       {"width_coeff", width_coeff},
          {"epsilon_m", 0.0},      {"carve_depth_coeff", carve}};
}

// island (noise, falloff, redistribution) → fill (ε = 0.01 m) → flow [→ colour, hillshade].
json island_flow_doc(double carve, bool after, double width_coeff = 300.0) {
  json doc = load_preset("island");
  json stages = json::array({doc["stages"][0], doc["stages"][1], doc["stages"][2],
                             json{{"stage", "fill"}, {"epsilon_m", 0.01}}, flow_stage(carve, width_coeff)});
  if (after) {
    stages.push_back(doc["stages"][3]);
    stages.push_back(doc["stages"][4]);
  }
  doc["stages"] = stages;
  return doc;
}

Recipe recipe_of(json doc, std::uint64_t seed) {
  doc["seed"] = seed;
  return parse_recipe(doc);
}

// The whole-map run of a recipe whose stage 3 is "fill" up to that stage (the flow stage's input),
// and (whole_map) the whole recipe resumed from it.
Terrain filled_input(Recipe r, int nx, int nz) {
  r.world.nx = nx;
  r.world.nz = nz;
  r.stages.resize(4);
  return run(r).terrain;
}
Terrain whole_map(Recipe r, int nx, int nz) {
  r.world.nx = nx;
  r.world.nz = nz;
  const Terrain t = filled_input(r, nx, nz);
  RunOptions opt;
  opt.resume = Resume{&t, 4};
  return run(r, opt).terrain;
}

struct Assembled {
  std::vector<float> height, flow, water;
  std::vector<int> stores;  // per tile
};

// flow_tiled over `h` (nx × nz) cut in tiles of `tile`, results assembled into whole layers;
// shared border samples must agree between the tiles that hold them.
TiledFlowStats tiled(const std::vector<float>& h, int nx, int nz, int tile, const Frame& world, const WorldFlowParams& p,
                     Assembled& a, std::vector<River>* rivers = nullptr, const std::vector<float>* filled = nullptr,
                     std::vector<Lake>* lakes = nullptr) {
  const WorldGrid g = world_grid(nx, nz, tile);
  const std::size_t n = std::size_t(nx) * std::size_t(nz);
  a.height.assign(n, -1.0f);
  a.flow.assign(n, -1.0f);
  a.water.assign(n, -1.0f);
  a.stores.assign(std::size_t(g.count()), 0);
  const TileLoad load = [&](std::int64_t X, std::int64_t Z) {
    const WorldGrid::Window w = g.window(X, Z);
    std::vector<float> v(std::size_t(w.nx) * std::size_t(w.nz));
    for (int j = 0; j < w.nz; ++j)
      for (int i = 0; i < w.nx; ++i)
        v[std::size_t(j) * w.nx + i] = h[std::size_t(w.iz0 + j) * std::size_t(nx) + std::size_t(w.ix0 + i)];
    return v;
  };
  const FlowTileStore store = [&](std::int64_t X, std::int64_t Z, FlowTile t) {
    ++a.stores[std::size_t(Z * g.tiles_x + X)];
    const WorldGrid::Window w = g.window(X, Z);
    ASSERT_EQ(t.height.size(), std::size_t(w.nx) * std::size_t(w.nz));
    for (int j = 0; j < w.nz; ++j)
      for (int i = 0; i < w.nx; ++i) {
        const std::size_t m = std::size_t(j) * w.nx + i, c = std::size_t(w.iz0 + j) * std::size_t(nx) + std::size_t(w.ix0 + i);
        for (auto [dst, src] : {std::pair{&a.height, &t.height}, {&a.flow, &t.flow}, {&a.water, &t.water}}) {
          float& d = (*dst)[c];
          if (d != -1.0f) {
            EXPECT_EQ(std::memcmp(&d, &(*src)[m], 4), 0) << "a shared border sample differs between tiles";
          }
          d = (*src)[m];
        }
      }
  };
  TileLoad load_filled;
  if (filled)
    load_filled = [&](std::int64_t X, std::int64_t Z) {
      const WorldGrid::Window w = g.window(X, Z);
      std::vector<float> v(std::size_t(w.nx) * std::size_t(w.nz));
      for (int j = 0; j < w.nz; ++j)
        for (int i = 0; i < w.nx; ++i)
          v[std::size_t(j) * w.nx + i] = (*filled)[std::size_t(w.iz0 + j) * std::size_t(nx) + std::size_t(w.ix0 + i)];
      return v;
    };
  return flow_tiled(g, world, p, load, store, rivers, {}, "height", load_filled, lakes);
}

std::size_t first_difference(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return 0;
  for (std::size_t k = 0; k < a.size(); ++k)
    if (std::memcmp(&a[k], &b[k], 4) != 0) return k;
  return a.size();
}

void expect_layers(const Terrain& whole, const Assembled& a, int nx) {
  for (auto [name, v] : {std::pair{"height", &a.height}, {"flow", &a.flow}, {"water", &a.water}}) {
    const std::vector<float>& ref = whole.get(name).data;
    const std::size_t k = first_difference(ref, *v);
    EXPECT_EQ(k, ref.size()) << "layer " << name << " differs first at (" << k % std::size_t(nx) << ", "
                             << k / std::size_t(nx) << "): whole " << (k < ref.size() ? ref[k] : 0.0f) << ", tiled "
                             << (k < v->size() ? (*v)[k] : 0.0f);
  }
}

// Rivers field for field (doubles bit for bit), then rivers.json and lakes.json byte for byte
// against the whole-map writers.
void expect_same_rivers(const Terrain& whole, const std::vector<River>& rivers, const std::vector<Lake>& lakes = {}) {
  ASSERT_EQ(whole.rivers.size(), rivers.size());
  auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  for (std::size_t k = 0; k < rivers.size(); ++k) {
    const River &a = whole.rivers[k], &b = rivers[k];
    ASSERT_EQ(a.order, b.order) << "river " << k;
    ASSERT_EQ(a.end, b.end) << "river " << k;
    ASSERT_EQ(a.vertices.size(), b.vertices.size()) << "river " << k;
    for (std::size_t v = 0; v < a.vertices.size(); ++v) {
      const RiverVertex &p = a.vertices[v], &q = b.vertices[v];
      ASSERT_TRUE(same(p.x_m, q.x_m) && same(p.y_m, q.y_m) && same(p.z_m, q.z_m) && same(p.discharge_m3s, q.discharge_m3s) &&
                  same(p.width_m, q.width_m))
          << "river " << k << " vertex " << v;
    }
  }
  MemoryOutput ref, out;
  const WriteContext ctx;
  for (const WriterDef& w : water_writers()) w.write(whole, ctx, ref);
  write_world_water(whole.frame, rivers, lakes, out);
  ASSERT_EQ(ref.files.size(), 2u);
  EXPECT_TRUE(ref.files == out.files);
}

// The whole-map input is real: rivers, discs wider than a cell, carving, flow across tiles.
void expect_rivers(const Terrain& input, const Terrain& whole) {
  std::size_t wet = 0, wide = 0;
  for (float w : whole.get("water").data) wet += w > 0, wide += w == 1.0f;
  EXPECT_GT(wet, 200u);
  EXPECT_GT(wide, 20u);
  EXPECT_FALSE(relief::test::same_bits(input.get("height").data, whole.get("height").data));  // carved
  EXPECT_GT(whole.rivers.size(), 10u);
  int top = 0;
  for (const River& r : whole.rivers) top = std::max(top, r.order);
  EXPECT_GE(top, 3);  // Strahler orders that need donors from several tiles
  EXPECT_TRUE(whole.lakes.empty());
}

}  // namespace

TEST(FlowTiled, IslandLayersEqualTheWholeMapAtSeveralTileSizes) {
  const Recipe r = recipe_of(island_flow_doc(20.0, false), 3);
  const int n = 257;
  const Terrain input = filled_input(r, n, n), whole = whole_map(r, n, n);
  expect_rivers(input, whole);
  const WorldFlowParams p = world_flow_params(r.stages[4].stage->params());
  for (int tile : {9, 17, 33, 65, 129, 257}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    Assembled a;
    std::vector<River> rivers;
    const TiledFlowStats st = tiled(input.get("height").data, n, n, tile, world_frame(r, n, n), p, a, &rivers);
    expect_layers(whole, a, n);
    expect_same_rivers(whole, rivers);
    for (int s : a.stores) EXPECT_EQ(s, 1);
    if (tile < n) {
      EXPECT_GT(st.cross_links, 0);
      EXPECT_GT(st.rounds, 1);  // orders and carving crossed tiles
    }
    EXPECT_EQ(st.tiles, std::int64_t(a.stores.size()));
    // Pass A and the final pass solve every tile once; pass S only the tiles where a channel may
    // be, at most once a round. In small tiles some are all sea: they have none.
    EXPECT_GT(st.channel_tiles, 0);
    EXPECT_LE(st.tile_solves - 2 * st.tiles, st.channel_tiles * st.rounds);
    if (tile <= 17) {
      EXPECT_LT(st.channel_tiles, st.tiles);
    }
  }
}

TEST(FlowTiled, ClippedLastTilesOfANonSquareWorldEqualTheWholeMap) {
  const Recipe r = recipe_of(island_flow_doc(20.0, false), 8);
  const int nx = 231, nz = 170;  // (nx−1) and (nz−1) are multiples of neither 32 nor 64
  const Terrain input = filled_input(r, nx, nz), whole = whole_map(r, nx, nz);
  expect_rivers(input, whole);
  const WorldFlowParams p = world_flow_params(r.stages[4].stage->params());
  for (int tile : {5, 33, 65}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    Assembled a;
    std::vector<River> rivers;
    tiled(input.get("height").data, nx, nz, tile, world_frame(r, nx, nz), p, a, &rivers);
    expect_layers(whole, a, nx);
    expect_same_rivers(whole, rivers);
  }
}

// One column of tiles (the world narrower than a tile along x) and one row of them.
TEST(FlowTiled, OneColumnOrOneRowOfTilesEqualsTheWholeMap) {
  const Recipe r = recipe_of(island_flow_doc(20.0, false), 8);
  for (auto [nx, nz, tile] : {std::tuple{100, 257, 129}, std::tuple{257, 70, 129}, std::tuple{129, 257, 129}}) {
    SCOPED_TRACE(std::to_string(nx) + "x" + std::to_string(nz) + " tile " + std::to_string(tile));
    const Terrain input = filled_input(r, nx, nz), whole = whole_map(r, nx, nz);
    Assembled a;
    std::vector<River> rivers;
    const TiledFlowStats st =
        tiled(input.get("height").data, nx, nz, tile, world_frame(r, nx, nz), world_flow_params(r.stages[4].stage->params()), a, &rivers);
    EXPECT_EQ(st.tiles, 2);
    expect_layers(whole, a, nx);
    expect_same_rivers(whole, rivers);
  }
}

TEST(FlowTiled, WithoutCarvingAndWithNarrowRiversEqualsTheWholeMap) {
  const Recipe r = recipe_of(island_flow_doc(0.0, false, 5.0), 5);
  const int n = 193;
  const Terrain input = filled_input(r, n, n), whole = whole_map(r, n, n);
  ASSERT_TRUE(relief::test::same_bits(input.get("height").data, whole.get("height").data));  // nothing carved
  std::size_t wet = 0;
  for (float w : whole.get("water").data) wet += w > 0 && w < 1;
  EXPECT_GT(wet, 100u);  // point covers (rivers narrower than a cell)
  const WorldFlowParams p = world_flow_params(r.stages[4].stage->params());
  for (int tile : {17, 65}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    Assembled a;
    std::vector<River> rivers;
    tiled(input.get("height").data, n, n, tile, world_frame(r, n, n), p, a, &rivers);
    expect_layers(whole, a, n);
    expect_same_rivers(whole, rivers);
  }
}

namespace {

// The whole-map flow stage on a synthetic height z(i, j) (filled first, so that it drains).
struct Synthetic {
  Terrain whole;
  std::vector<float> h;
  WorldFlowParams p;
};
Synthetic synthetic(int n, const std::function<double(int, int)>& z, const json& flow) {
  json doc = {{"world", {{"size", n}, {"width_m", 4000.0}, {"height_m", 500.0}, {"sea_level", 0.4}}},
              {"stages", json::array({json{{"stage", "noise"}}, flow})},
              {"seed", 1}};
  const Recipe r = parse_recipe(doc);
  Recipe first = r;
  first.stages.resize(1);
  Terrain t = run(first).terrain;
  std::vector<float>& h = t.get("height").data;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) h[std::size_t(j) * n + i] = float(z(i, j));
  hydro::fill_depressions<float>(h.data(), n, n, 0.4f, 0.0f);
  RunOptions opt;
  opt.resume = Resume{&t, 1};
  return {run(r, opt).terrain, h, world_flow_params(r.stages[1].stage->params())};
}

}  // namespace

// A valley along the diagonal: the main river runs through every tile corner (where four tiles
// meet and a sample's receiver lies in the diagonal tile), side valleys join it from both sides.
TEST(FlowTiled, ARiverThroughTileCornersEqualsTheWholeMap) {
  const int n = 129;
  const Synthetic sy = synthetic(
      n,
      [&](int i, int j) {
        const double across = std::abs(i - j), along = 2.0 * (n - 1) - i - j;
        const double ripple = ((i * 7 + j * 13) % 5) * 1e-5;  // side valleys and uneven slopes
        return 0.41 + 2e-3 * across + 1e-3 * along + ripple;
      },
      flow_stage(30.0));
  const Terrain& whole = sy.whole;
  const float cell2 = float(whole.frame.cell_m() * whole.frame.cell_m());
  ASSERT_GT(whole.get("flow").data[std::size_t(n - 2) * n + (n - 2)], 1000.0f * cell2);
  ASSERT_GT(whole.get("flow").data[std::size_t(32) * n + 32], 100.0f * cell2);  // a corner of tiles 3, 5, 9, 17, 33
  for (int tile : {3, 5, 9, 17, 33}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    Assembled a;
    std::vector<River> rivers;
    const TiledFlowStats st = tiled(sy.h, n, n, tile, whole.frame, sy.p, a, &rivers);
    expect_layers(whole, a, n);
    expect_same_rivers(whole, rivers);
    EXPECT_GE(st.rounds, 2);
    EXPECT_GT(st.cross_links, 0);
  }
}

// A wide river one sample below a row of tile borders (z = 32 for tiles of 5, 9, 17 and 33),
// flowing along it: its discs cover samples of the tiles above, which hold no river of their own.
TEST(FlowTiled, AWideRiverAlongATileBorderCoversTheTilesBeside) {
  const int n = 129;
  const Synthetic sy = synthetic(
      n, [&](int i, int j) { return 0.41 + 2e-3 * std::abs(j - 33) + 1e-3 * (n - 1 - i) + ((i * 5 + j * 3) % 4) * 1e-5; },
      flow_stage(0.0, 1000.0));
  const Terrain& whole = sy.whole;
  const std::vector<float>& water = whole.get("water").data;
  ASSERT_GT(water[std::size_t(29) * n + 100], 0.5f);  // four samples above the river, in the tiles above
  for (int tile : {5, 9, 17, 33}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    Assembled a;
    std::vector<River> rivers;
    const TiledFlowStats st = tiled(sy.h, n, n, tile, whole.frame, sy.p, a, &rivers);
    expect_layers(whole, a, n);
    expect_same_rivers(whole, rivers);
    EXPECT_GT(st.cover_cells, 0u);
  }
}

// No fill stage before the flow stage: it fills itself and keeps deep, large depressions as lakes.
// With the whole world's filled heights given (as a tiled fill gives them), the layers (lake floors
// under their water, water 1 on lakes, carving that stops at lake surfaces) and the rivers (vertices
// on a lake at its surface) equal the whole map's; lakes crossing tiles are joined by union-find.
TEST(FlowTiled, LakesAcrossTilesGiveTheWholeMapsLayersAndRivers) {
  for (const char* mode : {"lakes", "fill"}) {
    SCOPED_TRACE(mode);
    json doc = island_flow_doc(20.0, false);
    json flow = doc["stages"][4];
    flow["depressions"] = mode;
    flow["lake_min_depth_m"] = 0.5;
    flow["lake_min_area_m2"] = 2000.0;
    doc["stages"] = json::array({doc["stages"][0], doc["stages"][1], doc["stages"][2], flow});
    Recipe r = recipe_of(doc, 12);
    const int nx = 257, nz = 230;
    r.world.nx = nx, r.world.nz = nz;
    Recipe before = r;
    before.stages.resize(3);
    const Terrain input = run(before).terrain;
    const Terrain whole = run(r).terrain;
    std::vector<float> filled = input.get("height").data;
    const WorldFlowParams p = world_flow_params(r.stages[3].stage->params());
    hydro::fill_depressions<float>(filled.data(), nx, nz, float(r.world.sea_level), float(p.epsilon_m / r.world.height_m));
    ASSERT_FALSE(relief::test::same_bits(filled, input.get("height").data));  // it has depressions
    if (std::string(mode) == "lakes") {
      ASSERT_GE(whole.lakes.size(), 3u);
    } else {
      ASSERT_TRUE(whole.lakes.empty());
    }
    for (int tile : {9, 33, 65, 257}) {
      SCOPED_TRACE("tile " + std::to_string(tile));
      if (tile == 9 && !whole.lakes.empty()) {  // some lakes lie across tile borders
        const double span = 8 * whole.frame.cell_m();
        std::size_t across = 0;
        for (const Lake& l : whole.lakes)
          across += std::floor(l.x0_m / span) != std::floor(l.x1_m / span) || std::floor(l.z0_m / span) != std::floor(l.z1_m / span);
        EXPECT_GE(across, 2u);
      }
      Assembled a;
      std::vector<River> rivers;
      std::vector<Lake> lakes;
      const TiledFlowStats st =
          tiled(input.get("height").data, nx, nz, tile, world_frame(r, nx, nz), p, a, &rivers, &filled, &lakes);
      expect_layers(whole, a, nx);
      EXPECT_EQ(st.lakes, std::int64_t(whole.lakes.size()));
      ASSERT_EQ(whole.lakes.size(), lakes.size());
      auto same = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
      for (std::size_t k = 0; k < lakes.size(); ++k) {
        const Lake &u = whole.lakes[k], &v = lakes[k];
        EXPECT_TRUE(same(u.level_m, v.level_m) && same(u.area_m2, v.area_m2) && same(u.volume_m3, v.volume_m3) &&
                    same(u.max_depth_m, v.max_depth_m) && same(u.x_m, v.x_m) && same(u.z_m, v.z_m) &&
                    same(u.x0_m, v.x0_m) && same(u.z0_m, v.z0_m) && same(u.x1_m, v.x1_m) && same(u.z1_m, v.z1_m) &&
                    same(u.outlet_x_m, v.outlet_x_m) && same(u.outlet_z_m, v.outlet_z_m) && u.samples == v.samples)
            << "lake " << k;
      }
      expect_same_rivers(whole, rivers, lakes);
    }
  }
}

// flow_tiled's passes solve tiles on the calling arena's threads: on one and two threads the
// layers, rivers, lakes, stats and the order of the store calls are the same (lakes and carving
// across tiles of 33, so that pass S takes rounds).
TEST(FlowTiled, OneAndTwoThreadsGiveTheSameResultsAndStoreOrder) {
  json doc = island_flow_doc(20.0, false);
  json flow = doc["stages"][4];
  flow["lake_min_depth_m"] = 0.5;
  flow["lake_min_area_m2"] = 2000.0;
  doc["stages"] = json::array({doc["stages"][0], doc["stages"][1], doc["stages"][2], flow});
  Recipe r = recipe_of(doc, 12);
  const int nx = 257, nz = 230;
  r.world.nx = nx, r.world.nz = nz;
  Recipe before = r;
  before.stages.resize(3);
  const std::vector<float> h = run(before).terrain.get("height").data;
  std::vector<float> filled = h;
  const WorldFlowParams p = world_flow_params(r.stages[3].stage->params());
  hydro::fill_depressions<float>(filled.data(), nx, nz, float(r.world.sea_level), float(p.epsilon_m / r.world.height_m));
  const WorldGrid g = world_grid(nx, nz, 33);
  struct Out {
    std::vector<float> layers;  // every tile's height, flow, water in store order
    std::vector<std::int64_t> order;
    std::vector<River> rivers;
    std::vector<Lake> lakes;
    TiledFlowStats st;
  };
  auto tile_of = [&](const std::vector<float>& src, std::int64_t X, std::int64_t Z) {
    const WorldGrid::Window w = g.window(X, Z);
    std::vector<float> v(std::size_t(w.nx) * std::size_t(w.nz));
    for (int j = 0; j < w.nz; ++j)
      for (int i = 0; i < w.nx; ++i) v[std::size_t(j) * w.nx + i] = src[std::size_t(w.iz0 + j) * std::size_t(nx) + std::size_t(w.ix0 + i)];
    return v;
  };
  auto on = [&](int threads) {
    Out o;
    tbb::task_arena arena(threads);
    arena.execute([&] {
      o.st = flow_tiled(
          g, world_frame(r, nx, nz), p, [&](std::int64_t X, std::int64_t Z) { return tile_of(h, X, Z); },
          [&](std::int64_t X, std::int64_t Z, FlowTile t) {
            o.order.push_back(Z * g.tiles_x + X);
            for (auto* v : {&t.height, &t.flow, &t.water}) o.layers.insert(o.layers.end(), v->begin(), v->end());
          },
          &o.rivers, {}, "height", [&](std::int64_t X, std::int64_t Z) { return tile_of(filled, X, Z); }, &o.lakes);
    });
    return o;
  };
  const Out one = on(1), two = on(2);
  EXPECT_GT(one.st.rounds, 1);
  EXPECT_GE(one.lakes.size(), 3u);
  EXPECT_EQ(one.order, two.order);
  ASSERT_EQ(one.layers.size(), two.layers.size());
  EXPECT_EQ(std::memcmp(one.layers.data(), two.layers.data(), one.layers.size() * 4), 0);
  EXPECT_EQ(one.st.rounds, two.st.rounds);
  EXPECT_EQ(one.st.tile_solves, two.st.tile_solves);
  EXPECT_EQ(one.st.cover_cells, two.st.cover_cells);
  EXPECT_EQ(one.st.max_count, two.st.max_count);
  ASSERT_EQ(one.rivers.size(), two.rivers.size());
  for (std::size_t k = 0; k < one.rivers.size(); ++k) {
    ASSERT_EQ(one.rivers[k].vertices.size(), two.rivers[k].vertices.size()) << "river " << k;
    EXPECT_EQ(one.rivers[k].end, two.rivers[k].end);
    for (std::size_t v = 0; v < one.rivers[k].vertices.size(); ++v)
      EXPECT_EQ(std::memcmp(&one.rivers[k].vertices[v], &two.rivers[k].vertices[v], sizeof(RiverVertex)), 0) << "river " << k;
  }
  ASSERT_EQ(one.lakes.size(), two.lakes.size());
  for (std::size_t k = 0; k < one.lakes.size(); ++k) {
    EXPECT_EQ(std::memcmp(&one.lakes[k].volume_m3, &two.lakes[k].volume_m3, sizeof(double)), 0) << "lake " << k;
    EXPECT_EQ(one.lakes[k].samples, two.lakes[k].samples);
  }
}

TEST(FlowTiled, AHeightThatDoesNotDrainIsRefused) {
  const Recipe r = recipe_of(island_flow_doc(0.0, false), 3);
  const int n = 65;
  Recipe before = r;
  before.stages.resize(3);
  before.world.nx = before.world.nz = n;
  const Terrain raw = run(before).terrain;  // not filled: holds pits
  ASSERT_GT(hydro::count_pits<float>(raw.get("height").data.data(), n, n, 0.4f), 0u);
  Assembled a;
  try {
    tiled(raw.get("height").data, n, n, 17, world_frame(r, n, n), world_flow_params(r.stages[4].stage->params()), a);
    ADD_FAILURE() << "accepted a height with pits";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "height");
  }
}

// A stand-in world algorithm for the fill stage, for this test only: the whole world assembled in
// memory and filled by hydro::fill_depressions (what the fill stage does on the whole map), so
// that the flow stage's world algorithm is tested apart from the tiled fill's.
WorldStageAlgorithm whole_world_fill() {
  return [](const WorldStageIO& io, const RecipeStage& st, int) {
    const WorldGrid& g = io.grid;
    std::vector<float> z(std::size_t(g.nx * g.nz));
    for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
      for (std::int64_t X = 0; X < g.tiles_x; ++X) {
        const WorldGrid::Window w = g.window(X, Z);
        const std::vector<float> h = io.load(X, Z).layers.at("height").data;
        for (int j = 0; j < w.nz; ++j)
          for (int i = 0; i < w.nx; ++i) z[std::size_t((w.iz0 + j) * g.nx + w.ix0 + i)] = h[std::size_t(j) * w.nx + i];
      }
    const float eps = float(st.stage->params().value("epsilon_m", 0.0) / io.world.height_m);
    hydro::fill_depressions<float>(z.data(), int(g.nx), int(g.nz), float(io.world.sea_level), eps);
    for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
      for (std::int64_t X = 0; X < g.tiles_x; ++X) {
        const WorldGrid::Window w = g.window(X, Z);
        WorldTile t = io.load(X, Z);
        std::vector<float>& h = t.layers.at("height").data;
        for (int j = 0; j < w.nz; ++j)
          for (int i = 0; i < w.nx; ++i) h[std::size_t(j) * w.nx + i] = z[std::size_t((w.iz0 + j) * g.nx + w.ix0 + i)];
        io.store(X, Z, std::move(t));
      }
  };
}

// build_world with this algorithm registered (and a whole-world fill before it), colour and
// hillshade after: every layer of the store equals the whole-map run, and so do the rivers.
TEST(WorldFlow, BuildWorldEqualsTheWholeMap) {
  const Recipe r = recipe_of(island_flow_doc(20.0, true), 9);
  const int nx = 257, nz = 200;
  const Terrain ref = whole_map(r, nx, nz);
  for (int tile : {33, 129}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    TempDir d("world-flow");
    WorldSettings s = relief::test::world::settings(r, nx, nz, tile, d / "w");
    std::vector<River> rivers;
    s.algorithms["fill"] = whole_world_fill();
    s.algorithms["flow"] = world_flow([&](const Frame& world, std::vector<River> rv, std::vector<Lake> lakes) {
      EXPECT_EQ(world.nx, nx);
      EXPECT_TRUE(lakes.empty());
      rivers = std::move(rv);
    });
    build_world(s);
    expect_same_rivers(ref, rivers);
    const Terrain w = read_world_window(d / "w", 0, 0, nx, nz);
    ASSERT_EQ(ref.layers.size(), w.layers.size());
    for (auto& [name, layer] : ref.layers) {
      ASSERT_TRUE(w.has(name)) << name;
      const std::size_t k = first_difference(layer.data, w.get(name).data);
      EXPECT_EQ(k, layer.data.size()) << "layer " << name << " differs first at value " << k;
    }
  }
}

// Figures for the report (not a test of time: run with --gtest_also_run_disabled_tests): the flow
// stage on the whole map against flow_tiled at two tile sizes, same input, same bits.
TEST(FlowTiled, DISABLED_Figures) {
  Recipe r = recipe_of(island_flow_doc(20.0, false), 3);
  const int n = 2049;
  r.world.nx = r.world.nz = n;
  const Terrain input = filled_input(r, n, n);
  RunOptions opt;
  opt.threads = 1;
  opt.resume = Resume{&input, 4};
  const auto t0 = std::chrono::steady_clock::now();
  const Terrain whole = run(r, opt).terrain;
  const double whole_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("whole map %d^2: flow stage %.2f s, %zu rivers\n", n, whole_s, whole.rivers.size());
  const WorldFlowParams p = world_flow_params(r.stages[4].stage->params());
  for (int tile : {257, 513}) {
    Assembled a;
    std::vector<River> rivers;
    const auto t1 = std::chrono::steady_clock::now();
    const TiledFlowStats st = tiled(input.get("height").data, n, n, tile, world_frame(r, n, n), p, a, &rivers);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    std::printf("tile %d: %.2f s (%.2fx), %lld tiles, %lld perimeter nodes, %lld exits, %d rounds, %lld solves, "
                "%zu cover cells, %zu river pieces\n",
                tile, s, s / whole_s, (long long)st.tiles, (long long)st.perimeter_nodes, (long long)st.cross_links,
                st.rounds, (long long)st.tile_solves, st.cover_cells, st.river_pieces);
    expect_layers(whole, a, n);
    expect_same_rivers(whole, rivers);
  }
}

// No fill stage: world_flow fills (tiled) as the flow stage does and keeps lakes; the store's
// layers, the rivers and the lakes equal the whole-map run's.
TEST(WorldFlow, BuildWorldWithLakesAndNoFillStageEqualsTheWholeMap) {
  json doc = island_flow_doc(20.0, true);
  json flow = doc["stages"][4];
  flow["lake_min_depth_m"] = 0.5;
  flow["lake_min_area_m2"] = 2000.0;
  doc["stages"] = json::array({doc["stages"][0], doc["stages"][1], doc["stages"][2], flow, doc["stages"][5], doc["stages"][6]});
  Recipe r = recipe_of(doc, 12);
  const int nx = 257, nz = 230;
  Recipe rr = r;
  rr.world.nx = nx, rr.world.nz = nz;
  const Terrain ref = run(rr).terrain;
  ASSERT_GE(ref.lakes.size(), 3u);
  for (int tile : {33, 129}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    TempDir d("world-flow-lakes");
    WorldSettings s = relief::test::world::settings(r, nx, nz, tile, d / "w");
    std::vector<River> rivers;
    std::vector<Lake> lakes;
    s.algorithms["flow"] = world_flow([&](const Frame&, std::vector<River> rv, std::vector<Lake> lk) {
      rivers = std::move(rv);
      lakes = std::move(lk);
    });
    build_world(s);
    ASSERT_EQ(lakes.size(), ref.lakes.size());
    expect_same_rivers(ref, rivers, lakes);  // rivers.json and lakes.json byte for byte
    const Terrain w = read_world_window(d / "w", 0, 0, nx, nz);
    ASSERT_EQ(ref.layers.size(), w.layers.size());
    for (auto& [name, layer] : ref.layers) {
      ASSERT_TRUE(w.has(name)) << name;
      const std::size_t k = first_difference(layer.data, w.get(name).data);
      EXPECT_EQ(k, layer.data.size()) << "layer " << name << " differs first at value " << k;
    }
  }
}
