// Noise3: 3D gradient and simplex noise, the settings' validation, the per-octave and per-row
// terms and the scalar reference implementation (the definition the Highway kernels in
// noise3_simd.cpp reproduce bit for bit).
//
// Sources (implemented from the papers' descriptions, not from anyone's code):
//   * Ken Perlin, "Improving Noise", SIGGRAPH 2002: quintic fade, gradients along the 12
//     directions from a cube's centre to its edges (here with 4 tetrahedral ones: 16, isotropic).
//   * Ken Perlin, "Noise hardware" (SIGGRAPH 2001 course notes), and Stefan Gustavson, "Simplex
//     noise demystified" (2005): the skewed cubic lattice (F = 1/3, G = 1/6), the simplex found by
//     ranking the cell coordinates, radial kernels max(0, r² − |d|²)⁴·(g·d).
//   * F. K. Musgrave, "Texturing and Modeling" ch. 16: fBm, ridged multifractal, billow.
//
// Floating point: a fixed sequence of IEEE operations, no FMA contraction (the pragma below; GCC
// contracts by default once the target has FMA), so every machine and every SIMD target gives the
// same bits. The lattice split is in double, everything after it in float (noise3.hpp).
#include "relief/noise3.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <utility>
#include <vector>

#include "noise3_simd.hpp"
#include "noise_simd.hpp"
#include "relief/error.hpp"
#include "relief/random.hpp"

