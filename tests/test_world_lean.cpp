// World builds with phases (relief/world.hpp, "Phases"; issue 18): lean phase stores, phase tiles
// removed as soon as the next phase is complete, the disk estimate of the largest two consecutive
// stores, layer-filtered loads and spliced stores for world algorithms (WorldStageIO::load_layers,
// ::update), and world algorithms that run their tiles on the build's threads with the same bytes
// for any thread count.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <filesystem>
#include <limits>
#include <set>

#include "relief/error.hpp"
#include "relief/hydrology.hpp"
#include "relief/world.hpp"
#include "relief/world_flow.hpp"
#include "support.hpp"
#include "world_support.hpp"

using namespace relief;
using namespace relief::test::world;
using relief::test::TempDir;

namespace {

// The river world with a pointwise mask written into "water" before the fill: the flow stage
// overwrites "water" without reading it, so the phases before the flow leave it out of their stores.
// Phases: [noise, island, redistribute, mask] | fill | flow | [color, hillshade].
json masked_river_doc() {
  json doc = river_world_doc();
  json stages = json::array();
  for (const json& st : doc["stages"]) {
    if (st.value("stage", "") == "fill") stages.push_back({{"stage", "mask"}, {"layer", "water"}, {"from", 0.5}, {"soft", 0.1}});
    stages.push_back(st);
  }
  doc["stages"] = stages;
  return doc;
}

std::set<std::string> tiles_in(const fs::path& folder) {
  std::set<std::string> names;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(folder, ec))
    if (e.path().extension() == ".rtile") names.insert(e.path().filename().string());
  return names;
}

}  // namespace

// The mask's "water" is in the whole map until the flow overwrites it; the stores of the phases
// before the flow leave it out, and the world still equals the whole map.
TEST(WorldLean, PhasesLeaveOutLayersTheFlowOverwritesAndTheWorldEqualsTheWholeMap) {
  const Recipe r = recipe_of(masked_river_doc(), 5);
  Recipe upto_mask = r;
  upto_mask.stages.resize(4);
  ASSERT_TRUE(whole_map(upto_mask, 257, 257).has("water"));  // the mask made it
  const Terrain whole = whole_map(r, 257, 257);
  TempDir d("world-lean");
  WorldSettings s = settings(r, 257, 257, 65, d / "w", 1);  // tiles one at a time: after_tile in order
  const fs::path w = d.path / "w";
  int calls = 0, checked_first = 0, checked_last = 0;
  s.after_tile = [&](std::int64_t X, std::int64_t Z) {
    ++calls;
    if (calls <= 16) {  // the first local phase: its tile holds the height only
      const WorldTile t = decode_world_tile(relief::test::slurp(w / "phase-0" / fs::path(world_tile_path(X, Z)).filename()));
      EXPECT_EQ(t.layers.size(), 1u);
      EXPECT_TRUE(t.layers.count("height"));
      ++checked_first;
    } else if (calls == 17) {  // the last local phase: the fill's and the first phase's tiles are gone
      EXPECT_TRUE(fs::exists(w / "phase-0" / "complete"));
      EXPECT_TRUE(tiles_in(w / "phase-0").empty());
      EXPECT_TRUE(fs::exists(w / "phase-1" / "complete"));
      EXPECT_TRUE(tiles_in(w / "phase-1").empty());
      EXPECT_EQ(tiles_in(w / "phase-2").size(), 16u);  // the flow's, read by this phase
      const WorldTile t = decode_world_tile(relief::test::slurp(w / "phase-2" / "x0000_z0000.rtile"));
      EXPECT_EQ(t.layers.size(), 3u);  // height, flow, water
      ++checked_last;
    }
  };
  const WorldReport rep = build_world(s);
  EXPECT_EQ(checked_first, 16);
  EXPECT_EQ(checked_last, 1);
  expect_same_layers(whole, read_world_window(w, 0, 0, 257, 257));
  EXPECT_TRUE(verify_world(w).empty());
  for (const char* ph : {"phase-0", "phase-1", "phase-2"}) EXPECT_FALSE(fs::exists(w / ph)) << ph;
  // The disk estimate: the largest two consecutive phase stores (1, 1, 3 and all channels: the
  // flow's and the last), not one store of every channel per phase, nor the last store alone.
  std::uint64_t channels = 0;
  for (auto& [name, c] : rep.layers) channels += std::uint64_t(c);
  ASSERT_GT(channels, 3u);
  const WorldGrid& g = rep.grid;
  const std::uint64_t fixed = 4096 + std::uint64_t(g.count()) * 64 + 257ull * 257 * 3;  // the overview: 257² pixels
  ASSERT_GT(rep.estimated_bytes, fixed);
  const std::uint64_t stores = rep.estimated_bytes - fixed;
  EXPECT_GE(rep.estimated_store_bytes, rep.store_bytes);
  EXPECT_GT(stores, rep.estimated_store_bytes);      // the flow's store coexists with the last one
  EXPECT_LT(stores, 2 * rep.estimated_store_bytes);  // and is smaller (3 of its channels)
}

