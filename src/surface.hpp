#pragma once
// Internal: the surface geometry of a height layer — metric gradients, unit normals, face normals
// and the Lambertian hillshade — written once and used by the slope, colour and hillshade stages,
// prop placement, the mesh builder, the OBJ writer, the normal-map, splat and hillshade writers
// and the stage-by-stage pictures (relief/steps.hpp).
//
// The surface is y_m(x, z) = (e − sea_level) · height_m over the frame's sample grid (terrain.hpp).
// Its gradient at sample (i, j) is taken with central differences in the interior and one-sided
// differences at the border of the frame (so a window grown by a halo of one sample reproduces the
// whole map's gradient, and the world's edge uses the same one-sided rule):
//   y_x = (y(i+1, j) − y(i−1, j)) / (2·cell),   y_z = (y(i, j+1) − y(i, j−1)) / (2·cell).
// The unit normal is (−y_x, 1, −y_z) / √(y_x² + 1 + y_z²) (x east, y up, z south).
// Two precisions of the same differences: double (gradient_at, normal_at: meshes, files, the
// slope layer) and single (gradient_rows: the vectorised colour and hillshade kernels of
// pointwise.hpp, which difference the float elevations and scale by height_m / cell in float).
//
// Hillshade as in GIS (Burrough & McDonnell, "Principles of Geographical Information Systems",
// 1998; GDAL gdaldem hillshade): light azimuth clockwise from north, altitude above the horizon,
// z factor for vertical exaggeration.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "pointwise.hpp"
#include "relief/terrain.hpp"

namespace relief::detail {

// Gradient of y_m in metres per metre at sample (i, j) of the one-channel (or first-channel)
// layer h on frame fr. A frame one sample wide or deep has gradient 0 along that axis.
struct Gradient {
  double dx, dz;
};
inline Gradient gradient_at(const Frame& fr, const Layer& h, int i, int j) {
  auto y = [&](int a, int b) { return fr.y_m(h.data[(std::size_t(b) * fr.nx + a) * h.channels]); };
  const int i0 = std::max(i - 1, 0), i1 = std::min(i + 1, fr.nx - 1);
  const int j0 = std::max(j - 1, 0), j1 = std::min(j + 1, fr.nz - 1);
  const double cell = fr.cell_m();
  return Gradient{i1 > i0 ? (y(i1, j) - y(i0, j)) / ((i1 - i0) * cell) : 0.0,
                  j1 > j0 ? (y(i, j1) - y(i, j0)) / ((j1 - j0) * cell) : 0.0};
}

// Unit normal (−y_x, 1, −y_z)/√(y_x² + 1 + y_z²) of a gradient; (0, 0, 0) if it is not finite.
struct Normal {
  double x, y, z;
};
inline Normal normal_of(Gradient g) {
  double inv = 1.0 / std::sqrt(g.dx * g.dx + 1.0 + g.dz * g.dz);
  if (!std::isfinite(inv)) inv = 0;
  return Normal{-g.dx * inv, inv, -g.dz * inv};
}
inline Normal normal_at(const Frame& fr, const Layer& h, int i, int j) { return normal_of(gradient_at(fr, h, i, j)); }

// Slope angle of a gradient, degrees.
inline double slope_deg_of(Gradient g) { return std::atan(std::hypot(g.dx, g.dz)) * (180.0 / std::numbers::pi); }

// Unit normal of the triangle (a, b, c) (counter-clockwise seen from the side it points to): the
// normalised (b − a) × (c − a) in double. Returns false, leaving n unchanged, for a degenerate
// triangle.
inline bool face_normal(const float* a, const float* b, const float* c, double n[3]) {
  const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
  const double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
  const double x = uy * vz - uz * vy, y = uz * vx - ux * vz, z = ux * vy - uy * vx;
  const double len = std::sqrt(x * x + y * y + z * z);
  if (!(len > 0)) return false;
  n[0] = x / len, n[1] = y / len, n[2] = z / len;
  return true;
}

// The rows and factors of the single-precision gradient of row j of a one-channel layer h
// (pointwise.hpp: GradientRows), in metres per metre times `scale`: the differences of
// gradient_at taken on the float elevations, scaled by float(scale · height_m / (2·cell)).
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
// |∇|² in single precision at column i of the rows (the colour stage's rock rule, scalar form of
// color_row's): gx one-sided on the first and last column.
inline float gradient2_at(const GradientRows& rows, int i, int n) {
  const float* e = rows.mid;
  const float gx = n < 2        ? 0.0f
                   : i == 0     ? (e[1] - e[0]) * rows.edge
                   : i == n - 1 ? (e[n - 1] - e[n - 2]) * rows.edge
                                : (e[i + 1] - e[i - 1]) * rows.central;
  const float gz = (rows.down[i] - rows.up[i]) * rows.kz;
  return gx * gx + gz * gz;
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
// `albedo` is null; if not null either), both sized to the frame (existing buffers are reused).
// Single precision, the vectorised kernel of pointwise.hpp (hillshade_row): one pass over rows
// with a one-row halo, the same bits on every SIMD target. Row-parallel, deterministic. `height`
// has one channel. The hillshade stage, the hillshade writer (ambient 0, water_relief 1: plain
// Lambert) and the stage-by-stage pictures all shade through it.
void hillshade(const Frame& fr, const Layer& height, const Layer* albedo, const Light& light, Layer* shade,
               Layer* color);

}  // namespace relief::detail
