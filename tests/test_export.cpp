// Export writers: terrain meshes (chunks, jiggle, simplification, LOD, low-poly), props, GLB read
// back with tinygltf (instancing and MSFT_lod checked here: the Khronos validator ignores them),
// FBX parsed by our own reader, STL closedness, engine profiles (sizes, byte order, orientation,
// tiles), normal/splat/hillshade maps and the writer option table. The real client tools
// (gltf-validator, assimp, Blender, Pillow) run in test_clients.cpp.
#include <ImfArray.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <gtest/gtest.h>
#include <spng.h>
#include <tbb/global_control.h>
#include <tiny_gltf.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "relief/error.hpp"
#include "relief/export.hpp"
#include "relief/output.hpp"
#include "relief/random.hpp"
#include "relief/stage.hpp"
#include "support.hpp"

namespace fs = std::filesystem;

using namespace relief;

namespace {

// ---- fixtures -----------------------------------------------------------------------------------

// Smooth but asymmetric elevation in 0..1 (so flips and transpositions show).
float elev(int i, int j, int nx, int nz) {
  const double x = double(i) / (nx - 1), z = double(j) / (nz - 1);
  return float(0.2 + 0.5 * x * x + 0.25 * z + 0.05 * std::sin(7 * x + 3 * z));
}

Terrain terrain(int nx, int nz, double cell = 10.0) {
  Terrain t;
  t.frame.nx = nx;
  t.frame.nz = nz;
  t.frame.spacing_m = cell;
  t.frame.world_width_m = cell * (nx - 1);
  t.frame.world_depth_m = cell * (nz - 1);
  t.frame.height_m = 300;
  t.frame.sea_level = 0.3;
  Layer& h = t.layer("height", 1);
  h.data.resize(t.frame.count());
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) h.data[std::size_t(j) * nx + i] = elev(i, j, nx, nz);
  Layer& a = t.layer("albedo", 3);
  a.data.resize(t.frame.count() * 3);
  for (std::size_t k = 0; k < t.frame.count(); ++k) {
    a.data[3 * k] = float(k % nx) / float(nx);
    a.data[3 * k + 1] = 0.5f;
    a.data[3 * k + 2] = float(k / nx) / float(nz);
  }
  return t;
}

void add_props(Terrain& t) {
  const char* types[] = {"tree", "pine", "rock", "tree", "bush", "cactus", "mushroom", "tree"};
  for (int k = 0; k < 8; ++k) {
    Point p;
    p.kind = "prop";
    p.type = types[k];
    p.x_m = 10.0 + 7.0 * k;
    p.y_m = 3.0 + k;
    p.z_m = 50.0 - 4.0 * k;
    p.rotation_deg = 40.0 * k;
    p.scale = 0.8 + 0.1 * k;
    t.points.push_back(p);
  }
  Point feature;  // not a prop: ignored by the mesh writers
  feature.kind = "volcano";
  feature.type = "centre";
  t.points.push_back(feature);
}

void add_offset(Terrain& t, double amplitude_m) {
  Layer& o = t.layer("offset", 2);
  o.data.resize(t.frame.count() * 2);
  for (std::size_t k = 0; k < o.data.size(); ++k) o.data[k] = float(amplitude_m * (2 * unit_double(hash64(99, k)) - 1));
}

std::size_t total_triangles(const std::vector<TerrainChunk>& c) {
  std::size_t n = 0;
  for (auto& x : c) n += x.mesh.triangle_count();
  return n;
}

tinygltf::Model load_glb(const std::string& bytes) {
  tinygltf::Model m;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  const bool ok = loader.LoadBinaryFromMemory(&m, &err, &warn, reinterpret_cast<const unsigned char*>(bytes.data()),
                                              unsigned(bytes.size()));
  EXPECT_TRUE(ok) << err;
  EXPECT_EQ(err, "");
  return m;
}

template <class T>
std::vector<T> accessor_data(const tinygltf::Model& m, int index) {
  const auto& a = m.accessors[std::size_t(index)];
  const auto& v = m.bufferViews[std::size_t(a.bufferView)];
  const auto& b = m.buffers[std::size_t(v.buffer)];
  const std::size_t comps = a.type == TINYGLTF_TYPE_SCALAR ? 1 : a.type == TINYGLTF_TYPE_VEC2 ? 2 : a.type == TINYGLTF_TYPE_VEC3 ? 3 : 4;
  std::vector<T> out(a.count * comps);
  std::memcpy(out.data(), b.data.data() + v.byteOffset + a.byteOffset, out.size() * sizeof(T));
  return out;
}
using test::decode_png;
std::uint16_t u16_at(const test::Png& d, std::size_t k) {
  std::uint16_t v;
  std::memcpy(&v, d.bytes.data() + 2 * k, 2);
  return v;
}
std::uint16_t u16(float e) { return std::uint16_t(std::lround(std::clamp(double(e), 0.0, 1.0) * 65535.0)); }

// ---- a small binary FBX reader (the layout of writer_fbx.cpp's header comment) ------------------
struct FbxProp {
  char type = 0;
  std::int64_t i = 0;
  double d = 0;
  std::string s;
  std::vector<double> f64s;
  std::vector<std::int32_t> i32s;
};
struct FbxNode {
  std::string name;
  std::vector<FbxProp> props;
  std::vector<FbxNode> children;
  const FbxNode* child(const std::string& n) const {
    for (auto& c : children)
      if (c.name == n) return &c;
    return nullptr;
  }
};
struct FbxReader {
  const std::string& b;
  std::size_t pos = 0;
  bool ok = true;
  template <class T>
  T get() {
    T v{};
    if (pos + sizeof(T) > b.size()) {
      ok = false;
      return v;
    }
    std::memcpy(&v, b.data() + pos, sizeof(T));
    pos += sizeof(T);
    return v;
  }
  template <class T>
  std::vector<T> array() {
    const auto n = get<std::uint32_t>(), enc = get<std::uint32_t>(), len = get<std::uint32_t>();
    std::vector<T> out(n);
    if (enc == 0) {
      std::memcpy(out.data(), b.data() + pos, std::size_t(n) * sizeof(T));
    } else {
      uLongf dest = uLongf(n * sizeof(T));
      ok = ok && uncompress(reinterpret_cast<Bytef*>(out.data()), &dest, reinterpret_cast<const Bytef*>(b.data() + pos), len) == Z_OK &&
           dest == n * sizeof(T);
    }
    pos += len;
    return out;
  }
  // Reads one record; returns false on the null record.
  bool node(FbxNode& n) {
    const auto end = get<std::uint32_t>(), count = get<std::uint32_t>();
    get<std::uint32_t>();
    const auto len = get<std::uint8_t>();
    if (end == 0 && count == 0 && len == 0) return false;
    n.name = b.substr(pos, len);
    pos += len;
    for (std::uint32_t k = 0; k < count && ok; ++k) {
      FbxProp p;
      p.type = get<char>();
      switch (p.type) {
        case 'I': p.i = get<std::int32_t>(); break;
        case 'L': p.i = get<std::int64_t>(); break;
        case 'C': p.i = get<std::uint8_t>(); break;
        case 'D': p.d = get<double>(); break;
        case 'S':
        case 'R': {
          const auto l = get<std::uint32_t>();
          p.s = b.substr(pos, l);
          pos += l;
          break;
        }
        case 'd': p.f64s = array<double>(); break;
        case 'i': p.i32s = array<std::int32_t>(); break;
        default: ok = false;
      }
      n.props.push_back(std::move(p));
    }
    while (ok && pos < end) {
      FbxNode c;
      if (!node(c)) break;
      n.children.push_back(std::move(c));
    }
    ok = ok && pos == end;
    return true;
  }
};
std::vector<FbxNode> parse_fbx(const std::string& bytes, bool* ok) {
  std::vector<FbxNode> top;
  FbxReader r{bytes};
  r.pos = 27;
  *ok = bytes.compare(0, 20, "Kaydara FBX Binary  ") == 0;
  while (r.ok) {
    FbxNode n;
    if (!r.node(n)) break;
    top.push_back(std::move(n));
  }
  *ok = *ok && r.ok;
  return top;
}
const FbxNode* top_node(const std::vector<FbxNode>& top, const std::string& name) {
  for (auto& n : top)
    if (n.name == name) return &n;
  return nullptr;
}
double p70_number(const FbxNode& p70, const std::string& name) {
  for (auto& p : p70.children)
    if (!p.props.empty() && p.props[0].s == name) return p.props[4].type == 'D' ? p.props[4].d : double(p.props[4].i);
  return NAN;
}

