// Engine tile sets and the LOD pyramid from a world's tile store (relief/world_engine.hpp):
//   - `relief world --engine E --split KxM` writes the same files, byte for byte, as `relief
//     generate --engine E --split KxM` at the same size, for Unity, Unreal and Godot (EXR and r16),
//     with world tiles that do not line up with the engine tiles (clipped edge tiles included);
//   - the tiles, read back by Debian's Python (numpy, Pillow) or, for EXR, three.js's EXRLoader (a
//     JavaScript decoder, apart from the OpenEXR library that writes them) — not by our encoders —
//     share their borders (Unity, Godot) or abut (Unreal) and reassemble the world's heights;
//   - the LOD pyramid: level 0 is the store, level k is level k−1 at every other sample (checked by
//     Python from the PNGs), tile sizes and counts as documented;
//   - bad input (an engine tiling that does not fit the world) exits 2 naming the flag, before any
//     tile is built.

#include <cstring>
#include <filesystem>
#include <map>
#include <set>

#include "relief/recipe.hpp"
#include "relief/world.hpp"
#include "relief/world_engine.hpp"
#include "support.hpp"

using namespace relief;
using relief::test::relief_cli;
using relief::test::slurp;
using relief::test::TempDir;
namespace fs = std::filesystem;

namespace {

// The island preset without its global stage (redistribute): noise, island falloff, colour,
// hillshade — every stage local, so a world build is exact; the colour stage gives a color layer.
std::string write_recipe(const TempDir& d) {
  json doc = load_preset("island");
  json stages = json::array();
  for (int k : {0, 1, 3, 4}) stages.push_back(doc["stages"][k]);
  doc["stages"] = stages;
  const std::string path = d / "recipe.json";
  relief::test::write_text(path, doc.dump(2));
  return path;
}

std::uint16_t u16(float v) {
  const double d = v;
  if (!(d > 0.0)) return 0;
  return std::uint16_t((d < 1.0 ? d : 1.0) * 65535.0 + 0.5);
}

std::set<std::string> names_in(const fs::path& dir, const std::string& prefix) {
  std::set<std::string> s;
  for (auto& e : fs::directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    if (n.rfind(prefix, 0) == 0) s.insert(n);
  }
  return s;
}

struct Case {
  std::string engine, split, size, format;
  int tile;  // the world's tile (chosen not to line up with the engine tiles)
};

// Builds the world and the whole map; returns the world's folder.
void build_both(const Case& c, const TempDir& d, const std::string& recipe) {
  const std::string fmt = c.format.empty() ? "" : " --godot-format " + c.format;
  const auto g = relief_cli("generate " + recipe + " --seed 5 --size " + c.size + " --formats engine --engine " + c.engine + " --split " +
                            c.split + fmt + " -q -o " + (d / "generate"));
  ASSERT_EQ(g.code, 0) << g.out;
  const auto w = relief_cli("world " + recipe + " --seed 5 --size " + c.size + " --tile " + std::to_string(c.tile) + " --engine " +
                            c.engine + " --split " + c.split + fmt + " -q -o " + (d / "world"));
  ASSERT_EQ(w.code, 0) << w.out;
}

// Debian's Python reassembles the map from the tiles as each engine places them, checking that
// overlapping samples (shared borders) agree, and writes it as little-endian u16 (full.u16).
const char* kAssemble = R"PY(
import json, sys
import numpy as np
from PIL import Image
d = sys.argv[1]
s = json.load(open(d + '/' + sys.argv[2]))
t, ov = s['samples_per_tile'], s['overlap_samples']
st = t - ov
nx, nz = s['tiles_x'] * st + ov, s['tiles_y'] * st + ov
full = np.zeros((nz, nx), dtype=np.uint16)
seen = np.zeros((nz, nx), dtype=bool)
shared = 0
for tile in s['tiles']:
    f = d + '/' + tile['file']
    if f.endswith('.png'):
        im = Image.open(f)
        assert im.size == (t, t), im.size
        a = np.array(im).astype(np.uint16)
    else:
        a = np.fromfile(f, dtype='<u2')
        assert a.size == t * t, a.size
        a = a.reshape(t, t)
    if s['rows_flipped']:
        a = a[::-1, :]
    y0, x0 = tile['y'] * st, tile['x'] * st
    win, was = full[y0:y0 + t, x0:x0 + t], seen[y0:y0 + t, x0:x0 + t]
    if not np.array_equal(win[was], a[was]):
        sys.exit('tile %s disagrees with its neighbours on their shared samples' % tile['file'])
    shared += int(was.sum())
    win[...] = a
    was[...] = True
assert seen.all(), 'samples no tile covers'
full.astype('<u2').tofile(d + '/full.u16')
print(shared)
)PY";

