#pragma once
// Rasters a user brings: heightmaps, masks and elevation models read into memory for the `image`
// stage, and the GeoTIFF encoder of the `geotiff` writer.
//
// Formats read (Format::Auto picks by the file's first bytes, then by its name):
//   * PNG (libspng): greyscale, grey+alpha, RGB or RGBA at 8 or 16 bits per channel (colour is
//     averaged, alpha ignored). Values are codes 0..255 or 0..65535 (Raster::code_max).
//   * OpenEXR: one FLOAT/HALF/UINT channel ("Y", else "R", else the first), values as stored.
//   * r16: Relief's own `height.r16` (little-endian unsigned 16-bit, no header) with its sidecar
//     `height.json` beside it (NAME.r16 → NAME.json: width, height, min_m, max_m,
//     metres_per_pixel); without a sidecar the file must be square. Codes 0..65535.
//   * GDAL: GeoTIFF and every raster format GDAL reads (SRTM .hgt, ESRI ASCII grid, …), band 1,
//     values as stored (metres for elevation models). GDAL is loaded at run time (dlopen) the first
//     time a GDAL format is read or written, so a run that never touches one never loads it.
//     Nodata samples and non-finite values become the lowest valid value of the raster.
// A PNG may carry a Relief sidecar too (NAME.png → NAME.json, as height.png + height.json): its
// min_m/max_m give the metres of codes 0 and 65535 and metres_per_pixel a georeference.
//
// Bad input never crashes and never allocates what the header claims before checking it: the
// dimensions are read first and refused beyond kMaxRasterPixels (or a quarter of the machine's
// memory as floats); files larger than 2 GiB, non-regular files (FIFOs, devices) and GDAL's virtual
// or network paths (/vsi…) are refused. Every failure is a relief::Error naming `field_path`
// (e.g. `stages[0].path: cannot read 'a.png': No such file or directory`).
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "relief/params.hpp"
#include "relief/terrain.hpp"

namespace relief {

enum class RasterFormat { Auto, Png, Exr, R16, Gdal };

// Largest raster accepted: 2^28 samples (16384²; 1 GiB as floats).
constexpr std::uint64_t kMaxRasterPixels = std::uint64_t(1) << 28;

struct Raster {
  int width = 0, height = 0;        // pixels (columns along +x, rows along +z; row 0 = the north edge)
  std::vector<float> values;        // width · height, row-major, x fastest, as stored (codes or metres)
  double code_max = 0;              // 255 / 65535 for integer-coded images (PNG, r16); 0: values are quantities
  std::string format;               // "png", "exr", "r16", or GDAL's driver name ("GTiff", "SRTMHGT", …)
  // Metres of code 0 and code_max (a Relief sidecar); has_range_m false when unknown.
  bool has_range_m = false;
  double min_m = 0, max_m = 0;
  // Georeference: the spacing of pixel centres in metres along columns (+x, east) and rows (+z,
  // south), both positive; pixel (0, 0)'s centre in the file's coordinates (geo_x0 easting,
  // geo_z0 = −northing; informational). GDAL's geographic rasters (degrees) are converted at the
  // raster's central latitude (good to about 0.5 % over one degree); rotated transforms and
  // south-up rasters are refused.
  bool has_geo = false;
  double geo_x0 = 0, geo_z0 = 0, pixel_x_m = 0, pixel_z_m = 0;
};

// Reads `file` (the whole raster, once). `field_path` names the recipe field for errors.
Raster read_raster(const std::string& file, RasterFormat format, const std::string& field_path);
// The same decoders on bytes in memory (the fuzz target; GDAL through /vsimem/). `name` is used in
// messages and to guess the format. r16 from memory has no sidecar: square only.
Raster decode_raster(std::string_view bytes, const std::string& name, RasterFormat format, const std::string& field_path);
// Reads only the header of `file`: width, height, format and georeference (values left empty),
// with every check read_raster makes before decoding. Used to refuse a bad file when a recipe is
// parsed, before anything is generated.
Raster probe_raster(const std::string& file, RasterFormat format, const std::string& field_path);
// read_raster through a process-wide cache keyed by the file's absolute name, format, size and
// modification time (a few entries, least recently used dropped first). Thread-safe.
std::shared_ptr<const Raster> cached_raster(const std::string& file, RasterFormat format, const std::string& field_path);

// Reads only the header of bytes in memory (decode_raster's checks before decoding: dimensions
// against kMaxRasterPixels and memory), so a caller can refuse a raster by its size before decoding it.
Raster probe_raster_bytes(std::string_view bytes, const std::string& name, RasterFormat format, const std::string& field_path);

// Rasters held in memory (the studio's uploads: its server never reads a file a client names). An
// image stage whose path starts with kMemoryRasterPrefix reads the raster registered under that
// exact path and never the file system (probe_raster, read_raster and cached_raster alike; the
// stage's format parameter is not used: the raster was decoded before it was registered). The
// registry holds each raster weakly: it is there while the caller that registered it keeps its
// shared_ptr; a path with no live raster is an Error naming field_path. Registering a path again
// replaces it. A recipe file's relative paths are made absolute (resolve_recipe_files), so a
// recipe read from disk never names one. Thread-safe.
inline constexpr std::string_view kMemoryRasterPrefix = "memory:";
void register_memory_raster(const std::string& path, std::shared_ptr<const Raster> raster);

// Whether GDAL can be loaded on this machine (libgdal found at run time).
bool gdal_available();


// GeoTIFF of the height in metres (y_m, sea surface at 0): one Float32 band, deflate-compressed,
// nx × nz pixels, pixel-is-area, no CRS (a local frame in metres). GeoTransform
// [x0_m − cell/2, cell, 0, −(z0_m − cell/2), 0, −cell]: geo X = world x, geo Y = −world z (north
// up, z runs south), so the pixel centres sit on the samples. Throws Error("formats", …) when
// GDAL cannot be loaded.
std::string encode_geotiff_height(const Terrain& t);

}  // namespace relief