// ---- STL ---------------------------------------------------------------------------------------
struct Stl {
  std::vector<std::array<float, 12>> tris;  // normal, a, b, c
};
Stl parse_stl(const std::string& b) {
  Stl s;
  std::uint32_t n = 0;
  std::memcpy(&n, b.data() + 80, 4);
  EXPECT_EQ(b.size(), 84 + 50 * std::size_t(n));
  s.tris.resize(n);
  for (std::uint32_t k = 0; k < n; ++k) std::memcpy(s.tris[k].data(), b.data() + 84 + 50 * std::size_t(k), 48);
  return s;
}
struct Closedness {
  std::size_t bad_edges = 0, bad_normals = 0;
  double volume = 0;
};
// Welds by exact coordinates; every directed edge must occur once and its reverse once.
Closedness check_closed(const Stl& s) {
  std::map<std::array<float, 3>, int> ids;
  auto id = [&](const float* p) { return ids.emplace(std::array<float, 3>{p[0], p[1], p[2]}, int(ids.size())).first->second; };
  std::map<std::pair<int, int>, int> edges;
  Closedness c;
  for (auto& t : s.tris) {
    const int v[3] = {id(&t[3]), id(&t[6]), id(&t[9])};
    for (int k = 0; k < 3; ++k) edges[{v[k], v[(k + 1) % 3]}] += 1;
    const double ax = t[3], ay = t[4], az = t[5], bx = t[6], by = t[7], bz = t[8], cx = t[9], cy = t[10], cz = t[11];
    const double nx = (by - ay) * (cz - az) - (bz - az) * (cy - ay), ny = (bz - az) * (cx - ax) - (bx - ax) * (cz - az),
                 nz = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
    const double len = std::sqrt(nx * nx + ny * ny + nz * nz);
    if (len == 0 || (nx * t[0] + ny * t[1] + nz * t[2]) / len < 0.999) ++c.bad_normals;
    c.volume += (ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)) / 6.0;
  }
  for (auto& [e, n] : edges) {
    auto rev = edges.find({e.second, e.first});
    if (n != 1 || rev == edges.end() || rev->second != 1) ++c.bad_edges;
  }
  return c;
}

}  // namespace

// ---- options ------------------------------------------------------------------------------------

TEST(ExportOptions, TableDeclaresEveryOptionOnceWithDefaultsInRange) {
  std::set<std::string> names;
  for (const ParamInfo& p : export_options_table().infos()) {
    EXPECT_TRUE(names.insert(p.name).second) << p.name;
    EXPECT_FALSE(p.description.empty()) << p.name;
    if (p.type == ParamType::Int || p.type == ParamType::Float) {
      EXPECT_GE(p.default_value.get<double>(), p.min) << p.name;
      EXPECT_LE(p.default_value.get<double>(), p.max) << p.name;
    }
    if (p.type == ParamType::Choice) {
      EXPECT_NE(std::find(p.choices.begin(), p.choices.end(), p.default_value.get<std::string>()), p.choices.end()) << p.name;
    }
  }
  for (const char* n : {"engine", "split", "instancing", "stl_size_mm", "stl_exaggeration", "stl_base_mm", "lod_levels",
                        "simplify_error_m", "triangle_budget", "style", "normal_bits"})
    EXPECT_EQ(names.count(n), 1u) << n;
}

