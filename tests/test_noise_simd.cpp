// Tests for the Highway kernels behind Noise::row (src/noise_simd.cpp) and for the Gradient basis:
//   * every compiled Highway target this CPU runs (forced one at a time) gives bit-identical output
//     to the scalar reference Noise::row_reference, for every basis × fractal × cellular return,
//     periodic or not, warped or not, with odd row lengths, tails, offsets and large coordinates;
//   * the Gradient basis's golden hash (pinned on the scalar reference);
//   * the Gradient basis is statistically equivalent to the Perlin basis: range, mean, standard
//     deviation, isotropy of derivatives, radially averaged power spectrum.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "noise_simd.hpp"
#include "relief/noise.hpp"
#include "relief/noise_classic.hpp"
#include "relief/random.hpp"
#include "spectrum_support.hpp"
#include "support.hpp"

namespace relief {
namespace {

using test::fft;
using test::ks;
using test::radial_power;

using test::fnv1a;
using test::same_bits;
constexpr auto& kBases = test::kAllBases;
constexpr auto& kReturns = test::kAllReturns;
constexpr auto name = test::basis_name;
const Fractal kFractals[] = {Fractal::None, Fractal::Fbm, Fractal::Ridged, Fractal::Billow};


// Restores automatic dispatch even when an assertion returns early.
struct ForceTarget {
  explicit ForceTarget(std::int64_t bits) { detail::noise_simd_force_target(bits); }
  ~ForceTarget() { detail::noise_simd_force_target(0); }
};



struct RowCase {
  double z;
  std::int64_t i0;
  double dx;
  int n;
};
// Odd lengths (1, 3, 17: shorter than one vector; 301: tails), negative and huge offsets, a
// non-dyadic spacing, and coordinates a million and a billion metres out.
const RowCase kRows[] = {{0.0, 0, 1.0, 1},          {3.25, -7, 0.731, 3},       {-41.5, 12, 2.5, 17},
                         {777.7, -37, 9.775, 301},  {1e6 + 0.3, 1000000000, 1.0, 64},
                         {-2.5e7, -123456789, 3.3, 33}, {0.5, 0, 1e-3, 40}};

// One configuration: the SIMD path (current target) against the scalar reference, bit for bit.
// Returns the number of rows that differ; reports the first difference.
int mismatches(const NoiseSettings& s, const std::string& what) {
  const Noise n(s);
  int bad = 0;
  for (const RowCase& r : kRows) {
    std::vector<float> simd(std::size_t(r.n), -7.0f), ref(std::size_t(r.n), -9.0f);
    n.row(r.z, r.i0, r.dx, r.n, simd.data());
    n.row_reference(r.z, r.i0, r.dx, r.n, ref.data());
    if (!same_bits(simd, ref)) {
      if (bad++ == 0) {
        for (int i = 0; i < r.n; ++i)
          if (std::memcmp(&simd[std::size_t(i)], &ref[std::size_t(i)], 4) != 0) {
            ADD_FAILURE() << what << " row z=" << r.z << " i0=" << r.i0 << " n=" << r.n << ": sample " << i
                          << " simd " << simd[std::size_t(i)] << " reference " << ref[std::size_t(i)]
                          << " (|diff| " << std::fabs(simd[std::size_t(i)] - ref[std::size_t(i)]) << ")";
            break;
          }
      }
    }
  }
  return bad;
}

// ---- targets ----------------------------------------------------------------------------------------

TEST(SimdTargets, IncludeTheScalarFallbackAndCanBeForced) {
  const auto targets = detail::noise_simd_targets();
  ASSERT_GE(targets.size(), 2u);  // at least one SIMD target and the scalar fallback on x86-64
  EXPECT_EQ(targets.back().name, "SCALAR");
  for (const auto& t : targets) {
    ForceTarget f(t.bits);
    EXPECT_EQ(detail::noise_simd_current_target(), t.name);
  }
  EXPECT_EQ(detail::noise_simd_current_target(), targets.front().name);  // automatic choice again
}

// The core property: every target equals the scalar reference bit for bit, for every basis,
// fractal, cellular return, with and without period and warp.
TEST(SimdTargets, EveryTargetBitIdenticalToScalarReference) {
  for (const auto& t : detail::noise_simd_targets()) {
    ForceTarget f(t.bits);
    int configs = 0;
    for (NoiseBasis b : kBases)
      for (Fractal fr : kFractals)
        for (CellularReturn ret : kReturns) {
          if (b != NoiseBasis::Cellular && ret != CellularReturn::F1) continue;
          for (int variant = 0; variant < 4; ++variant) {
            const bool periodic = variant & 1, warp = variant & 2;
            if (periodic && b == NoiseBasis::Simplex) continue;
            NoiseSettings s;
            s.basis = b;
            s.fractal = fr;
            s.cellular = ret;
            s.octaves = 5;
            s.lacunarity = 2.1;
            s.persistence = 0.55;
            s.frequency = 1.0 / 57.0;
            s.scale_x = 1.3;
            s.jitter = 0.9;
            s.seed = 0xC0FFEEull + std::uint64_t(variant);
            if (periodic) {
              s.period_x_m = 700.0;
              s.period_z_m = variant == 3 ? 0.0 : 450.0;  // also x-only periodic with warp
            }
            if (warp) {
              s.warp_m = 23.0;
              s.warp_frequency = 1.0 / 90.0;
            }
            const std::string what = t.name + " " + name(b) + " fractal " + std::to_string(int(fr)) + " return " +
                                     std::to_string(int(ret)) + (periodic ? " periodic" : "") + (warp ? " warp" : "");
            EXPECT_EQ(mismatches(s, what), 0) << what;
            ++configs;
          }
        }
    EXPECT_EQ(configs, (5 * 4 - 4 + 4 * 4) * 4 - 4 * 2);  // 32 basis×fractal×return, 4 variants, simplex 2
  }
}

TEST(SimdTargets, SixteenOctavesAndZPeriodOnly) {
  for (const auto& t : detail::noise_simd_targets()) {
    ForceTarget f(t.bits);
    for (NoiseBasis b : {NoiseBasis::Perlin, NoiseBasis::Value, NoiseBasis::Gradient, NoiseBasis::Cellular}) {
      NoiseSettings s;
      s.basis = b;
      s.octaves = 16;
      s.lacunarity = 1.7;
      s.frequency = 1.0 / 3000.0;
      s.period_z_m = 5000.0;
      EXPECT_EQ(mismatches(s, t.name + " " + name(b)), 0) << t.name << " " << name(b);
    }
  }
}

// Simplex's vector path picks its lattice rows' vertex arrays per lane by selects (warp) or per row;
// dense grids put samples on and near every cell edge, lattice vertex, triangle edge and kernel
// boundary. Perlin's AVX-512 path looks its table
// up with 16-bit permutes: rows of 2048 samples at frequency 1 cross every one of its 256 cells.
TEST(SimdTargets, SimplexAndPerlinDenseGridsBitIdenticalToScalarReference) {
  for (const auto& t : detail::noise_simd_targets()) {
    ForceTarget f(t.bits);
    for (NoiseBasis b : {NoiseBasis::Simplex, NoiseBasis::Perlin})
      for (double freq : {1.0, 1.0 / 8.0, 1.0 / 61.0}) {
        NoiseSettings s;
        s.basis = b;
        s.fractal = Fractal::Fbm;
        s.octaves = 3;
        s.frequency = freq;
        s.seed = 17;
        const Noise n(s);
        int bad = 0;
        for (int j = -40; j < 40 && bad == 0; ++j) {
          const int len = freq == 1.0 ? 2048 : 203;
          const double dx = freq == 1.0 ? 0.37 : 0.125;
          std::vector<float> simd(std::size_t(len), 0.0f), ref(std::size_t(len), 1.0f);
          n.row(double(j) * 0.25, -101, dx, len, simd.data());
          n.row_reference(double(j) * 0.25, -101, dx, len, ref.data());
          if (!same_bits(simd, ref)) ++bad;
        }
        EXPECT_EQ(bad, 0) << t.name << " " << name(b) << " frequency " << freq;
      }
  }
}

// Cellular F1 visits the 3×3 neighbourhood own cell first and skips neighbours that cannot come
// closer (a bound on the feature points' position, per jitter, shrunk by 2⁻¹⁸ for float rounding);
// the rows kernel culls each cell's candidates by float bounds (noise_rows_simd.cpp, CellLists).
// Dense grids for every return at several jitters, including 0 (every point at its cell's centre),
// and with a period, must still give the reference's bits. (No distances tie here: the random
// per-octave offsets never put fx or fy on 0, ½ or 1; CellularTies below makes them tie.)
TEST(SimdTargets, CellularDenseGridsBitIdenticalToScalarReference) {
  for (const auto& t : detail::noise_simd_targets()) {
    ForceTarget f(t.bits);
    for (CellularReturn ret : kReturns)
      for (double jitter : {1.0, 0.6, 0.0})
        for (int variant = 0; variant < 2; ++variant) {
          NoiseSettings s;
          s.basis = NoiseBasis::Cellular;
          s.cellular = ret;
          s.jitter = jitter;
          s.fractal = variant ? Fractal::Fbm : Fractal::None;
          s.octaves = 3;
          s.frequency = variant ? 1.0 / 16.0 : 1.0 / 4.0;
          if (variant) s.period_x_m = 160.0;
          s.seed = 99;
          const Noise n(s);
          int bad = 0;
          for (int j = -30; j < 30 && bad == 0; ++j) {
            std::vector<float> simd(333, 0.0f), ref(333, 1.0f);
            n.row(double(j) * 0.5, -120, 0.25, 333, simd.data());
            n.row_reference(double(j) * 0.5, -120, 0.25, 333, ref.data());
            if (!same_bits(simd, ref)) ++bad;
          }
          EXPECT_EQ(bad, 0) << t.name << " return " << int(ret) << " jitter " << jitter << " variant " << variant;
        }
  }
}

TEST(SimdTargets, NonFiniteCoordinatesDoNotCrashAnyTarget) {
  // Values are unspecified; the sanitizer build checks there is no UB in either path.
  for (const auto& t : detail::noise_simd_targets()) {
    ForceTarget f(t.bits);
    for (NoiseBasis b : kBases) {
      NoiseSettings s;
      s.basis = b;
      s.warp_m = 5.0;
      const Noise n(s);
      float v[19];
      for (double bad : {std::nan(""), HUGE_VAL, -HUGE_VAL, 1e300}) {
        n.row(bad, -3, 1.0, 19, v);
        n.row(1.0, 0, bad, 19, v);
      }
      EXPECT_TRUE(std::isfinite(n.at(12.5, 7.25))) << t.name << " " << name(b);
    }
  }
}

// ---- Gradient: pinned output ------------------------------------------------------------------------

// 64 × 64 samples 9.5 m apart around the origin, by the scalar reference and by the dispatched
// path.
struct PinnedGrid {
  std::vector<float> ref, simd;
};
PinnedGrid pinned_grid(const Noise& n) {
  PinnedGrid g;
  for (int j = 0; j < 64; ++j) {
    std::vector<float> a(64), b(64);
    n.row_reference(j * 9.5, -32, 9.5, 64, a.data());
    n.row(j * 9.5, -32, 9.5, 64, b.data());
    g.ref.insert(g.ref.end(), a.begin(), a.end());
    g.simd.insert(g.simd.end(), b.begin(), b.end());
  }
  return g;
}

TEST(Gradient, GoldenHashOnScalarReference) {
  // 64 × 64 samples of 6-octave fBm, seed 2024 (as the other bases' golden hashes in test_noise.cpp),
  // computed by the scalar reference; the dispatched path must give the same bytes.
  NoiseSettings s;
  s.basis = NoiseBasis::Gradient;
  s.frequency = 1.0 / 300.0;
  s.seed = 2024;
  const Noise n(s);
  const auto [ref, simd] = pinned_grid(n);
  // Changed deliberately with the dyadic lattice (lacunarity 2: octaves ≥ 1 at 2ᵏ·u₀ + ½).
  EXPECT_EQ(fnv1a(ref), 14297808085583764422ull);
  EXPECT_TRUE(same_bits(ref, simd));
}

TEST(Gradient, RidgedGoldenHashesOnScalarReference) {
  // The same 64 × 64 samples as 6-octave ridged, on the dyadic lattice (lacunarity 2) and the
  // general one (1.9). Changed deliberately when √aₖ moved into the corner offsets (ridged_scale in
  // noise_simd.hpp; before: 11466826381672026036 and 4707178536399064673, the same mean to 1e-6).
  const std::pair<double, std::uint64_t> cases[] = {{2.0, 15553687347833334078ull}, {1.9, 14566465231067961733ull}};
  for (const auto& [lacunarity, golden] : cases) {
    NoiseSettings s;
    s.basis = NoiseBasis::Gradient;
    s.fractal = Fractal::Ridged;
    s.lacunarity = lacunarity;
    s.frequency = 1.0 / 300.0;
    s.seed = 2024;
    const Noise n(s);
    const auto [ref, simd] = pinned_grid(n);
    EXPECT_EQ(fnv1a(ref), golden) << "lacunarity " << lacunarity;
    EXPECT_TRUE(same_bits(ref, simd)) << "lacunarity " << lacunarity;
  }
}

TEST(Gradient, LipschitzAcrossCellEdges) {
  // 1 cell per metre; steps of 0.01 cell cross a cell edge about 1 time in 100. A wrong next-cell
  // index or hash at an edge would show as a jump; smooth gradient noise moves by at most a few
  // times the step (its slope is bounded by ~2.5 per cell here).
  NoiseSettings s;
  s.basis = NoiseBasis::Gradient;
  s.fractal = Fractal::None;
  s.frequency = 1.0;
  const Noise n(s);
  double worst = 0;
  for (std::uint64_t i = 0; i < 20000; ++i) {
    const double x = -500 + 1000 * unit_double(hash64(0x11, i)), z = -500 + 1000 * unit_double(hash64(0x12, i));
    worst = std::max(worst, double(std::fabs(n.at(x + 0.01, z) - n.at(x, z))));
    worst = std::max(worst, double(std::fabs(n.at(x, z + 0.01) - n.at(x, z))));
  }
  EXPECT_LT(worst, 0.05);
  EXPECT_GT(worst, 0.005);  // not flat
}

// ---- Gradient vs Perlin: statistics ------------------------------------------------------------------

NoiseSettings single(NoiseBasis b, std::uint64_t seed, double frequency = 1.0 / 16.0) {
  NoiseSettings s;
  s.basis = b;
  s.fractal = Fractal::None;
  s.frequency = frequency;
  s.seed = seed;
  return s;
}

std::vector<double> patch(const NoiseSettings& s, int side, double x0 = 0, double z0 = 0) {
  const Noise n(s);
  std::vector<double> v(std::size_t(side) * side);
  std::vector<float> row(static_cast<std::size_t>(side));
  for (int j = 0; j < side; ++j) {
    n.row(z0 + j, std::int64_t(x0), 1.0, side, row.data());
    for (int i = 0; i < side; ++i) v[std::size_t(j) * side + i] = row[std::size_t(i)];
  }
  return v;
}

struct Moments {
  double min = 1e9, max = -1e9, mean = 0, sd = 0;
  double q001 = 0, q999 = 0;  // 0.1 % and 99.9 % quantiles
  double dvar[4] = {0, 0, 0, 0};  // variance of the derivative along x, z, (1, 1)/√2, (1, −1)/√2
};
// `seeds` × 256² samples. At 4 samples per cell (16 seeds: 65 536 cells) for the value
// statistics: over a few thousand cells the standard deviation still varies by several per cent
// with the seed. At 16 samples per cell for derivatives (64 seeds: 16 384 cells), so that the
// finite differences (also along the diagonals, √2 samples long) stay close to the derivative.
// `make(seed)`: the settings for one seed.
template <class Make>
Moments moments_of(Make make, int seeds) {
  Moments m;
  double sum = 0, sq = 0, count = 0, dcount = 0;
  const int side = 256;
  std::vector<double> all;
  for (std::uint64_t seed = 1; seed <= std::uint64_t(seeds); ++seed) {
    const auto v = patch(make(seed), side, 1000.0 * double(seed), -500.0 * double(seed));
    all.insert(all.end(), v.begin(), v.end());
    for (double x : v) {
      m.min = std::min(m.min, x);
      m.max = std::max(m.max, x);
      sum += x;
      sq += x * x;
      ++count;
    }
    auto at = [&](int i, int j) { return v[std::size_t(j) * side + i]; };
    for (int j = 1; j + 1 < side; ++j)
      for (int i = 1; i + 1 < side; ++i) {
        const double dxv = at(i + 1, j) - at(i, j), dzv = at(i, j + 1) - at(i, j);
        const double d1 = (at(i + 1, j + 1) - at(i, j)) / std::sqrt(2.0);
        const double d2 = (at(i + 1, j - 1) - at(i, j)) / std::sqrt(2.0);
        m.dvar[0] += dxv * dxv;
        m.dvar[1] += dzv * dzv;
        m.dvar[2] += d1 * d1;
        m.dvar[3] += d2 * d2;
        ++dcount;
      }
  }
  auto quantile = [&](double q) {
    auto it = all.begin() + std::ptrdiff_t(q * double(all.size() - 1));
    std::nth_element(all.begin(), it, all.end());
    return *it;
  };
  m.q001 = quantile(0.001);
  m.q999 = quantile(0.999);
  m.mean = sum / count;
  m.sd = std::sqrt(sq / count - m.mean * m.mean);
  for (double& d : m.dvar) d /= dcount;
  return m;
}
Moments moments(NoiseBasis b, double frequency, int seeds = 16) {
  return moments_of([&](std::uint64_t seed) { return single(b, seed, frequency); }, seeds);
}

TEST(GradientVsPerlin, RangeMeanAndSpread) {
  const Moments g = moments(NoiseBasis::Gradient, 1.0 / 4.0), p = moments(NoiseBasis::Perlin, 1.0 / 4.0);
  EXPECT_GE(g.min, -1.0);
  EXPECT_LE(g.max, 1.0);
  EXPECT_NEAR(g.mean, 0.0, 0.02);
  EXPECT_NEAR(p.mean, 0.0, 0.02);
  EXPECT_NEAR(g.sd / p.sd, 1.0, 0.03) << "gradient sd " << g.sd << ", perlin sd " << p.sd;
  std::printf("sd gradient %.5f perlin %.5f; extremes gradient %.3f %.3f perlin %.3f %.3f; 0.1%%/99.9%% quantiles "
              "gradient %.3f %.3f perlin %.3f %.3f\n",
              g.sd, p.sd, g.min, g.max, p.min, p.max, g.q001, g.q999, p.q001, p.q999);
  // The tails agree: 0.1 % and 99.9 % quantiles within 0.05. (The extremes differ more: Perlin's
  // diagonal gradients, length √2, reach ±1 near cell centres; the gradient set has no exact
  // diagonals and is bounded by √1.375·√½ ≈ 0.83.)
  EXPECT_NEAR(g.q001, p.q001, 0.05) << g.q001 << " vs " << p.q001;
  EXPECT_NEAR(g.q999, p.q999, 0.05) << g.q999 << " vs " << p.q999;
  EXPECT_GE(p.min, -1.0);
  EXPECT_LE(p.max, 1.0);
}

TEST(GradientVsPerlin, DerivativesAreIsotropic) {
  const Moments g = moments(NoiseBasis::Gradient, 1.0 / 16.0, 64), p = moments(NoiseBasis::Perlin, 1.0 / 16.0, 64);
  std::printf("derivative variance gradient x %.6f z %.6f diag %.6f anti %.6f; perlin x %.6f z %.6f diag %.6f anti %.6f\n",
              g.dvar[0], g.dvar[1], g.dvar[2], g.dvar[3], p.dvar[0], p.dvar[1], p.dvar[2], p.dvar[3]);
  const auto [lo, hi] = std::minmax_element(std::begin(g.dvar), std::end(g.dvar));
  EXPECT_LT(*hi / *lo, 1.05) << "x " << g.dvar[0] << " z " << g.dvar[1] << " diag " << g.dvar[2] << " anti "
                             << g.dvar[3];
  // The same total derivative variance as Perlin's (the same "roughness" at the same frequency).
  const double gsum = g.dvar[0] + g.dvar[1], psum = p.dvar[0] + p.dvar[1];
  EXPECT_NEAR(gsum / psum, 1.0, 0.08) << gsum << " vs " << psum;
}


// Radially averaged power spectrum of 256² patches, each normalised to total power 1, averaged
// over 16 seeds (seeds from `first`); bin r holds the wave vectors with round(|k|) = r cycles per
// patch. At 8 samples per cell a patch holds 32² lattice cells.
template <class Make>
std::vector<double> spectrum_of(Make make, std::uint64_t first) {
  const int n = 256, seeds = 16;
  std::vector<double> bins(std::size_t(n / 2 + 1), 0.0);
  for (std::uint64_t seed = first; seed < first + seeds; ++seed) {
    std::vector<double> v;
    if constexpr (std::is_same_v<decltype(make(seed)), std::vector<double>>)
      v = make(seed);  // the patch's values themselves (n² of them)
    else
      v = patch(make(seed), n, 300.0 * double(seed), 0.0);
    double mean = 0;
    for (double x : v) mean += x;
    mean /= double(v.size());
    std::vector<std::vector<std::complex<double>>> rows(static_cast<std::size_t>(n), std::vector<std::complex<double>>(static_cast<std::size_t>(n)));
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) rows[std::size_t(j)][std::size_t(i)] = v[std::size_t(j) * n + i] - mean;
      fft(rows[std::size_t(j)]);
    }
    std::vector<double> local(bins.size(), 0.0);
    const double total = radial_power(rows, local);
    for (std::size_t r = 0; r < bins.size(); ++r) bins[r] += local[r] / total / seeds;
  }
  return bins;
}
std::vector<double> spectrum(NoiseBasis b, double frequency, std::uint64_t first = 11) {
  return spectrum_of([&](std::uint64_t seed) { return single(b, seed, frequency); }, first);
}


