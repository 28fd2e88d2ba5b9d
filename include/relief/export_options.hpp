#pragma once
// Writer options and engine profiles: what the writers are told, and which sizes an engine takes.
//
// Writer options are declared once, in export_options_table(), like a stage's parameters: the
// table drives validation (errors name the option), the CLI flags (`--NAME` with '_' → '-'),
// `relief explain` and the docs. Nothing re-declares an option elsewhere.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "relief/params.hpp"

namespace relief {

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

}  // namespace relief