TEST(ExportOptions, BadValuesNameTheOption) {
  ExportOptions o;
  auto message = [&](const std::string& name, const json& v) {
    try {
      set_export_option(o, name, v, "--" + name);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message("stl_size_mm", 5).rfind("--stl_size_mm: ", 0), 0u) << message("stl_size_mm", 5);
  EXPECT_NE(message("engine", "cryengine").find("--engine"), std::string::npos);
  EXPECT_NE(message("lod_levels", 1.5).find("--lod_levels"), std::string::npos);
  EXPECT_NE(message("stl_sise_mm", 5).find("did you mean 'stl_size_mm'"), std::string::npos);
  auto invalid = [](ExportOptions x) {
    try {
      validate_export_options(x, [](const std::string& n) { return "--" + n; });
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  ExportOptions s;
  s.engine = Engine::Unreal;
  s.split = "4by4";
  EXPECT_EQ(invalid(s).rfind("--split: ", 0), 0u) << invalid(s);
  s.split = "4x4";
  EXPECT_EQ(invalid(s), "no error");
  s.engine = Engine::None;
  EXPECT_EQ(invalid(s).rfind("--split: ", 0), 0u);
  ExportOptions nb;
  nb.normal_bits = 12;
  EXPECT_EQ(invalid(nb).rfind("--normal_bits: ", 0), 0u);
}

// ---- terrain meshes ----------------------------------------------------------------------------

TEST(Mesh, ChunksTileTheGridAndShareBorderVertices) {
  Terrain t = terrain(65, 33);
  ExportOptions o;
  o.chunk_quads = 16;
  auto chunks = build_terrain_chunks(t, o);
  ASSERT_EQ(chunks.size(), 4u * 2u);
  EXPECT_EQ(total_triangles(chunks), 2u * 64 * 32);
  // Every sample's vertex appears in each chunk that contains it, bit for bit.
  std::map<std::pair<float, float>, std::array<float, 8>> seen;
  std::size_t shared = 0;
  for (auto& c : chunks)
    for (std::size_t v = 0; v < c.mesh.vertex_count(); ++v) {
      const float* p = &c.mesh.positions[3 * v];
      std::array<float, 8> rec = {p[0], p[1], p[2], c.mesh.normals[3 * v], c.mesh.normals[3 * v + 1], c.mesh.normals[3 * v + 2],
                                  c.mesh.uvs[2 * v], c.mesh.uvs[2 * v + 1]};
      auto [it, fresh] = seen.emplace(std::make_pair(p[0], p[2]), rec);
      if (!fresh) {
        ++shared;
        EXPECT_EQ(it->second, rec);
      }
    }
  EXPECT_EQ(seen.size(), 65u * 33u);
  EXPECT_EQ(shared, 3u * 33 + 1 * 65 + 3u);  // three inner x borders, one inner z border (crossings counted once more)
}

TEST(Mesh, VerticesFollowTheFrameUvsAndNormals) {
  Terrain t = terrain(9, 5);
  t.frame.ix0 = 4;  // a window not at the origin
  ExportOptions o;
  auto chunks = build_terrain_chunks(t, o);
  ASSERT_EQ(chunks.size(), 1u);
  const MeshData& m = chunks[0].mesh;
  ASSERT_EQ(m.vertex_count(), 45u);
  for (int j = 0; j < 5; ++j)
    for (int i = 0; i < 9; ++i) {
      const std::size_t v = std::size_t(j) * 9 + i;
      EXPECT_FLOAT_EQ(m.positions[3 * v], float(t.frame.x_m(i)));
      EXPECT_FLOAT_EQ(m.positions[3 * v + 1], float(t.frame.y_m(elev(i, j, 9, 5))));
      EXPECT_FLOAT_EQ(m.positions[3 * v + 2], float(t.frame.z_m(j)));
      EXPECT_FLOAT_EQ(m.uvs[2 * v], float(i / 8.0));
      EXPECT_FLOAT_EQ(m.uvs[2 * v + 1], float(j / 4.0));
      const double n = std::hypot(m.normals[3 * v], m.normals[3 * v + 1], m.normals[3 * v + 2]);
      EXPECT_NEAR(n, 1.0, 1e-6);
    }
  // Every triangle winds counter-clockwise seen from +Y.
  for (std::size_t k = 0; k < m.triangle_count(); ++k) {
    const float* a = &m.positions[3 * m.indices[3 * k]];
    const float* b = &m.positions[3 * m.indices[3 * k + 1]];
    const float* c = &m.positions[3 * m.indices[3 * k + 2]];
    const double ny = double(b[2] - a[2]) * (c[0] - a[0]) - double(b[0] - a[0]) * (c[2] - a[2]);
    EXPECT_GT(ny, 0) << k;
  }
}

TEST(Mesh, NormalsOfATiltedPlane) {
  Terrain t = terrain(5, 5, 10.0);
  auto& h = t.get("height").data;
  // y_m = 300·e + c: e = 0.01·i gives 3 m per 10 m cell along x, e = 0.02·j gives 6 m per cell along z.
  for (int j = 0; j < 5; ++j)
    for (int i = 0; i < 5; ++i) h[std::size_t(j) * 5 + i] = float(0.3 + 0.01 * i + 0.02 * j);
  auto m = build_terrain_chunks(t, ExportOptions{})[0].mesh;
  const double len = std::sqrt(0.3 * 0.3 + 1 + 0.6 * 0.6);
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    EXPECT_NEAR(m.normals[3 * v], -0.3 / len, 1e-5);
    EXPECT_NEAR(m.normals[3 * v + 1], 1.0 / len, 1e-5);
    EXPECT_NEAR(m.normals[3 * v + 2], -0.6 / len, 1e-5);
  }
}

TEST(Mesh, OffsetLayerMovesVerticesInXAndZOnly) {
  Terrain t = terrain(17, 9);
  const auto plain = build_terrain_chunks(t, ExportOptions{});
  add_offset(t, 2.5);
  const auto jig = build_terrain_chunks(t, ExportOptions{});
  const Layer& off = t.get("offset");
  ASSERT_EQ(plain[0].mesh.vertex_count(), jig[0].mesh.vertex_count());
  for (std::size_t v = 0; v < jig[0].mesh.vertex_count(); ++v) {
    EXPECT_FLOAT_EQ(jig[0].mesh.positions[3 * v], float(double(plain[0].mesh.positions[3 * v]) + off.data[2 * v]));
    EXPECT_EQ(jig[0].mesh.positions[3 * v + 1], plain[0].mesh.positions[3 * v + 1]);
    EXPECT_FLOAT_EQ(jig[0].mesh.positions[3 * v + 2], float(double(plain[0].mesh.positions[3 * v + 2]) + off.data[2 * v + 1]));
  }
  // The OBJ writer applies the same offsets.
  MemoryOutput out;
  find_writer("obj")->write(t, {}, out);
  std::istringstream s(out.files.at("terrain.obj"));
  std::string line;
  std::size_t v = 0;
  while (std::getline(s, line)) {
    if (line.rfind("v ", 0) != 0) continue;
    double x, y, z;
    std::istringstream(line.substr(2)) >> x >> y >> z;
    const int i = int(v % 17), j = int(v / 17);
    EXPECT_NEAR(x, t.frame.x_m(i) + off.data[2 * v], 1e-4);
    EXPECT_NEAR(z, t.frame.z_m(j) + off.data[2 * v + 1], 1e-4);
    ++v;
  }
  EXPECT_EQ(v, 17u * 9u);
  // A malformed offset layer is an error naming it.
  t.layer("offset", 1);
  try {
    build_terrain_chunks(t, ExportOptions{});
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "offset");
  }
  EXPECT_THROW(find_writer("obj")->write(t, {}, out), Error);
}

TEST(Mesh, SimplifyKeepsTheSurfaceWithinTheErrorAndTheBordersLocked) {
  Terrain t = terrain(65, 65, 10.0);
  ExportOptions o;
  o.chunk_quads = 32;
  const auto full = build_terrain_chunks(t, o);
  o.simplify_error_m = 0.5;
  const auto simp = build_terrain_chunks(t, o);
  EXPECT_LT(total_triangles(simp), total_triangles(full) / 3);
  // Border vertices of each chunk are kept: the set of vertices on chunk borders is unchanged.
  auto border_set = [](const std::vector<TerrainChunk>& cs) {
    std::set<std::array<float, 3>> s;
    for (auto& c : cs)
      for (std::size_t v = 0; v < c.mesh.vertex_count(); ++v) {
        const float* p = &c.mesh.positions[3 * v];
        const double x = p[0] / 10.0, z = p[2] / 10.0;
        if (std::fmod(x, 32.0) == 0 || std::fmod(z, 32.0) == 0) s.insert({p[0], p[1], p[2]});
      }
    return s;
  };
  EXPECT_EQ(border_set(full), border_set(simp));
  // Every grid sample lies within a few times the error of the simplified surface (vertical
  // distance; meshoptimizer bounds a quadric distance, not this one, hence the factor).
  double worst = 0;
  const Layer& h = t.get("height");
  for (auto& c : simp) {
    const MeshData& m = c.mesh;
    for (int j = c.cz * 32; j <= c.cz * 32 + 32; ++j)
      for (int i = c.cx * 32; i <= c.cx * 32 + 32; ++i) {
        const double x = i * 10.0, z = j * 10.0, y = t.frame.y_m(h.data[std::size_t(j) * 65 + i]);
        for (std::size_t k = 0; k < m.triangle_count(); ++k) {
          const float* a = &m.positions[3 * m.indices[3 * k]];
          const float* b = &m.positions[3 * m.indices[3 * k + 1]];
          const float* cc = &m.positions[3 * m.indices[3 * k + 2]];
          const double d = (b[2] - cc[2]) * (a[0] - cc[0]) + (cc[0] - b[0]) * (a[2] - cc[2]);
          const double l1 = ((b[2] - cc[2]) * (x - cc[0]) + (cc[0] - b[0]) * (z - cc[2])) / d;
          const double l2 = ((cc[2] - a[2]) * (x - cc[0]) + (a[0] - cc[0]) * (z - cc[2])) / d;
          const double l3 = 1 - l1 - l2;
          if (l1 < -1e-9 || l2 < -1e-9 || l3 < -1e-9) continue;
          worst = std::max(worst, std::abs(l1 * a[1] + l2 * b[1] + l3 * cc[1] - y));
          break;
        }
      }
  }
  EXPECT_LT(worst, 4 * 0.5);
  EXPECT_GT(worst, 0.0);
}

TEST(Mesh, TriangleBudgetIsMet) {
  Terrain t = terrain(65, 65);
  ExportOptions o;
  o.chunk_quads = 64;
  o.triangle_budget = 2000;
  const auto c = build_terrain_chunks(t, o);
  EXPECT_LE(total_triangles(c), 2000u);
  EXPECT_GT(total_triangles(c), 1500u);
}

TEST(Mesh, LodChainLosesDetailLevelByLevel) {
  Terrain t = terrain(65, 65);
  ExportOptions o;
  o.chunk_quads = 32;
  o.lod_error_m = 0.2;
  std::size_t prev = total_triangles(build_terrain_chunks(t, o, 0));
  for (int k = 1; k <= 3; ++k) {
    const std::size_t n = total_triangles(build_terrain_chunks(t, o, k));
    EXPECT_LT(n, prev) << "lod " << k;
    prev = n;
  }
}

TEST(Mesh, LowpolyIsFlatShadedAndColouredFromTheAlbedo) {
  Terrain t = terrain(17, 17);
  ExportOptions o;
  o.style = MeshStyle::Lowpoly;
  const MeshData m = build_terrain_chunks(t, o)[0].mesh;
  ASSERT_EQ(m.vertex_count(), 3 * m.triangle_count());
  ASSERT_EQ(m.colors.size(), m.positions.size());
  const Layer& a = t.get("albedo");
  for (std::size_t k = 0; k < m.triangle_count(); ++k) {
    for (int c = 1; c < 3; ++c)
      for (int d = 0; d < 3; ++d) {
        EXPECT_EQ(m.normals[9 * k + 3 * c + d], m.normals[9 * k + d]);
        EXPECT_EQ(m.colors[9 * k + 3 * c + d], m.colors[9 * k + d]);
      }
    // The colour is the albedo of a sample of the triangle's cell.
    const double u = (m.uvs[6 * k] + m.uvs[6 * k + 2] + m.uvs[6 * k + 4]) / 3, v = (m.uvs[6 * k + 1] + m.uvs[6 * k + 3] + m.uvs[6 * k + 5]) / 3;
    const std::size_t s = std::size_t(std::lround(v * 16)) * 17 + std::size_t(std::lround(u * 16));
    EXPECT_EQ(m.colors[9 * k], a.data[3 * s]);
    EXPECT_EQ(m.colors[9 * k + 2], a.data[3 * s + 2]);
  }
}

TEST(Mesh, IdenticalForAnyThreadCount) {
  Terrain t = terrain(97, 65);
  ExportOptions o;
  o.chunk_quads = 16;
  o.simplify_error_m = 0.3;
  std::vector<TerrainChunk> one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = build_terrain_chunks(t, o);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 3);
    two = build_terrain_chunks(t, o);
  }
  ASSERT_EQ(one.size(), two.size());
  for (std::size_t k = 0; k < one.size(); ++k) {
    EXPECT_EQ(one[k].mesh.positions, two[k].mesh.positions);
    EXPECT_EQ(one[k].mesh.indices, two[k].mesh.indices);
  }
}

