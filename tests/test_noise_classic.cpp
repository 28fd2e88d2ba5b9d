// Tests for include/relief/noise_classic.hpp (the `noise` package's functions, relief.compat):
// reference properties of simplex and improved noise, tiling, fractal sums, and the array paths
// against the scalar ones. The package's own values are compared in python/tests/test_compat.py.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include "relief/noise_classic.hpp"
#include "relief/random.hpp"

namespace relief::classic {
namespace {

float pt(std::uint64_t stream, std::uint64_t i, float lo, float hi) {
  return float(lo + (hi - lo) * unit_double(hash64(0xc1a55ull, stream, i)));
}

// Simplex noise is zero at every lattice vertex: the vertex's own term has d = 0 and every other
// vertex is farther than the kernel radius (2D: |d|² = 2/3 > 0.5; 3D: ≥ 0.75 > 0.6).
TEST(NoiseClassic, SimplexIsZeroAtLatticeVertices) {
  const float G2 = 0.21132486540518713f;
  for (int i = -5; i <= 5; ++i)
    for (int j = -5; j <= 5; ++j) {
      const float x = float(i) - float(i + j) * G2, y = float(j) - float(i + j) * G2;
      EXPECT_NEAR(simplex2(x, y), 0.0f, 1e-5f) << i << "," << j;
    }
  for (int i = -3; i <= 3; ++i)
    for (int k = -3; k <= 3; ++k) {
      const float t = float(i + 2 + k) / 6.0f;
      EXPECT_NEAR(simplex3(float(i) - t, 2.0f - t, float(k) - t), 0.0f, 1e-5f);
    }
  EXPECT_EQ(simplex4(0, 0, 0, 0), 0.0f);
}

TEST(NoiseClassic, RangeMeanAndSpreadOfEveryBasis) {
  struct Stat {
    double sum = 0, sum2 = 0, max = 0;
    void add(float v) {
      sum += v;
      sum2 += double(v) * v;
      max = std::max(max, std::fabs(double(v)));
    }
  } s2, s3, s4, p2, p3;
  const int n = 200000;
  for (int k = 0; k < n; ++k) {
    const float x = pt(0, k, -500, 500), y = pt(1, k, -500, 500), z = pt(2, k, -500, 500), w = pt(3, k, -500, 500);
    s2.add(simplex2(x, y));
    s3.add(simplex3(x, y, z));
    s4.add(simplex4(x, y, z, w));
    p2.add(improved2(x, y, 1024, 1024, 0));
    p3.add(improved3(x, y, z, 1024, 1024, 1024, 0));
  }
  for (const Stat* s : {&s2, &s3, &s4, &p2, &p3}) {
    EXPECT_LT(std::fabs(s->sum / n), 0.01);
    const double sd = std::sqrt(s->sum2 / n);
    EXPECT_GT(sd, 0.1);
    EXPECT_LT(sd, 0.5);
    EXPECT_LE(s->max, 1.0);
    EXPECT_GT(s->max, 0.6);  // the scale factors bring the extremes near ±1
  }
}

// Noise is continuous: no jumps between neighbouring simplices or cells.
TEST(NoiseClassic, Continuous) {
  const float e = 1e-3f;
  for (int k = 0; k < 20000; ++k) {
    const float x = pt(4, k, -50, 50), y = pt(5, k, -50, 50), z = pt(6, k, -50, 50);
    EXPECT_LT(std::fabs(simplex2(x + e, y) - simplex2(x, y)), 0.02f);
    EXPECT_LT(std::fabs(simplex3(x, y + e, z) - simplex3(x, y, z)), 0.02f);
    EXPECT_LT(std::fabs(simplex4(x, y, z + e, 0.5f) - simplex4(x, y, z, 0.5f)), 0.02f);
    EXPECT_LT(std::fabs(improved3(x, y, z + e, 1024, 1024, 1024, 0) - improved3(x, y, z, 1024, 1024, 1024, 0)), 0.02f);
  }
}

// Improved noise is zero at integer points (every gradient term vanishes there).
TEST(NoiseClassic, ImprovedIsZeroAtIntegers) {
  for (int i = -4; i <= 4; ++i)
    for (int j = -4; j <= 4; ++j) {
      EXPECT_EQ(improved2(float(i), float(j), 1024, 1024, 0), 0.0f);
      EXPECT_EQ(improved3(float(i), float(j), 3.0f, 1024, 1024, 1024, 0), 0.0f);
    }
}

TEST(NoiseClassic, ImprovedTilesWithItsRepeat) {
  for (int k = 0; k < 2000; ++k) {
    // Coordinates with few mantissa bits, so that x + R is exact.
    const float x = std::round(pt(7, k, 0, 64) * 64) / 64, y = std::round(pt(8, k, 0, 64) * 64) / 64;
    EXPECT_EQ(pnoise2(x, y, 3, 0.5f, 2.0f, 16, 8, 0), pnoise2(x + 16, y + 8, 3, 0.5f, 2.0f, 16, 8, 0));
    EXPECT_EQ(pnoise3(x, y, 1.25f, 1, 0.5f, 2.0f, 4, 4, 4, 0), pnoise3(x + 4, y + 8, 5.25f, 1, 0.5f, 2.0f, 4, 4, 4, 0));
  }
}

TEST(NoiseClassic, TiledSimplexTilesWithItsRepeat) {
  for (int k = 0; k < 2000; ++k) {
    const float x = pt(9, k, 0, 40), y = pt(10, k, 0, 40);
    EXPECT_NEAR(snoise2(x, y, 4, 0.5f, 2.0f, 40, 40, 0), snoise2(x + 40, y + 40, 4, 0.5f, 2.0f, 40, 40, 0), 1e-4f);
    EXPECT_NEAR(snoise2(x, y, 1, 0.5f, 2.0f, 40, kNoRepeat, 0), snoise2(x + 40, y, 1, 0.5f, 2.0f, 40, kNoRepeat, 0), 1e-4f);
  }
}

// A fractal sum of one octave is the basis; more octaves are the normalised sum of scaled copies.
TEST(NoiseClassic, FractalSums) {
  for (int k = 0; k < 1000; ++k) {
    const float x = pt(11, k, -20, 20), y = pt(12, k, -20, 20), z = pt(13, k, -20, 20);
    EXPECT_EQ(snoise2(x, y, 1, 0.5f, 2.0f, kNoRepeat, kNoRepeat, 0), simplex2(x, y));
    EXPECT_EQ(snoise3(x, y, z, 1, 0.5f, 2.0f), simplex3(x, y, z));
    const float two = (simplex2(x, y) + simplex2(x * 2, y * 2) * 0.5f) / 1.5f;
    EXPECT_EQ(snoise2(x, y, 2, 0.5f, 2.0f, kNoRepeat, kNoRepeat, 0), two);
  }
}

// The array paths (vectorised on this CPU) give the scalar values bit for bit, across block edges.
TEST(NoiseClassic, ArraysEqualScalars) {
  const std::size_t n = 1000;
  std::vector<float> x(n), y(n), z(n), a(n), b(n), c(n), d(n);
  for (std::size_t k = 0; k < n; ++k) {
    x[k] = pt(14, k, -300, 300);
    y[k] = pt(15, k, -300, 300);
    z[k] = pt(16, k, -300, 300);
  }
  const ClassicFractal f{6, 0.5f, 2.0f};
  snoise2(x.data(), y.data(), n, f, kNoRepeat, kNoRepeat, 3.5f, a.data());
  snoise3(x.data(), y.data(), z.data(), n, f, b.data());
  pnoise2(x.data(), y.data(), n, f, 1024, 1024, 1, c.data());
  pnoise3(x.data(), y.data(), z.data(), n, f, 1024, 1024, 1024, 0, d.data());
  for (std::size_t k = 0; k < n; ++k) {
    ASSERT_EQ(a[k], snoise2(x[k], y[k], 6, 0.5f, 2.0f, kNoRepeat, kNoRepeat, 3.5f)) << k;
    ASSERT_EQ(b[k], snoise3(x[k], y[k], z[k], 6, 0.5f, 2.0f)) << k;
    ASSERT_EQ(c[k], pnoise2(x[k], y[k], 6, 0.5f, 2.0f, 1024, 1024, 1)) << k;
    ASSERT_EQ(d[k], pnoise3(x[k], y[k], z[k], 6, 0.5f, 2.0f, 1024, 1024, 1024, 0)) << k;
  }
}

// snoise2 over arrays (the AVX2 kernel on CPUs without AVX-512, with the generic code for the tail
// of a length that is not a multiple of 8) gives the scalar function's bits, the sign of zeros
// included: lattice vertices (exact zeros), large (|x·frequency| < 2³¹: the lattice is an int) and tiny
// coordinates, odd lengths, many octaves.
TEST(NoiseClassic, Snoise2ArraysEqualScalarsBitForBit) {
  std::vector<float> x, y;
  for (int k = 0; k < 3000; ++k) {
    const float scale = k < 1000 ? 300.0f : k < 2000 ? 1e6f : 1e-3f;
    x.push_back(pt(17, k, -scale, scale));
    y.push_back(pt(18, k, -scale, scale));
  }
  const float G2 = 0.21132486540518713f;
  for (int i = -4; i <= 4; ++i)
    for (int j = -4; j <= 4; ++j) {  // lattice vertices, and the origin's signed zeros
      x.push_back(float(i) - float(i + j) * G2);
      y.push_back(float(j) - float(i + j) * G2);
    }
  x.insert(x.end(), {0.0f, -0.0f, 0.0f, -0.0f, 2e6f, -2e6f, 0.5f});
  y.insert(y.end(), {0.0f, 0.0f, -0.0f, -0.0f, -2e6f, 3.0f, 0.5f});
  for (const std::size_t n : {x.size(), std::size_t(7), std::size_t(9), std::size_t(263)})
    for (const ClassicFractal f : {ClassicFractal{1, 0.5f, 2.0f}, ClassicFractal{6, 0.5f, 2.0f}, ClassicFractal{9, 0.7f, 2.3f}})
      for (const float base : {0.0f, 3.5f, -17.0f}) {
        std::vector<float> a(n);
        snoise2(x.data(), y.data(), n, f, kNoRepeat, kNoRepeat, base, a.data());
        for (std::size_t k = 0; k < n; ++k) {
          const float s = snoise2(x[k], y[k], f.octaves, f.persistence, f.lacunarity, kNoRepeat, kNoRepeat, base);
          ASSERT_EQ(std::bit_cast<std::uint32_t>(a[k]), std::bit_cast<std::uint32_t>(s))
              << "k " << k << " of " << n << ", octaves " << f.octaves << ", base " << base << ": " << a[k] << " vs " << s;
        }
      }
}

}  // namespace
}  // namespace relief::classic
