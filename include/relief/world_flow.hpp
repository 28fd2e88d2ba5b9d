#pragma once
// A world algorithm for the global "flow" stage (src/stage_erosion.cpp, apply_flow), exact byte
// for byte against a whole-map run of the same recipe, holding one tile plus perimeter data in
// memory (issue 18; Barnes 2017, "Parallel non-divergent flow accumulation for trillion cell
// digital elevation models on desktops or clusters"). Implementation: src/world_flow.cpp.
//
// Input. `load` gives the height the stage reads. Either it already drains, in the sense of
// hydro::already_drains (hydrology.hpp: every sample that is not an outlet has a strictly lower
// neighbour; a fill stage ran before), so that apply_flow fills nothing and makes no lakes —
// flow_tiled checks this on every sample (with a one-sample halo across tiles) and throws
// Error(error_path, …) when it fails — or the caller also gives `filled`: the whole world's
// hydro::fill_depressions of that height with the stage's epsilon_m (as fill_depressions_tiled,
// relief/world.hpp, computes it tile by tile), and then lakes are made as apply_flow makes them.
//
// What it reproduces, per tile window (WorldGrid::window), bit for bit:
//   "height"  unchanged, or carved (carve_depth_coeff > 0) receivers-first as apply_flow does;
//   "flow"    float(double(count) · cell²), count = samples draining through the sample (64-bit);
//   "water"   river cover (point cover w / cell, or the anti-aliased disc where wider than a cell).
//   lakes     connected components (8-neighbours) of raised samples, labelled per tile and joined
//             across tiles by union-find over perimeter labels; kept by max depth and area (order-free
//             aggregates), so the layers need no lake's whole extent;
// and Terrain::rivers (whole polylines across tiles, same order, same values) and Terrain::lakes
// (same order, same records: each kept lake's samples are gathered and apply_flow's depth-first
// order replayed, so its sums add the same doubles in the same order — memory: the samples of all
// kept lakes, 30-60 bytes each); write_world_water writes their JSON files.
//
// Method. Ownership: tile (X, Z) owns the samples of its window minus its last column and row,
// except the last tile of a row or column, which owns them too: the owned rectangles partition the
// world. Receivers (D8, hydro::d8_receivers) of a tile's owned samples come from its window grown by
// one sample, the halo read from "bands": the heights within one sample of every inner tile border
// (3 · (nz·(tiles_x−1) + nx·(tiles_z−1)) floats), which each tile sets in pass A.
//   Pass A (each tile once, by anti-diagonals X + Z: a tile's halo lies in the tiles left of and
//     above it, which earlier diagonals solved): local accumulation inside the owned rectangle;
//     every perimeter sample p of it becomes a node with its local count and its link: the next
//     perimeter sample downstream inside the tile, or (an "exit") its receiver in the neighbouring
//     tile. Per tile result: its band heights, its nodes (node order), its components of raised
//     samples (count, max depth), whether it has land and its largest local count.
//   Global solve: a topological pass over the perimeter graph gives each node its inflow from
//     other tiles (64-bit integers; exact, order-free).
//   Pass S (rounds until no perimeter value changes, as the tiled fill does), only over the tiles
//     where a channel may be (some land, and the largest local count plus all inflow from other
//     tiles at the threshold; the others keep their initial perimeter values whatever happens):
//     each tile finishes counts from its entries' inflows, then channels, Strahler orders (the
//     orders of channel donors in other tiles as known so far: they only rise) and carving (the
//     carved heights of receivers in other tiles as known so far, starting uncarved: they only
//     fall). Both are monotone over a finite acyclic graph, so the rounds stop at the exact values.
//     Per tile result: its perimeter nodes' channel donors, orders and carved heights.
//   Pass W (in pass S's first round): every river disc's cover of a sample that is not inside the
//     disc's own owned rectangle (one entry per sample, the largest) goes into a map by world sample
//     (the disc radius is unbounded a priori, so no fixed halo); bucketed by tile before the final pass.
//   Final pass: each tile's layers, from its own solve, the perimeter nodes (shared samples it does
//     not own) and its cover entries. Per tile result: its layers, river pieces and lake samples.
// Threads: every pass solves tiles concurrently on the calling task arena's threads (pass A by
// diagonals, pass S and the tiled fill by classes of tiles that are never neighbours, X mod 2 and
// Z mod 2) and merges their results in a fixed order, so the bits, the stats and the order of the
// store calls are the same for any thread count.
// Memory: up to two tiles in flight per thread plus as many kept for reuse, each a grown tile and
// its solve (about 60 bytes a sample: ~60 MB in tiles of 1025), plus about 70 bytes per perimeter
// sample of the owned rectangles (4·T per tile: 16.8 M samples, ~1.2 GB, for a 65537² world in
// tiles of 1025), the height bands, the cover map (samples within a disc radius of tile borders,
// ~40 bytes each), a table of disc distances (at most 16 MiB), all river vertices and, with lakes,
// the samples of all kept lakes.
// Time: each tile is loaded and solved twice (A, final), plus once per pass-S round that needs it;
// pass S's rounds are bounded by the longest chain of tile crossings along a river whose order or
// carving changes.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "relief/output_interface.hpp"
#include "relief/terrain.hpp"
#include "relief/world.hpp"

