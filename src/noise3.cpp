// Noise3: 3D gradient and simplex noise, the settings' validation, the per-octave and per-row
// terms and the scalar reference implementation (the definition the Highway kernels in
// noise3_simd.cpp reproduce bit for bit).
//
// Sources (implemented from the papers' descriptions, not from anyone's code):
//   * Ken Perlin, "Improving Noise", SIGGRAPH 2002: quintic fade, gradients along the 12
//     directions from a cube's centre to its edges (here with 4 tetrahedral ones: 16, isotropic).
//   * Ken Perlin, "Noise hardware" (SIGGRAPH 2001 course notes), and Stefan Gustavson, "Simplex
//     noise demystified" (2005): radial kernels max(0, r² − |d|²)⁴·(g·d) on the simplex grid's
//     lattice, which is body-centred cubic (here taken axis-aligned, in rows along x: noise3.hpp).
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

// The two phases of a row's x split: p = 0 for the rows of Z³ (vertices at x = X), p = 1 for those of
// Z³ + ½ (vertices at x = X' + ½): the lower vertex's X·Pₓ and the offset d from it, in float.
struct S3Phase {
  std::uint32_t xp;
  float d;
};
inline void s3_phases(const detail::Noise3Octave& o, double x, S3Phase (&p)[2]) {
  const Split s = split(x * o.freq_x + o.offset_x);
  const std::uint32_t xp = s.i * detail::kG3Px;
  const bool hi = s.f >= 0.5f;  // then X' = X, d' = d − ½ (exact); else X' = X − 1, d' = d + ½
  p[0] = {xp, s.f};
  p[1] = {hi ? xp : xp - detail::kG3Px, hi ? s.f - 0.5f : s.f + 0.5f};
}

// One vertex's term max(0, rc − d_x²)⁴·(G·d), rc = ½ − (d_y² + d_z²) the row's part, G·d as
// ±(G_x·d_x + t[k & 7]) with t the row's G_y·d_y + G_z·d_z (negated for k ≥ 8).
inline float s3_term(std::uint32_t xp, std::uint32_t yz, float dx, float rc, const float* t) {
  float att = rc - dx * dx;
  att = att > 0.0f ? att : 0.0f;
  const std::uint32_t k = ((xp ^ yz) * detail::kG3M) >> 28;
  const float v = detail::kG3Xc * dx + t[k & 7];
  const float dot = k & 8 ? -v : v;
  const float a2 = att * att;
  return (a2 * a2) * dot;
}

