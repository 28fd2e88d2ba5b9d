// World builds (relief/world.hpp, issue 18 phase 1): tiles of pointwise and neighbourhood stages
// equal the whole-map run byte for byte; the tile store round-trips; resuming (after a cancel or a
// SIGKILL of the CLI) gives the bytes of an uninterrupted build; bad input is refused up front.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <set>
#include <thread>
#include <tuple>

#include "relief/error.hpp"
#include "relief/hydrology.hpp"
#include "relief/pipeline.hpp"
#include "relief/world.hpp"
#include "relief/world_bounded.hpp"
#include "support.hpp"
#include "world_internal.hpp"
#include "world_support.hpp"

using namespace relief;
using namespace relief::test::world;
using relief::test::TempDir;
namespace fs = std::filesystem;

namespace {

// noise → thermal (halo 2·ceil(distance/cell)) → slope-dependent colour → hillshade: the widest
// halos of the local stages.
json thermal_doc() {
  json doc = load_preset("island");
  json stages = json::array();
  stages.push_back(doc["stages"][0]);
  stages.push_back(doc["stages"][1]);
  stages.push_back({{"stage", "thermal"}, {"distance_m", 40.0}});
  stages.push_back({{"stage", "slope"}});
  stages.push_back(doc["stages"][3]);
  stages.push_back(doc["stages"][4]);
  doc["stages"] = stages;
  return doc;
}

// report.json's phases: the recipe's stages in order, a global stage alone in its phase; each phase
// built has a resident peak; each stage names its phase and that peak.
void expect_phase_report(const json& report, const Recipe& r) {
  const json& phases = report.at("performance").at("phases");
  const json& stages = report.at("performance").at("stages");
  std::size_t i = 0;
  for (std::size_t k = 0; k < phases.size(); ++k) {
    const json& p = phases[k];
    if (p["global"].get<bool>()) {
      EXPECT_EQ(p["stages"].size(), 1u);
    }
    for (const json& name : p["stages"]) {
      ASSERT_LT(i, r.stages.size());
      EXPECT_EQ(name, r.stages[i].def->name);
      EXPECT_EQ(stages[i]["phase"], k);
      if (!p["skipped"].get<bool>()) {
        EXPECT_EQ(stages[i]["phase_peak_memory_bytes"], p["peak_memory_bytes"]);
      }
      ++i;
    }
    if (p["skipped"].get<bool>()) continue;
    EXPECT_GT(p["peak_memory_bytes"].get<std::uint64_t>(), 0u);
  }
  EXPECT_EQ(i, r.stages.size());
}

std::size_t count_tiles(const fs::path& dir) {
  std::error_code ec;
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir / "tiles", ec))
    if (e.path().extension() == ".rtile") ++n;
  return n;
}

}  // namespace

// ---- the grid --------------------------------------------------------------------------------

TEST(WorldGrid, TilesShareBordersAndTheLastOnesAreClipped) {
  const WorldGrid g = world_grid(257, 257, 33);
  EXPECT_EQ(g.tiles_x, 8);
  EXPECT_EQ(g.tiles_z, 8);
  EXPECT_EQ(g.window(1, 0).ix0, 32);
  EXPECT_EQ(g.window(7, 7).ix0 + g.window(7, 7).nx, 257);
  const WorldGrid c = world_grid(300, 200, 65);
  EXPECT_EQ(c.tiles_x, 5);  // 299 = 4·64 + 43
  EXPECT_EQ(c.tiles_z, 4);  // 199 = 3·64 + 7
  EXPECT_EQ(c.window(4, 0).ix0, 256);
  EXPECT_EQ(c.window(4, 0).nx, 44);
  EXPECT_EQ(c.window(0, 3).nz, 8);
  EXPECT_EQ(c.window(3, 2).nx, 65);
  // A tile longer than one axis but not the other: one clipped tile along that axis.
  const WorldGrid n = world_grid(513, 100, 129);
  EXPECT_EQ(n.tiles_z, 1);
  EXPECT_EQ(n.window(0, 0).nz, 100);
  EXPECT_EQ(world_tile_path(3, 12), "tiles/x0003_z0012.rtile");
}

TEST(WorldGrid, BadTilesAndSizesNameTheField) {
  for (int t : {0, 1, 2, 64, 100, 16385}) {
    try {
      world_grid(1025, 1025, t, "--size", "--tile");
      ADD_FAILURE() << "tile " << t << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.path(), "--tile") << t;
    }
  }
  try {
    world_grid(257, 129, 513, "--size", "--tile");
    ADD_FAILURE() << "tile larger than the world accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "--tile");
    EXPECT_NE(e.message().find("larger than the world"), std::string::npos) << e.what();
  }
  EXPECT_THROW(world_grid(1, 257, 33), Error);
  EXPECT_THROW(world_grid(kMaxWorldSize + 1, 257, 33), Error);
  EXPECT_THROW(world_grid(kMaxWorldSize, kMaxWorldSize, 33), Error);  // 32768² tiles: too many
}

// ---- exactness ---------------------------------------------------------------------------------

TEST(WorldExact, IslandTilesEqualTheWholeMapAtSeveralTileSizes) {
  const Recipe r = recipe_of(preset_doc("island"));
  const Terrain whole = whole_map(r, 257, 257);
  for (int tile : {33, 65, 129, 257}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    TempDir d("world-exact");
    const WorldReport rep = build_world(settings(r, 257, 257, tile, d / "w"));
    EXPECT_EQ(rep.tiles_built, rep.grid.count());
    const Terrain world = read_world_window(d / "w", 0, 0, 257, 257);
    expect_same_layers(whole, world);
    EXPECT_TRUE(verify_world(d / "w").empty());
  }
}