// Runs kAssemble on a folder; returns the shared sample count it printed (−1 on failure).
long assemble(const fs::path& dir, const std::string& sidecar) {
  relief::test::write_text(dir / "assemble.py", kAssemble);
  const auto r = relief::test::sh(std::string(RELIEF_SYSTEM_PYTHON) + " '" + (dir / "assemble.py").string() + "' '" + dir.string() + "' " + sidecar);
  EXPECT_EQ(r.code, 0) << r.out;
  return r.code == 0 ? std::stol(r.out) : -1;
}

// Every EXR tile of a folder, decoded by three.js's EXRLoader under node (tests/clients/exr_read.mjs):
// file name → (width, height, values from the top row).
struct Exr {
  int w = 0, h = 0;
  std::vector<float> px;
};
std::map<std::string, Exr> read_exr_js(const fs::path& dir, const std::vector<std::string>& files) {
  const fs::path three = fs::path(RELIEF_SOURCE_DIR) / "web" / "node_modules" / "three";
  EXPECT_TRUE(fs::exists(three / "examples" / "jsm" / "loaders" / "EXRLoader.js")) << "run scripts/setup.sh (npm ci in web/)";
  std::string cmd = "node '" + (fs::path(RELIEF_SOURCE_DIR) / "tests" / "clients" / "exr_read.mjs").string() + "' '" + three.string() + "'";
  for (const std::string& f : files) cmd += " '" + (dir / f).string() + "'";
  const auto r = relief::test::sh(cmd);
  EXPECT_EQ(r.code, 0) << r.out.substr(0, 2000);
  std::map<std::string, Exr> out;
  std::size_t at = 0;
  while (r.code == 0 && at < r.out.size()) {
    const std::size_t end = r.out.find('\n', at);
    const std::string line = r.out.substr(at, end == std::string::npos ? std::string::npos : end - at);
    at = end == std::string::npos ? r.out.size() : end + 1;
    if (line.empty() || line[0] != '{') continue;  // not the decoder's output (a warning of node's, say)
    const json j = json::parse(line);
    EXPECT_EQ(j["channels"], json::array({"Y"}));
    Exr e;
    e.w = j["width"], e.h = j["height"];
    for (const json& v : j["values"]) e.px.push_back(float(v.get<double>()));
    out[fs::path(j["file"].get<std::string>()).filename().string()] = std::move(e);
  }
  return out;
}

class WorldEngineSets : public ::testing::TestWithParam<Case> {};

}  // namespace

