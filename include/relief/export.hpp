#pragma once
// Engine-ready exports: writer options, terrain and prop meshes, and the encoders behind the
// glb, fbx, stl, engine, normalmap, splat and hillshade writers.
//
// Writer options are declared once, in export_options_table(), like a stage's parameters: the
// table drives validation (errors name the option), the CLI flags (`--NAME` with '_' → '-'),
// `relief explain` and the docs. Nothing re-declares an option elsewhere.
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
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "relief/params.hpp"
#include "relief/terrain.hpp"

namespace relief {

// ---- writer options ----------------------------------------------------------------------------

// The choices of the writer options, read from their strings by export_options_table() (the
// strings of the recipe's "export" block and of the CLI flags; to_string gives them back).
enum class MeshStyle { Smooth, Lowpoly };
enum class Instancing { Nodes, Gpu };
enum class Engine { None, Unity, Unreal, Godot };
enum class GodotFormat { Exr, R16 };
enum class NormalConvention { Auto, OpenGl, DirectX };
enum class SplatSource { Auto, Biome, Rules };
const std::string& to_string(Engine e);  // "none", "unity", "unreal", "godot"

// How a caller names a writer option in errors: the CLI flag the user typed ("--engine") or the
// recipe path ("export.engine"). An empty OptionPath names it "export.NAME".
using OptionPath = std::function<std::string(const std::string& name)>;
std::string option_path(const OptionPath& path_of, const std::string& name);
struct ExportOptions {
  // Meshes (glb, fbx)
  int chunk_quads = 128;             // cells per chunk side
  double simplify_error_m = 0;       // 0 = no simplification
  std::int64_t triangle_budget = 0;  // 0 = no budget
  int lod_levels = 0;                // extra levels terrain_lod1.glb …
  double lod_error_m = 2.0;          // LOD k: error lod_error_m · 2^(k−1), ≥ 1/4^k of the triangles
  bool lod_msft = false;             // also put the chain into terrain.glb through MSFT_lod
  MeshStyle style = MeshStyle::Smooth;
  Instancing instancing = Instancing::Nodes;
  // STL
  double stl_size_mm = 150;
  double stl_exaggeration = 2.0;
  double stl_base_mm = 3.0;
  // Engines and maps
  Engine engine = Engine::None;
  std::string split = "1x1";    // tiles along x and z, "NxM"
  GodotFormat godot_format = GodotFormat::Exr;
  int normal_bits = 8;
  NormalConvention normal_convention = NormalConvention::Auto;
  SplatSource splat_source = SplatSource::Auto;
  double splat_rock_slope_deg = 35;
  double splat_rock_elevation = 0.7;
  double splat_snow_elevation = 0.85;
  double splat_beach_m = 4;
  double hillshade_azimuth_deg = 315;
  double hillshade_altitude_deg = 45;

