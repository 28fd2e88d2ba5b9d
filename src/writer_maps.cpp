// Maps for engines and artists: tangent-space normal maps, splat (weight) maps, hillshade, and the
// engine heightmap profiles (Unity RAW, Unreal PNG, Godot EXR/r16) with optional tiling.
//
// Our image convention: column = +x, row 0 = the z-min edge. Engine orientation (each profile's
// sidecar states it too):
//   * Unity is left-handed (x right, y up, z forward). Mapping our z to Unity −z keeps the map
//     unmirrored, and Unity's RAW import puts file row 0 at terrain z = 0 (its z-min, our z-max
//     edge): the Unity profile writes rows bottom-up (flipped). Leave "Flip Vertically" off.
//   * Unreal (left-handed, Z up): image column → +X, image row → +Y, the same as our x and z with
//     y → Z; no flip.
//   * Godot (right-handed, Y up) and its heightmap terrain plugins map pixel (x, y) to world
//     (x, z): no flip.
// Normal maps: the surface normal of surface.hpp, ∝ (−y_x, 1, −y_z) (central differences). In tangent
// space the texture's "right" is +x and its "up" (towards row 0) is −z, so R = n_x, G = −n_z
// (OpenGL, +Y up) or n_z (DirectX, +Y down), B = n_y.
// Splat weights are quantised with the largest-remainder method so that the 8-bit weights of a
// sample sum to exactly 255 across all splat images.
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfOutputFile.h>

#include <algorithm>
#include <limits>
#include <cmath>
#include <cstring>
#include <numeric>

#include "../src/parallel.hpp"
#include "relief/error.hpp"
#include "relief/export.hpp"
#include "relief/output.hpp"
#include "surface.hpp"

