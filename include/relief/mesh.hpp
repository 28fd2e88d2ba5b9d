#pragma once
// Terrain and prop meshes: what the mesh writers (glb, fbx, obj) encode.
//
// Mesh conventions (all mesh writers):
//   * Y up, metres; a vertex of sample (i, j) sits at x = frame.x_m(i) + dx, y = frame.y_m(e),
//     z = frame.z_m(j) + dz, where (dx, dz) come from an optional two-channel layer "offset"
//     (vertex jiggle, metres; absent = 0). Triangles wind counter-clockwise seen from +Y.
//   * UV (u, v) = (i / (nx − 1), j / (nz − 1)) with v = 0 at image row 0 (the z-min edge), the
//     glTF convention (image top-left at uv 0,0). OBJ and FBX store 1 − v (their v = 0 is the
//     image bottom).
//   * Normals from central differences of the heights (one-sided at the window border).
//   * Terrains are cut into chunks of at most chunk_quads × chunk_quads cells; neighbouring chunks
//     share their border vertices bit for bit (the same sample gives the same vertex), and
//     simplification locks chunk borders, so chunks join without cracks.
#include <cstdint>
#include <string>
#include <vector>

#include "relief/export_options.hpp"
#include "relief/terrain.hpp"

namespace relief {

struct MeshData {
  std::vector<float> positions;  // x, y, z per vertex (metres)
  std::vector<float> normals;    // unit, per vertex
  std::vector<float> uvs;        // u, v per vertex (glTF convention); may be empty
  std::vector<float> colors;     // r, g, b per vertex in 0..1 (sRGB); may be empty
  std::vector<std::uint32_t> indices;  // triangles, counter-clockwise seen from outside
  std::size_t vertex_count() const { return positions.size() / 3; }
  std::size_t triangle_count() const { return indices.size() / 3; }
};

struct TerrainChunk {
  int cx = 0, cz = 0;  // chunk index along x and z
  MeshData mesh;
};

// The terrain as chunks in row-major chunk order (x fastest). `lod` 0 is the base mesh (full
// grid, or simplified by simplify_error_m / triangle_budget); lod k ≥ 1 is level k of the chain.
// style "lowpoly" unwelds every triangle (flat normals) and colours it from the colour layer at its
// centre ("albedo", else "color"; none = no colours). Throws Error on a missing or malformed height
// layer. Deterministic for any thread count.
std::vector<TerrainChunk> build_terrain_chunks(const Terrain& t, const ExportOptions& o, int lod = 0);
// LOD levels 1..levels at once (each simplified from the previous one): element k − 1 is level k.
std::vector<std::vector<TerrainChunk>> build_terrain_lod_chain(const Terrain& t, const ExportOptions& o, int levels);

// Prop models: low-poly, flat-shaded, vertex-coloured, base at y = 0, metres at scale 1.
const std::vector<std::string>& prop_types();  // tree, pine, bush, rock, cactus, mushroom, palm
MeshData prop_mesh(const std::string& type);   // throws Error("points", …) for an unknown type
// The terrain's props (points of kind "prop"), in order. Throws Error("points[k].type") for a type
// prop_mesh does not know.
std::vector<const Point*> terrain_props(const Terrain& t);

}  // namespace relief
