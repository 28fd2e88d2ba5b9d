#pragma once
// The world's overview picture (overview.png of relief/world.hpp) in memory that does not grow with
// the world: the samples are kept as 16-bit fixed point in an unnamed temporary file of the world
// folder (2 bytes per overview pixel on disk), and the picture is coloured, hillshaded and
// PNG-encoded row by row straight into overview.png.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace relief::detail {

class WorldOverview {
 public:
  // Heights (the terrain's normalised units: 0 = bottom, 1 = height_m above it) are kept in
  // [kLow, kHigh] at a step of (kHigh − kLow) / 65535 ≈ 7.6·10⁻⁵; outside, clamped; NaN as kLow.
  static constexpr double kLow = -2.0, kHigh = 3.0;

  WorldOverview() = default;
  // An overview of width × height samples (every one kLow until set) kept in an unnamed temporary
  // file in `dir` (removed when this is destroyed, or by the system if the process dies); an empty
  // one (no file) when width or height is 0. Throws Error("output", …) when the file cannot be made.
  WorldOverview(const std::string& dir, int width, int height);
  ~WorldOverview();
  WorldOverview(const WorldOverview&) = delete;
  WorldOverview& operator=(const WorldOverview&) = delete;
  int width() const { return w_; }
  int height() const { return h_; }
  // Sets the samples at = first, first + 1, …, first + n − 1 (at = row · width + column) from
  // `h`. Thread-compatible (one caller at a time). Throws Error("output", …) on a write error.
  void set_run(std::size_t first, const float* h, std::size_t n);

  // Writes `dir`/overview.png atomically and flushed (temporary file, fsync, rename): the heights
  // coloured by a hypsometric ramp (sea below `sea`), hillshaded by Lambert n·l from the north-west
  // at 45° on the overview grid itself (cell = cell_m metres, heights × height_m metres), 8-bit RGB.
  // Memory: three rows of samples and one of pixels. Throws Error("output", …)
  // naming the file when it cannot be written.
  void write_png(const std::string& dir, double cell_m, double height_m, double sea) const;

  // Bytes of memory the overview of w × h pixels takes (the memory check's estimate).
  static std::uint64_t memory_bytes(std::int64_t w, std::int64_t) { return std::uint64_t(w) * 12 + 64 * 1024; }
  static std::uint16_t quantise(float h);
  static double height_of(std::uint16_t q) { return kLow + double(q) * ((kHigh - kLow) / 65535.0); }

 private:
  void read_row(int j, std::uint16_t* out) const;
  int w_ = 0, h_ = 0;
  int fd_ = -1;
};

}  // namespace relief::detail
