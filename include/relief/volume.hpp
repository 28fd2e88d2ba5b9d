#pragma once
// Volumes: caves, overhangs and arches on top of the heightfield.
//
// A heightfield holds one height per position; a cave, an overhang or an arch needs a density
// volume. Relief keeps the heightfield pipeline as it is and adds a sparse density band around
// its surface, described by a VolumeSpec that the volume stages ("volume", "overhangs", "caves")
// leave on the Terrain and that the volume writers (caves.glb, caves.obj, caves.vdb) evaluate
// chunk by chunk. Nothing of the volume is held in memory between chunks.
//
// Density (positive in rock, negative in air, the surface is its 0 level set), in metres:
//   base(x, y, z) = (H(x', z') − y) / √(1 + |∇H(x, z)|²)
//     H: the surface height in metres above the sea surface (frame.y_m of the "height" layer),
//        bilinear between samples, clamped at the world's edge; (x', z') = (x, z) unless an
//        "overhangs" stage warps them (below). The division makes it a first-order signed distance
//        near the surface (vertical distance times the cosine of the slope).
//   overhangs: (x', z') = (x, z) + w(x, z)·strength_m·(n₁(x, y·vertical, z), n₂(…)): a 3D domain warp
//        of the surface (Quilez), whose weight w in 0..1 rises with the slope (smoothstep between
//        min_slope_deg and min_slope_deg + 20°) of the steepest height sample within strength_m
//        (a square max filter: the ground in front of a cliff moves with it, so the cliff can lean
//        out over it), times the optional mask layer. Steep cliffs lean out, undercut and pinch into
//        mushroom rocks and arches while gentle ground stays a heightfield.
//   caves: where density > 0, density ← density − g·max(0, density − carve) (= min(density, carve)
//      where the gate g is 1), carve ≥ 0 in rock outside the caves and < 0 inside:
//        cheese  (threshold − n(x, y·stretch, z))·L          large chambers
//        spaghetti (√(n₁² + n₂²) − radius)·L                 long tunnels where two noises are ≈ 0
//        noodle    the same, thinner and at a higher frequency
//      g in 0..1 is a product of smoothsteps of the depth below the local surface H(x, z) − y (no
//      carving within cover_m of it, except at entrances, where cover_m fades to 0 and tunnels break
//      through; none deeper than max_depth_m) and of y (nothing carved below the sea surface unless
//      flooded). L converts noise units to
//      metres (wavelength / 2π), so the carve is a rough distance too.
//   closed: density = min(density, distance to the walls of the band's box), so the mesh is a closed
//      solid (sides half a voxel beyond the world's edge, a flat base below the band, both between
//      sample layers) that engines, Blender and 3D printers take without holes.
//   Finally a sample within δ = 10⁻³ voxel of 0 is moved to ±δ (0 to −δ, air), so no sample lies on
//   the surface (the vertices of all its crossed edges would meet in one point: zero-area triangles).
// All noise is 3D (relief/noise3.hpp) in world coordinates, seeded from the recipe seed and the
// stage index: any chunk of the world gives the same values, whatever the chunk or thread.
//
// Voxel grid: voxel (i, j, k) sits at (i·voxel_m, j·voxel_m, k·voxel_m) metres, y up with the sea
// surface at y = 0; i runs from −1 to round(world_width_m / voxel_m) + 1 (one voxel beyond each
// side, outside a closed volume's walls), likewise k; j spans the band. Chunks are blocks of `chunk` cells on each
// axis that share their boundary sample layers (relief/volume_mesh.hpp), so neighbouring chunks'
// seam vertices coincide exactly.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "relief/mesh.hpp"
#include "relief/noise.hpp"
#include "relief/terrain.hpp"
#include "relief/volume_mesh.hpp"

