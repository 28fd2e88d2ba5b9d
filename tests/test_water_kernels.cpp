// The fast erosion and water kernels against plain reference implementations: the fused SIMD
// thermal step against the two-pass Jacobi step. Each must agree bit for bit, for every Highway
// target and thread count.
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <vector>

#include "erosion.hpp"
#include "hydrology.hpp"
#include "noise_simd.hpp"
#include "relief/pipeline.hpp"
#include "relief/random.hpp"
#include "relief/recipe.hpp"

using namespace relief;

namespace {

Frame frame(int nx, int nz, double cell_m = 10.0, double height_m = 500.0, double sea = 0.3) {
  Frame f;
  f.nx = nx;
  f.nz = nz;
  f.spacing_m = cell_m;
  f.world_width_m = cell_m * (nx - 1);
  f.world_depth_m = cell_m * (nz - 1);
  f.height_m = height_m;
  f.sea_level = sea;
  return f;
}

// An fBm island from the island preset's first stages.
std::vector<float> island(int n, std::uint64_t seed, Frame& f) {
  json doc = load_preset("island");
  doc["world"]["size"] = n;
  doc["world"]["width_m"] = 4000;
  doc["seed"] = seed;
  doc["stages"] = json::array({doc["stages"][0], doc["stages"][1], doc["stages"][2]});
  Terrain t = run(parse_recipe(doc)).terrain;
  f = t.frame;
  return t.get("height").data;
}

// Rough heights with many exact ties (quantised to 1/32): plateaus, equal drops, pits.
std::vector<float> rough(int nx, int nz, std::uint64_t seed) {
  std::vector<float> z(std::size_t(nx) * nz);
  for (std::size_t c = 0; c < z.size(); ++c) z[c] = float(std::floor(unit_double(hash64(seed, c, 1)) * 32.0) / 32.0);
  return z;
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

// ---- references ------------------------------------------------------------------------------

// The two-pass Jacobi thermal step, written plainly (the rule of erosion.hpp).
std::vector<float> thermal_reference(const std::vector<float>& e, const Frame& f, double talus_deg, double rate) {
  const int nx = f.nx, nz = f.nz;
  const float T = float(std::tan(talus_deg * std::acos(-1.0) / 180.0) * f.cell_m() / f.height_m);
  const float c = float(rate);
  auto at = [&](const std::vector<float>& v, int i, int j) {
    return v[std::size_t(std::clamp(j, 0, nz - 1)) * nx + std::size_t(std::clamp(i, 0, nx - 1))];
  };
  std::vector<float> out(e.size()), q(e.size()), next(e.size());
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      const float h = at(e, i, j);
      const float d0 = h - at(e, i - 1, j), d1 = h - at(e, i + 1, j), d2 = h - at(e, i, j - 1), d3 = h - at(e, i, j + 1);
      const float dmax = std::max(std::max(d0, d1), std::max(d2, d3));
      const float tot = (d0 > T ? d0 : 0.0f) + (d1 > T ? d1 : 0.0f) + (d2 > T ? d2 : 0.0f) + (d3 > T ? d3 : 0.0f);
      const float o = dmax > T ? c * (dmax - T) : 0.0f;
      out[std::size_t(j) * nx + i] = o;
      q[std::size_t(j) * nx + i] = tot > 0.0f ? o / tot : 0.0f;
    }
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      const float h = at(e, i, j);
      const float a0 = at(e, i - 1, j) - h, a1 = at(e, i + 1, j) - h, a2 = at(e, i, j - 1) - h, a3 = at(e, i, j + 1) - h;
      const float gain = (a0 > T ? at(q, i - 1, j) * a0 : 0.0f) + (a1 > T ? at(q, i + 1, j) * a1 : 0.0f) +
                         (a2 > T ? at(q, i, j - 1) * a2 : 0.0f) + (a3 > T ? at(q, i, j + 1) * a3 : 0.0f);
      next[std::size_t(j) * nx + i] = h - out[std::size_t(j) * nx + i] + gain;
    }
  return next;
}

void for_each_target(const std::function<void(const char*)>& fn) {
  const auto targets = detail::noise_simd_targets();
  ASSERT_GE(targets.size(), 2u);
  for (const auto& t : targets) {
    detail::noise_simd_force_target(t.bits);
    fn(t.name.c_str());
    detail::noise_simd_force_target(0);
  }
}

}  // namespace

// =================================================================================== thermal

TEST(ThermalKernel, FusedPassMatchesTheTwoPassJacobiStep) {
  // Odd sizes (row tails of every vector width, a single row or column, blocks of 16 rows with a
  // short last block) and an island, over several iterations so that outflow spreads.
  Frame fi;
  const std::vector<float> isl = island(129, 3, fi);
  struct Case {
    Frame f;
    std::vector<float> z;
  };
  std::vector<Case> cases = {{fi, isl}};
  for (auto [nx, nz] : std::vector<std::pair<int, int>>{{37, 23}, {1, 19}, {19, 1}, {2, 2}, {50, 33}})
    cases.push_back({frame(nx, nz, 2.0, 20.0), rough(nx, nz, std::uint64_t(nx * 100 + nz))});
  for (const Case& cs : cases) {
    std::vector<float> z = cs.z, ref = cs.z, next(z.size());
    int changed = 0;
    for (int it = 0; it < 4; ++it) {
      erosion::thermal_iteration(z.data(), next.data(), cs.f, 25.0, 0.5);
      z.swap(next);
      const std::vector<float> r = thermal_reference(ref, cs.f, 25.0, 0.5);
      changed += r != ref;
      ref = r;
      ASSERT_TRUE(same_bits(z, ref)) << cs.f.nx << "×" << cs.f.nz << ", iteration " << it;
    }
    EXPECT_GT(changed, 0) << cs.f.nx << "×" << cs.f.nz << ": the case must exercise the talus rule";
  }
}

TEST(ThermalKernel, EveryHighwayTargetAndThreadCountGivesTheSameBits) {
  Frame f;
  const std::vector<float> z0 = island(257, 4, f);
  std::vector<float> ref;
  auto run3 = [&] {
    std::vector<float> z = z0, next(z.size());
    for (int it = 0; it < 3; ++it) {
      erosion::thermal_iteration(z.data(), next.data(), f, 20.0, 0.4);
      z.swap(next);
    }
    return z;
  };
  for_each_target([&](const char* name) {
    const std::vector<float> z = run3();
    if (ref.empty()) {
      ref = z;
      EXPECT_FALSE(same_bits(z, z0));
    } else {
      EXPECT_TRUE(same_bits(z, ref)) << name;
    }
  });
  for (int threads : {1, 2, 3, 7}) {
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, threads);
    tbb::task_arena arena(threads);
    std::vector<float> z;
    arena.execute([&] { z = run3(); });
    EXPECT_TRUE(same_bits(z, ref)) << threads << " threads";
  }
}