TEST(GradientVsPerlin, RadialPowerSpectrumMatches) {
  const auto g = spectrum(NoiseBasis::Gradient, 1.0 / 8.0), p = spectrum(NoiseBasis::Perlin, 1.0 / 8.0);
  // Reference for the tolerances: Perlin against itself with other seeds.
  const auto p2 = spectrum(NoiseBasis::Perlin, 1.0 / 8.0, 101);
  const auto peak = [](const std::vector<double>& s) { return std::max_element(s.begin(), s.end()) - s.begin(); };
  EXPECT_NEAR(double(peak(g)), double(peak(p)), 1.0);
  std::printf("KS distance: gradient-perlin %.4f, perlin-perlin (other seeds) %.4f\n", ks(g, p), ks(p2, p));
  EXPECT_LT(ks(g, p), 0.03);
  // Bin by bin where the power is (bins holding ≥ 1 % of it), smoothed over 3 bins (a single bin
  // of 16 patches varies by up to 25 % between seed sets), against both Perlin seed sets: within 10 %.
  auto smooth = [](const std::vector<double>& s, std::size_t r) { return s[r - 1] + s[r] + s[r + 1]; };
  double worst = 0;
  for (std::size_t r = 1; r + 1 < g.size(); ++r)
    if (p[r] >= 0.01) worst = std::max(worst, std::fabs(2 * smooth(g, r) / (smooth(p, r) + smooth(p2, r)) - 1.0));
  EXPECT_LT(worst, 0.1);
  // The comparison discriminates: value noise (a different spectrum) and Perlin at 1.25× the
  // frequency are both further from Perlin than the tolerance.
  const double ks_value = ks(spectrum(NoiseBasis::Value, 1.0 / 8.0), p);
  const double ks_faster = ks(spectrum(NoiseBasis::Perlin, 1.25 / 8.0), p);
  std::printf("KS distance to perlin: value %.4f, perlin at 1.25x frequency %.4f\n", ks_value, ks_faster);
  EXPECT_GT(ks_value, 0.03);
  EXPECT_GT(ks_faster, 0.03);
}