// The estimate decides: a folder with one byte less than it is refused before any work, one with
// exactly that much is built.
TEST(WorldLean, TheDiskCheckUsesTheLeanEstimate) {
  const Recipe r = recipe_of(masked_river_doc(), 5);
  TempDir d("world-lean-disk");
  const WorldReport rep = build_world(settings(r, 129, 129, 33, d / "a"));
  WorldSettings s = settings(r, 129, 129, 33, d / "b");
  s.disk_free_bytes = rep.estimated_bytes - 1;
  try {
    build_world(s);
    ADD_FAILURE() << "a folder one byte short of the estimate was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "world.size");
  }
  EXPECT_FALSE(fs::exists(d.path / "b" / "tiles"));
  s.disk_free_bytes = rep.estimated_bytes;
  build_world(s);
  expect_same_store(d.path / "a", d.path / "b");
}

// A build stopped in its last phase (the earlier phases' tiles already removed) resumes to the
// same bytes; so does one stopped in the flow's input phase.
TEST(WorldLean, ABuildStoppedAfterPhaseTilesWereRemovedResumesToTheSameBytes) {
  const Recipe r = recipe_of(masked_river_doc(), 8);
  TempDir ref("world-lean-ref"), part("world-lean-part");
  build_world(settings(r, 257, 257, 65, ref / "w"));
  for (int stop : {7, 20}) {
    SCOPED_TRACE("stopped after " + std::to_string(stop) + " tiles");
    WorldSettings s = settings(r, 257, 257, 65, part / "w", 1);
    int n = 0;
    s.after_tile = [&](std::int64_t, std::int64_t) {
      if (++n == stop) throw Cancelled();
    };
    EXPECT_THROW(build_world(s), Cancelled);
    if (stop > 16) {
      EXPECT_TRUE(tiles_in(part.path / "w" / "phase-0").empty());
      EXPECT_TRUE(tiles_in(part.path / "w" / "phase-1").empty());
    }
    const WorldReport again = build_world(settings(r, 257, 257, 65, part / "w"));
    if (stop > 16) {
      EXPECT_EQ(again.tiles_skipped, stop);  // the first phase, and the last one's finished tiles
    }
    expect_same_store(ref.path / "w", part.path / "w");
    fs::remove_all(part.path / "w");
  }
}

// The world algorithms' tiles run on the build's threads: the same store for 1 and 2 threads.
TEST(WorldLean, WorldAlgorithmsGiveTheSameBytesForOneAndTwoThreads) {
  const Recipe r = recipe_of(masked_river_doc(), 3);
  TempDir d("world-lean-threads");
  for (int threads : {1, 2}) build_world(settings(r, 300, 257, 65, d / ("t" + std::to_string(threads)), threads));
  expect_same_store(d.path / "t1", d.path / "t2");
}

