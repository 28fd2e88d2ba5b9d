#pragma once
// Tilemaps: inside-outside (corner) tiles for k terrain types, generated tilesets, Tiled export.
//
// Sources:
//   * D. Lee, M. Goban, L. Taranowski, "Landscape Generation Using Perlin Noise" (seed 002): four
//     corner samples per tile, each classified into one of k vertex types, read in the order
//     top-left, top-right, bottom-left, bottom-right as a base-k number that indexes one of k⁴
//     tiles (land at the top-left corner alone is binary 1000 = 8); water takes precedence where
//     types meet, and the suggested fix for the missing land bridges: both variants of the
//     ambiguous saddle tile, picked at random (here: from a hash of the seed and the tile).
//   * W. E. Lorensen, H. E. Cline, "Marching Cubes", SIGGRAPH 1987, in its 2D form (marching
//     squares): the boundary inside a cell follows an iso-line of the interpolated corner values,
//     crossing each mixed edge at its midpoint for 0/1 corners; the saddle cell is the ambiguous case.
//   * Tiled's Wang sets (Tiled manual, "Terrains"; TMX format, <wangset>/<wangtile>): a corner set
//     lists for each tile a `wangid` of 8 colours in the order top, top-right, right, bottom-right,
//     bottom, bottom-left, left, top-left; a corner set uses the odd slots, 0 means none and wang
//     colours are 1-based.
//
// Conventions (stated once):
//   * The tile grid has tiles_x × tiles_z tiles and (tiles_x + 1) × (tiles_z + 1) vertices. Tile
//     (u, v) is column u (+x, east) and row v (+z, south); "top" is image row 0, the z-min edge,
//     as for every Relief image. Its corners are TL = vertex (u, v), TR = (u + 1, v),
//     BL = (u, v + 1), BR = (u + 1, v + 1).
//   * The grid stretches over the terrain's window: vertex (u, v) sits at fractional sample
//     position fi = u · (nx − 1) / tiles_x, fj = v · (nz − 1) / tiles_z of the height grid (exact
//     rational arithmetic), i.e. at world x = x0_m + fi · cell_m, z = z0_m + fj · cell_m. When
//     tiles_x divides nx − 1 (e.g. 513 samples, 128 tiles) every vertex falls exactly on a sample.
//   * Types are ordered 0..k−1 (for elevation: deep water, water, sand, …, snow), 2 ≤ k ≤ 8.
//   * Tile indices (the tileset's local tile ids; TMX/TMJ gids are index + 1):
//       base tiles      0 .. k⁴ − 1        index = TL·k³ + TR·k² + BL·k + BR
//       saddle variants k⁴ + r, r = 0 .. k(k−1) − 1: the ambiguous tile TL = BR = a, TR = BL = b
//                       (a ≠ b) with the other type connected through the centre; r enumerates
//                       (a, b) in increasing base index: r = a·(k − 1) + (b < a ? b : b − 1)
//       solid variants  k⁴ + k(k−1) + t, t = 0 .. k − 1: all four corners t, another texture
//     k⁴ + k² tiles in all, laid out in the atlas with k² columns and k² + 1 rows (index i at
//     column i mod k², row i div k²), so base tiles sit at row TL·k + TR, column BL·k + BR.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "relief/params.hpp"
#include "relief/terrain.hpp"

