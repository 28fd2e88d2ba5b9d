#include "texture.hpp"

#include <spng.h>
#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <system_error>

#include "relief/error.hpp"

namespace relief::detail {

Rgb Texture::sample(double x_m, double z_m, double tile_m) const {
  const double u = x_m / tile_m, v = z_m / tile_m;
  const double fu = (u - std::floor(u)) * width - 0.5, fv = (v - std::floor(v)) * height - 0.5;
  const double x0 = std::floor(fu), z0 = std::floor(fv);
  const double tx = fu - x0, tz = fv - z0;
  auto wrap = [](long long a, int n) { return int(((a % n) + n) % n); };
  const int i0 = wrap((long long)x0, width), i1 = wrap((long long)x0 + 1, width);
  const int j0 = wrap((long long)z0, height), j1 = wrap((long long)z0 + 1, height);
  float out[3];
  for (int c = 0; c < 3; ++c) {
    auto px = [&](int i, int j) { return double(rgb[(std::size_t(j) * width + i) * 3 + c]); };
    const double top = px(i0, j0) + (px(i1, j0) - px(i0, j0)) * tx;
    const double bottom = px(i0, j1) + (px(i1, j1) - px(i0, j1)) * tx;
    out[c] = float(top + (bottom - top) * tz);
  }
  return Rgb{out[0], out[1], out[2]};
}

namespace {

std::shared_ptr<const Texture> decode(const std::string& file, const std::string& field_path) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    const int e = errno;
    throw Error(field_path, "cannot read texture '" + file + "': " + std::error_code(e, std::generic_category()).message());
  }
  // Only a regular file of a PNG's plausible size: a recipe naming /dev/zero, a FIFO or a huge file
  // gets an error instead of reading forever.
  std::error_code ec;
  const auto status = std::filesystem::status(file, ec);
  if (!std::filesystem::is_regular_file(status))
    throw Error(field_path, "cannot read texture '" + file + "': not a regular file");
  const auto file_size = std::filesystem::file_size(file, ec);
  if (ec || file_size > (std::uintmax_t(512) << 20))
    throw Error(field_path, "cannot read texture '" + file + "': " + (ec ? ec.message() : "larger than 512 MiB"));
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string bytes = ss.str();
  std::unique_ptr<spng_ctx, void (*)(spng_ctx*)> ctx(spng_ctx_new(0), spng_ctx_free);
  if (!ctx) throw Error(field_path, "cannot decode texture '" + file + "': out of memory");
  auto fail = [&](int rc) {
    throw Error(field_path, "texture '" + file + "' is not a PNG image libspng can decode: " + spng_strerror(rc));
  };
  spng_set_crc_action(ctx.get(), SPNG_CRC_USE, SPNG_CRC_USE);
  if (int rc = spng_set_png_buffer(ctx.get(), bytes.data(), bytes.size())) fail(rc);
  spng_ihdr ihdr{};
  if (int rc = spng_get_ihdr(ctx.get(), &ihdr)) fail(rc);
  if (ihdr.width == 0 || ihdr.height == 0 || ihdr.width > 8192 || ihdr.height > 8192)
    throw Error(field_path, "texture '" + file + "' is " + std::to_string(ihdr.width) + "x" + std::to_string(ihdr.height) +
                                " pixels; expected 1..8192 on each side");
  std::size_t size = 0;
  if (int rc = spng_decoded_image_size(ctx.get(), SPNG_FMT_RGBA8, &size)) fail(rc);
  std::vector<unsigned char> px(size);
  if (int rc = spng_decode_image(ctx.get(), px.data(), px.size(), SPNG_FMT_RGBA8, SPNG_DECODE_TRNS)) fail(rc);
  auto t = std::make_shared<Texture>();
  t->width = int(ihdr.width);
  t->height = int(ihdr.height);
  t->rgb.resize(std::size_t(t->width) * t->height * 3);
  for (std::size_t k = 0; k < std::size_t(t->width) * t->height; ++k)
    for (int c = 0; c < 3; ++c) t->rgb[3 * k + c] = float(px[4 * k + c]) / 255.0f;
  return t;
}

}  // namespace

std::shared_ptr<const Texture> load_texture(const std::string& file, const std::string& field_path) {
  if (file.empty()) throw Error(field_path, "expected a PNG file name, got \"\"");
  struct Entry {
    long long size = -1, mtime_ns = -1;
    std::shared_ptr<const Texture> tex;
  };
  static std::mutex mu;
  static std::map<std::string, Entry> cache;
  struct stat st{};
  const bool known = ::stat(file.c_str(), &st) == 0;
  const long long size = known ? (long long)st.st_size : -1;
  const long long mtime = known ? (long long)st.st_mtim.tv_sec * 1000000000LL + st.st_mtim.tv_nsec : -1;
  std::lock_guard<std::mutex> lock(mu);
  auto it = cache.find(file);
  if (known && it != cache.end() && it->second.size == size && it->second.mtime_ns == mtime) return it->second.tex;
  auto tex = decode(file, field_path);
  cache[file] = Entry{size, mtime, tex};
  return tex;
}

std::vector<std::shared_ptr<const Texture>> load_level_textures(const std::vector<Level>& levels,
                                                                const std::string& levels_path) {
  std::vector<std::shared_ptr<const Texture>> out(levels.size());
  for (std::size_t k = 0; k < levels.size(); ++k)
    if (!levels[k].texture.empty())
      out[k] = load_texture(levels[k].texture, levels_path + "[" + std::to_string(k) + "].texture");
  return out;
}

Rgb level_color(const std::vector<Level>& lv, const std::vector<std::shared_ptr<const Texture>>& tex, bool gradient,
                float e, double x_m, double z_m) {
  auto col = [&](std::size_t k) {
    const Texture* t = k < tex.size() ? tex[k].get() : nullptr;
    return t ? t->sample(x_m, z_m, lv[k].tile_m) : lv[k].color;
  };
  auto at = [&](std::size_t k) { return float(lv[k].at); };
  if (!gradient) {
    for (std::size_t k = 0; k < lv.size(); ++k)
      if (e <= at(k)) return col(k);
    return col(lv.size() - 1);
  }
  if (e <= at(0)) return col(0);
  if (e >= at(lv.size() - 1)) return col(lv.size() - 1);
  std::size_t k = 0;
  while (!(e <= at(k + 1))) ++k;  // at[k] < e ≤ at[k+1], so at[k+1] > at[k]
  const double s = (double(e) - at(k)) / (double(at(k + 1)) - at(k));
  const Rgb a = col(k), b = col(k + 1);
  return Rgb{float(a.r + (b.r - a.r) * s), float(a.g + (b.g - a.g) * s), float(a.b + (b.b - a.b) * s)};
}

}  // namespace relief::detail