namespace relief {

// The flow stage's parameters (the same names, defaults and units as its table in
// src/stage_erosion.cpp).
struct WorldFlowParams {
  bool lakes = true;  // depressions: "lakes" (true) or "fill"
  double epsilon_m = 0.0;
  double lake_min_depth_m = 1.0, lake_min_area_m2 = 5000.0;
  double river_area_km2 = 0.2;
  double runoff_mm_per_year = 1000.0;
  double width_coeff = 5.0, width_exponent = 0.5, min_width_m = 0.0;
  double carve_depth_coeff = 0.0;
};
// From the stage's resolved params (Stage::params()).
WorldFlowParams world_flow_params(const json& stage_params);

// One tile's results, each window.nx × window.nz samples (WorldGrid::window).
struct FlowTile {
  std::vector<float> height, flow, water;
};
using FlowTileStore = std::function<void(std::int64_t X, std::int64_t Z, FlowTile tile)>;

struct TiledFlowStats {
  std::int64_t tiles = 0;
  std::int64_t perimeter_nodes = 0;   // owned-rectangle perimeter samples of all tiles
  std::int64_t cross_links = 0;       // exits: samples draining into another tile
  int rounds = 0;                     // pass S rounds (the last one changes nothing)
  std::int64_t tile_solves = 0;       // tile solves in all passes
  std::int64_t channel_tiles = 0;     // tiles where a channel may be (the only ones pass S solves)
  std::uint64_t max_count = 0;        // largest drainage count (samples)
  std::size_t cover_cells = 0;        // entries of the cross-tile river cover map
  std::size_t river_pieces = 0;       // river pieces traced in tiles (when rivers were asked for)
  std::int64_t lakes = 0;             // depressions kept as lakes (with `filled`)
};

// Runs the flow stage over the world grid `grid` whose whole frame is `world` (cell size, height
// scale and sea level as the whole-map run uses them). `load(X, Z)` returns tile (X, Z)'s heights
// (the stage's input, window.nx × window.nz); `store(X, Z, tile)` receives its results once, in the
// final pass. When `rivers` is not null it receives Terrain::rivers of the whole-map run, equal
// field for field (whole polylines across tiles, in the same order); memory: all their vertices.
// `filled` (optional): see "Input" above. `lakes` (optional) receives Terrain::lakes, likewise.
// `load` and `filled` may be called concurrently for different tiles; `store` is called once per
// tile, in tile order (row-major), from one thread at a time.
// Throws Error(error_path, …) when the height does not already drain (see the top).
// `cancelled` (optional) is checked between tiles: true throws relief::Cancelled.
TiledFlowStats flow_tiled(const WorldGrid& grid, const Frame& world, const WorldFlowParams& params, const TileLoad& load,
                          const FlowTileStore& store, std::vector<River>* rivers = nullptr,
                          const std::function<bool()>& cancelled = {}, const std::string& error_path = "height",
                          const TileLoad& filled = {}, std::vector<Lake>* lakes = nullptr);

// Where a world's rivers and lakes go (the world frame, then Terrain::rivers and Terrain::lakes as
// the whole-map run makes them).
using WorldWaterSink = std::function<void(const Frame& world, std::vector<River> rivers, std::vector<Lake> lakes)>;

// The world algorithm for build_world (default_world_algorithms()["flow"]): flow_tiled over the
// stored tiles' "height" (WorldStageIO::load_layers when set: no other layer decoded), writing
// "height", "flow" and "water" into each tile (WorldStageIO::update when set: the other layers'
// coded bytes copied through); the rivers and lakes
// go to `water` when given, else (WorldStageIO::out set, as build_world sets it) into the world
// folder as rivers.json and lakes.json (write_world_water). When the height does not drain (no
// fill stage before this one), it first fills it as apply_flow does: fill_depressions_tiled
// (relief/world.hpp), keeping each tile's final border levels (4·T floats per tile), and gives
// flow_tiled each tile's filled heights as one hydro::fill_depressions_tile solve seeded with them.
WorldStageAlgorithm world_flow(WorldWaterSink water = {});

// rivers.json and lakes.json of a world, byte for byte those the whole-map run's writers
// (src/writer_water.cpp) write for the same rivers and lakes: the same writers, on a Terrain that
// holds only the world frame, the rivers, the lakes and an empty "flow" layer.
void write_world_water(const Frame& world, const std::vector<River>& rivers, const std::vector<Lake>& lakes, Output& out);

}  // namespace relief
