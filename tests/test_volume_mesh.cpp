// Tests for relief::mesh_density (include/relief/volume_mesh.hpp, src/marching_cubes.cpp):
//   * the compile-time case table closes up: for every case, and every pair of cases that can share a
//     face, each mesh edge is used once in each direction (checked exhaustively, no field needed);
//   * watertight meshes on closed regions (a sphere, a sum-of-sines cave field, a hashed random field
//     full of ambiguous faces): no boundary edge, no non-manifold edge, opposite directions;
//   * seams: 2×2×2 blocks give the single block's mesh, vertex for vertex and normal bit for bit;
//   * against references: OpenVDB volumeToMesh (same density, sign flipped), the analytic sphere and plane;
//   * determinism (twice, 1 and 2 threads), orientation (triangles face the air), errors.
#include <gtest/gtest.h>
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
[[maybe_unused]] double area(const VolumeMesh& m) {
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

}  // namespace
}  // namespace relief