TEST(Mesh, MissingOrBrokenHeightIsAnError) {
  Terrain t = terrain(5, 5);
  t.get("height").data[7] = NAN;
  EXPECT_THROW(build_terrain_chunks(t, ExportOptions{}), Error);
  t.layers.erase("height");
  EXPECT_THROW(build_terrain_chunks(t, ExportOptions{}), Error);
}

// ---- props -------------------------------------------------------------------------------------

TEST(Props, EveryTypeIsALowPolyModelStandingOnTheGround) {
  for (const std::string& type : prop_types()) {
    const MeshData m = prop_mesh(type);
    EXPECT_GT(m.triangle_count(), 4u) << type;
    EXPECT_LT(m.triangle_count(), 400u) << type;  // low-poly
    ASSERT_EQ(m.colors.size(), m.positions.size()) << type;
    double lo = 1e9, hi = -1e9;
    for (std::size_t v = 0; v < m.vertex_count(); ++v) lo = std::min(lo, double(m.positions[3 * v + 1])), hi = std::max(hi, double(m.positions[3 * v + 1]));
    EXPECT_LE(lo, 0.0) << type;   // touches or enters the ground
    EXPECT_GT(lo, -0.5) << type;  // but is not buried
    EXPECT_GT(hi, 0.3) << type;
    EXPECT_LT(hi, 15.0) << type;
    // Stored normals agree with the winding.
    for (std::size_t k = 0; k < m.triangle_count(); ++k) {
      const float* a = &m.positions[9 * k];
      const double ux = a[3] - a[0], uy = a[4] - a[1], uz = a[5] - a[2], vx = a[6] - a[0], vy = a[7] - a[1], vz = a[8] - a[2];
      const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
      EXPECT_GT(nx * m.normals[9 * k] + ny * m.normals[9 * k + 1] + nz * m.normals[9 * k + 2], 0) << type << " " << k;
    }
  }
  EXPECT_THROW(prop_mesh("baobab"), Error);
}

TEST(Props, UnknownTypeOrBadScaleNamesThePoint) {
  Terrain t = terrain(5, 5);
  add_props(t);
  t.points[1].type = "baobab";
  try {
    terrain_props(t);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "points[1].type");
    EXPECT_NE(std::string(e.what()).find("mushroom"), std::string::npos);
  }
  t.points[1].type = "pine";
  t.points[2].scale = 0;
  try {
    terrain_props(t);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "points[2].scale");
  }
}

// ---- GLB ---------------------------------------------------------------------------------------