TEST(WorldExact, ClippedEdgeTilesOfANonSquareWorldEqualTheWholeMap) {
  // 300 × 200: neither side is a multiple of the tile; the last column and row are clipped.
  const Recipe r = recipe_of(preset_doc("desert"), 5);
  const Terrain whole = whole_map(r, 300, 200);
  TempDir d("world-clip");
  build_world(settings(r, 300, 200, 65, d / "w"));
  expect_same_layers(whole, read_world_window(d / "w", 0, 0, 300, 200));
  // A window across tile borders reads the same samples.
  const Terrain part = read_world_window(d / "w", 50, 60, 100, 90);
  const Layer& h = part.get("height");
  for (int j = 0; j < 90; ++j)
    for (int i = 0; i < 100; ++i)
      ASSERT_EQ(std::memcmp(&h.data[std::size_t(j) * 100 + i], &whole.get("height").data[std::size_t(60 + j) * 300 + 50 + i], 4), 0);
}

TEST(WorldExact, WideHalosOfThermalSlopeAndColourAreExact) {
  const Recipe r = recipe_of(thermal_doc(), 3);
  const Terrain whole = whole_map(r, 257, 257);
  for (int tile : {33, 129}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    TempDir d("world-thermal");
    const WorldReport rep = build_world(settings(r, 257, 257, tile, d / "w"));
    expect_same_layers(whole, read_world_window(d / "w", 0, 0, 257, 257));
    const json m = read_world_manifest(d / "w");
    EXPECT_GT(m["halo"].get<int>(), 4);  // thermal's halo is in
    for (const json& st : m["stages"]) EXPECT_EQ(st["world"], "exact");
    EXPECT_EQ(m["stages"][2]["locality"], "neighbourhood");
  }
}

TEST(WorldExact, BytesDoNotDependOnTheThreadCount) {
  const Recipe r = recipe_of(preset_doc("island"));
  TempDir a("world-t1"), b("world-t2");
  const WorldReport ra = build_world(settings(r, 257, 257, 33, a / "w", 1));
  const WorldReport rb = build_world(settings(r, 257, 257, 33, b / "w", 2));
  EXPECT_EQ(ra.tiles_at_once, 1);
  EXPECT_EQ(rb.tiles_at_once, 2);  // tile-parallel
  expect_same_store(a.path / "w", b.path / "w");
}

// Stream power's refinement (relief/world_bounded.hpp) on a world small enough for the sanitizer
// pass (the refinement's own tests are in the slow test_world_bounded): a 257² world with a coarse
// grid of 65², blocks of 64 grown by 16, 3 sweeps (so the ring records go through both temporary
// files), 5 steps. Its store does not depend on the tile size or the thread count, and it drains.
TEST(WorldBounded, SmallStreamPowerRefinementIsTheSameForAnyTileAndThreadCount) {
  json doc = preset_doc("eroded-mountains");
  json stages = json::array();
  for (const json& st : doc["stages"]) {
    stages.push_back(st);
    if (st["stage"] == "stream_power") {
      stages.back()["steps"] = 5;
      break;
    }
  }
  doc["stages"] = stages;
  const Recipe r = recipe_of(doc);
  auto build = [&](int tile, int threads, const fs::path& dir) {
    WorldSettings s = settings(r, 257, 257, tile, dir.string(), threads);
    s.algorithms["stream_power"] = world_stream_power(65, 64, 16, 3);
    return build_world(s);
  };
  TempDir a("world-sp-a"), b("world-sp-b");
  build(65, 2, a / "w");
  build(129, 1, b / "w");
  const Terrain t = read_world_window(a / "w", 0, 0, 257, 257);
  expect_same_layers(t, read_world_window(b / "w", 0, 0, 257, 257));
  EXPECT_TRUE(hydro::already_drains<float>(t.get("height").data.data(), 257, 257, float(t.frame.sea_level)));
  // Against the coarse change alone (sweeps 0), the refinement changes the heights.
  TempDir c("world-sp-c");
  WorldSettings s = settings(r, 257, 257, 65, c / "w", 2);
  s.algorithms["stream_power"] = world_stream_power(65, 64, 16, 0);
  build_world(s);
  EXPECT_NE(read_world_window(c / "w", 0, 0, 257, 257).get("height").data, t.get("height").data);
  // Two sweeps (the second one's turns read the first one's records and their earlier neighbours'
  // of their own sweep) against one (no records): the second sweep changes the heights, and the
  // world still drains.
  auto sweeps = [&](int n, const fs::path& dir) {
    WorldSettings w = settings(r, 257, 257, 65, dir.string(), 2);
    w.algorithms["stream_power"] = world_stream_power(65, 64, 16, n);
    build_world(w);
    return read_world_window(dir, 0, 0, 257, 257).get("height").data;
  };
  TempDir e("world-sp-e");
  const std::vector<float> one = sweeps(1, e / "one"), two = sweeps(2, e / "two");
  EXPECT_NE(one, two);
  EXPECT_TRUE(hydro::already_drains<float>(two.data(), 257, 257, float(t.frame.sea_level)));
}

// ---- the store -----------------------------------------------------------------------------------

// A world with global phases (noise, island, redistribute | fill | flow | color, hillshade):
// report.json lists the four phases with their resident peaks; run again, the finished phases are
// skipped and have none.
TEST(WorldStore, ReportListsThePhasesAndTheirMemory) {
  TempDir d("world-report-phases");
  const Recipe r = recipe_of(relief::test::world::river_world_doc(), 3);
  build_world(relief::test::world::settings(r, 257, 257, 65, d / "w"));
  const json first = json::parse(relief::test::slurp(d.path / "w" / "report.json"));
  const json& phases = first["performance"]["phases"];
  ASSERT_EQ(phases.size(), 4u) << phases.dump();
  EXPECT_EQ(phases[1]["stages"], json::array({"fill"}));
  EXPECT_EQ(phases[2]["stages"], json::array({"flow"}));
  for (const json& p : phases) EXPECT_FALSE(p["skipped"].get<bool>());
  expect_phase_report(first, r);
  build_world(relief::test::world::settings(r, 257, 257, 65, d / "w"));
  const json again = json::parse(relief::test::slurp(d.path / "w" / "report.json"));
  EXPECT_TRUE(again["performance"]["phases"][1]["skipped"].get<bool>());
  EXPECT_FALSE(again["performance"]["phases"][1].contains("peak_memory_bytes"));
  expect_phase_report(again, r);
}