// The redefined simplex (rows along x, src/noise.cpp) keeps the feature size and spectrum of the
// definition it replaced: Gustavson's skewed classic simplex with the lattice scale √3/2 applied to
// the frequency (an edge of 2√2/3 cycles). Its radially averaged power spectrum is that of
// simplex2 (src/noise_classic.cpp, relief.compat's) at √3/2 times the frequency, within the
// tolerance GradientVsPerlin holds gradient to (a KS distance below 0.03; measured 0.024, and below
// 0.03 only for scales from 0.86 to 0.90), and the comparison discriminates: the classic at 1.25×
// that frequency, or value noise, is further away.
TEST(Simplex, RadialPowerSpectrumMatchesTheDefinitionItReplaced) {
  const double f = 1.0 / 8.0, lattice = 0.86602540378443864676;
  auto classic = [](double freq) {
    return [freq](std::uint64_t seed) {  // the patches spectrum_of reads: 256² samples from x = 300·seed
      std::vector<double> v(std::size_t(256) * 256);
      for (int j = 0; j < 256; ++j)
        for (int i = 0; i < 256; ++i)
          v[std::size_t(j) * 256 + std::size_t(i)] =
              relief::classic::simplex2(float((300.0 * double(seed) + i) * freq), float(j * freq));
      return v;
    };
  };
  const auto s = spectrum(NoiseBasis::Simplex, f), c = spectrum_of(classic(lattice * f), 11);
  const auto peak = [](const std::vector<double>& v) { return std::max_element(v.begin(), v.end()) - v.begin(); };
  EXPECT_NEAR(double(peak(s)), double(peak(c)), 2.0);  // a broad peak: its bin moves by 1–2 between seed sets
  const double ks_classic = ks(s, c), ks_seeds = ks(s, spectrum(NoiseBasis::Simplex, f, 101));
  const double ks_faster = ks(spectrum_of(classic(1.25 * lattice * f), 11), s), ks_value = ks(spectrum(NoiseBasis::Value, f), s);
  std::printf("KS distance: simplex-classic %.4f, simplex-simplex (other seeds) %.4f, classic at 1.25x %.4f, value %.4f\n",
              ks_classic, ks_seeds, ks_faster, ks_value);
  EXPECT_LT(ks_classic, 0.03);
  EXPECT_GT(ks_faster, 0.03);
  EXPECT_GT(ks_value, 0.03);
}

