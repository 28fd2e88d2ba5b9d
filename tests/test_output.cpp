// Writers and encoders: PNG/raw read back by independent decoders (Pillow and numpy through the
// system Python, libspng in-process), the OBJ parsed back, atomic file replacement.
#include <gtest/gtest.h>

#include <set>
#include <signal.h>
#include <spng.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "relief/error.hpp"
#include "relief/output.hpp"
#include "relief/stage.hpp"
#include "support.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace fs = std::filesystem;
using namespace relief;

namespace {

// ---- fixtures -------------------------------------------------------------------------------

struct TempDir : relief::test::TempDir {
  TempDir() : relief::test::TempDir("relief_test_output") {}
};

std::string read_file(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}
void write_file(const fs::path& p, const std::string& bytes) {
  std::ofstream f(p, std::ios::binary);
  f << bytes;
}

std::vector<std::string> temp_leftovers(const fs::path& dir) {
  std::vector<std::string> out;
  for (auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find(".tmp-") != std::string::npos) out.push_back(e.path().string());
  return out;
}

// Asymmetric in i and j, so transposition or flips change the values.
float elev(int i, int j) { return float(1 + 3 * i + 17 * j) / 64.0f; }

// 5×3 samples (non-square), cells of 10 m, window not at the world's origin.
Terrain small_terrain(int nx = 5, int nz = 3) {
  Terrain t;
  t.frame.nx = nx;
  t.frame.nz = nz;
  t.frame.spacing_m = 10;
  t.frame.world_width_m = 1000;
  t.frame.world_depth_m = 1000;
  t.frame.ix0 = 10;  // x0 = 100 m
  t.frame.iz0 = 3;   // z0 = 30 m
  t.frame.height_m = 600;
  t.frame.sea_level = 0.4;
  Layer h;
  h.channels = 1;
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) h.data.push_back(elev(i, j));
  t.layers["height"] = h;
  return t;
}

Layer colour_layer(int nx, int nz, int salt) {
  Layer c;
  c.channels = 3;
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      c.data.push_back(float(i * 50 + salt) / 255.0f);
      c.data.push_back(float(j * 100 + 7) / 255.0f);
      c.data.push_back(float(255 - i * 10 - j * 30 - salt) / 255.0f);
    }
  return c;
}

std::uint16_t u16(float v) { return std::uint16_t(std::lround(std::clamp(double(v), 0.0, 1.0) * 65535.0)); }

// Runs a Python snippet with the system interpreter (the one that sees Pillow and numpy) and
// returns its stdout. The script gets the argument list as sys.argv[1:].
std::string run_python(const TempDir& dir, const std::string& script, const std::string& args) {
  const std::string py = dir / "check.py";
  write_file(py, script);
  const std::string cmd = std::string(RELIEF_SYSTEM_PYTHON) + " '" + py + "' " + args + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return "popen failed";
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int rc = ::pclose(p);
  if (rc != 0) return "python failed (" + std::to_string(rc) + "): " + out;
  return out;
}

std::vector<long> numbers_after(const std::string& text, const std::string& tag) {
  std::vector<long> v;
  std::istringstream s(text);
  std::string line;
  while (std::getline(s, line)) {
    if (line.rfind(tag + " ", 0) != 0) continue;
    std::istringstream ls(line.substr(tag.size() + 1));
    long x;
    while (ls >> x) v.push_back(x);
  }
  return v;
}


json parse_json(const std::string& s) { return json::parse(s); }

// ---- OBJ reader ------------------------------------------------------------------------------

struct Vec3 {
  double x = 0, y = 0, z = 0;
};
struct Obj {
  std::vector<Vec3> v, vn;
  std::vector<std::pair<double, double>> vt;
  std::vector<std::array<long, 9>> f;  // v/vt/vn × 3
  std::vector<std::string> mtllib, usemtl;
  int bad_lines = 0;
};
Obj parse_obj(const std::string& text) {
  Obj o;
  std::istringstream s(text);
  std::string line;
  while (std::getline(s, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "v" || tag == "vn") {
      Vec3 p;
      if (!(ls >> p.x >> p.y >> p.z)) ++o.bad_lines;
      (tag == "v" ? o.v : o.vn).push_back(p);
    } else if (tag == "vt") {
      double u, v;
      if (!(ls >> u >> v)) ++o.bad_lines;
      o.vt.push_back({u, v});
    } else if (tag == "f") {
      std::array<long, 9> f{};
      for (int k = 0; k < 3; ++k) {
        std::string c;
        ls >> c;
        if (std::sscanf(c.c_str(), "%ld/%ld/%ld", &f[3 * k], &f[3 * k + 1], &f[3 * k + 2]) != 3) ++o.bad_lines;
      }
      std::string extra;
      if (ls >> extra) ++o.bad_lines;  // triangles only
      o.f.push_back(f);
    } else if (tag == "mtllib" || tag == "usemtl") {
      std::string name;
      ls >> name;
      (tag == "mtllib" ? o.mtllib : o.usemtl).push_back(name);
    } else if (tag != "o" && tag != "g" && tag != "s") {
      ++o.bad_lines;
    }
  }
  return o;
}

Vec3 face_normal(const Obj& o, const std::array<long, 9>& f) {
  const Vec3 a = o.v[f[0] - 1], b = o.v[f[3] - 1], c = o.v[f[6] - 1];
  const Vec3 u{b.x - a.x, b.y - a.y, b.z - a.z}, w{c.x - a.x, c.y - a.y, c.z - a.z};
  return {u.y * w.z - u.z * w.y, u.z * w.x - u.x * w.z, u.x * w.y - u.y * w.x};
}

MemoryOutput run_writer(const std::string& name, const Terrain& t, const WriteContext& ctx = {}) {
  const WriterDef* w = find_writer(name);
  EXPECT_NE(w, nullptr) << name;
  MemoryOutput out;
  if (w) w->write(t, ctx, out);
  return out;
}

const char* kPillowGray = R"(
import sys
from PIL import Image
im = Image.open(sys.argv[1])
# Pillow 9.4 opens 16-bit greyscale PNG as mode "I" (newer versions as "I;16").
print("mode", "I16" if im.mode in ("I", "I;16") else im.mode)
ihdr = open(sys.argv[1], "rb").read()[16:26]
print("ihdr_depth_type", ihdr[8], ihdr[9])
print("size", im.size[0], im.size[1])
w, h = im.size
for j in range(h):
    print("row", *[im.getpixel((i, j)) for i in range(w)])
)";

}  // namespace

