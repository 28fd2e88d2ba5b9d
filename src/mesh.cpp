// Terrain meshes (chunked grid, vertex jiggle, simplification, LOD, low-poly style) and the
// low-poly prop models.
//
// LOD level k (1…) is simplified from level k − 1 with an error bound of lod_error_m·2^(k−1) and
// a floor of 1/4^k of the grid's triangles; errors of successive levels add up (at most
// lod_error_m·(2^k − 1) from the grid).
// Simplification and LOD use meshoptimizer's edge-collapse simplifier (Garland & Heckbert,
// "Surface Simplification Using Quadric Error Metrics", SIGGRAPH 1997, as implemented by
// meshopt_simplify) with meshopt_SimplifyLockBorder so that chunk borders stay identical on both
// sides; vertex order is then optimised for the GPU's post-transform cache (Forsyth / Tom
// Forsyth's "Linear-Speed Vertex Cache Optimisation", via meshopt_optimizeVertexCache).
// meshoptimizer measures errors relative to the mesh extent: an error in metres is divided by
// meshopt_simplifyScale before the call.
#include <meshoptimizer.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "relief/error.hpp"
#include "relief/export.hpp"
#include "relief/random.hpp"
#include "surface.hpp"

namespace relief {
namespace {

const Layer& checked_height(const Terrain& t) {
  auto it = t.layers.find("height");
  if (it == t.layers.end()) throw Error("formats", "meshes need a 'height' layer (no elevation stage in the recipe?)");
  const Layer& h = it->second;
  const Frame& f = t.frame;
  if (f.nx < 2 || f.nz < 2)
    throw Error("height", "a mesh needs at least 2x2 samples, got " + std::to_string(f.nx) + "x" + std::to_string(f.nz));
  if (h.channels != 1 || h.data.size() != f.count())
    throw Error("height", "layer has " + std::to_string(h.data.size()) + " values in " + std::to_string(h.channels) +
                              " channel(s), expected " + std::to_string(f.count()) + " in 1");
  for (std::size_t k = 0; k < h.data.size(); ++k)
    if (!std::isfinite(h.data[k]))
      throw Error("height", "non-finite elevation at sample (" + std::to_string(k % f.nx) + ", " + std::to_string(k / f.nx) + ")");
  return h;
}

const Layer* checked_offset(const Terrain& t) {
  auto it = t.layers.find("offset");
  if (it == t.layers.end()) return nullptr;
  const Layer& o = it->second;
  if (o.channels != 2 || o.data.size() != t.frame.count() * 2)
    throw Error("offset", "layer must have 2 channels (dx_m, dz_m) and " + std::to_string(t.frame.count()) + " samples");
  for (float v : o.data)
    if (!std::isfinite(v)) throw Error("offset", "non-finite vertex offset");
  return &o;
}

const Layer* colour_source(const Terrain& t) {
  for (const char* n : {"albedo", "color"}) {
    auto it = t.layers.find(n);
    if (it != t.layers.end() && it->second.channels == 3 && it->second.data.size() == t.frame.count() * 3) return &it->second;
  }
  return nullptr;
}

// Removes unused vertices and orders them for the vertex cache (after simplification).
void compact(MeshData& m) {
  const std::size_t nv = m.vertex_count();
  meshopt_optimizeVertexCache(m.indices.data(), m.indices.data(), m.indices.size(), nv);
  std::vector<unsigned int> remap(nv);
  const std::size_t unique = meshopt_optimizeVertexFetchRemap(remap.data(), m.indices.data(), m.indices.size(), nv);
  meshopt_remapIndexBuffer(m.indices.data(), m.indices.data(), m.indices.size(), remap.data());
  auto stream = [&](std::vector<float>& v, std::size_t comps) {
    if (v.empty()) return;
    std::vector<float> out(unique * comps);
    meshopt_remapVertexBuffer(out.data(), v.data(), nv, comps * sizeof(float), remap.data());
    v = std::move(out);
  };
  stream(m.positions, 3);
  stream(m.normals, 3);
  stream(m.uvs, 2);
  stream(m.colors, 3);
}

// Every triangle gets its own three vertices with the face normal and the colour at its centre.
void unweld_flat(MeshData& m, const Terrain& t, const Layer* colour) {
  MeshData out;
  const std::size_t nt = m.triangle_count();
  out.positions.reserve(nt * 9);
  out.normals.reserve(nt * 9);
  out.uvs.reserve(nt * 6);
  if (colour) out.colors.reserve(nt * 9);
  const int nx = t.frame.nx, nz = t.frame.nz;
  for (std::size_t k = 0; k < nt; ++k) {
    const std::uint32_t* tri = &m.indices[3 * k];
    const float* p[3] = {&m.positions[3 * tri[0]], &m.positions[3 * tri[1]], &m.positions[3 * tri[2]]};
    double n[3] = {0, 1, 0};  // up for a degenerate triangle
    detail::face_normal(p[0], p[1], p[2], n);
    float rgb[3] = {1, 1, 1};
    if (colour) {
      // Colour of the nearest sample to the triangle's centre in uv space.
      double u = 0, v = 0;
      for (int c = 0; c < 3; ++c) u += m.uvs[2 * tri[c]], v += m.uvs[2 * tri[c] + 1];
      const int i = std::clamp(int(std::lround(u / 3 * (nx - 1))), 0, nx - 1);
      const int j = std::clamp(int(std::lround(v / 3 * (nz - 1))), 0, nz - 1);
      const float* s = &colour->data[(std::size_t(j) * nx + i) * 3];
      for (int c = 0; c < 3; ++c) rgb[c] = std::clamp(s[c], 0.0f, 1.0f);
    }
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t vi = tri[c];
      out.positions.insert(out.positions.end(), p[c], p[c] + 3);
      out.normals.push_back(float(n[0]));
      out.normals.push_back(float(n[1]));
      out.normals.push_back(float(n[2]));
      out.uvs.push_back(m.uvs[2 * vi]);
      out.uvs.push_back(m.uvs[2 * vi + 1]);
      if (colour) out.colors.insert(out.colors.end(), rgb, rgb + 3);
      out.indices.push_back(std::uint32_t(3 * k + c));
    }
  }
  m = std::move(out);
}

}  // namespace