// ---- Gradient: the dyadic lattice (lacunarity 2) ---------------------------------------------------

TEST(SimdTargets, DyadicLatticeBitIdenticalToScalarReference) {
  // Lacunarity exactly 2 (and no period) takes the fixed-point octave stepping; the tests above
  // use 2.1 and 1.7. Every fractal, warped or not, 2 to 16 octaves, anisotropic.
  for (const auto& t : detail::noise_simd_targets()) {
    ForceTarget f(t.bits);
    for (NoiseBasis b : {NoiseBasis::Gradient, NoiseBasis::Value})
    for (Fractal fr : {Fractal::Fbm, Fractal::Ridged, Fractal::Billow})
      for (int octaves : {2, 7, 16})
        for (bool warp : {false, true}) {
          NoiseSettings s;
          s.basis = b;
          s.fractal = fr;
          s.octaves = octaves;
          s.persistence = 0.6;
          s.frequency = 1.0 / 57.0;
          s.scale_z = 0.7;
          s.seed = 0xD1AD1Cull + std::uint64_t(octaves);
          if (warp) {
            s.warp_m = 31.0;
            s.warp_frequency = 1.0 / 80.0;
          }
          const std::string what = t.name + " " + name(b) + " dyadic fractal " + std::to_string(int(fr)) + " octaves " +
                                   std::to_string(octaves) + (warp ? " warp" : "");
          EXPECT_EQ(mismatches(s, what), 0) << what;
        }
  }
}

TEST(Gradient, DyadicFbmIsContinuousAcrossEveryOctavesCellEdges) {
  // 12 octaves with persistence 0.8, so that the finest octaves still weigh: a wrong carry into a
  // cell index at one of their cell edges would jump by ~a_k·0.3/Σa ≥ 3e-3. Steps of 2e-4 m cross
  // an edge of the finest octave (cells of 64/2¹¹ m) about 1 time in 150, of octave k 2^(11−k)
  // times less often; the smooth sum moves by at most ~4e-4 over such a step.
  NoiseSettings s;
  s.basis = NoiseBasis::Gradient;
  s.octaves = 12;
  s.persistence = 0.8;
  s.frequency = 1.0 / 64.0;
  s.seed = 77;
  const Noise n(s);
  // On the scalar reference (the vector paths equal it bit for bit: tests above), at x as at().
  auto at = [&](double x, double z) {
    float v;
    n.row_reference(z, 1, x, 1, &v);
    return double(v);
  };
  double worst = 0;
  for (std::uint64_t i = 0; i < 40000; ++i) {
    const double x = -2000 + 4000 * unit_double(hash64(0x21, i)), z = -2000 + 4000 * unit_double(hash64(0x22, i));
    worst = std::max(worst, std::fabs(at(x + 2e-4, z) - at(x, z)));
    worst = std::max(worst, std::fabs(at(x, z + 2e-4) - at(x, z)));
  }
  std::printf("largest change over a 2e-4 m step: %.3g\n", worst);
  EXPECT_LT(worst, 8e-4);
  EXPECT_GT(worst, 1e-5);  // not flat
}