// ---- encoders --------------------------------------------------------------------------------

TEST(Output, HeightPngReadByPillowMatchesLayer) {
  TempDir dir;
  Terrain t = small_terrain();
  FileOutput out(dir.path.string());
  find_writer("heightmap")->write(t, {}, out);
  const std::string r = run_python(dir, kPillowGray, "'" + (dir / "height.png") + "'");
  EXPECT_NE(r.find("mode I16\n"), std::string::npos) << r;
  EXPECT_EQ(numbers_after(r, "ihdr_depth_type"), (std::vector<long>{16, 0})) << r;  // 16-bit greyscale
  EXPECT_EQ(numbers_after(r, "size"), (std::vector<long>{5, 3})) << r;  // width = nx, height = nz
  std::vector<long> want;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 5; ++i) want.push_back(u16(elev(i, j)));  // image row j = terrain row j
  EXPECT_EQ(numbers_after(r, "row"), want) << r;
}

TEST(Output, R16ReadByNumpyIsLittleEndianRowMajor) {
  TempDir dir;
  Terrain t = small_terrain();
  FileOutput out(dir.path.string());
  find_writer("heightmap")->write(t, {}, out);
  EXPECT_EQ(fs::file_size(dir.path / "height.r16"), 5u * 3u * 2u);
  const std::string r = run_python(dir, R"(
import sys, numpy as np
a = np.fromfile(sys.argv[1], dtype='<u2').reshape(3, 5)   # rows = z, columns = x
for j in range(a.shape[0]):
    print("row", *[int(v) for v in a[j]])
)",
                                   "'" + (dir / "height.r16") + "'");
  std::vector<long> want;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 5; ++i) want.push_back(u16(elev(i, j)));
  EXPECT_EQ(numbers_after(r, "row"), want) << r;
}

TEST(Output, R16BytesAreLowByteFirst) {
  Layer l;
  l.data = {258.0f / 65535.0f, 1.0f};  // 0x0102, 0xFFFF
  const std::string b = encode_r16(l);
  ASSERT_EQ(b.size(), 4u);
  EXPECT_EQ(std::uint8_t(b[0]), 0x02);
  EXPECT_EQ(std::uint8_t(b[1]), 0x01);
  EXPECT_EQ(std::uint8_t(b[2]), 0xFF);
  EXPECT_EQ(std::uint8_t(b[3]), 0xFF);
}

TEST(Output, Gray16PngRoundTripsThroughSpng) {
  Terrain t = small_terrain();
  const test::Png d = test::decode_png(encode_png_gray16(t.layers["height"], 5, 3));
  EXPECT_EQ(d.ihdr.width, 5u);
  EXPECT_EQ(d.ihdr.height, 3u);
  EXPECT_EQ(d.ihdr.bit_depth, 16);
  EXPECT_EQ(d.ihdr.color_type, SPNG_COLOR_TYPE_GRAYSCALE);
  ASSERT_EQ(d.bytes.size(), 5u * 3u * 2u);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 5; ++i) {
      std::uint16_t v;
      std::memcpy(&v, d.bytes.data() + 2 * (j * 5 + i), 2);
      EXPECT_EQ(v, u16(elev(i, j))) << i << "," << j;
    }
}

TEST(Output, Gray16ClampsAndRounds) {
  Layer l;
  l.data = {-0.5f, 1.5f, std::numeric_limits<float>::quiet_NaN(), 0.5f, 1.0f / 65535.0f, 0.0f};
  const test::Png d = test::decode_png(encode_png_gray16(l, 3, 2));
  ASSERT_EQ(d.bytes.size(), 12u);
  std::uint16_t v[6];
  std::memcpy(v, d.bytes.data(), 12);
  EXPECT_EQ(v[0], 0);      // below 0 clamps
  EXPECT_EQ(v[1], 65535);  // above 1 clamps
  EXPECT_EQ(v[2], 0);      // NaN → 0
  EXPECT_EQ(v[3], 32768);  // 32767.5 rounds up
  EXPECT_EQ(v[4], 1);
  EXPECT_EQ(v[5], 0);
}

TEST(Output, Rgb8PngReadByPillowMatchesLayer) {
  TempDir dir;
  const Layer c = colour_layer(4, 3, 5);
  write_file(dir.path / "c.png", encode_png_rgb8(c, 4, 3));
  const std::string r = run_python(dir, R"(
import sys
from PIL import Image
im = Image.open(sys.argv[1])
print("mode", im.mode)
print("size", *im.size)
for j in range(im.size[1]):
    print("row", *[ch for i in range(im.size[0]) for ch in im.getpixel((i, j))])
)",
                                   "'" + (dir / "c.png") + "'");
  EXPECT_NE(r.find("mode RGB\n"), std::string::npos) << r;
  EXPECT_EQ(numbers_after(r, "size"), (std::vector<long>{4, 3})) << r;
  std::vector<long> want;
  for (float v : c.data) want.push_back(std::lround(v * 255.0f));
  EXPECT_EQ(numbers_after(r, "row"), want) << r;
}

TEST(Output, Gray8PngRoundTripsThroughSpng) {
  Layer l;
  l.data = {0.0f, 0.25f, 1.0f, 2.0f, -1.0f, 0.5f};
  const test::Png d = test::decode_png(encode_png_gray8(l, 2, 3));
  EXPECT_EQ(d.ihdr.width, 2u);
  EXPECT_EQ(d.ihdr.height, 3u);
  EXPECT_EQ(d.ihdr.bit_depth, 8);
  EXPECT_EQ(d.bytes, (std::vector<std::uint8_t>{0, 64, 255, 255, 0, 128}));
}

TEST(Output, EncodersRejectWrongSize) {
  Layer l;
  l.data.assign(14, 0.5f);  // 5×3 needs 15
  EXPECT_THROW(encode_png_gray16(l, 5, 3), Error);
  EXPECT_THROW(encode_png_gray8(l, 5, 3), Error);
  Layer c;
  c.channels = 3;
  c.data.assign(5 * 3 * 3 - 1, 0.5f);
  EXPECT_THROW(encode_png_rgb8(c, 5, 3), Error);
  l.data.assign(15, 0.5f);
  EXPECT_NO_THROW(encode_png_gray16(l, 5, 3));
  EXPECT_THROW(encode_png_gray16(l, 0, 15), Error);
}

