// Classic simplex and improved Perlin noise with Perlin's permutation, as the Python `noise` package
// computes them (relief/noise_classic.hpp says what, to the bit, and where we differ).
//
// Sources: Perlin 2001 (simplex noise), Gustavson 2005 "Simplex noise demystified" (the skew
// factors F = (√(n+1) − 1)/n, G = (1 − 1/√(n+1))/n, kernel radii, gradient sets), Perlin 2002
// (improved noise). The fast sine used for tiling is the parabola approximation the package uses
// (x in half-turns: y = 4(x − x|x|)… refined as y·(3.1 + 3.6|y|) after dividing out the 4).
//
// Why the code looks the way it does: every expression keeps the package's order of operations in
// float (the build has -ffp-contract=off, so no FMA), because the point of these functions is the
// same bits. The array functions evaluate one octave over a block of points at a time with
// branch-free bodies (selects instead of ifs, table lookups instead of switches) so that the
// compiler vectorises them with gathers; target_clones picks AVX-512, AVX2 or the baseline at run
// time. Every clone computes the same IEEE operations, so the bits do not depend on the CPU.
#include "relief/noise_classic.hpp"

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include "relief/noise.hpp"

namespace relief::classic {
namespace {

// Gustavson's 3D gradient set (the 12 cube edges, plus 4 repeats for a power-of-two table).
constexpr float kGrad3[16][3] = {{1, 1, 0},  {-1, 1, 0}, {1, -1, 0}, {-1, -1, 0}, {1, 0, 1},  {-1, 0, 1}, {1, 0, -1}, {-1, 0, -1},
                                 {0, 1, 1},  {0, -1, 1}, {0, 1, -1}, {0, -1, -1}, {1, 0, -1}, {-1, 0, -1}, {0, -1, 1}, {0, 1, 1}};

struct Tables {
  std::array<std::int32_t, 256> p{};  // Perlin's permutation; index & 255 everywhere
  // Simplex: gradient components of the lattice hash h (0..511): kGrad3[P[h] % 12].
  std::array<float, 512> sg0{}, sg1{}, sg2{};
  // 2D simplex: the first two components of kGrad3[P[h] % 12] packed in 4 bits as
  // (gx + 1) | (gy + 1) << 2; and for each lattice cell (I, J) the codes of its four corners
  // gc[I + P[J]], gc[I+1 + P[J]], gc[I + P[J+1]], gc[I+1 + P[J+1]] (indices & 255) in one int,
  // g4[J·256 + I] (256 KB): the three corners a sample needs come from one lookup instead of nine
  // dependent ones (one gather per octave in the vectorised loops).
  std::array<std::int32_t, 512> gc{};
  std::vector<std::int32_t> g4;
};

Tables make_tables() {
  Tables t;
  const auto& perm = perlin_permutation();
  for (int k = 0; k < 256; ++k) t.p[k] = perm[k];
  for (int h = 0; h < 512; ++h) {
    const int g = t.p[h & 255] % 12;
    t.sg0[h] = kGrad3[g][0];
    t.sg1[h] = kGrad3[g][1];
    t.sg2[h] = kGrad3[g][2];
    t.gc[h] = (int(kGrad3[g][0]) + 1) | ((int(kGrad3[g][1]) + 1) << 2);
  }
  t.g4.resize(256 * 256);
  auto code = [&](int i, int j) { return t.gc[(i & 255) + t.p[j & 255]]; };
  for (int j = 0; j < 256; ++j)
    for (int i = 0; i < 256; ++i)
      t.g4[std::size_t(j) * 256 + i] = code(i, j) | code(i + 1, j) << 4 | code(i, j + 1) << 8 | code(i + 1, j + 1) << 12;
  return t;
}

const Tables& tables() {
  static const Tables t = make_tables();
  return t;
}

// The package's fast sine, x in half-turns (x = 2 is a full turn).
inline float fast_sin(float x) {
  const float z = x + 25165824.0f;  // 1.5·2²⁴: rounds x to an even integer (float spacing 2 there)
  x = x - (z - 25165824.0f);
  const float y = x - x * std::fabs(x);
  const float Q = 3.1f, P = 3.6f;
  return y * (Q + P * std::fabs(y));
}
inline float fast_cos(float x) { return fast_sin(x + 0.5f); }

// floor for |v| < 2³¹ (beyond 2²⁴ every float is an integer and the lattice arithmetic is meaningless
// anyway): truncation and a correction, which the vectoriser handles (it does not vectorise
// std::floor without -fno-trapping-math). Equal to std::floor in that range.
inline float lattice_floor(float v) {
  // Integer arithmetic for the correction: a float subtraction under a condition would be kept
  // from vectorising without AVX-512 masks (-ftrapping-math).
  const int t = int(v);
  return float(t - (float(t) > v));
}

// max(v, 0) with +0 for v ≤ 0, by masking the bits: no branch or select that the compiler could
// turn back into a branch around the arithmetic that follows (which -ftrapping-math then keeps from
// vectorising on AVX2, where there are no masked operations).
inline float positive_part(float v) { return std::bit_cast<float>(std::bit_cast<std::int32_t>(v) & -std::int32_t(v > 0.0f)); }

constexpr float F2 = 0.3660254037844386f;   // (√3 − 1) / 2
constexpr float G2 = 0.21132486540518713f;  // (3 − √3) / 6

__attribute__((always_inline)) inline float simplex2_t(const Tables& T, float x, float y) {
  const float s = (x + y) * F2;
  const float i = lattice_floor(x + s);
  const float j = lattice_floor(y + s);
  const float t = (i + j) * G2;
  const float x0 = x - (i - t);
  const float y0 = y - (j - t);
  const int i1 = x0 > y0;
  const int j1 = x0 <= y0;
  const float x2 = x0 + G2 * 2.0f - 1.0f;
  const float y2 = y0 + G2 * 2.0f - 1.0f;
  const float x1 = x0 - float(i1) + G2;
  const float y1 = y0 - float(j1) + G2;
  const int I = int(i) & 255;
  const int J = int(j) & 255;
  // Gradient of corner (I + a, J + b): kGrad3[PERM[I + a + PERM[J + b]] % 12], packed (Tables::g4).
  const int cell = T.g4.data()[J * 256 + I];
  const int c0 = cell & 15;
  const int c1 = (cell >> (8 - 4 * i1)) & 15;  // (I+1, J) when i1, else (I, J+1)
  const int c2 = (cell >> 12) & 15;
  const float f0 = 0.5f - x0 * x0 - y0 * y0;
  const float f1 = 0.5f - x1 * x1 - y1 * y1;
  const float f2 = 0.5f - x2 * x2 - y2 * y2;
  const float d0 = float((c0 & 3) - 1) * x0 + float(((c0 >> 2) & 3) - 1) * y0;
  const float d1 = float((c1 & 3) - 1) * x1 + float(((c1 >> 2) & 3) - 1) * y1;
  const float d2 = float((c2 & 3) - 1) * x2 + float(((c2 >> 2) & 3) - 1) * y2;
  // No branch (the package skips a corner with f ≤ 0; here its kernel is 0): everything is computed
  // for every lane, so the loops vectorise. The one difference: where the package adds +0 for a
  // skipped corner we add 0·d (±0), so an exactly zero result may differ in its sign.
  const float e0 = positive_part(f0), e1 = positive_part(f1), e2 = positive_part(f2);
  const float n0 = e0 * e0 * e0 * e0 * d0;
  const float n1 = e1 * e1 * e1 * e1 * d1;
  const float n2 = e2 * e2 * e2 * e2 * d2;
  return (n0 + n1 + n2) * 70.0f;
}

constexpr float F3 = 1.0f / 3.0f;
constexpr float G3 = 1.0f / 6.0f;

__attribute__((always_inline)) inline float simplex3_t(const Tables& T, float x, float y, float z) {
  const float s = (x + y + z) * F3;
  const float i = lattice_floor(x + s);
  const float j = lattice_floor(y + s);
  const float k = lattice_floor(z + s);
  const float t = (i + j + k) * G3;
  const float x0 = x - (i - t), y0 = y - (j - t), z0 = z - (k - t);
  // Corner offsets, in the package's order (see the header for the one case it orders differently).
  const bool xy = x0 >= y0, yz = y0 >= z0, xz = x0 >= z0;
  // The simplex's second and third corners (Gustavson): by the order of x0, y0, z0, as boolean
  // arithmetic (no branches, so the array loops vectorise).
  //   x ≥ y: y ≥ z → (1,0,0), (1,1,0);  x ≥ z > y → (1,0,0), (1,0,1);  z > x → (0,0,1), (1,0,1)
  //   x < y: z > y → (0,0,1), (0,1,1);  z > x → (0,1,0), (0,1,1);      else  → (0,1,0), (1,1,0)
  const int a1 = xy & (yz | xz);
  const int b1 = !xy & yz;
  const int c1 = xy ? (!yz & !xz) : !yz;
  const int a2 = xy | (yz & xz);
  const int b2 = !xy | yz;
  const int c2 = xy ? !yz : (!yz | !xz);
  const float x1 = x0 - float(a1) + G3, y1 = y0 - float(b1) + G3, z1 = z0 - float(c1) + G3;
  const float x2 = x0 - float(a2) + 2.0f * G3, y2 = y0 - float(b2) + 2.0f * G3, z2 = z0 - float(c2) + 2.0f * G3;
  const float x3 = x0 - 1.0f + 3.0f * G3, y3 = y0 - 1.0f + 3.0f * G3, z3 = z0 - 1.0f + 3.0f * G3;
  const int I = int(i) & 255, J = int(j) & 255, K = int(k) & 255;
  const int h0 = I + T.p[(J + T.p[K]) & 255];
  const int h1 = I + a1 + T.p[(J + b1 + T.p[(c1 + K) & 255]) & 255];
  const int h2 = I + a2 + T.p[(J + b2 + T.p[(c2 + K) & 255]) & 255];
  const int h3 = I + 1 + T.p[(J + 1 + T.p[(K + 1) & 255]) & 255];
  const float f0 = 0.6f - x0 * x0 - y0 * y0 - z0 * z0;
  const float f1 = 0.6f - x1 * x1 - y1 * y1 - z1 * z1;
  const float f2 = 0.6f - x2 * x2 - y2 * y2 - z2 * z2;
  const float f3 = 0.6f - x3 * x3 - y3 * y3 - z3 * z3;
  const float d0 = x0 * T.sg0[h0] + y0 * T.sg1[h0] + z0 * T.sg2[h0];
  const float d1 = x1 * T.sg0[h1] + y1 * T.sg1[h1] + z1 * T.sg2[h1];
  const float d2 = x2 * T.sg0[h2] + y2 * T.sg1[h2] + z2 * T.sg2[h2];
  const float d3 = x3 * T.sg0[h3] + y3 * T.sg1[h3] + z3 * T.sg2[h3];
  // Branch-free as in simplex2_t (only an exact zero's sign can differ from the package).
  const float e0 = positive_part(f0), e1 = positive_part(f1), e2 = positive_part(f2), e3 = positive_part(f3);
  const float n0 = e0 * e0 * e0 * e0 * d0;
  const float n1 = e1 * e1 * e1 * e1 * d1;
  const float n2 = e2 * e2 * e2 * e2 * d2;
  const float n3 = e3 * e3 * e3 * e3 * d3;
  return (n0 + n1 + n2 + n3) * 32.0f;
}

constexpr float F4 = 0.30901699437494745f;  // (√5 − 1) / 4
constexpr float G4 = 0.1381966011250105f;   // (5 − √5) / 20

__attribute__((always_inline)) inline float simplex4_t(const Tables& T, float x, float y, float z, float w) {
  const float s = (x + y + z + w) * F4;
  const float i = lattice_floor(x + s), j = lattice_floor(y + s), k = lattice_floor(z + s), l = lattice_floor(w + s);
  const float t = (i + j + k + l) * G4;
  const float x0 = x - (i - t), y0 = y - (j - t), z0 = z - (k - t), w0 = w - (l - t);
  // Rank of each coordinate among the four (how many of the others it exceeds): Gustavson's
  // SIMPLEX[c] table for the comparison code c, computed instead of looked up (every code that
  // comparisons of real numbers can produce is a consistent order, so the two agree).
  const int xy = x0 > y0, xz = x0 > z0, yz = y0 > z0, xw = x0 > w0, yw = y0 > w0, zw = z0 > w0;
  const int r0 = xy + xz + xw, r1 = !xy + yz + yw, r2 = !xz + !yz + zw, r3 = !xw + !yw + !zw;
  const int i1 = r0 >= 3, j1 = r1 >= 3, k1 = r2 >= 3, l1 = r3 >= 3;
  const int i2 = r0 >= 2, j2 = r1 >= 2, k2 = r2 >= 2, l2 = r3 >= 2;
  const int i3 = r0 >= 1, j3 = r1 >= 1, k3 = r2 >= 1, l3 = r3 >= 1;
  const float x1 = x0 - float(i1) + G4, y1 = y0 - float(j1) + G4, z1 = z0 - float(k1) + G4, w1 = w0 - float(l1) + G4;
  const float x2 = x0 - float(i2) + 2.0f * G4, y2 = y0 - float(j2) + 2.0f * G4, z2 = z0 - float(k2) + 2.0f * G4,
              w2 = w0 - float(l2) + 2.0f * G4;
  const float x3 = x0 - float(i3) + 3.0f * G4, y3 = y0 - float(j3) + 3.0f * G4, z3 = z0 - float(k3) + 3.0f * G4,
              w3 = w0 - float(l3) + 3.0f * G4;
  const float x4 = x0 - 1.0f + 4.0f * G4, y4 = y0 - 1.0f + 4.0f * G4, z4 = z0 - 1.0f + 4.0f * G4, w4 = w0 - 1.0f + 4.0f * G4;
  const int I = int(i) & 255, J = int(j) & 255, K = int(k) & 255, L = int(l) & 255;
  auto hash = [&](int a, int b, int cc, int d) {
    return T.p[(I + a + T.p[(J + b + T.p[(K + cc + T.p[(L + d) & 255]) & 255]) & 255]) & 255] & 0x1f;
  };
  const int g0 = hash(0, 0, 0, 0), g1 = hash(i1, j1, k1, l1), g2 = hash(i2, j2, k2, l2), g3 = hash(i3, j3, k3, l3),
            g4 = hash(1, 1, 1, 1);
  // Gradient g (0..31) of Gustavson's 4D set: zero at coordinate g >> 3, the other three ±1 with
  // the signs in the bits of g & 7 (first non-zero coordinate in bit 2), computed, not looked up.
  // Branch-free like simplex2_t (a corner out of reach adds 0·dot, so only an exact zero's sign
  // can differ from the package).
  auto term = [&](float tt, int g, float a, float b, float cc, float d) {
    const int zero = g >> 3, sg = g & 7;
    auto comp = [&](int axis) {
      const int r = axis - (axis > zero);  // 3 only for axis == zero, whose component is 0 anyway
      return float((axis != zero) * (1 - 2 * ((sg >> ((2 - r) & 3)) & 1)));  // & 3: no negative shift
    };
    float e = positive_part(tt);  // the package keeps tt = 0 too: the same zero
    e *= e;
    return e * e * (comp(0) * a + comp(1) * b + comp(2) * cc + comp(3) * d);
  };
  const float n0 = term(0.6f - x0 * x0 - y0 * y0 - z0 * z0 - w0 * w0, g0, x0, y0, z0, w0);
  const float n1 = term(0.6f - x1 * x1 - y1 * y1 - z1 * z1 - w1 * w1, g1, x1, y1, z1, w1);
  const float n2 = term(0.6f - x2 * x2 - y2 * y2 - z2 * z2 - w2 * w2, g2, x2, y2, z2, w2);
  const float n3 = term(0.6f - x3 * x3 - y3 * y3 - z3 * z3 - w3 * w3, g3, x3, y3, z3, w3);
  const float n4 = term(0.6f - x4 * x4 - y4 * y4 - z4 * z4 - w4 * w4, g4, x4, y4, z4, w4);
  return float(27.0 * double(n0 + n1 + n2 + n3 + n4));
}

inline float lerp(float t, float a, float b) { return a + t * (b - a); }
inline float fade(float x) { return x * x * x * (x * (x * 6 - 15) + 10); }
inline float grad2(int hash, float x, float y) {
  const int h = hash & 15;
  return x * kGrad3[h][0] + y * kGrad3[h][1];
}
inline float grad3(int hash, float x, float y, float z) {
  const int h = hash & 15;
  return x * kGrad3[h][0] + y * kGrad3[h][1] + z * kGrad3[h][2];
}

inline float improved2_t(const Tables& T, float x, float y, float repeatx, float repeaty, int base) {
  int i = int(std::floor(std::fmod(x, repeatx)));
  int j = int(std::floor(std::fmod(y, repeaty)));
  int ii = int(std::fmod(float(i + 1), repeatx));
  int jj = int(std::fmod(float(j + 1), repeaty));
  i = (i & 255) + base;
  j = (j & 255) + base;
  ii = (ii & 255) + base;
  jj = (jj & 255) + base;
  x -= std::floor(x);
  y -= std::floor(y);
  const float fx = fade(x), fy = fade(y);
  auto P = [&](int h) { return T.p[h & 255]; };
  const int A = P(i), AA = P(A + j), AB = P(A + jj), B = P(ii), BA = P(B + j), BB = P(B + jj);
  return lerp(fy, lerp(fx, grad2(P(AA), x, y), grad2(P(BA), x - 1, y)), lerp(fx, grad2(P(AB), x, y - 1), grad2(P(BB), x - 1, y - 1)));
}

inline float improved3_t(const Tables& T, float x, float y, float z, int repeatx, int repeaty, int repeatz, int base) {
  int i = int(std::floor(std::fmod(x, float(repeatx))));
  int j = int(std::floor(std::fmod(y, float(repeaty))));
  int k = int(std::floor(std::fmod(z, float(repeatz))));
  int ii = int(std::fmod(float(i + 1), float(repeatx)));
  int jj = int(std::fmod(float(j + 1), float(repeaty)));
  int kk = int(std::fmod(float(k + 1), float(repeatz)));
  i = (i & 255) + base;
  j = (j & 255) + base;
  k = (k & 255) + base;
  ii = (ii & 255) + base;
  jj = (jj & 255) + base;
  kk = (kk & 255) + base;
  x -= std::floor(x);
  y -= std::floor(y);
  z -= std::floor(z);
  const float fx = fade(x), fy = fade(y), fz = fade(z);
  auto P = [&](int h) { return T.p[h & 255]; };
  const int A = P(i), AA = P(A + j), AB = P(A + jj), B = P(ii), BA = P(B + j), BB = P(B + jj);
  return lerp(fz,
              lerp(fy, lerp(fx, grad3(P(AA + k), x, y, z), grad3(P(BA + k), x - 1, y, z)),
                   lerp(fx, grad3(P(AB + k), x, y - 1, z), grad3(P(BB + k), x - 1, y - 1, z))),
              lerp(fy, lerp(fx, grad3(P(AA + kk), x, y, z - 1), grad3(P(BA + kk), x - 1, y, z - 1)),
                   lerp(fx, grad3(P(AB + kk), x, y - 1, z - 1), grad3(P(BB + kk), x - 1, y - 1, z - 1))));
}

inline float fbm3(const Tables& T, float x, float y, float z, int octaves, float persistence, float lacunarity) {
  float freq = 1.0f, amp = 1.0f, max = 1.0f;
  float total = simplex3_t(T, x, y, z);
  for (int i = 1; i < octaves; ++i) {
    freq *= lacunarity;
    amp *= persistence;
    max += amp;
    total += simplex3_t(T, x * freq, y * freq, z * freq) * amp;
  }
  return total / max;
}

inline float fbm4(const Tables& T, float x, float y, float z, float w, int octaves, float persistence, float lacunarity) {
  float freq = 1.0f, amp = 1.0f, max = 1.0f;
  float total = simplex4_t(T, x, y, z, w);
  for (int i = 1; i < octaves; ++i) {
    freq *= lacunarity;
    amp *= persistence;
    max += amp;
    total += simplex4_t(T, x * freq, y * freq, z * freq, w * freq) * amp;
  }
  return total / max;
}

float snoise2_tiled(const Tables& T, float x, float y, int octaves, float persistence, float lacunarity, float repeatx, float repeaty,
                    float z) {
  float w = z;
  if (repeaty != kNoRepeat) {
    const float yf = float(double(y) * 2.0 / double(repeaty));
    const float yr = float(double(repeaty) * 0.31830988618379067154 * 0.5);
    const float vy = fast_sin(yf), vyz = fast_cos(yf);
    y = vy * yr;
    w += vyz * yr;
    if (repeatx == kNoRepeat) return fbm3(T, x, y, w, octaves, persistence, lacunarity);
  }
  if (repeatx != kNoRepeat) {
    const float xf = float(double(x) * 2.0 / double(repeatx));
    const float xr = float(double(repeatx) * 0.31830988618379067154 * 0.5);
    const float vx = fast_sin(xf), vxz = fast_cos(xf);
    x = vx * xr;
    z += vxz * xr;
    if (repeaty == kNoRepeat) return fbm3(T, x, y, z, octaves, persistence, lacunarity);
  }
  return fbm4(T, x, y, z, w, octaves, persistence, lacunarity);
}

}  // namespace

float simplex2(float x, float y) { return simplex2_t(tables(), x, y); }
float simplex3(float x, float y, float z) { return simplex3_t(tables(), x, y, z); }
float simplex4(float x, float y, float z, float w) { return simplex4_t(tables(), x, y, z, w); }
float improved2(float x, float y, float repeatx, float repeaty, int base) { return improved2_t(tables(), x, y, repeatx, repeaty, base); }
float improved3(float x, float y, float z, int repeatx, int repeaty, int repeatz, int base) {
  return improved3_t(tables(), x, y, z, repeatx, repeaty, repeatz, base);
}

float snoise2(float x, float y, int octaves, float persistence, float lacunarity, float repeatx, float repeaty, float base) {
  const Tables& T = tables();
  if (repeatx != kNoRepeat || repeaty != kNoRepeat) return snoise2_tiled(T, x, y, octaves, persistence, lacunarity, repeatx, repeaty, base);
  float freq = 1.0f, amp = 1.0f, max = 1.0f;
  float total = simplex2_t(T, x + base, y + base);
  for (int i = 1; i < octaves; ++i) {
    freq *= lacunarity;
    amp *= persistence;
    max += amp;
    total += simplex2_t(T, x * freq + base, y * freq + base) * amp;
  }
  return total / max;
}

float snoise3(float x, float y, float z, int octaves, float persistence, float lacunarity) {
  const Tables& T = tables();
  if (octaves == 1) return simplex3_t(T, x, y, z);
  return fbm3(T, x, y, z, octaves, persistence, lacunarity);
}

float pnoise2(float x, float y, int octaves, float persistence, float lacunarity, float repeatx, float repeaty, int base) {
  const Tables& T = tables();
  if (octaves == 1) return improved2_t(T, x, y, repeatx, repeaty, base);
  float freq = 1.0f, amp = 1.0f, max = 0.0f, total = 0.0f;
  for (int i = 0; i < octaves; ++i) {
    total += improved2_t(T, x * freq, y * freq, repeatx * freq, repeaty * freq, base) * amp;
    max += amp;
    freq *= lacunarity;
    amp *= persistence;
  }
  return total / max;
}

float pnoise3(float x, float y, float z, int octaves, float persistence, float lacunarity, int repeatx, int repeaty, int repeatz, int base) {
  const Tables& T = tables();
  if (octaves == 1) return improved3_t(T, x, y, z, repeatx, repeaty, repeatz, base);
  float freq = 1.0f, amp = 1.0f, max = 0.0f, total = 0.0f;
  for (int i = 0; i < octaves; ++i) {
    total += improved3_t(T, x * freq, y * freq, z * freq, int(float(repeatx) * freq), int(float(repeaty) * freq),
                         int(float(repeatz) * freq), base) *
             amp;
    max += amp;
    freq *= lacunarity;
    amp *= persistence;
  }
  return total / max;
}

// ---- arrays ---------------------------------------------------------------------------------
// The octave loop runs outside the point loop, so each inner loop is one simplex evaluation per
// point with no loop-carried state: the shape the vectoriser handles (gathers for the tables).

namespace {

constexpr std::size_t kBlock = 256;

// Sums go into a local array (n ≤ kBlock): the compiler can then prove that the stores do not
// alias the tables it gathers from, which it cannot for the caller's `out`.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void snoise2_flat_block(
    const Tables& T, const float* __restrict x, const float* __restrict y, std::size_t n, int octaves, float persistence,
    float lacunarity, float base, float* __restrict out) {
  float acc[kBlock];
  for (std::size_t k = 0; k < n; ++k) acc[k] = simplex2_t(T, x[k] + base, y[k] + base);
  float freq = 1.0f, amp = 1.0f, max = 1.0f;
  for (int i = 1; i < octaves; ++i) {
    freq *= lacunarity;
    amp *= persistence;
    max += amp;
    for (std::size_t k = 0; k < n; ++k) acc[k] += simplex2_t(T, x[k] * freq + base, y[k] * freq + base) * amp;
  }
  for (std::size_t k = 0; k < n; ++k) out[k] = acc[k] / max;
}

#if defined(__x86_64__) && defined(__GNUC__)
// snoise2_flat_block written out for AVX2 (8 lanes), for CPUs with AVX2 but not AVX-512 (those
// keep the x86-64-v4 clone). The compiler's v3 clone of the loop above spends a third of its work
// turning the packed gradient codes into floats (shift, mask, subtract, convert per component) and
// emulates the table gather with 8 extracts and inserts. Here a gradient component is one
// vpermps of a constant 8-entry table indexed by the code's low 3 bits (entry c = (c & 3) − 1,
// the same float the scalar code makes), and the gather is vpgatherdd. Every floating-point
// operation is the scalar code's, in its order (lattice_floor and positive_part as integer and mask
// operations on the same values), so the bits are those of simplex2_t: tests/test_noise_classic.cpp
// and python/tests/test_compat.py check them. Measured on an AMD EPYC (Zen 3): see README (Python).
#define RELIEF_AVX2 __attribute__((target("avx2"), always_inline)) inline
RELIEF_AVX2 __m256 lfloor_avx2(__m256 v) {  // lattice_floor: float(t - (float(t) > v)), t = int(v)
  const __m256i t = _mm256_cvttps_epi32(v);
  const __m256i gt = _mm256_castps_si256(_mm256_cmp_ps(_mm256_cvtepi32_ps(t), v, _CMP_GT_OQ));
  return _mm256_cvtepi32_ps(_mm256_add_epi32(t, gt));
}
RELIEF_AVX2 __m256 positive_part_avx2(__m256 v) { return _mm256_and_ps(v, _mm256_cmp_ps(v, _mm256_setzero_ps(), _CMP_GT_OQ)); }
RELIEF_AVX2 __m256 grad_avx2(__m256i code) {  // (code & 3) - 1 as a float, from the code's low 3 bits
  return _mm256_permutevar8x32_ps(_mm256_setr_ps(-1.0f, 0.0f, 1.0f, 2.0f, -1.0f, 0.0f, 1.0f, 2.0f), code);
}
RELIEF_AVX2 __m256 kernel_avx2(__m256 e, __m256 d) { return _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(e, e), e), e), d); }

