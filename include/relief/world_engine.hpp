#pragma once
// Engine tile sets and the LOD pyramid (issue 18): the engine heightmap tiles that `relief generate
// --engine E --split KxM` writes from one map, written by `relief world` from a tile store instead,
// byte for byte the same, in memory bounded by the engine tile (never the world); and a LOD pyramid
// of heightmap and colour tiles for CDLOD / clipmap renderers and map viewers.
//
// ---- how each engine tiles a split map (the one definition both writers use) -----------------
// A map of nx × nz samples split into kx × kz engine tiles of t × t samples (t from the engine's
// legal list, engine_tile_sizes in relief/export_options.hpp):
//   Unity, Godot  tiles overlap by one sample: tile (X, Y) holds samples [X·(t−1), X·(t−1) + t) along
//                 x (and the same along z), so nx = kx·(t−1) + 1. Each tile is its own terrain
//                 (Unity Terrain, a Godot heightmap-terrain node), placed edge to edge in metres
//                 ((t−1)·cell apart); neighbours must hold the same border samples or the terrains
//                 crack. Unity's terrain groups connect neighbours only by position (Terrain
//                 grouping ID, auto connect) and do not average their edges.
//   Unreal        tiles abut with no shared sample: tile (X, Y) holds samples [X·t, X·t + t), so
//                 nx = kx·t. Unreal 5's tiled import (Landscape > Import from File, World
//                 Partition) reads every `<name>_x<X>_y<Y>` file (all the same size) into one
//                 heightmap and copies tile (X, Y) to X·width, Y·height, edge to edge
//                 (GetImportDataInternal, LandscapeImportHelper.cpp); overlapping tiles would repeat
//                 a row and column at every seam.
// Tile (X, Y): X along +x, Y along our +z, named `<engine>_height_x<X>_y<Y>.<ext>` (no suffix
// for 1×1). File formats, orientation and value mapping: the README's Engines section and the
// sidecar `<engine>_height.json` (which both writers produce identically).
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "relief/export_options.hpp"
#include "relief/params.hpp"
#include "relief/terrain.hpp"

namespace relief {

// Samples shared by neighbouring engine tiles: 1 for Unity and Godot, 0 for Unreal.
int engine_tile_overlap(Engine e);

// The engine tile grid of a map (see the top of this file).
struct EngineTiling {
  Engine engine = Engine::None;
  GodotFormat godot_format = GodotFormat::Exr;
  int tiles_x = 1, tiles_z = 1;  // kx × kz
  int tile = 0;                  // t, samples per tile side
  int stride = 0;                // t − overlap: first sample of tile X is X·stride
  std::string extension() const;                  // ".raw", ".png", ".exr" or ".r16"
  std::string file_name(int X, int Y) const;      // "<engine>_height_x<X>_y<Y><ext>", or without suffix for 1×1
};
// Checks that nx × nz is legal for the options' engine and split (check_engine_size: Error naming
// option_path(path_of, "engine"), mentioning `size_path`) and returns the tiling.
EngineTiling engine_tiling(const ExportOptions& o, int nx, int nz, const OptionPath& path_of = {},
                           const std::string& size_path = "world.size");
// The bytes of one engine tile: `h` holds t × t normalised elevations (t = tiling.tile) in our
// layout (row-major, x fastest, row 0 at the tile's z-min edge); the encoder applies the engine's
// flip and value mapping (16-bit: round(clamp(e, 0, 1)·65535); EXR: metres, `world.y_m(e)` as float).
std::string encode_engine_tile(const EngineTiling& tiling, const Frame& world, const float* h);
// `<engine>_height.json` and `<engine>_import.txt` of the whole tile set. `world` is the whole map's
// frame (ix0 = iz0 = 0, nx × nz samples); only its spacing, origin, height_m and sea_level are read.
std::string engine_sidecar(const EngineTiling& tiling, const Frame& world);
std::string engine_import_text(const EngineTiling& tiling, const Frame& world);

// ---- from a world's tile store -----------------------------------------------------------------
// The LOD pyramid (lod/ in the store's folder). Level 0 is the store's own tile grid at full
// resolution: tile (X, Z) of level k covers world samples
//     ix = X·(T−1)·2^k + i·2^k,   iz = Z·(T−1)·2^k + j·2^k,   0 ≤ i, j < T,
// keeping only those inside the world (ix ≤ nx−1, iz ≤ nz−1), so its size is
//     min(T, floor((nx−1 − X·(T−1)·2^k) / 2^k) + 1) along x (likewise z),
// for X < ceil((nx−1) / ((T−1)·2^k)). Level k is level k−1 point-sampled at every other sample:
// sample (i, j) of level-k tile (X, Z) is sample (2i − (T−1)·a, 2j − (T−1)·b) of level-(k−1) tile
// (2X + a, 2Z + b), where a = 1 if 2i > T−1 else 0 (and 2i = T−1 is the shared border, the same
// value in both children). No filter: every level's samples are world samples, bit for bit, so
// neighbouring tiles of every level share their borders exactly and a renderer can morph between
// levels at the coarser level's vertices. The last level is the first with one tile (the whole
// world in at most T × T samples).
// Files per tile: lod/<k>/x<X>_z<Z>.png — 16-bit greyscale PNG, value = round(clamp(e, 0, 1)·65535)
// of the normalised elevation e (metres: (e − sea_level)·height_m, in lod/lod.json), row 0 at the
// z-min edge, column = +x; and lod/<k>/x<X>_z<Z>_color.png — 8-bit RGB of the "color" layer
// (round(clamp(c, 0, 1)·255)) when the world has one. lod/lod.json lists the levels (tile size,
// sample spacing in metres, tile counts) and the value mapping.
struct WorldExportSettings {
  std::string store_dir;     // a complete tile store (build_world's output folder)
  ExportOptions options;     // engine, split, godot_format (engine None: no engine tile set)
  bool lod = false;          // write the LOD pyramid
  std::string engine_subdir = "engine";  // under store_dir: the engine tile set
  std::string lod_subdir = "lod";        // under store_dir: the pyramid
  // (An earlier export's files in these folders — engine tile set names; the level folders and
  // lod.json — are removed first, so a changed split or world leaves no stale tiles.)
  OptionPath option_path;    // how errors name the options (the CLI: "--engine", "--split")
  std::string size_path = "world.size";
  std::function<void(std::string_view what, double fraction)> progress;  // optional
  std::function<bool()> cancelled;  // optional; true stops with relief::Cancelled between tiles
};
struct WorldExportReport {
  std::vector<std::string> files;  // relative to store_dir, in the order written
  std::uint64_t bytes = 0;
  int engine_tiles = 0;
  int lod_levels = 0;  // levels written (0 without lod)
  std::int64_t lod_tiles = 0;
};
// Throws Error (naming the option as settings.option_path does) when the world's size does not fit
// the engine's tiling (check before a build with check_world_export, which needs no store).
void check_world_export(const ExportOptions& o, std::int64_t nx, std::int64_t nz, const OptionPath& path_of = {},
                        const std::string& size_path = "world.size");
// Writes the engine tile set and/or the LOD pyramid from the store (every file atomically: temporary
// file, rename). Memory: one engine tile's heights (t² floats, assembled from the store tiles) plus
// one decoded store tile; for the pyramid, about two tiles per level. Throws Error("output", …) when
// the store is missing or unfinished, Error("tile", …) for a damaged tile, Error naming the engine
// option when the world's size does not fit the tiling.
WorldExportReport export_world(const WorldExportSettings& s);

}  // namespace relief