// The dyadic lattice (lacunarity 2: octave k at 2ᵏ·u₀ + ½) against the general path's seeded
// per-octave offsets (lacunarity the next double above 2: the same frequencies to 16 digits):
// the same value distribution, derivative variance (isotropic) and spectrum of 6-octave fBm.
NoiseSettings fbm6(std::uint64_t seed, double lacunarity, double frequency, NoiseBasis b = NoiseBasis::Gradient) {
  NoiseSettings s;
  s.basis = b;
  s.lacunarity = lacunarity;
  s.frequency = frequency;
  s.seed = seed;
  return s;
}

TEST(Gradient, DyadicFbmStatisticsMatchTheSeededOffsets) {
  const double general = std::nextafter(2.0, 3.0);
  const Moments dy = moments_of([](std::uint64_t seed) { return fbm6(seed, 2.0, 1.0 / 64.0); }, 32);
  const Moments ge = moments_of([&](std::uint64_t seed) { return fbm6(seed, general, 1.0 / 64.0); }, 32);
  std::printf("6-octave fBm sd dyadic %.5f general %.5f; mean %.5f %.5f; derivative variance x %.3g %.3g z %.3g "
              "%.3g diag %.3g %.3g anti %.3g %.3g\n",
              dy.sd, ge.sd, dy.mean, ge.mean, dy.dvar[0], ge.dvar[0], dy.dvar[1], ge.dvar[1], dy.dvar[2], ge.dvar[2],
              dy.dvar[3], ge.dvar[3]);
  EXPECT_NEAR(dy.sd / ge.sd, 1.0, 0.04);
  EXPECT_NEAR(dy.mean, ge.mean, 0.02);
  EXPECT_NEAR(dy.q001, ge.q001, 0.05);
  EXPECT_NEAR(dy.q999, ge.q999, 0.05);
  // Per direction (the finest octave's 2 m cells make 1 m finite differences direction-biased
  // in both paths alike, so the directions are compared path to path, not to each other).
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(dy.dvar[k] / ge.dvar[k], 1.0, 0.05) << "direction " << k;
  const auto sd = spectrum_of([](std::uint64_t seed) { return fbm6(seed, 2.0, 1.0 / 32.0); }, 11);
  const auto sg = spectrum_of([&](std::uint64_t seed) { return fbm6(seed, general, 1.0 / 32.0); }, 11);
  const auto sg2 = spectrum_of([&](std::uint64_t seed) { return fbm6(seed, general, 1.0 / 32.0); }, 101);
  std::printf("fBm spectrum KS distance: dyadic-general %.4f, general-general (other seeds) %.4f\n", ks(sd, sg),
              ks(sg2, sg));
  EXPECT_LT(ks(sd, sg), 0.03);
}

// ---- Value: lattice values and the dyadic lattice -----------------------------------------------

// Value noise with independent lattice values uniform in [−1, 1) (variance 1/3) blended by the
// quintic fade s(f) has variance (1/3)·I², I = ∫₀¹ ((1 − s)² + s²) df (the weights of the two
// corners along each axis), whatever the position's distribution over the cell as long as it is
// uniform. Correlated or non-uniform lattice values (a weak hash) would move it. 64 seeds × 256²
// samples at 16 per cell (16 384 cells, random offsets), as the derivative statistics above.
TEST(Value, RangeMeanSpreadAndIsotropyMatchTheDefinition) {
  double integral = 0;
  const int steps = 100000;
  for (int i = 0; i < steps; ++i) {
    const double f = (i + 0.5) / steps, sf = f * f * f * (f * (f * 6 - 15) + 10);
    integral += ((1 - sf) * (1 - sf) + sf * sf) / steps;
  }
  const double sd_theory = std::sqrt(1.0 / 3.0) * integral;
  const Moments v = moments(NoiseBasis::Value, 1.0 / 16.0, 64);
  std::printf("value sd %.5f (theory %.5f) mean %.5f extremes %.4f %.4f; derivative variance x %.3g z %.3g diag "
              "%.3g anti %.3g\n",
              v.sd, sd_theory, v.mean, v.min, v.max, v.dvar[0], v.dvar[1], v.dvar[2], v.dvar[3]);
  EXPECT_GE(v.min, -1.0);
  EXPECT_LT(v.max, 1.0);
  EXPECT_LT(v.min, -0.9);  // the lattice values reach near ±1
  EXPECT_GT(v.max, 0.9);
  EXPECT_NEAR(v.mean, 0.0, 0.02);
  EXPECT_NEAR(v.sd / sd_theory, 1.0, 0.03);
  // Along x and z alike (the square lattice's two axes are symmetric in the definition), and along
  // both diagonals alike.
  EXPECT_NEAR(v.dvar[0] / v.dvar[1], 1.0, 0.05);
  EXPECT_NEAR(v.dvar[2] / v.dvar[3], 1.0, 0.05);
}

// The dyadic lattice (lacunarity 2) against the seeded per-octave offsets (lacunarity the next
// double above 2), for Value as for Gradient above.
TEST(Value, DyadicFbmStatisticsMatchTheSeededOffsets) {
  const double general = std::nextafter(2.0, 3.0);
  const NoiseBasis b = NoiseBasis::Value;
  const Moments dy = moments_of([&](std::uint64_t seed) { return fbm6(seed, 2.0, 1.0 / 64.0, b); }, 32);
  const Moments ge = moments_of([&](std::uint64_t seed) { return fbm6(seed, general, 1.0 / 64.0, b); }, 32);
  std::printf("value 6-octave fBm sd dyadic %.5f general %.5f; mean %.5f %.5f\n", dy.sd, ge.sd, dy.mean, ge.mean);
  EXPECT_NEAR(dy.sd / ge.sd, 1.0, 0.04);
  EXPECT_NEAR(dy.mean, ge.mean, 0.02);
  EXPECT_NEAR(dy.q001, ge.q001, 0.05);
  EXPECT_NEAR(dy.q999, ge.q999, 0.05);
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(dy.dvar[k] / ge.dvar[k], 1.0, 0.05) << "direction " << k;
  const auto sd = spectrum_of([&](std::uint64_t seed) { return fbm6(seed, 2.0, 1.0 / 32.0, b); }, 11);
  const auto sg = spectrum_of([&](std::uint64_t seed) { return fbm6(seed, general, 1.0 / 32.0, b); }, 11);
  const auto sg2 = spectrum_of([&](std::uint64_t seed) { return fbm6(seed, general, 1.0 / 32.0, b); }, 101);
  std::printf("value fBm spectrum KS distance: dyadic-general %.4f, general-general (other seeds) %.4f\n", ks(sd, sg),
              ks(sg2, sg));
  EXPECT_LT(ks(sd, sg), 0.03);
}

// ---- Simplex: range and isotropy ------------------------------------------------------------------

