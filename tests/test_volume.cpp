// The volume: density band, volume stages and volume writers (relief/volume.hpp).
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>
#include <tbb/global_control.h>

#include <cmath>
#include <map>
#include <sstream>

#include "relief/generate.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "relief/volume.hpp"
#include "support.hpp"

using namespace relief;
using namespace relief::test;

namespace {

// A small world: 65² samples over 128 m (2 m spacing), 200 m of relief, sea level 0.2: a plateau
// with a steep cliff down to a lower shelf along x, all above the sea except a corner.
Terrain cliff_terrain(int n = 65) {
  const Frame f = square_frame(n, 2.0 * (n - 1), 200.0, 0.2);
  return grid_terrain(f, [&](int i, int j) {
    const double x = double(i) / (n - 1), z = double(j) / (n - 1);
    const double cliff = 1.0 / (1.0 + std::exp(-(x - 0.5) * 60.0));  // steep step at x = 0.5
    return 0.2 + 0.03 + 0.17 * cliff + 0.013 * std::sin(9.1 * z + 0.3) + 0.0071;
  });
}

VolumeSpec caves_spec(std::uint64_t seed = 7) {
  VolumeSpec s;
  s.chunk = 16;
  s.base_m = 8;
  CaveSpec c;
  auto n3 = [&](double wl, int oct, std::uint64_t sd) {
    NoiseSettings n;
    n.basis = NoiseBasis::Gradient;
    n.fractal = oct > 1 ? Fractal::Fbm : Fractal::None;
    n.octaves = oct;
    n.frequency = 1.0 / wl;
    n.seed = sd;
    return n;
  };
  c.cheese = n3(40, 2, seed);
  c.spaghetti = n3(60, 1, seed + 16);
  c.noodle = n3(24, 1, seed + 32);
  c.cheese_threshold = 0.3;
  c.spaghetti_radius = 0.12;
  c.noodle_radius = 0.08;
  c.cover_m = 4;
  c.max_depth_m = 30;
  c.entrances = 0.4;
  c.entrance = n3(50, 1, seed + 48);
  c.entrance.fractal = Fractal::None;
  s.caves.push_back(c);
  return s;
}

VolumeSpec overhang_spec(std::uint64_t seed = 11) {
  VolumeSpec s;
  s.chunk = 16;
  OverhangSpec o;
  o.noise.basis = NoiseBasis::Gradient;
  o.noise.fractal = Fractal::Fbm;
  o.noise.octaves = 2;
  o.noise.frequency = 1.0 / 30.0;
  o.noise.seed = seed;
  o.strength_m = 20;
  o.min_slope_deg = 30;
  s.overhangs.push_back(o);
  return s;
}

struct Merged {
  std::vector<std::array<float, 3>> pos;
  std::vector<std::uint32_t> tri;  // merged vertex ids
  std::int64_t boundary_edges = 0, nonmanifold_edges = 0, degenerate = 0;
};

// All chunks' triangles with vertices merged by exact position; edges counted.
Merged merge(const std::vector<VolumeChunkMesh>& chunks) {
  Merged m;
  std::map<std::array<float, 3>, std::uint32_t> ids;
  for (auto& c : chunks) {
    std::vector<std::uint32_t> local(c.mesh.vertex_count());
    for (std::size_t a = 0; a < local.size(); ++a) {
      const std::array<float, 3> p{c.mesh.positions[a * 3], c.mesh.positions[a * 3 + 1], c.mesh.positions[a * 3 + 2]};
      auto [it, fresh] = ids.emplace(p, std::uint32_t(m.pos.size()));
      if (fresh) m.pos.push_back(p);
      local[a] = it->second;
    }
    for (auto i : c.mesh.indices) m.tri.push_back(local[i]);
  }
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
  for (std::size_t q = 0; q < m.tri.size(); q += 3) {
    const std::uint32_t a = m.tri[q], b = m.tri[q + 1], c = m.tri[q + 2];
    if (a == b || b == c || a == c) {
      ++m.degenerate;
      continue;
    }
    for (auto [u, v] : {std::pair{a, b}, std::pair{b, c}, std::pair{c, a}}) ++edges[{std::min(u, v), std::max(u, v)}];
  }
  for (auto& [e, n] : edges) {
    if (n == 1) ++m.boundary_edges;
    if (n > 2) ++m.nonmanifold_edges;
  }
  return m;
}

std::vector<VolumeChunkMesh> mesh_all(const Terrain& t, const VolumeSpec& s, VolumeStats* st = nullptr) {
  std::vector<VolumeChunkMesh> out;
  const VolumeStats r = mesh_volume(t, s, 1, [&](VolumeChunkMesh&& c) { out.push_back(std::move(c)); });
  if (st) *st = r;
  return out;
}

}  // namespace