#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace relief {
namespace {

// The low 32 bits of the int64 an integer-valued double |v| ≤ 2⁵¹ holds (beyond: some fixed
// value; NaN: some value), read from the mantissa of v + 1.5·2⁵², as the kernels do.
inline std::uint32_t low32(double integral) {
  const double m = integral + detail::kMagicInt;
  std::uint64_t bits;
  std::memcpy(&bits, &m, 8);
  return std::uint32_t(bits);
}

// floor(u), bit for bit (±0, integers beyond 2⁵², ±inf and NaN are their own floor), without the
// libm call std::floor is on baseline x86-64 (no roundsd before SSE4.1): the per-row terms of
// short rows (volume chunks) spend most of their time here otherwise.
inline double floor_exact(double u) {
  if (!(std::fabs(u) < 4503599627370496.0) || u == 0.0) return u;
  const double t = double(std::int64_t(u));  // truncation, exact below 2⁵²
  return t > u ? t - 1.0 : t;
}

struct Split {
  std::uint32_t i;  // floor(u) modulo 2³²
  float f;          // u − floor(u), rounded to float
};
inline Split split(double u) {
  const double fl = floor_exact(u);
  return {low32(fl), float(u - fl)};
}

inline float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
inline float lerp(float t, float a, float b) { return a + t * (b - a); }

// ---- Gradient ------------------------------------------------------------------------------------

// G·d at a corner: k from the hash's top 4 bits; G[k & 7]·d as G_x·d_x + (G_y·d_y + G_z·d_z),
// negated when k ≥ 8 (G[k + 8] = −G[k]).
inline float g3_corner(std::uint32_t xp, std::uint32_t yz, float ax, float ay, float az) {
  const std::uint32_t k = ((xp ^ yz) * detail::kG3M) >> 28, g = k & 7;
  const float v = detail::kG3X[g] * ax + (detail::kG3Y[g] * ay + detail::kG3Z[g] * az);
  return k & 8 ? -v : v;
}

inline float gradient3(const detail::Noise3Octave& o, const detail::Noise3Row& r, double x) {
  const Split sx = split(x * o.freq_x + o.offset_x);
  const std::uint32_t xp0 = sx.i * detail::kG3Px, xp1 = xp0 + detail::kG3Px;  // (X + 1)·Pₓ mod 2³²
  const float fx = sx.f, fx1 = sx.f - 1.0f, wx = fade(sx.f);
  float l[4];
  for (int c = 0; c < 4; ++c)
    l[c] = lerp(wx, g3_corner(xp0, r.yz[c], fx, r.ay[c], r.az[c]), g3_corner(xp1, r.yz[c], fx1, r.ay[c], r.az[c]));
  return lerp(r.sz, lerp(r.sy, l[0], l[1]), lerp(r.sy, l[2], l[3]));
}

// ---- Simplex -------------------------------------------------------------------------------------

// One vertex's term max(0, ½ − |d|²)⁴·(G·d), G from the vertex's hash (negated for k ≥ 8, as above).
inline float s3_term(std::uint32_t xp, std::uint32_t yp, std::uint32_t zp, float dx, float dy, float dz) {
  float att = ((detail::kS3R2 - dx * dx) - dy * dy) - dz * dz;
  att = att > 0.0f ? att : 0.0f;
  const std::uint32_t k = ((xp ^ yp ^ zp) * detail::kG3M) >> 28, g = k & 7;
  const float v = (detail::kG3X[g] * dx + detail::kG3Y[g] * dy) + detail::kG3Z[g] * dz;
  const float dot = k & 8 ? -v : v;
  const float a2 = att * att;
  return (a2 * a2) * dot;
}

inline float simplex3(const detail::Noise3Octave& o, const detail::Noise3Row& r, double x) {
  const double u = x * o.freq_x + o.offset_x;
  const double s = (u + r.vw) * detail::kS3Skew;
  const Split a = split(u + s), b = split(r.v + s), c = split(r.w + s);
  const float t = ((a.f + b.f) + c.f) * detail::kS3Unskew;
  const float x0 = a.f - t, y0 = b.f - t, z0 = c.f - t;
  // The simplex: vertex 1 on the axis of the largest coordinate, vertex 2 on the two largest.
  const bool cxy = x0 >= y0, cyz = y0 >= z0, cxz = x0 >= z0;
  const bool i1 = cxy && cxz, j1 = !cxy && cyz, k1 = !cxz && !cyz;
  const bool i2 = cxy || cxz, j2 = !cxy || cyz, k2 = !cxz || !cyz;
  const std::uint32_t xp0 = a.i * detail::kG3Px, xp1 = xp0 + detail::kG3Px;
  const std::uint32_t yp0 = b.i * detail::kG3Py, yp1 = yp0 + detail::kG3Py;
  const std::uint32_t zr = c.i * detail::kG3Pz;
  const std::uint32_t zp0 = zr ^ o.key, zp1 = (zr + detail::kG3Pz) ^ o.key;
  auto one = [](bool v) { return v ? 1.0f : 0.0f; };
  const float t0 = s3_term(xp0, yp0, zp0, x0, y0, z0);
  const float t1 = s3_term(i1 ? xp1 : xp0, j1 ? yp1 : yp0, k1 ? zp1 : zp0, (x0 - one(i1)) + detail::kS3Unskew,
                           (y0 - one(j1)) + detail::kS3Unskew, (z0 - one(k1)) + detail::kS3Unskew);
  const float t2 = s3_term(i2 ? xp1 : xp0, j2 ? yp1 : yp0, k2 ? zp1 : zp0, (x0 - one(i2)) + detail::kS3Unskew2,
                           (y0 - one(j2)) + detail::kS3Unskew2, (z0 - one(k2)) + detail::kS3Unskew2);
  const float t3 = s3_term(xp1, yp1, zp1, x0 - 0.5f, y0 - 0.5f, z0 - 0.5f);
  return (((t0 + t1) + t2) + t3) * detail::kS3Scale;
}

// ---- validation ------------------------------------------------------------------------------------

const char* basis_name(NoiseBasis b) {
  switch (b) {
    case NoiseBasis::Perlin: return "perlin";
    case NoiseBasis::Simplex: return "simplex";
    case NoiseBasis::Value: return "value";
    case NoiseBasis::Cellular: return "cellular";
    case NoiseBasis::Gradient: return "gradient";
  }
  return "unknown";
}

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

namespace detail {

void noise3_row_terms(const Noise3Octave& o, NoiseBasis basis, double y_m, double z_m, Noise3Row& r) {
  r.v = y_m * o.freq_y + o.offset_y;
  r.w = z_m * o.freq_z + o.offset_z;
  r.vw = r.v + r.w;
  if (basis != NoiseBasis::Gradient) return;
  const Split sy = split(r.v), sz = split(r.w);
  const std::uint32_t yp0 = sy.i * kG3Py, yp1 = yp0 + kG3Py;
  const std::uint32_t zr = sz.i * kG3Pz;
  const std::uint32_t zp0 = zr ^ o.key, zp1 = (zr + kG3Pz) ^ o.key;
  const float fy1 = sy.f - 1.0f, fz1 = sz.f - 1.0f;
  r.yz[0] = yp0 ^ zp0;
  r.yz[1] = yp1 ^ zp0;
  r.yz[2] = yp0 ^ zp1;
  r.yz[3] = yp1 ^ zp1;
  r.ay[0] = sy.f, r.ay[1] = fy1, r.ay[2] = sy.f, r.ay[3] = fy1;
  r.az[0] = sz.f, r.az[1] = sz.f, r.az[2] = fz1, r.az[3] = fz1;
  r.sy = fade(sy.f);
  r.sz = fade(sz.f);
  // t[c][k] = G_y[k]·ay[c] + G_z[k]·az[c], each product computed once (ay and az take two values).
  float py[2][8], pz[2][8];
  for (int k = 0; k < 8; ++k) {
    py[0][k] = kG3Y[k] * sy.f, py[1][k] = kG3Y[k] * fy1;
    pz[0][k] = kG3Z[k] * sz.f, pz[1][k] = kG3Z[k] * fz1;
  }
  for (int c = 0; c < 4; ++c) {
    for (int k = 0; k < 8; ++k) r.t[c][k] = py[c & 1][k] + pz[c >> 1][k];
    std::memcpy(&r.t[c][8], &r.t[c][0], 8 * sizeof(float));  // entries 8..15 repeat 0..7
  }
}

}  // namespace detail

struct Noise3::State {
  std::vector<detail::Noise3Octave> octaves;
  detail::Noise3Args args;
};

Noise3::Noise3(const NoiseSettings& s) : s_(s) {
  if (s.basis != NoiseBasis::Gradient && s.basis != NoiseBasis::Simplex)
    throw Error("basis", std::string("3D noise supports basis gradient or simplex, got ") + basis_name(s.basis));
  for (auto [field, v] : {std::pair{"period_x_m", s.period_x_m}, std::pair{"period_z_m", s.period_z_m}})
    if (v != 0.0) throw Error(field, "3D noise is not periodic: expected 0, got " + num(v));
  if (s.warp_m != 0.0) throw Error("warp_m", "3D noise has no domain warp: expected 0, got " + num(s.warp_m));
  // Everything else exactly as the 2D Noise checks it (same fields, same messages).
  { const Noise check(s); }

  auto st = std::make_shared<State>();
  const int count = s.fractal == Fractal::None ? 1 : s.octaves;
  double f = s.frequency, amp = 1.0, amp_sum = 0.0;
  for (int k = 0; k < count; ++k) {
    detail::Noise3Octave o;
    o.freq_x = f * s.scale_x;
    o.freq_y = f;
    o.freq_z = f * s.scale_z;
    const std::uint64_t ki = std::uint64_t(k);
    o.offset_x = 256.0 * unit_double(hash64(s.seed, detail::kTag3Offset, 3 * ki));
    o.offset_y = 256.0 * unit_double(hash64(s.seed, detail::kTag3Offset, 3 * ki + 1));
    o.offset_z = 256.0 * unit_double(hash64(s.seed, detail::kTag3Offset, 3 * ki + 2));
    o.amp = float(amp);
    const std::uint64_t key = hash64(s.seed, detail::kTag3Key, ki);
    o.key = std::uint32_t(key ^ (key >> 32));
    st->octaves.push_back(o);
    amp_sum += amp;
    f *= s.lacunarity;
    amp *= s.persistence;
  }
  detail::Noise3Args& a = st->args;
  a.basis = s.basis;
  a.fractal = s.fractal;
  a.inv = float(1.0 / amp_sum);
  a.octaves = st->octaves.data();
  a.count = count;
  state_ = std::move(st);
}

void Noise3::row_reference(double y_m, double z_m, std::int64_t i0, double dx_m, int n, float* out) const {
  const detail::Noise3Args& a = state_->args;
  std::vector<detail::Noise3Row> rows(std::size_t(a.count));
  for (int k = 0; k < a.count; ++k) detail::noise3_row_terms(a.octaves[k], a.basis, y_m, z_m, rows[std::size_t(k)]);
  const bool gradient = a.basis == NoiseBasis::Gradient;
  const float inv = a.inv, inv2 = inv + inv;  // ridged: 2·(acc·inv) as acc·(2·inv), ×2 exact
  for (int i = 0; i < n; ++i) {
    const double x = double(i0 + i) * dx_m;
    float acc = 0.0f;
    for (int k = 0; k < a.count; ++k) {
      const detail::Noise3Octave& o = a.octaves[k];
      const float v = gradient ? gradient3(o, rows[std::size_t(k)], x) : simplex3(o, rows[std::size_t(k)], x);
      switch (a.fractal) {
        case Fractal::None:
        case Fractal::Fbm: acc = acc + o.amp * v; break;
        case Fractal::Ridged: {
          const float r = 1.0f - std::fabs(v);
          acc = acc + o.amp * (r * r);
          break;
        }
        case Fractal::Billow: acc = acc + o.amp * (2.0f * std::fabs(v) - 1.0f); break;
      }
    }
    float v = a.fractal == Fractal::Ridged ? acc * inv2 - 1.0f : acc * inv;
    v = v > -1.0f ? v : -1.0f;  // NaN → −1
    out[i] = v < 1.0f ? v : 1.0f;
  }
}

void Noise3::row(double y_m, double z_m, std::int64_t i0, double dx_m, int n, float* out) const {
  if (n <= 0) return;
  const detail::Noise3Args& a = state_->args;
  detail::Noise3Row rows[kMaxOctaves];
  for (int k = 0; k < a.count; ++k) detail::noise3_row_terms(a.octaves[k], a.basis, y_m, z_m, rows[k]);
  detail::noise3_row_simd(a, rows, i0, dx_m, n, out);
}

void Noise3::rows(const double* y_m, const double* z_m, int nrows, std::int64_t i0, double dx_m, int n, float* out,
                  std::ptrdiff_t stride) const {
  if (n <= 0 || nrows <= 0) return;
  const detail::Noise3Args& a = state_->args;
  if (a.basis != NoiseBasis::Gradient || nrows == 1) {
    for (int r = 0; r < nrows; ++r) row(y_m[r], z_m[r], i0, dx_m, n, out + r * stride);
    return;
  }
  // Strips of columns whose terms (16 bytes per column per octave) fit in about 32 KiB.
  const int strip = std::max(64, (32768 / (16 * a.count)) / 64 * 64);
  const int width = std::min(strip, (n + 15) / 16 * 16);
  const std::size_t entries = std::size_t(detail::kG3ColumnArrays) * std::size_t(a.count) * std::size_t(width);
  constexpr std::align_val_t kAlign{64};
  std::unique_ptr<std::uint32_t, void (*)(std::uint32_t*)> cols(
      static_cast<std::uint32_t*>(::operator new(entries * sizeof(std::uint32_t), kAlign)),
      [](std::uint32_t* p) { ::operator delete(p, std::align_val_t{64}); });
  // Every row's (y, z) terms once (384 bytes per row and octave; not zero-filled).
  const std::unique_ptr<detail::Noise3Row[]> rt(new detail::Noise3Row[std::size_t(nrows) * std::size_t(a.count)]);
  for (int r = 0; r < nrows; ++r)
    for (int k = 0; k < a.count; ++k)
      detail::noise3_row_terms(a.octaves[k], a.basis, y_m[r], z_m[r], rt[std::size_t(r) * std::size_t(a.count) + std::size_t(k)]);
  for (int c0 = 0; c0 < n; c0 += strip) {
    const int m = std::min(strip, n - c0);
    const int npad = (m + 15) / 16 * 16;
    detail::noise3_columns_simd(a, i0 + c0, dx_m, npad, cols.get(), width);
    for (int r = 0; r < nrows; ++r)
      detail::noise3_row_columns_simd(a, rt.get() + std::size_t(r) * std::size_t(a.count), cols.get(), width, m,
                                      out + r * stride + c0);
  }
}

float Noise3::at(double x_m, double y_m, double z_m) const {
  float v = 0.0f;
  row(y_m, z_m, 1, x_m, 1, &v);  // x = double(1)·x_m = x_m exactly
  return v;
}

}  // namespace relief
