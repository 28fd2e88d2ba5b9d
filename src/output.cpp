// Outputs (FileOutput, atomic file writes) and the byte encoders: PNG (via libspng) and raw r16.
//
// Atomic writes: the bytes go to a temporary file `.NAME.tmp-XXXXXX` in the target directory
// (same file system, so rename(2) is atomic), are flushed with fsync, then renamed onto NAME.
// Any failure removes the temporary file and leaves a previous NAME untouched.
#include <fcntl.h>
#include <spng.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "relief/error.hpp"
#include "relief/output.hpp"

namespace fs = std::filesystem;

namespace relief {
namespace {

std::string errno_text(int e) { return std::error_code(e, std::generic_category()).message(); }

// Suffix for temporary names: unique within the process (counter) and across processes (pid,
// clock). O_EXCL makes a collision an EEXIST, which we retry.
std::string temp_suffix(unsigned attempt) {
  static std::atomic<std::uint64_t> counter{0};
  std::uint64_t x = std::uint64_t(::getpid()) * 0x9E3779B97F4A7C15ull ^
                    std::uint64_t(std::chrono::steady_clock::now().time_since_epoch().count()) ^
                    (counter.fetch_add(1) + attempt) * 0xBF58476D1CE4E5B9ull;
  x ^= x >> 31;
  x *= 0x94D049BB133111EBull;
  x ^= x >> 29;
  static const char digits[] = "abcdefghijklmnopqrstuvwxyz0123456789";
  std::string s(6, 'x');
  for (char& c : s) {
    c = digits[x % 36];
    x /= 36;
  }
  return s;
}

// ---- pixel conversion ----------------------------------------------------------------------
// clamp(v, 0, 1) with NaN mapped to 0 (std::clamp would pass NaN through, and converting NaN to
// an integer is undefined behaviour).
inline double unit(float v) {
  double d = v;
  if (!(d > 0.0)) return 0.0;
  return d < 1.0 ? d : 1.0;
}
inline std::uint16_t to_u16(float v) { return std::uint16_t(unit(v) * 65535.0 + 0.5); }
inline std::uint8_t to_u8(float v) { return std::uint8_t(unit(v) * 255.0 + 0.5); }

void check_layer(const Layer& l, int nx, int nz, int channels, const char* what) {
  if (l.channels != channels)
    throw Error("layer", std::string(what) + ": layer has " + std::to_string(l.channels) + " channel(s), expected " +
                             std::to_string(channels));
  if (nx < 1 || nz < 1)
    throw Error("layer", std::string(what) + ": invalid size " + std::to_string(nx) + "x" + std::to_string(nz));
  const std::size_t want = std::size_t(nx) * std::size_t(nz) * std::size_t(channels);
  if (l.data.size() != want)
    throw Error("layer", std::string(what) + ": layer has " + std::to_string(l.data.size()) + " values, expected " +
                             std::to_string(want) + " (" + std::to_string(nx) + "x" + std::to_string(nz) + "x" +
                             std::to_string(channels) + ")");
}

// zlib level for image data. Measured on a 1025x1025 fBm terrain (8 octaves of value noise),
// libspng 0.7.3, adaptive filter choice (SPNG_FILTER_CHOICE_ALL), one core:
//   16-bit grey:  level 1: 1464 KB  59 ms | 3: 1453 KB  79 ms | 4: 1427 KB  97 ms | 6 (zlib default): 1426 KB 192 ms | 9: 1426 KB 193 ms
//   8-bit RGB:    level 1:  668 KB  53 ms | 3:  580 KB  82 ms | 4:  533 KB  73 ms | 6:  486 KB 188 ms | 9:  431 KB 2346 ms
// Level 4 is within 0.1 % of level 6 on heights (the bulk of our PNG bytes) at half the time;
// colour images are ~10 % larger than at 6. Level 9 is an order of magnitude slower for RGB.
constexpr int kPngCompressionLevel = 4;

std::string encode_png(const void* pixels, std::size_t len, int w, int h, int bit_depth, int color_type,
                       int filter_choice = SPNG_FILTER_CHOICE_ALL) {
  std::unique_ptr<spng_ctx, decltype(&spng_ctx_free)> ctx(spng_ctx_new(SPNG_CTX_ENCODER), &spng_ctx_free);
  if (!ctx) throw Error("output", "PNG encoder: out of memory");
  auto check = [](int r) {
    if (r) throw Error("output", std::string("PNG encoding failed: ") + spng_strerror(r));
  };
  check(spng_set_option(ctx.get(), SPNG_ENCODE_TO_BUFFER, 1));
  check(spng_set_option(ctx.get(), SPNG_IMG_COMPRESSION_LEVEL, kPngCompressionLevel));
  check(spng_set_option(ctx.get(), SPNG_FILTER_CHOICE, filter_choice));
  spng_ihdr ihdr{};
  ihdr.width = std::uint32_t(w);
  ihdr.height = std::uint32_t(h);
  ihdr.bit_depth = std::uint8_t(bit_depth);
  ihdr.color_type = std::uint8_t(color_type);
  check(spng_set_ihdr(ctx.get(), &ihdr));
  // SPNG_FMT_PNG: samples in the PNG's layout, 16-bit samples in host byte order.
  check(spng_encode_image(ctx.get(), pixels, len, SPNG_FMT_PNG, SPNG_ENCODE_FINALIZE));
  std::size_t out_len = 0;
  int err = 0;
  void* buf = spng_get_png_buffer(ctx.get(), &out_len, &err);
  if (!buf) check(err ? err : SPNG_EINTERNAL);
  std::string out(static_cast<const char*>(buf), out_len);
  std::free(buf);
  return out;
}

}  // namespace

// ---- files --------------------------------------------------------------------------------

void write_file_atomic(const std::string& path, std::string_view bytes) {
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  const std::string base = target.filename().string();
  if (base.empty() || base == "." || base == "..") throw Error("output", "invalid file name '" + path + "'");

  fs::path tmp;
  int fd = -1;
  for (unsigned attempt = 0; attempt < 100 && fd < 0; ++attempt) {
    tmp = dir / ("." + base + ".tmp-" + temp_suffix(attempt));
    // 0666 & ~umask, like any freshly created file (mkstemp would give 0600).
    fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0 && errno != EEXIST) throw Error("output", "cannot write to '" + path + "': " + errno_text(errno));
  }
  if (fd < 0) throw Error("output", "cannot write to '" + path + "': no free temporary name");