// The scale bounds |n| by 10.564·0.0726755 = 0.7678 (noise.cpp, simplex_cell); the noise comes close
// to that bound, has mean 0 and the standard deviation of the definitions it replaced (0.4174 on
// these samples for the skewed-square classic simplex), and its derivatives have the same variance
// along x, z and both diagonals (the triangular lattice and the 8 gradient directions leave no
// preferred axis, whichever way the lattice's rows run).
TEST(Simplex, RangeMeanAndIsotropicDerivatives) {
  const Moments s = moments(NoiseBasis::Simplex, 1.0 / 16.0, 64);
  std::printf("simplex sd %.5f mean %.5f extremes %.4f %.4f; 0.1%%/99.9%% quantiles %.3f %.3f; derivative variance "
              "x %.3g z %.3g diag %.3g anti %.3g\n",
              s.sd, s.mean, s.min, s.max, s.q001, s.q999, s.dvar[0], s.dvar[1], s.dvar[2], s.dvar[3]);
  EXPECT_GE(s.min, -0.7678);
  EXPECT_LE(s.max, 0.7678);
  EXPECT_LT(s.min, -0.7);
  EXPECT_GT(s.max, 0.7);
  EXPECT_NEAR(s.mean, 0.0, 0.02);
  EXPECT_NEAR(s.sd, 0.4174, 0.01);
  const auto [lo, hi] = std::minmax_element(std::begin(s.dvar), std::end(s.dvar));
  EXPECT_LT(*hi / *lo, 1.05);
}

// The definition (noise.cpp, "Simplex basis"), evaluated independently in double: a triangular
// lattice of unit edge, rows J at height J·√3/2 along x, vertex (C, J) at x = C (+ ½ for odd J),
// every vertex within the kernel's radius summed (not only the containing triangle's), Gradient's
// hash and directions, against Noise::at: equal to float precision, near the origin and a billion
// metres out (the float offsets are relative to the lattice cell, the position's size stays in
// the double split). Octave 0's offsets and key are those of make_octave (noise.cpp).
double simplex_by_definition(std::uint64_t seed, double f, double x, double z) {
  constexpr std::uint64_t kTagTable = 0x7461626c65ull, kTagOffset = 0x6f6666736574ull;
  const double ox = 256.0 * unit_double(hash64(seed, kTagOffset, 0)) * detail::kSimplexLx;
  const double oz = 256.0 * unit_double(hash64(seed, kTagOffset, 1)) * detail::kSimplexLz;
  const std::uint64_t key = hash64(seed, kTagTable, 0);
  const std::uint32_t key32 = std::uint32_t(key ^ (key >> 32));
  const double u = x * (f * detail::kSimplexLx) + ox, v = z * (f * detail::kSimplexLz) + oz;  // edges, row heights
  const double h = std::sqrt(3.0) / 2.0;
  const std::int64_t i = std::int64_t(std::floor(u)), j = std::int64_t(std::floor(v));
  double sum = 0;
  int near = 0;
  for (std::int64_t J = j - 2; J <= j + 3; ++J)
    for (std::int64_t C = i - 3; C <= i + 3; ++C) {
      const double dx = (u - double(i)) - (double(C - i) + ((J & 1) ? 0.5 : 0.0));
      const double dy = (v - double(J)) * h;
      const double att = 0.75 - (dx * dx + dy * dy);
      if (att <= 0) continue;
      near += att > 1e-12;
      const std::uint32_t k = (((std::uint32_t(C) * detail::kGradPx) ^ (std::uint32_t(J) * detail::kGradPz) ^ key32) *
                               detail::kGradM) >> 29;
      sum += std::pow(att, 4) * (double(detail::kGradDirX[k]) * dx + double(detail::kGradDirY[k]) * dy);
    }
  EXPECT_LE(near, 3) << "more than a triangle's vertices within the kernel's radius at " << x << ", " << z;
  return sum * detail::kSimplexScale;
}
TEST(Simplex, MatchesItsDefinitionEvaluatedIndependently) {
  for (double far : {0.0, 1e9, -3.7e8}) {
    const std::uint64_t seed = 41;
    const double f = 1.0 / 7.0;
    NoiseSettings s = single(NoiseBasis::Simplex, seed, f);
    const Noise n(s);
    double worst = 0, spread = 0;
    for (std::uint64_t i = 0; i < 20000; ++i) {
      const double x = far - 300 + 600 * unit_double(hash64(0x51, i)), z = -far - 300 + 600 * unit_double(hash64(0x52, i));
      const double ref = simplex_by_definition(seed, f, x, z);
      worst = std::max(worst, std::fabs(double(n.at(x, z)) - ref));
      spread = std::max(spread, std::fabs(ref));
    }
    std::printf("simplex at %.3g m: largest difference to the definition in double %.3g (values up to %.3f)\n", far,
                worst, spread);
    EXPECT_LT(worst, 2e-5) << far;
    EXPECT_GT(spread, 0.6) << far;
  }
}

// ---- Cellular: the definition, and the hash's independence ------------------------------------------

// The definition (noise.cpp, "Cellular basis"), evaluated independently in double: the cell
// labels ⌊u⌋ + a modulo 2³², the pre-hash s = X·Pₓ + (Z·P_z ⊕ key32) modulo 2³², lowbias32's
// second half after Gradient's multiply, the feature point X + ½ + J·(hi16·2⁻¹⁶ − ½) (likewise z
// with the low 16 bits), the two smallest distances over the 3×3 block (the owner the first with the
// smallest, b outer, a inner; CellValue the top 24 bits of mix32(s_owner ⊕ 0x5BD1E995) ·2⁻²³),
// against Noise::at: equal to float precision near the origin and a billion metres out (the float
// offsets are relative to the cell; the position's size stays in the double split).
// Octave 0's offsets and key are those of make_octave (noise.cpp).
std::uint32_t mix32_by_definition(std::uint32_t t) {
  t *= 0x27D4EB2Fu;
  t ^= t >> 16;
  t *= 0x7FEB352Du;
  return t ^ (t >> 15);
}
double cellular_by_definition(std::uint64_t seed, double f, double jitter, CellularReturn ret, double x, double z) {
  constexpr std::uint64_t kTagTable = 0x7461626c65ull, kTagOffset = 0x6f6666736574ull;
  const double ox = 256.0 * unit_double(hash64(seed, kTagOffset, 0));
  const double oz = 256.0 * unit_double(hash64(seed, kTagOffset, 1));
  const std::uint64_t key = hash64(seed, kTagTable, 0);
  const std::uint32_t key32 = std::uint32_t(key ^ (key >> 32));
  const double u = x * f + ox, v = z * f + oz;
  const double fu = std::floor(u), fv = std::floor(v);
  const double fx = u - fu, fy = v - fv;  // in the sample's cell
  const std::int64_t i = std::int64_t(fu), j = std::int64_t(fv);
  double d1 = HUGE_VAL, d2 = HUGE_VAL;
  std::uint32_t s1 = 0;
  for (int b = -1; b <= 1; ++b)
    for (int a = -1; a <= 1; ++a) {
      const std::uint32_t s = std::uint32_t(i + a) * 0x9E3779B1u + ((std::uint32_t(j + b) * 0x85EBCA6Bu) ^ key32);
      const std::uint32_t h = mix32_by_definition(s);
      const double px = a + 0.5 + jitter * (double(h >> 16) / 65536.0 - 0.5);
      const double py = b + 0.5 + jitter * (double(h & 0xFFFFu) / 65536.0 - 0.5);
      const double d = (px - fx) * (px - fx) + (py - fy) * (py - fy);
      if (d < d1) {
        d2 = d1;
        d1 = d;
        s1 = s;
      } else if (d < d2) {
        d2 = d;
      }
    }
  switch (ret) {
    case CellularReturn::F1: return 2.0 * std::min(std::sqrt(d1), 1.0) - 1.0;
    case CellularReturn::F2: return 2.0 * std::min(std::sqrt(d2) / 1.5, 1.0) - 1.0;
    case CellularReturn::F2MinusF1: return 2.0 * std::min(std::sqrt(d2) - std::sqrt(d1), 1.0) - 1.0;
    case CellularReturn::CellValue: break;
  }
  return double(std::int32_t(mix32_by_definition(s1 ^ 0x5BD1E995u)) >> 8) * 0x1p-23;
}
TEST(Cellular, MatchesItsDefinitionEvaluatedIndependently) {
  for (CellularReturn ret : kReturns)
    for (double jitter : {1.0, 0.7})
      for (double far : {0.0, 1e9, -3.7e8}) {
        const std::uint64_t seed = 43;
        const double f = 1.0 / 7.0;
        NoiseSettings s = single(NoiseBasis::Cellular, seed, f);
        s.cellular = ret;
        s.jitter = jitter;
        const Noise n(s);
        double worst = 0, lo = 1, hi = -1;
        for (std::uint64_t i = 0; i < 20000; ++i) {
          const double x = far - 300 + 600 * unit_double(hash64(0x53, i)),
                       z = -far - 300 + 600 * unit_double(hash64(0x54, i));
          const double ref = cellular_by_definition(seed, f, jitter, ret, x, z);
          worst = std::max(worst, std::fabs(double(n.at(x, z)) - ref));
          lo = std::min(lo, ref);
          hi = std::max(hi, ref);
        }
        std::printf("cellular return %d jitter %.1f at %.3g m: largest difference to the definition in double %.3g "
                    "(values %.3f..%.3f)\n",
                    int(ret), jitter, far, worst, lo, hi);
        EXPECT_LT(worst, 2e-5) << int(ret) << " " << far;
        EXPECT_GT(hi - lo, 1.0) << int(ret) << " " << far;  // not constant
      }
}