TEST(Output, EncodersRejectWrongChannels) {
  Layer c;
  c.channels = 3;
  c.data.assign(15 * 3, 0.5f);
  EXPECT_THROW(encode_png_gray16(c, 5, 3), Error);
  EXPECT_THROW(encode_png_gray8(c, 5, 3), Error);
  EXPECT_THROW(encode_r16(c), Error);
  Layer g;
  g.data.assign(15 * 3, 0.5f);  // right count for RGB, wrong channel count
  EXPECT_THROW(encode_png_rgb8(g, 5, 3), Error);
}

// ---- writers ---------------------------------------------------------------------------------

TEST(Writers, RegistryOrderAndFiles) {
  const auto& r = writer_registry();
  std::vector<std::string> names;
  for (auto& w : r) {
    names.push_back(w.name);
    const std::set<std::string> defaults = {"heightmap", "color", "albedo", "obj", "rivers",
                                            "lakes", "biomes", "features", "props", "report", "caves"};
    EXPECT_EQ(w.in_default_set, defaults.count(w.name) == 1) << w.name;  // the rest need options or a stage
    EXPECT_FALSE(w.files.empty()) << w.name;
    EXPECT_FALSE(w.description.empty()) << w.name;
    EXPECT_TRUE(bool(w.write)) << w.name;
  }
  EXPECT_EQ(names, (std::vector<std::string>{"heightmap", "color", "albedo", "obj", "rivers", "lakes", "biomes", "features",
                                             "props", "report", "tilemap", "glb", "fbx", "stl", "engine", "normalmap", "splat",
                                             "hillshade", "geotiff", "caves", "caves_obj", "vdb"}));
  EXPECT_EQ(find_writer("obj"), &r[3]);
  EXPECT_EQ(find_writer("png"), nullptr);
}

TEST(Writers, EachWriterWritesExactlyItsDeclaredFiles) {
  Terrain t = small_terrain();
  t.layers["color"] = colour_layer(5, 3, 1);
  t.layers["albedo"] = colour_layer(5, 3, 2);
  // The tilemap writer encodes what the tilemap stage made.
  find_stage("tilemap")->parse({{"stage", "tilemap"}, {"tiles_x", 3}, {"tiles_z", 2}, {"tile_size", 8}}, "stages[0]")->apply(t, {});
  t.layer("flow", 1);  // rivers.json and lakes.json are written for recipes with a flow stage
  t.layer("biome", 1);  // all ocean
  t.biomes.push_back({"ocean", 0.1f, 0.2f, 0.6f});
  t.points.push_back({"prop", "tree", 1, 2, 3, 45, 1});
  t.points.push_back({"volcano", "volcano", 4, 5, 6, 0, 1});
  // The volume writers mesh what the volume stages leave.
  find_stage("volume")->parse({{"stage", "volume"}, {"chunk", 8}}, "stages[1]")->apply(t, {});
  for (auto& w : writer_registry()) {
    // Export writers' files depend on options: see test_export.cpp.
    if (!w.in_default_set && w.name != "tilemap") continue;
    EXPECT_TRUE(!w.applies || w.applies(t)) << w.name;
    MemoryOutput out;
    w.write(t, {}, out);
    std::vector<std::string> got;
    for (auto& [name, bytes] : out.files) {
      got.push_back(name);
      EXPECT_FALSE(bytes.empty()) << name;
    }
    std::vector<std::string> want = w.files;
    std::sort(want.begin(), want.end());
    EXPECT_EQ(got, want) << w.name;
  }
}

TEST(Writers, HeightSidecarDescribesTheRaw) {
  Terrain t = small_terrain();
  MemoryOutput out = run_writer("heightmap", t);
  const json s = parse_json(out.files.at("height.json"));
  EXPECT_EQ(s["width"], 5);
  EXPECT_EQ(s["height"], 3);
  EXPECT_EQ(s["format"], "r16 little-endian unsigned");
  EXPECT_EQ(s["byte_order"], "little-endian");
  EXPECT_DOUBLE_EQ(s["metres_per_pixel"].get<double>(), 10.0);
  EXPECT_DOUBLE_EQ(s["width_m"].get<double>(), 40.0);
  EXPECT_DOUBLE_EQ(s["depth_m"].get<double>(), 20.0);
  EXPECT_DOUBLE_EQ(s["x0_m"].get<double>(), 100.0);
  EXPECT_DOUBLE_EQ(s["z0_m"].get<double>(), 30.0);
  EXPECT_DOUBLE_EQ(s["min_m"].get<double>(), -240.0);  // (0 − 0.4) · 600
  EXPECT_DOUBLE_EQ(s["max_m"].get<double>(), 360.0);   // (1 − 0.4) · 600
  EXPECT_DOUBLE_EQ(s["sea_level"].get<double>(), 0.4);
  EXPECT_DOUBLE_EQ(s["sea_level_m"].get<double>(), 0.0);
  EXPECT_NE(s["layout"].get<std::string>().find("row 0 is the z-min"), std::string::npos);
  EXPECT_EQ(out.files.at("height.r16").size(), 30u);
}

TEST(Writers, HeightmapWithoutHeightThrows) {
  Terrain t = small_terrain();
  t.layers.erase("height");
  EXPECT_THROW(run_writer("heightmap", t), Error);
  EXPECT_THROW(run_writer("obj", t), Error);
}

TEST(Writers, HeightmapRejectsMismatchedLayer) {
  Terrain t = small_terrain();
  t.layers["height"].data.pop_back();
  EXPECT_THROW(run_writer("heightmap", t), Error);
  EXPECT_THROW(run_writer("obj", t), Error);
}

TEST(Writers, ColorWithoutColourLayerThrowsFormatsError) {
  Terrain t = small_terrain();
  try {
    run_writer("color", t);
    FAIL() << "expected relief::Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "formats");
    EXPECT_NE(std::string(e.what()).find("colour stage"), std::string::npos) << e.what();
  }
  EXPECT_THROW(run_writer("albedo", t), Error);
}