  auto fail = [&](const std::string& what, int e) {
    if (fd >= 0) ::close(fd);
    std::error_code ignore;
    fs::remove(tmp, ignore);
    throw Error("output", what + " '" + path + "': " + errno_text(e));
  };

  const char* p = bytes.data();
  std::size_t left = bytes.size();
  while (left > 0) {
    ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("cannot write", errno);
    }
    p += n;
    left -= std::size_t(n);
  }
  // Data must be on disk before the rename makes it visible under the real name.
  if (::fsync(fd) != 0) fail("cannot write", errno);
  if (::close(fd) != 0) {
    fd = -1;
    fail("cannot write", errno);
  }
  fd = -1;
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) fail("cannot replace", ec.value());
}

FileOutput::FileOutput(std::string dir) : dir_(std::move(dir)) {
  if (dir_.empty()) dir_.push_back('.');  // (not `= "."`: GCC 12 -Wrestrict false positive, PR 105329)
  // Nothing is created here, so that a run which fails before its first file leaves the file
  // system as it was: check that the directory, or else its nearest existing ancestor (where
  // put() will create the rest), is a directory we can write into.
  std::error_code ec;
  fs::path existing = fs::path(dir_);
  while (!fs::exists(existing, ec)) {
    const fs::path parent = existing.parent_path();
    if (parent.empty() || parent == existing) {
      existing = ".";
      break;
    }
    existing = parent;
  }
  if (!fs::is_directory(existing, ec))
    throw Error("output", "cannot create directory '" + dir_ + "': " +
                              (existing == fs::path(dir_) ? std::string("exists and is not a directory")
                                                          : "'" + existing.string() + "' is not a directory"));
  // W_OK|X_OK: we need to create entries in it. (root passes access(); a read-only file system
  // still reports EROFS.)
  if (::access(existing.c_str(), W_OK | X_OK) != 0)
    throw Error("output", "cannot write to '" + existing.string() + "': " + errno_text(errno));
}

void FileOutput::create_directory() {
  if (created_) return;
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec) throw Error("output", "cannot create directory '" + dir_ + "': " + ec.message());
  if (!fs::is_directory(dir_, ec))
    throw Error("output", "cannot create directory '" + dir_ + "': " +
                              (ec ? ec.message() : std::string("exists and is not a directory")));
  created_ = true;
}

