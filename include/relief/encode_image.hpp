#pragma once
// Image encoders: PNG, raw 16-bit and EXR bytes of layers, and the map writers' images (normal
// map, hillshade, splat maps). Every encoder here:
//   Threads: reads its arguments only (const), keeps no state: any number may run at once; the map
//            images spread their rows over the caller's oneTBB arena.
//   Bytes:   a function of its arguments alone (no time stamps or other metadata that vary), the
//            same for any thread count, run and machine with the same build.
//   Throws:  relief::Error as stated below, std::bad_alloc; nothing is returned on a throw.
// Images are row-major, row 0 the z-min (north) edge, column = +x (the layers' own layout).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "relief/export_options.hpp"
#include "relief/params.hpp"
#include "relief/terrain.hpp"

namespace relief {

// ---- layers as images ------------------------------------------------------------------------
// The Layer forms throw Error("layer", …) when the layer's channel count or size does not match
// (nx × nz samples); every PNG form throws Error("output", …) when encoding fails.
// 16-bit greyscale PNG of a one-channel layer, value = round(clamp(v, 0, 1) · 65535).
std::string encode_png_gray16(const Layer& l, int nx, int nz);
// 8-bit RGB PNG of a three-channel layer in 0..1.
std::string encode_png_rgb8(const Layer& l, int nx, int nz);
// 8-bit RGB PNG of width × height pixels, 3 bytes per pixel, row-major (row 0 at the top). Uses the
// SUB filter on every row (fast for large, flat-coloured images such as tilemap renders).
std::string encode_png_rgb8(const std::uint8_t* rgb, int width, int height);
// 8-bit greyscale PNG of a one-channel layer in 0..1.
std::string encode_png_gray8(const Layer& l, int nx, int nz);
// Little-endian unsigned 16-bit raw, same mapping as the PNG.
std::string encode_r16(const Layer& l);
// PNG of ready pixels: `channels` 1 (grey), 2 (grey+alpha), 3 (RGB) or 4 (RGBA) samples of
// `bit_depth` 8 or 16 bits (16-bit samples in host byte order), rows top to bottom.
std::string encode_png_pixels(const void* pixels, std::size_t bytes, int width, int height, int bit_depth, int channels);

// ---- the map writers' images ------------------------------------------------------------------
// 32-bit float single-channel ("Y") EXR, ZIP compressed, of `values` (nx × nz, row-major). Throws
// Error("output", …) on a size mismatch or when OpenEXR fails.
std::string encode_exr_gray32(const std::vector<float>& values, int nx, int nz);

// Tangent-space normal map as RGB PNG (8 or 16 bits): R = +x, G = image up (OpenGL) or image down
// (DirectX), B = out of the surface; value = (n + 1) / 2; normals from central differences
// (one-sided at the border).
//   Reads:   the "height" layer only (and the frame's spacing and height_m).
//   Throws:  Error("formats", …) without a height layer, Error("height", …) for a malformed one,
//            Error("normal_bits", …) unless bits is 8 or 16.
std::string encode_normal_map(const Terrain& t, int bits, bool directx);
// Grey hillshade PNG (8-bit): Lambert n·L, light from azimuth (clockwise from north = −z) and
// altitude in degrees; no ambient term, the sea shaded like the land (the hillshade stage's picture
// differs: it has both).
//   Reads:   the "height" layer only. Throws: as encode_normal_map (no bits).
std::string encode_hillshade(const Terrain& t, double azimuth_deg, double altitude_deg);

struct SplatMaps {
  std::vector<std::string> images;  // splat0.png … RGBA 8-bit, weights summing to 255 across all images
  json description;                 // channel → layer name / biome id
};
// Splat (texture weight) maps: one weight per biome id (splat_source "biome", or "auto" with a
// biome layer), else four rule layers sand, grass, rock, snow from elevation, slope and the sea
// (splat_rock_slope_deg, splat_rock_elevation, splat_snow_elevation, splat_beach_m).
//   Reads:   the "height" layer; the "biome" layer when used; the options named above.
//   Throws:  Error("formats", …) / Error("height", …) as encode_normal_map; splat_source "biome"
//            without a 'biome' layer: Error(path_of("splat_source"), …); Error("biome", …) for a
//            malformed biome layer or ids outside 0..63.
SplatMaps encode_splat(const Terrain& t, const ExportOptions& o, const OptionPath& path_of = {});

}  // namespace relief