namespace {

// The grid mesh of one chunk: samples [i0, i1] × [j0, j1].
MeshData grid_chunk(const Terrain& t, const Layer& h, const Layer* off, int i0, int j0, int i1, int j1) {
  const Frame& f = t.frame;
  const int nx = f.nx, nz = f.nz;
  auto Y = [&](int i, int j) { return f.y_m(h.data[std::size_t(j) * nx + i]); };
  const int w = i1 - i0 + 1, d = j1 - j0 + 1;
  MeshData m;
  m.positions.resize(std::size_t(w) * d * 3);
  m.normals.resize(std::size_t(w) * d * 3);
  m.uvs.resize(std::size_t(w) * d * 2);
  for (int j = j0; j <= j1; ++j) {
    for (int i = i0; i <= i1; ++i) {
      const std::size_t v = std::size_t(j - j0) * w + (i - i0);
      const std::size_t s = std::size_t(j) * nx + i;
      const double dx = off ? off->data[2 * s] : 0.0, dz = off ? off->data[2 * s + 1] : 0.0;
      m.positions[3 * v] = float(f.x_m(i) + dx);
      m.positions[3 * v + 1] = float(Y(i, j));
      m.positions[3 * v + 2] = float(f.z_m(j) + dz);
      // The surface normal (surface.hpp): central differences, one-sided at the border.
      const detail::Normal n = detail::normal_at(f, h, i, j);
      m.normals[3 * v] = float(n.x);
      m.normals[3 * v + 1] = float(n.y);
      m.normals[3 * v + 2] = float(n.z);
      m.uvs[2 * v] = float(double(i) / (nx - 1));
      m.uvs[2 * v + 1] = float(double(j) / (nz - 1));
    }
  }
  m.indices.reserve(std::size_t(w - 1) * (d - 1) * 6);
  for (int j = 0; j + 1 < d; ++j)
    for (int i = 0; i + 1 < w; ++i) {
      const std::uint32_t a = std::uint32_t(j * w + i), b = a + 1, cc = a + std::uint32_t(w), e = cc + 1;
      // (i,j) → (i,j+1) → (i+1,j) is counter-clockwise seen from +Y (x east, z south).
      m.indices.insert(m.indices.end(), {a, cc, b, b, cc, e});
    }
  return m;
}

// Simplifies with locked borders: stops at `target_tris` triangles (0 = no count target) or when
// the next collapse would exceed `error_m` metres (0 = no error limit); then compacts.
void simplify_mesh(MeshData& m, double error_m, std::size_t target_tris) {
  const std::size_t nv = m.vertex_count();
  const float scale = meshopt_simplifyScale(m.positions.data(), nv, 12);
  const float rel = error_m > 0 ? float(error_m / std::max(scale, 1e-30f)) : 1e10f;
  std::vector<std::uint32_t> out(m.indices.size());
  const std::size_t n = meshopt_simplify(out.data(), m.indices.data(), m.indices.size(), m.positions.data(), nv, 12,
                                         std::min(target_tris * 3, m.indices.size()), rel, meshopt_SimplifyLockBorder, nullptr);
  out.resize(n);
  m.indices = std::move(out);
  compact(m);
}

struct ChunkGrid {
  int q, ncx, ncz;
  std::size_t count() const { return std::size_t(ncx) * std::size_t(ncz); }
};
ChunkGrid chunk_grid(const Frame& f, const ExportOptions& o) {
  const int q = o.chunk_quads;
  if (q < 1) throw Error("chunk_quads", "expected at least 1");
  return {q, (f.nx - 1 + q - 1) / q, (f.nz - 1 + q - 1) / q};
}

}  // namespace

