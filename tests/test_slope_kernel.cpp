// The slope stage's row kernel (src/slope_kernel.hpp) against its scalar definition, bit for bit on
// every compiled Highway target; Terrain::layer_for_overwrite (relief/terrain.hpp); the slope and
// hillshade stages, which write their layers through it, give the same bytes whatever the stale
// contents of the buffers they are handed.
#include <gtest/gtest.h>
// The kernel's target list (src/hwy_kernels.hpp: SSSE3 not compiled), so that the targets listed
// below are the ones it was built for.
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS HWY_SSSE3
#endif
#include <hwy/targets.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "relief/stage.hpp"
#include "relief/terrain.hpp"
#include "slope_kernel.hpp"
#include "stages.hpp"
#include "support.hpp"

using relief::json;
using relief::Layer;
using relief::Terrain;
using relief::detail::SlopeRow;

namespace {

// Restores Highway's normal target choice when a test ends.
struct ForcedTarget {
  explicit ForcedTarget(std::int64_t target) { hwy::SetSupportedTargetsForTest(target); }
  ~ForcedTarget() { hwy::SetSupportedTargetsForTest(0); }
};

// The definitions of slope_kernel.hpp, written out again here.
float mean_abs(const float* up, const float* mid, const float* down, int i) {
  const float* r[3] = {up, mid, down};
  const double e = mid[i];
  double sum = 0;
  bool first = true;
  for (int dj = 0; dj < 3; ++dj)
    for (int di = -1; di <= 1; ++di) {
      if (dj == 1 && di == 0) continue;
      const double t = std::fabs(e - double(r[dj][i + di]));
      sum = first ? t : sum + t;
      first = false;
    }
  return float(sum / 8.0);
}
float degrees(const SlopeRow& k, const float* up, const float* mid, const float* down, int i) {
  auto y = [&](float e) { return (double(e) - k.sea_level) * k.height_m; };
  const double gx = (y(mid[i + 1]) - y(mid[i - 1])) / k.cell2_m, gz = (y(down[i]) - y(up[i])) / k.cell2_m;
  return float(std::atan(std::hypot(gx, gz)) * (180.0 / std::numbers::pi));
}

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// A hash of (seed, index) in [0, 1).
double unit(std::uint64_t seed, std::uint64_t k) {
  std::uint64_t z = seed * 0x9E3779B97F4A7C15ull + k * 0xBF58476D1CE4E5B9ull + 1;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return double(z >> 11) * 0x1p-53;
}

// Three rows of n values in one of several characters: gentle terrain, rough terrain with cliffs
// up to vertical, flats and single steps (gradients near 0, tan(π/8) and tan(3π/8), where the
// kernel's argument reduction switches), tiny differences, and non-finite or huge values.
std::vector<float> rows_of(int kind, int n, std::uint64_t seed) {
  std::vector<float> v(3 * std::size_t(n));
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < n; ++i) {
      const std::uint64_t k = std::uint64_t(j) * n + i;
      const double u = unit(seed, k);
      double e = 0;
      switch (kind) {
        case 0: e = 0.5 + 0.001 * (i + 1.3 * j) + 1e-5 * u; break;                   // gentle
        case 1: e = u * (u < 0.1 ? 50.0 : 1.0); break;                                // rough, cliffs
        case 2: e = (i / 3 + j) % 4 == 0 ? 0.45 + 0.01 * u : 0.45; break;              // flats, steps
        case 3: e = 0.4 + std::ldexp(u, -20 - int(seed % 20)); break;                  // tiny
        case 4: e = 0.4 + (i + j) * 0.4142135 / 600.0 * (1 + 1e-7 * u); break;        // near tan(π/8)
        case 5: e = 0.4 + (i + j) * 2.4142135 / 600.0 * (1 + 1e-7 * u); break;        // near tan(3π/8)
        default: {                                                                      // odd values
          const double pick = unit(seed + 1, k);
          e = pick < 0.05   ? std::numeric_limits<double>::quiet_NaN()
              : pick < 0.1  ? std::numeric_limits<double>::infinity()
              : pick < 0.15 ? -std::numeric_limits<double>::infinity()
              : pick < 0.2  ? 3e38 * (u - 0.5)
              : pick < 0.25 ? 1e-40 * u
                            : u;
        }
      }
      v[std::size_t(j) * n + i] = float(e);
    }
  return v;
}

}  // namespace