TEST(Volume, PlainHeightfieldClosedIsAWatertightSolidWhoseTopIsTheSurface) {
  Terrain t = cliff_terrain();
  VolumeSpec s;
  s.chunk = 16;
  VolumeStats st;
  const auto chunks = mesh_all(t, s, &st);
  const Merged m = merge(chunks);
  ASSERT_GT(m.tri.size(), 0u);
  EXPECT_EQ(m.boundary_edges, 0);
  EXPECT_EQ(m.nonmanifold_edges, 0);
  EXPECT_EQ(m.degenerate, 0);
  // Upward-facing vertices lie on the heightfield (within the linear interpolation's error).
  const VolumeGrid g = volume_grid(t, s);
  int checked = 0;
  for (auto& c : chunks)
    for (std::size_t a = 0; a < c.mesh.vertex_count(); ++a) {
      const double x = c.mesh.positions[a * 3], y = c.mesh.positions[a * 3 + 1], z = c.mesh.positions[a * 3 + 2];
      if (c.mesh.normals[a * 3 + 1] < 0.9 || x < 2 || z < 2 || x > 126 || z > 126 || y < g.y_bottom_m + 1) continue;
      const int i = int(std::lround(x / 2.0)), k = int(std::lround(z / 2.0));
      if (std::fabs(x - 2.0 * i) > 1e-3 || std::fabs(z - 2.0 * k) > 1e-3) continue;  // on a column
      EXPECT_NEAR(y, t.frame.y_m(t.get("height").data[std::size_t(k) * 65 + i]), 0.05) << x << "," << z;
      ++checked;
    }
  EXPECT_GT(checked, 500);
  // The classification skipped the air above and the rock below.
  EXPECT_GT(st.air + st.solid, 0);
  EXPECT_EQ(st.chunks, st.air + st.solid + st.evaluated);
}

TEST(Volume, CavesAreCarvedBelowTheCoverAndTheMeshStaysWatertight) {
  Terrain t = cliff_terrain();
  const VolumeSpec s = caves_spec();
  const auto chunks = mesh_all(t, s);
  const Merged m = merge(chunks);
  EXPECT_EQ(m.boundary_edges, 0);
  EXPECT_EQ(m.nonmanifold_edges, 0);
  // Cave walls: vertices well inside the world, deeper than the cover below the local surface.
  const VolumeGrid g = volume_grid(t, s);
  int cave = 0, below_sea = 0;
  for (auto& p : m.pos) {
    const double x = p[0], y = p[1], z = p[2];
    if (x < 1 || z < 1 || x > 127 || z > 127 || y < g.y_bottom_m + 1) continue;  // walls and base
    const int i = std::clamp(int(std::lround(x / 2.0)), 0, 64), k = std::clamp(int(std::lround(z / 2.0)), 0, 64);
    const double h = t.frame.y_m(t.get("height").data[std::size_t(k) * 65 + i]);
    if (h - y > s.caves[0].cover_m) ++cave;
    if (y < -1e-3) ++below_sea;
    EXPECT_LE(h - y, s.caves[0].max_depth_m + 3.0) << "carved below max_depth_m at " << x << "," << y << "," << z;
  }
  EXPECT_GT(cave, 100);
  EXPECT_EQ(below_sea, 0) << "nothing is carved below the sea surface unless flooded";
}