namespace relief {

struct OverhangSpec {
  NoiseSettings noise;  // basis, fractal, octaves, frequency, seed: the warp noises (n₂ uses seed + 1)
  double strength_m = 12.0;
  double min_slope_deg = 35.0;
  double vertical = 1.0;  // y frequency factor of the warp noise (< 1: taller, column-like forms)
  std::string mask;       // optional one-channel layer 0..1 multiplying the weight ("" = none)
};

struct CaveSpec {
  NoiseSettings cheese, spaghetti, noodle;  // the noises (spaghetti/noodle: n₂ uses seed + 1)
  bool has_cheese = true, has_spaghetti = true, has_noodle = true;
  double cheese_threshold = 0.45;  // carve where n > threshold
  double cheese_stretch = 2.0;     // y frequency factor (> 1: flatter chambers)
  double spaghetti_radius = 0.07;  // noise units
  double noodle_radius = 0.035;
  double cover_m = 6.0;            // rock kept above a cave (except at entrances)
  double max_depth_m = 60.0;       // nothing carved deeper than this below the local surface
  double entrances = 0.15;         // 0..1: share of the surface where tunnels may open
  NoiseSettings entrance;          // 2D noise picking where entrances are
  bool flooded = false;            // carve below the sea surface too
};

struct VolumeSpec {
  // The recipe path of the "volume" stage that set the band ("stages[5]"); empty when the band has
  // its defaults. Errors about the band name `<path>.voxel_m` (or `volume.voxel_m` when empty).
  std::string path;
  double voxel_m = 0.0;  // 0: the frame's sample spacing
  int chunk = 32;        // cells per chunk edge
  double base_m = 20.0;  // rock kept below the lowest surface (closed volumes' base)
  bool closed = true;
  float rock_color[3] = {0.42f, 0.38f, 0.34f};  // sRGB 0..1: cave walls, cliffs and undersides
  int max_chunks = 4000000;                      // refused beyond this (volume_grid)
  std::vector<OverhangSpec> overhangs;  // applied in recipe order
  std::vector<CaveSpec> caves;
};

// What evaluating a VolumeSpec over a terrain gives: the chunk grid and its meshes.
struct VolumeChunkMesh {
  int cx = 0, cy = 0, cz = 0;  // chunk index
  // World metres, y up (sea surface 0), counter-clockwise seen from the air; normals from the
  // density gradient; colours (sRGB 0..1) from the albedo layer ("albedo", else "color") on the
  // ground's top surface, rock_color on walls, overhangs and inside caves; no UVs.
  MeshData mesh;
};

struct VolumeGrid {
  double voxel_m = 1.0;
  int chunk = 32;
  std::int64_t i0 = -1, j0 = 0, k0 = -1;  // voxel index of the grid's first sample on each axis
  std::int64_t ni = 0, nj = 0, nk = 0;     // samples on each axis
  int chunks_x = 0, chunks_y = 0, chunks_z = 0;
  double y_bottom_m = 0, y_top_m = 0;      // the band's box (closed volumes' walls)
  std::int64_t surface_chunks = 0;          // chunks that will be evaluated (classified Surface)
  // Estimated bytes of the whole mesh held at once (the GLB writer): surface chunks × chunk² cells ×
  // 2 triangles × (36 bytes of vertex data per triangle, half a vertex each, plus 12 of indices),
  // twice (the model and the encoded file). Caves add surface: the estimate is a floor.
  double mesh_bytes_estimate() const { return double(surface_chunks) * chunk * chunk * 2.0 * (18.0 + 12.0) * 2.0; }
};

// The grid the spec covers on this terrain (needs the "height" layer). Throws relief::Error
// naming `<path>.voxel_m` / `<path>.chunk` (path: VolumeSpec::path, else "volume") when the band
// would need more than max_chunks chunks (estimated before anything is evaluated).
VolumeGrid volume_grid(const Terrain& t, const VolumeSpec& spec);

// How a chunk was classified before evaluating it.
enum class ChunkKind { Air, Solid, Surface };

struct VolumeStats {
  std::int64_t chunks = 0, air = 0, solid = 0, evaluated = 0, meshed = 0;
  std::int64_t voxels_evaluated = 0, triangles = 0, vertices = 0;
  double evaluate_s = 0, mesh_s = 0;  // summed over threads
};

// The density samples of chunk (cx, cy, cz) with a 1-sample apron: (chunk + 3)³ samples starting
// at voxel (i0 + cx·chunk − 1, …). Pure function of (terrain, spec, chunk): bit-identical for any
// thread and any order.
DensityBlock evaluate_chunk(const Terrain& t, const VolumeSpec& spec, const VolumeGrid& g, int cx, int cy, int cz,
                            std::uint64_t seed);
// The chunk's kind from the band's bounds (cheap: no noise is evaluated). Air and Solid chunks
// hold no surface (Solid chunks touching a closed volume's walls are Surface).
ChunkKind classify_chunk(const Terrain& t, const VolumeSpec& spec, const VolumeGrid& g, int cx, int cy, int cz);

// Evaluates and meshes every Surface chunk (in parallel over the caller's oneTBB arena), calling
// `sink` once per chunk with a mesh, in chunk order (y, then z, then x) from the calling thread:
// the bytes of what the sink sees are the same for any thread count. `progress` (may be empty)
// gets the fraction of chunks done; `cancelled` (may be empty) is asked between batches of chunks,
// and true stops the call with relief::Cancelled.
VolumeStats mesh_volume(const Terrain& t, const VolumeSpec& spec, std::uint64_t seed,
                        const std::function<void(VolumeChunkMesh&&)>& sink,
                        const std::function<void(double)>& progress = {}, const std::function<bool()>& cancelled = {});

// Evaluates every Surface chunk (in parallel) and calls `sink` with each chunk's density block (the
// chunk's samples plus the 1-sample apron), in chunk order, from the calling thread (the .vdb writer).
VolumeStats evaluate_volume(const Terrain& t, const VolumeSpec& spec, std::uint64_t seed,
                            const std::function<void(int cx, int cy, int cz, const DensityBlock&)>& sink,
                            const std::function<void(double)>& progress = {}, const std::function<bool()>& cancelled = {});

}  // namespace relief