  // Derived
  int split_x() const;
  int split_z() const;
  bool directx_normals() const;  // normal_convention, or the engine's (Unreal: DirectX)
};

const Table<ExportOptions>& export_options_table();
// Reads one option. `name` is the table name (underscores); `path` names it in errors (the CLI
// passes "--stl-size-mm"). Throws Error(path, …) for unknown names and bad values.
void set_export_option(ExportOptions& o, const std::string& name, const json& value, const std::string& path);
// Cross-field checks (split syntax, split and godot_format only with an engine that uses them,
// normal_bits ∈ {8, 16}). `path_of(name)` names an option in
// errors. Throws Error.
void validate_export_options(const ExportOptions& o, const std::function<std::string(const std::string&)>& path_of);

// ---- engine profiles ---------------------------------------------------------------------------
// Legal per-tile sample counts: Unity 2ⁿ+1 (33..4097); Unreal's recommended landscape sizes
// 127, 253, 505, 1009, 2017, 4033, 8129; Godot 2ⁿ+1 (33..16385, the Heightmap Terrain plugin's
// sizes). A terrain split into k tiles along an axis needs k·(t − 1) + 1 samples on that axis.
std::vector<int> engine_tile_sizes(Engine engine);
// The legal total size for `tiles` tiles closest to `wanted` (ties: the larger).
int engine_legal_size(Engine engine, int wanted, int tiles);
// Throws Error(path_of("engine"), …) unless nx and nz are legal for the options' engine and split;
// the message names `size_path` as the thing to change (the CLI passes its flag names: "--engine",
// "--size").
void check_engine_size(const ExportOptions& o, int nx, int nz, const OptionPath& path_of = {},
                       const std::string& size_path = "world.size");
// Option names as the command line's flags (--engine, --split) or as the recipe's fields
// (export.engine, world.size), for check_engine_size's and validate_export_options' path_of.
std::string cli_flag_path(const std::string& name);
std::string recipe_path(const std::string& name);

// ---- meshes ------------------------------------------------------------------------------------
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

// ---- encoders ----------------------------------------------------------------------------------
struct GlbFiles {
  std::string base;               // terrain.glb
  std::vector<std::string> lods;  // terrain_lod1.glb …
};
// The terrain as binary glTF 2.0: Y up, metres, one mesh per chunk (options chunk_size, style,
// simplify_error_m / triangle_budget), the albedo embedded as a PNG texture, the props as shared
// meshes or EXT_mesh_gpu_instancing (instancing), and with lod_levels > 0 one terrain_lodK.glb per
// level (also linked from the base file's chunks with MSFT_lod when lod_msft is set).
//   Reads:   the "height" layer (required, one channel, frame-sized); "albedo", else "color"
//            (three channels) for the texture or the low-poly face colours, when present; the
//            points of kind "prop". Other layers, rivers, lakes and the tilemap are not read.
//   Throws:  Error("height", …) on a missing or malformed height layer; Error("points[k].type", …)
//            for a prop type prop_mesh() does not know; Error("output", …) if serialisation fails;
//            std::bad_alloc. Nothing is returned or written on a throw.
//   Threads: reads `t` and `o` only, so any number of encoders may run at once on the same
//            terrain; meshing and simplification run row-parallel on the caller's oneTBB arena.
//   Bytes:   a function of (t, o) alone: the same for any thread count, run and machine with the
//            same build (no time stamps, no pointers, no unordered containers in the output).
GlbFiles encode_glb(const Terrain& t, const ExportOptions& o);
// The terrain as binary FBX 7.4 (the base mesh in chunks, Y up, metres through UnitScaleFactor 100;
// props as models sharing one geometry per type), with the albedo embedded as albedo.png.
//   Reads:   as encode_glb (no LOD chain: lod_levels and lod_msft are not read).
//   Throws:  as encode_glb, and Error("output", …) when the file would pass FBX 7.4's 4 GiB limit
//            or compression fails.
//   Threads, bytes: as encode_glb (the FBX time stamps are fixed values, not the clock).
std::string encode_fbx(const Terrain& t, const ExportOptions& o);
// Binary STL of a closed solid (top surface, skirt, base), millimetres, Z up, x east, y north.
std::string encode_stl(const Terrain& t, const ExportOptions& o);
// 32-bit float single-channel ("Y") EXR, ZIP compressed, of `values` (nx × nz, row-major).
std::string encode_exr_gray32(const std::vector<float>& values, int nx, int nz);

// Tangent-space normal map as RGB PNG (8 or 16 bits): R = +x, G = image up (OpenGL) or image down
// (DirectX), B = out of the surface; value = (n + 1) / 2.
std::string encode_normal_map(const Terrain& t, int bits, bool directx);
// Grey hillshade PNG (8-bit): Lambert n·L, light from azimuth (clockwise from north = −z) and
// altitude in degrees.
std::string encode_hillshade(const Terrain& t, double azimuth_deg, double altitude_deg);

struct SplatMaps {
  std::vector<std::string> images;  // splat0.png … RGBA 8-bit, weights summing to 255 across all images
  json description;                 // channel → layer name / biome id
};
// splat_source "biome" without a 'biome' layer throws Error(path_of("splat_source"), …).
SplatMaps encode_splat(const Terrain& t, const ExportOptions& o, const OptionPath& path_of = {});

}  // namespace relief