TEST(Writers, ColorPrefersColorAndFallsBackToAlbedo) {
  Terrain t = small_terrain();
  t.layers["albedo"] = colour_layer(5, 3, 2);
  const std::string from_albedo = run_writer("color", t).files.at("color.png");
  EXPECT_EQ(from_albedo, encode_png_rgb8(t.layers["albedo"], 5, 3));
  t.layers["color"] = colour_layer(5, 3, 9);
  EXPECT_EQ(run_writer("color", t).files.at("color.png"), encode_png_rgb8(t.layers["color"], 5, 3));
  EXPECT_EQ(run_writer("albedo", t).files.at("albedo.png"), encode_png_rgb8(t.layers["albedo"], 5, 3));
  EXPECT_NE(encode_png_rgb8(t.layers["color"], 5, 3), encode_png_rgb8(t.layers["albedo"], 5, 3));
}

TEST(Writers, ReportHasVersionSeedRecipeAndMergedKeys) {
  Terrain t = small_terrain();
  WriteContext ctx;
  ctx.seed = 9007199254740991ull;  // 2^53 − 1
  ctx.recipe = json::parse(R"({"world": {"size": 513}, "stages": [{"type": "noise"}]})");
  ctx.report = json::parse(R"({"timings": [{"name": "noise", "ms": 1.5}], "peak_memory_bytes": 1234})");
  const std::string text = run_writer("report", t, ctx).files.at("report.json");
  const json r = parse_json(text);
  EXPECT_TRUE(r["relief_version"].is_string());
  EXPECT_EQ(r["seed"].get<std::uint64_t>(), ctx.seed);
  EXPECT_EQ(r["recipe"], ctx.recipe);
  EXPECT_EQ(r["timings"], ctx.report["timings"]);
  EXPECT_EQ(r["peak_memory_bytes"], 1234);
  EXPECT_NE(text.find("\n  \"seed\": 9007199254740991"), std::string::npos) << text;  // 2-space indent
}

// ---- OBJ -------------------------------------------------------------------------------------

TEST(Obj, CountsAndIndicesInRange) {
  Terrain t = small_terrain();
  const Obj o = parse_obj(run_writer("obj", t).files.at("terrain.obj"));
  EXPECT_EQ(o.bad_lines, 0);
  EXPECT_EQ(o.v.size(), 15u);
  EXPECT_EQ(o.vn.size(), 15u);
  EXPECT_EQ(o.vt.size(), 15u);
  EXPECT_EQ(o.f.size(), 2u * 4u * 2u);
  for (auto& f : o.f)
    for (long k : f) {
      EXPECT_GE(k, 1);
      EXPECT_LE(k, 15);
    }
  EXPECT_EQ(o.mtllib, (std::vector<std::string>{"terrain.mtl"}));
  EXPECT_EQ(o.usemtl, (std::vector<std::string>{"terrain"}));
}

TEST(Obj, VerticesSitAtFrameCoordinates) {
  Terrain t = small_terrain();
  const Frame& fr = t.frame;
  const Obj o = parse_obj(run_writer("obj", t).files.at("terrain.obj"));
  ASSERT_EQ(o.v.size(), 15u);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 5; ++i) {
      const Vec3& p = o.v[j * 5 + i];
      EXPECT_NEAR(p.x, fr.x_m(i), 5e-5) << i << "," << j;
      EXPECT_NEAR(p.y, fr.y_m(elev(i, j)), 5e-5) << i << "," << j;
      EXPECT_NEAR(p.z, fr.z_m(j), 5e-5) << i << "," << j;
    }
  EXPECT_EQ(o.v.front().x, 100.0);
  EXPECT_EQ(o.v.front().z, 30.0);
  EXPECT_EQ(o.v.back().x, 140.0);
  EXPECT_EQ(o.v.back().z, 50.0);
}

TEST(Obj, UvsMapImageRowZeroToTop) {
  Terrain t = small_terrain();
  const Obj o = parse_obj(run_writer("obj", t).files.at("terrain.obj"));
  ASSERT_EQ(o.vt.size(), 15u);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 5; ++i) {
      EXPECT_NEAR(o.vt[j * 5 + i].first, i / 4.0, 1e-5);
      EXPECT_NEAR(o.vt[j * 5 + i].second, 1.0 - j / 2.0, 1e-5);
    }
  // Each face uses the same index for position, uv and normal.
  for (auto& f : o.f)
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(f[3 * k], f[3 * k + 1]);
      EXPECT_EQ(f[3 * k], f[3 * k + 2]);
    }
}

TEST(Obj, FlatTerrainFacesPointUp) {
  Terrain t = small_terrain();
  std::fill(t.layers["height"].data.begin(), t.layers["height"].data.end(), 0.4f);
  const Obj o = parse_obj(run_writer("obj", t).files.at("terrain.obj"));
  ASSERT_EQ(o.f.size(), 16u);
  for (auto& f : o.f) {
    const Vec3 n = face_normal(o, f);
    EXPECT_GT(n.y, 0.0);
    EXPECT_NEAR(n.x, 0.0, 1e-9);
    EXPECT_NEAR(n.z, 0.0, 1e-9);
  }
  for (auto& n : o.vn) {
    EXPECT_DOUBLE_EQ(n.y, 1.0);
    EXPECT_DOUBLE_EQ(n.x, 0.0);
    EXPECT_DOUBLE_EQ(n.z, 0.0);
  }
  for (auto& v : o.v) EXPECT_EQ(v.y, 0.0);  // sea level is y = 0
}

TEST(Obj, SlopedTerrainFacesPointUpAndNormalsMatchThePlane) {
  // A plane rising 1 m per metre in x and 0.5 m per metre in z (steep, so winding mistakes show).
  Terrain t = small_terrain(6, 4);
  const Frame& fr = t.frame;
  Layer& h = t.layers["height"];
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 6; ++i) h.data[j * 6 + i] = float((fr.x_m(i) - 100 + 0.5 * (fr.z_m(j) - 30)) / 600.0 + 0.1);
  const Obj o = parse_obj(run_writer("obj", t).files.at("terrain.obj"));
  ASSERT_EQ(o.f.size(), 2u * 5u * 3u);
  for (auto& f : o.f) EXPECT_GT(face_normal(o, f).y, 0.0);
  // Analytic normal of y = x + 0.5 z: (−1, 1, −0.5)/1.5; borders (one-sided) agree on a plane.
  for (auto& n : o.vn) {
    EXPECT_NEAR(n.x, -1.0 / 1.5, 2e-4);
    EXPECT_NEAR(n.y, 1.0 / 1.5, 2e-4);
    EXPECT_NEAR(n.z, -0.5 / 1.5, 2e-4);
  }
}