TEST(WorldStore, ManifestDescribesTheWorldAndTheTilesVerify) {
  const Recipe r = recipe_of(preset_doc("island"));
  TempDir d("world-store");
  const WorldReport rep = build_world(settings(r, 257, 129, 65, d / "w"));
  const json m = read_world_manifest(d / "w");
  EXPECT_EQ(m["status"], "complete");
  EXPECT_EQ(m["frame"]["size"], json::array({257, 129}));
  EXPECT_EQ(m["grid"]["tiles"], json::array({4, 2}));
  EXPECT_EQ(m["tiles"].size(), 8u);
  EXPECT_EQ(m["tiles"][5]["tile"], json::array({1, 1}));
  EXPECT_EQ(m["tiles"][5]["window"], json::array({64, 64, 65, 65}));
  // Each tile's checksum is its own: the CRC-32 its trailer holds (not the whole file's CRC-32,
  // which is the same residue for every file that ends in its own CRC-32).
  std::set<std::string> sums;
  for (const json& t : m["tiles"]) sums.insert(t["crc32"].get<std::string>());
  EXPECT_EQ(sums.size(), 8u);
  EXPECT_EQ(sums.count("2144df1c"), 0u);
  // The tiles are written as text: the file is what dump(1) would give for the whole document.
  EXPECT_EQ(relief::test::slurp(d.path / "w" / "world.json"), m.dump(1) + "\n");
  EXPECT_EQ(m["world_id"], rep.world_id);
  EXPECT_EQ(m["seed"], 11);
  EXPECT_EQ(m["recipe"]["world"]["size"], json::array({257, 129}));
  std::set<std::string> layers;
  for (const json& l : m["layers"]) layers.insert(l["name"].get<std::string>());
  EXPECT_EQ(layers, (std::set<std::string>{"albedo", "color", "height", "shade"}));  // colour and hillshade's layers
  const json report = json::parse(relief::test::slurp(d.path / "w" / "report.json"));
  EXPECT_EQ(report["tiles"]["built"], 8);
  EXPECT_EQ(report["performance"]["stages"].size(), r.stages.size());
  expect_phase_report(report, r);
  EXPECT_EQ(report["estimated_store_bytes"], rep.estimated_store_bytes);
  EXPECT_EQ(report["estimated_disk_bytes"], rep.estimated_bytes);
  // overview.png: a PNG of the world's size (under 2048 px, so one pixel per sample).
  const auto png = relief::test::decode_png(relief::test::slurp(d.path / "w" / "overview.png"));
  EXPECT_EQ(png.width(), 257);
  EXPECT_EQ(png.height(), 129);
  EXPECT_TRUE(verify_world(d / "w").empty());
  // One flipped byte in a tile: the verification names it, decoding refuses it.
  const fs::path t = d.path / "w" / world_tile_path(2, 1);
  std::string bytes = relief::test::slurp(t);
  bytes[bytes.size() / 2] ^= 0x01;
  relief::test::write_text(t, bytes);
  const auto bad = verify_world(d / "w");
  ASSERT_EQ(bad.size(), 1u);
  EXPECT_EQ(bad[0], world_tile_path(2, 1));
  EXPECT_THROW(decode_world_tile(bytes), Error);
  // A rerun rebuilds the damaged tile (and only it) and the store verifies again.
  const WorldReport again = build_world(settings(r, 257, 129, 65, d / "w"));
  EXPECT_EQ(again.tiles_built, 1);
  EXPECT_EQ(again.tiles_skipped, 7);
  EXPECT_TRUE(verify_world(d / "w").empty());
}

TEST(WorldStore, TileFilesRoundTrip) {
  WorldTile t;
  t.X = 2;
  t.Z = 5;
  t.world_id = "0123456789abcdef";
  t.window = {64, 160, 33, 17};
  Layer h;
  h.data.resize(33 * 17);
  for (std::size_t k = 0; k < h.data.size(); ++k) h.data[k] = float(k) * 0.001f - 0.2f;
  h.data[7] = -0.0f;
  h.data[8] = std::numeric_limits<float>::quiet_NaN();
  h.data[9] = std::numeric_limits<float>::infinity();
  Layer c;
  c.channels = 3;
  c.data.resize(33 * 17 * 3, 0.25f);
  t.layers["height"] = h;
  t.layers["color"] = c;
  const std::string bytes = detail::encode_tile(t);
  EXPECT_EQ(bytes.substr(0, 8), "RLFTILE1");
  const WorldTile u = decode_world_tile(bytes);
  EXPECT_EQ(u.X, 2);
  EXPECT_EQ(u.Z, 5);
  EXPECT_EQ(u.world_id, t.world_id);
  EXPECT_EQ(u.window.ix0, 64);
  EXPECT_EQ(u.window.nz, 17);
  ASSERT_EQ(u.layers.size(), 2u);
  EXPECT_TRUE(relief::test::same_bits(u.layers.at("height").data, h.data));  // -0, NaN, inf kept
  EXPECT_EQ(u.layers.at("color").channels, 3);
  EXPECT_TRUE(relief::test::same_bits(u.layers.at("color").data, c.data));
  EXPECT_EQ(detail::encode_tile(u), bytes);  // deterministic
  // Round trip through a real build's file: decode what the builder wrote and compare with run().
  const Recipe r = recipe_of(preset_doc("hills"));
  TempDir w("world-rt2");
  build_world(settings(r, 65, 65, 33, w / "w"));
  const WorldTile back = read_world_tile(w / "w", 1, 0);
  EXPECT_EQ(back.X, 1);
  EXPECT_EQ(back.window.ix0, 32);
  EXPECT_EQ(back.window.nx, 33);
  Recipe rr = r;
  rr.world.nx = rr.world.nz = 65;
  RunOptions opt;
  opt.window = rr.world.frame().window(32, 0, 33, 33);
  const Terrain direct = run(rr, opt).terrain;
  for (auto& [name, l] : direct.layers) {
    ASSERT_TRUE(back.layers.count(name)) << name;
    EXPECT_TRUE(relief::test::same_bits(l.data, back.layers.at(name).data)) << name;
  }
  // Truncated and empty files are refused, naming the file.
  const std::string full = relief::test::slurp(w.path / "w" / world_tile_path(1, 0));
  EXPECT_THROW(decode_world_tile(full.substr(0, full.size() - 9), "x"), Error);
  EXPECT_THROW(decode_world_tile("", "x"), Error);
}

