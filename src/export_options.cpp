// Writer options: the one table (name, type, default, range, unit, description), validation, and
// the engine profiles' legal sizes.
#include <algorithm>
#include <cstdlib>
#include <string>

#include "relief/error.hpp"
#include "relief/export.hpp"

namespace relief {
namespace {

using O = ExportOptions;

const ChoiceNames<Engine> kEngineNames{
    {Engine::None, "none"}, {Engine::Unity, "unity"}, {Engine::Unreal, "unreal"}, {Engine::Godot, "godot"}};

Table<O> make_table() {
  Table<O> t;
  auto& f = t.fields;
  f.push_back(param(&O::chunk_quads, "chunk_quads", 8, 4096, "cells",
                    "glb/fbx: terrain chunk size in cells per side (one mesh per chunk; uint32 indices above 65535 vertices)"));
  f.push_back(param(&O::simplify_error_m, "simplify_error_m", 0, 10000, "m",
                    "glb/fbx: simplify the terrain mesh up to this geometric error (0 = full grid)"));
  f.push_back(param(&O::triangle_budget, "triangle_budget", 0, 2e9, "triangles",
                    "glb/fbx: simplify the terrain mesh to about this many triangles (0 = no budget)"));
  f.push_back(param(&O::lod_levels, "lod_levels", 0, 6, "", "glb: extra LOD levels written as terrain_lod1.glb …"));
  f.push_back(param(&O::lod_error_m, "lod_error_m", 0.001, 10000, "m",
                    "glb: LOD k allows an error of lod_error_m·2^(k-1) and keeps at least 1/4^k of the triangles"));
  f.push_back(param(&O::lod_msft, "lod_msft", 0, 1, "", "glb: also put the LOD chain into terrain.glb through MSFT_lod"));
  f.push_back(choice(&O::style, "style", {{MeshStyle::Smooth, "smooth"}, {MeshStyle::Lowpoly, "lowpoly"}},
                     "glb/fbx: smooth (textured) or lowpoly (flat-shaded faces coloured from the albedo)"));
  f.push_back(choice(&O::instancing, "instancing", {{Instancing::Nodes, "nodes"}, {Instancing::Gpu, "gpu"}},
                     "glb: props as nodes sharing one mesh per type, or EXT_mesh_gpu_instancing (used, not required)"));
  f.push_back(param(&O::stl_size_mm, "stl_size_mm", 10, 2000, "mm", "stl: print size of the longer horizontal side"));
  f.push_back(param(&O::stl_exaggeration, "stl_exaggeration", 0.1, 50, "x", "stl: vertical exaggeration"));
  f.push_back(param(&O::stl_base_mm, "stl_base_mm", 0.5, 100, "mm", "stl: base thickness under the lowest point"));
  f.push_back(choice(&O::engine, "engine", kEngineNames,
                     "engine heightmap profile: legal size, format, orientation, sidecar and import settings"));
  f.push_back(text(&O::split, "split", "engine: tiles along x and z, NxM, named _x0_y0 (unity, godot: neighbours share a border sample; unreal: edge to edge)"));
  f.push_back(choice(&O::godot_format, "godot_format", {{GodotFormat::Exr, "exr"}, {GodotFormat::R16, "r16"}},
                     "engine godot: 32-bit float EXR (metres) or r16"));
  f.push_back(param(&O::normal_bits, "normal_bits", 8, 16, "bits", "normalmap: 8 or 16 bits per channel"));
  f.back().info.values = {8, 16};  // validate_export_options refuses the others
  f.push_back(choice(&O::normal_convention, "normal_convention",
                     {{NormalConvention::Auto, "auto"}, {NormalConvention::OpenGl, "opengl"}, {NormalConvention::DirectX, "directx"}},
                     "normalmap: green channel +Y up (opengl) or down (directx); auto = directx for unreal"));
  f.push_back(choice(&O::splat_source, "splat_source", {{SplatSource::Auto, "auto"}, {SplatSource::Biome, "biome"}, {SplatSource::Rules, "rules"}},
                     "splat: weights from the biome layer or from height/slope rules (auto: biome if present)"));
  f.push_back(param(&O::splat_rock_slope_deg, "splat_rock_slope_deg", 1, 89, "deg", "splat rules: rock from this slope"));
  f.push_back(param(&O::splat_rock_elevation, "splat_rock_elevation", 0, 1, "",
                    "splat rules: rock from this normalised elevation (bare mountain tops)"));
  f.push_back(param(&O::splat_snow_elevation, "splat_snow_elevation", 0, 1, "",
                    "splat rules: snow from this normalised elevation"));
  f.push_back(param(&O::splat_beach_m, "splat_beach_m", 0, 1000, "m", "splat rules: sand up to this height above the sea"));
  f.push_back(param(&O::hillshade_azimuth_deg, "hillshade_azimuth_deg", 0, 360, "deg",
                    "hillshade: light direction, clockwise from north (the z-min edge)"));
  f.push_back(param(&O::hillshade_altitude_deg, "hillshade_altitude_deg", 1, 90, "deg", "hillshade: light altitude"));
  return t;
}

// "NxM" → (N, M), or (0, 0) when malformed.
std::pair<int, int> parse_split(const std::string& s) {
  auto x = s.find_first_of("xX");
  if (x == std::string::npos || x == 0 || x + 1 >= s.size() || s.size() > 9) return {0, 0};
  auto num = [](const std::string& t) {
    if (t.find_first_not_of("0123456789") != std::string::npos) return 0;
    return std::atoi(t.c_str());
  };
  return {num(s.substr(0, x)), num(s.substr(x + 1))};
}

}  // namespace

const std::string& to_string(Engine e) { return choice_name(kEngineNames, e); }

std::string option_path(const OptionPath& path_of, const std::string& name) {
  return path_of ? path_of(name) : "export." + name;
}

int ExportOptions::split_x() const { return std::max(1, parse_split(split).first); }
int ExportOptions::split_z() const { return std::max(1, parse_split(split).second); }
bool ExportOptions::directx_normals() const {
  return normal_convention == NormalConvention::DirectX ||
         (normal_convention == NormalConvention::Auto && engine == Engine::Unreal);
}

const Table<ExportOptions>& export_options_table() {
  static const Table<ExportOptions> t = make_table();
  return t;
}

void set_export_option(ExportOptions& o, const std::string& name, const json& value, const std::string& path) {
  const auto& t = export_options_table();
  std::vector<std::string> names;
  for (auto& f : t.fields) {
    if (f.info.name == name) {
      f.read(o, value, path);
      return;
    }
    names.push_back(f.info.name);
  }
  std::string near = nearest_name(name, names);
  throw Error(path, "unknown writer option" + (near.empty() ? std::string() : " (did you mean '" + near + "'?)"));
}

void validate_export_options(const ExportOptions& o, const std::function<std::string(const std::string&)>& path_of) {
  auto [sx, sz] = parse_split(o.split);
  if (sx < 1 || sz < 1 || sx > 64 || sz > 64)
    throw Error(path_of("split"), "expected NxM with 1..64 tiles per axis, e.g. 4x4, got \"" + o.split + "\"");
  if ((sx > 1 || sz > 1) && o.engine == Engine::None)
    throw Error(path_of("split"), "splitting writes engine tiles: choose an engine (unity, unreal or godot)");
  if (o.godot_format != GodotFormat::Exr && o.engine != Engine::Godot)
    throw Error(path_of("godot_format"), "applies to the godot engine: choose engine godot, or leave the format at exr");
  if (o.normal_bits != 8 && o.normal_bits != 16)
    throw Error(path_of("normal_bits"), "expected 8 or 16, got " + std::to_string(o.normal_bits));
  if (o.lod_msft && o.lod_levels == 0)
    throw Error(path_of("lod_msft"), "MSFT_lod needs a chain: set lod_levels to 1 or more");
}

std::vector<int> engine_tile_sizes(Engine engine) {
  std::vector<int> v;
  switch (engine) {
    case Engine::Unity:
      for (int n = 32; n <= 4096; n *= 2) v.push_back(n + 1);
      break;
    case Engine::Unreal: v = {127, 253, 505, 1009, 2017, 4033, 8129}; break;
    case Engine::Godot:
      for (int n = 32; n <= 16384; n *= 2) v.push_back(n + 1);
      break;
    case Engine::None: break;
  }
  return v;
}

int engine_legal_size(Engine engine, int wanted, int tiles) {
  int best = 0;
  const int ov = engine == Engine::Unreal ? 0 : 1;  // engine_tile_overlap (world_engine.hpp)
  for (int t : engine_tile_sizes(engine)) {
    const int n = tiles * (t - ov) + ov;
    if (best == 0 || std::abs(n - wanted) < std::abs(best - wanted) ||
        (std::abs(n - wanted) == std::abs(best - wanted) && n > best))
      best = n;
  }
  return best;
}

std::string cli_flag_path(const std::string& name) {
  std::string f = "--" + name;
  std::replace(f.begin(), f.end(), '_', '-');
  return f;
}
std::string recipe_path(const std::string& name) { return name == "size" ? "world.size" : "export." + name; }

void check_engine_size(const ExportOptions& o, int nx, int nz, const OptionPath& path_of, const std::string& size_path) {
  const auto sizes = engine_tile_sizes(o.engine);
  const std::string path = option_path(path_of, "engine");
  if (sizes.empty()) throw Error(path, "the engine writer needs an engine: unity, unreal or godot");
  const int kx = o.split_x(), kz = o.split_z();
  // Unity and Godot tiles share a border sample (n = k·(t − 1) + 1); Unreal's tiled import puts
  // tiles edge to edge (n = k·t): see relief/world_engine.hpp.
  const int ov = o.engine == Engine::Unreal ? 0 : 1;
  auto tile = [&](int n, int k) { return n > ov && (n - ov) % k == 0 ? (n - ov) / k + ov : 0; };
  const int tx = tile(nx, kx), tz = tile(nz, kz);
  const bool ok = tx != 0 && tx == tz && std::find(sizes.begin(), sizes.end(), tx) != sizes.end();
  if (ok) return;
  std::string list;
  for (int t : sizes) list += (list.empty() ? "" : ", ") + std::to_string(kx * (t - ov) + ov) + "x" + std::to_string(kz * (t - ov) + ov);
  throw Error(path, to_string(o.engine) + " needs " + (kx * kz > 1 ? "tiles of a legal square size; with split " + o.split + " that is " : "one of ") +
                        list + "; got " + std::to_string(nx) + "x" + std::to_string(nz) + " (use " + size_path + ")");
}

}  // namespace relief