TEST(Obj, NormalsAreUnitLengthAndFollowTheSlope) {
  Terrain t = small_terrain();  // elevation rises with i (x) and faster with j (z)
  const Obj o = parse_obj(run_writer("obj", t).files.at("terrain.obj"));
  for (auto& n : o.vn) {
    EXPECT_NEAR(n.x * n.x + n.y * n.y + n.z * n.z, 1.0, 1e-4);
    EXPECT_LT(n.x, 0.0);  // uphill towards +x ⇒ normal leans to −x
    EXPECT_LT(n.z, 0.0);
    EXPECT_GT(n.y, 0.0);
  }
}

TEST(Obj, MtlReferencesAlbedo) {
  Terrain t = small_terrain();
  const std::string mtl = run_writer("obj", t).files.at("terrain.mtl");
  EXPECT_NE(mtl.find("newmtl terrain\n"), std::string::npos);
  EXPECT_NE(mtl.find("Kd 1 1 1\n"), std::string::npos);
  EXPECT_NE(mtl.find("map_Kd albedo.png\n"), std::string::npos);
}

TEST(Obj, RejectsNonFiniteHeights) {
  Terrain t = small_terrain();
  t.layers["height"].data[7] = std::numeric_limits<float>::infinity();
  EXPECT_THROW(run_writer("obj", t), Error);
}

TEST(Obj, ReportsProgressUpToOne) {
  Terrain t = small_terrain(65, 65);
  std::vector<double> seen;
  WriteContext ctx;
  ctx.progress = [&](std::string_view what, double f) {
    EXPECT_EQ(what, "obj");
    seen.push_back(f);
  };
  run_writer("obj", t, ctx);
  ASSERT_GE(seen.size(), 10u);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_GE(seen.front(), 0.0);
  EXPECT_EQ(seen.back(), 1.0);
}

TEST(Obj, SameInputSameBytes) {
  Terrain t = small_terrain(17, 9);
  EXPECT_EQ(run_writer("obj", t).files.at("terrain.obj"), run_writer("obj", t).files.at("terrain.obj"));
}

// A rough terrain for the precision tests: hashed heights over the whole range (2.5 km of relief),
// a jiggle layer of ±3 m, a window west and north of the world origin (negative coordinates) and a
// spacing with no short decimal form.
Terrain rough_terrain(int nx, int nz) {
  Terrain t = small_terrain(nx, nz);
  t.frame.ix0 = -37;
  t.frame.iz0 = -5;
  t.frame.spacing_m = 7.3;
  t.frame.height_m = 2500;
  std::uint64_t x = 88172645463325252ull;
  auto next = [&] {  // xorshift64: any fixed sequence will do
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    return double(x >> 11) / double(1ull << 53);
  };
  for (float& v : t.layers["height"].data) v = float(next());
  Layer off;
  off.channels = 2;
  for (std::size_t k = 0; k < 2 * t.frame.count(); ++k) off.data.push_back(float(6 * next() - 3));
  t.layers["offset"] = off;
  return t;
}

// A number as the OBJ writes it: no "-0", no trailing zero after the point, no bare point, at most
// `decimals` digits after it.
bool tidy_number(const std::string& s, int decimals) {
  std::size_t k = s[0] == '-' ? 1 : 0;
  const std::size_t int_begin = k;
  while (k < s.size() && std::isdigit(static_cast<unsigned char>(s[k]))) ++k;
  if (k == int_begin || (s[int_begin] == '0' && k - int_begin > 1)) return false;
  if (k == s.size()) return s != "-0";
  if (s[k] != '.' || k + 1 == s.size() || s.back() == '0' || int(s.size() - k - 1) > decimals) return false;
  for (std::size_t d = k + 1; d < s.size(); ++d)
    if (!std::isdigit(static_cast<unsigned char>(s[d]))) return false;
  return true;
}

TEST(Obj, NumbersAreWithinTheStatedPrecision) {
  // The contract in writers.cpp: positions to 0.1 mm, normals to 1e-5, uvs to 1e-5 (at this size),
  // each rounded to the nearest step: error at most half a step.
  const int nx = 83, nz = 41;
  Terrain t = rough_terrain(nx, nz);
  const Frame& fr = t.frame;
  const std::string text = run_writer("obj", t).files.at("terrain.obj");
  const Obj o = parse_obj(text);
  ASSERT_EQ(o.bad_lines, 0);
  ASSERT_EQ(o.v.size(), std::size_t(nx) * nz);
  ASSERT_EQ(o.vn.size(), o.v.size());
  ASSERT_EQ(o.vt.size(), o.v.size());
  const auto& h = t.layers["height"].data;
  const auto& off = t.layers["offset"].data;
  auto Y = [&](int i, int j) { return fr.y_m(h[std::size_t(j) * nx + i]); };
  double worst_p = 0, worst_n = 0, worst_t = 0;
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      const std::size_t k = std::size_t(j) * nx + i;
      const Vec3& p = o.v[k];
      worst_p = std::max({worst_p, std::fabs(p.x - (fr.x_m(i) + double(off[2 * k]))), std::fabs(p.y - Y(i, j)),
                          std::fabs(p.z - (fr.z_m(j) + double(off[2 * k + 1])))});
      // Central differences (one-sided at the border) of the metric heights.
      const int i0 = std::max(i - 1, 0), i1 = std::min(i + 1, nx - 1), j0 = std::max(j - 1, 0), j1 = std::min(j + 1, nz - 1);
      const double hx = (Y(i1, j) - Y(i0, j)) / ((i1 - i0) * fr.cell_m()), hz = (Y(i, j1) - Y(i, j0)) / ((j1 - j0) * fr.cell_m());
      const double len = std::sqrt(hx * hx + 1 + hz * hz);
      const Vec3& n = o.vn[k];
      worst_n = std::max({worst_n, std::fabs(n.x + hx / len), std::fabs(n.y - 1 / len), std::fabs(n.z + hz / len)});
      worst_t = std::max({worst_t, std::fabs(o.vt[k].first - double(i) / (nx - 1)),
                          std::fabs(o.vt[k].second - (1.0 - double(j) / (nz - 1)))});
    }
  EXPECT_LE(worst_p, 0.5e-4 + 1e-9);
  EXPECT_GT(worst_p, 0.3e-4);  // the data does need the rounding (so the bound is tight, not vacuous)
  EXPECT_LE(worst_n, 0.5e-5 + 1e-12);
  EXPECT_LE(worst_t, 0.5e-5 + 1e-12);
  // Every number is tidy.
  std::istringstream lines(text);
  std::string line;
  long numbers = 0;
  while (std::getline(lines, line)) {
    const int decimals = line.rfind("v ", 0) == 0 ? 4 : line.rfind("vn ", 0) == 0 || line.rfind("vt ", 0) == 0 ? 5 : -1;
    if (decimals < 0) continue;
    std::istringstream ls(line);
    std::string tag, num;
    ls >> tag;
    while (ls >> num) {
      ++numbers;
      EXPECT_TRUE(tidy_number(num, decimals)) << line;
    }
  }
  EXPECT_EQ(numbers, long(nx) * nz * 8);
}

