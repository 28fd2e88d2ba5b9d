#pragma once
// Internal: PNG textures tiled in world space, used instead of a flat colour by colour levels
// (the `color` stage, each biome type's gradient) and by whole biome types. Seed 000 wanted users
// to upload a texture per level or biome; a texture here is any PNG libspng decodes (grey, palette,
// RGB, with or without alpha — alpha is ignored), repeated every tile_m metres along world x and z,
// sampled bilinearly with wrap-around. Image row 0 lies at the tile's z-min edge.
#include <memory>
#include <string>
#include <vector>

#include "relief/params.hpp"

namespace relief::detail {

struct Texture {
  int width = 0, height = 0;
  std::vector<float> rgb;  // width · height · 3 values in 0..1, row-major
  // Bilinear sample of the tile repeated every tile_m metres (tile_m > 0).
  Rgb sample(double x_m, double z_m, double tile_m) const;
};

// Loads (and caches, keyed by path, size and modification time) a PNG texture of at most
// 8192×8192 pixels. Throws Error(field_path, …) naming the file when it is missing, unreadable or
// not a PNG: e.g. `stages[2].types[1].texture: cannot read texture 'sand.png': No such file or
// directory`. Thread-safe.
std::shared_ptr<const Texture> load_texture(const std::string& file, const std::string& field_path);

// The textures of a list of colour levels (nullptr where a level has a flat colour). Throws like
// load_texture with `levels_path[k].texture`.
std::vector<std::shared_ptr<const Texture>> load_level_textures(const std::vector<Level>& levels,
                                                                const std::string& levels_path);

// The colour of a value v through colour levels at world position (x_m, z_m): each level's
// colour is its texture sample when it has one, else its flat colour.
//   bands:    the first level with v ≤ at; above the last `at`, the last level.
//   gradient: each level sits at its `at`, linear in between; the first below, the last above.
// Comparisons are made in single precision, the precision of the layers.
Rgb level_color(const std::vector<Level>& levels, const std::vector<std::shared_ptr<const Texture>>& textures,
                bool gradient, float v, double x_m, double z_m);

}  // namespace relief::detail
