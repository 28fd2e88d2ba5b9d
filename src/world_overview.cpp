// overview.png of a world build, coloured and encoded row by row (src/world_overview.hpp).
#include "world_overview.hpp"

#include <spng.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cerrno>
#include <cstring>
#include <memory>
#include <stdexcept>

#include <fcntl.h>
#include <unistd.h>

#include "relief/error.hpp"
#include "relief/file_output.hpp"

namespace relief::detail {

WorldOverview::WorldOverview(const std::string& dir, int width, int height) : w_(width), h_(height) {
  if (w_ <= 0 || h_ <= 0) {
    w_ = h_ = 0;
    return;
  }
  fd_ = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd_ < 0) {  // a file system without O_TMPFILE: a named temporary file, unlinked at once
    std::string name = dir + "/.overview.tmp-" + std::to_string(::getpid()) + "-XXXXXX";
    fd_ = ::mkostemp(name.data(), O_CLOEXEC);
    if (fd_ >= 0) ::unlink(name.c_str());
  }
  if (fd_ < 0)
    throw Error("output", "cannot make the overview's temporary file in '" + dir + "': " + std::strerror(errno));
  std::vector<std::uint16_t> row(std::size_t(w_), quantise(float(kLow)));
  for (int j = 0; j < h_; ++j) {
    const std::size_t n = row.size() * sizeof(std::uint16_t);
    if (::pwrite(fd_, row.data(), n, off_t(std::size_t(j) * n)) != ssize_t(n))
      throw Error("output", "cannot write the overview's temporary file in '" + dir + "': " + std::strerror(errno));
  }
}

WorldOverview::~WorldOverview() {
  if (fd_ >= 0) ::close(fd_);
}

std::uint16_t WorldOverview::quantise(float h) {
  double v = double(h);
  if (!(v >= kLow)) v = kLow;  // NaN too
  if (v > kHigh) v = kHigh;
  return std::uint16_t(std::lround((v - kLow) / (kHigh - kLow) * 65535.0));
}

void WorldOverview::set_run(std::size_t first, const float* h, std::size_t n) {
  if (n == 0 || fd_ < 0) return;
  if (first + n > std::size_t(w_) * std::size_t(h_)) throw std::logic_error("WorldOverview::set_run: outside the overview");
  std::uint16_t buf[512];
  for (std::size_t done = 0; done < n;) {
    const std::size_t m = std::min<std::size_t>(512, n - done);
    for (std::size_t k = 0; k < m; ++k) buf[k] = quantise(h[done + k]);
    const std::size_t bytes = m * sizeof(std::uint16_t);
    if (::pwrite(fd_, buf, bytes, off_t((first + done) * sizeof(std::uint16_t))) != ssize_t(bytes))
      throw Error("output", std::string("cannot write the overview's temporary file: ") + std::strerror(errno));
    done += m;
  }
}

void WorldOverview::read_row(int j, std::uint16_t* out) const {
  j = std::clamp(j, 0, h_ - 1);
  const std::size_t bytes = std::size_t(w_) * sizeof(std::uint16_t);
  if (::pread(fd_, out, bytes, off_t(std::size_t(j) * bytes)) != ssize_t(bytes))
    throw Error("output", std::string("cannot read the overview's temporary file: ") + std::strerror(errno));
}

