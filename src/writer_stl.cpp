// Binary STL of a printable relief: a closed, consistently oriented solid made of the terrain
// surface, a vertical skirt down to z = 0 and a flat base, in millimetres, Z up.
//
// Format: "StereoLithography Interface Specification", 3D Systems, 1989 (binary form: 80-byte
// header, uint32 triangle count, then per triangle a float32 normal, three float32 vertices and
// a uint16 attribute; little-endian). The header must not start with "solid", which readers take
// for the ASCII form.
//
// Print space: X = east (our +x), Y = north (our −z), Z = up, so the print seen from above is the
// map seen from above (the map's z-min edge at the back). (x, y, z) → (x, −z, y) is a rotation,
// not a mirror, so triangles that wind counter-clockwise seen from +y wind counter-clockwise seen
// from +Z. Sizes: the longer horizontal side measures stl_size_mm; the lowest terrain point sits
// stl_base_mm above the bottom; heights are multiplied by stl_exaggeration. Vertex jiggle (the
// "offset" layer) applies inside; on the border it only moves along the border, so the skirt
// stays planar and the print keeps its size.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "relief/error.hpp"
#include "relief/export.hpp"
#include "surface.hpp"

namespace relief {

std::string encode_stl(const Terrain& t, const ExportOptions& o) {
  const Frame& f = t.frame;
  auto hit = t.layers.find("height");
  if (hit == t.layers.end()) throw Error("formats", "stl needs a 'height' layer (no elevation stage in the recipe?)");
  const Layer& h = hit->second;
  const int nx = f.nx, nz = f.nz;
  if (nx < 2 || nz < 2) throw Error("height", "a mesh needs at least 2x2 samples");
  if (h.channels != 1 || h.data.size() != f.count()) throw Error("height", "layer size does not match the frame");
  const Layer* off = nullptr;
  if (auto it = t.layers.find("offset"); it != t.layers.end()) {
    off = &it->second;
    if (off->channels != 2 || off->data.size() != f.count() * 2)
      throw Error("offset", "layer must have 2 channels (dx_m, dz_m) and " + std::to_string(f.count()) + " samples");
  }
  float lo = std::numeric_limits<float>::max();
  for (float e : h.data) {
    if (!std::isfinite(e)) throw Error("height", "non-finite elevation");
    lo = std::min(lo, e);
  }
  const double s = o.stl_size_mm / std::max(f.width_m(), f.depth_m());  // mm per metre
  const double zs = s * o.stl_exaggeration * f.height_m;                  // mm per unit of elevation

  // Vertices: the nx·nz top grid, then the bottom copies of the border, then the base centre.
  std::vector<float> v;
  v.reserve((f.count() + 2 * std::size_t(nx + nz)) * 3 + 3);
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      const std::size_t k = std::size_t(j) * nx + i;
      double dx = off ? off->data[2 * k] : 0.0, dz = off ? off->data[2 * k + 1] : 0.0;
      if (i == 0 || i == nx - 1) dx = 0;
      if (j == 0 || j == nz - 1) dz = 0;
      v.push_back(float((double(i) * f.cell_m() + dx) * s));
      v.push_back(float((f.depth_m() - (double(j) * f.cell_m() + dz)) * s));
      v.push_back(float(o.stl_base_mm + (double(h.data[k]) - lo) * zs));
    }
  // Border loop of top-grid indices, then oriented counter-clockwise seen from +Z.
  std::vector<std::uint32_t> loop;
  for (int i = 0; i < nx - 1; ++i) loop.push_back(std::uint32_t(i));
  for (int j = 0; j < nz - 1; ++j) loop.push_back(std::uint32_t(j * nx + nx - 1));
  for (int i = nx - 1; i > 0; --i) loop.push_back(std::uint32_t((nz - 1) * nx + i));
  for (int j = nz - 1; j > 0; --j) loop.push_back(std::uint32_t(j * nx));
  double area2 = 0;
  for (std::size_t k = 0; k < loop.size(); ++k) {
    const float* a = &v[3 * loop[k]];
    const float* b = &v[3 * loop[(k + 1) % loop.size()]];
    area2 += double(a[0]) * b[1] - double(b[0]) * a[1];
  }
  if (area2 < 0) std::reverse(loop.begin(), loop.end());
  const std::uint32_t bottom0 = std::uint32_t(v.size() / 3);
  for (std::uint32_t k : loop) v.insert(v.end(), {v[3 * k], v[3 * k + 1], 0.0f});
  const std::uint32_t centre = std::uint32_t(v.size() / 3);
  v.insert(v.end(), {float(f.width_m() * s / 2), float(f.depth_m() * s / 2), 0.0f});

  const std::size_t top = 2 * std::size_t(nx - 1) * (nz - 1), n = loop.size();
  const std::size_t count = top + 3 * n;
  if (count > 0xFFFFFFFFull) throw Error("output", "stl: more than 2^32 triangles");
  std::string out(84 + 50 * count, '\0');
  const char header[] = "binary STL: Relief terrain relief, millimetres, Z up, X east, Y north";
  std::memcpy(out.data(), header, sizeof header - 1);
  const std::uint32_t c32 = std::uint32_t(count);
  std::memcpy(out.data() + 80, &c32, 4);
  char* p = out.data() + 84;
  auto tri = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    const float* A = &v[3 * a];
    const float* B = &v[3 * b];
    const float* C = &v[3 * c];
    double n[3] = {0, 0, 0};  // a degenerate triangle has no normal
    detail::face_normal(A, B, C, n);
    const float rec[12] = {float(n[0]), float(n[1]), float(n[2]), A[0], A[1], A[2], B[0], B[1], B[2], C[0], C[1], C[2]};
    std::memcpy(p, rec, 48);  // little-endian floats on every target we build for
    p += 50;                  // + uint16 attribute 0
  };
  for (int j = 0; j + 1 < nz; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      const std::uint32_t a = std::uint32_t(j * nx + i), b = a + 1, d = a + std::uint32_t(nx), e = d + 1;
      tri(a, d, b);  // counter-clockwise seen from +y, hence from +Z
      tri(b, d, e);
    }
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t p0 = loop[k], p1 = loop[(k + 1) % n];
    const std::uint32_t b0 = bottom0 + std::uint32_t(k), b1 = bottom0 + std::uint32_t((k + 1) % n);
    tri(b0, b1, p1);  // skirt: outward, to the right of a counter-clockwise loop
    tri(b0, p1, p0);
    tri(centre, b1, b0);  // base: facing −Z
  }
  return out;
}

}  // namespace relief