// One simplex2_t over 8 lanes, in two halves so that a block can run them as two loops: the first
// (skew, lattice cell, x0/y0, the gather of the cell's gradient codes) for every point, then the
// second (the three corners' kernels). Each loop has short dependency chains, so the gather's
// latency overlaps with other points' work instead of stalling one long chain.
RELIEF_AVX2 __m256i simplex2_cell_avx2(const std::int32_t* g4, __m256 x, __m256 y, __m256& x0, __m256& y0) {
  const __m256 s = _mm256_mul_ps(_mm256_add_ps(x, y), _mm256_set1_ps(F2));
  const __m256 i = lfloor_avx2(_mm256_add_ps(x, s));
  const __m256 j = lfloor_avx2(_mm256_add_ps(y, s));
  const __m256 t = _mm256_mul_ps(_mm256_add_ps(i, j), _mm256_set1_ps(G2));
  x0 = _mm256_sub_ps(x, _mm256_sub_ps(i, t));
  y0 = _mm256_sub_ps(y, _mm256_sub_ps(j, t));
  const __m256i m255 = _mm256_set1_epi32(255);
  const __m256i I = _mm256_and_si256(_mm256_cvttps_epi32(i), m255);
  const __m256i J = _mm256_and_si256(_mm256_cvttps_epi32(j), m255);
  return _mm256_i32gather_epi32(reinterpret_cast<const int*>(g4), _mm256_add_epi32(_mm256_slli_epi32(J, 8), I), 4);
}