TEST(Glb, RoundTripThroughTinygltf) {
  Terrain t = terrain(33, 17);
  ExportOptions o;
  o.chunk_quads = 16;
  const GlbFiles g = encode_glb(t, o);
  EXPECT_TRUE(g.lods.empty());
  const tinygltf::Model m = load_glb(g.base);
  ASSERT_EQ(m.meshes.size(), 2u);  // 2×1 chunks, no props
  EXPECT_EQ(m.asset.version, "2.0");
  ASSERT_EQ(m.images.size(), 1u);
  EXPECT_EQ(m.images[0].mimeType, "image/png");
  EXPECT_EQ(m.images[0].width, 33);
  EXPECT_EQ(m.images[0].height, 17);
  ASSERT_EQ(m.materials.size(), 1u);
  EXPECT_EQ(m.materials[0].pbrMetallicRoughness.baseColorTexture.index, 0);
  std::size_t verts = 0;
  for (auto& mesh : m.meshes) {
    const auto& p = mesh.primitives.at(0);
    EXPECT_EQ(p.attributes.count("COLOR_0"), 0u);  // textured: no vertex colours
    EXPECT_EQ(p.attributes.count("TEXCOORD_0"), 1u);
    EXPECT_EQ(p.attributes.count("NORMAL"), 1u);
    const auto pos = accessor_data<float>(m, p.attributes.at("POSITION"));
    verts += pos.size() / 3;
    EXPECT_EQ(m.accessors[std::size_t(p.indices)].componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
  }
  EXPECT_EQ(verts, 2u * 17 * 17);
  EXPECT_EQ(encode_glb(t, o).base, g.base);  // deterministic
  // The embedded image is the albedo PNG.
  const auto& img = m.images[0];
  const auto& view = m.bufferViews[std::size_t(img.bufferView)];
  const std::string png(reinterpret_cast<const char*>(m.buffers[0].data.data() + view.byteOffset), view.byteLength);
  EXPECT_EQ(png, encode_png_rgb8(t.get("albedo"), 33, 17));
}

TEST(Glb, Uint32IndicesOnlyWhenAChunkNeedsThem) {
  Terrain t = terrain(257, 257, 1.0);
  t.layers.erase("albedo");
  ExportOptions o;
  o.chunk_quads = 254;  // 255² = 65025 vertices: uint16
  tinygltf::Model a = load_glb(encode_glb(t, o).base);
  EXPECT_EQ(a.accessors[std::size_t(a.meshes[0].primitives[0].indices)].componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
  o.chunk_quads = 256;  // 257² = 66049 vertices: uint32
  tinygltf::Model b = load_glb(encode_glb(t, o).base);
  ASSERT_EQ(b.meshes.size(), 1u);
  const auto& acc = b.accessors[std::size_t(b.meshes[0].primitives[0].indices)];
  EXPECT_EQ(acc.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
  const auto idx = accessor_data<std::uint32_t>(b, b.meshes[0].primitives[0].indices);
  EXPECT_EQ(*std::max_element(idx.begin(), idx.end()), 66048u);
  EXPECT_TRUE(b.textures.empty());  // no albedo layer: untextured
}

TEST(Glb, PropsShareOneMeshPerTypeAcrossNodes) {
  Terrain t = terrain(17, 17);
  add_props(t);
  const tinygltf::Model m = load_glb(encode_glb(t, ExportOptions{}).base);
  std::map<int, int> uses;
  int props = 0;
  for (auto& n : m.nodes) {
    if (n.mesh < 0 || n.name.rfind("terrain", 0) == 0) continue;
    ++props;
    ++uses[n.mesh];
  }
  EXPECT_EQ(props, 8);
  EXPECT_EQ(uses.size(), 6u);  // six types
  EXPECT_EQ(m.meshes.size(), 1u + 6u);
  // tree_1 is the second tree: point 3.
  int found = 0;
  for (auto& n : m.nodes)
    if (n.name == "tree_1") {
      ++found;
      const Point& p = t.points[3];
      ASSERT_EQ(n.translation.size(), 3u);
      EXPECT_DOUBLE_EQ(n.translation[0], p.x_m);
      EXPECT_DOUBLE_EQ(n.translation[1], p.y_m);
      EXPECT_DOUBLE_EQ(n.translation[2], p.z_m);
      EXPECT_NEAR(n.rotation[1], std::sin(p.rotation_deg * M_PI / 360), 1e-12);
      EXPECT_NEAR(n.rotation[3], std::cos(p.rotation_deg * M_PI / 360), 1e-12);
      EXPECT_DOUBLE_EQ(n.scale[0], p.scale);
    }
  EXPECT_EQ(found, 1);
  EXPECT_TRUE(m.extensionsUsed.empty());
}

TEST(Glb, GpuInstancingAccessorsMatchTheProps) {
  Terrain t = terrain(17, 17);
  add_props(t);
  ExportOptions o;
  o.instancing = Instancing::Gpu;
  const tinygltf::Model m = load_glb(encode_glb(t, o).base);
  EXPECT_EQ(m.extensionsUsed, std::vector<std::string>{"EXT_mesh_gpu_instancing"});
  EXPECT_TRUE(m.extensionsRequired.empty());  // viewers without it still show the terrain
  int nodes = 0;
  std::size_t instances = 0;
  for (auto& n : m.nodes) {
    auto it = n.extensions.find("EXT_mesh_gpu_instancing");
    if (it == n.extensions.end()) continue;
    ++nodes;
    const std::string type = n.name.substr(0, n.name.find("_instances"));
    EXPECT_EQ(m.meshes[std::size_t(n.mesh)].name, type);
    const auto& attrs = it->second.Get("attributes");
    const auto tr = accessor_data<float>(m, attrs.Get("TRANSLATION").GetNumberAsInt());
    const auto rot = accessor_data<float>(m, attrs.Get("ROTATION").GetNumberAsInt());
    const auto sc = accessor_data<float>(m, attrs.Get("SCALE").GetNumberAsInt());
    EXPECT_EQ(m.accessors[std::size_t(attrs.Get("ROTATION").GetNumberAsInt())].type, TINYGLTF_TYPE_VEC4);
    std::vector<const Point*> mine;
    for (auto& p : t.points)
      if (p.kind == "prop" && p.type == type) mine.push_back(&p);
    ASSERT_EQ(tr.size(), 3 * mine.size());
    ASSERT_EQ(rot.size(), 4 * mine.size());
    ASSERT_EQ(sc.size(), 3 * mine.size());
    for (std::size_t k = 0; k < mine.size(); ++k) {
      EXPECT_FLOAT_EQ(tr[3 * k], float(mine[k]->x_m));
      EXPECT_FLOAT_EQ(tr[3 * k + 2], float(mine[k]->z_m));
      EXPECT_NEAR(std::hypot(std::hypot(rot[4 * k], rot[4 * k + 1]), std::hypot(rot[4 * k + 2], rot[4 * k + 3])), 1.0, 1e-6);
      EXPECT_NEAR(rot[4 * k + 1], std::sin(mine[k]->rotation_deg * M_PI / 360), 1e-6);
      EXPECT_FLOAT_EQ(sc[3 * k + 1], float(mine[k]->scale));
    }
    instances += mine.size();
  }
  EXPECT_EQ(nodes, 6);
  EXPECT_EQ(instances, 8u);
}

TEST(Glb, LodChainAsFilesAndThroughMsftLod) {
  Terrain t = terrain(65, 65);
  add_props(t);
  ExportOptions o;
  o.chunk_quads = 32;
  o.lod_levels = 2;
  o.lod_error_m = 0.3;
  o.lod_msft = true;
  const GlbFiles g = encode_glb(t, o);
  ASSERT_EQ(g.lods.size(), 2u);
  const tinygltf::Model m = load_glb(g.base);
  EXPECT_NE(std::find(m.extensionsUsed.begin(), m.extensionsUsed.end(), "MSFT_lod"), m.extensionsUsed.end());
  auto tris = [&](const tinygltf::Model& mm, int mesh) { return mm.accessors[std::size_t(mm.meshes[std::size_t(mesh)].primitives[0].indices)].count / 3; };
  int with_lod = 0;
  for (auto& n : m.nodes) {
    auto it = n.extensions.find("MSFT_lod");
    if (it == n.extensions.end()) continue;
    ++with_lod;
    const auto& ids = it->second.Get("ids");
    ASSERT_EQ(ids.ArrayLen(), 2u);
    const auto& l1 = m.nodes[std::size_t(ids.Get(0).GetNumberAsInt())];
    const auto& l2 = m.nodes[std::size_t(ids.Get(1).GetNumberAsInt())];
    EXPECT_LT(tris(m, l1.mesh), tris(m, n.mesh));
    EXPECT_LT(tris(m, l2.mesh), tris(m, l1.mesh));
    EXPECT_EQ(n.extras.Get("MSFT_screencoverage").ArrayLen(), 3u);
  }
  EXPECT_EQ(with_lod, 4);
  for (std::size_t k = 0; k < 2; ++k) {
    const tinygltf::Model l = load_glb(g.lods[k]);
    EXPECT_EQ(l.meshes.size(), 4u);  // terrain chunks only
    EXPECT_EQ(l.textures.size(), 1u);
  }
}

TEST(Glb, LowpolyHasVertexColoursAndNoTexture) {
  Terrain t = terrain(17, 17);
  ExportOptions o;
  o.style = MeshStyle::Lowpoly;
  const tinygltf::Model m = load_glb(encode_glb(t, o).base);
  EXPECT_TRUE(m.textures.empty());
  EXPECT_EQ(m.meshes[0].primitives[0].attributes.count("COLOR_0"), 1u);
  EXPECT_EQ(m.meshes[0].primitives[0].attributes.count("TEXCOORD_0"), 0u);
}

// ---- FBX ---------------------------------------------------------------------------------------

TEST(Fbx, StructureUnitsAndSharedPropGeometry) {
  Terrain t = terrain(33, 33);
  add_props(t);
  ExportOptions o;
  o.chunk_quads = 16;
  const std::string bytes = encode_fbx(t, o);
  EXPECT_EQ(bytes, encode_fbx(t, o));  // deterministic
  ASSERT_GT(bytes.size(), 200u);
  std::uint32_t version;
  std::memcpy(&version, bytes.data() + 23, 4);
  EXPECT_EQ(version, 7400u);
  EXPECT_EQ(bytes.substr(bytes.size() - 16), std::string("\xf8\x5a\x8c\x6a\xde\xf5\xd9\x7e\xec\xe9\x0c\xe3\x75\x8f\x29\x0b", 16));
  EXPECT_EQ((bytes.size() - 16 - 120 - 4) % 16, 0u);  // footer padding aligns the version to 16
  bool ok = false;
  const auto top = parse_fbx(bytes, &ok);
  ASSERT_TRUE(ok);
  const FbxNode* gs = top_node(top, "GlobalSettings");
  ASSERT_TRUE(gs);
  EXPECT_EQ(p70_number(*gs->child("Properties70"), "UnitScaleFactor"), 100.0);
  EXPECT_EQ(p70_number(*gs->child("Properties70"), "UpAxis"), 1.0);
  ASSERT_TRUE(top_node(top, "CreationTime"));
  EXPECT_EQ(top_node(top, "CreationTime")->props[0].s, "1970-01-01 10:00:00:000");
  const FbxNode* objects = top_node(top, "Objects");
  ASSERT_TRUE(objects);
  std::map<std::int64_t, const FbxNode*> by_id;
  int geometries = 0, models = 0, videos = 0;
  std::size_t terrain_vertices = 0;
  for (auto& n : objects->children) {
    by_id[n.props[0].i] = &n;
    if (n.name == "Geometry") {
      ++geometries;
      const auto& v = n.child("Vertices")->props[0].f64s;
      const auto& pvi = n.child("PolygonVertexIndex")->props[0].i32s;
      EXPECT_EQ(pvi.size() % 3, 0u);
      for (std::size_t k = 2; k < pvi.size(); k += 3) EXPECT_LT(pvi[k], 0);  // every third closes a triangle
      EXPECT_EQ(n.child("LayerElementNormal")->child("Normals")->props[0].f64s.size(), v.size());
      if (n.props[1].s.rfind("terrain", 0) == 0) {
        terrain_vertices += v.size() / 3;
        const auto& uv = n.child("LayerElementUV")->child("UV")->props[0].f64s;
        EXPECT_EQ(uv.size(), v.size() / 3 * 2);
      } else {
        EXPECT_TRUE(n.child("LayerElementColor"));
      }
    }
    if (n.name == "Model") ++models;
    if (n.name == "Video") {
      ++videos;
      EXPECT_EQ(n.child("Content")->props[0].s, encode_png_rgb8(t.get("albedo"), 33, 33));
    }
  }
  EXPECT_EQ(geometries, 4 + 6);  // 2×2 chunks + one geometry per prop type
  EXPECT_EQ(models, 2 + 4 + 8);  // terrain and props groups, chunks, one model per prop
  EXPECT_EQ(videos, 1);
  EXPECT_EQ(terrain_vertices, 4u * 17 * 17);
  // The three trees' models connect to one shared geometry.
  std::map<std::int64_t, std::set<std::int64_t>> geom_of_type;
  for (auto& c : top_node(top, "Connections")->children) {
    auto child = by_id.find(c.props[1].i), parent = by_id.find(c.props[2].i);
    if (child == by_id.end() || parent == by_id.end()) continue;
    if (child->second->name == "Geometry" && parent->second->props[1].s.rfind("tree_", 0) == 0)
      geom_of_type[0].insert(child->first);
  }
  EXPECT_EQ(geom_of_type[0].size(), 1u);
}

// ---- STL ---------------------------------------------------------------------------------------

TEST(Stl, IsAClosedOutwardSolidOfTheRequestedSize) {
  Terrain t = terrain(33, 17, 10.0);  // 320 m × 160 m
  ExportOptions o;
  o.stl_size_mm = 120;
  o.stl_exaggeration = 3;
  o.stl_base_mm = 4;
  const std::string bytes = encode_stl(t, o);
  EXPECT_NE(bytes.compare(0, 5, "solid"), 0);
  const Stl s = parse_stl(bytes);
  EXPECT_EQ(s.tris.size(), 2u * 32 * 16 + 3u * (2 * 32 + 2 * 16));
  const Closedness c = check_closed(s);
  EXPECT_EQ(c.bad_edges, 0u);
  EXPECT_EQ(c.bad_normals, 0u);
  EXPECT_GT(c.volume, 0);
  float lo[3] = {1e9f, 1e9f, 1e9f}, hi[3] = {-1e9f, -1e9f, -1e9f};
  for (auto& tr : s.tris)
    for (int v = 0; v < 3; ++v)
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], tr[3 + 3 * v + a]), hi[a] = std::max(hi[a], tr[3 + 3 * v + a]);
  EXPECT_FLOAT_EQ(lo[0], 0);
  EXPECT_FLOAT_EQ(hi[0], 120);
  EXPECT_FLOAT_EQ(hi[1], 60);
  EXPECT_FLOAT_EQ(lo[2], 0);
  const auto& h = t.get("height").data;
  const double emin = *std::min_element(h.begin(), h.end()), emax = *std::max_element(h.begin(), h.end());
  EXPECT_NEAR(hi[2], 4 + (emax - emin) * 300 * 3 * (120.0 / 320.0), 1e-3);
  // Volume: base slab plus the relief above it, within the discretisation of the surface.
  EXPECT_GT(c.volume, 120.0 * 60 * 4);
}

TEST(Stl, StaysClosedWithVertexJiggleAndKeepsStraightSides) {
  Terrain t = terrain(17, 17, 10.0);
  add_offset(t, 3.0);
  const Stl s = parse_stl(encode_stl(t, ExportOptions{}));
  const Closedness c = check_closed(s);
  EXPECT_EQ(c.bad_edges, 0u);
  EXPECT_EQ(c.bad_normals, 0u);
  EXPECT_GT(c.volume, 0);
  for (auto& tr : s.tris)
    for (int v = 0; v < 3; ++v)
      if (tr[3 + 3 * v + 2] == 0.0f && !(tr[3 + 3 * v] == 75.0f && tr[3 + 3 * v + 1] == 75.0f)) {  // bottom, not the centre
        const float x = tr[3 + 3 * v], y = tr[3 + 3 * v + 1];
        EXPECT_TRUE(x == 0 || x == 150.0f || y == 0 || y == 150.0f) << x << " " << y;
      }
}

// ---- engine profiles ---------------------------------------------------------------------------

TEST(Engine, LegalSizes) {
  EXPECT_EQ(engine_legal_size(Engine::Unity, 1000, 1), 1025);
  EXPECT_EQ(engine_legal_size(Engine::Unity, 5000, 1), 4097);
  EXPECT_EQ(engine_legal_size(Engine::Unreal, 1025, 1), 1009);
  EXPECT_EQ(engine_legal_size(Engine::Unreal, 2017, 4), 2020);  // 4 tiles of 505, edge to edge (no shared sample)
  EXPECT_EQ(engine_legal_size(Engine::Unity, 1025, 4), 1025);   // 4 tiles of 257
  EXPECT_EQ(engine_legal_size(Engine::Godot, 600, 1), 513);
  ExportOptions o;
  o.engine = Engine::Unreal;
  EXPECT_NO_THROW(check_engine_size(o, 1009, 1009));
  try {
    check_engine_size(o, 1025, 1025);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "export.engine");  // the library names the recipe's field by default
    EXPECT_NE(std::string(e.what()).find("1009x1009"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("(use world.size)"), std::string::npos);
  }
  try {
    check_engine_size(o, 1025, 1025, [](const std::string& n) { return "--" + n; }, "--size");  // as the CLI names its flags
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "--engine");
    EXPECT_NE(std::string(e.what()).find("(use --size)"), std::string::npos);
  }
  o.split = "2x2";
  EXPECT_NO_THROW(check_engine_size(o, 1010, 1010));  // tiles of 505, edge to edge
  EXPECT_THROW(check_engine_size(o, 1009, 1009), Error);  // the overlapping layout is not Unreal's
  EXPECT_THROW(check_engine_size(o, 1010, 505), Error);
  o.engine = Engine::Unity;  // Unity (and Godot) tiles share their border sample
  EXPECT_NO_THROW(check_engine_size(o, 513, 513));  // tiles of 257
  EXPECT_THROW(check_engine_size(o, 514, 514), Error);
}