inline float simplex3(const detail::Noise3Octave& o, const detail::Noise3Row& r, double x) {
  S3Phase p[2];
  s3_phases(o, x, p);
  float tm[8];
  for (int s = 0; s < 4; ++s) {
    const S3Phase& q = p[s >> 1];
    tm[2 * s] = s3_term(q.xp, r.yz[s], q.d, r.rc[s], r.t[s]);
    tm[2 * s + 1] = s3_term(q.xp + detail::kG3Px, r.yz[s], q.d - 1.0f, r.rc[s], r.t[s]);
  }
  return (((tm[0] + tm[1]) + (tm[2] + tm[3])) + ((tm[4] + tm[5]) + (tm[6] + tm[7]))) * detail::kS3Scale;
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

namespace {

// The row-constant half of G[k]·d, t[k] = G_y[k]·dy + G_z[k]·dz (k = 0..15: the tables repeat 0..7
// in 8..15, so entries 8..15 equal 0..7; computed, not copied: a wide reload of fresh scalar stores
// would stall on store forwarding).
void row_table(float dy, float dz, float* t) {
  for (int k = 0; k < 16; ++k) t[k] = kG3Y[k] * dy + kG3Z[k] * dz;
}

// Simplex: the four rows of the centred square lattice Z² ∪ (Z² + (½, ½)) around (v, w): the corners
// of its cell (a square of side √½ turned 45°) that holds (v, w). In the unit square [Y, Y + 1] ×
// [Z, Z + 1] around (v, w), with a = v − Y − ½, b = w − Z − ½: the square's centre (Y + ½, Z + ½), the
// two corners on the side nearest to (v, w) (y side if |a| ≥ |b|, at Y + 1 if a ≥ 0, else Y; z side
// likewise) and the centre of the unit square beyond that side. Every other row is at least √½ away,
// where the kernel is 0. Rows 0, 1: the corners (Z³'s rows; lower z or y first); 2, 3: the centres
// (Z³ + ½'s rows, the one of this square first), each named by its lower corner.
void simplex_rows(const Noise3Octave& o, Noise3Row& r) {
  const double Y = floor_exact(r.v), Z = floor_exact(r.w);
  const double a = (r.v - Y) - 0.5, b = (r.w - Z) - 0.5;
  double ry[4], rz[4];  // the rows' lower corners (integers)
  if (std::fabs(a) >= std::fabs(b)) {
    const double side = a >= 0.0 ? 1.0 : 0.0;
    ry[0] = Y + side, rz[0] = Z, ry[1] = Y + side, rz[1] = Z + 1.0;
    ry[2] = Y, rz[2] = Z, ry[3] = Y + (a >= 0.0 ? 1.0 : -1.0), rz[3] = Z;
  } else {
    const double side = b >= 0.0 ? 1.0 : 0.0;
    ry[0] = Y, rz[0] = Z + side, ry[1] = Y + 1.0, rz[1] = Z + side;
    ry[2] = Y, rz[2] = Z, ry[3] = Y, rz[3] = Z + (b >= 0.0 ? 1.0 : -1.0);
  }
  for (int s = 0; s < 4; ++s) {
    const double h = s >= 2 ? 0.5 : 0.0;
    const float dy = float(r.v - (ry[s] + h)), dz = float(r.w - (rz[s] + h));  // exact differences
    r.yz[s] = (low32(ry[s]) * kG3Py) ^ ((low32(rz[s]) * kG3Pz) ^ (s >= 2 ? o.key_half : o.key));
    r.ay[s] = dy, r.az[s] = dz;
    r.rc[s] = kS3R2 - (dy * dy + dz * dz);
    row_table(dy, dz, r.t[s]);
  }
  r.sy = r.sz = 0.0f;
}

}  // namespace

void noise3_row_terms(const Noise3Octave& o, NoiseBasis basis, double y_m, double z_m, Noise3Row& r) {
  r.v = y_m * o.freq_y + o.offset_y;
  r.w = z_m * o.freq_z + o.offset_z;
  if (basis != NoiseBasis::Gradient) {
    simplex_rows(o, r);
    return;
  }
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
    r.rc[c] = 0.0f;
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
    const std::uint64_t key_half = hash64(s.seed, detail::kTag3KeyHalf, ki);
    o.key_half = std::uint32_t(key_half ^ (key_half >> 32));
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
  if (nrows == 1) {
    row(y_m[0], z_m[0], i0, dx_m, n, out);
    return;
  }
  // Strips of columns whose terms (16 bytes per column per octave for gradient, 40 for simplex) fit
  // in about 32 KiB.
  const int arrays = a.basis == NoiseBasis::Gradient ? detail::kG3ColumnArrays : detail::kS3ColumnArrays;
  const int strip = std::max(64, (32768 / (4 * arrays * a.count)) / 64 * 64);
  const int width = std::min(strip, (n + 15) / 16 * 16);
  const std::size_t entries = std::size_t(arrays) * std::size_t(a.count) * std::size_t(width);
  constexpr std::align_val_t kAlign{64};
  std::unique_ptr<std::uint32_t, void (*)(std::uint32_t*)> cols(
      static_cast<std::uint32_t*>(::operator new(entries * sizeof(std::uint32_t), kAlign)),
      [](std::uint32_t* p) { ::operator delete(p, std::align_val_t{64}); });
  // Every row's (y, z) terms once (~400 bytes per row and octave; not zero-filled).
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