// The 32-bit cell hash's outputs (noise_simd.hpp, cell_mix32) over 10⁵ random cells: the feature
// point's offsets ox (top 16 bits) and oy (low 16 bits) are uniform (Kolmogorov–Smirnov distance of
// 64-bin histograms to the uniform one), and ox, oy, the cell value and the right and upper
// neighbours' ox, oy are pairwise uncorrelated (|r| < 0.02; 4.5σ at 10⁵ samples); each of the 32
// hash bits agrees with the same bit of the right and of the upper neighbour's hash half the time
// (|P − ½| < 0.01, 6σ; Gradient's single multiply fails this: its low bits follow the labels' low
// bits, bit 0 alternating from cell to cell).
TEST(Cellular, HashOffsetsUniformAndUncorrelated) {
  const std::uint32_t key32 = 0x2545F491u;
  const int count = 100000, bins = 64;
  std::vector<double> hx(bins, 0.0), hy(bins, 0.0), uni(bins, 1.0 / bins);
  std::vector<double> v[7];  // ox, oy, cell value, right ox, right oy, upper ox, upper oy
  for (auto& w : v) w.reserve(count);
  auto point = [&](std::uint32_t X, std::uint32_t Z, double& px, double& py) {
    const std::uint32_t h = detail::cell_mix32(X * detail::kGradPx + ((Z * detail::kGradPz) ^ key32));
    px = double(h >> 16) * detail::kCell2m16 - 0.5;
    py = double(h & 0xFFFFu) * detail::kCell2m16 - 0.5;
  };
  auto hash = [&](std::uint32_t X, std::uint32_t Z) {
    return detail::cell_mix32(X * detail::kGradPx + ((Z * detail::kGradPz) ^ key32));
  };
  int same_right[32] = {}, same_up[32] = {};
  for (int i = 0; i < count; ++i) {
    const std::uint64_t r = hash64(0xCE11, std::uint64_t(i));
    const std::uint32_t X = std::uint32_t(r), Z = std::uint32_t(r >> 32);
    const std::uint32_t h = hash(X, Z), hr = hash(X + 1u, Z), hu = hash(X, Z + 1u);
    for (int b = 0; b < 32; ++b) {
      same_right[b] += int(((h ^ hr) >> b & 1u) == 0u);
      same_up[b] += int(((h ^ hu) >> b & 1u) == 0u);
    }
    double ox, oy, rx, ry, ux, uy;
    point(X, Z, ox, oy);
    point(X + 1u, Z, rx, ry);
    point(X, Z + 1u, ux, uy);
    const std::uint32_t s = X * detail::kGradPx + ((Z * detail::kGradPz) ^ key32);
    const double cv = double(std::int32_t(detail::cell_mix32(s ^ detail::kCellCvKey)) >> 8) * 0x1p-23;
    hx[std::size_t((ox + 0.5) * bins)] += 1.0 / count;
    hy[std::size_t((oy + 0.5) * bins)] += 1.0 / count;
    const double vals[7] = {ox, oy, cv, rx, ry, ux, uy};
    for (int k = 0; k < 7; ++k) v[k].push_back(vals[k]);
  }
  auto corr = [&](const std::vector<double>& a, const std::vector<double>& b) {
    double ma = 0, mb = 0;
    for (int i = 0; i < count; ++i) ma += a[std::size_t(i)], mb += b[std::size_t(i)];
    ma /= count;
    mb /= count;
    double sab = 0, saa = 0, sbb = 0;
    for (int i = 0; i < count; ++i) {
      const double da = a[std::size_t(i)] - ma, db = b[std::size_t(i)] - mb;
      sab += da * db;
      saa += da * da;
      sbb += db * db;
    }
    return sab / std::sqrt(saa * sbb);
  };
  double worst = 0;
  for (int a = 0; a < 7; ++a)
    for (int b = a + 1; b < 7; ++b) {
      if ((a == 3 && b == 4) || (a == 5 && b == 6)) continue;  // the same pairs as (0, 1)
      const double r = corr(v[a], v[b]);
      worst = std::max(worst, std::fabs(r));
      EXPECT_LT(std::fabs(r), 0.02) << a << " " << b;
    }
  double bit_worst = 0;
  for (int b = 0; b < 32; ++b)
    for (int c : {same_right[b], same_up[b]}) {
      const double dev = std::fabs(double(c) / count - 0.5);
      bit_worst = std::max(bit_worst, dev);
      EXPECT_LT(dev, 0.01) << "bit " << b;
    }
  std::printf("cellular hash: KS distance to uniform ox %.4f oy %.4f; largest |correlation| %.4f; largest bit "
              "agreement bias with a neighbour %.4f\n",
              ks(hx, uni), ks(hy, uni), worst, bit_worst);
  EXPECT_LT(ks(hx, uni), 0.01);
  EXPECT_LT(ks(hy, uni), 0.01);
}

// Octave 0's lattice offsets (make_octave in noise.cpp; cellular_by_definition above).
void octave0_offsets(std::uint64_t seed, double& ox, double& oz) {
  constexpr std::uint64_t kTagOffset = 0x6f6666736574ull;
  ox = 256.0 * unit_double(hash64(seed, kTagOffset, 0));
  oz = 256.0 * unit_double(hash64(seed, kTagOffset, 1));
}