// ---- resuming -----------------------------------------------------------------------------------

TEST(WorldResume, CancelledBuildResumesToTheSameBytes) {
  const Recipe r = recipe_of(preset_doc("island"));
  TempDir ref("world-ref"), part("world-part");
  build_world(settings(r, 257, 257, 33, ref / "w"));
  WorldSettings s = settings(r, 257, 257, 33, part / "w", 1);
  int n = 0;
  s.after_tile = [&](std::int64_t, std::int64_t) {
    if (++n == 10) throw Cancelled();
  };
  EXPECT_THROW(build_world(s), Cancelled);
  EXPECT_EQ(read_world_manifest(part / "w")["status"], "building");
  EXPECT_EQ(count_tiles(part.path / "w"), 10u);
  const WorldReport rep = build_world(settings(r, 257, 257, 33, part / "w"));
  EXPECT_EQ(rep.tiles_skipped, 10);
  EXPECT_EQ(rep.tiles_built, 54);
  expect_same_store(ref.path / "w", part.path / "w");
}

TEST(WorldResume, WithoutASeedTheFolderSeedIsReused) {
  json doc = preset_doc("hills");
  doc.erase("seed");
  const Recipe r = parse_recipe(doc);
  TempDir d("world-seed");
  const WorldReport a = build_world(settings(r, 129, 129, 33, d / "w"));
  const WorldReport b = build_world(settings(r, 129, 129, 33, d / "w"));
  EXPECT_FALSE(a.seed_reused);
  EXPECT_TRUE(b.seed_reused);
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_EQ(b.tiles_skipped, b.grid.count());
}

// ---- refusals -------------------------------------------------------------------------------------

TEST(WorldErrors, GlobalStagesAreRefusedUpFront) {
  json doc = preset_doc("island");  // noise, island, …, then a tilemap: global, with no world algorithm
  doc["stages"].push_back({{"stage", "tilemap"}});
  const Recipe r = recipe_of(doc);
  TempDir d("world-global");
  try {
    build_world(settings(r, 257, 257, 65, d / "w"));
    ADD_FAILURE() << "a global stage was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[" + std::to_string(r.stages.size() - 1) + "]");
    EXPECT_NE(e.message().find("no world support yet"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(d.path / "w"));  // nothing written
}

TEST(WorldErrors, AFolderHoldingADifferentWorldIsRefusedUnlessForced) {
  const Recipe r = recipe_of(preset_doc("island"));
  TempDir d("world-diff");
  build_world(settings(r, 129, 129, 33, d / "w"));
  const std::string before = relief::test::slurp(d.path / "w" / world_tile_path(0, 0));
  auto expect_refused = [&](WorldSettings s, const char* what) {
    s.out_path = "--out";
    s.force_name = "--force";
    try {
      build_world(std::move(s));
      ADD_FAILURE() << what << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.path(), "--out") << what;
      EXPECT_NE(e.message().find("--force"), std::string::npos) << e.what();
    }
  };
  expect_refused(settings(recipe_of(preset_doc("island"), 12), 129, 129, 33, d / "w"), "another seed");
  expect_refused(settings(r, 129, 129, 65, d / "w"), "another tile");
  expect_refused(settings(r, 161, 129, 33, d / "w"), "another size");
  json changed = preset_doc("island");
  changed["stages"][0]["octaves"] = 3;
  expect_refused(settings(recipe_of(changed), 129, 129, 33, d / "w"), "another recipe");
  EXPECT_EQ(relief::test::slurp(d.path / "w" / world_tile_path(0, 0)), before);  // untouched
  // --force replaces it: every old tile goes (the new grid has fewer), the new world verifies.
  WorldSettings s = settings(r, 129, 129, 65, d / "w");
  s.force = true;
  const WorldReport rep = build_world(s);
  EXPECT_EQ(rep.tiles_built, 4);
  EXPECT_EQ(count_tiles(d.path / "w"), 4u);
  EXPECT_TRUE(verify_world(d / "w").empty());
}

TEST(WorldErrors, AWorldTooLargeForTheDiskIsRefusedBeforeStarting) {
  const Recipe r = recipe_of(preset_doc("island"));
  TempDir d("world-disk");
  WorldSettings s = settings(r, 257, 257, 65, d / "w");
  s.disk_free_bytes = 100000;  // far less than 257² samples of 5 channels
  try {
    build_world(s);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "world.size");
    EXPECT_NE(e.message().find("on disk"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(d.path / "w"));
}

TEST(WorldErrors, TilesTooLargeForTheMemoryBudgetAreRefused) {
  const Recipe r = recipe_of(preset_doc("island"));
  TempDir d("world-mem");
  WorldSettings s = settings(r, 1025, 1025, 1025, d / "w");
  s.memory_budget_bytes = 8 << 20;
  try {
    build_world(s);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "tile");
  }
}

// A world whose tiles fit but whose droplet erosion's groups do not: the refusal names the stage,
// not the tile (a droplet's reach of about 1000 cells of 1 m makes a group's window most of a 2049²
// world, far more than a tile of 129).
TEST(WorldErrors, AWorldAlgorithmTooLargeForTheMemoryBudgetNamesItsStage) {
  const Recipe r = recipe_of(json::parse(R"({"name": "rain", "world": {"size": 2049, "width_m": 2048, "height_m": 300, "sea_level": 0.1},
    "stages": [{"stage": "noise", "basis": "gradient", "fractal": "fbm", "octaves": 4, "frequency": 4},
               {"stage": "hydraulic", "droplets_per_km2": 2000, "lifetime": 200, "step_m": 5, "brush_radius_m": 6}]})"));
  TempDir d("world-mem-stage");
  WorldSettings s = settings(r, 2049, 2049, 129, d / "w");
  s.memory_budget_bytes = 64 << 20;
  try {
    build_world(s);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[1]") << e.what();
    EXPECT_NE(e.message().find("'hydraulic'"), std::string::npos) << e.what();
    EXPECT_NE(e.message().find("lifetime"), std::string::npos) << e.what();
  }
  s.memory_budget_bytes = 0;  // the machine's: it fits, and only the dry run is asked for
  s.dry_run = true;
  const WorldReport dry = build_world(s);
  EXPECT_EQ(dry.memory_stage, "hydraulic");
  EXPECT_GT(dry.tile_memory_bytes, std::uint64_t(64) << 20);
}