TEST_P(WorldEngineSets, EqualGenerateSplitByteForByteAndJoin) {
  const Case c = GetParam();
  TempDir d("relief-world-engine");
  const std::string recipe = write_recipe(d);
  build_both(c, d, recipe);
  if (HasFatalFailure()) return;
  const fs::path gen = d.path / "generate", eng = d.path / "world" / "engine";
  const auto a = names_in(gen, c.engine + "_"), b = names_in(eng, c.engine + "_");
  ASSERT_FALSE(a.empty());
  EXPECT_EQ(a, b);  // same names
  for (const std::string& n : a) EXPECT_TRUE(slurp(gen / n) == slurp(eng / n)) << n << " differs";  // same bytes
  const json s = json::parse(slurp(eng / (c.engine + "_height.json")));
  EXPECT_EQ(s["overlap_samples"], c.engine == "unreal" ? 0 : 1);

  // Read back without our decoders; compare with the store's heights.
  const json m = read_world_manifest((d.path / "world").string());
  const std::int64_t nx = m["frame"]["size"][0], nz = m["frame"]["size"][1];
  const Terrain whole = read_world_window((d.path / "world").string(), 0, 0, int(nx), int(nz));
  const auto& h = whole.get("height").data;
  if (c.engine == "godot" && c.format != "r16") {
    // EXR in metres: every tile's samples are the world's y_m, borders shared.
    const int t = s["samples_per_tile"];
    std::vector<std::string> files;
    for (const json& tile : s["tiles"]) files.push_back(tile["file"]);
    const std::map<std::string, Exr> exr = read_exr_js(eng, files);
    ASSERT_EQ(exr.size(), files.size());
    for (const json& tile : s["tiles"]) {
      const Exr& e = exr.at(tile["file"].get<std::string>());
      const std::vector<float>& px = e.px;
      ASSERT_EQ(e.w, t);
      ASSERT_EQ(e.h, t);
      const int x0 = tile["x"].get<int>() * (t - 1), z0 = tile["y"].get<int>() * (t - 1);
      for (int j = 0; j < t; ++j)
        for (int i = 0; i < t; ++i)
          ASSERT_EQ(px[std::size_t(j) * t + i], float(whole.frame.y_m(h[std::size_t(z0 + j) * nx + x0 + i]))) << i << " " << j;
    }
    return;
  }
  const long shared = assemble(eng, c.engine + "_height.json");
  const int kx = s["tiles_x"], kz = s["tiles_y"], t = s["samples_per_tile"];
  // Unreal: tiles abut (no sample twice); Unity, Godot: each inner seam repeats a row or column.
  const long ov = c.engine == "unreal" ? 0 : 1;
  const long expect_shared = long(kx) * kz * t * t - (kx * (t - ov) + ov) * (kz * (t - ov) + ov);
  EXPECT_EQ(shared, expect_shared);
  const std::string full = slurp(eng / "full.u16");
  ASSERT_EQ(full.size(), std::size_t(nx * nz * 2));
  for (std::size_t k = 0; k < h.size(); ++k) {
    const std::uint16_t v = std::uint16_t(std::uint8_t(full[2 * k]) | (std::uint8_t(full[2 * k + 1]) << 8));
    ASSERT_EQ(v, u16(h[k])) << "sample " << k % nx << ", " << k / nx;
  }
}

INSTANTIATE_TEST_SUITE_P(Engines, WorldEngineSets,
                         ::testing::Values(Case{"unity", "2x2", "257", "", 65},      // world tiles of 65 in engine tiles of 129
                                           Case{"unreal", "2x2", "254", "", 65},     // 2×2 tiles of 127, edge to edge; clipped world tiles
                                           Case{"godot", "2x2", "257", "exr", 33},   // EXR in metres
                                           Case{"godot", "2x1", "257x129", "r16", 65}),  // non-square split
                         [](const auto& info) { return info.param.engine + "_" + info.param.split + info.param.format; });

// Python checks the pyramid from its PNGs: level k tile (X, Z) sample (i, j) equals level k−1 tile
// (2X + a, 2Z + b) sample (2i − a(T−1), 2j − b(T−1)), for heights and colours; tile sizes and counts
// as world_engine.hpp states; the last level is one tile.
const char* kLodCheck = R"PY(
import json, sys, os
import numpy as np
from PIL import Image
d = sys.argv[1]
L = json.load(open(d + '/lod.json'))
T = L['tile_samples']; nx, nz = L['world_samples']
levels = L['levels']
assert levels[-1]['tiles_x'] == 1 and levels[-1]['tiles_z'] == 1
def tiles(n, k):
    span = (T - 1) << k
    return (n - 1 + span - 1) // span
def size(n, X, k):
    return min(T, ((n - 1 - ((T - 1) << k) * X) >> k) + 1)
cache = {}
def load(k, X, Z, suffix):
    key = (k, X, Z, suffix)
    if key not in cache:
        cache[key] = np.array(Image.open('%s/%d/x%d_z%d%s.png' % (d, k, X, Z, suffix)))
    return cache[key]
