// Tests for relief::mesh_density (include/relief/volume_mesh.hpp, src/marching_cubes.cpp):
//   * the compile-time case table closes up: for every case, and every pair of cases that can share a
//     face, each mesh edge is used once in each direction (checked exhaustively, no field needed);
//   * watertight meshes on closed regions (a sphere, a sum-of-sines cave field, a hashed random field
//     full of ambiguous faces): no boundary edge, no non-manifold edge, opposite directions;
//   * seams: 2×2×2 blocks give the single block's mesh, vertex for vertex and normal bit for bit;
//   * against references: OpenVDB volumeToMesh (same density, sign flipped), the analytic sphere and plane;
//   * determinism (twice, 1 and 2 threads), orientation (triangles face the air), errors.
#include <gtest/gtest.h>
#include <hwy/targets.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <map>
#include <string>
#include <tuple>
#include <algorithm>
#include <cstdio>
#include <numbers>
#include <unordered_map>
#include <vector>

#include "marching_cubes_tables.hpp"
#include "relief/error.hpp"
#include "relief/volume_mesh.hpp"

namespace relief {
namespace {

using Field = std::function<float(double, double, double)>;  // world index coordinates → density

DensityBlock make_block(int nx, int ny, int nz, std::int64_t ix0, std::int64_t iy0, std::int64_t iz0, double cell,
                        const Field& f) {
  DensityBlock b;
  b.nx = nx, b.ny = ny, b.nz = nz, b.cell_m = cell, b.ix0 = ix0, b.iy0 = iy0, b.iz0 = iz0;
  b.d.resize(std::size_t(nx) * ny * nz);
  for (int j = 0; j < ny; ++j)
    for (int k = 0; k < nz; ++k)
      for (int i = 0; i < nx; ++i)
        b.d[(std::size_t(j) * nz + k) * nx + i] = f(double(ix0 + i), double(iy0 + j), double(iz0 + k));
  return b;
}

// Forces the samples at or outside the apron boundary (index ≤ apron or ≥ n − 1 − apron) to air, so
// that the surface inside the meshed cells is closed.
void close_region(DensityBlock& b, int apron) {
  for (int j = 0; j < b.ny; ++j)
    for (int k = 0; k < b.nz; ++k)
      for (int i = 0; i < b.nx; ++i) {
        auto out = [&](int x, int n) { return x <= apron || x >= n - 1 - apron; };
        if (out(i, b.nx) || out(j, b.ny) || out(k, b.nz)) b.d[(std::size_t(j) * b.nz + k) * b.nx + i] = -1.0f;
      }
}

std::uint64_t hash64(std::uint64_t x) {  // SplitMix64's finaliser
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

float caves(double x, double y, double z) {  // a few sines: chambers, tunnels, overhangs
  return float(std::sin(0.31 * x + 0.2) + std::sin(0.23 * y + 1.1) * std::cos(0.27 * z) +
               0.5 * std::sin(0.41 * (x + y - z)) + 0.35 * std::cos(0.57 * x - 0.33 * z + 0.7 * y) - 0.3);
}

float random_field(double x, double y, double z) {  // uniform in [-1, 1) per sample, no zeros
  const std::uint64_t h = hash64(std::uint64_t(std::int64_t(x)) * 73856093u ^ std::uint64_t(std::int64_t(y)) * 19349663u ^
                                 std::uint64_t(std::int64_t(z)) * 83492791u);
  const float v = float(double(h >> 11) * 0x1.0p-53 * 2.0 - 1.0);
  return v == 0.0f ? 0.5f : v;
}

struct EdgeCounts {
  std::size_t boundary = 0, non_manifold = 0, same_direction = 0, edges = 0;
};
// Undirected edges used by one triangle (boundary), by more than two (non-manifold), or twice in the
// same direction (inconsistent orientation).
EdgeCounts count_edges(const VolumeMesh& m) {
  std::unordered_map<std::uint64_t, int> directed;
  for (std::size_t t = 0; t < m.indices.size(); t += 3)
    for (int e = 0; e < 3; ++e) {
      const std::uint64_t u = m.indices[t + e], v = m.indices[t + (e + 1) % 3];
      ++directed[u << 32 | v];
    }
  EdgeCounts c;
  for (auto& [key, n] : directed) {
    const std::uint64_t u = key >> 32, v = key & 0xffffffffu;
    const auto rev = directed.find(v << 32 | u);
    const int back = rev == directed.end() ? 0 : rev->second;
    if (u < v || rev == directed.end()) ++c.edges;
    if (n > 1) ++c.same_direction;
    if (n + back == 1) ++c.boundary;
    if (n + back > 2) ++c.non_manifold;
  }
  return c;
}

std::array<double, 3> pos(const VolumeMesh& m, std::uint32_t v) {
  return {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
}
std::array<double, 3> face_cross(const VolumeMesh& m, std::size_t t) {
  const auto a = pos(m, m.indices[t]), b = pos(m, m.indices[t + 1]), c = pos(m, m.indices[t + 2]);
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  return {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
}
double area(const VolumeMesh& m) {
  double s = 0;
  for (std::size_t t = 0; t < m.indices.size(); t += 3) {
    const auto c = face_cross(m, t);
    s += 0.5 * std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
  }
  return s;
}
std::size_t degenerate(const VolumeMesh& m) {
  std::size_t n = 0;
  for (std::size_t t = 0; t < m.indices.size(); t += 3) {
    const auto c = face_cross(m, t);
    n += c[0] == 0 && c[1] == 0 && c[2] == 0;
  }
  return n;
}
// Triangles whose geometric normal points the same way as their vertices' mean normal (−∇density).
double fraction_facing_air(const VolumeMesh& m) {
  std::size_t good = 0;
  for (std::size_t t = 0; t < m.indices.size(); t += 3) {
    const auto c = face_cross(m, t);
    double dot = 0;
    for (int e = 0; e < 3; ++e)
      for (int q = 0; q < 3; ++q) dot += c[q] * m.normals[3 * m.indices[t + e] + q];
    good += dot > 0;
  }
  return double(good) / double(m.indices.size() / 3);
}
void expect_closed(const VolumeMesh& m) {
  const EdgeCounts c = count_edges(m);
  EXPECT_GT(m.indices.size(), 0u);
  EXPECT_EQ(c.boundary, 0u);
  EXPECT_EQ(c.non_manifold, 0u);
  EXPECT_EQ(c.same_direction, 0u);
  // Closed: V − E + F = 2 − 2·genus is even.
  const long long chi = (long long)(m.positions.size() / 3) - (long long)c.edges + (long long)(m.indices.size() / 3);
  EXPECT_EQ(chi % 2, 0);
  // Every vertex is used.
  std::vector<char> used(m.positions.size() / 3, 0);
  for (auto v : m.indices) used[v] = 1;
  EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0);
}

// ---------------------------------------------------------------------------------------------------
// The case table, exhaustively.

TEST(VolumeMeshTable, EveryCaseClosesInsideTheCube) {
  using namespace mc;
  for (int cfg = 0; cfg < 256; ++cfg) {
    int dir[12][12] = {};
    for (int t = 0; t < kCases.count[cfg]; ++t)
      for (int e = 0; e < 3; ++e) ++dir[kCases.edges[cfg][3 * t + e]][kCases.edges[cfg][3 * t + (e + 1) % 3]];
    for (int u = 0; u < 12; ++u)
      for (int v = 0; v < 12; ++v) {
        EXPECT_LE(dir[u][v], 1) << "case " << cfg;
        if (!edges_share_face(u, v)) {
          EXPECT_EQ(dir[u][v], dir[v][u]) << "case " << cfg << " edges " << u << "," << v;
        }
      }
    // Triangles only use crossed edges, and every crossed edge is used.
    std::uint16_t used = 0;
    for (int t = 0; t < 3 * kCases.count[cfg]; ++t) used = std::uint16_t(used | 1u << kCases.edges[cfg][t]);
    EXPECT_EQ(used, kCases.edge_mask[cfg]) << "case " << cfg;
  }
}

TEST(VolumeMeshTable, EveryPairOfCasesSharingAFaceAgreesOnIt) {
  using namespace mc;
  std::size_t pairs = 0;
  for (int a = 0; a < 3; ++a) {
    // Cube A below (face side 1), cube B above (its face side 0): B's corner c ^ 1 << a is A's c.
    for (int ca = 0; ca < 256; ++ca)
      for (int cb = 0; cb < 256; ++cb) {
        bool match = true;
        for (int c = 0; c < 8; ++c)
          if (((c >> a) & 1) == 1 && ((ca >> c) & 1) != ((cb >> (c ^ (1 << a))) & 1)) match = false;
        if (!match) continue;
        ++pairs;
        // Face edges, named by A's ids; B's edge f on its face 0 is A's edge with corners shifted by +a.
        auto on_face = [&](int e, int s) { return edge_axis(e) != a && ((edge_corner0(e) >> a) & 1) == s; };
        auto b_to_a = [&](int f) { return edge_between(edge_corner0(f) | 1 << a, edge_corner1(f) | 1 << a); };
        int dir[12][12] = {};
        for (int t = 0; t < kCases.count[ca]; ++t)
          for (int e = 0; e < 3; ++e) {
            const int u = kCases.edges[ca][3 * t + e], v = kCases.edges[ca][3 * t + (e + 1) % 3];
            if (on_face(u, 1) && on_face(v, 1)) ++dir[u][v];
          }
        for (int t = 0; t < kCases.count[cb]; ++t)
          for (int e = 0; e < 3; ++e) {
            const int u = kCases.edges[cb][3 * t + e], v = kCases.edges[cb][3 * t + (e + 1) % 3];
            if (on_face(u, 0) && on_face(v, 0)) ++dir[b_to_a(u)][b_to_a(v)];
          }
        for (int u = 0; u < 12; ++u)
          for (int v = 0; v < 12; ++v) {
            ASSERT_LE(dir[u][v], 1) << "axis " << a << " cases " << ca << "/" << cb;
            ASSERT_EQ(dir[u][v], dir[v][u]) << "axis " << a << " cases " << ca << "/" << cb << " edges " << u << "," << v;
          }
      }
  }
  EXPECT_EQ(pairs, 3u * 256u * 16u);  // each face has 16 sign patterns, each shared with 16 B cases
}

TEST(VolumeMeshTable, SingleCornerFacesAwayFromIt) {
  // Corner 0 solid: one triangle, normal (right-hand rule over edge midpoints) towards +x+y+z.
  ASSERT_EQ(mc::kCases.count[1], 1);
  auto mid = [](int e) {
    std::array<double, 3> p{};
    for (int q = 0; q < 3; ++q) p[q] = 0.5 * (((mc::edge_corner0(e) >> q) & 1) + ((mc::edge_corner1(e) >> q) & 1));
    return p;
  };
  const auto a = mid(mc::kCases.edges[1][0]), b = mid(mc::kCases.edges[1][1]), c = mid(mc::kCases.edges[1][2]);
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  EXPECT_GT(u[1] * v[2] - u[2] * v[1], 0);
  EXPECT_GT(u[2] * v[0] - u[0] * v[2], 0);
  EXPECT_GT(u[0] * v[1] - u[1] * v[0], 0);
}

// ---------------------------------------------------------------------------------------------------
// Watertight meshes.

constexpr double kSphereC[3] = {15.3, 16.1, 15.7};
constexpr double kSphereR = 10.4;
float sphere(double x, double y, double z) {
  return float(kSphereR - std::sqrt((x - kSphereC[0]) * (x - kSphereC[0]) + (y - kSphereC[1]) * (y - kSphereC[1]) +
                                    (z - kSphereC[2]) * (z - kSphereC[2])));
}

TEST(VolumeMesh, SphereIsWatertightAndFacesTheAir) {
  const DensityBlock b = make_block(32, 33, 34, 0, 0, 0, 0.5, sphere);
  const VolumeMesh m = mesh_density(b);
  expect_closed(m);
  const EdgeCounts c = count_edges(m);
  EXPECT_EQ((long long)(m.positions.size() / 3) - (long long)c.edges + (long long)(m.indices.size() / 3), 2);  // a sphere
  EXPECT_EQ(degenerate(m), 0u);
  EXPECT_EQ(fraction_facing_air(m), 1.0);
}

TEST(VolumeMesh, CaveFieldIsWatertight) {
  DensityBlock b = make_block(48, 40, 44, -20, 5, 7, 1.0, caves);
  close_region(b, 1);
  const VolumeMesh m = mesh_density(b);
  expect_closed(m);
  EXPECT_EQ(degenerate(m), 0u);
  EXPECT_GT(fraction_facing_air(m), 0.99);
  // The field has handles (tunnels): a genus well above 0 shows the test looks at real caves.
  const EdgeCounts c = count_edges(m);
  const long long chi = (long long)(m.positions.size() / 3) - (long long)c.edges + (long long)(m.indices.size() / 3);
  EXPECT_LT(chi, 0);
}

TEST(VolumeMesh, RandomFieldWithEveryAmbiguityIsWatertight) {
  for (int apron : {1, 2}) {
    DensityBlock b = make_block(30, 28, 26, 3, -9, 11, 0.25, random_field);
    close_region(b, apron);
    const VolumeMesh m = mesh_density(b, apron);
    expect_closed(m);
    EXPECT_EQ(degenerate(m), 0u);
  }
}

TEST(VolumeMesh, ZeroSamplesAreAirAndStayWatertight) {
  // Integer-valued field with many exact zeros: the zero samples count as air; vertices at t = 1 can
  // coincide in position (degenerate triangles, kept), but the index topology stays closed.
  DensityBlock b = make_block(20, 20, 20, 0, 0, 0, 1.0, [](double x, double y, double z) {
    return float(std::int64_t(hash64(std::uint64_t(x + 31 * y + 977 * z)) % 3) - 1);  // −1, 0, 1
  });
  close_region(b, 1);
  const VolumeMesh m = mesh_density(b);
  expect_closed(m);
  // Every degenerate triangle has a vertex on a zero sample (a coordinate that is an exact integer on all axes).
  for (std::size_t t = 0; t < m.indices.size(); t += 3) {
    const auto c = face_cross(m, t);
    if (c[0] != 0 || c[1] != 0 || c[2] != 0) continue;
    bool on_sample = false;
    for (int e = 0; e < 3; ++e) {
      const auto p = pos(m, m.indices[t + e]);
      on_sample |= p[0] == std::floor(p[0]) && p[1] == std::floor(p[1]) && p[2] == std::floor(p[2]);
    }
    EXPECT_TRUE(on_sample);
  }
  // Edges joining a solid sample to a zero sample carry their vertex on the zero sample.
  std::size_t at_zero = 0;
  for (std::size_t v = 0; v < m.positions.size() / 3; ++v) {
    const auto p = pos(m, std::uint32_t(v));
    if (p[0] == std::floor(p[0]) && p[1] == std::floor(p[1]) && p[2] == std::floor(p[2])) {
      EXPECT_EQ(b.at(int(p[0]), int(p[1]), int(p[2])), 0.0f);
      ++at_zero;
    }
  }
  EXPECT_GT(at_zero, 0u);
}


// ---------------------------------------------------------------------------------------------------
// Seams: 2×2×2 blocks against one block.

struct Key {
  std::uint32_t x, y, z;
  bool operator<(const Key& o) const { return std::tie(x, y, z) < std::tie(o.x, o.y, o.z); }
};
Key key_of(const VolumeMesh& m, std::uint32_t v) {
  Key k{};
  std::memcpy(&k.x, &m.positions[3 * v], 4);
  std::memcpy(&k.y, &m.positions[3 * v + 1], 4);
  std::memcpy(&k.z, &m.positions[3 * v + 2], 4);
  return k;
}
// A triangle as its vertices' indices in the reference mesh, rotated so that the smallest comes first
// (the winding is kept).
std::array<std::uint32_t, 3> canonical(std::array<std::uint32_t, 3> t) {
  while (t[0] > t[1] || t[0] > t[2]) t = {t[1], t[2], t[0]};
  return t;
}

void check_seams(int apron, const Field& f) {
  const int N[3] = {41, 37, 45};
  const std::int64_t o[3] = {-13, 250, 7};
  const double cell = 0.75;
  const VolumeMesh whole = mesh_density(make_block(N[0], N[1], N[2], o[0], o[1], o[2], cell, f), apron);
  std::map<Key, std::uint32_t> ref;
  for (std::uint32_t v = 0; v < whole.positions.size() / 3; ++v) ref.emplace(key_of(whole, v), v);
  ASSERT_EQ(ref.size(), whole.positions.size() / 3) << "the reference mesh has coinciding vertices";
  std::vector<std::array<std::uint32_t, 3>> ref_tris, block_tris;
  for (std::size_t t = 0; t < whole.indices.size(); t += 3)
    ref_tris.push_back(canonical({whole.indices[t], whole.indices[t + 1], whole.indices[t + 2]}));

  // Axis split: the first block has n0 samples, the second starts 2·apron + 1 samples before its end.
  int start[3][2], size[3][2];
  for (int q = 0; q < 3; ++q) {
    size[q][0] = N[q] / 2 + apron;
    start[q][0] = 0;
    start[q][1] = size[q][0] - 1 - 2 * apron;
    size[q][1] = N[q] - start[q][1];
  }
  std::vector<char> covered(ref.size(), 0);
  std::size_t block_vertices = 0, seam_copies = 0;
  for (int bx = 0; bx < 2; ++bx)
    for (int by = 0; by < 2; ++by)
      for (int bz = 0; bz < 2; ++bz) {
        const VolumeMesh m =
            mesh_density(make_block(size[0][bx], size[1][by], size[2][bz], o[0] + start[0][bx], o[1] + start[1][by],
                                    o[2] + start[2][bz], cell, f),
                         apron);
        std::vector<std::uint32_t> to_ref(m.positions.size() / 3);
        block_vertices += to_ref.size();
        for (std::uint32_t v = 0; v < to_ref.size(); ++v) {
          const auto it = ref.find(key_of(m, v));
          ASSERT_NE(it, ref.end()) << "block vertex " << v << " is not a vertex of the single block's mesh";
          to_ref[v] = it->second;
          seam_copies += covered[it->second];
          covered[it->second] = 1;
          EXPECT_EQ(std::memcmp(&m.normals[3 * v], &whole.normals[3 * it->second], 12), 0) << "normal of vertex " << v;
        }
        for (std::size_t t = 0; t < m.indices.size(); t += 3)
          block_tris.push_back(canonical({to_ref[m.indices[t]], to_ref[m.indices[t + 1]], to_ref[m.indices[t + 2]]}));
      }
  EXPECT_EQ(std::count(covered.begin(), covered.end(), 0), 0);
  EXPECT_GT(seam_copies, 100u);  // the seams are crossed by the surface many times
  EXPECT_EQ(block_vertices - seam_copies, ref.size());
  EXPECT_EQ(block_tris.size(), ref_tris.size());
  std::sort(ref_tris.begin(), ref_tris.end());
  std::sort(block_tris.begin(), block_tris.end());
  EXPECT_TRUE(block_tris == ref_tris);
}

TEST(VolumeMeshSeams, EightBlocksEqualOneBlock) {
  check_seams(1, caves);
  check_seams(2, caves);
}
TEST(VolumeMeshSeams, EightBlocksEqualOneBlockOnARandomField) { check_seams(1, random_field); }

// ---------------------------------------------------------------------------------------------------
// Against references.

struct VdbMesh {
  std::size_t triangles = 0, quads = 0, points = 0;
  double area = 0;
};
VdbMesh openvdb_mesh(const DensityBlock& b) {
  openvdb::initialize();
  auto grid = openvdb::FloatGrid::create(1.0f);  // background: air (OpenVDB: negative inside)
  grid->setTransform(openvdb::math::Transform::createLinearTransform(b.cell_m));
  auto acc = grid->getAccessor();
  for (int j = 0; j < b.ny; ++j)
    for (int k = 0; k < b.nz; ++k)
      for (int i = 0; i < b.nx; ++i)
        acc.setValue(openvdb::Coord(int(b.ix0 + i), int(b.iy0 + j), int(b.iz0 + k)), -b.at(i, j, k));
  std::vector<openvdb::Vec3s> pts;
  std::vector<openvdb::Vec3I> tris;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*grid, pts, tris, quads, 0.0, 0.0);
  VdbMesh r;
  r.triangles = tris.size(), r.quads = quads.size(), r.points = pts.size();
  auto tri_area = [&](unsigned a, unsigned b2, unsigned c) {
    const openvdb::Vec3d p = pts[a], q = pts[b2], s = pts[c];
    return 0.5 * (q - p).cross(s - p).length();
  };
  for (auto& t : tris) r.area += tri_area(t[0], t[1], t[2]);
  for (auto& q : quads) r.area += tri_area(q[0], q[1], q[2]) + tri_area(q[0], q[2], q[3]);
  return r;
}

void compare_with_openvdb(const DensityBlock& b, double area_tol) {
  const VolumeMesh m = mesh_density(b);
  const VdbMesh v = openvdb_mesh(b);
  const EdgeCounts c = count_edges(m);
  const long long V = (long long)(m.positions.size() / 3), F = (long long)(m.indices.size() / 3);
  const long long chi = V - (long long)c.edges + F;
  std::printf("    ours: %lld vertices, %lld triangles, area %.3f; OpenVDB: %zu points, %zu quads, %zu triangles, area %.3f\n",
              V, F, area(m), v.points, v.quads, v.triangles, v.area);
  // OpenVDB's mesh is dual: one quad per crossed edge, so (sign conventions matched: a zero sample is
  // outside for both) its quads are our vertices, and a closed triangle mesh has F = 2V − 2χ.
  EXPECT_EQ(v.triangles, 0u);
  EXPECT_EQ((long long)v.quads, V);
  EXPECT_EQ(F, 2 * (long long)v.quads - 2 * chi);
  EXPECT_NEAR(area(m) / v.area, 1.0, area_tol);
}

// Areas: OpenVDB places one point per crossed cell (the mean of its edge crossings, a dual surface) and
// so cuts corners that our primal mesh follows; the gap grows with curvature per cell. Measured: sphere
// of radius 10.4 cells 0.28 %, the cave field (features ~10 cells across) 2.3 %: tolerances 1 % and 3 %.
TEST(VolumeMeshReference, SphereAgainstOpenVdb) {
  compare_with_openvdb(make_block(32, 33, 34, 0, 0, 0, 0.5, sphere), 0.01);
}
TEST(VolumeMeshReference, CavesAgainstOpenVdb) {
  DensityBlock b = make_block(64, 48, 56, -20, 5, 7, 1.0, caves);
  close_region(b, 1);
  compare_with_openvdb(b, 0.03);
}

TEST(VolumeMeshReference, SphereAgainstTheAnalyticSurface) {
  const double cell = 0.5;
  const VolumeMesh m = mesh_density(make_block(32, 33, 34, 0, 0, 0, cell, sphere));
  const double r = kSphereR * cell;
  double worst = 0, worst_normal = 0;
  for (std::uint32_t v = 0; v < m.positions.size() / 3; ++v) {
    const auto p = pos(m, v);
    double q[3], len = 0;
    for (int c = 0; c < 3; ++c) q[c] = p[c] - kSphereC[c] * cell, len += q[c] * q[c];
    len = std::sqrt(len);
    worst = std::max(worst, std::abs(len - r));
    double dot = 0;
    for (int c = 0; c < 3; ++c) dot += q[c] / len * m.normals[3 * v + c];
    worst_normal = std::max(worst_normal, std::acos(std::min(1.0, dot)));
  }
  const double a = area(m), exact = 4 * std::numbers::pi * r * r;
  std::printf("    sphere r = %.2f m: area %.4f vs %.4f (%.3f%%), worst vertex distance %.5f m, worst normal %.3f°\n", r,
              a, exact, 100 * (a / exact - 1), worst, worst_normal * 180 / std::numbers::pi);
  // The vertex's distance to the sphere is the exact distance field's value there, i.e. the error of
  // linear interpolation along the edge: at most h²/8 · max |d''| ≤ h²/(8(r − h)) = 0.0066 m here
  // (h = 0.5 m, r = 5.2 m; along a line at distance ρ from the centre d'' = ρ²/|p|³ ≤ 1/|p|).
  EXPECT_LT(worst, 0.0067);
  // The mesh is inscribed in the sphere up to that error: its area is a little smaller, by O((h/r)²).
  EXPECT_LT(a, exact);
  EXPECT_GT(a, 0.98 * exact);
  // Normals: central differences of the distance field, nearly radial.
  EXPECT_LT(worst_normal, 2.0 * std::numbers::pi / 180);
}

TEST(VolumeMeshReference, TiltedPlaneIsExact) {
  // d = h(x, z) − y with h linear: every vertex lies on the plane, the mesh tiles the plane's part
  // inside the meshed box exactly (area = Lx·Lz·√(1 + sx² + sz²)), normals are the plane's.
  // Slopes and offset chosen so that the plane passes through no sample (with 0.21, −0.13 and 14.3 it
  // passes through many, up to rounding, and the vertices at t ≈ 0 there make zero-area triangles).
  const double sx = 0.2113579, sz = -0.1372461, h0 = 14.3179, cell = 1.5;
  auto plane = [&](double x, double y, double z) { return float(h0 + sx * x + sz * z - y); };
  const int nx = 40, ny = 30, nz = 36;
  const VolumeMesh m = mesh_density(make_block(nx, ny, nz, 0, 0, 0, cell, plane));
  const double Lx = (nx - 3) * cell, Lz = (nz - 3) * cell;  // meshed samples 1 .. n − 2
  const double exact = Lx * Lz * std::sqrt(1 + sx * sx + sz * sz);
  EXPECT_NEAR(area(m) / exact, 1.0, 1e-5);
  const double nn = std::sqrt(1 + sx * sx + sz * sz), n[3] = {-sx / nn, 1 / nn, -sz / nn};
  for (std::uint32_t v = 0; v < m.positions.size() / 3; ++v) {
    const auto p = pos(m, v);
    ASSERT_NEAR((h0 + sx * p[0] / cell + sz * p[2] / cell - p[1] / cell) * cell / nn, 0.0, 2e-5);
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(m.normals[3 * v + c], n[c], 1e-5);
  }
  EXPECT_EQ(degenerate(m), 0u);
  EXPECT_EQ(fraction_facing_air(m), 1.0);
  EXPECT_EQ(count_edges(m).non_manifold, 0u);
}

// ---------------------------------------------------------------------------------------------------
// Determinism and errors.

TEST(VolumeMesh, DeterministicForAnyThreadCount) {
  const DensityBlock b = make_block(70, 66, 68, 5, -3, 1, 1.0, caves);
  auto same = [](const VolumeMesh& x, const VolumeMesh& y) {
    return x.positions.size() == y.positions.size() && x.indices == y.indices &&
           std::memcmp(x.positions.data(), y.positions.data(), x.positions.size() * 4) == 0 &&
           std::memcmp(x.normals.data(), y.normals.data(), x.normals.size() * 4) == 0;
  };
  const VolumeMesh a = mesh_density(b), again = mesh_density(b);
  EXPECT_TRUE(same(a, again));
  for (int threads : {1, 2, 3}) {
    tbb::task_arena arena(threads);
    VolumeMesh t;
    arena.execute([&] { t = mesh_density(b); });
    EXPECT_TRUE(same(a, t)) << threads << " threads";
  }
  EXPECT_GT(a.indices.size(), 10000u);
}

std::uint64_t fnv1a_bytes(const void* data, std::size_t n, std::uint64_t h = 0xcbf29ce484222325ull) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t q = 0; q < n; ++q) h = (h ^ p[q]) * 0x100000001b3ull;
  return h;
}

// A golden hash of positions, normals and indices for the hashed random field (integer arithmetic
// only, so the density is the same everywhere; the mesh then uses IEEE division and square root, no
// libm): any change to the table, the vertex order or the arithmetic shows here.
TEST(VolumeMesh, GoldenHash) {
  DensityBlock b = make_block(45, 38, 41, -17, 4, 1000, 0.5, random_field);
  for (int threads : {1, 2, 3}) {
    tbb::task_arena arena(threads);
    VolumeMesh m;
    arena.execute([&] { m = mesh_density(b, 1); });
    std::uint64_t h = fnv1a_bytes(m.positions.data(), m.positions.size() * 4);
    h = fnv1a_bytes(m.normals.data(), m.normals.size() * 4, h);
    h = fnv1a_bytes(m.indices.data(), m.indices.size() * 4, h);
    EXPECT_EQ(m.positions.size() / 3, 88453u) << "vertices";
    EXPECT_EQ(m.indices.size() / 3, 179307u) << "triangles";
    EXPECT_EQ(h, 0x4caadf3c52c1ec9eull) << std::hex << h;
  }
}

// The kernels are compiled per Highway target: every target this CPU runs gives the same bytes (the
// sign bits are exact comparisons, the rest scalar code without FMA contraction). nx = 131 = 2·64 + 3:
// full words and a tail.
TEST(VolumeMesh, EveryHighwayTargetGivesTheSameBytes) {
  DensityBlock b = make_block(131, 40, 37, -70, 2, 9, 1.0, caves);
  const VolumeMesh want = mesh_density(b);
  std::size_t targets = 0;
  for (std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    hwy::SetSupportedTargetsForTest(target);
    const VolumeMesh got = mesh_density(b);
    hwy::SetSupportedTargetsForTest(0);
    ++targets;
    EXPECT_EQ(got.indices, want.indices) << hwy::TargetName(target);
    ASSERT_EQ(got.positions.size(), want.positions.size()) << hwy::TargetName(target);
    EXPECT_EQ(std::memcmp(got.positions.data(), want.positions.data(), want.positions.size() * 4), 0);
    EXPECT_EQ(std::memcmp(got.normals.data(), want.normals.data(), want.normals.size() * 4), 0);
  }
  EXPECT_GE(targets, 2u);
  EXPECT_GT(want.indices.size(), 10000u);
}

void expect_error(const DensityBlock& b, int apron, const std::string& field) {
  try {
    mesh_density(b, apron);
    ADD_FAILURE() << "no error for " << field;
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), field) << e.what();
  }
}

