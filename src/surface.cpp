// Surface geometry (surface.hpp). The Lambertian hillshade follows Burrough & McDonnell 1998 and
// GDAL gdaldem hillshade; its per-sample work is the vectorised row kernel of pointwise.cpp.
#include "surface.hpp"

#include <numbers>
#include <vector>

#include "parallel.hpp"

namespace relief::detail {

void hillshade(const Frame& fr, const Layer& h, const Layer* albedo, const Light& p, Layer* shade, Layer* color) {
  constexpr double kRad = std::numbers::pi / 180.0;
  const double az = p.azimuth_deg * kRad, alt = p.altitude_deg * kRad;
  // World axes: x east, y up, z south. Azimuth is clockwise from north (−z).
  const double lx = std::cos(alt) * std::sin(az), ly = std::sin(alt), lz = -std::cos(alt) * std::cos(az);
  HillshadeRow k;
  k.lx = float(lx), k.ly = float(ly), k.lz = float(lz);
  k.ambient = float(p.ambient);
  k.diffuse = float(1.0 - p.ambient);
  k.flat = float(p.ambient + (1.0 - p.ambient) * ly);
  k.water_relief = float(p.water_relief);
  k.sea_below = float_at_least(fr.sea_level);
  const std::size_t count = fr.count();
  // Outputs far beyond the last-level cache (here 16 bytes per sample over 32 MiB, from about
  // 1450² on) cannot stay cached for the next reader anyway: write the colour without reading it.
  k.stream = color && count * 16 > (std::size_t(32) << 20);
  // Every sample is written below: size the outputs without clearing them.
  auto size = [&](Layer& l, int channels) {
    l.channels = channels;
    l.data.resize(count * std::size_t(channels));
  };
  if (shade) size(*shade, 1);
  if (color) size(*color, 3);
  if (albedo && (albedo->channels != 3 || albedo->data.size() != 3 * count)) albedo = nullptr;
  parallel_rows(fr.nz, [&](int j) {
    float* rgb = nullptr;
    if (color) {
      rgb = color->row(j, fr.nx);
    } else {  // the kernel always writes a colour row: a scratch row per thread
      thread_local std::vector<float> scratch;
      scratch.resize(3 * std::size_t(fr.nx));
      rgb = scratch.data();
    }
    hillshade_row(k, gradient_rows(fr, h, j, p.z_factor), albedo ? albedo->row(j, fr.nx) : nullptr,
                  shade ? shade->row(j, fr.nx) : nullptr, rgb, fr.nx);
  });
}

}  // namespace relief::detail