// ---- the CLI -----------------------------------------------------------------------------------

TEST(WorldCli, BuildsAStoreAndRefusesBadInputWithExitCode2) {
  TempDir d("world-cli");
  const std::string out = d / "w";
  const auto ok = relief::test::relief_cli("world island --size 129 --tile 33 --seed 4 -q -o " + out);
  ASSERT_EQ(ok.code, 0) << ok.out;
  EXPECT_TRUE(ok.out.empty()) << ok.out;  // -q
  EXPECT_TRUE(verify_world(out).empty());
  // The CLI's world equals the library's whole-map run.
  expect_same_layers(whole_map(recipe_of(preset_doc("island"), 4), 129, 129), read_world_window(out, 0, 0, 129, 129));
  relief::test::expect_cli_error("world island --size 257 --tile 64 -o " + (d / "a"), "--tile: expected a tile size of 2^n+1");
  relief::test::expect_cli_error("world island --size 257 --tile 513 -o " + (d / "a"), "larger than the world");
  {  // a stage with no world algorithm: the tilemap (its grid stretches over the whole map)
    json doc = preset_doc("island");
    doc["stages"].push_back({{"stage", "tilemap"}});
    relief::test::write_text(d / "tilemap.json", doc.dump());
    relief::test::expect_cli_error("world " + (d / "tilemap.json") + " --size 257 --tile 65 -o " + (d / "a"),
                                   "stages[" + std::to_string(doc["stages"].size() - 1) + "]: 'tilemap' has no world support yet");
    EXPECT_FALSE(fs::exists(d / "a"));
  }
  relief::test::expect_cli_error("world island --size 129 --tile 33 --seed 5 -q -o " + out, "--out: the folder");
  relief::test::expect_cli_error("world island --size 1048577 --tile 8193 -o " + (d / "a"), "on disk");
  relief::test::expect_cli_error("world island --size 1048578 --tile 33 -o " + (d / "a"), "--size");
  const auto forced = relief::test::relief_cli("world island --size 129 --tile 33 --seed 5 -q --force -o " + out);
  EXPECT_EQ(forced.code, 0) << forced.out;
}

// SIGKILL at several points of a CLI build; the rerun gives the uninterrupted build's bytes.
TEST(WorldCli, ResumeAfterSigkillGivesTheSameBytes) {
  TempDir ref("world-kill-ref");
  const std::string args = "world island --size 513 --tile 33 --seed 9 -q -j 1";
  const auto full = relief::test::relief_cli(args + " -o " + (ref / "w"));
  ASSERT_EQ(full.code, 0) << full.out;
  int resumed_partial = 0;
  for (std::size_t kill_at : {std::size_t(0), std::size_t(20), std::size_t(150)}) {
    SCOPED_TRACE("kill after " + std::to_string(kill_at) + " tiles");
    TempDir d("world-kill");
    const fs::path out = d.path / "w";
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      const std::string o = out.string();
      ::freopen("/dev/null", "w", stdout);
      ::execl(RELIEF_BINARY, RELIEF_BINARY, "world", "island", "--size", "513", "--tile", "33", "--seed", "9", "-q", "-j", "1",
              "-o", o.c_str(), (char*)nullptr);
      ::_exit(127);
    }
    const auto t0 = std::chrono::steady_clock::now();
    int st = 0;
    bool exited = false;
    while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(60) && !exited) {
      if (fs::exists(out / "world.json") && count_tiles(out) >= kill_at) break;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      exited = ::waitpid(pid, &st, WNOHANG) == pid;
    }
    if (!exited) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &st, 0);
    }
    if (WIFSIGNALED(st) && fs::exists(out / "world.json") && read_world_manifest(out.string())["status"] == "building") ++resumed_partial;
    const auto again = relief::test::relief_cli(args + " -o " + out.string());
    ASSERT_EQ(again.code, 0) << again.out;
    expect_same_store(ref.path / "w", out);
    for (const auto& e : fs::recursive_directory_iterator(out))
      EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();  // no temporaries left
  }
  EXPECT_GE(resumed_partial, 2);  // the kills landed mid-build (256 tiles take far longer than the polls)
}

// ---- phase 2: depression filling that tiles can reproduce -----------------------------------------

namespace {

// A 9×3 grid: a flat trough (0) between two equal spills (1.0) on the left and right borders, high
// walls (5.0) above and below.
std::vector<float> trough() {
  std::vector<float> z(9 * 3, 5.0f);
  for (int j = 0; j < 3; ++j) z[std::size_t(j) * 9] = z[std::size_t(j) * 9 + 8] = 1.0f;
  for (int i = 1; i < 8; ++i) z[9 + std::size_t(i)] = 0.0f;
  return z;
}

// The island preset's heights at n² (seed 2), with a flat-floored basin cut into it so that one
// depression spans many tiles.
std::vector<float> basin_world(int n) {
  Recipe r = recipe_of(preset_doc("island"), 2);
  r.world.nx = r.world.nz = n;
  std::vector<float> z = run(r).terrain.get("height").data;
  for (int j = n / 4; j < 3 * n / 4; ++j)
    for (int i = n / 5; i < 4 * n / 5; ++i) z[std::size_t(j) * n + i] = 0.45f;  // above the sea (0.4): a lake bed
  return z;
}

std::vector<float> tiled_fill(const std::vector<float>& z, int nx, int nz, int tile, float sea, float eps, TiledFillStats* stats = nullptr) {
  const WorldGrid g = world_grid(nx, nz, tile);
  std::vector<float> out(z.size(), std::numeric_limits<float>::quiet_NaN());
  auto load = [&](std::int64_t X, std::int64_t Z) {
    const WorldGrid::Window w = g.window(X, Z);
    std::vector<float> t(std::size_t(w.nx) * w.nz);
    for (int j = 0; j < w.nz; ++j)
      for (int i = 0; i < w.nx; ++i) t[std::size_t(j) * w.nx + i] = z[std::size_t(w.iz0 + j) * nx + std::size_t(w.ix0 + i)];
    return t;
  };
  auto store = [&](std::int64_t X, std::int64_t Z, std::vector<float> f) {
    const WorldGrid::Window w = g.window(X, Z);
    for (int j = 0; j < w.nz; ++j)
      for (int i = 0; i < w.nx; ++i) out[std::size_t(w.iz0 + j) * nx + std::size_t(w.ix0 + i)] = f[std::size_t(j) * w.nx + i];
  };
  const TiledFillStats st = fill_depressions_tiled(g, sea, eps, load, store);
  if (stats) *stats = st;
  return out;
}

}  // namespace