TEST(Volume, OverhangsMakeDownwardFacingSurfacesOnlyWhereTheGroundIsSteep) {
  Terrain t = cliff_terrain();
  const auto plain = merge(mesh_all(t, [] {
    VolumeSpec s;
    s.chunk = 16;
    return s;
  }()));
  const auto chunks = mesh_all(t, overhang_spec());
  const Merged m = merge(chunks);
  EXPECT_EQ(m.boundary_edges, 0);
  EXPECT_EQ(m.nonmanifold_edges, 0);
  const VolumeGrid g = volume_grid(t, overhang_spec());
  int down = 0, down_far_from_cliff = 0;
  for (auto& c : chunks)
    for (std::size_t a = 0; a < c.mesh.vertex_count(); ++a) {
      const double x = c.mesh.positions[a * 3], y = c.mesh.positions[a * 3 + 1];
      if (y < g.y_bottom_m + 2 * g.voxel_m) continue;  // the base (and its edges) face down by construction
      if (c.mesh.normals[a * 3 + 1] < -0.25) {
        ++down;
        if (std::fabs(x - 64.0) > 30.0) ++down_far_from_cliff;
      }
    }
  EXPECT_GT(down, 10) << "the warp leans the cliff out";
  EXPECT_EQ(down_far_from_cliff, 0) << "gentle ground stays a heightfield";
  EXPECT_NE(m.tri.size(), plain.tri.size());
}

TEST(Volume, ChunksAgreeOnTheirSharedSamplesAndSkippedChunksHoldNoSurface) {
  Terrain t = cliff_terrain();
  VolumeSpec s = caves_spec();
  s.overhangs = overhang_spec().overhangs;
  const VolumeGrid g = volume_grid(t, s);
  ASSERT_GE(g.chunks_x, 3);
  // Neighbours along x, y and z: the shared layers (and the aprons over them) hold the same bits.
  for (int cy = 0; cy + 1 < g.chunks_y; ++cy) {
    const DensityBlock a = evaluate_chunk(t, s, g, 1, cy, 1, 1);
    const DensityBlock bx = evaluate_chunk(t, s, g, 2, cy, 1, 1);
    const DensityBlock by = evaluate_chunk(t, s, g, 1, cy + 1, 1, 1);
    const DensityBlock bz = evaluate_chunk(t, s, g, 1, cy, 2, 1);
    const int C = g.chunk;
    for (int u = 0; u < a.nx; ++u)
      for (int w = 0; w < a.nx; ++w)
        for (int d = 0; d < 3; ++d) {  // a's layers C, C+1, C+2 are b's 0, 1, 2
          ASSERT_EQ(a.at(C + d, u, w), bx.at(d, u, w));
          ASSERT_EQ(a.at(u, C + d, w), by.at(u, d, w));
          ASSERT_EQ(a.at(u, w, C + d), bz.at(u, w, d));
        }
  }
  // A chunk classified as air or rock is all air or all rock when evaluated anyway.
  int skipped = 0;
  for (int cy = 0; cy < g.chunks_y; ++cy)
    for (int cz = 0; cz < g.chunks_z; ++cz)
      for (int cx = 0; cx < g.chunks_x; ++cx) {
        const ChunkKind k = classify_chunk(t, s, g, cx, cy, cz);
        if (k == ChunkKind::Surface) continue;
        ++skipped;
        const DensityBlock b = evaluate_chunk(t, s, g, cx, cy, cz, 1);
        for (float d : b.d) ASSERT_TRUE(k == ChunkKind::Air ? d < 0 : d > 0) << cx << "," << cy << "," << cz;
      }
  EXPECT_GT(skipped, 0);
}

TEST(Volume, SameBytesForAnyThreadCount) {
  Terrain t = cliff_terrain();
  VolumeSpec s = caves_spec();
  s.overhangs = overhang_spec().overhangs;
  auto run = [&](int threads) {
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<float> all;
    std::vector<std::uint32_t> idx;
    mesh_volume(t, s, 3, [&](VolumeChunkMesh&& c) {
      all.insert(all.end(), c.mesh.positions.begin(), c.mesh.positions.end());
      all.insert(all.end(), c.mesh.normals.begin(), c.mesh.normals.end());
      all.insert(all.end(), c.mesh.colors.begin(), c.mesh.colors.end());
      idx.insert(idx.end(), c.mesh.indices.begin(), c.mesh.indices.end());
    });
    return std::pair{all, idx};
  };
  const auto one = run(1), two = run(2), three = run(3);
  EXPECT_TRUE(same_bits(one.first, two.first));
  EXPECT_TRUE(same_bits(one.first, three.first));
  EXPECT_EQ(one.second, two.second);
  EXPECT_EQ(one.second, three.second);
}