// load_layers gives the named layers as load() does and nothing else; update() writes the bytes
// that store() writes for the whole tile. Checked through the caller's algorithms: `fill` by
// load/store only, `flow` by the default algorithm with the filtered calls hidden, against a build
// with the library's own.
TEST(WorldLean, LoadLayersAndUpdateMatchLoadAndStore) {
  const Recipe r = recipe_of(river_world_doc(), 4);
  TempDir d("world-lean-io");
  build_world(settings(r, 257, 257, 65, d / "lean"));
  WorldSettings s = settings(r, 257, 257, 65, d / "plain");
  std::atomic<int> compared{0};
  s.algorithms["fill"] = [&](const WorldStageIO& io, const RecipeStage& st, int index) {
    ASSERT_TRUE(io.load_layers && io.update);
    for (std::int64_t Z = 0; Z < io.grid.tiles_z; ++Z)
      for (std::int64_t X = 0; X < io.grid.tiles_x; ++X) {
        const WorldTile all = io.load(X, Z), some = io.load_layers(X, Z, {"height"});
        ASSERT_EQ(some.layers.size(), 1u);
        EXPECT_EQ(std::memcmp(all.layers.at("height").data.data(), some.layers.at("height").data.data(),
                              all.layers.at("height").data.size() * 4),
                  0);
        EXPECT_EQ(some.window.ix0, all.window.ix0);
        EXPECT_EQ(some.window.nz, all.window.nz);
        try {
          io.load_layers(X, Z, {"height", "no-such-layer"});
          ADD_FAILURE() << "a missing layer was not refused";
        } catch (const Error& e) {
          EXPECT_NE(e.message().find("no-such-layer"), std::string::npos) << e.what();
        }
        ++compared;
      }
    WorldStageIO plain = io;
    plain.load_layers = nullptr;
    plain.update = nullptr;
    world_fill()(plain, st, index);
  };
  s.algorithms["flow"] = [&](const WorldStageIO& io, const RecipeStage& st, int index) {
    WorldStageIO plain = io;
    plain.load_layers = nullptr;
    plain.update = nullptr;
    world_flow()(plain, st, index);
  };
  build_world(s);
  EXPECT_EQ(compared.load(), 16);
  // The tiles and the world files the stages wrote are the same bytes (world.json differs: it
  // names the caller's algorithms).
  auto a = store_files(d.path / "lean"), b = store_files(d.path / "plain");
  for (auto* m : {&a, &b}) m->erase("world.json");
  ASSERT_EQ(a.size(), b.size());
  for (auto& [name, bytes] : a) {
    ASSERT_TRUE(b.count(name)) << name;
    EXPECT_TRUE(bytes == b.at(name)) << name << " differs";
  }
}

// fill_depressions_tiled on one and two threads: the same heights, the same stats, the same
// sequence of store calls (its schedule is fixed).
TEST(WorldLean, TiledFillIsTheSameOnOneAndTwoThreads) {
  Recipe r = recipe_of(preset_doc("island"), 2);
  r.world.nx = r.world.nz = 257;
  std::vector<float> z = run(r).terrain.get("height").data;
  for (int j = 64; j < 192; ++j)
    for (int i = 50; i < 200; ++i) z[std::size_t(j) * 257 + std::size_t(i)] = 0.45f;  // a basin across tiles
  const WorldGrid g = world_grid(257, 257, 33);
  struct Out {
    std::vector<float> filled = std::vector<float>(257 * 257, std::numeric_limits<float>::quiet_NaN());
    std::vector<std::int64_t> calls;
    TiledFillStats st;
  };
  auto fill_on = [&](int threads) {
    Out o;
    tbb::task_arena arena(threads);
    arena.execute([&] {
      o.st = fill_depressions_tiled(
          g, 0.4f, 1e-5f,
          [&](std::int64_t X, std::int64_t Z) {
            const WorldGrid::Window w = g.window(X, Z);
            std::vector<float> t(std::size_t(w.nx) * std::size_t(w.nz));
            for (int j = 0; j < w.nz; ++j)
              for (int i = 0; i < w.nx; ++i) t[std::size_t(j) * w.nx + i] = z[std::size_t(w.iz0 + j) * 257 + std::size_t(w.ix0 + i)];
            return t;
          },
          [&](std::int64_t X, std::int64_t Z, std::vector<float> f) {
            o.calls.push_back(Z * g.tiles_x + X);
            const WorldGrid::Window w = g.window(X, Z);
            for (int j = 0; j < w.nz; ++j)
              for (int i = 0; i < w.nx; ++i) o.filled[std::size_t(w.iz0 + j) * 257 + std::size_t(w.ix0 + i)] = f[std::size_t(j) * w.nx + i];
          });
    });
    return o;
  };
  const Out one = fill_on(1), two = fill_on(2);
  EXPECT_GT(one.st.rounds, 1);
  EXPECT_EQ(one.st.rounds, two.st.rounds);
  EXPECT_EQ(one.st.tile_solves, two.st.tile_solves);
  EXPECT_EQ(one.calls, two.calls);
  EXPECT_EQ(std::memcmp(one.filled.data(), two.filled.data(), one.filled.size() * 4), 0);
  // And the whole map's fill, bit for bit.
  std::vector<float> whole = z;
  hydro::fill_depressions<float>(whole.data(), 257, 257, 0.4f, 1e-5f);
  EXPECT_EQ(std::memcmp(whole.data(), one.filled.data(), whole.size() * 4), 0);
}