void FileOutput::put(const std::string& filename, std::string bytes) {
  // Writers emit plain names; refuse anything that would escape the directory.
  if (filename.empty() || filename == "." || filename == ".." || filename.find('/') != std::string::npos ||
      filename.find('\0') != std::string::npos)
    throw Error("output", "invalid file name '" + filename + "'");
  create_directory();
  const std::string path = (fs::path(dir_) / filename).string();
  write_file_atomic(path, bytes);
  written_.push_back(path);
  bytes_ += bytes.size();
}

// ---- encoders -----------------------------------------------------------------------------

std::string encode_png_gray16(const Layer& l, int nx, int nz) {
  check_layer(l, nx, nz, 1, "16-bit PNG");
  std::vector<std::uint16_t> px(l.data.size());
  for (std::size_t k = 0; k < px.size(); ++k) px[k] = to_u16(l.data[k]);
  return encode_png(px.data(), px.size() * 2, nx, nz, 16, SPNG_COLOR_TYPE_GRAYSCALE);
}

std::string encode_png_rgb8(const Layer& l, int nx, int nz) {
  check_layer(l, nx, nz, 3, "RGB PNG");
  std::vector<std::uint8_t> px(l.data.size());
  for (std::size_t k = 0; k < px.size(); ++k) px[k] = to_u8(l.data[k]);
  return encode_png(px.data(), px.size(), nx, nz, 8, SPNG_COLOR_TYPE_TRUECOLOR);
}

std::string encode_png_rgb8(const std::uint8_t* rgb, int width, int height) {
  if (width < 1 || height < 1)
    throw Error("layer", "RGB PNG: invalid size " + std::to_string(width) + "x" + std::to_string(height));
  // One SUB filter instead of the adaptive choice: measured on an 8192² tilemap render (libspng
  // 0.7.3, level 4, one core) 715 ms and 6.67 MB against 1970 ms and 6.85 MB adaptive.
  return encode_png(rgb, std::size_t(width) * std::size_t(height) * 3, width, height, 8, SPNG_COLOR_TYPE_TRUECOLOR,
                    SPNG_FILTER_CHOICE_SUB);
}

std::string encode_png_gray8(const Layer& l, int nx, int nz) {
  check_layer(l, nx, nz, 1, "8-bit PNG");
  std::vector<std::uint8_t> px(l.data.size());
  for (std::size_t k = 0; k < px.size(); ++k) px[k] = to_u8(l.data[k]);
  return encode_png(px.data(), px.size(), nx, nz, 8, SPNG_COLOR_TYPE_GRAYSCALE);
}

std::string encode_png_pixels(const void* pixels, std::size_t bytes, int width, int height, int bit_depth, int channels) {
  if (width < 1 || height < 1 || (bit_depth != 8 && bit_depth != 16) || channels < 1 || channels > 4 ||
      bytes != std::size_t(width) * std::size_t(height) * std::size_t(channels) * std::size_t(bit_depth / 8))
    throw Error("output", "PNG: " + std::to_string(bytes) + " bytes do not make a " + std::to_string(width) + "x" +
                              std::to_string(height) + " image of " + std::to_string(channels) + " channel(s) at " +
                              std::to_string(bit_depth) + " bits");
  static const int types[] = {SPNG_COLOR_TYPE_GRAYSCALE, SPNG_COLOR_TYPE_GRAYSCALE_ALPHA, SPNG_COLOR_TYPE_TRUECOLOR,
                              SPNG_COLOR_TYPE_TRUECOLOR_ALPHA};
  return encode_png(pixels, bytes, width, height, bit_depth, types[channels - 1]);
}

std::string encode_r16(const Layer& l) {
  if (l.channels != 1)
    throw Error("layer", "r16: layer has " + std::to_string(l.channels) + " channel(s), expected 1");
  std::string out(l.data.size() * 2, '\0');
  for (std::size_t k = 0; k < l.data.size(); ++k) {
    const std::uint16_t v = to_u16(l.data[k]);
    out[2 * k] = char(v & 0xFF);  // little-endian whatever the host
    out[2 * k + 1] = char(v >> 8);
  }
  return out;
}

}  // namespace relief