TEST(VolumeMesh, BadInputNamesTheField) {
  const DensityBlock good = make_block(6, 6, 4, 0, 0, 0, 1.0, sphere);
  EXPECT_NO_THROW(mesh_density(good, 1));
  expect_error(good, 0, "apron");
  expect_error(good, -3, "apron");
  expect_error(good, 2, "nz");  // 4 < 2·2 + 2
  DensityBlock b = good;
  b.d.pop_back();
  expect_error(b, 1, "d");
  b = good;
  b.nx = 3, b.d.resize(3 * 5 * 4);
  expect_error(b, 1, "nx");
  b = good;
  b.ny = 3, b.d.resize(6 * 3 * 4);
  expect_error(b, 1, "ny");
  for (double cell : {0.0, -1.0, std::nan(""), double(INFINITY)}) {
    b = good;
    b.cell_m = cell;
    expect_error(b, 1, "cell_m");
  }
  b = good;
  b.d[(std::size_t(2) * b.nz + 2) * b.nx + 2] = 1.0f;  // a solid sample next to a NaN: a vertex needs it
  b.d[(std::size_t(2) * b.nz + 2) * b.nx + 3] = std::nanf("");
  expect_error(b, 1, "d");
  b = good;
  b.d.assign(b.d.size(), -1.0f);
  b.d[0] = std::nanf("");  // in the apron, next to nothing crossed: counts as air
  EXPECT_NO_THROW(mesh_density(b, 1));
  EXPECT_TRUE(mesh_density(b, 1).indices.empty());
}

}  // namespace
}  // namespace relief
