// The "image" stage: a raster the user brings (heightmap, mask, elevation model) read into a layer.
//
// Placement in world metres: `extent` stretches the image so that its first pixel's centre sits at
// (x_m, z_m) and its last at (x_m + width_m, z_m + depth_m) (0 = the world's width / depth):
// corners included, the convention of Relief's own heightmaps, so a 513² height.png read into a
// 513² world lands sample on sample. `georeference` keeps the file's pixel size in metres (a
// GeoTIFF's transform, a Relief sidecar's metres_per_pixel) with its first pixel at (x_m, z_m).
//
// Sampling is a function of world position only (pixel coordinate u = (x − x_m) / pixel size, snapped
// to the nearest integer within 1e-9 so grid-aligned samples read their pixel exactly), so the stage
// is pointwise: a 257² preview equals every other sample of the 513² build. Filters: bicubic
// (Keys 1981, "Cubic convolution interpolation for digital image processing", a = −0.5, with
// Keys' boundary condition f(−1) = 3f(0) − 3f(1) + f(2), so linear and quadratic ramps stay exact up
// to the image's edge), bilinear, nearest. Separable: each row combines four image rows once, then
// four columns per sample; the taps of every column are computed once per run.
//
// Values: `normalised` maps code / code_max (or a float file's value) v to low + (high − low)·v;
// `metres` maps metres m (float files as stored; PNG/r16 codes through low_m..high_m or the file's
// sidecar) to elevation sea_level + (m − sea_m) / world.height_m. Then the blend (as the noise
// stage's, plus `lerp` by a mask layer) and a clamp to 0..1.
#include <algorithm>
#include <cmath>
#include <mutex>

#include "parallel.hpp"
#include "relief/image.hpp"
#include "stages.hpp"

