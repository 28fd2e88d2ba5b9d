#pragma once
// relief::mesh_density — marching cubes over a block of density samples (the caves issue's
// volumetric layer): a welded, watertight triangle mesh of the density's 0 level set, whose seam
// vertices agree bit for bit with those of the neighbouring blocks.
//
// Conventions (stated once here, relied on by the tests):
//   * Inside/outside: a sample is SOLID when density > 0 and AIR otherwise. A sample that is exactly
//     0 (or NaN) counts as air, so an edge is crossed exactly when one end is > 0 and the other is
//     not. The surface therefore never passes "between" two zero samples.
//   * Ambiguous faces (two diagonally opposite solid corners, two air corners): the solid corners
//     are separated and the air connects across the face. The rule depends only on the face's four
//     corner signs, so the two cubes sharing a face always draw the same segments on it, which is
//     what makes the mesh watertight. The 256-case table is derived from this rule at compile time
//     (src/marching_cubes_tables.hpp): on each cube face every solid arc of corners is cut off by one
//     segment; the segments chain into closed loops; each loop is fanned into triangles.
//   * Watertightness: where the surface lies wholly inside the meshed cells (a closed region), every
//     mesh edge belongs to exactly two triangles, with opposite directions (an oriented closed
//     2-manifold in terms of indices). Where the surface leaves the meshed cells the mesh has a
//     boundary there, which the neighbouring block's mesh closes (same vertices, bit for bit).
//   * Degenerate triangles: kept. A triangle has zero area only when the surface passes exactly
//     through a sample (a vertex at t = 0 or 1 of its edge coincides with the vertices of the other
//     edges at that sample) or in measure-zero collinear cases. They are kept because removing them
//     would open holes in the index topology; a consumer that needs positive areas can weld by
//     position (meshoptimizer) first. Vertices are never merged by position here.
//
// Papers: W. E. Lorensen, H. E. Cline, "Marching cubes: A high resolution 3D surface construction
// algorithm", SIGGRAPH 1987; C. Montani, R. Scateni, R. Scopigno, "A modified look-up table for
// implicit disambiguation of Marching Cubes", The Visual Computer 10(6), 1994 (a sign-only,
// face-consistent disambiguation, the rule used here).
#include <cstddef>
#include <cstdint>
#include <vector>

namespace relief {

// A block of density samples on the world voxel grid. Sample (i, j, k) — i along x (east), j along y (up),
// k along z (south) — sits at world position ((ix0 + i)·cell_m, (iy0 + j)·cell_m, (iz0 + k)·cell_m) metres
// (computed from the integer index, never accumulated, so neighbouring blocks' shared samples have identical
// positions). Layout: x fastest, then z, then y: d[(std::size_t(j)·nz + k)·nx + i]. density > 0 is solid
// (inside the ground), < 0 is air; the surface is the 0 level set.
struct DensityBlock {
  int nx = 0, ny = 0, nz = 0;
  double cell_m = 1.0;
  std::int64_t ix0 = 0, iy0 = 0, iz0 = 0;
  std::vector<float> d;
  float at(int i, int j, int k) const { return d[(std::size_t(j) * nz + k) * nx + i]; }
};

struct VolumeMesh {
  std::vector<float> positions;        // x, y, z per vertex, world metres
  std::vector<float> normals;          // unit, −∇density (pointing into the air), per vertex
  std::vector<std::uint32_t> indices;  // triangles, counter-clockwise seen from the air
};

// Meshes the 0 level set over the cells between samples [apron, n − 1 − apron] on each axis; the `apron`
// outer sample layers (≥ 1) are read only for the normals (central differences of the density), so blocks
// that overlap by 2·apron + 1 sample layers produce seam vertices with identical bits (positions AND normals).
// Vertices are welded per grid edge (each crossed edge gives one vertex shared by its cells' triangles).
// Deterministic; throws relief::Error on a block too small or with a size not matching d.
//
// Contract in detail:
//   * Meshed region: samples [apron, n − 1 − apron] on each axis, i.e. the cells (unit cubes between
//     samples) with lower corner in [apron, n − 2 − apron]. Each axis needs n ≥ 2·apron + 2 (one cell).
//     Only edges of meshed cells get vertices, and every vertex is used by at least one triangle.
//   * Seams: block B continues block A along x when B.ix0 = A.ix0 + A.nx − 1 − 2·apron (they share
//     2·apron + 1 sample layers, A's last meshed layer is B's first) and the shared samples hold the
//     same densities (the density is a function of world position). Then the vertices on the shared
//     plane have identical positions and normals in both meshes, and the two meshes together are the
//     mesh of the union (no triangle is produced twice: each cell belongs to one block). Same for y, z.
//   * Vertex of a crossed edge from sample p0 to p1 = p0 + one step along the axis (always the lower
//     index first, whatever the signs): t = d0 / (d0 − d1) in double, position along the axis
//     (world index of p0 + t)·cell_m, the other two coordinates world index·cell_m; then rounded to float.
//     t ∈ [0, 1]; t = 1 exactly when d1 = 0 (a zero sample is air).
//   * Normal: g = central-difference gradient of the density at p0 and at p1 (double), n = −((1 − t)·g0 +
//     t·g1) normalised, rounded to float. Where that is zero or not finite, the unit axis vector of the
//     edge pointing from its solid end to its air end.
//   * Vertex order: by sample layer j (ascending), then row k, then the row's x edges, z edges and y edges
//     (the y edges from layer j to j + 1), each by i. Triangle order: by cell layer j, row k, cell i, then
//     the case table's order. Independent of the thread count: the work is split by layers of the block
//     on the current oneTBB arena, each layer's output written to its fixed place. Independent of the SIMD
//     target too (the per-layer kernels are compiled per Highway target; tested bit for bit). Reentrant:
//     blocks may be meshed concurrently (no shared mutable state).
//   * Cost: one bit per sample decides which rows and cells are skipped (words of 64 samples with no sign
//     change cost a few integer operations); work per vertex and per triangle otherwise. Memory besides
//     the mesh: about 0.7 byte per sample (sign bits, crossed-edge bits and per-word vertex counts).
//   * Errors (relief::Error, path = the field): `apron` < 1; `nx`/`ny`/`nz` < 2·apron + 2; `cell_m` not
//     finite and > 0; `d` whose size is not nx·ny·nz; `d` with nx·ny·nz ≥ 2³⁰ samples (32-bit vertex
//     indices: a block has at most 3 vertices per sample); `d` non-finite where a vertex needs it (a
//     crossed edge's samples or their central-difference neighbours). NaN elsewhere counts as air.
VolumeMesh mesh_density(const DensityBlock& b, int apron = 1);

}  // namespace relief