// The fill is a least fixpoint, so it does not depend on which of two equal spills the flood pops
// first: both ends of the trough sit one step above their spill, and the middle four steps up,
// rounded step by step. (The Priority-Flood+ε with a FIFO pit queue that came before raised the
// whole trough from whichever spill it popped first: its far end sat 7ε above the spill.)
TEST(WorldFill, FillDoesNotDependOnTheProcessingOrder) {
  const float eps = 0.01f;
  std::vector<float> a = trough();
  hydro::fill_depressions<float>(a.data(), 9, 3, 0.0f, eps);
  EXPECT_EQ(a[9 + 1], a[9 + 7]);
  EXPECT_EQ(a[9 + 1], 1.0f + eps);
  EXPECT_EQ(a[9 + 4], (1.0f + eps + eps) + eps + eps);
  // A symmetric input gives symmetric levels.
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 9; ++i) EXPECT_EQ(a[std::size_t(j) * 9 + i], a[std::size_t(j) * 9 + std::size_t(8 - i)]);
  // A cell less than ε above the level it drains to keeps its height (g(L, z) = z when z > L).
  std::vector<float> g = {5, 5, 5, 5, 5, 1.0f, 1.005f, 2, 5, 5, 5, 5, 5, 5, 5};  // 5×3, spill at (0, 1)
  hydro::fill_depressions<float>(g.data(), 5, 3, 0.0f, eps);
  EXPECT_EQ(g[6], 1.005f);
  EXPECT_EQ(g[7], 2.0f);
}

TEST(WorldFill, FillDrainsEverySample) {
  const int n = 129;
  const std::vector<float> z = basin_world(n);
  for (float eps : {0.0f, 1e-5f}) {
    std::vector<float> f = z;
    hydro::fill_depressions<float>(f.data(), n, n, 0.4f, eps);
    for (int j = 1; j < n - 1; ++j)
      for (int i = 1; i < n - 1; ++i) {
        const std::size_t c = std::size_t(j) * n + i;
        ASSERT_GE(f[c], z[c]);
        if (z[c] < 0.4f) continue;
        bool lower = false;
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) lower = lower || f[std::size_t(j + dj) * n + i + di] < f[c];
        ASSERT_TRUE(lower) << "sample " << i << "," << j << " does not drain";
        if (f[c] > z[c]) {  // raised: by at least eps above the neighbour it drains to
          float lowest = f[c];
          for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) lowest = std::min(lowest, f[std::size_t(j + dj) * n + i + di]);
          ASSERT_GE(double(f[c]) - double(lowest), double(eps) * 0.999) << i << "," << j;
        }
      }
    // The basin's floor was raised (it is a closed depression).
    EXPECT_GT(f[std::size_t(n / 2) * n + n / 2], 0.45f);
  }
}

TEST(WorldFill, TiledFillEqualsTheWholeMapBitForBit) {
  const int n = 257;
  const std::vector<float> z = basin_world(n);
  for (float eps : {0.0f, 2e-6f}) {
    std::vector<float> ref = z;
    hydro::fill_depressions<float>(ref.data(), n, n, 0.4f, eps);
    for (int tile : {17, 33, 65, 129, 257}) {
      SCOPED_TRACE("tile " + std::to_string(tile) + " eps " + std::to_string(eps));
      TiledFillStats st;
      const std::vector<float> got = tiled_fill(z, n, n, tile, 0.4f, eps, &st);
      EXPECT_TRUE(relief::test::same_bits(ref, got));
      if (tile < 257) {
        EXPECT_GT(st.rounds, 1);  // the basin spans tiles: borders had to be exchanged
      }
      if (tile < 257) {
        // Peer: each tile filled alone (its border as outlets) is not the world's fill.
        const WorldGrid g = world_grid(n, n, tile);
        std::vector<float> naive(z.size());
        for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
          for (std::int64_t X = 0; X < g.tiles_x; ++X) {
            const WorldGrid::Window w = g.window(X, Z);
            std::vector<float> t(std::size_t(w.nx) * w.nz);
            for (int j = 0; j < w.nz; ++j)
              for (int i = 0; i < w.nx; ++i) t[std::size_t(j) * w.nx + i] = z[std::size_t(w.iz0 + j) * n + std::size_t(w.ix0 + i)];
            hydro::fill_depressions<float>(t.data(), w.nx, w.nz, 0.4f, eps);
            for (int j = 0; j < w.nz; ++j)
              for (int i = 0; i < w.nx; ++i) naive[std::size_t(w.iz0 + j) * n + std::size_t(w.ix0 + i)] = t[std::size_t(j) * w.nx + i];
          }
        EXPECT_FALSE(relief::test::same_bits(ref, naive));
      }
    }
  }
  // A non-square world whose last tiles are clipped.
  const std::vector<float> zs(z.begin(), z.begin() + std::ptrdiff_t(257) * 200);
  std::vector<float> ref = zs;
  hydro::fill_depressions<float>(ref.data(), 257, 200, 0.4f, 1e-6f);
  EXPECT_TRUE(relief::test::same_bits(ref, tiled_fill(zs, 257, 200, 65, 0.4f, 1e-6f)));
}

// ---- progress and interrupts ----------------------------------------------------------------------