RELIEF_AVX2 __m256 simplex2_corners_avx2(__m256 x0, __m256 y0, __m256i cell) {
  const __m256 g2 = _mm256_set1_ps(G2), g2x2m = _mm256_set1_ps(G2 * 2.0f), one = _mm256_set1_ps(1.0f), half = _mm256_set1_ps(0.5f);
  const __m256 i1 = _mm256_cmp_ps(x0, y0, _CMP_GT_OQ);  // x0 > y0
  const __m256 j1 = _mm256_cmp_ps(x0, y0, _CMP_LE_OQ);  // x0 <= y0
  const __m256 x2 = _mm256_sub_ps(_mm256_add_ps(x0, g2x2m), one);
  const __m256 y2 = _mm256_sub_ps(_mm256_add_ps(y0, g2x2m), one);
  const __m256 x1 = _mm256_add_ps(_mm256_sub_ps(x0, _mm256_and_ps(i1, one)), g2);
  const __m256 y1 = _mm256_add_ps(_mm256_sub_ps(y0, _mm256_and_ps(j1, one)), g2);
  // Corner 1's code at bit 8 − 4·i1 (i1 as the mask −1/0: 8 + 4·mask).
  const __m256i c1 = _mm256_srlv_epi32(cell, _mm256_add_epi32(_mm256_set1_epi32(8), _mm256_slli_epi32(_mm256_castps_si256(i1), 2)));
  const __m256i c2 = _mm256_srli_epi32(cell, 12);
  const __m256 f0 = _mm256_sub_ps(_mm256_sub_ps(half, _mm256_mul_ps(x0, x0)), _mm256_mul_ps(y0, y0));
  const __m256 f1 = _mm256_sub_ps(_mm256_sub_ps(half, _mm256_mul_ps(x1, x1)), _mm256_mul_ps(y1, y1));
  const __m256 f2 = _mm256_sub_ps(_mm256_sub_ps(half, _mm256_mul_ps(x2, x2)), _mm256_mul_ps(y2, y2));
  const __m256 d0 = _mm256_add_ps(_mm256_mul_ps(grad_avx2(cell), x0), _mm256_mul_ps(grad_avx2(_mm256_srli_epi32(cell, 2)), y0));
  const __m256 d1 = _mm256_add_ps(_mm256_mul_ps(grad_avx2(c1), x1), _mm256_mul_ps(grad_avx2(_mm256_srli_epi32(c1, 2)), y1));
  const __m256 d2 = _mm256_add_ps(_mm256_mul_ps(grad_avx2(c2), x2), _mm256_mul_ps(grad_avx2(_mm256_srli_epi32(cell, 14)), y2));
  const __m256 e0 = positive_part_avx2(f0), e1 = positive_part_avx2(f1), e2 = positive_part_avx2(f2);
  const __m256 sum = _mm256_add_ps(_mm256_add_ps(kernel_avx2(e0, d0), kernel_avx2(e1, d1)), kernel_avx2(e2, d2));
  return _mm256_mul_ps(sum, _mm256_set1_ps(70.0f));
}