namespace {
// The asymmetric fixture: 33×33 with distinct values per sample.
Terrain engine_fixture() {
  Terrain t = terrain(33, 33, 4.0);
  auto& h = t.get("height").data;
  for (int j = 0; j < 33; ++j)
    for (int i = 0; i < 33; ++i) h[std::size_t(j) * 33 + i] = float(i + 40 * j) / 2000.0f;
  return t;
}
MemoryOutput engine_files(const Terrain& t, const std::string& engine, const std::string& split = "1x1",
                          const std::string& godot = "exr") {
  WriteContext ctx;
  set_export_option(ctx.options, "engine", engine, "engine");  // the strings, through the table
  ctx.options.split = split;
  set_export_option(ctx.options, "godot_format", godot, "godot_format");
  MemoryOutput out;
  find_writer("engine")->write(t, ctx, out);
  return out;
}
}  // namespace

TEST(Engine, UnityRawIsLittleEndianWithRowsFlipped) {
  const Terrain t = engine_fixture();
  const MemoryOutput out = engine_files(t, "unity");
  ASSERT_EQ(out.files.count("unity_height.raw"), 1u);
  const std::string& raw = out.files.at("unity_height.raw");
  ASSERT_EQ(raw.size(), 33u * 33 * 2);
  const auto& h = t.get("height").data;
  for (int r = 0; r < 33; ++r)
    for (int i = 0; i < 33; ++i) {
      const std::size_t k = std::size_t(r) * 33 + i;
      const std::uint16_t v = std::uint16_t(std::uint8_t(raw[2 * k]) | (std::uint8_t(raw[2 * k + 1]) << 8));
      EXPECT_EQ(v, u16(h[std::size_t(32 - r) * 33 + i])) << r << " " << i;  // file row 0 = our z-max row
    }
  const json s = json::parse(out.files.at("unity_height.json"));
  EXPECT_EQ(s["rows_flipped"], true);
  EXPECT_EQ(s["unity"]["heightmap_resolution"], 33);
  EXPECT_DOUBLE_EQ(s["unity"]["terrain_height"].get<double>(), 300.0);
  EXPECT_DOUBLE_EQ(s["unity"]["terrain_width"].get<double>(), 128.0);
  EXPECT_DOUBLE_EQ(s["tiles"][0]["unity_position"][1].get<double>(), -90.0);  // y of elevation 0: sea at 0
  EXPECT_NE(out.files.at("unity_import.txt").find("Flip Vertically: off"), std::string::npos);
}

