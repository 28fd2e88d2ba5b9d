#include "hillshade.hpp"

#include <numbers>

#include "parallel.hpp"

namespace relief::detail {

void hillshade(const Frame& fr, const Layer& h, const Layer* albedo, const Light& p, Layer* shade, Layer& color) {
  constexpr double kRad = std::numbers::pi / 180.0;
  const double az = p.azimuth_deg * kRad, alt = p.altitude_deg * kRad;
  // World axes: x east, y up, z south. Azimuth is clockwise from north (−z).
  const double lx = std::cos(alt) * std::sin(az), ly = std::sin(alt), lz = -std::cos(alt) * std::cos(az);
  const double flat = p.ambient + (1.0 - p.ambient) * ly;
  if (shade) {
    shade->channels = 1;
    shade->data.assign(fr.count(), 0.0f);
  }
  color.channels = 3;
  color.data.assign(fr.count() * 3, 0.0f);
  parallel_rows(fr.nz, [&](int j) {
    for (int i = 0; i < fr.nx; ++i) {
      const std::size_t k = std::size_t(j) * fr.nx + i;
      const Gradient g = gradient_at(fr, h, i, j);
      const double fx = p.z_factor * g.dx, fz = p.z_factor * g.dz;
      const double ndotl = (-fx * lx + ly - fz * lz) / std::sqrt(1.0 + fx * fx + fz * fz);
      double s = p.ambient + (1.0 - p.ambient) * std::max(0.0, ndotl);
      if (double(h.data[k * h.channels]) < fr.sea_level) s = flat + p.water_relief * (s - flat);
      if (shade) shade->data[k] = float(s);
      for (int c = 0; c < 3; ++c) color.data[3 * k + c] = float((albedo ? double(albedo->data[3 * k + c]) : 1.0) * s);
    }
  });
}

}  // namespace relief::detail