// One octave over a block (n a multiple of 8, at most kBlock): acc = n(x·freq + base, y·freq + base)
// for the first octave (freq = 1: x·1 is x), acc += n(…)·amp for the others, as snoise2_flat_block.
__attribute__((target("avx2"))) void snoise2_octave_avx2(const std::int32_t* g4, const float* __restrict x, const float* __restrict y,
                                                         std::size_t n, float freq, float base, float amp, bool first,
                                                         float* __restrict acc) {
  alignas(32) float X0[kBlock], Y0[kBlock];
  alignas(32) std::int32_t C[kBlock];
  const __m256 fr = _mm256_set1_ps(freq), b = _mm256_set1_ps(base), am = _mm256_set1_ps(amp);
  for (std::size_t k = 0; k < n; k += 8) {
    __m256 x0, y0;
    const __m256i c = simplex2_cell_avx2(g4, _mm256_add_ps(_mm256_mul_ps(_mm256_loadu_ps(x + k), fr), b),
                                         _mm256_add_ps(_mm256_mul_ps(_mm256_loadu_ps(y + k), fr), b), x0, y0);
    _mm256_store_ps(X0 + k, x0);
    _mm256_store_ps(Y0 + k, y0);
    _mm256_store_si256(reinterpret_cast<__m256i*>(C + k), c);
  }
  for (std::size_t k = 0; k < n; k += 8) {
    const __m256 v =
        simplex2_corners_avx2(_mm256_load_ps(X0 + k), _mm256_load_ps(Y0 + k), _mm256_load_si256(reinterpret_cast<const __m256i*>(C + k)));
    _mm256_store_ps(acc + k, first ? v : _mm256_add_ps(_mm256_load_ps(acc + k), _mm256_mul_ps(v, am)));
  }
}