TEST(Obj, WritesKnownValuesExactly) {
  // y = (e − 0.4)·600: chosen heights whose metric values have known roundings.
  Terrain t = small_terrain(2, 2);
  auto& h = t.layers["height"].data;
  h = {float(0.4), float(0.4 + 1e-7), float(0.4 - 1e-7), 1.0f};
  const std::string text = run_writer("obj", t).files.at("terrain.obj");
  // Metric elevations: float(0.4) → 3.6e-6 m, written "0"; float(0.4 ± 1e-7) → about ±6e-5 m,
  // within 0.05 mm of ±0.0001, never "-0"; 1.0 → 360 m, written "360".
  const Obj o = parse_obj(text);
  ASSERT_EQ(o.v.size(), 4u);
  EXPECT_NE(text.find("\nv 100 0 30\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\nv 110 360 40\n"), std::string::npos) << text;
  EXPECT_EQ(text.find("-0 "), std::string::npos) << text;
  EXPECT_EQ(text.find("-0\n"), std::string::npos) << text;
  EXPECT_NEAR(o.v[1].y, t.frame.y_m(h[1]), 0.5e-4);
  EXPECT_NEAR(o.v[2].y, t.frame.y_m(h[2]), 0.5e-4);
  EXPECT_NE(o.v[1].y, 0.0);
  EXPECT_NE(text.find("\nvt 0 1\nvt 1 1\nvt 0 0\nvt 1 0\n"), std::string::npos) << text;
}

TEST(Obj, FaceIndicesAreExactAcrossDecimalCarries) {
  // 41×30 = 1230 vertices: indices cross 9→10, 99→100 and 999→1000 inside rows.
  const int nx = 41, nz = 30;
  Terrain t = small_terrain(nx, nz);
  const std::string text = run_writer("obj", t).files.at("terrain.obj");
  std::string want;
  for (int j = 0; j + 1 < nz; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      const long a = long(j) * nx + i + 1, c = a + 1, d = a + nx, e = d + 1;
      auto corner = [](long k) { return std::to_string(k) + "/" + std::to_string(k) + "/" + std::to_string(k); };
      want += "f " + corner(a) + " " + corner(d) + " " + corner(c) + "\n";
      want += "f " + corner(c) + " " + corner(d) + " " + corner(e) + "\n";
    }
  const std::size_t at = text.find("usemtl terrain\n");
  ASSERT_NE(at, std::string::npos);
  EXPECT_EQ(text.substr(at + 15), want);
}

TEST(Obj, UvDecimalsGrowWithTheGrid) {
  // 3001 samples across (u = i/3000 has no short decimal form): five decimals would be up to 1/67
  // texel off; the writer keeps within 1/100.
  const int nx = 3001, nz = 2;
  Terrain t = small_terrain(nx, nz);
  const Obj o = parse_obj(run_writer("obj", t).files.at("terrain.obj"));
  ASSERT_EQ(o.vt.size(), std::size_t(nx) * nz);
  double worst = 0;
  for (int i = 0; i < nx; ++i) worst = std::max(worst, std::fabs(o.vt[std::size_t(i)].first - double(i) / (nx - 1)));
  EXPECT_LE(worst * (nx - 1), 0.01);
  EXPECT_LE(worst, 0.5e-6 + 1e-12);
}

TEST(Obj, SameBytesForAnyThreadCountAndOutput) {
  Terrain t = rough_terrain(190, 75);
  std::vector<std::string> texts;
  for (int threads : {1, 2, 3, 7}) {
    tbb::task_arena arena(threads);
    MemoryOutput out;
    arena.execute([&] { find_writer("obj")->write(t, {}, out); });
    texts.push_back(out.files.at("terrain.obj"));
  }
  for (std::size_t k = 1; k < texts.size(); ++k) EXPECT_TRUE(texts[k] == texts[0]) << "threads case " << k;
  // Streamed into a file: the same bytes.
  TempDir dir;
  FileOutput files(dir.path.string(), FileOutput::Mode::OnCommit);
  find_writer("obj")->write(t, {}, files);
  files.commit();
  EXPECT_TRUE(read_file(dir.path / "terrain.obj") == texts[0]);
}

// ---- FileOutput -------------------------------------------------------------------------------

TEST(FileOutput, WritesFilesAndCountsBytes) {
  TempDir dir;
  const std::string sub = dir / "a/b";  // created on demand
  FileOutput out(sub);
  out.put("x.bin", std::string("hello\0world", 11));
  out.put("y.txt", "abc");
  EXPECT_EQ(read_file(fs::path(sub) / "x.bin"), std::string("hello\0world", 11));
  EXPECT_EQ(read_file(fs::path(sub) / "y.txt"), "abc");
  EXPECT_EQ(out.bytes_written(), 14u);
  ASSERT_EQ(out.written().size(), 2u);
  EXPECT_EQ(fs::path(out.written()[0]).filename(), "x.bin");
  EXPECT_TRUE(temp_leftovers(sub).empty());
}

