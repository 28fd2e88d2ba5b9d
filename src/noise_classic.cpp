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
#include <cmath>
#include <cstdint>

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
  // Improved noise: grad2/grad3 of hash h use kGrad3[h & 15].
  // 4D simplex: for each of the 64 orderings, the rank (0..3) of each coordinate.
  std::array<std::array<std::int32_t, 4>, 64> rank{};
  // 4D gradients (Gustavson): all (0, ±1, ±1, ±1) permutations, 32 of them.
  std::array<std::array<float, 4>, 32> grad4{};
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
  }
  // Rank of each coordinate for the ordering code c = (x>y)·32 + (x>z)·16 + (y>z)·8 + (x>w)·4 +
  // (y>w)·2 + (z>w): the number of other coordinates it exceeds. Codes that no ordering produces
  // (contradictory comparisons) get all zeros, as in Gustavson's table.
  for (int c = 0; c < 64; ++c) {
    const bool xy = c & 32, xz = c & 16, yz = c & 8, xw = c & 4, yw = c & 2, zw = c & 1;
    const int rx = xy + xz + xw, ry = !xy + yz + yw, rz = !xz + !yz + zw, rw = !xw + !yw + !zw;
    // A consistent ordering has ranks that are a permutation of 0..3.
    const int seen = (1 << rx) | (1 << ry) | (1 << rz) | (1 << rw);
    if (seen == 15) t.rank[c] = {rx, ry, rz, rw};
    else t.rank[c] = {0, 0, 0, 0};
  }
  int k = 0;
  for (int zero = 0; zero < 4; ++zero)
    for (int s = 0; s < 8; ++s) {
      std::array<float, 4> g{};
      int bit = 2;
      for (int a = 0; a < 4; ++a) {
        if (a == zero) continue;
        g[a] = (s >> bit) & 1 ? -1.0f : 1.0f;
        --bit;
      }
      t.grad4[k++] = g;
    }
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
  const float t = float(int(v));
  return t > v ? t - 1.0f : t;
}

constexpr float F2 = 0.3660254037844386f;   // (√3 − 1) / 2
constexpr float G2 = 0.21132486540518713f;  // (3 − √3) / 6

inline float simplex2_t(const Tables& T, float x, float y) {
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
  const int h0 = I + T.p[J];
  const int h1 = I + i1 + T.p[(J + j1) & 255];
  const int h2 = I + 1 + T.p[(J + 1) & 255];
  const float f0 = 0.5f - x0 * x0 - y0 * y0;
  const float f1 = 0.5f - x1 * x1 - y1 * y1;
  const float f2 = 0.5f - x2 * x2 - y2 * y2;
  // Loads and products unconditionally, then a select: branch-free, so it vectorises.
  const float d0 = T.sg0[h0] * x0 + T.sg1[h0] * y0;
  const float d1 = T.sg0[h1] * x1 + T.sg1[h1] * y1;
  const float d2 = T.sg0[h2] * x2 + T.sg1[h2] * y2;
  const float n0 = f0 > 0 ? f0 * f0 * f0 * f0 * d0 : 0.0f;
  const float n1 = f1 > 0 ? f1 * f1 * f1 * f1 * d1 : 0.0f;
  const float n2 = f2 > 0 ? f2 * f2 * f2 * f2 * d2 : 0.0f;
  return (n0 + n1 + n2) * 70.0f;
}

constexpr float F3 = 1.0f / 3.0f;
constexpr float G3 = 1.0f / 6.0f;

inline float simplex3_t(const Tables& T, float x, float y, float z) {
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
  const float n0 = f0 > 0 ? f0 * f0 * f0 * f0 * d0 : 0.0f;
  const float n1 = f1 > 0 ? f1 * f1 * f1 * f1 * d1 : 0.0f;
  const float n2 = f2 > 0 ? f2 * f2 * f2 * f2 * d2 : 0.0f;
  const float n3 = f3 > 0 ? f3 * f3 * f3 * f3 * d3 : 0.0f;
  return (n0 + n1 + n2 + n3) * 32.0f;
}

constexpr float F4 = 0.30901699437494745f;  // (√5 − 1) / 4
constexpr float G4 = 0.1381966011250105f;   // (5 − √5) / 20

inline float simplex4_t(const Tables& T, float x, float y, float z, float w) {
  const float s = (x + y + z + w) * F4;
  const float i = lattice_floor(x + s), j = lattice_floor(y + s), k = lattice_floor(z + s), l = lattice_floor(w + s);
  const float t = (i + j + k + l) * G4;
  const float x0 = x - (i - t), y0 = y - (j - t), z0 = z - (k - t), w0 = w - (l - t);
  const int c = (x0 > y0) * 32 + (x0 > z0) * 16 + (y0 > z0) * 8 + (x0 > w0) * 4 + (y0 > w0) * 2 + (z0 > w0);
  const auto& r = T.rank[c];
  const int i1 = r[0] >= 3, j1 = r[1] >= 3, k1 = r[2] >= 3, l1 = r[3] >= 3;
  const int i2 = r[0] >= 2, j2 = r[1] >= 2, k2 = r[2] >= 2, l2 = r[3] >= 2;
  const int i3 = r[0] >= 1, j3 = r[1] >= 1, k3 = r[2] >= 1, l3 = r[3] >= 1;
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
  auto term = [&](float tt, int g, float a, float b, float cc, float d) {
    if (tt >= 0.0f) {
      tt *= tt;
      const auto& G = T.grad4[g];
      return tt * tt * (G[0] * a + G[1] * b + G[2] * cc + G[3] * d);
    }
    return 0.0f;
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

}  // namespace

void snoise2(const float* x, const float* y, std::size_t n, const ClassicFractal& f, float repeatx, float repeaty, float base, float* out) {
  const Tables& T = tables();
  if (repeatx != kNoRepeat || repeaty != kNoRepeat) {
    for (std::size_t k = 0; k < n; ++k)
      out[k] = snoise2_tiled(T, x[k], y[k], f.octaves, f.persistence, f.lacunarity, repeatx, repeaty, base);
    return;
  }
  for (std::size_t k0 = 0; k0 < n; k0 += kBlock) {
    const std::size_t m = n - k0 < kBlock ? n - k0 : kBlock;
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