TEST(Volume, OversizedBandIsRefusedBeforeAnythingIsEvaluated) {
  Terrain t = cliff_terrain();
  VolumeSpec s;
  s.voxel_m = 0.01;
  s.max_chunks = 1000;
  try {
    volume_grid(t, s);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "volume.voxel_m");
  }
  s.voxel_m = 0;
  s.chunk = 4;
  try {
    volume_grid(t, s);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "volume.chunk");
  }
}

// ---- through recipes and writers ---------------------------------------------------------------

namespace {
json cave_recipe() {
  return json::parse(R"({
    "seed": 5,
    "world": {"size": 65, "width_m": 256, "height_m": 160, "sea_level": 0.25},
    "stages": [
      {"stage": "noise", "octaves": 4, "frequency": 2},
      {"stage": "redistribute", "exponent": 1.2},
      {"stage": "color"},
      {"stage": "volume", "chunk": 16, "base_m": 10},
      {"stage": "overhangs", "strength_m": 6, "wavelength_m": 40, "min_slope_deg": 25},
      {"stage": "caves", "cheese_threshold": 0.35, "cheese_wavelength_m": 50, "spaghetti_radius": 0.1,
       "spaghetti_wavelength_m": 70, "noodle_wavelength_m": 30, "max_depth_m": 30, "cover_m": 4, "entrances": 0.3}
    ]
  })");
}

std::map<std::string, std::string> generate_files(const json& doc, const std::string& formats, int threads = 0) {
  GenerateSettings s;
  s.recipe = parse_recipe(doc);
  s.formats = formats;
  s.threads = threads;
  MemoryOutput out;
  generate(s, out);
  return out.files;
}
}  // namespace

TEST(VolumeWriters, GlbHasOneNodePerMeshedChunkAndOBJMatchesIt) {
  const auto files = generate_files(cave_recipe(), "caves,caves_obj");
  ASSERT_TRUE(files.count("caves.glb"));
  ASSERT_TRUE(files.count("caves.obj"));
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  const std::string& glb = files.at("caves.glb");
  ASSERT_TRUE(loader.LoadBinaryFromMemory(&model, &err, &warn, reinterpret_cast<const unsigned char*>(glb.data()),
                                          unsigned(glb.size())))
      << err;
  std::size_t vertices = 0, triangles = 0;
  int chunk_nodes = 0;
  for (auto& n : model.nodes)
    if (n.mesh >= 0) {
      ++chunk_nodes;
      EXPECT_EQ(n.name.rfind("caves_x", 0), 0u);
      const auto& prim = model.meshes[std::size_t(n.mesh)].primitives[0];
      vertices += model.accessors[std::size_t(prim.attributes.at("POSITION"))].count;
      triangles += model.accessors[std::size_t(prim.indices)].count / 3;
      EXPECT_TRUE(prim.attributes.count("NORMAL"));
      EXPECT_TRUE(prim.attributes.count("COLOR_0"));
    }
  EXPECT_GT(chunk_nodes, 4);
  // The OBJ holds the same chunks, vertices and triangles.
  std::istringstream obj(files.at("caves.obj"));
  std::string line;
  std::size_t v = 0, f = 0, o = 0;
  while (std::getline(obj, line)) {
    if (line.rfind("v ", 0) == 0) ++v;
    else if (line.rfind("f ", 0) == 0) ++f;
    else if (line.rfind("o ", 0) == 0) ++o;
  }
  EXPECT_EQ(v, vertices);
  EXPECT_EQ(f, triangles);
  EXPECT_EQ(int(o), chunk_nodes);
}

TEST(VolumeWriters, SameFilesForAnyThreadCount) {
  const auto a = generate_files(cave_recipe(), "caves,vdb", 1);
  const auto b = generate_files(cave_recipe(), "caves,vdb", 2);
  EXPECT_EQ(a.at("caves.glb"), b.at("caves.glb"));
  EXPECT_EQ(a.at("caves.vdb"), b.at("caves.vdb"));
}