namespace relief::stages {
namespace {

enum class Placement { Extent, Georeference };
enum class Filter { Bicubic, Bilinear, Nearest };
enum class Outside { Clamp, Keep };
enum class Values { Normalised, Metres };
enum class Blend { Set, Add, Multiply, Max, Min, Lerp };

struct ImageParams {
  std::string layer = "height";
  std::string path;
  RasterFormat format = RasterFormat::Auto;
  Placement placement = Placement::Extent;
  double x_m = 0, z_m = 0, width_m = 0, depth_m = 0;
  Filter filter = Filter::Bicubic;
  Outside outside = Outside::Clamp;
  Values values = Values::Normalised;
  double low = 0, high = 1;
  double low_m = 0, high_m = 0;
  double sea_m = 0;
  Blend blend = Blend::Set;
  std::string blend_mask;
};

Table<ImageParams> table() {
  using P = ImageParams;
  return Table<P>{{
      text(&P::layer, "layer", "Layer to write (height, or any mask name)"),
      text(&P::path, "path", "Raster file: PNG (8/16-bit), OpenEXR, Relief's .r16 (+ .json), GeoTIFF or any GDAL format; relative to the recipe's folder"),
      choice(&P::format, "format",
             {{RasterFormat::Auto, "auto"}, {RasterFormat::Png, "png"}, {RasterFormat::Exr, "exr"}, {RasterFormat::R16, "r16"},
              {RasterFormat::Gdal, "gdal"}},
             "File format (auto: from the file's first bytes, then its name)"),
      choice(&P::placement, "placement", {{Placement::Extent, "extent"}, {Placement::Georeference, "georeference"}},
             "extent: the image spans x_m..x_m+width_m, z_m..z_m+depth_m (pixel centres, corners included); "
             "georeference: the file's own pixel size in metres, first pixel at (x_m, z_m)"),
      param(&P::x_m, "x_m", -1e7, 1e7, "m", "World x of the image's first pixel centre"),
      param(&P::z_m, "z_m", -1e7, 1e7, "m", "World z of the image's first pixel centre"),
      param(&P::width_m, "width_m", 0, 1e7, "m", "extent: x distance from the first to the last pixel centre (0 = the world's width)"),
      param(&P::depth_m, "depth_m", 0, 1e7, "m", "extent: z distance from the first to the last pixel centre (0 = the world's depth)"),
      choice(&P::filter, "filter", {{Filter::Bicubic, "bicubic"}, {Filter::Bilinear, "bilinear"}, {Filter::Nearest, "nearest"}},
             "Resampling between pixel centres"),
      choice(&P::outside, "outside", {{Outside::Clamp, "clamp"}, {Outside::Keep, "keep"}},
             "Beyond the image: its edge pixels repeat (clamp), or the layer is left as it is (keep)"),
      choice(&P::values, "values", {{Values::Normalised, "normalised"}, {Values::Metres, "metres"}},
             "normalised: 0..1 (codes / 255 or 65535) map to low..high; metres: file metres map through world.height_m"),
      param(&P::low, "low", -4, 4, "", "normalised: elevation of value 0"),
      param(&P::high, "high", -4, 4, "", "normalised: elevation of value 1"),
      param(&P::low_m, "low_m", -1e5, 1e5, "m", "metres: metres of code 0 of a PNG or r16 (low_m = high_m = 0: the file's sidecar)"),
      param(&P::high_m, "high_m", -1e5, 1e5, "m", "metres: metres of the highest code of a PNG or r16"),
      param(&P::sea_m, "sea_m", -1e5, 1e5, "m", "metres: the file's metres that lie at the world's sea level"),
      choice(&P::blend, "blend",
             {{Blend::Set, "set"}, {Blend::Add, "add"}, {Blend::Multiply, "multiply"}, {Blend::Max, "max"}, {Blend::Min, "min"},
              {Blend::Lerp, "lerp"}},
             "How the image combines with the layer's current values (lerp: by the layer named in blend_mask)"),
      text(&P::blend_mask, "blend_mask", "lerp: mask layer (0..1) weighting the image against the current values"),
  }};
}

void validate(const ImageParams& p, const std::string& path) {
  if (p.layer.empty()) throw Error(path + ".layer", "expected a layer name, got \"\"");
  if (p.blend == Blend::Lerp && p.blend_mask.empty()) throw Error(path + ".blend_mask", "blend lerp needs a mask layer name");
  // The header only: a missing, unreadable, corrupt or oversized file is refused before anything
  // is generated. The pixels are decoded once per run, when the stage runs (cached_raster). No file
  // (the default, e.g. a stage just inserted in the studio) parses, and its run is refused.
  if (p.path.empty()) return;
  const Raster r = probe_raster(p.path, p.format, path + ".path");
  if (p.placement == Placement::Georeference && !r.has_geo)
    throw Error(path + ".placement", "'" + p.path + "' has no georeference (GeoTIFF transform or Relief sidecar): use extent");
}

// Taps of one axis position: `n` consecutive pixels from `start` with their weights.
struct Taps {
  int start = 0, n = 0;
  double w[4] = {0, 0, 0, 0};
  bool outside = false;
};

Taps taps_at_full(double u, int size, Filter filter, Outside outside);

// The taps with one weight of exactly 1 (a grid-aligned sample) reduced to that one tap: the same
// sum (the others add +0), read with one load (the native-resolution case stays near a copy).
Taps taps_at(double u, int size, Filter filter, Outside outside) {
  Taps t = taps_at_full(u, size, filter, outside);
  int ones = -1, nonzero = 0;
  for (int k = 0; k < t.n; ++k) {
    if (t.w[k] != 0) ++nonzero;
    if (t.w[k] == 1) ones = k;
  }
  if (nonzero == 1 && ones >= 0) {
    t.start += ones;
    t.n = 1;
    t.w[0] = 1;
    t.w[1] = t.w[2] = t.w[3] = 0;
  }
  return t;
}

Taps taps_at_full(double u, int size, Filter filter, Outside outside) {
  Taps t;
  if (std::isnan(u)) u = 0;
  const double r = std::nearbyint(u);
  if (std::abs(u - r) <= 1e-9 * std::max(1.0, std::abs(u))) u = r;
  if (u < 0 || u > size - 1) {
    if (outside == Outside::Keep) {
      t.outside = true;
      return t;
    }
    u = std::clamp(u, 0.0, double(size - 1));
  }
  if (size == 1) {
    t.n = 1;
    t.w[0] = 1;
    return t;
  }
  if (filter == Filter::Nearest) {
    t.start = int(std::clamp(std::floor(u + 0.5), 0.0, double(size - 1)));
    t.n = 1;
    t.w[0] = 1;
    return t;
  }
  int i0 = int(std::floor(u));
  if (i0 >= size - 1) i0 = size - 2;
  const double f = u - i0;
  if (filter == Filter::Bilinear) {
    t.start = i0;
    t.n = 2;
    t.w[0] = 1 - f;
    t.w[1] = f;
    return t;
  }
  // Catmull-Rom (Keys a = −0.5) taps at i0−1 .. i0+2.
  const double f2 = f * f, f3 = f2 * f;
  const double wt[4] = {(-f3 + 2 * f2 - f) / 2, (3 * f3 - 5 * f2 + 2) / 2, (-3 * f3 + 4 * f2 + f) / 2, (f3 - f2) / 2};
  t.n = std::min(size, 4);
  t.start = std::clamp(i0 - 1, 0, size - t.n);
  auto add = [&](int idx, double w) { t.w[idx - t.start] += w; };
  for (int k = 0; k < 4; ++k) {
    const int idx = i0 - 1 + k;
    const double w = wt[k];
    if (w == 0) continue;
    if (idx >= 0 && idx < size) {
      add(idx, w);
    } else if (size >= 3) {  // Keys' boundary: f(−1) = 3f(0) − 3f(1) + f(2), mirrored at the far end
      const int a = idx < 0 ? 0 : size - 1, b = idx < 0 ? 1 : size - 2, c = idx < 0 ? 2 : size - 3;
      add(a, 3 * w);
      add(b, -3 * w);
      add(c, w);
    } else {  // two pixels: linear extrapolation f(−1) = 2f(0) − f(1)
      const int a = idx < 0 ? 0 : 1, b = idx < 0 ? 1 : 0;
      add(a, 2 * w);
      add(b, -w);
    }
  }
  return t;
}

void apply(Terrain& t, const ImageParams& p, const Context& ctx) {
  const std::string stage = "stages[" + std::to_string(ctx.stage_index) + "]";
  const std::shared_ptr<const Raster> rp = cached_raster(p.path, p.format, stage + ".path");
  const Raster& r = *rp;
  const Frame& f = t.frame;
  if (p.placement == Placement::Georeference && !r.has_geo)
    throw Error(stage + ".placement", "'" + p.path + "' has no georeference: use extent");
  // Pixel sizes in metres (extent: the span over the pixel-centre intervals; one pixel: any size).
  double px = 0, pz = 0;
  if (p.placement == Placement::Georeference) {
    px = r.pixel_x_m;
    pz = r.pixel_z_m;
  } else {
    const double w = p.width_m > 0 ? p.width_m : f.world_width_m, d = p.depth_m > 0 ? p.depth_m : f.world_depth_m;
    px = r.width > 1 ? w / (r.width - 1) : 1.0;
    pz = r.height > 1 ? d / (r.height - 1) : 1.0;
  }
  if (!(px > 0) || !(pz > 0) || !std::isfinite(px) || !std::isfinite(pz))
    throw Error(stage + ".placement", "'" + p.path + "' gives no usable pixel size in metres");
  // Value mapping: e = a·v + b.
  double a = 1, b = 0;
  if (p.values == Values::Normalised) {
    const double scale = r.code_max > 0 ? 1.0 / r.code_max : 1.0;
    a = (p.high - p.low) * scale;
    b = p.low;
  } else {
    double m_scale = 1, m_off = 0;  // metres = m_off + m_scale·v
    if (r.code_max > 0) {
      double lo = p.low_m, hi = p.high_m;
      if (lo == 0 && hi == 0) {
        if (!r.has_range_m)
          throw Error(stage + ".low_m", "'" + p.path + "' holds codes, not metres, and has no sidecar giving their range: set low_m and high_m");
        lo = r.min_m;
        hi = r.max_m;
      }
      m_scale = (hi - lo) / r.code_max;
      m_off = lo;
    }
    a = m_scale / f.height_m;
    b = f.sea_level + (m_off - p.sea_m) / f.height_m;
  }
  const bool existed = t.has(p.layer) && t.layers[p.layer].channels == 1;
  Blend mode = p.blend;
  if (!existed && mode == Blend::Multiply) mode = Blend::Set;
  const Layer* mask = nullptr;
  if (mode == Blend::Lerp) {
    auto it = t.layers.find(p.blend_mask);
    if (it == t.layers.end() || it->second.channels != 1)
      throw Error(stage + ".blend_mask", "no one-channel layer '" + p.blend_mask + "' (a stage before this one must write it)");
    mask = &it->second;
  }
  Layer& out = t.layer(p.layer, 1);
  std::vector<Taps> cols(std::size_t(f.nx));
  int cmin = r.width, cmax = -1;
  for (int i = 0; i < f.nx; ++i) {
    cols[std::size_t(i)] = taps_at((f.x_m(i) - p.x_m) / px, r.width, p.filter, p.outside);
    const Taps& c = cols[std::size_t(i)];
    if (!c.outside) cmin = std::min(cmin, c.start), cmax = std::max(cmax, c.start + c.n - 1);
  }
  // Grid-aligned columns (native resolution, or any whole-pixel spacing of 1): every column one tap
  // of weight 1 at consecutive pixels. Its rows skip the separable pass (same values: 1·v + 0).
  bool direct = cmax >= cmin;
  for (int i = 0; i < f.nx && direct; ++i) {
    const Taps& c = cols[std::size_t(i)];
    direct = !c.outside && c.n == 1 && c.start == cols[0].start + i;
  }
  bool some_outside = false;
  for (const Taps& c : cols) some_outside = some_outside || c.outside;
  // One blend over a row of image values s(i) (a functor), the mode chosen outside the loop.
  auto blend_row = [&](float* row, const float* mrow, auto&& value) {
    auto each = [&](auto&& op) {
      if (!some_outside) {
        for (int i = 0; i < f.nx; ++i) row[i] = std::clamp(op(row[i], float(a * value(i) + b), i), 0.0f, 1.0f);
        return;
      }
      for (int i = 0; i < f.nx; ++i) {
        if (cols[std::size_t(i)].outside) continue;
        row[i] = std::clamp(op(row[i], float(a * value(i) + b), i), 0.0f, 1.0f);
      }
    };
    switch (mode) {
      case Blend::Set: each([](float, float u, int) { return u; }); break;
      case Blend::Add: each([](float h, float u, int) { return h + u; }); break;
      case Blend::Multiply: each([](float h, float u, int) { return h * u; }); break;
      case Blend::Max: each([](float h, float u, int) { return std::max(h, u); }); break;
      case Blend::Min: each([](float h, float u, int) { return std::min(h, u); }); break;
      case Blend::Lerp: each([&](float h, float u, int i) { return h + std::clamp(mrow[i], 0.0f, 1.0f) * (u - h); }); break;
    }
  };
  detail::parallel_rows(f.nz, [&](int j) {
    const Taps rt = taps_at((f.z_m(j) - p.z_m) / pz, r.height, p.filter, p.outside);
    if (rt.outside || cmax < cmin) return;
    float* row = out.row(j, f.nx);
    const float* mrow = mask ? mask->row(j, f.nx) : nullptr;
    if (direct && rt.n == 1) {
      const float* src = r.values.data() + std::size_t(rt.start) * std::size_t(r.width) + std::size_t(cols[0].start);
      blend_row(row, mrow, [src](int i) { return double(src[i]); });
      return;
    }
    thread_local std::vector<double> tmp;
    tmp.resize(std::size_t(r.width));
    for (int c = cmin; c <= cmax; ++c) {
      double s = 0;
      for (int k = 0; k < rt.n; ++k) s += rt.w[k] * double(r.values[std::size_t(rt.start + k) * std::size_t(r.width) + std::size_t(c)]);
      tmp[std::size_t(c)] = s;
    }
    blend_row(row, mrow, [&](int i) {
      const Taps& c = cols[std::size_t(i)];
      double s = 0;
      for (int k = 0; k < c.n; ++k) s += c.w[k] * tmp[std::size_t(c.start + k)];
      return s;
    });
  });
}

}  // namespace

StageDef image() {
  StageDef d = make_stage<ImageParams>("image", "A raster you bring (PNG, OpenEXR, r16, GeoTIFF, …) into a layer, placed in world metres",
                                       pointwise(), table(), apply, validate);
  d.memory.layer_param = "layer";
  return d;
}

}  // namespace relief::stages