TEST(SlopeKernel, ScalarDefinitionBitForBitOnEveryTarget) {
  const auto targets = hwy::SupportedAndGeneratedTargets();
  ASSERT_FALSE(targets.empty());
  const SlopeRow frames[] = {{0.4, 600.0, 2.0 * 4000.0 / 4096}, {0.3, 250.0, 2.0 * 700.0 / 36}, {0.0, 64.0, 16.0}, {0.4, 1e6, 0.01}};
  for (std::int64_t target : targets) {
    ForcedTarget force(target);
    ASSERT_STREQ(relief::detail::slope_target(), hwy::TargetName(target)) << "dispatch did not switch";
    std::size_t checked = 0;
    for (int kind = 0; kind <= 6; ++kind)
      for (int n : {3, 4, 5, 7, 9, 17, 67, 130, 1027})
        for (std::uint64_t seed = 1; seed <= 6; ++seed)
          for (const SlopeRow& k : frames) {
            const std::vector<float> h = rows_of(kind, n, seed * 131 + std::uint64_t(n));
            const float *up = h.data(), *mid = up + n, *down = mid + n;
            std::vector<float> s(std::size_t(n), -7.0f), sd(std::size_t(n), -7.0f);
            relief::detail::slope_row(k, up, mid, down, s.data(), sd.data(), n);
            EXPECT_TRUE(same_bits(s[0], -7.0f) && same_bits(sd[0], -7.0f) && same_bits(s[n - 1], -7.0f) &&
                        same_bits(sd[n - 1], -7.0f))
                << "the border columns are the caller's";
            for (int i = 1; i + 1 < n; ++i) {
              ASSERT_TRUE(same_bits(s[i], mean_abs(up, mid, down, i)))
                  << hwy::TargetName(target) << " kind " << kind << " n " << n << " i " << i << ": " << s[i] << " vs "
                  << mean_abs(up, mid, down, i);
              ASSERT_TRUE(same_bits(sd[i], degrees(k, up, mid, down, i)))
                  << hwy::TargetName(target) << " kind " << kind << " n " << n << " i " << i << ": " << sd[i] << " vs "
                  << degrees(k, up, mid, down, i);
              ASSERT_TRUE(same_bits(sd[i], relief::detail::slope_deg_reference(k, up, mid, down, i)));
              ++checked;
            }
          }
    EXPECT_GT(checked, 100000u);
  }
}