TEST(FileOutput, ReplacesExistingFile) {
  TempDir dir;
  FileOutput out(dir.path.string());
  out.put("f.txt", "first version, longer");
  out.put("f.txt", "second");
  EXPECT_EQ(read_file(dir.path / "f.txt"), "second");
  EXPECT_TRUE(temp_leftovers(dir.path).empty());
}

TEST(FileOutput, DirectoryUnderRegularFileFails) {
  TempDir dir;
  write_file(dir.path / "plain", "not a directory");
  try {
    FileOutput out(dir / "plain/sub");
    FAIL() << "expected relief::Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "output");
    EXPECT_NE(std::string(e.what()).find("plain/sub"), std::string::npos) << e.what();
  }
  EXPECT_THROW(FileOutput(dir / "plain"), Error);  // exists, but is not a directory
}

TEST(FileOutput, FailedReplaceLeavesTargetAndNoTempFile) {
  // rename(2) cannot replace a non-empty directory with a file, even for root.
  TempDir dir;
  FileOutput out(dir.path.string());
  out.put("good.txt", "good");
  fs::create_directories(dir.path / "busy");
  write_file(dir.path / "busy" / "inside", "keep me");
  try {
    out.put("busy", "new bytes");
    FAIL() << "expected relief::Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "output");
  }
  EXPECT_EQ(read_file(dir.path / "busy" / "inside"), "keep me");
  EXPECT_EQ(read_file(dir.path / "good.txt"), "good");
  EXPECT_TRUE(temp_leftovers(dir.path).empty());
  EXPECT_EQ(out.written().size(), 1u);
}

TEST(FileOutput, FailedWriteKeepsPreviousGoodFile) {
  // A file size limit makes write(2) fail half way with EFBIG, for root too.
  TempDir dir;
  FileOutput out(dir.path.string());
  out.put("height.r16", "good old content");
  rlimit old{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  auto old_handler = ::signal(SIGXFSZ, SIG_IGN);
  rlimit small = old;
  small.rlim_cur = 8;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  bool threw = false;
  try {
    out.put("height.r16", std::string(100000, 'x'));
  } catch (const Error& e) {
    threw = e.path() == "output";
  }
  ::setrlimit(RLIMIT_FSIZE, &old);
  ::signal(SIGXFSZ, old_handler);
  EXPECT_TRUE(threw);
  EXPECT_EQ(read_file(dir.path / "height.r16"), "good old content");
  EXPECT_TRUE(temp_leftovers(dir.path).empty());
}

TEST(FileOutput, RejectsNamesOutsideTheDirectory) {
  TempDir dir;
  FileOutput out(dir / "sub");
  EXPECT_THROW(out.put("../escape.txt", "x"), Error);
  EXPECT_THROW(out.put("", "x"), Error);
  EXPECT_FALSE(fs::exists(dir.path / "escape.txt"));
}

TEST(FileOutput, WriteFileAtomicIntoMissingDirectoryFails) {
  TempDir dir;
  try {
    write_file_atomic(dir / "missing/f.txt", "x");
    FAIL() << "expected relief::Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "output");
  }
  write_file_atomic(dir / "f.txt", "atomic");
  EXPECT_EQ(read_file(dir.path / "f.txt"), "atomic");
}

// Both durability modes keep the same visibility contract (Atomic only skips the fsync).
class FileOutputSync : public ::testing::TestWithParam<FileOutput::Sync> {};
INSTANTIATE_TEST_SUITE_P(BothModes, FileOutputSync, ::testing::Values(FileOutput::Sync::Durable, FileOutput::Sync::Atomic),
                         [](const auto& info) { return info.param == FileOutput::Sync::Durable ? "Durable" : "Atomic"; });

TEST_P(FileOutputSync, OnCommitShowsNothingUntilCommit) {
  TempDir dir;
  write_file(dir.path / "a.txt", "old a");
  FileOutput out(dir.path.string(), FileOutput::Mode::OnCommit, GetParam());
  out.put("b.txt", "new b");
  auto s = out.open("a.txt");
  s->write("new ");
  s->write("a");
  s->close();
  EXPECT_EQ(read_file(dir.path / "a.txt"), "old a");
  EXPECT_FALSE(fs::exists(dir.path / "b.txt"));
  EXPECT_EQ(temp_leftovers(dir.path).size(), 2u);
  EXPECT_TRUE(out.written().empty());
  out.commit();
  EXPECT_EQ(read_file(dir.path / "a.txt"), "new a");
  EXPECT_EQ(read_file(dir.path / "b.txt"), "new b");
  EXPECT_TRUE(temp_leftovers(dir.path).empty());
  ASSERT_EQ(out.written().size(), 2u);  // in name order, whatever the order of the puts
  EXPECT_EQ(fs::path(out.written()[0]).filename(), "a.txt");
  EXPECT_EQ(fs::path(out.written()[1]).filename(), "b.txt");
  EXPECT_EQ(out.bytes_written(), 10u);
}

TEST_P(FileOutputSync, OnCommitWithoutCommitChangesNoFile) {
  TempDir dir;
  write_file(dir.path / "height.png", "old");
  {
    FileOutput out(dir.path.string(), FileOutput::Mode::OnCommit, GetParam());
    out.put("height.png", "new");
    out.put("color.png", "new");
    auto open_stream = out.open("terrain.obj");
    open_stream->write("half a mesh");
    // An Error in another writer: the output goes away without commit().
  }
  EXPECT_EQ(read_file(dir.path / "height.png"), "old");
  EXPECT_FALSE(fs::exists(dir.path / "color.png"));
  EXPECT_FALSE(fs::exists(dir.path / "terrain.obj"));
  EXPECT_TRUE(temp_leftovers(dir.path).empty());
}

// A stream whose size estimate is too large (the OBJ writer's is an upper bound) gets its blocks
// allocated up front; the file ends exactly at what was written and keeps no reserved block past it.
TEST_P(FileOutputSync, OverestimatedStreamEndsAtWhatWasWrittenAndKeepsNoSpareBlocks) {
  TempDir dir;
  const std::string piece(256 * 1024, 'x');
  FileOutput out(dir.path.string(), FileOutput::Mode::OnCommit, GetParam());
  auto s = out.open("big.obj", 64u << 20);  // 64 MiB estimate
  for (int k = 0; k < 6; ++k) s->write(piece);  // 1.5 MiB written
  s->close();
  out.commit();
  const fs::path f = dir.path / "big.obj";
  EXPECT_EQ(fs::file_size(f), 6u * piece.size());
  struct stat st {};
  ASSERT_EQ(::stat(f.c_str(), &st), 0);
  EXPECT_LE(std::uint64_t(st.st_blocks) * 512u, 2u << 20) << "blocks reserved past the end were not given back";
  EXPECT_EQ(read_file(f), [&] {
    std::string all;
    for (int k = 0; k < 6; ++k) all += piece;
    return all;
  }());
}

TEST_P(FileOutputSync, ImmediatePutReplacesAtOnce) {
  TempDir dir;
  write_file(dir.path / "f.txt", "old");
  FileOutput out(dir.path.string(), FileOutput::Mode::Immediate, GetParam());
  out.put("f.txt", "new");
  EXPECT_EQ(read_file(dir.path / "f.txt"), "new");
  EXPECT_TRUE(temp_leftovers(dir.path).empty());
}

TEST(FileOutput, OnCommitRejectsTheSameNameTwice) {
  TempDir dir;
  FileOutput out(dir.path.string(), FileOutput::Mode::OnCommit);
  out.put("x.txt", "one");
  try {
    out.put("x.txt", "two");
    FAIL() << "expected relief::Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "output");
    EXPECT_NE(std::string(e.what()).find("x.txt"), std::string::npos) << e.what();
  }
  out.commit();
  EXPECT_EQ(read_file(dir.path / "x.txt"), "one");
}

// The CLI's signal thread and a commit (remove_live_temporaries, commits_published): while a
// commit of several outputs runs — also between the publish of one output and the next — nothing is
// removed and the thread is told so; once no commit runs, the temporaries go and no later commit
// can start. In a child process: the last step closes that process's outputs for good.
TEST(FileOutput, InterruptWaitsForACommitOfSeveralOutputsAndThenClosesTheProcess) {
  TempDir dir;
  fs::create_directories(dir.path / "a");
  write_file(dir.path / "a" / "f.txt", "old");
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::alarm(60);  // a deadlock ends the child (the parent sees a signal), never the suite
    int failed = 0;
    auto check = [&](bool ok, int bit) { failed |= ok ? 0 : bit; };
    // The second output's publish waits until the main thread has asked to interrupt.
    struct Slow final : Output {
      std::atomic<int> stage{0};
      void put(const std::string&, std::string) override {}
      void publish() override {
        stage = 1;
        while (stage.load() != 2) ::usleep(1000);
      }
    } slow;
    FileOutput a((dir.path / "a").string(), FileOutput::Mode::OnCommit);
    a.put("f.txt", "new");
    const std::uint64_t published = commits_published();
    std::thread commit([&] { commit_all({&a, &slow}); });
    while (slow.stage.load() != 1) ::usleep(1000);
    check(read_file(dir.path / "a" / "f.txt") == "new", 1);  // the first output is published
    check(commits_published() == published + 1, 2);
    if (remove_live_temporaries()) ::_exit(failed | 4);  // between the two publishes: nothing may be removed
    slow.stage = 2;
    commit.join();
    FileOutput b((dir.path / "b").string(), FileOutput::Mode::OnCommit);
    b.put("g.txt", "pending");
    check(temp_leftovers(dir.path / "b").size() == 1, 8);
    check(remove_live_temporaries(), 16);  // no commit runs: the temporaries go
    check(temp_leftovers(dir.path / "b").empty(), 32);
    ::_exit(failed);
  }
  int st = 0;
  ASSERT_EQ(::waitpid(pid, &st, 0), pid);
  ASSERT_TRUE(WIFEXITED(st)) << st;
  EXPECT_EQ(WEXITSTATUS(st), 0) << "failed checks (bits): " << WEXITSTATUS(st);
  EXPECT_EQ(read_file(dir.path / "a" / "f.txt"), "new");
  EXPECT_FALSE(fs::exists(dir.path / "b" / "g.txt"));
}

