// Fuzz target: the raster readers of the `image` stage (relief/image.hpp: decode_raster).
//
// Input: one byte choosing the format hint (0 auto, 1 png, 2 exr, 3 r16, 4 gdal; the value modulo
// 6), then the file's bytes. 5 reads an r16 file with its Relief sidecar from disk (the sidecar's
// JSON reader: NAME.json beside NAME.r16 gives the size and the metres): two bytes giving the
// sidecar's length L (little-endian), L bytes of sidecar, then the r16 bytes. GDAL is given only TIFF-like bytes ("II*\0" / "MM\0*"), so the run
// fuzzes our use of its GeoTIFF reader rather than every driver GDAL ships.
// Passes when the input decodes or is refused with relief::Error; a decoded raster must hold
// width · height values (and at most kMaxRasterPixels). Anything else is a bug.
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "relief/image.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const relief::RasterFormat formats[] = {relief::RasterFormat::Auto, relief::RasterFormat::Png, relief::RasterFormat::Exr,
                                                 relief::RasterFormat::R16, relief::RasterFormat::Gdal};
  static const char* names[] = {"input", "input.png", "input.exr", "input.r16", "input.tif"};
  const int pick = data[0] % 6;
  const std::string_view bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  auto check = [](const relief::Raster& r) {
    if (r.width < 1 || r.height < 1 || r.values.size() != std::size_t(r.width) * std::size_t(r.height) ||
        r.values.size() > relief::kMaxRasterPixels) {
      std::fprintf(stderr, "fuzz_image: decoded %dx%d with %zu values\n", r.width, r.height, r.values.size());
      std::abort();
    }
  };
  if (pick == 5) {
    if (bytes.size() < 2) return 0;
    const std::size_t len = std::min<std::size_t>(std::uint8_t(bytes[0]) | std::size_t(std::uint8_t(bytes[1])) << 8, bytes.size() - 2);
    struct TempDir {  // this process's two files, removed at exit
      std::filesystem::path path = std::filesystem::temp_directory_path() / ("relief-fuzz-image-" + std::to_string(::getpid()));
      TempDir() { std::filesystem::create_directories(path); }
      ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path, ec);
      }
    };
    static const TempDir temp;
    const std::filesystem::path& dir = temp.path;
    const std::string r16 = (dir / "height.r16").string();
    std::ofstream(dir / "height.json", std::ios::binary | std::ios::trunc).write(bytes.data() + 2, std::streamsize(len));
    std::ofstream(r16, std::ios::binary | std::ios::trunc).write(bytes.data() + 2 + len, std::streamsize(bytes.size() - 2 - len));
    try {
      const relief::Raster head = relief::probe_raster(r16, relief::RasterFormat::R16, "stages[0].path");
      const relief::Raster r = relief::read_raster(r16, relief::RasterFormat::R16, "stages[0].path");
      check(r);
      if (head.width != r.width || head.height != r.height) {
        std::fprintf(stderr, "fuzz_image: probe %dx%d, read %dx%d\n", head.width, head.height, r.width, r.height);
        std::abort();
      }
    } catch (const relief::Error&) {
    }
    return 0;
  }
  const bool tiff = bytes.size() >= 4 && (std::memcmp(bytes.data(), "II*\0", 4) == 0 || std::memcmp(bytes.data(), "MM\0*", 4) == 0);
  const bool png = bytes.size() >= 8 && std::memcmp(bytes.data(), "\x89PNG", 4) == 0;
  const bool exr = bytes.size() >= 4 && std::memcmp(bytes.data(), "\x76\x2f\x31\x01", 4) == 0;
  // Auto with bytes that are none of ours would go to GDAL: only TIFF-like bytes do.
  if ((pick == 4 || (pick == 0 && !png && !exr)) && !tiff) return 0;
  try {
    check(relief::decode_raster(bytes, names[pick], formats[pick], "stages[0].path"));
  } catch (const relief::Error&) {
  }
  return 0;
}