TEST(VolumeWriters, VdbIsALevelSetNegativeInRock) {
  const auto files = generate_files(cave_recipe(), "vdb");
  openvdb::initialize();
  std::istringstream is(files.at("caves.vdb"), std::ios_base::binary);
  openvdb::io::Stream stream(is);
  auto grids = stream.getGrids();
  ASSERT_EQ(grids->size(), 1u);
  auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>((*grids)[0]);
  ASSERT_TRUE(grid);
  EXPECT_EQ(grid->getName(), "surface");
  EXPECT_EQ(grid->getGridClass(), openvdb::GRID_LEVEL_SET);
  const double voxel = 256.0 / 64;
  EXPECT_NEAR(grid->voxelSize()[0], voxel, 1e-9);
  EXPECT_GT(grid->activeVoxelCount(), 1000u);
  // High above everything: air (positive); deep below the surface but above the base: rock.
  auto acc = grid->getConstAccessor();
  EXPECT_GT(acc.getValue(openvdb::Coord(32, int(200 / voxel), 32)), 0.0f);
  Terrain t;
  {
    GenerateSettings s;
    s.recipe = parse_recipe(cave_recipe());
    RunOptions ro;
    t = run(s.recipe, ro).terrain;
  }
  const VolumeGrid g = volume_grid(t, *t.volume);
  const int j_deep = int(std::ceil(g.y_bottom_m / voxel)) + 1;
  EXPECT_LT(acc.getValue(openvdb::Coord(32, j_deep, 32)), 0.0f);
}

TEST(VolumeWriters, ErrorsNameTheField) {
  json d = cave_recipe();
  d["stages"][4]["mask"] = "nope";
  try {
    generate_files(d, "caves");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[4].mask");
  }
  d = cave_recipe();
  d["stages"][5]["cheese"] = false;
  d["stages"][5]["spaghetti"] = false;
  d["stages"][5]["noodle"] = false;
  try {
    parse_recipe(d);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[5].cheese");
  }
  d = cave_recipe();
  d["stages"][3]["chunk"] = 4;
  try {
    parse_recipe(d);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[3].chunk");
  }
  // A volume writer named for a recipe without a volume says what it needs.
  d = cave_recipe();
  d["stages"].erase(5);
  d["stages"].erase(4);
  d["stages"].erase(3);
  try {
    generate_files(d, "caves");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("volume"), std::string::npos) << e.what();
  }
}

// The bytes of the mesh of a fixed spec: a change of the density's definition, the 3D noise or the
// mesher shows here (and must be named in the change that makes it).
TEST(Volume, GoldenHash) {
  Terrain t = cliff_terrain();
  VolumeSpec s = caves_spec();
  s.overhangs = overhang_spec().overhangs;
  std::vector<float> all;
  std::uint64_t tris = 0;
  mesh_volume(t, s, 3, [&](VolumeChunkMesh&& c) {
    all.insert(all.end(), c.mesh.positions.begin(), c.mesh.positions.end());
    all.insert(all.end(), c.mesh.normals.begin(), c.mesh.normals.end());
    tris += c.mesh.triangle_count();
  });
  EXPECT_EQ(tris, 50252u);
  EXPECT_EQ(fnv1a(all), 0xf2ec4c59182046d8ull);
}

TEST(VolumeWriters, CancelledWhileMeshingStopsTheRun) {
  json doc = cave_recipe();
  doc["stages"][3]["chunk"] = 8;  // several batches of chunks: the writer asks between them
  GenerateSettings s;
  s.recipe = parse_recipe(doc);
  s.formats = "caves";
  s.threads = 1;
  bool meshing = false;
  int asked_while_meshing = 0;
  s.progress = [&](std::string_view what, double) { meshing = meshing || what == "caves"; };
  s.cancelled = [&] {
    if (meshing) ++asked_while_meshing;
    return meshing;
  };
  MemoryOutput out;
  EXPECT_THROW(generate(s, out), Cancelled);
  EXPECT_GE(asked_while_meshing, 1);
  EXPECT_EQ(out.files.count("caves.glb"), 0u);
}

// From the command line: a band too fine for the machine is refused before any work, exit 2,
// naming the volume stage's parameter; a volume writer without a volume names what it needs.
TEST(VolumeCli, BadBandsExitWithCode2NamingTheField) {
  expect_cli_error("generate sea-cliff --size 129 --set 'stages[5].voxel_m=0.01' --formats caves -o /tmp/relief_volume_cli_bad",
                   "stages[5].voxel_m");
  EXPECT_FALSE(std::filesystem::exists("/tmp/relief_volume_cli_bad"));
  expect_cli_error("generate island --size 65 --formats caves -o /tmp/relief_volume_cli_bad", "volume");
}