// The same sums as snoise2_flat_block; n is a multiple of 8.
__attribute__((target("avx2"))) void snoise2_flat_block_avx2(const Tables& T, const float* __restrict x, const float* __restrict y,
                                                             std::size_t n, int octaves, float persistence, float lacunarity,
                                                             float base, float* __restrict out) {
  alignas(32) float acc[kBlock];
  const std::int32_t* g4 = T.g4.data();
  snoise2_octave_avx2(g4, x, y, n, 1.0f, base, 1.0f, true, acc);
  float freq = 1.0f, amp = 1.0f, max = 1.0f;
  for (int o = 1; o < octaves; ++o) {
    freq *= lacunarity;
    amp *= persistence;
    max += amp;
    snoise2_octave_avx2(g4, x, y, n, freq, base, amp, false, acc);
  }
  const __m256 mx = _mm256_set1_ps(max);
  for (std::size_t k = 0; k < n; k += 8) _mm256_storeu_ps(out + k, _mm256_div_ps(_mm256_load_ps(acc + k), mx));
}

bool use_avx2_kernel() {
  // Not where target_clones picks the x86-64-v4 clone (AVX-512 F, BW, CD, DQ and VL).
  static const bool v4 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                         __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl");
  static const bool yes = __builtin_cpu_supports("avx2") && !v4;
  return yes;
}
#else
bool use_avx2_kernel() { return false; }
#endif

