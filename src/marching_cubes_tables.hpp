#pragma once
// Internal: the marching-cubes case table, derived at compile time from one face rule (see
// include/relief/volume_mesh.hpp for the conventions it serves). Nothing here is pasted from
// a published table: the 256 cases follow from the rule below, and tests/test_volume_mesh.cpp checks
// the result exhaustively (every pair of cases that can share a face closes up into a manifold).
//
// Numbering:
//   * corner c = x | y << 1 | z << 2 (x, y, z ∈ {0, 1} offsets from the cell's lower corner);
//     case bit c = 1 when corner c is solid (density > 0).
//   * edge e = 4·axis + o, axis 0 = x, 1 = y, 2 = z; o = offset along the lower of the two other axes
//     | offset along the higher one << 1 (x edges: o = dy | dz << 1, y edges: dx | dz << 1, z edges:
//     dx | dy << 1). Its end corners are lo (axis bit 0) and lo | 1 << axis.
//
// Rule: each face, walked counter-clockwise as seen from outside the cube, is cut by one segment per
// run of consecutive solid corners, from the edge where the walk leaves the run to the edge where it
// entered it. On a face with two opposite solid corners the solid corners are thus separated (the air
// connects across the face). The segment depends only on the face's corner signs, so both cubes
// sharing the face draw it (in opposite directions). Every crossed edge has one outgoing and one
// incoming segment (its two faces walk it in opposite directions), so the segments chain into
// closed loops; each loop is fanned into triangles, wound counter-clockwise seen from the air. The fan's
// apex is the first loop vertex (from the lowest edge id along the loop) whose diagonals join no two
// vertices on a common cube face (a diagonal on a face could also be drawn by the neighbouring cube);
// when every apex has such a diagonal, the one with fewest.
#include <cstdint>

namespace relief::mc {

inline constexpr int kMaxTriangles = 12;  // an upper bound (12 crossed edges, loops ≥ 3); the table's real max is smaller

struct CaseTable {
  std::uint8_t count[256] = {};                     // triangles of the case
  std::uint8_t edges[256][3 * kMaxTriangles] = {};  // their edge ids, 3 per triangle
  std::uint16_t edge_mask[256] = {};                // bit e: edge e is crossed
  int max_count = 0;
};

constexpr int edge_axis(int e) { return e >> 2; }
// The edge's lower corner.
constexpr int edge_corner0(int e) {
  const int a = e >> 2, o = e & 3;
  const int u = a == 0 ? 1 : 0, v = a == 2 ? 1 : 2;  // the other two axes, lower first
  return ((o & 1) << u) | (((o >> 1) & 1) << v);
}
constexpr int edge_corner1(int e) { return edge_corner0(e) | (1 << edge_axis(e)); }
// The edge joining corners ca and cb (which differ in exactly one bit).
constexpr int edge_between(int ca, int cb) {
  const int diff = ca ^ cb, lo = ca & cb;
  const int a = diff == 1 ? 0 : diff == 2 ? 1 : 2;
  const int u = a == 0 ? 1 : 0, v = a == 2 ? 1 : 2;
  return 4 * a + (((lo >> u) & 1) | (((lo >> v) & 1) << 1));
}
// True when edges e and f both lie on one face of the cube.
constexpr bool edges_share_face(int e, int f) {
  for (int a = 0; a < 3; ++a)
    for (int s = 0; s < 2; ++s) {
      auto on = [&](int g) { return edge_axis(g) != a && ((edge_corner0(g) >> a) & 1) == s; };
      if (on(e) && on(f)) return true;
    }
  return false;
}
// Face (axis a, side s): its corners counter-clockwise seen from outside.
constexpr void face_corners(int a, int s, int q[4]) {
  const int u = (a + 1) % 3, v = (a + 2) % 3;  // (u, v, a) right-handed
  const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (int m = 0; m < 4; ++m) {
    const int src = s == 1 ? m : (4 - m) % 4;  // reversed when the face looks down −a
    q[m] = (s << a) | (uv[src][0] << u) | (uv[src][1] << v);
  }
}

constexpr CaseTable build_case_table() {
  CaseTable t{};
  for (int cfg = 0; cfg < 256; ++cfg) {
    auto solid = [&](int c) { return ((cfg >> c) & 1) != 0; };
    int next[12];
    for (int e = 0; e < 12; ++e) next[e] = -1;
    std::uint16_t crossed = 0;
    for (int e = 0; e < 12; ++e)
      if (solid(edge_corner0(e)) != solid(edge_corner1(e))) crossed = std::uint16_t(crossed | (1u << e));
    for (int a = 0; a < 3; ++a)
      for (int s = 0; s < 2; ++s) {
        int q[4] = {};
        face_corners(a, s, q);
        for (int m = 0; m < 4; ++m) {
          if (!solid(q[m]) || solid(q[(m + 1) % 4])) continue;  // the walk leaves a solid run at edge m
          int first = m;
          while (solid(q[(first + 3) % 4])) first = (first + 3) % 4;  // back to the run's first corner
          const int leave = edge_between(q[m], q[(m + 1) % 4]);
          const int enter = edge_between(q[(first + 3) % 4], q[first]);
          next[leave] = enter;
        }
      }
    t.edge_mask[cfg] = crossed;
    int n = 0;
    std::uint16_t seen = 0;
    for (int e0 = 0; e0 < 12; ++e0) {
      if (!((crossed >> e0) & 1) || ((seen >> e0) & 1)) continue;
      int loop[12] = {}, m = 0;
      for (int e = e0; !((seen >> e) & 1); e = next[e]) {
        seen = std::uint16_t(seen | (1u << e));
        loop[m++] = e;
      }
      // The apex whose fan draws the fewest diagonals on a cube face (first such).
      int best = 0, best_bad = 1 << 20;
      for (int apex = 0; apex < m; ++apex) {
        int bad = 0;
        for (int k = 2; k <= m - 2; ++k)
          if (edges_share_face(loop[apex], loop[(apex + k) % m])) ++bad;
        if (bad < best_bad) best = apex, best_bad = bad;
      }
      // Loop order (leave → enter) winds clockwise seen from the air: the fan reverses it.
      for (int k = 1; k + 1 < m; ++k) {
        t.edges[cfg][3 * n + 0] = std::uint8_t(loop[best]);
        t.edges[cfg][3 * n + 1] = std::uint8_t(loop[(best + k + 1) % m]);
        t.edges[cfg][3 * n + 2] = std::uint8_t(loop[(best + k) % m]);
        ++n;
      }
    }
    t.count[cfg] = std::uint8_t(n);
    if (n > t.max_count) t.max_count = n;
  }
  return t;
}

inline constexpr CaseTable kCases = build_case_table();
static_assert(kCases.max_count <= kMaxTriangles);
static_assert(kCases.count[0] == 0 && kCases.count[255] == 0);
static_assert(kCases.count[1] == 1 && kCases.count[3] == 2);

}  // namespace relief::mc
