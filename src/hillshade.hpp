#pragma once
// Internal: metric gradients and the Lambertian hillshade, shared by the slope/colour/hillshade
// stages and by the stage-by-stage previews (relief/steps.hpp).
//
// Hillshade as in GIS (Burrough & McDonnell, "Principles of Geographical Information Systems",
// 1998; GDAL gdaldem hillshade): light azimuth clockwise from north, altitude above the horizon,
// z factor for vertical exaggeration.
#include <algorithm>
#include <cmath>

#include "relief/terrain.hpp"

namespace relief::detail {

// Gradient of the surface y_m(x, z) in metres per metre at sample (i, j): central differences in
// the interior, one-sided at the border of the window.
struct Gradient {
  double dx, dz;
};
inline Gradient gradient_at(const Frame& fr, const Layer& h, int i, int j) {
  const double cell = fr.cell_m();
  auto at = [&](int a, int b) { return double(h.data[(std::size_t(b) * fr.nx + a) * h.channels]); };
  const int i0 = std::max(i - 1, 0), i1 = std::min(i + 1, fr.nx - 1);
  const int j0 = std::max(j - 1, 0), j1 = std::min(j + 1, fr.nz - 1);
  return Gradient{(at(i1, j) - at(i0, j)) * fr.height_m / ((i1 - i0) * cell),
                  (at(i, j1) - at(i, j0)) * fr.height_m / ((j1 - j0) * cell)};
}

struct Light {
  double azimuth_deg = 315.0;
  double altitude_deg = 45.0;
  double z_factor = 1.0;
  double ambient = 0.2;
  double water_relief = 0.3;
};

// shade = ambient + (1 − ambient) · max(0, n · l), n the unit surface normal of z_factor · y_m,
// l the unit vector towards the light. Under the sea (e < sea_level):
// shade = flat + water_relief · (shade − flat), flat = ambient + (1 − ambient) · sin(altitude).
// Writes `shade` (1 channel, if not null) and `color` = albedo × shade (3 channels; white when
// `albedo` is null), both sized to the frame. Row-parallel, deterministic.
void hillshade(const Frame& fr, const Layer& height, const Layer* albedo, const Light& light, Layer* shade,
               Layer& color);

}  // namespace relief::detail
