#pragma once
// Internal: metric gradients and the Lambertian hillshade, shared by the slope/colour/hillshade
// stages and by the stage-by-stage previews (relief/steps.hpp).
//
// Hillshade as in GIS (Burrough & McDonnell, "Principles of Geographical Information Systems",
// 1998; GDAL gdaldem hillshade): light azimuth clockwise from north, altitude above the horizon,
// z factor for vertical exaggeration.
#include <algorithm>
#include <cmath>

#include "pointwise.hpp"
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

// The rows and factors of the single-precision gradient of row j of a one-channel layer h
// (pointwise.hpp: GradientRows), in metres per metre times `scale`: the same differences as
// gradient_at, rounded to float.
inline GradientRows gradient_rows(const Frame& fr, const Layer& h, int j, double scale) {
  GradientRows r;
  r.mid = h.row(j, fr.nx);
  r.up = h.row(std::max(j - 1, 0), fr.nx);
  r.down = h.row(std::min(j + 1, fr.nz - 1), fr.nx);
  const double per_m = scale * fr.height_m / fr.cell_m();
  r.central = float(per_m / 2.0);
  r.edge = float(per_m);
  r.kz = (j > 0 && j < fr.nz - 1) ? r.central : r.edge;
  return r;
}

// shade = ambient + (1 − ambient) · max(0, n · l), n the unit surface normal of z_factor · y_m,
// l the unit vector towards the light. Under the sea (e < sea_level):
// shade = flat + water_relief · (shade − flat), flat = ambient + (1 − ambient) · sin(altitude).
// Writes `shade` (1 channel, if not null) and `color` = albedo × shade (3 channels; white when
// `albedo` is null), both sized to the frame (existing buffers are reused). Single precision, the
// vectorised kernel of pointwise.hpp (hillshade_row): one pass over rows with a one-row halo, the
// same bits on every SIMD target. Row-parallel, deterministic. `height` has one channel.
// Used by the hillshade stage and by the stage-by-stage pictures (relief/steps.hpp).
void hillshade(const Frame& fr, const Layer& height, const Layer* albedo, const Light& light, Layer* shade,
               Layer& color);

}  // namespace relief::detail