std::vector<TerrainChunk> build_terrain_chunks(const Terrain& t, const ExportOptions& o, int lod) {
  if (lod > 0) return build_terrain_lod_chain(t, o, lod).back();
  const Layer& h = checked_height(t);
  const Layer* off = checked_offset(t);
  const Frame& f = t.frame;
  const ChunkGrid g = chunk_grid(f, o);
  const Layer* colour = colour_source(t);
  const double total_tris = 2.0 * double(f.nx - 1) * double(f.nz - 1);
  std::vector<TerrainChunk> chunks(g.count());
  tbb::parallel_for(std::size_t(0), chunks.size(), [&](std::size_t k) {
    TerrainChunk& c = chunks[k];
    c.cx = int(k % std::size_t(g.ncx));
    c.cz = int(k / std::size_t(g.ncx));
    const int i0 = c.cx * g.q, j0 = c.cz * g.q;
    c.mesh = grid_chunk(t, h, off, i0, j0, std::min(i0 + g.q, f.nx - 1), std::min(j0 + g.q, f.nz - 1));
    if (o.simplify_error_m > 0 || o.triangle_budget > 0) {
      const std::size_t target =
          o.triangle_budget > 0 ? std::size_t(std::llround(double(o.triangle_budget) * double(c.mesh.triangle_count()) / total_tris)) : 0;
      simplify_mesh(c.mesh, o.simplify_error_m, target);
    }
    if (o.style == MeshStyle::Lowpoly) unweld_flat(c.mesh, t, colour);
  });
  return chunks;
}

std::vector<std::vector<TerrainChunk>> build_terrain_lod_chain(const Terrain& t, const ExportOptions& o, int levels) {
  const Layer& h = checked_height(t);
  const Layer* off = checked_offset(t);
  const Frame& f = t.frame;
  const ChunkGrid g = chunk_grid(f, o);
  const Layer* colour = colour_source(t);
  std::vector<std::vector<TerrainChunk>> chain(std::size_t(std::max(levels, 0)), std::vector<TerrainChunk>(g.count()));
  tbb::parallel_for(std::size_t(0), g.count(), [&](std::size_t k) {
    const int cx = int(k % std::size_t(g.ncx)), cz = int(k / std::size_t(g.ncx));
    const int i0 = cx * g.q, j0 = cz * g.q;
    MeshData m = grid_chunk(t, h, off, i0, j0, std::min(i0 + g.q, f.nx - 1), std::min(j0 + g.q, f.nz - 1));
    const std::size_t full = m.triangle_count();
    for (int lod = 1; lod <= levels; ++lod) {
      // Each level starts from the previous one (cheaper than from the full grid each time).
      simplify_mesh(m, o.lod_error_m * std::ldexp(1.0, lod - 1), full >> (2 * std::min(lod, 15)));
      TerrainChunk& c = chain[std::size_t(lod - 1)][k];
      c.cx = cx;
      c.cz = cz;
      c.mesh = m;
      if (o.style == MeshStyle::Lowpoly) unweld_flat(c.mesh, t, colour);
    }
  });
  return chain;
}

// ---- props ---------------------------------------------------------------------------------------

