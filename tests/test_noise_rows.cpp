// Tests for the block API of Noise (Noise::columns, Noise::row(z, columns), Noise::rows): the x-only
// terms computed once per window of columns and reused for every row must give exactly the values
// of the per-row path, bit for bit, on every forced Highway target; settings without x-only terms
// (other bases, domain warp) fall back to the per-row kernel. Gradient, Value and Simplex have such
// terms.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "noise_simd.hpp"
#include "relief/noise.hpp"

namespace relief {
namespace {

struct ForceTarget {
  explicit ForceTarget(std::int64_t bits) { detail::noise_simd_force_target(bits); }
  ~ForceTarget() { detail::noise_simd_force_target(0); }
};

bool same_bits(const float* a, const float* b, std::size_t n) { return std::memcmp(a, b, n * sizeof(float)) == 0; }

struct Window {
  std::int64_t i0;
  double dx;
  int n;
  double z0, dz;  // rows at z0 + r·dz
};
// Shorter than one vector, odd tails, several L1 strips (1700 columns), negative and huge offsets,
// a non-dyadic spacing, a billion metres out.
const Window kWindows[] = {{0, 1.0, 1, 0.0, 1.0},           {-7, 0.731, 3, 3.25, 0.731},
                           {12, 2.5, 17, -41.5, 2.5},        {-37, 9.775, 301, 777.7, 9.775},
                           {0, 1.0, 1700, 0.0, 1.0},         {1000000000, 1.0, 67, 1e6 + 0.3, 1.0},
                           {-123456789, 3.3, 333, -2.5e7, 3.3}};

// rows() and row(z, columns()) against row() for every window, rows at varied z. Returns the number
// of differing rows and reports the first.
int mismatches(const NoiseSettings& s, const std::string& what) {
  const Noise noise(s);
  int bad = 0;
  for (const Window& w : kWindows) {
    const int nrows = 5;
    const std::ptrdiff_t stride = w.n + 3;  // gaps between rows must stay untouched
    std::vector<double> z(nrows);
    for (int r = 0; r < nrows; ++r) z[std::size_t(r)] = w.z0 + double(r * r) * w.dz;
    std::vector<float> block(std::size_t(stride) * nrows, -5.0f), cols(std::size_t(w.n), -6.0f),
        ref(std::size_t(w.n), -7.0f);
    noise.rows(z.data(), nrows, w.i0, w.dx, w.n, block.data(), stride);
    const NoiseColumns c = noise.columns(w.i0, w.dx, w.n);
    for (int r = 0; r < nrows; ++r) {
      noise.row(z[std::size_t(r)], w.i0, w.dx, w.n, ref.data());
      noise.row(z[std::size_t(r)], c, cols.data());
      const float* b = block.data() + r * stride;
      const bool ok = same_bits(b, ref.data(), ref.size()) && same_bits(cols.data(), ref.data(), ref.size()) &&
                      b[w.n] == -5.0f && b[w.n + 1] == -5.0f && b[w.n + 2] == -5.0f;
      if (!ok && bad++ == 0) {
        for (int i = 0; i < w.n; ++i)
          if (b[i] != ref[std::size_t(i)] || cols[std::size_t(i)] != ref[std::size_t(i)]) {
            ADD_FAILURE() << what << ": n " << w.n << " row " << r << " i " << i << ": rows " << b[i] << " columns "
                          << cols[std::size_t(i)] << " row() " << ref[std::size_t(i)];
            break;
          }
      }
    }
  }
  return bad;
}

NoiseSettings gradient(Fractal fr, int octaves, double lacunarity) {
  NoiseSettings s;
  s.basis = NoiseBasis::Gradient;
  s.fractal = fr;
  s.octaves = octaves;
  s.lacunarity = lacunarity;
  s.persistence = 0.55;
  s.frequency = 1.0 / 57.0;
  s.scale_x = 1.3;
  s.seed = 0xB10Cull + std::uint64_t(octaves);
  return s;
}

// The core property: every fractal, dyadic (lacunarity 2) and not, 1 to 16 octaves, periodic in x
// and z, z only or x only, on every compiled target. Value shares Gradient's lattice and column
// terms: both bases.
TEST(NoiseRows, GradientAndValueBlockBitIdenticalToRowOnEveryTarget) {
  const Fractal fractals[] = {Fractal::None, Fractal::Fbm, Fractal::Ridged, Fractal::Billow};
  for (const auto& t : detail::noise_simd_targets()) {
    ForceTarget f(t.bits);
    for (NoiseBasis b : {NoiseBasis::Gradient, NoiseBasis::Value}) {
      int configs = 0;
      for (Fractal fr : fractals)
        for (double lac : {2.0, 2.1})
          for (int octaves : {1, 6, 16})
            for (int period = 0; period < 4; ++period) {  // none, x and z, z only, x only
              NoiseSettings s = gradient(fr, octaves, lac);
              s.basis = b;
              if (period == 1 || period == 3) s.period_x_m = 700.0;
              if (period == 1 || period == 2) s.period_z_m = 450.0;
              const std::string what = t.name + " basis " + std::to_string(int(b)) + " fractal " +
                                       std::to_string(int(fr)) + " lacunarity " + std::to_string(lac) + " octaves " +
                                       std::to_string(octaves) + " period " + std::to_string(period);
              EXPECT_TRUE(Noise(s).columns(0, 1.0, 10).precomputed()) << what;
              EXPECT_EQ(mismatches(s, what), 0) << what;
              ++configs;
            }
      EXPECT_EQ(configs, 4 * 2 * 3 * 4);
    }
  }
}

// Settings without x-only terms fall back to the per-row kernel, with the same values.
TEST(NoiseRows, WarpAndOtherBasesFallBackToRows) {
  for (const auto& t : detail::noise_simd_targets()) {
    ForceTarget f(t.bits);
    for (NoiseBasis b : {NoiseBasis::Perlin, NoiseBasis::Simplex, NoiseBasis::Value, NoiseBasis::Cellular,
                         NoiseBasis::Gradient})
      for (bool periodic : {false, true}) {
        if (periodic && b == NoiseBasis::Simplex) continue;
        NoiseSettings s = gradient(Fractal::Fbm, 4, 2.0);
        s.basis = b;
        if (periodic) s.period_x_m = s.period_z_m = 640.0;
        s.warp_m = 23.0;
        s.warp_frequency = 1.0 / 90.0;
        const std::string what = t.name + " basis " + std::to_string(int(b)) + (periodic ? " periodic" : "");
        EXPECT_FALSE(Noise(s).columns(0, 1.0, 10).precomputed()) << what;
        EXPECT_EQ(mismatches(s, what + " warp"), 0) << what;
        s.warp_m = 0.0;
        EXPECT_EQ(Noise(s).columns(0, 1.0, 10).precomputed(),
                  b == NoiseBasis::Gradient || b == NoiseBasis::Value || b == NoiseBasis::Simplex)
            << what;
        EXPECT_EQ(mismatches(s, what), 0) << what;
      }
  }
}

// Columns remember their window; used with another Noise they give that Noise's values (it falls
// back to its own per-row path) rather than the builder's terms.
TEST(NoiseRows, ColumnsKeepTheirWindowAndBelongToTheirNoise) {
  const Noise a(gradient(Fractal::Fbm, 6, 2.0));
  NoiseSettings sb = gradient(Fractal::Fbm, 6, 2.0);
  sb.seed = 99;
  const Noise b(sb);
  const NoiseColumns c = a.columns(-40, 0.5, 123);
  EXPECT_EQ(c.i0(), -40);
  EXPECT_EQ(c.dx_m(), 0.5);
  EXPECT_EQ(c.size(), 123);
  std::vector<float> got(123), want(123), own(123);
  b.row(17.0, c, got.data());
  b.row(17.0, -40, 0.5, 123, want.data());
  a.row(17.0, -40, 0.5, 123, own.data());
  EXPECT_TRUE(same_bits(got.data(), want.data(), want.size()));
  EXPECT_FALSE(same_bits(got.data(), own.data(), own.size()));
}

TEST(NoiseRows, EmptyBlocksWriteNothing) {
  const Noise noise(gradient(Fractal::Ridged, 3, 2.0));
  std::vector<float> out(8, -3.0f);
  const double z[2] = {1.0, 2.0};
  noise.rows(z, 2, 0, 1.0, 0, out.data(), 4);
  noise.rows(z, 0, 0, 1.0, 4, out.data(), 4);
  noise.row(1.0, noise.columns(0, 1.0, 0), out.data());
  noise.row(1.0, noise.columns(0, 1.0, -5), out.data());
  for (float v : out) EXPECT_EQ(v, -3.0f);
  EXPECT_FALSE(noise.columns(0, 1.0, 0).precomputed());
}

// Perlin, Cellular and Simplex rows and blocks (the kernels of noise_rows_simd.cpp where the target
// has them; Simplex's blocks take the column terms of noise_simd.cpp) against the scalar reference, bit for bit, on every forced target: every fractal,
// periodic along x, z, both or neither, every cellular return at jitters 1, 0.6 and 0, in the windows
// above and in windows of 2048 columns at 1 and 2.7 samples per cell (every table entry, cells
// straddled by most vectors), rows far apart and rows sharing their lattice row.
int reference_mismatches(const NoiseSettings& s, const std::string& what) {
  const Noise noise(s);
  struct W {
    std::int64_t i0;
    double dx;
    int n;
    double z0, dz;
    int nrows;
  };
  std::vector<W> windows;
#if defined(__SANITIZE_ADDRESS__)
  // The sanitizer build (unoptimised, 45x slower here) checks the kernels' memory accesses: every
  // window shape of kWindows (tails, strips, offsets) on 3 rows; the long windows below add only
  // more of the same accesses (this test took 8 of the sanitizer pass's 33 minutes with them).
  for (const Window& w : kWindows) windows.push_back({w.i0, w.dx, w.n, w.z0, w.dz, 3});
#else
  for (const Window& w : kWindows) windows.push_back({w.i0, w.dx, w.n, w.z0, w.dz, 5});
  windows.push_back({-1000, 0.37, 2048, -3.0, 0.11, 9});
  windows.push_back({77, 1.0 / 2.7, 2048, 12.0, 0.5, 4});
#endif
  int bad = 0;
  for (const W& w : windows) {
    const std::ptrdiff_t stride = w.n + 3;
    std::vector<double> z(std::size_t(w.nrows));
    for (int r = 0; r < w.nrows; ++r) z[std::size_t(r)] = w.z0 + double(r * r) * w.dz;
    std::vector<float> block(std::size_t(stride) * std::size_t(w.nrows), -5.0f), one(std::size_t(w.n), -6.0f),
        ref(std::size_t(w.n), -7.0f);
    noise.rows(z.data(), w.nrows, w.i0, w.dx, w.n, block.data(), stride);
    for (int r = 0; r < w.nrows; ++r) {
      noise.row_reference(z[std::size_t(r)], w.i0, w.dx, w.n, ref.data());
      noise.row(z[std::size_t(r)], w.i0, w.dx, w.n, one.data());
      const float* b = block.data() + r * stride;
      const bool ok = same_bits(b, ref.data(), ref.size()) && same_bits(one.data(), ref.data(), ref.size()) &&
                      b[w.n] == -5.0f && b[w.n + 1] == -5.0f && b[w.n + 2] == -5.0f;
      if (!ok && bad++ == 0) {
        for (int i = 0; i < w.n; ++i)
          if (!same_bits(b + i, &ref[std::size_t(i)], 1) || !same_bits(&one[std::size_t(i)], &ref[std::size_t(i)], 1)) {
            ADD_FAILURE() << what << ": n " << w.n << " dx " << w.dx << " row " << r << " i " << i << ": rows " << b[i]
                          << " row() " << one[std::size_t(i)] << " reference " << ref[std::size_t(i)];
            break;
          }
      }
    }
  }
  return bad;
}

TEST(NoiseRows, PerlinCellularAndSimplexBitIdenticalToReferenceOnEveryTarget) {
  const Fractal fractals[] = {Fractal::None, Fractal::Fbm, Fractal::Ridged, Fractal::Billow};
  const CellularReturn returns[] = {CellularReturn::F1, CellularReturn::F2, CellularReturn::F2MinusF1,
                                    CellularReturn::CellValue};
  for (const auto& t : detail::noise_simd_targets()) {
    ForceTarget f(t.bits);
    int configs = 0;
    for (NoiseBasis b : {NoiseBasis::Perlin, NoiseBasis::Cellular, NoiseBasis::Simplex})
      for (Fractal fr : fractals)
        for (int period = 0; period < 4; ++period)
          for (CellularReturn ret : returns)
            for (double jitter : {1.0, 0.6, 0.0}) {
              if (b != NoiseBasis::Cellular && (ret != CellularReturn::F1 || jitter != 1.0)) continue;
              if (b == NoiseBasis::Simplex && period != 0) continue;  // simplex has no period
              if (b == NoiseBasis::Cellular && jitter != 1.0 && (fr != Fractal::None || period != 1)) continue;
              NoiseSettings s = gradient(fr, 4, 2.1);
              s.basis = b;
              s.cellular = ret;
              s.jitter = jitter;
              s.frequency = 1.0 / 13.0;
              if (period == 1 || period == 3) s.period_x_m = 700.0;
              if (period == 1 || period == 2) s.period_z_m = 450.0;
              const std::string what = t.name + " basis " + std::to_string(int(b)) + " fractal " +
                                       std::to_string(int(fr)) + " period " + std::to_string(period) + " return " +
                                       std::to_string(int(ret)) + " jitter " + std::to_string(jitter);
              EXPECT_EQ(reference_mismatches(s, what), 0) << what;
              ++configs;
            }
    EXPECT_EQ(configs, 4 * 4 + 4 * 4 * 4 + 4 * 2 + 4);
  }
}

// A period of one lattice cell along x at the Perlin table's last entry: every sample's right
// neighbour wraps to cell 0 (the table's entry 256).
TEST(NoiseRows, PerlinPeriodsOfFewCells) {
  for (double period : {13.0, 3.0 * 13.0, 257.0 * 13.0}) {
    NoiseSettings s = gradient(Fractal::Fbm, 3, 2.0);
    s.basis = NoiseBasis::Perlin;
    s.frequency = 1.0 / 13.0;
    s.period_x_m = period;
    s.period_z_m = period;
    EXPECT_EQ(reference_mismatches(s, "period " + std::to_string(period)), 0) << period;
  }
}

// Non-finite and huge coordinates through the block kernels: no crash, no write outside the rows, and
// the scalar reference's values (NaN for NaN: the payload and sign of a NaN are unspecified; cellular
// beyond 2⁵⁰ cells and non-finite spacings take the per-sample kernels). The HWY_SCALAR target's
// per-sample kernels differ from the reference for Perlin at coordinates beyond 2⁵¹ cells (1e300 m,
// a spacing of 3e15 m): not compared there.
bool same_or_both_nan(const float* a, const float* b, int n) {
  for (int i = 0; i < n; ++i)
    if (!(std::isnan(a[i]) && std::isnan(b[i])) && !same_bits(a + i, b + i, 1)) return false;
  return true;
}
TEST(NoiseRows, NonFiniteAndHugeCoordinatesMatchTheReference) {
  const double bad[] = {std::nan(""), HUGE_VAL, -HUGE_VAL, 1e300, -3e15};
  for (const auto& t : detail::noise_simd_targets()) {
    ForceTarget f(t.bits);
    for (NoiseBasis b : {NoiseBasis::Perlin, NoiseBasis::Cellular, NoiseBasis::Simplex})
      for (double v : bad) {
        NoiseSettings s = gradient(Fractal::Fbm, 3, 2.0);
        s.basis = b;
        const Noise noise(s);
        const int n = 200;
        const bool compare = t.name != "SCALAR" || std::fabs(v) < 1e15 || std::isnan(v) || b != NoiseBasis::Perlin;
        std::vector<float> got(n + 4, -5.0f), ref(n, 0.0f);
        const double z[2] = {v, 3.5};
        for (int r = 0; r < 2; ++r) {
          noise.rows(z + r, 1, -3, 1.0, n, got.data(), n + 4);
          noise.row_reference(z[r], -3, 1.0, n, ref.data());
          if (compare) {
            EXPECT_TRUE(same_or_both_nan(got.data(), ref.data(), n)) << t.name << " basis " << int(b) << " z " << z[r];
          }
          EXPECT_EQ(got[n], -5.0f);
          noise.row(1.0, -3, v, n, got.data());
          noise.row_reference(1.0, -3, v, n, ref.data());
          if (compare) {
            EXPECT_TRUE(same_or_both_nan(got.data(), ref.data(), n)) << t.name << " basis " << int(b) << " dx " << v;
          }
          EXPECT_EQ(got[n], -5.0f);
        }
      }
  }
}

}  // namespace
}  // namespace relief