TEST(FileOutput, OnCommitTakesPutsFromManyThreads) {
  TempDir dir;
  FileOutput out(dir.path.string(), FileOutput::Mode::OnCommit);
  std::vector<std::string> names;
  for (int k = 0; k < 64; ++k) names.push_back(std::to_string(100 + k) + ".txt");  // name order = k order
  tbb::parallel_for(0, 64, [&](int k) { out.put(names[std::size_t(k)], std::string(std::size_t(k) * 1000, char('a' + k % 26))); });
  out.commit();
  ASSERT_EQ(out.written().size(), 64u);
  for (int k = 0; k < 64; ++k) {
    EXPECT_EQ(fs::path(out.written()[std::size_t(k)]).filename(), names[std::size_t(k)]);
    EXPECT_EQ(read_file(out.written()[std::size_t(k)]), std::string(std::size_t(k) * 1000, char('a' + k % 26)));
  }
  EXPECT_TRUE(temp_leftovers(dir.path).empty());
}

TEST(FileOutput, StreamWithoutCloseLeavesNoFile) {
  TempDir dir;
  FileOutput out(dir.path.string());
  {
    auto s = out.open("mesh.obj");
    s->write("v 0 0 0\n");
  }
  EXPECT_FALSE(fs::exists(dir.path / "mesh.obj"));
  EXPECT_TRUE(temp_leftovers(dir.path).empty());
  auto s = out.open("mesh.obj");
  s->write("v 0 0 0\n");
  s->write("v 1 0 0\n");
  s->close();
  EXPECT_EQ(read_file(dir.path / "mesh.obj"), "v 0 0 0\nv 1 0 0\n");  // Immediate: visible at close()
}

TEST(MemoryOutput, StreamAppearsWholeAtClose) {
  MemoryOutput out;
  auto s = out.open("a.txt", 100);
  s->write("one ");
  s->write("two");
  EXPECT_EQ(out.files.count("a.txt"), 0u);
  s->close();
  EXPECT_EQ(out.files.at("a.txt"), "one two");
}