namespace {

struct Vec3 {
  double x = 0, y = 0, z = 0;
};
Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 operator*(Vec3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// Flat-shaded builder: each triangle gets its own vertices and face normal. Triangles are oriented
// away from `centre` (the parts are convex), so callers need not care about winding.
struct FlatBuilder {
  MeshData m;
  void tri(Vec3 a, Vec3 b, Vec3 c, Vec3 centre, Vec3 rgb) {
    Vec3 n = cross(b - a, c - a);
    const double len = std::sqrt(dot(n, n));
    if (len < 1e-12) return;
    const Vec3 mid = (a + b + c) * (1.0 / 3.0);
    if (dot(n, mid - centre) < 0) {
      std::swap(b, c);
      n = n * -1.0;
    }
    n = n * (1.0 / len);
    for (Vec3 p : {a, b, c}) {
      const auto idx = std::uint32_t(m.vertex_count());
      m.positions.insert(m.positions.end(), {float(p.x), float(p.y), float(p.z)});
      m.normals.insert(m.normals.end(), {float(n.x), float(n.y), float(n.z)});
      m.colors.insert(m.colors.end(), {float(rgb.x), float(rgb.y), float(rgb.z)});
      m.indices.push_back(idx);
    }
  }
  // Frustum along y from (x, y0, z) radius r0 to y1 radius r1 (r1 = 0: a cone), closed.
  void frustum(Vec3 base, double h, double r0, double r1, int seg, Vec3 rgb, double phase = 0) {
    const Vec3 centre = base + Vec3{0, h * 0.5, 0};
    auto ring = [&](double y, double r, int k) {
      const double a = phase + 2 * M_PI * k / seg;
      return base + Vec3{r * std::cos(a), y, r * std::sin(a)};
    };
    const Vec3 top = base + Vec3{0, h, 0};
    for (int k = 0; k < seg; ++k) {
      const Vec3 a0 = ring(0, r0, k), a1 = ring(0, r0, k + 1);
      tri(base, a0, a1, centre, rgb);  // bottom cap
      if (r1 > 0) {
        const Vec3 b0 = ring(h, r1, k), b1 = ring(h, r1, k + 1);
        tri(a0, a1, b1, centre, rgb);
        tri(a0, b1, b0, centre, rgb);
        tri(top, b0, b1, centre, rgb);  // top cap
      } else {
        tri(a0, a1, top, centre, rgb);
      }
    }
  }
  // Axis-aligned box from lo to hi, closed.
  void box(Vec3 lo, Vec3 hi, Vec3 rgb) {
    const Vec3 c = (lo + hi) * 0.5;
    auto P = [&](int k) { return Vec3{k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z}; };
    static const int quads[6][4] = {{0, 1, 3, 2}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 3, 7, 5}};
    for (auto& q : quads) {
      tri(P(q[0]), P(q[1]), P(q[2]), c, rgb);
      tri(P(q[0]), P(q[2]), P(q[3]), c, rgb);
    }
  }
  // Icosahedron of radius r (scaled by s per axis) at c; `jitter` moves vertices radially.
  void ico(Vec3 c, double r, Vec3 s, Vec3 rgb, double jitter = 0, std::uint64_t salt = 0) {
    const double p = (1 + std::sqrt(5.0)) / 2;
    std::vector<Vec3> v = {{-1, p, 0}, {1, p, 0}, {-1, -p, 0}, {1, -p, 0}, {0, -1, p}, {0, 1, p},
                           {0, -1, -p}, {0, 1, -p}, {p, 0, -1}, {p, 0, 1}, {-p, 0, -1}, {-p, 0, 1}};
    const double norm = std::sqrt(1 + p * p);
    for (std::size_t k = 0; k < v.size(); ++k) {
      const double f = r / norm * (1.0 + jitter * (2 * unit_double(hash64(salt, k)) - 1));
      v[k] = c + Vec3{v[k].x * f * s.x, v[k].y * f * s.y, v[k].z * f * s.z};
    }
    static const int faces[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                                     {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                                     {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    for (auto& fc : faces) tri(v[fc[0]], v[fc[1]], v[fc[2]], c, rgb);
  }
};

const Vec3 kBark{0.36, 0.25, 0.16}, kLeaf{0.23, 0.50, 0.18}, kNeedle{0.12, 0.34, 0.20}, kBush{0.30, 0.52, 0.22},
    kStone{0.50, 0.49, 0.46}, kCactus{0.30, 0.55, 0.30}, kStem{0.90, 0.86, 0.74}, kCap{0.78, 0.16, 0.12};

}  // namespace

const std::vector<std::string>& prop_types() {
  static const std::vector<std::string> t = {"tree", "pine", "bush", "rock", "cactus", "mushroom", "palm"};
  return t;
}

MeshData prop_mesh(const std::string& type) {
  FlatBuilder b;
  if (type == "tree") {  // broadleaf: trunk and a round crown, 7.5 m
    b.frustum({0, 0, 0}, 3.2, 0.35, 0.22, 6, kBark);
    b.ico({0, 5.0, 0}, 2.6, {1, 0.95, 1}, kLeaf, 0.12, 11);
  } else if (type == "pine") {  // conifer: three stacked cones, 10 m
    b.frustum({0, 0, 0}, 1.8, 0.3, 0.2, 6, kBark);
    b.frustum({0, 1.4, 0}, 4.0, 2.2, 0, 8, kNeedle);
    b.frustum({0, 3.8, 0}, 3.6, 1.7, 0, 8, kNeedle, 0.4);
    b.frustum({0, 6.2, 0}, 3.8, 1.1, 0, 8, kNeedle, 0.8);
  } else if (type == "bush") {  // 1.4 m
    b.ico({0, 0.6, 0}, 1.0, {1.1, 0.75, 1.0}, kBush, 0.15, 23);
  } else if (type == "rock") {  // irregular, partly buried, about 1.2 m
    b.ico({0, 0.35, 0}, 1.1, {1.2, 0.7, 0.9}, kStone, 0.3, 37);
  } else if (type == "cactus") {  // saguaro-like column with two arms, 4 m
    b.frustum({0, 0, 0}, 4.0, 0.32, 0.26, 8, kCactus);
    b.box({0.2, 1.45, -0.15}, {0.85, 1.75, 0.15}, kCactus);  // elbow joining the column to the right arm
    b.frustum({0.7, 1.45, 0}, 1.5, 0.19, 0.15, 6, kCactus);
    b.box({-0.8, 2.05, -0.13}, {-0.2, 2.3, 0.13}, kCactus);  // left elbow
    b.frustum({-0.68, 2.05, 0}, 1.1, 0.17, 0.13, 6, kCactus);
  } else if (type == "palm") {  // leaning trunk in three tapering pieces and a flat crown of fronds, 8 m
    b.frustum({0, 0, 0}, 2.6, 0.26, 0.21, 6, kBark);
    b.frustum({0.25, 2.5, 0}, 2.5, 0.21, 0.17, 6, kBark);
    b.frustum({0.7, 4.9, 0}, 2.3, 0.17, 0.14, 6, kBark);
    b.ico({1.05, 7.3, 0}, 2.4, {1.0, 0.28, 1.0}, kLeaf, 0.2, 41);
  } else if (type == "mushroom") {  // 0.5 m
    b.frustum({0, 0, 0}, 0.32, 0.07, 0.06, 6, kStem);
    b.frustum({0, 0.28, 0}, 0.22, 0.28, 0, 8, kCap);
  } else {
    std::string list;
    for (auto& n : prop_types()) list += (list.empty() ? "" : ", ") + n;
    throw Error("points", "unknown prop type \"" + type + "\"; known: " + list);
  }
  return std::move(b.m);
}

std::vector<const Point*> terrain_props(const Terrain& t) {
  std::vector<const Point*> out;
  const auto& known = prop_types();
  for (std::size_t k = 0; k < t.points.size(); ++k) {
    const Point& p = t.points[k];
    if (p.kind != "prop") continue;
    const std::string path = "points[" + std::to_string(k) + "]";
    if (std::find(known.begin(), known.end(), p.type) == known.end()) {
      std::string list;
      for (auto& n : known) list += (list.empty() ? "" : ", ") + n;
      throw Error(path + ".type", "unknown prop type \"" + p.type + "\"; known: " + list);
    }
    if (!std::isfinite(p.x_m) || !std::isfinite(p.y_m) || !std::isfinite(p.z_m) || !std::isfinite(p.rotation_deg))
      throw Error(path, "non-finite position or rotation");
    if (!(p.scale > 0) || !std::isfinite(p.scale)) throw Error(path + ".scale", "expected a positive scale");
    out.push_back(&p);
  }
  return out;
}

}  // namespace relief