// Many gradients spread over every angle: the polynomial path (not the fallback) is what gives
// these bits, and a wrong coefficient or reduction would show as a mismatch.
TEST(SlopeKernel, EveryAngleFromZeroToNinety) {
  const int n = 4099;
  const SlopeRow k{0.4, 600.0, 2.0 * 4000.0 / 4096};
  std::vector<float> up(n), mid(n), down(n);
  std::size_t checked = 0;
  for (int row = 0; row < 64; ++row) {
    for (int i = 0; i < n; ++i) {
      // slope angle spread over (0°, 90°): gz = tan(angle), gx a fraction of it.
      const double angle = (double(row * n + i) + 0.5) / (64.0 * n) * (std::numbers::pi / 2);
      const double g = std::tan(angle) * k.cell2_m / k.height_m;
      up[i] = float(0.5 - 0.5 * g);
      down[i] = float(0.5 + 0.5 * g);
      mid[i] = float(0.5 + 0.25 * g * std::sin(0.37 * i));
    }
    std::vector<float> s(n), sd(n);
    relief::detail::slope_row(k, up.data(), mid.data(), down.data(), s.data(), sd.data(), n);
    for (int i = 1; i + 1 < n; ++i) {
      ASSERT_TRUE(same_bits(sd[i], degrees(k, up.data(), mid.data(), down.data(), i))) << row << " " << i;
      ASSERT_TRUE(same_bits(s[i], mean_abs(up.data(), mid.data(), down.data(), i))) << row << " " << i;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 64u * (n - 2));
}

// ======================================================================== layer_for_overwrite

namespace {
relief::Frame frame(int nx, int nz) {
  relief::Frame f;
  f.nx = nx, f.nz = nz;
  f.spacing_m = 10.0;
  f.world_width_m = 10.0 * (nx - 1);
  f.world_depth_m = 10.0 * (nz - 1);
  return f;
}
}  // namespace

TEST(LayerForOverwrite, FreshLayerHasTheFramesSizeAndChannels) {
  Terrain t;
  t.frame = frame(7, 5);
  Layer& l = t.layer_for_overwrite("shade", 3);
  EXPECT_EQ(l.channels, 3);
  EXPECT_EQ(l.data.size(), 7u * 5u * 3u);
  EXPECT_TRUE(t.has("shade"));
  // Large enough for the huge-page hint (4 MiB and more): still the right size.
  Terrain big;
  big.frame = frame(1025, 1025);
  EXPECT_EQ(big.layer_for_overwrite("color", 3).data.size(), 1025u * 1025u * 3u);
}

TEST(LayerForOverwrite, KeepsAnExistingBufferAndItsValues) {
  Terrain t;
  t.frame = frame(6, 4);
  Layer& l = t.layer("slope", 1);
  for (std::size_t k = 0; k < l.data.size(); ++k) l.data[k] = float(k) + 0.5f;
  const float* before = l.data.data();
  Layer& again = t.layer_for_overwrite("slope", 1);
  EXPECT_EQ(&again, &l);
  EXPECT_EQ(again.data.data(), before) << "no new allocation";
  for (std::size_t k = 0; k < again.data.size(); ++k) ASSERT_EQ(again.data[k], float(k) + 0.5f) << "no zero fill";
  // A different channel count reshapes it (same buffer when it holds the new size).
  Layer& three = t.layer_for_overwrite("slope", 3);
  EXPECT_EQ(three.channels, 3);
  EXPECT_EQ(three.data.size(), 6u * 4u * 3u);
  Layer& one = t.layer_for_overwrite("slope", 1);
  EXPECT_EQ(one.data.size(), 6u * 4u);
  EXPECT_EQ(one.data[5], 5.5f) << "shrinking writes nothing";
}

TEST(LayerForOverwrite, TakesTheSmallestSpareBufferThatFits) {
  Terrain t;
  t.frame = frame(8, 8);
  std::vector<float> small(10, 1.0f), fits(64, 2.0f), larger(500, 3.0f);
  const float* fits_data = fits.data();
  t.spare.push_back(std::move(larger));
  t.spare.push_back(std::move(small));
  t.spare.push_back(std::move(fits));
  Layer& l = t.layer_for_overwrite("shade", 1);
  EXPECT_EQ(l.data.data(), fits_data);
  EXPECT_EQ(l.data.size(), 64u);
  EXPECT_EQ(l.data[0], 2.0f) << "a spare buffer's old values are not cleared";
  EXPECT_EQ(t.spare.size(), 2u);
}

TEST(LayerForOverwrite, LayerStillZeroFillsWhenTheShapeChanges) {
  Terrain t;
  t.frame = frame(5, 5);
  t.spare.push_back(std::vector<float>(25, 9.0f));
  Layer& l = t.layer("water", 1);
  for (float v : l.data) ASSERT_EQ(v, 0.0f);
}

// ============================================================ stages on stale output buffers

namespace {
Terrain rough(int nx, int nz) {
  relief::Frame f = frame(nx, nz);
  f.height_m = 300.0;
  return relief::test::grid_terrain(f, [](int i, int j) {
    return 0.45 + 0.3 * std::sin(0.7 * i + 0.13 * j * j) * std::cos(0.21 * i * j) + (i % 11 == 3 ? 0.2 : 0.0);
  });
}
void apply(const char* stage, Terrain& t, json params = json::object()) {
  params["stage"] = stage;
  relief::Context c;
  c.seed = 3;
  relief::find_stage(stage)->parse(params, "test")->apply(t, c);
}
// Every layer's bytes.
std::vector<std::string> bytes(const Terrain& t, std::initializer_list<const char*> names) {
  std::vector<std::string> out;
  for (const char* n : names) {
    const auto& d = t.get(n).data;
    out.emplace_back(reinterpret_cast<const char*>(d.data()), d.size() * sizeof(float));
  }
  return out;
}
}  // namespace

TEST(SlopeStage, SameBytesOverStaleBuffers) {
  for (auto [nx, nz] : {std::pair{3, 3}, {2, 9}, {9, 2}, {37, 23}, {130, 67}}) {
    for (const char* border : {"mean", "eight"}) {
      Terrain fresh = rough(nx, nz);
      apply("slope", fresh, {{"border", border}});
      // The same terrain with both output layers present and full of NaN and garbage.
      Terrain stale = rough(nx, nz);
      for (const char* n : {"slope", "slope_deg"}) {
        Layer& l = stale.layer(n, 1);
        for (std::size_t k = 0; k < l.data.size(); ++k) l.data[k] = k % 2 ? std::numeric_limits<float>::quiet_NaN() : -1e30f;
      }
      apply("slope", stale, {{"border", border}});
      EXPECT_EQ(bytes(fresh, {"slope", "slope_deg"}), bytes(stale, {"slope", "slope_deg"})) << nx << "x" << nz << " " << border;
      // And from spare buffers holding garbage.
      Terrain spare = rough(nx, nz);
      spare.spare.push_back(std::vector<float>(std::size_t(nx) * nz + 3, std::numeric_limits<float>::quiet_NaN()));
      spare.spare.push_back(std::vector<float>(std::size_t(nx) * nz, 7.0f));
      apply("slope", spare, {{"border", border}});
      EXPECT_EQ(bytes(fresh, {"slope", "slope_deg"}), bytes(spare, {"slope", "slope_deg"})) << nx << "x" << nz << " " << border;
    }
  }
}

TEST(HillshadeStage, SameBytesOverStaleBuffers) {
  for (auto [nx, nz] : {std::pair{2, 2}, {3, 7}, {37, 23}, {130, 67}}) {
    for (bool albedo : {false, true}) {
      Terrain fresh = rough(nx, nz);
      if (albedo) apply("color", fresh);
      Terrain stale = fresh;
      apply("hillshade", fresh);
      for (auto [n, c] : {std::pair{"shade", 1}, {"color", 3}}) {
        Layer& l = stale.layer(n, c);
        for (std::size_t k = 0; k < l.data.size(); ++k) l.data[k] = k % 3 ? std::numeric_limits<float>::quiet_NaN() : 5.0f;
      }
      apply("hillshade", stale);
      EXPECT_EQ(bytes(fresh, {"shade", "color"}), bytes(stale, {"shade", "color"})) << nx << "x" << nz << " " << albedo;
    }
  }
}