__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void snoise3_block(
    const Tables& T, const float* __restrict x, const float* __restrict y, const float* __restrict z, std::size_t n, int octaves,
    float persistence, float lacunarity, float* __restrict out) {
  float acc[kBlock];
  for (std::size_t k = 0; k < n; ++k) acc[k] = simplex3_t(T, x[k], y[k], z[k]);
  float freq = 1.0f, amp = 1.0f, max = 1.0f;
  for (int i = 1; i < octaves; ++i) {
    freq *= lacunarity;
    amp *= persistence;
    max += amp;
    for (std::size_t k = 0; k < n; ++k) acc[k] += simplex3_t(T, x[k] * freq, y[k] * freq, z[k] * freq) * amp;
  }
  if (octaves > 1)
    for (std::size_t k = 0; k < n; ++k) acc[k] = acc[k] / max;
  for (std::size_t k = 0; k < n; ++k) out[k] = acc[k];
}

// Tiled snoise2 (both repeats: 4D noise on the torus; one: 3D, see snoise2_tiled): the mapping onto
// circles per point, then the octave loop over the block.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void snoise2_torus_block(
    const Tables& T, const float* __restrict x, const float* __restrict y, std::size_t n, int octaves, float persistence,
    float lacunarity, float repeatx, float repeaty, float base, float* __restrict out) {
  float X[kBlock], Y[kBlock], Z[kBlock], W[kBlock], acc[kBlock];
  const float yr = float(double(repeaty) * 0.31830988618379067154 * 0.5);
  const float xr = float(double(repeatx) * 0.31830988618379067154 * 0.5);
  for (std::size_t k = 0; k < n; ++k) {
    const float yf = float(double(y[k]) * 2.0 / double(repeaty));
    const float xf = float(double(x[k]) * 2.0 / double(repeatx));
    Y[k] = fast_sin(yf) * yr;
    W[k] = base + fast_cos(yf) * yr;
    X[k] = fast_sin(xf) * xr;
    Z[k] = base + fast_cos(xf) * xr;
  }
  for (std::size_t k = 0; k < n; ++k) acc[k] = simplex4_t(T, X[k], Y[k], Z[k], W[k]);
  float freq = 1.0f, amp = 1.0f, max = 1.0f;
  for (int i = 1; i < octaves; ++i) {
    freq *= lacunarity;
    amp *= persistence;
    max += amp;
    for (std::size_t k = 0; k < n; ++k) acc[k] += simplex4_t(T, X[k] * freq, Y[k] * freq, Z[k] * freq, W[k] * freq) * amp;
  }
  for (std::size_t k = 0; k < n; ++k) out[k] = acc[k] / max;
}

}  // namespace

