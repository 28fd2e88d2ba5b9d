// Fuzz target: the raster readers of the `image` stage (relief/image.hpp: decode_raster).
//
// Input: one byte choosing the format hint (0 auto, 1 png, 2 exr, 3 r16, 4 gdal; the value modulo
// 5), then the file's bytes. GDAL is given only TIFF-like bytes ("II*\0" / "MM\0*"), so the run
// fuzzes our use of its GeoTIFF reader rather than every driver GDAL ships.
// Passes when the input decodes or is refused with relief::Error; a decoded raster must hold
// width · height values (and at most kMaxRasterPixels). Anything else is a bug.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "relief/image.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const relief::RasterFormat formats[] = {relief::RasterFormat::Auto, relief::RasterFormat::Png, relief::RasterFormat::Exr,
                                                 relief::RasterFormat::R16, relief::RasterFormat::Gdal};
  static const char* names[] = {"input", "input.png", "input.exr", "input.r16", "input.tif"};
  const int pick = data[0] % 5;
  const std::string_view bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  const bool tiff = bytes.size() >= 4 && (std::memcmp(bytes.data(), "II*\0", 4) == 0 || std::memcmp(bytes.data(), "MM\0*", 4) == 0);
  const bool png = bytes.size() >= 8 && std::memcmp(bytes.data(), "\x89PNG", 4) == 0;
  const bool exr = bytes.size() >= 4 && std::memcmp(bytes.data(), "\x76\x2f\x31\x01", 4) == 0;
  // Auto with bytes that are none of ours would go to GDAL: only TIFF-like bytes do.
  if ((pick == 4 || (pick == 0 && !png && !exr)) && !tiff) return 0;
  try {
    const relief::Raster r = relief::decode_raster(bytes, names[pick], formats[pick], "stages[0].path");
    if (r.width < 1 || r.height < 1 || r.values.size() != std::size_t(r.width) * std::size_t(r.height) ||
        r.values.size() > relief::kMaxRasterPixels) {
      std::fprintf(stderr, "fuzz_image: decoded %dx%d with %zu values\n", r.width, r.height, r.values.size());
      std::abort();
    }
  } catch (const relief::Error&) {
  }
  return 0;
}