TEST(Engine, UnrealPngIsSixteenBitUnflippedWithZScale) {
  Terrain t = engine_fixture();
  // Unreal needs 127, 253 …: use 127² with the same asymmetric pattern.
  t = terrain(127, 127, 4.0);
  auto& h = t.get("height").data;
  for (std::size_t k = 0; k < h.size(); ++k) h[k] = float(k % 127 + 3 * (k / 127)) / 600.0f;
  const MemoryOutput out = engine_files(t, "unreal");
  const test::Png d = decode_png(out.files.at("unreal_height.png"));
  EXPECT_EQ(d.ihdr.width, 127u);
  EXPECT_EQ(d.ihdr.height, 127u);
  EXPECT_EQ(d.ihdr.bit_depth, 16);
  EXPECT_EQ(d.ihdr.color_type, SPNG_COLOR_TYPE_GRAYSCALE);
  for (std::size_t k = 0; k < h.size(); k += 37) EXPECT_EQ(u16_at(d, k), u16(h[k])) << k;  // no flip
  const json s = json::parse(out.files.at("unreal_height.json"));
  EXPECT_EQ(s["rows_flipped"], false);
  const double z = s["unreal"]["scale_cm"][2].get<double>();
  // 65535 steps of z/128 cm cover the 300 m between elevation 0 and 1.
  EXPECT_NEAR(65535 * z / 128, 300 * 100, 1e-6);
  // Location Z puts value 0 at −90 m: z_cm(v) = loc + (v − 32768)·Z/128.
  EXPECT_NEAR(s["unreal"]["location_z_cm"].get<double>() + (0 - 32768) * z / 128, -9000, 1e-6);
}

TEST(Engine, GodotExrHoldsMetresUnflipped) {
  const Terrain t = engine_fixture();
  const MemoryOutput out = engine_files(t, "godot");
  const std::string path = (fs::temp_directory_path() / ("relief_godot_" + std::to_string(::getpid()) + ".exr")).string();
  {
    std::ofstream f(path, std::ios::binary);
    f << out.files.at("godot_height.exr");
  }
  Imf::InputFile in(path.c_str());
  const auto dw = in.header().dataWindow();
  const int w = dw.max.x - dw.min.x + 1, hgt = dw.max.y - dw.min.y + 1;
  ASSERT_EQ(w, 33);
  ASSERT_EQ(hgt, 33);
  EXPECT_EQ(in.header().channels().findChannel("Y")->type, Imf::FLOAT);
  std::vector<float> px(33 * 33);
  Imf::FrameBuffer fb;
  fb.insert("Y", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(px.data()), sizeof(float), sizeof(float) * 33));
  in.setFrameBuffer(fb);
  in.readPixels(dw.min.y, dw.max.y);
  fs::remove(path);
  const auto& h = t.get("height").data;
  for (std::size_t k = 0; k < px.size(); ++k) EXPECT_FLOAT_EQ(px[k], float(t.frame.y_m(h[k]))) << k;
  EXPECT_EQ(json::parse(out.files.at("godot_height.json"))["godot"]["vertical_scale"], 1.0);
  // r16 alternative: little-endian normalised values, not flipped.
  const MemoryOutput r = engine_files(t, "godot", "1x1", "r16");
  const std::string& raw = r.files.at("godot_height.r16");
  ASSERT_EQ(raw.size(), 33u * 33 * 2);
  EXPECT_EQ(std::uint16_t(std::uint8_t(raw[2 * 40]) | (std::uint8_t(raw[2 * 40 + 1]) << 8)), u16(h[40]));
}

TEST(Engine, SplitTilesOverlapByOneSampleAndJoinWithoutSeams) {
  Terrain t = terrain(65, 65, 4.0);  // unity 2×2 tiles of 33
  const MemoryOutput out = engine_files(t, "unity", "2x2");
  for (const char* n : {"unity_height_x0_y0.raw", "unity_height_x1_y0.raw", "unity_height_x0_y1.raw", "unity_height_x1_y1.raw"})
    ASSERT_EQ(out.files.count(n), 1u) << n;
  auto sample = [&](int tx, int ty, int col, int row) {
    const std::string& raw = out.files.at("unity_height_x" + std::to_string(tx) + "_y" + std::to_string(ty) + ".raw");
    const std::size_t k = std::size_t(row) * 33 + col;
    return std::uint16_t(std::uint8_t(raw[2 * k]) | (std::uint8_t(raw[2 * k + 1]) << 8));
  };
  const auto& h = t.get("height").data;
  // Reassemble the whole map from the tiles (Unity rows are flipped within each tile).
  for (int j = 0; j < 65; ++j)
    for (int i = 0; i < 65; ++i) {
      const int tx = std::min(i / 32, 1), ty = std::min(j / 32, 1);
      ASSERT_EQ(sample(tx, ty, i - 32 * tx, 32 - (j - 32 * ty)), u16(h[std::size_t(j) * 65 + i])) << i << " " << j;
    }
  // Shared borders are identical: last column of x0 = first column of x1.
  for (int r = 0; r < 33; ++r) EXPECT_EQ(sample(0, 0, 32, r), sample(1, 0, 0, r));
  const json s = json::parse(out.files.at("unity_height.json"));
  EXPECT_EQ(s["tiles"].size(), 4u);
  EXPECT_EQ(s["overlap_samples"], 1);
  EXPECT_DOUBLE_EQ(s["tiles"][1]["x0_m"].get<double>(), 128.0);
  // The terrain group: Unity +z is our -z, so tile y0 is the top neighbour of tile y1.
  EXPECT_EQ(s["tiles"][2]["neighbors"]["top"], "unity_height_x0_y0.raw");
  EXPECT_EQ(s["tiles"][2]["neighbors"]["right"], "unity_height_x1_y1.raw");
  EXPECT_TRUE(s["tiles"][2]["neighbors"]["bottom"].is_null());
  EXPECT_TRUE(s["tiles"][2]["neighbors"]["left"].is_null());
  EXPECT_DOUBLE_EQ(s["tiles"][2]["unity_position"][2].get<double>(), -256.0);  // Unity z of our z-max edge
}

// Unreal's tiled import copies tile (X, Y) to X·width, Y·height with no shared row, so Unreal tiles
// abut: 2×2 tiles of 127 hold a 254² map, each sample exactly once.
TEST(Engine, UnrealSplitTilesAbutWithoutSharedSamples) {
  Terrain t = terrain(254, 254, 4.0);
  auto& h = t.get("height").data;
  for (std::size_t k = 0; k < h.size(); ++k) h[k] = float(k % 254 + 7 * (k / 254)) / 2200.0f;
  const MemoryOutput out = engine_files(t, "unreal", "2x2");
  std::vector<test::Png> tiles;
  for (int ty = 0; ty < 2; ++ty)
    for (int tx = 0; tx < 2; ++tx) {
      const std::string n = "unreal_height_x" + std::to_string(tx) + "_y" + std::to_string(ty) + ".png";
      ASSERT_EQ(out.files.count(n), 1u) << n;
      tiles.push_back(decode_png(out.files.at(n)));
      ASSERT_EQ(tiles.back().ihdr.width, 127u);
    }
  // Unreal's placement: tile (X, Y) at (127·X, 127·Y).
  for (int j = 0; j < 254; ++j)
    for (int i = 0; i < 254; ++i) {
      const test::Png& p = tiles[std::size_t(j / 127) * 2 + std::size_t(i / 127)];
      ASSERT_EQ(u16_at(p, std::size_t(j % 127) * 127 + std::size_t(i % 127)), u16(h[std::size_t(j) * 254 + i])) << i << " " << j;
    }
  const json s = json::parse(out.files.at("unreal_height.json"));
  EXPECT_EQ(s["overlap_samples"], 0);
  EXPECT_DOUBLE_EQ(s["tiles"][1]["x0_m"].get<double>(), 127 * 4.0);
  EXPECT_EQ(s["unreal"]["landscape_samples"][0], 254);
  // The overlapping layout (253 = 2·126 + 1) is refused for Unreal.
  EXPECT_THROW(engine_files(terrain(253, 253, 4.0), "unreal", "2x2"), Error);
}

// ---- maps ----------------------------------------------------------------------------------------