void snoise2(const float* x, const float* y, std::size_t n, const ClassicFractal& f, float repeatx, float repeaty, float base, float* out) {
  const Tables& T = tables();
  if (repeatx != kNoRepeat && repeaty != kNoRepeat) {
    for (std::size_t k0 = 0; k0 < n; k0 += kBlock) {
      const std::size_t m = n - k0 < kBlock ? n - k0 : kBlock;
      snoise2_torus_block(T, x + k0, y + k0, m, f.octaves, f.persistence, f.lacunarity, repeatx, repeaty, base, out + k0);
    }
    return;
  }
  if (repeatx != kNoRepeat || repeaty != kNoRepeat) {
    // One axis tiled: that axis onto a circle, then 3D simplex (snoise2_tiled), in blocks.
    float X[kBlock], Y[kBlock], Z[kBlock];
    const bool tile_y = repeaty != kNoRepeat;
    const double rep = tile_y ? repeaty : repeatx;
    const float r = float(rep * 0.31830988618379067154 * 0.5);
    for (std::size_t k0 = 0; k0 < n; k0 += kBlock) {
      const std::size_t m = n - k0 < kBlock ? n - k0 : kBlock;
      for (std::size_t k = 0; k < m; ++k) {
        const float a = tile_y ? y[k0 + k] : x[k0 + k];
        const float af = float(double(a) * 2.0 / rep);
        const float v = fast_sin(af) * r, c = base + fast_cos(af) * r;
        X[k] = tile_y ? x[k0 + k] : v;
        Y[k] = tile_y ? v : y[k0 + k];
        Z[k] = c;
      }
      snoise3_block(T, X, Y, Z, m, f.octaves, f.persistence, f.lacunarity, out + k0);
    }
    return;
  }
  const bool avx2 = use_avx2_kernel();
  for (std::size_t k0 = 0; k0 < n; k0 += kBlock) {
    const std::size_t m = n - k0 < kBlock ? n - k0 : kBlock;
#if defined(__x86_64__) && defined(__GNUC__)
    if (avx2) {
      const std::size_t m8 = m & ~std::size_t(7);
      if (m8) snoise2_flat_block_avx2(T, x + k0, y + k0, m8, f.octaves, f.persistence, f.lacunarity, base, out + k0);
      if (m8 < m) snoise2_flat_block(T, x + k0 + m8, y + k0 + m8, m - m8, f.octaves, f.persistence, f.lacunarity, base, out + k0 + m8);
      continue;
    }
#endif
    snoise2_flat_block(T, x + k0, y + k0, m, f.octaves, f.persistence, f.lacunarity, base, out + k0);
  }
}

void snoise3(const float* x, const float* y, const float* z, std::size_t n, const ClassicFractal& f, float* out) {
  const Tables& T = tables();
  for (std::size_t k0 = 0; k0 < n; k0 += kBlock) {
    const std::size_t m = n - k0 < kBlock ? n - k0 : kBlock;
    snoise3_block(T, x + k0, y + k0, z + k0, m, f.octaves, f.persistence, f.lacunarity, out + k0);
  }
}

void pnoise2(const float* x, const float* y, std::size_t n, const ClassicFractal& f, float repeatx, float repeaty, int base, float* out) {
  for (std::size_t k = 0; k < n; ++k) out[k] = pnoise2(x[k], y[k], f.octaves, f.persistence, f.lacunarity, repeatx, repeaty, base);
}

void pnoise3(const float* x, const float* y, const float* z, std::size_t n, const ClassicFractal& f, int repeatx, int repeaty, int repeatz,
             int base, float* out) {
  for (std::size_t k = 0; k < n; ++k)
    out[k] = pnoise3(x[k], y[k], z[k], f.octaves, f.persistence, f.lacunarity, repeatx, repeaty, repeatz, base);
}

}  // namespace relief::classic