checked = 0
for lv in levels:
    k = lv['level']
    assert lv['tiles_x'] == tiles(nx, k) and lv['tiles_z'] == tiles(nz, k), lv
    n_files = len([f for f in os.listdir('%s/%d' % (d, k)) if not f.endswith('_color.png')])
    assert n_files == lv['tiles_x'] * lv['tiles_z'], (k, n_files)
    for Z in range(lv['tiles_z']):
        for X in range(lv['tiles_x']):
            for suffix in ['', '_color']:
                p = load(k, X, Z, suffix)
                assert p.shape[0] == size(nz, Z, k) and p.shape[1] == size(nx, X, k), (k, X, Z, p.shape)
                if k == 0:
                    continue
                for j in range(p.shape[0]):
                    b = 1 if 2 * j > T - 1 else 0
                    for a in (0, 1):
                        i_idx = [i for i in range(p.shape[1]) if (1 if 2 * i > T - 1 else 0) == a]
                        if not i_idx:
                            continue
                        ch = load(k - 1, 2 * X + a, 2 * Z + b, suffix)
                        src = ch[2 * j - b * (T - 1), [2 * i - a * (T - 1) for i in i_idx]]
                        if not np.array_equal(p[j, i_idx], src):
                            sys.exit('level %d tile %d,%d%s row %d differs from level %d' % (k, X, Z, suffix, j, k - 1))
                        checked += len(i_idx)
print(checked)
)PY";

