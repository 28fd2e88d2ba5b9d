#pragma once
// Writers: take a Terrain and produce bytes, in memory (the studio) or as files (the CLI).
//
// A writer emits named files into an Output. FileOutput writes each file to a temporary name
// in the target directory and renames it into place, so a crash or an error never leaves half a
// file where a previous good file stood.
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "relief/export.hpp"
#include "relief/params.hpp"
#include "relief/terrain.hpp"

namespace relief {

class Output {
 public:
  virtual ~Output() = default;
  virtual void put(const std::string& filename, std::string bytes) = 0;
};

class MemoryOutput final : public Output {
 public:
  void put(const std::string& filename, std::string bytes) override { files[filename] = std::move(bytes); }
  std::map<std::string, std::string> files;
};

// Writes into `dir`, created (with missing parents) by the first put(), so that a run that fails
// before writing anything leaves the file system unchanged. The constructor already throws
// Error("output", …) when the directory could not be created or written (its nearest existing
// ancestor is not a writable directory). Each put() is atomic (temporary file + rename).
class FileOutput final : public Output {
 public:
  explicit FileOutput(std::string dir);
  void put(const std::string& filename, std::string bytes) override;
  const std::vector<std::string>& written() const { return written_; }  // paths, in order
  std::uint64_t bytes_written() const { return bytes_; }

 private:
  void create_directory();
  std::string dir_;
  bool created_ = false;
  std::vector<std::string> written_;
  std::uint64_t bytes_ = 0;
};

// Atomically writes `bytes` to `path` (temporary file in the same directory, then rename).
void write_file_atomic(const std::string& path, std::string_view bytes);

struct WriteContext {
  std::uint64_t seed = 0;
  ExportOptions options;  // writer options (relief/export.hpp), validated by the caller
  json recipe;  // resolved recipe (for report.json)
  json report;  // timings etc. (for report.json)
  std::function<void(std::string_view what, double fraction)> progress;
};

struct WriterDef {
  std::string name;         // --formats name
  std::string description;  // one line
  std::vector<std::string> files;  // files it writes
  bool in_default_set = true;
  std::function<void(const Terrain&, const WriteContext&, Output&)> write;
  // When set and false for a terrain (e.g. no biome layer, no props), runs of the default set skip
  // the writer; named in --formats it runs anyway and its Error names what is missing.
  std::function<bool(const Terrain&)> applies = nullptr;
};

const std::vector<WriterDef>& writer_registry();
const WriterDef* find_writer(std::string_view name);

// ---- encoders (also used directly by tests and the studio) ---------------------------------
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

}  // namespace relief