TEST(Maps, NormalMapOfATiltedPlaneInBothConventions) {
  Terrain t = terrain(9, 9, 10.0);
  auto& h = t.get("height").data;
  for (int j = 0; j < 9; ++j)
    for (int i = 0; i < 9; ++i) h[std::size_t(j) * 9 + i] = float(0.3 + 0.01 * i - 0.02 * j);  // rises east, falls south
  const double len = std::sqrt(0.09 + 1 + 0.36);
  const double n[3] = {-0.3 / len, 1 / len, 0.6 / len};
  const test::Png gl = decode_png(encode_normal_map(t, 8, false));
  const test::Png dx = decode_png(encode_normal_map(t, 8, true));
  ASSERT_EQ(gl.bytes.size(), 81u * 3);
  for (std::size_t k = 0; k < 81; ++k) {
    EXPECT_EQ(gl.bytes[3 * k], std::lround((n[0] + 1) / 2 * 255));
    EXPECT_EQ(gl.bytes[3 * k + 1], std::lround((-n[2] + 1) / 2 * 255));  // OpenGL: green = towards row 0 (−z)
    EXPECT_EQ(dx.bytes[3 * k + 1], std::lround((n[2] + 1) / 2 * 255));   // DirectX: inverted
    EXPECT_EQ(gl.bytes[3 * k + 2], std::lround((n[1] + 1) / 2 * 255));
  }
  // The surface falls towards +z (south, the image bottom): its normal leans towards the image
  // bottom, so OpenGL green is below 128.
  EXPECT_LT(gl.bytes[1], 128);
  const test::Png g16 = decode_png(encode_normal_map(t, 16, false));
  EXPECT_EQ(g16.ihdr.bit_depth, 16);
  EXPECT_EQ(u16_at(g16, 0), std::lround((n[0] + 1) / 2 * 65535));
}

TEST(Maps, SplatRulesWeightsSumTo255AndFollowHeightAndSlope) {
  Terrain t = terrain(33, 33, 10.0);
  auto& h = t.get("height").data;
  for (int j = 0; j < 33; ++j)
    for (int i = 0; i < 33; ++i) {
      double e = 0.29;                 // below the sea: sand
      if (i >= 8) e = 0.5;             // flat land: grass
      if (i >= 16) e = 0.5 + 0.1 * (i - 16);  // 30 m per 10 m cell: rock
      if (i >= 26) e = 0.95;           // high plateau: snow
      h[std::size_t(j) * 33 + i] = float(std::min(e, 0.95));
    }
  ExportOptions o;
  o.splat_rock_elevation = 1.0;  // rock from slope only here
  const SplatMaps s = encode_splat(t, o);
  ASSERT_EQ(s.images.size(), 1u);
  const test::Png d = decode_png(s.images[0]);
  EXPECT_EQ(d.ihdr.color_type, SPNG_COLOR_TYPE_TRUECOLOR_ALPHA);
  for (std::size_t k = 0; k < 33 * 33; ++k)
    EXPECT_EQ(d.bytes[4 * k] + d.bytes[4 * k + 1] + d.bytes[4 * k + 2] + d.bytes[4 * k + 3], 255) << k;
  auto at = [&](int i, int c) { return d.bytes[(std::size_t(16) * 33 + i) * 4 + c]; };
  EXPECT_EQ(at(3, 0), 255);   // sand
  EXPECT_EQ(at(12, 1), 255);  // grass
  EXPECT_EQ(at(20, 2), 255);  // rock
  EXPECT_EQ(at(30, 3), 255);  // snow
  EXPECT_EQ(s.description["channels"][2]["layer"], "rock");
  // High flat ground below the snow line is rock by elevation.
  o.splat_rock_elevation = 0.9;
  o.splat_snow_elevation = 0.99;
  const test::Png high = decode_png(encode_splat(t, o).images[0]);
  EXPECT_EQ(high.bytes[(std::size_t(16) * 33 + 30) * 4 + 2], 255);
}

TEST(Maps, SplatFromTheBiomeLayerSpansSeveralImages) {
  Terrain t = terrain(30, 10);
  Layer& b = t.layer("biome", 1);
  b.data.resize(t.frame.count());
  for (int j = 0; j < 10; ++j)
    for (int i = 0; i < 30; ++i) b.data[std::size_t(j) * 30 + i] = float(i / 5);  // ids 0..5 in vertical bands
  const SplatMaps s = encode_splat(t, ExportOptions{});
  ASSERT_EQ(s.images.size(), 2u);
  EXPECT_EQ(s.description["source"], "biome");
  const test::Png a = decode_png(s.images[0]), c = decode_png(s.images[1]);
  for (std::size_t k = 0; k < 300; ++k) {
    int sum = 0;
    for (int ch = 0; ch < 4; ++ch) sum += a.bytes[4 * k + ch] + c.bytes[4 * k + ch];
    EXPECT_EQ(sum, 255) << k;
    EXPECT_EQ(c.bytes[4 * k + 2] + c.bytes[4 * k + 3], 0);  // padding channels stay empty
  }
  EXPECT_EQ(a.bytes[(5 * 30 + 12) * 4 + 2], 255);  // band 2, inside
  EXPECT_EQ(c.bytes[(5 * 30 + 27) * 4 + 1], 255);  // band 5 → image 1, green
  // On a border the two neighbours share the weight (3×3 window: 3 and 6 of 9).
  EXPECT_EQ(a.bytes[(5 * 30 + 4) * 4 + 0], 170);
  EXPECT_EQ(a.bytes[(5 * 30 + 4) * 4 + 1], 85);
  ExportOptions rules;
  rules.splat_source = SplatSource::Rules;
  EXPECT_EQ(encode_splat(t, rules).images.size(), 1u);
  t.layers.erase("biome");
  ExportOptions biome;
  biome.splat_source = SplatSource::Biome;
  EXPECT_THROW(encode_splat(t, biome), Error);
  // The error names the option as the caller says the user gave it (recipe path by default).
  auto path_of = [&](const OptionPath& f) {
    try {
      encode_splat(t, biome, f);
    } catch (const Error& e) {
      EXPECT_EQ(e.message(), "\"biome\" needs a 'biome' layer in the terrain");
      return e.path();
    }
    return std::string("no error");
  };
  EXPECT_EQ(path_of({}), "export.splat_source");
  EXPECT_EQ(path_of([](const std::string& n) { return n == "splat_source" ? "--splat-source" : "?"; }), "--splat-source");
}

// One hillshade (src/surface.hpp): the writer's greyscale is the hillshade stage's shade without
// ambient light and with the sea shaded like the land, rounded to 8 bits — not a second
// implementation (it was a double-precision one, which differed in the last bit of a few pixels).
TEST(Maps, HillshadeWriterIsTheHillshadeStageWithoutAmbient) {
  // Enough samples that the old double-precision writer hit a rounding boundary somewhere.
  Terrain t = terrain(513, 385, 10.0);
  auto& h = t.get("height").data;
  for (std::size_t k = 0; k < h.size(); ++k) h[k] = float(0.2 + 0.6 * unit_double(hash64(99, k)));  // rough, sea and land
  const StageDef* def = find_stage("hillshade");
  ASSERT_NE(def, nullptr);
  const json p = {{"azimuth_deg", 300.0}, {"altitude_deg", 35.0}, {"ambient", 0.0}, {"water_relief", 1.0}};
  Terrain shaded = t;
  def->parse(p, "stages[0]")->apply(shaded, Context{});
  const auto& shade = shaded.get("shade").data;
  const relief::test::Png d = relief::test::decode_png(encode_hillshade(t, 300.0, 35.0));
  ASSERT_EQ(d.bytes.size(), shade.size());
  std::size_t differ = 0;
  for (std::size_t k = 0; k < shade.size(); ++k)
    differ += d.bytes[k] != std::uint8_t(std::lround(std::clamp(double(shade[k]), 0.0, 1.0) * 255));
  EXPECT_EQ(differ, 0u);
}

TEST(Maps, HillshadeIsBrightOnSlopesFacingTheLight) {
  Terrain t = terrain(21, 21, 10.0);
  auto& h = t.get("height").data;
  for (int j = 0; j < 21; ++j)
    for (int i = 0; i < 21; ++i) h[std::size_t(j) * 21 + i] = float(0.5 - 0.02 * std::abs(i - 10));  // a ridge along z
  const test::Png d = decode_png(encode_hillshade(t, 270, 45));                          // light from the west
  EXPECT_EQ(d.ihdr.bit_depth, 8);
  const int west = d.bytes[10 * 21 + 5], east = d.bytes[10 * 21 + 15];
  EXPECT_GT(west, east + 60);
  const test::Png flat_light = decode_png(encode_hillshade(t, 0, 90));  // overhead: both sides equal
  EXPECT_EQ(flat_light.bytes[10 * 21 + 5], flat_light.bytes[10 * 21 + 15]);
}