// Issue 17: with Gradient's pre-hash X·Pₓ ⊕ Z·P_z ⊕ key, s(−X, −Z) = s(X, Z) whenever X and Z have
// as many trailing zero bits (−a = a ⊕ the ones above a's lowest set bit, and Pₓ, P_z are odd), so
// a third of the cells around the lattice origin copied their point reflection (offsets and value).
// The cell values of octave 0's 256² cells X, Z ∈ [−128, 128) through Noise::at (frequency 1,
// jitter 0, each cell sampled at its centre: the own point at distance 0 owns it): the values
// repeated (cells minus distinct values) are about N²/2²⁵ = 128 for a random 24-bit value (the ⊕
// form: about 11,000), and no cell equals its reflection (random: 3·10⁻³ expected; ⊕: about 11,000).
TEST(Cellular, CellsDoNotRepeatTheirPointReflectionAboutTheLatticeOrigin) {
  for (std::uint64_t seed : {43ull, 2024ull}) {
    NoiseSettings s = single(NoiseBasis::Cellular, seed, 1.0);
    s.cellular = CellularReturn::CellValue;
    s.jitter = 0.0;
    const Noise n(s);
    double ox, oz;
    octave0_offsets(seed, ox, oz);
    constexpr int kHalf = 128, kSide = 2 * kHalf;
    std::vector<float> v(std::size_t(kSide) * kSide);
    for (int Z = -kHalf; Z < kHalf; ++Z)
      for (int X = -kHalf; X < kHalf; ++X)
        v[std::size_t(Z + kHalf) * kSide + std::size_t(X + kHalf)] = n.at(X + 0.5 - ox, Z + 0.5 - oz);
    int reflected = 0;
    for (int Z = -kHalf + 1; Z < kHalf; ++Z)
      for (int X = -kHalf + 1; X < kHalf; ++X)
        if ((X != 0 || Z != 0) && v[std::size_t(Z + kHalf) * kSide + std::size_t(X + kHalf)] ==
                                      v[std::size_t(-Z + kHalf) * kSide + std::size_t(-X + kHalf)])
          ++reflected;
    std::vector<float> sorted = v;
    std::sort(sorted.begin(), sorted.end());
    const int repeats = int(sorted.size()) - int(std::unique(sorted.begin(), sorted.end()) - sorted.begin());
    std::printf("cellular seed %llu: %d of %d cell values repeated (random 24-bit values: about 128), %d cells "
                "equal to their point reflection (counted from both sides)\n",
                static_cast<unsigned long long>(seed), repeats, kSide * kSide, reflected);
    EXPECT_LE(repeats, 256) << seed;
    EXPECT_LE(reflected, 2) << seed;
    EXPECT_GT(sorted.back() - sorted.front(), 1.9f) << seed;  // values spread over [−1, 1)
  }
}

// Ties (noise.hpp: equal distances are owned by the first of the 3×3 block, offsets b outer along z,
// a inner along x). Frequency 1, jitter 0: every feature point at its cell's centre. The row
// z = ⌈off_z⌉ − off_z puts v on an integer (fy = 0): rows Z − 1 and Z tie for every sample. Just
// below 2⁴⁹ cells (i0 = 2⁵² − 4096, dx = ⅛) u = x + off_x is rounded to a multiple of 1/16, x is one
// of ⅛, so fx = k/8 + (off_x rounded to 1/16 modulo ⅛): for this seed that residue is 0 and fx = 0
// every 8th sample: columns X − 1 and X tie (four ways on the tied rows). 20 samples (the per-sample
// kernel), 400 (the rows kernel) and blocks of rows (Noise::rows), every forced target, every return,
// bit for bit against the reference; the reference against the definition (CellValue: its first
// owner); the ties checked to happen (F2 − F1 = −1 exactly: d2 = d1). A kernel whose last equal
// distance wins fails here (checked: the rows kernel on AVX2 and AVX3, the per-sample kernel on
// every target; the dense grids above pass with either).
TEST(Cellular, TiesAreOwnedByTheFirstInBlockOrderOnEveryTarget) {
  const std::uint64_t seed = 7;
  double ox, oz;
  octave0_offsets(seed, ox, oz);
  const double zt = std::ceil(oz) - oz;  // exact; zt + oz = ⌈oz⌉ exactly
  ASSERT_EQ(zt + oz, std::ceil(oz));
  struct W {
    std::int64_t i0;
    double dx;
    std::vector<double> z;
    int min_ties;  // samples with d2 = d1 expected per row of 20 (0: not checked)
  };
  const std::int64_t far = (std::int64_t(1) << 52) - 4096;  // the rows kernel takes i0 + n < 2⁵²
  const W windows[] = {{-37, 0.37, {zt, zt + 1.0, zt - 3.0}, 20},
                       {far, 0.125, {zt, zt + 2.0}, 20},
                       {far, 0.125, {0.3, zt + 0.5, -7.77}, 2}};
  for (const auto& t : detail::noise_simd_targets()) {
    ForceTarget f(t.bits);
    for (CellularReturn ret : kReturns) {
      NoiseSettings s = single(NoiseBasis::Cellular, seed, 1.0);
      s.cellular = ret;
      s.jitter = 0.0;
      const Noise n(s);
      for (const W& w : windows)
        for (int len : {20, 400}) {
          const int rows = int(w.z.size());
          std::vector<float> block(std::size_t(len) * std::size_t(rows), -5.0f);
          n.rows(w.z.data(), rows, w.i0, w.dx, len, block.data(), len);
          for (int r = 0; r < rows; ++r) {
            const double z = w.z[std::size_t(r)];
            std::vector<float> got(std::size_t(len), -6.0f), ref(std::size_t(len), -7.0f);
            n.row(z, w.i0, w.dx, len, got.data());
            n.row_reference(z, w.i0, w.dx, len, ref.data());
            const std::string what = t.name + " return " + std::to_string(int(ret)) + " i0 " +
                                     std::to_string(w.i0) + " n " + std::to_string(len) + " z " + std::to_string(z);
            int bad = 0, ties = 0, def_bad = 0;
            for (int i = 0; i < len; ++i) {
              const float* b = block.data() + std::size_t(r) * std::size_t(len);
              if (std::memcmp(&got[std::size_t(i)], &ref[std::size_t(i)], 4) != 0 ||
                  std::memcmp(b + i, &ref[std::size_t(i)], 4) != 0) {
                if (bad++ == 0)
                  ADD_FAILURE() << what << " sample " << i << ": row " << got[std::size_t(i)] << " rows " << b[i]
                                << " reference " << ref[std::size_t(i)];
              }
              const double x = double(w.i0 + i) * w.dx;
              const double def = cellular_by_definition(seed, 1.0, 0.0, ret, x, z);
              if (!(std::fabs(double(ref[std::size_t(i)]) - def) <= 2e-5) && def_bad++ == 0)
                ADD_FAILURE() << what << " sample " << i << ": reference " << ref[std::size_t(i)] << " definition " << def;
              if (ret == CellularReturn::F2MinusF1 && ref[std::size_t(i)] == -1.0f) ++ties;
            }
            EXPECT_EQ(bad, 0) << what;
            EXPECT_EQ(def_bad, 0) << what;
            if (ret == CellularReturn::F2MinusF1 && w.min_ties > 0) {
              EXPECT_GE(ties, w.min_ties * len / 20) << what;  // the distances really tie
            }
          }
        }
    }
  }
}

}  // namespace
}  // namespace relief