namespace relief {

constexpr int kMinTileTypes = 2;
constexpr int kMaxTileTypes = 8;

// Corner types in the seed's order, each in 0..k−1.
struct TileCorners {
  int tl = 0, tr = 0, bl = 0, br = 0;
  bool operator==(const TileCorners&) const = default;
};

int base_tile_count(int k);       // k⁴
int saddle_variant_count(int k);  // k(k−1)
int tile_count(int k);            // k⁴ + k²: base, saddle variants, solid variants
int atlas_columns(int k);         // k²
int atlas_rows(int k);            // k² + 1

// TL·k³ + TR·k² + BL·k + BR. Corners must be in 0..k−1 (throws Error("tile", …) otherwise).
int tile_index(const TileCorners& c, int k);
// Corners of any tile index in 0..tile_count(k)−1 (variants give their base tile's corners).
// Throws Error("tile", …) for an index out of range.
TileCorners tile_corners(int index, int k);
// TL = BR ≠ TR = BL: the one tile whose centre is ambiguous (marching squares' saddle).
bool is_saddle(const TileCorners& c);
// Index of the saddle variant of a saddle tile (throws Error("tile", …) for a non-saddle).
int saddle_variant_index(const TileCorners& c, int k);
// Index of the second solid tile of type t.
int solid_variant_index(int type, int k);

// Which type wins where types meet inside a tile.
//   Lower:  the lowest type present takes precedence (seed 002: water wins, so only narrow straits)
//   Higher: the highest type present takes precedence (land wins: narrow bridges, no straits)
enum class Precedence { Lower, Higher };

// What one tile looks like, without colour: its corners, the type favoured in its interior
// (precedence; in a saddle variant, the other one) and whether it uses the alternative texture.
struct TileShape {
  TileCorners corners;
  int favoured = 0;
  bool alt_texture = false;
  Precedence precedence = Precedence::Lower;  // orders exact ties after the favoured type
};
TileShape tile_shape(int index, int k, Precedence p);

// One terrain type: name (also picks its texture, see below), colour, and for elevation
// classification the highest elevation it covers (the first type with e ≤ max_elevation wins; the
// last type takes everything above).
struct TileType {
  std::string name;
  Rgb color;
  double max_elevation = 1.0;
};

// How tiles are drawn.
//   Texture kinds by keyword in the type's name (case-insensitive, first match): deep/water/sea/
//   ocean/lake/river → ripples; sand/beach/desert/dune → speckle; grass/meadow/field/plain →
//   tufts; forest/wood/tree/jungle → crowns; rock/stone/mountain/cliff → cracks; snow/ice/glacier
//   → faint drifts; anything else → soft mottling. Every texture repeats with the tile (period =
//   tile_px pixels on both axes), so tiles of one type join without seams.
struct TileStyle {
  int tile_px = 32;                 // 8..128
  std::vector<TileType> types;      // k = types.size(), 2..8
  Precedence precedence = Precedence::Lower;
  double texture = 1.0;             // texture strength, 0 = flat colours
  double edges = 1.0;               // strength of the shore/outline where types meet, 0 = none
  std::uint64_t seed = 0;           // texture seed
  int k() const { return int(types.size()); }
};
// Throws Error naming `path`.field for an invalid style (tile_px, k, strengths).
void validate_style(const TileStyle& s, const std::string& path);

// Per-pixel shape of a tile: S × S type ids, row-major, row 0 at the top. Each pixel takes the
// type with the largest score among the tile's corner types at the pixel centre, where
//   score_t(x, y) = Σ_{corners of type t} w_corner(s(x), s(y)) + [saddle and t favoured] · β · ((16·x(1−x)·y(1−y))²)
// with x, y ∈ (0, 1) the position in the tile, s(x) = 3x² − 2x³ (smoothstep) and w the bilinear
// corner weights, β = 0.18. The smoothstep makes the corner fields flat across tile edges, so
// boundaries cross an edge at its midpoint and at a right angle, and neighbouring tiles join
// smoothly. In a saddle tile both types score exactly ½ at the centre: the bump opens a channel
// for the favoured type (precedence, or the other type in the saddle variant); it vanishes with
// its derivative on the edges, so it never breaks a seam. Elsewhere the shape is symmetric in
// the types; exact ties go to the favoured type, then to precedence order.
std::vector<std::uint8_t> tile_type_map(const TileShape& shape, int S);

// 8-bit RGB image, row-major, 3 bytes per pixel, row 0 at the top.
struct RgbImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
};

// One tile drawn at style.tile_px (4×4 supersampled shape, per-type texture, edge lines).
RgbImage render_tile(int index, const TileStyle& style);
// The atlas: every tile of tile_count(k) at its place (see the layout above).
RgbImage render_atlas(const TileStyle& style);

// A generated tilemap: the output of the "tilemap" stage.
struct TileMap {
  TileStyle style;
  int tiles_x = 0, tiles_z = 0;
  std::vector<std::uint8_t> corner_v;  // (tiles_x+1)·(tiles_z+1) vertex types: vertex (u, v) at v·(tiles_x+1) + u
  std::vector<std::uint32_t> tile_t;   // tiles_x·tiles_z tile indices: tile (u, v) at v·tiles_x + u
  // What decided the corner types: elevation thresholds or the biome layer ("elevation" or
  // "biome" in the sidecar, as in the stage's `classify`).
  enum class Classify { Elevation, Biome } classify = Classify::Elevation;
  TileCorners corners(int u, int v) const;
};

// Picks the tile of every cell from corner_v: the base index, replaced by its saddle variant when
// unit_double(hash64(seed, u, v)) < saddle_variants, and an all-t tile by its solid variant when
// unit_double(hash64(seed ^ salt, u, v)) < solid_variants. Fills m.tile_t.
void choose_tiles(TileMap& m, std::uint64_t seed, double saddle_variants, double solid_variants);

// The map drawn by copying each tile's atlas cell: tiles_x·S × tiles_z·S pixels.
RgbImage render_map(const TileMap& m, const RgbImage& atlas);

// ---- Tiled export (Tiled 1.8 formats) -------------------------------------------------------
// File names used by the writer.
inline constexpr const char* kTilesetPng = "tileset.png";
inline constexpr const char* kTilesetTsx = "tileset.tsx";
// The tileset: image, tile count, one corner Wang set "terrain" with one colour per type.
std::string encode_tsx(const TileStyle& s, const std::string& image = kTilesetPng);
// Orthogonal maps with one tile layer "terrain" (CSV data in TMX, an array in TMJ), referring to the
// external tileset `tsx` with firstgid 1.
std::string encode_tmx(const TileMap& m, const std::string& tsx = kTilesetTsx);
std::string encode_tmj(const TileMap& m, const std::string& tsx = kTilesetTsx);
// tiles_z lines of tiles_x comma-separated tile indices (0-based local ids, not gids).
std::string encode_tile_csv(const TileMap& m);

// Default types for elevation classification, written for sea level 0.4:
// deep water, water, sand, grass, forest, rock.
std::vector<Level> default_tile_types();

}  // namespace relief