TEST(WorldProgress, CountsTilesAndStagesAndEndsAtOne) {
  const Recipe r = recipe_of(preset_doc("island"));
  TempDir d("world-progress");
  for (int pass = 0; pass < 2; ++pass) {  // a build, then a resume that skips every tile
    std::vector<WorldProgress> seen;
    std::vector<std::string> stages;
    WorldSettings s = settings(r, 257, 257, 129, d / "w", 1);
    s.progress = [&](const WorldProgress& p) {
      seen.push_back(p);
      if (!p.stage_name.empty()) stages.emplace_back(p.stage_name);
    };
    build_world(s);
    ASSERT_FALSE(seen.empty());
    for (std::size_t k = 1; k < seen.size(); ++k) {
      EXPECT_GE(seen[k].fraction, seen[k - 1].fraction);
      EXPECT_GE(seen[k].tiles_done, seen[k - 1].tiles_done);
    }
    EXPECT_EQ(seen.back().tiles_done, 4);
    EXPECT_EQ(seen.back().tiles_total, 4);
    EXPECT_DOUBLE_EQ(seen.back().fraction, 1.0);
    if (pass == 0) {
      EXPECT_EQ(seen.back().tiles_skipped, 0);
      EXPECT_NE(std::find(stages.begin(), stages.end(), "hillshade"), stages.end());  // stages are named
      EXPECT_GE(seen.back().seconds_left, 0.0);
    } else {
      EXPECT_EQ(seen.back().tiles_skipped, 4);
    }
  }
}

TEST(WorldCli, SigintKeepsTheFinishedTilesAndTheRerunResumes) {
  TempDir ref("world-int-ref"), d("world-int");
  const auto full = relief::test::relief_cli("world island --size 513 --tile 33 --seed 8 -q -j 1 -o " + (ref / "w"));
  ASSERT_EQ(full.code, 0) << full.out;
  const fs::path out = d.path / "w", err = d.path / "stderr.txt";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::freopen(err.c_str(), "w", stderr);
    ::freopen("/dev/null", "w", stdout);
    const std::string o = out.string();
    ::execl(RELIEF_BINARY, RELIEF_BINARY, "world", "island", "--size", "513", "--tile", "33", "--seed", "8", "-j", "1", "-o", o.c_str(),
            (char*)nullptr);
    ::_exit(127);
  }
  const auto t0 = std::chrono::steady_clock::now();
  int st = 0;
  bool exited = false;  // e.g. the binary could not be run
  while (count_tiles(out) < 30 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(60) && !exited) {
    std::this_thread::sleep_for(std::chrono::microseconds(200));
    exited = ::waitpid(pid, &st, WNOHANG) == pid;
  }
  if (!exited) {
    ::kill(pid, SIGINT);
    ::waitpid(pid, &st, 0);
  }
  if (WIFEXITED(st) && WEXITSTATUS(st) == 0) GTEST_SKIP() << "the build finished before the interrupt";
  ASSERT_TRUE(WIFEXITED(st));
  EXPECT_EQ(WEXITSTATUS(st), 130);
  EXPECT_NE(relief::test::slurp(err).find("finished tiles are kept"), std::string::npos) << relief::test::slurp(err);
  const std::size_t kept = count_tiles(out);
  EXPECT_GE(kept, 30u);
  const auto again = relief::test::relief_cli("world island --size 513 --tile 33 --seed 8 -j 1 -o " + out.string());
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_NE(again.out.find(std::to_string(kept) + " resumed"), std::string::npos) << again.out;
  fs::remove(err);
  expect_same_store(ref.path / "w", out);
}

// ---- phases: a global stage run by a world algorithm ------------------------------------------------

namespace {

// island + fill (+ colour and hillshade after it, when `after`).
json fill_doc(bool after) {
  json doc = load_preset("island");
  json stages = json::array({doc["stages"][0], doc["stages"][1], doc["stages"][2], json{{"stage", "fill"}, {"epsilon_m", 0.01}}});
  if (after) {
    stages.push_back(doc["stages"][3]);
    stages.push_back(doc["stages"][4]);
  }
  doc["stages"] = stages;
  return doc;
}

}  // namespace

TEST(WorldPhases, AWorldAlgorithmBetweenLocalPhasesIsExact) {
  const Recipe r = recipe_of(fill_doc(true), 4);
  const Terrain whole = whole_map(r, 257, 257);
  Recipe unfilled = r;
  unfilled.stages.resize(3);
  ASSERT_FALSE(relief::test::same_bits(whole.get("height").data, whole_map(unfilled, 257, 257).get("height").data));  // it filled
  for (int tile : {33, 129}) {
    SCOPED_TRACE("tile " + std::to_string(tile));
    TempDir d("world-phases");
    const WorldReport rep = build_world(settings(r, 257, 257, tile, d / "w"));
    expect_same_layers(whole, read_world_window(d / "w", 0, 0, 257, 257));
    EXPECT_TRUE(verify_world(d / "w").empty());
    EXPECT_FALSE(fs::exists(d.path / "w" / "phase-0"));  // intermediate phases removed at the end
    EXPECT_EQ(read_world_manifest(d / "w")["stages"][3]["world"], "exact");
    EXPECT_EQ(rep.tiles_built, 2 * rep.grid.count());  // two local phases
  }
}

TEST(WorldPhases, AWorldAlgorithmAsTheLastStageIsExact) {
  const Recipe r = recipe_of(fill_doc(false), 6);
  const Terrain whole = whole_map(r, 200, 257);
  TempDir d("world-phase-last");
  build_world(settings(r, 200, 257, 65, d / "w"));
  expect_same_layers(whole, read_world_window(d / "w", 0, 0, 200, 257));
  EXPECT_TRUE(verify_world(d / "w").empty());
}