TEST(WorldLod, LevelKIsLevelKMinusOneAtEveryOtherSample) {
  TempDir d("relief-world-lod");
  const std::string recipe = write_recipe(d);
  // 250 × 193 in tiles of 33: clipped tiles along x at every level, along z from level 2.
  const auto w = relief_cli("world " + recipe + " --seed 3 --size 250x193 --tile 33 --lod -q -o " + (d / "world"));
  ASSERT_EQ(w.code, 0) << w.out;
  const fs::path lod = d.path / "world" / "lod";
  const json L = json::parse(slurp(lod / "lod.json"));
  ASSERT_EQ(L["levels"].size(), 4u);  // 8x6 tiles, 4x3, 2x2, 1
  EXPECT_TRUE(L.contains("color"));
  // Level 0 is the store, read back with libspng.
  const std::string dir = (d.path / "world").string();
  for (std::int64_t Z : {0, 5})
    for (std::int64_t X : {0, 7}) {
      const WorldTile t = read_world_tile(dir, X, Z);
      const auto p = relief::test::decode_png(slurp(lod / "0" / ("x" + std::to_string(X) + "_z" + std::to_string(Z) + ".png")));
      ASSERT_EQ(p.width(), t.window.nx);
      ASSERT_EQ(p.height(), t.window.nz);
      const auto& h = t.layers.at("height").data;
      for (std::size_t k = 0; k < h.size(); ++k) {
        std::uint16_t v;
        std::memcpy(&v, p.bytes.data() + 2 * k, 2);
        ASSERT_EQ(v, u16(h[k])) << X << "," << Z << " sample " << k;
      }
    }
  // The top level is the whole world at every 8th sample.
  const Terrain whole = read_world_window(dir, 0, 0, 250, 193);
  const auto top = relief::test::decode_png(slurp(lod / "3" / "x0_z0.png"));
  ASSERT_EQ(top.width(), 32);   // samples 0, 8, …, 248 (249 is off the lattice)
  ASSERT_EQ(top.height(), 25);  // 0, 8, …, 192
  for (int j = 0; j < 25; ++j)
    for (int i = 0; i < 32; ++i) {
      std::uint16_t v;
      std::memcpy(&v, top.bytes.data() + 2 * (std::size_t(j) * 32 + i), 2);
      ASSERT_EQ(v, u16(whole.get("height").data[std::size_t(8 * j) * 250 + 8 * i])) << i << " " << j;
    }
  relief::test::write_text(lod / "check.py", kLodCheck);
  const auto r = relief::test::sh(std::string(RELIEF_SYSTEM_PYTHON) + " '" + (lod / "check.py").string() + "' '" + lod.string() + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_GT(std::stol(r.out), 10000);
}

TEST(WorldEngineCli, TilingThatDoesNotFitTheWorldExitsTwoBeforeBuilding) {
  TempDir d("relief-world-engine-bad");
  const std::string recipe = write_recipe(d);
  const std::string base = "world " + recipe + " --seed 1 --tile 65 -q -o " + (d / "w");
  // 257 = 2·128 + 1 is Unity's and Godot's 2×2 layout, not Unreal's (edge to edge: 2·t).
  relief::test::expect_cli_error(base + " --size 257 --engine unreal --split 2x2", "--engine: unreal needs tiles of a legal square size");
  relief::test::expect_cli_error(base + " --size 254 --engine unity --split 2x2", "(use --size)");
  relief::test::expect_cli_error(base + " --size 257 --split 2x2", "--split: splitting writes engine tiles");
  relief::test::expect_cli_error(base + " --size 257 --engine cryengine", "--engine: ");
  relief::test::expect_cli_error(base + " --size 257 --engine unity --godot-format r16", "--godot-format: ");
  EXPECT_FALSE(fs::exists(d.path / "w" / "world.json"));  // refused before any tile
}

namespace {
// A small world built through the library (island without its global stage), for export_world.
std::string small_world(const TempDir& d, std::int64_t n, int tile) {
  json doc = load_preset("island");
  json stages = json::array();
  for (int k : {0, 1, 3, 4}) stages.push_back(doc["stages"][k]);
  doc["stages"] = stages;
  doc["seed"] = 2;
  WorldSettings s;
  s.recipe = parse_recipe(doc);
  s.nx = s.nz = n;
  s.tile = tile;
  s.out_dir = d / "world";
  s.threads = 2;
  build_world(s);
  return s.out_dir;
}
}  // namespace

TEST(WorldExport, ASecondExportLeavesNoStaleTiles) {
  TempDir d("relief-world-export");
  WorldExportSettings s;
  s.store_dir = small_world(d, 257, 65);
  s.options.engine = Engine::Unity;
  s.options.split = "2x2";
  s.lod = true;
  const WorldExportReport a = export_world(s);
  EXPECT_EQ(a.engine_tiles, 4);
  EXPECT_EQ(a.lod_levels, 3);  // 4×4 tiles of 65, 2×2, 1
  EXPECT_EQ(a.lod_tiles, 16 + 4 + 1);
  s.options.split = "1x1";
  s.options.engine = Engine::Godot;
  s.lod = false;
  const WorldExportReport b = export_world(s);
  EXPECT_EQ(b.engine_tiles, 1);
  EXPECT_EQ(names_in(fs::path(s.store_dir) / "engine", ""),
            (std::set<std::string>{"godot_height.exr", "godot_height.json", "godot_import.txt"}));
  for (const std::string& f : b.files) EXPECT_TRUE(fs::exists(fs::path(s.store_dir) / f)) << f;
  EXPECT_TRUE(fs::exists(fs::path(s.store_dir) / "lod" / "2" / "x0_z0.png"));  // not asked for: left alone
}

TEST(WorldExport, RefusesAnUnfinishedStoreAndATilingThatDoesNotFit) {
  TempDir d("relief-world-export-bad");
  WorldExportSettings s;
  s.store_dir = small_world(d, 129, 65);
  s.options.engine = Engine::Unreal;  // 129 is not 127·k
  try {
    export_world(s);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "export.engine");
  }
  EXPECT_THROW(check_world_export(s.options, 129, 129), Error);
  EXPECT_NO_THROW(check_world_export(s.options, 127, 127));
  s.options.engine = Engine::Unity;  // legal: 129 = 2^7 + 1
  EXPECT_NO_THROW(export_world(s));
  json m = json::parse(slurp(fs::path(s.store_dir) / "world.json"));
  m["status"] = "building";
  relief::test::write_text(fs::path(s.store_dir) / "world.json", m.dump());
  try {
    export_world(s);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "output");
  }
}