void WorldOverview::write_png(const std::string& dir, double cell_m, double height_m, double sea) const {
  if (w_ < 1 || h_ < 1 || fd_ < 0) throw Error("output", "overview.png: the overview is empty");
  FileOutput out(dir, FileOutput::Mode::Immediate, FileOutput::Sync::Durable);
  std::unique_ptr<OutputStream> file = out.open("overview.png");
  std::unique_ptr<spng_ctx, decltype(&spng_ctx_free)> ctx(spng_ctx_new(SPNG_CTX_ENCODER), &spng_ctx_free);
  if (!ctx) throw Error("output", "overview.png: PNG encoder: out of memory");
  auto check = [](int r) {
    if (r) throw Error("output", std::string("overview.png: PNG encoding failed: ") + spng_strerror(r));
  };
  auto write_fn = [](spng_ctx*, void* user, void* data, std::size_t n) -> int {
    static_cast<OutputStream*>(user)->write(std::string_view(static_cast<const char*>(data), n));
    return 0;
  };
  check(spng_set_png_stream(ctx.get(), write_fn, file.get()));
  // As encode_png_rgb8 (output.cpp) for pictures: zlib level 4, the SUB filter.
  check(spng_set_option(ctx.get(), SPNG_IMG_COMPRESSION_LEVEL, 4));
  check(spng_set_option(ctx.get(), SPNG_FILTER_CHOICE, SPNG_FILTER_CHOICE_SUB));
  spng_ihdr ihdr{};
  ihdr.width = std::uint32_t(w_);
  ihdr.height = std::uint32_t(h_);
  ihdr.bit_depth = 8;
  ihdr.color_type = SPNG_COLOR_TYPE_TRUECOLOR;
  check(spng_set_ihdr(ctx.get(), &ihdr));
  check(spng_encode_image(ctx.get(), nullptr, 0, SPNG_FMT_PNG, SPNG_ENCODE_PROGRESSIVE | SPNG_ENCODE_FINALIZE));

  const double az = 315.0 * M_PI / 180.0, alt = 45.0 * M_PI / 180.0;
  const double lx = std::cos(alt) * std::sin(az), ly = std::sin(alt), lz = -std::cos(alt) * std::cos(az);
  struct Stop {
    double t, r, g, b;
  };
  static const Stop land[] = {{0.0, 70, 130, 60}, {0.35, 150, 160, 90}, {0.7, 130, 100, 70}, {1.0, 245, 245, 245}};
  std::vector<std::uint8_t> row(std::size_t(w_) * 3);
  // Rows j − 1, j, j + 1 of the samples (clamped to the picture), rolled down as j advances.
  std::vector<std::uint16_t> rows(std::size_t(w_) * 3);
  std::uint16_t* up = rows.data();
  std::uint16_t* mid = up + w_;
  std::uint16_t* down = mid + w_;
  read_row(0, mid);
  std::copy_n(mid, w_, up);
  read_row(1, down);
  for (int j = 0; j < h_; ++j) {
    if (j > 0) {
      std::uint16_t* old = up;
      up = mid;
      mid = down;
      down = old;
      read_row(j + 1, down);
    }
    auto at = [&](int i, const std::uint16_t* r) { return height_of(r[std::clamp(i, 0, w_ - 1)]); };
    for (int i = 0; i < w_; ++i) {
      const double e = at(i, mid);
      const int i0 = std::max(0, i - 1), i1 = std::min(w_ - 1, i + 1), j0 = std::max(0, j - 1), j1 = std::min(h_ - 1, j + 1);
      const double dx = i1 > i0 ? (at(i1, mid) - at(i0, mid)) * height_m / ((i1 - i0) * cell_m) : 0.0;
      const double dz = j1 > j0 ? (at(i, j1 > j ? down : mid) - at(i, j0 < j ? up : mid)) * height_m / ((j1 - j0) * cell_m) : 0.0;
      const double len = std::sqrt(dx * dx + dz * dz + 1.0);
      const double shade = std::max(0.0, (-dx * lx + ly - dz * lz) / len);
      double r, g, b, k;
      if (e < sea) {
        const double t = sea > 0 ? std::clamp(e / sea, 0.0, 1.0) : 1.0;
        r = 10 + 50 * t, g = 40 + 80 * t, b = 90 + 90 * t;
        k = 0.8 + 0.2 * shade;
      } else {
        const double t = sea < 1 ? std::clamp((e - sea) / (1 - sea), 0.0, 1.0) : 0.0;
        int s = 0;
        while (s < 2 && t > land[s + 1].t) ++s;
        const double u = (t - land[s].t) / (land[s + 1].t - land[s].t);
        r = land[s].r + (land[s + 1].r - land[s].r) * u;
        g = land[s].g + (land[s + 1].g - land[s].g) * u;
        b = land[s].b + (land[s + 1].b - land[s].b) * u;
        k = 0.35 + 0.65 * shade;
      }
      std::uint8_t* p = row.data() + std::size_t(i) * 3;
      p[0] = std::uint8_t(std::clamp(std::lround(r * k), 0L, 255L));
      p[1] = std::uint8_t(std::clamp(std::lround(g * k), 0L, 255L));
      p[2] = std::uint8_t(std::clamp(std::lround(b * k), 0L, 255L));
    }
    const int rc = spng_encode_row(ctx.get(), row.data(), row.size());
    if (rc != 0 && !(rc == SPNG_EOI && j + 1 == h_)) check(rc);
  }
  file->close();
}

}  // namespace relief::detail