TEST(WorldPhases, ACancelledPhasedBuildResumesToTheSameBytes) {
  const Recipe r = recipe_of(fill_doc(true), 4);
  TempDir ref("world-ph-ref"), part("world-ph-part");
  build_world(settings(r, 257, 257, 65, ref / "w"));
  for (int stop : {5, 20, 28}) {  // in the first local phase, and in the second (16 tiles each)
    SCOPED_TRACE("cancelled after " + std::to_string(stop) + " tiles");
    WorldSettings s = (settings(r, 257, 257, 65, part / "w", 1));
    int n = 0;
    s.after_tile = [&](std::int64_t, std::int64_t) {
      if (++n == stop) throw Cancelled();
    };
    EXPECT_THROW(build_world(s), Cancelled);
    if (stop > 16) {
      EXPECT_TRUE(fs::exists(part.path / "w" / "phase-0" / "complete"));
    }
    build_world(settings(r, 257, 257, 65, part / "w"));
    expect_same_store(ref.path / "w", part.path / "w");
    fs::remove_all(part.path / "w");
  }
}

TEST(WorldPhases, AGlobalStageWithoutAnAlgorithmIsStillRefused) {
  json doc = fill_doc(true);
  doc["stages"][3] = json{{"stage", "tilemap"}};  // global, no world algorithm
  TempDir d("world-ph-refuse");
  try {
    build_world(settings(recipe_of(doc, 4), 257, 257, 65, d / "w"));
    ADD_FAILURE() << "tilemap accepted without a world algorithm";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[3]");
    EXPECT_NE(e.message().find("no world support yet"), std::string::npos) << e.what();
  }
  EXPECT_EQ(default_world_algorithms().count("fill"), 1u);
}

// A world wider than one map may be (kMaxSize samples): the frame and the tiles still follow the
// whole-map run of the same recipe at that size (which run() computes when asked directly).
TEST(WorldExact, AWorldWiderThanOneMapEqualsTheWholeRun) {
  const Recipe r = recipe_of(preset_doc("hills"), 7);
  const int nx = kMaxSize + 2048, nz = 33;
  const Terrain whole = whole_map(r, nx, nz);
  TempDir d("world-wide");
  const WorldReport rep = build_world(settings(r, nx, nz, 2049, d / "w"));
  EXPECT_EQ(rep.grid.tiles_x, 17);
  EXPECT_EQ(read_world_manifest(d / "w")["frame"]["size"][0], nx);
  expect_same_layers(whole, read_world_window(d / "w", 0, 0, nx, nz));
}

// What `relief explain` and world.json say each stage guarantees in a world build.
TEST(WorldGuarantees, FromTheStagesLocalityAndTheLibrarysWorldAlgorithms) {
  auto of = [](const char* name) { return world_guarantee(*find_stage(name)); };
  EXPECT_EQ(of("noise").guarantee, "exact");
  EXPECT_NE(of("noise").how.find("pointwise"), std::string::npos);
  EXPECT_EQ(of("thermal").guarantee, "exact");
  EXPECT_NE(of("thermal").how.find("halo"), std::string::npos) << of("thermal").how;
  EXPECT_EQ(of("fill").guarantee, "exact");
  EXPECT_NE(of("fill").how.find("Barnes"), std::string::npos);
  EXPECT_EQ(of("tilemap").guarantee, "none");
  EXPECT_NE(of("tilemap").how.find("whole map"), std::string::npos) << of("tilemap").how;
  // Every stage the library registers a world algorithm for says so.
  for (const auto& [name, algo] : default_world_algorithms()) EXPECT_NE(of(name.c_str()).guarantee, "none") << name;
  EXPECT_EQ(of("hydraulic").guarantee, "exact");
  EXPECT_EQ(of("stream_power").guarantee, "bounded");
  EXPECT_NE(of("stream_power").how.find("grid of at most 2049"), std::string::npos) << of("stream_power").how;
  // The CLI prints it.
  const auto out = relief::test::relief_cli("explain fill");
  ASSERT_EQ(out.code, 0) << out.out;
  EXPECT_NE(out.out.find("world builds: exact"), std::string::npos) << out.out;
  const auto sp = relief::test::relief_cli("explain stream_power");
  ASSERT_EQ(sp.code, 0) << sp.out;
  EXPECT_NE(sp.out.find("world builds: bounded"), std::string::npos) << sp.out;
}

// world.json says the same as `relief explain`: stream power bounded, the rest exact.
TEST(WorldGuarantees, TheManifestSaysWhatEachStageGuarantees) {
  json doc = preset_doc("eroded-mountains");
  json stages = json::array();
  for (const json& st : doc["stages"]) {
    json c = st;
    if (c["stage"] == "stream_power") c["steps"] = 5;
    if (c["stage"] == "hydraulic") c["droplets_per_km2"] = 100;
    stages.push_back(c);
  }
  doc["stages"] = stages;
  const Recipe r = recipe_of(doc, 2);
  TempDir d("world-guarantees");
  build_world(settings(r, 129, 129, 65, d / "w"));
  const json m = read_world_manifest(d / "w");
  ASSERT_EQ(m["stages"].size(), r.stages.size());
  int bounded = 0;
  for (const json& st : m["stages"]) {
    const std::string name = st["stage"];
    EXPECT_EQ(st["world"], world_guarantee(*find_stage(name)).guarantee) << name;
    EXPECT_EQ(st["world_how"], world_guarantee(*find_stage(name)).how) << name;
    EXPECT_EQ(st["world"], name == "stream_power" ? "bounded" : "exact") << name;
    bounded += st["world"] == "bounded";
  }
  EXPECT_EQ(bounded, 1);
}

// A recipe of the river-island kind whose every stage is exact (fill and flow by their world
// algorithms): the world equals the whole map for tiles that cut its rivers, a clipped last row and
// column included (the 2049² version with tiles of 257, 513 and 1025 is test_world_exact, slow).
TEST(WorldExact, RiverWorldWithFillAndFlowEqualsTheWholeMap) {
  const Recipe r = recipe_of(river_world_doc(), 3);
  for (auto [nx, nz, tile] : {std::tuple{513, 513, 65}, std::tuple{513, 500, 129}}) {
    SCOPED_TRACE(std::to_string(nx) + "x" + std::to_string(nz) + " tile " + std::to_string(tile));
    const Terrain whole = whole_map(r, nx, nz);
    ASSERT_TRUE(whole.has("flow") && whole.has("water"));
    TempDir d("world-rivers");
    build_world(settings(r, nx, nz, tile, d / "w"));
    expect_same_layers(whole, read_world_window(d / "w", 0, 0, nx, nz));
  }
}