namespace relief {
namespace {

const Layer& height_of(const Terrain& t, const char* writer) {
  auto it = t.layers.find("height");
  if (it == t.layers.end()) throw Error("formats", std::string(writer) + " needs a 'height' layer (no elevation stage in the recipe?)");
  const Layer& h = it->second;
  if (h.channels != 1 || h.data.size() != t.frame.count()) throw Error("height", "layer size does not match the frame");
  return h;
}

// Unit normal of sample (i, j) (surface.hpp: central differences, one-sided at the border).
struct Normals {
  const Frame& f;
  const Layer& h;
  void at(int i, int j, double n[3]) const {
    const detail::Normal v = detail::normal_at(f, h, i, j);
    n[0] = v.x, n[1] = v.y, n[2] = v.z;
  }
};

double smoothstep(double a, double b, double x) {
  if (b <= a) return x >= b ? 1.0 : 0.0;
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// Largest-remainder rounding of weights (summing to 1) to integers summing to 255.
void quantise_255(const double* w, int n, std::uint8_t* out) {
  int q[64];
  double rem[64];
  int sum = 0;
  for (int c = 0; c < n; ++c) {
    const double x = std::clamp(w[c], 0.0, 1.0) * 255.0;
    q[c] = int(std::floor(x));
    rem[c] = x - q[c];
    sum += q[c];
  }
  for (int left = 255 - sum; left > 0; --left) {
    int best = 0;
    for (int c = 1; c < n; ++c)
      if (rem[c] > rem[best]) best = c;
    q[best] += 1;
    rem[best] = -1;
  }
  for (int c = 0; c < n; ++c) out[c] = std::uint8_t(std::clamp(q[c], 0, 255));
}

class MemoryStream final : public Imf::OStream {
 public:
  MemoryStream() : Imf::OStream("memory") {}
  void write(const char c[], int n) override {
    if (pos_ + std::size_t(n) > data.size()) data.resize(pos_ + std::size_t(n));
    std::memcpy(data.data() + pos_, c, std::size_t(n));
    pos_ += std::size_t(n);
  }
  uint64_t tellp() override { return pos_; }
  void seekp(uint64_t pos) override { pos_ = std::size_t(pos); }
  std::string data;

 private:
  std::size_t pos_ = 0;
};

}  // namespace

std::string encode_exr_gray32(const std::vector<float>& values, int nx, int nz) {
  if (nx < 1 || nz < 1 || values.size() != std::size_t(nx) * std::size_t(nz)) throw Error("output", "exr: size mismatch");
  Imf::Header header(nx, nz);
  header.compression() = Imf::ZIP_COMPRESSION;
  header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
  Imf::FrameBuffer fb;
  fb.insert("Y", Imf::Slice(Imf::FLOAT, const_cast<char*>(reinterpret_cast<const char*>(values.data())), sizeof(float),
                            sizeof(float) * std::size_t(nx)));
  MemoryStream ms;
  try {
    Imf::OutputFile file(ms, header, 0);
    file.setFrameBuffer(fb);
    file.writePixels(nz);
  } catch (const std::exception& e) {
    throw Error("output", std::string("exr: ") + e.what());
  }
  return std::move(ms.data);
}

std::string encode_normal_map(const Terrain& t, int bits, bool directx) {
  const Frame& f = t.frame;
  const Layer& h = height_of(t, "normalmap");
  if (bits != 8 && bits != 16) throw Error("normal_bits", "expected 8 or 16, got " + std::to_string(bits));
  const Normals nm{f, h};
  const double g_sign = directx ? 1.0 : -1.0;
  // (n + 1) / 2 in 8 or 16 bits per channel.
  auto encode = [&](auto sample) {
    using T = decltype(sample);
    constexpr double kMax = double(std::numeric_limits<T>::max());
    std::vector<T> px(f.count() * 3);
    detail::parallel_rows(f.nz, [&](int j) {
      for (int i = 0; i < f.nx; ++i) {
        double v[3];
        nm.at(i, j, v);
        const double c[3] = {v[0], g_sign * v[2], v[1]};
        for (int k = 0; k < 3; ++k) px[(std::size_t(j) * f.nx + i) * 3 + k] = T(std::lround((c[k] + 1) * 0.5 * kMax));
      }
    });
    return encode_png_pixels(px.data(), px.size() * sizeof(T), f.nx, f.nz, int(8 * sizeof(T)), 3);
  };
  return bits == 8 ? encode(std::uint8_t{}) : encode(std::uint16_t{});
}

std::string encode_hillshade(const Terrain& t, double azimuth_deg, double altitude_deg) {
  const Frame& f = t.frame;
  const Layer& h = height_of(t, "hillshade");
  // The hillshade of surface.hpp as plain Lambert: max(0, n · l), no ambient light, the sea shaded
  // like the land.
  detail::Light light;
  light.azimuth_deg = azimuth_deg;
  light.altitude_deg = altitude_deg;
  light.z_factor = 1.0;
  light.ambient = 0.0;
  light.water_relief = 1.0;
  Layer shade;
  detail::hillshade(f, h, nullptr, light, &shade, nullptr);
  std::vector<std::uint8_t> px(f.count());
  detail::parallel_rows(f.nz, [&](int j) {
    const float* s = shade.row(j, f.nx);
    for (int i = 0; i < f.nx; ++i)
      px[std::size_t(j) * f.nx + i] = std::uint8_t(std::lround(std::clamp(double(s[i]), 0.0, 1.0) * 255));
  });
  return encode_png_pixels(px.data(), px.size(), f.nx, f.nz, 8, 1);
}

SplatMaps encode_splat(const Terrain& t, const ExportOptions& o, const OptionPath& path_of) {
  const Frame& f = t.frame;
  const Layer& h = height_of(t, "splat");
  const Layer* biome = nullptr;
  if (auto it = t.layers.find("biome"); it != t.layers.end()) biome = &it->second;
  const bool use_biome = o.splat_source == SplatSource::Biome || (o.splat_source == SplatSource::Auto && biome);
  if (o.splat_source == SplatSource::Biome && !biome)
    throw Error(option_path(path_of, "splat_source"), "\"biome\" needs a 'biome' layer in the terrain");

  SplatMaps out;
  int layers = 4;
  std::vector<std::string> names;
  std::vector<int> ids;
  if (use_biome) {
    if (biome->channels != 1 || biome->data.size() != f.count()) throw Error("biome", "layer size does not match the frame");
    int max_id = 0;
    for (float v : biome->data) {
      if (!std::isfinite(v) || v < 0 || v > 63) throw Error("biome", "biome ids must be integers in 0..63");
      max_id = std::max(max_id, int(std::lround(v)));
    }
    layers = max_id + 1;
    for (int k = 0; k < layers; ++k) names.push_back("biome " + std::to_string(k)), ids.push_back(k);
  } else {
    names = {"sand", "grass", "rock", "snow"};
  }
  const int images = (layers + 3) / 4;
  std::vector<std::vector<std::uint8_t>> px(std::size_t(images), std::vector<std::uint8_t>(f.count() * 4, 0));
  const Normals nm{f, h};
  detail::parallel_rows(f.nz, [&](int j) {
    std::vector<double> w(static_cast<std::size_t>(layers));
    std::uint8_t q[64];
    for (int i = 0; i < f.nx; ++i) {
      std::fill(w.begin(), w.end(), 0.0);
      if (use_biome) {
        // Soft borders: the share of each biome in the 3×3 neighbourhood (clamped at the edges).
        int cnt = 0;
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            const int ii = std::clamp(i + di, 0, f.nx - 1), jj = std::clamp(j + dj, 0, f.nz - 1);
            w[std::size_t(std::lround(biome->data[std::size_t(jj) * f.nx + ii]))] += 1;
            ++cnt;
          }
        for (double& x : w) x /= cnt;
      } else {
        const double e = h.data[std::size_t(j) * f.nx + i], y = f.y_m(e);
        double n[3];
        nm.at(i, j, n);
        const double slope = std::acos(std::clamp(n[1], -1.0, 1.0)) * 180 / M_PI;
        const double rock = std::max(smoothstep(o.splat_rock_slope_deg - 5, o.splat_rock_slope_deg + 5, slope),
                                     smoothstep(o.splat_rock_elevation - 0.02, o.splat_rock_elevation + 0.02, e));
        const double snow = smoothstep(o.splat_snow_elevation - 0.02, o.splat_snow_elevation + 0.02, e);
        const double sand = 1 - smoothstep(o.splat_beach_m, o.splat_beach_m + std::max(2.0, 0.5 * o.splat_beach_m), y);
        // Priority rock > snow > sand > grass; the four weights sum to 1 by construction.
        w[2] = rock;
        w[3] = snow * (1 - rock);
        w[0] = sand * (1 - rock) * (1 - snow);
        w[1] = (1 - rock) * (1 - snow) * (1 - sand);
      }
      quantise_255(w.data(), layers, q);
      for (int c = 0; c < layers; ++c) px[std::size_t(c / 4)][(std::size_t(j) * f.nx + i) * 4 + std::size_t(c % 4)] = q[c];
    }
  });
  json ch = json::array();
  for (int c = 0; c < images * 4; ++c) {
    json e = {{"image", "splat" + std::to_string(c / 4) + ".png"}, {"channel", std::string(1, "RGBA"[c % 4])}};
    if (c < layers) {
      e["layer"] = names[std::size_t(c)];
      if (use_biome) e["biome_id"] = ids[std::size_t(c)];
    } else {
      e["layer"] = nullptr;  // padding channel, always 0
    }
    ch.push_back(e);
  }
  out.description = {{"source", use_biome ? "biome" : "rules"},
                     {"width", f.nx},
                     {"height", f.nz},
                     {"layout", "image column = +x, row 0 = the z-min edge"},
                     {"weights", "8-bit; per sample the weights of all channels of all images sum to 255"},
                     {"channels", ch}};
  if (!use_biome)
    out.description["rules"] = {{"sand", "up to splat_beach_m above the sea"},
                                {"grass", "everything else"},
                                {"rock", "slopes from splat_rock_slope_deg, elevations from splat_rock_elevation"},
                                {"snow", "normalised elevation from splat_snow_elevation"},
                                {"splat_beach_m", o.splat_beach_m},
                                {"splat_rock_slope_deg", o.splat_rock_slope_deg},
                                {"splat_rock_elevation", o.splat_rock_elevation},
                                {"splat_snow_elevation", o.splat_snow_elevation}};
  for (auto& p : px) out.images.push_back(encode_png_pixels(p.data(), p.size(), f.nx, f.nz, 8, 4));
  return out;
}

}  // namespace relief
