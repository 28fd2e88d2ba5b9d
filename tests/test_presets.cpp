// Presets keep the promises of their descriptions (issue 16, items 11 and 12).
//
// Each built-in preset's description promises things a user will look for ("a few ponds",
// "snowy summits", "ringed by sea"). Each promise is measured here over seeds 1..10 at 129² and
// must hold for at least 8 of them ("most seeds"). The measures are deliberately plain: elevation
// bands of the preset's own colour levels, 4-connected water and land bodies, biome shares of the
// land, slopes from central differences in metres. Labelled `slow` (tests/CMakeLists.txt): 90 runs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <map>
#include <numbers>
#include <set>
#include <string>
#include <vector>

#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "relief/volume.hpp"
#include "support.hpp"

using namespace relief;
using json = nlohmann::json;

namespace {

constexpr int kSize = 129;
constexpr int kSeeds = 10;
constexpr int kMost = 8;  // "most seeds": at least 8 of 10

Terrain generate(const std::string& preset, std::uint64_t seed) {
  return run(test::preset_recipe(preset, kSize, seed)).terrain;
}

struct Body {
  std::size_t size = 0;
  bool touches_border = false;
};

// 4-connected components of `mask` (row-major nx × nz).
std::vector<Body> bodies(const std::vector<char>& mask, int nx, int nz) {
  std::vector<int> label(mask.size(), -1);
  std::vector<Body> out;
  for (std::size_t s = 0; s < mask.size(); ++s) {
    if (!mask[s] || label[s] >= 0) continue;
    Body b;
    std::deque<std::size_t> q{s};
    label[s] = int(out.size());
    while (!q.empty()) {
      const std::size_t k = q.front();
      q.pop_front();
      ++b.size;
      const int i = int(k % std::size_t(nx)), j = int(k / std::size_t(nx));
      b.touches_border = b.touches_border || i == 0 || j == 0 || i == nx - 1 || j == nz - 1;
      const int di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
      for (int d = 0; d < 4; ++d) {
        const int ii = i + di[d], jj = j + dj[d];
        if (ii < 0 || jj < 0 || ii >= nx || jj >= nz) continue;
        const std::size_t n = std::size_t(jj) * std::size_t(nx) + std::size_t(ii);
        if (mask[n] && label[n] < 0) label[n] = int(out.size()), q.push_back(n);
      }
    }
    out.push_back(b);
  }
  return out;
}

std::vector<char> land_mask(const Terrain& t) {
  const auto& h = t.get("height").data;
  std::vector<char> m(h.size());
  for (std::size_t k = 0; k < h.size(); ++k) m[k] = h[k] > t.frame.sea_level;
  return m;
}

std::vector<char> invert(std::vector<char> m) {
  for (char& c : m) c = !c;
  return m;
}

double fraction(const std::vector<char>& m) {
  return double(std::count(m.begin(), m.end(), 1)) / double(m.size());
}

// Slope in degrees at (i, j): central differences (one-sided at the border) of the height in metres.
double slope_deg(const Terrain& t, int i, int j) {
  const auto& h = t.get("height").data;
  const int nx = t.frame.nx, nz = t.frame.nz;
  auto at = [&](int a, int b) { return double(h[std::size_t(b) * nx + a]) * t.frame.height_m; };
  const int i0 = std::max(0, i - 1), i1 = std::min(nx - 1, i + 1), j0 = std::max(0, j - 1), j1 = std::min(nz - 1, j + 1);
  const double gx = (at(i1, j) - at(i0, j)) / ((i1 - i0) * t.frame.cell_m());
  const double gz = (at(i, j1) - at(i, j0)) / ((j1 - j0) * t.frame.cell_m());
  return std::atan(std::hypot(gx, gz)) * 180.0 / std::numbers::pi;
}

// The steepest land sample next to the sea (4-neighbours), in degrees.
double max_coast_slope_deg(const Terrain& t) {
  const auto land = land_mask(t);
  const int nx = t.frame.nx, nz = t.frame.nz;
  double m = 0;
  for (int j = 1; j + 1 < nz; ++j)
    for (int i = 1; i + 1 < nx; ++i) {
      const std::size_t k = std::size_t(j) * nx + i;
      if (!land[k]) continue;
      if (land[k - 1] && land[k + 1] && land[k - nx] && land[k + nx]) continue;
      m = std::max(m, slope_deg(t, i, j));
    }
  return m;
}

// Elevation share of the land in (lo, hi].
double land_share(const Terrain& t, double lo, double hi) {
  const auto& h = t.get("height").data;
  std::size_t n = 0, in = 0;
  for (float e : h) {
    if (e <= t.frame.sea_level) continue;
    ++n;
    in += e > lo && e <= hi;
  }
  return n ? double(in) / double(n) : 0.0;
}

// Biome shares of the land (the ocean excluded), by name (names may repeat in a table: summed).
std::map<std::string, double> biome_shares(const Terrain& t) {
  const auto& b = t.get("biome").data;
  std::map<std::string, double> out;
  std::size_t land = 0;
  for (float v : b) land += v != 0.0f;
  for (float v : b)
    if (v != 0.0f) out[t.biomes[std::size_t(v)].name] += 1.0 / double(land);
  return out;
}

// Steps (4-neighbour) from each sample to the nearest sea sample.
std::vector<int> steps_to_sea(const Terrain& t) {
  const auto land = land_mask(t);
  const int nx = t.frame.nx, nz = t.frame.nz;
  std::vector<int> d(land.size(), -1);
  std::deque<std::size_t> q;
  for (std::size_t k = 0; k < land.size(); ++k)
    if (!land[k]) d[k] = 0, q.push_back(k);
  while (!q.empty()) {
    const std::size_t k = q.front();
    q.pop_front();
    const int i = int(k % std::size_t(nx)), j = int(k / std::size_t(nx));
    const int di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
    for (int s = 0; s < 4; ++s) {
      const int ii = i + di[s], jj = j + dj[s];
      if (ii < 0 || jj < 0 || ii >= nx || jj >= nz) continue;
      const std::size_t n = std::size_t(jj) * nx + ii;
      if (d[n] < 0) d[n] = d[k] + 1, q.push_back(n);
    }
  }
  return d;
}

// Outline squareness of the island: the outermost land radius from the map centre, averaged over
// the diagonal directions, divided by its average over the axis directions. A square outline gives
// up to √2, a round one 1.
double diagonal_over_axis(const Terrain& t) {
  const auto land = land_mask(t);
  const int nx = t.frame.nx, nz = t.frame.nz, bins = 72;
  const double cx = (nx - 1) / 2.0, cz = (nz - 1) / 2.0;
  std::vector<double> rmax(bins, 0.0);
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      if (!land[std::size_t(j) * nx + i]) continue;
      const double a = std::atan2(j - cz, i - cx);
      const int b = std::clamp(int((a + std::numbers::pi) / (2 * std::numbers::pi) * bins), 0, bins - 1);
      rmax[std::size_t(b)] = std::max(rmax[std::size_t(b)], std::hypot(i - cx, j - cz));
    }
  double diag = 0, axis = 0;
  int nd = 0, na = 0;
  for (int b = 0; b < bins; ++b) {
    const double a = (b + 0.5) / bins * 2 * std::numbers::pi - std::numbers::pi;
    if (std::cos(4 * a) < -0.7) diag += rmax[std::size_t(b)], ++nd;
    if (std::cos(4 * a) > 0.7) axis += rmax[std::size_t(b)], ++na;
  }
  return (diag / nd) / (axis / na);
}

// Runs `check` on seeds 1..10; it returns "" when the promise holds, else what failed. Expects at
// least kMost passes and prints every failure.
void expect_most_seeds(const std::string& preset, const std::string& promise,
                       const std::function<std::string(const Terrain&)>& check) {
  int pass = 0;
  std::string failures;
  for (std::uint64_t seed = 1; seed <= kSeeds; ++seed) {
    const std::string why = check(generate(preset, seed));
    if (why.empty()) ++pass;
    else failures += "\n  seed " + std::to_string(seed) + ": " + why;
  }
  EXPECT_GE(pass, kMost) << preset << ": \"" << promise << "\" holds for " << pass << " of " << kSeeds << " seeds"
                         << failures;
}

std::string fmt(const char* what, double v) { return std::string(what) + " " + std::to_string(v); }

// "" when the land is one island (at least 90 % of it in one 4-connected body) off the map border.
std::string one_island(const Terrain& t) {
  const auto b = bodies(land_mask(t), t.frame.nx, t.frame.nz);
  std::size_t total = 0, biggest = 0;
  for (const Body& x : b) {
    if (x.touches_border) return "land on the map border";
    total += x.size, biggest = std::max(biggest, x.size);
  }
  if (total == 0 || biggest < 0.9 * total) return "not one island";
  return "";
}

}  // namespace

TEST(PresetPromises, IslandIsOneIslandRingedBySeaWithEveryBand) {
  expect_most_seeds("island", "a single island ringed by sea, sandy coasts, grass and forest, rocky highlands",
                    [](const Terrain& t) -> std::string {
                      if (const std::string why = one_island(t); !why.empty()) return why;
                      // The colour levels: sand (0.4, 0.415], grass to 0.5, forest to 0.6, rock above.
                      if (land_share(t, 0.4, 0.415) < 0.02) return fmt("sand", land_share(t, 0.4, 0.415));
                      if (land_share(t, 0.415, 0.5) < 0.05) return fmt("grass", land_share(t, 0.415, 0.5));
                      if (land_share(t, 0.5, 0.6) < 0.05) return fmt("forest", land_share(t, 0.5, 0.6));
                      if (land_share(t, 0.6, 1.0) < 0.02) return fmt("rocky highlands", land_share(t, 0.6, 1.0));
                      return "";
                    });
}

TEST(PresetPromises, HillsHaveAFewPondsLittleWaterAndGentleSlopes) {
  // Before issue 16 the hills never reached sea level: no seed of 1..10 had a pond.
  expect_most_seeds("hills", "rolling green hills with a few ponds: gentle slopes, little water",
                    [](const Terrain& t) -> std::string {
                      const auto water = invert(land_mask(t));
                      int ponds = 0;
                      for (const Body& x : bodies(water, t.frame.nx, t.frame.nz)) ponds += x.size >= 3;
                      if (ponds < 1 || ponds > 12) return fmt("ponds", ponds);
                      if (fraction(water) > 0.05) return fmt("water share", fraction(water));
                      double m = 0;
                      for (int j = 0; j < t.frame.nz; ++j)
                        for (int i = 0; i < t.frame.nx; ++i) m = std::max(m, slope_deg(t, i, j));
                      if (m > 25) return fmt("steepest slope (deg)", m);
                      return "";
                    });
}

TEST(PresetPromises, MountainsHaveValleyLakesRockAndSnow) {
  expect_most_seeds("mountains", "an alpine range: ridged crests, deep valleys with lakes, rock and snow",
                    [](const Terrain& t) -> std::string {
                      int lakes = 0;
                      for (const Body& x : bodies(invert(land_mask(t)), t.frame.nx, t.frame.nz))
                        lakes += !x.touches_border && x.size >= 3;
                      if (lakes < 1) return "no lake away from the map border";
                      // The colour levels: rock (0.38, 0.62], snow above 0.62 (rock_max).
                      const auto& h = t.get("height").data;
                      std::size_t rock = 0, snow = 0;
                      for (float e : h) rock += e > 0.38f && e <= 0.62f, snow += e > 0.62f;
                      if (rock < 0.05 * h.size()) return fmt("rock share", double(rock) / h.size());
                      if (snow < 0.005 * h.size()) return fmt("snow share", double(snow) / h.size());
                      return "";
                    });
}

TEST(PresetPromises, DesertHasAlmostNoWater) {
  expect_most_seeds("desert", "dry dune fields and rocky mesas, almost no water", [](const Terrain& t) -> std::string {
    const double w = fraction(invert(land_mask(t)));
    return w > 0.01 ? fmt("water share", w) : "";
  });
}

TEST(PresetPromises, TerracedValleyHasARiverValley) {
  expect_most_seeds("terraced-valley", "rice-terrace hillsides around a winding river valley",
                    [](const Terrain& t) -> std::string {
                      const auto water = invert(land_mask(t));
                      std::size_t biggest = 0;
                      for (const Body& x : bodies(water, t.frame.nx, t.frame.nz)) biggest = std::max(biggest, x.size);
                      if (biggest < 0.01 * water.size()) return fmt("largest water body share", double(biggest) / water.size());
                      return "";
                    });
}

TEST(PresetPromises, ErodedMountainsHaveRiversRunningToTheSea) {
  expect_most_seeds("eroded-mountains", "a coastal range carved by rivers running to the sea",
                    [](const Terrain& t) -> std::string {
                      int to_sea = 0;
                      for (const River& r : t.rivers) to_sea += r.end == "sea";
                      if (to_sea < 5) return fmt("rivers reaching the sea", to_sea);
                      if (fraction(invert(land_mask(t))) < 0.05) return "no sea";
                      return "";
                    });
}

TEST(PresetPromises, RiverIslandIsOneRoundIslandWithRiverMouthsAllRound) {
  // Outline: the squircle falloff drew the island as a rounded square (diagonal / axis extent 1.17
  // on average over seeds 1..10, up to √2 for a square); the circular one is round (≈ 1.0).
  double squareness = 0;
  expect_most_seeds("river-island", "a green island drained by branching rivers, river mouths all round",
                    [&](const Terrain& t) -> std::string {
                      squareness += diagonal_over_axis(t) / kSeeds;
                      const auto b = bodies(land_mask(t), t.frame.nx, t.frame.nz);
                      std::size_t total = 0, biggest = 0;
                      for (const Body& x : b) {
                        if (x.touches_border) return "land on the map border";
                        total += x.size, biggest = std::max(biggest, x.size);
                      }
                      if (total == 0 || biggest < 0.9 * total) return "not one island";
                      // Mouths in at least three of the four quadrants around the centre.
                      std::set<int> quadrants;
                      int mouths = 0;
                      for (const River& r : t.rivers)
                        if (r.end == "sea") {
                          ++mouths;
                          const auto& v = r.vertices.back();
                          quadrants.insert(int(v.x_m > t.frame.world_width_m / 2) + 2 * int(v.z_m > t.frame.world_depth_m / 2));
                        }
                      if (mouths < 5) return fmt("river mouths", mouths);
                      if (quadrants.size() < 3) return fmt("quadrants with a river mouth", double(quadrants.size()));
                      return "";
                    });
  EXPECT_LT(squareness, 1.06) << "the island's outline is square";
}

TEST(PresetPromises, VolcanicIslandHasItsFeaturesBlendedBiomesAndNoSeaCliffs) {
  expect_most_seeds("volcanic-island", "Voronoi biomes blended, a volcano with a lava crater, a crater and a peak",
                    [](const Terrain& t) -> std::string {
                      std::set<std::string> kinds;
                      for (const Point& p : t.points) kinds.insert(p.kind);
                      for (const char* k : {"volcano", "crater", "peak"})
                        if (!kinds.count(k)) return std::string("no ") + k;
                      const auto shares = biome_shares(t);
                      if (!shares.count("lava")) return "no lava";
                      int types = 0;
                      for (const auto& [name, s] : shares)
                        types += name != "beach" && name != "volcano" && name != "lava" && s >= 0.01;
                      if (types < 3) return fmt("biome types over 1 % of the land", types);
                      return "";
                    });
}

TEST(PresetPromises, VolcanicIslandMeetsTheSeaWithoutCliffs) {
  // The biomes stage promises "no sea cliffs": its relief fades in over coast_m (150 m) from the
  // sea. A plateau (lifted ~0.6 of the land range, 270 m here) rose at up to 60° right at the
  // water line (seeds 1..8); coast_slope_deg 25 lengthens the fade-in where the lift is tall.
  expect_most_seeds("volcanic-island", "no sea cliffs", [](const Terrain& t) -> std::string {
    const double m = max_coast_slope_deg(t);
    return m > 30 ? fmt("steepest coastal slope (deg)", m) : "";
  });
}

TEST(PresetPromises, ArchipelagoHasRainforestCoastsDryInteriorsAndSnowySummits) {
  // Before issue 16 snow covered under 0.5 % of the land for 7 of these 10 seeds and rainforest
  // under 5 % for all of them.
  expect_most_seeds("archipelago", "a chain of islands: rainforest coasts, dry interiors, snowy summits",
                    [](const Terrain& t) -> std::string {
                      int islands = 0;
                      for (const Body& x : bodies(land_mask(t), t.frame.nx, t.frame.nz))
                        islands += x.size >= std::size_t(0.002 * t.frame.count());
                      if (islands < 2) return fmt("islands", islands);
                      auto s = biome_shares(t);
                      const double rain = s["tropical rainforest"] + s["temperate rainforest"];
                      const double dry = s["subtropical desert"] + s["temperate desert"] + s["grassland"] + s["shrubland"];
                      if (s["snow"] < 0.005) return fmt("snow share of the land", s["snow"]);
                      if (rain < 0.05) return fmt("rainforest share of the land", rain);
                      if (dry < 0.05) return fmt("dry biome share of the land", dry);
                      // Rainforest on the coasts, dry biomes and snow inland: mean steps to the sea.
                      const auto d = steps_to_sea(t);
                      const auto& b = t.get("biome").data;
                      std::map<std::string, double> sum, n;
                      for (std::size_t k = 0; k < b.size(); ++k) {
                        if (b[k] == 0.0f) continue;
                        const std::string& name = t.biomes[std::size_t(b[k])].name;
                        const std::string g = name.find("rainforest") != std::string::npos ? "rain"
                                              : name == "snow"                                ? "snow"
                                                                                               : "other";
                        sum[g] += d[k], n[g] += 1;
                        sum["land"] += d[k], n["land"] += 1;
                      }
                      const double rain_d = sum["rain"] / n["rain"], land_d = sum["land"] / n["land"];
                      const double snow_d = sum["snow"] / n["snow"];
                      if (rain_d >= land_d) return fmt("rainforest's mean distance to the sea over the land's", rain_d / land_d);
                      if (snow_d <= land_d) return fmt("snow's mean distance to the sea over the land's", snow_d / land_d);
                      return "";
                    });
}

// "A sea-cliff island with arches, overhangs and caves: a plateau that drops into the sea in cliffs
// warped into undercuts and arches, with cheese chambers and tunnels that open at the surface."
// At 257² (3.9 m voxels: the tunnels are metres wide), seeds 1..10: the island, its cliffs (share of
// coast samples steeper than 40°), overhangs (mesh vertices facing down, away from the closed
// volume's base), and caves open to the sky (air voxels deeper than the cover below the local
// surface and 30 m or more inland, reached from the sky through air: a flood fill of the density's
// air, 6-connected). Measured: 94–100 % of the coast steeper than 40°, 17–22 k downward vertices,
// 84–102 k open cave voxels (3–6 k sealed).
TEST(PresetPromises, SeaCliffHasCliffsOverhangsAndCavesWithEntrances) {
  int pass = 0;
  std::string failures;
  for (std::uint64_t seed = 1; seed <= kSeeds; ++seed) {
    const Terrain t = run(test::preset_recipe("sea-cliff", 257, seed)).terrain;
    const std::string why = [&]() -> std::string {
      if (const std::string why = one_island(t); !why.empty()) return why;
      const auto land = land_mask(t);
      // Cliffs: land samples next to the sea.
      const int nx = t.frame.nx, nz = t.frame.nz;
      std::size_t coast = 0, steep = 0;
      for (int j = 1; j + 1 < nz; ++j)
        for (int i = 1; i + 1 < nx; ++i) {
          const std::size_t k = std::size_t(j) * nx + i;
          if (!land[k] || (land[k - 1] && land[k + 1] && land[k - nx] && land[k + nx])) continue;
          ++coast;
          steep += slope_deg(t, i, j) > 40.0;
        }
      if (double(steep) < 0.3 * double(coast)) return fmt("steep coast share", double(steep) / double(coast));
      // Overhangs and the dense density band.
      const VolumeSpec& spec = *t.volume;
      const VolumeGrid g = volume_grid(t, spec);
      std::size_t down = 0;
      mesh_volume(t, spec, seed, [&](VolumeChunkMesh&& c) {
        for (std::size_t a = 0; a < c.mesh.vertex_count(); ++a) {
          const double x = c.mesh.positions[a * 3], y = c.mesh.positions[a * 3 + 1], z = c.mesh.positions[a * 3 + 2];
          if (y < g.y_bottom_m + 3 * g.voxel_m || x < 0 || z < 0 || x > t.frame.world_width_m || z > t.frame.world_depth_m) continue;
          down += c.mesh.normals[a * 3 + 1] < -0.3f;
        }
      });
      if (down < 50) return fmt("downward-facing vertices", double(down));
      const std::size_t ni = std::size_t(g.ni), nj = std::size_t(g.nj), nk = std::size_t(g.nk);
      std::vector<signed char> air(ni * nj * nk, 0);  // 1 air, 0 rock; chunks never evaluated: by kind
      for (std::size_t j = 0; j < nj; ++j)
        for (std::size_t k = 0; k < nk; ++k)
          for (std::size_t i = 0; i < ni; ++i) {
            const double y = double(g.j0 + std::int64_t(j)) * g.voxel_m;
            const int si = std::clamp(int(g.i0) + int(i), 0, nx - 1), sk = std::clamp(int(g.k0) + int(k), 0, nz - 1);
            air[(j * nk + k) * ni + i] = y > t.frame.y_m(t.get("height").data[std::size_t(sk) * nx + si]);  // heightfield guess
          }
      evaluate_volume(t, spec, seed, [&](int, int, int, const DensityBlock& d) {
        for (int j = 1; j + 1 < d.ny; ++j)
          for (int k = 1; k + 1 < d.nz; ++k)
            for (int i = 1; i + 1 < d.nx; ++i) {
              const std::int64_t gi = d.ix0 + i - g.i0, gj = d.iy0 + j - g.j0, gk = d.iz0 + k - g.k0;
              if (gi < 0 || gj < 0 || gk < 0 || gi >= g.ni || gj >= g.nj || gk >= g.nk) continue;
              air[(std::size_t(gj) * nk + std::size_t(gk)) * ni + std::size_t(gi)] = d.at(i, j, k) <= 0;
            }
      });
      // Flood the air from the band's top layer.
      std::vector<char> seen(air.size(), 0);
      std::deque<std::size_t> q;
      for (std::size_t s = (nj - 1) * nk * ni; s < air.size(); ++s)
        if (air[s]) seen[s] = 1, q.push_back(s);
      std::size_t open_cave = 0, sealed = 0;
      const std::vector<int> to_sea = steps_to_sea(t);
      while (!q.empty()) {
        const std::size_t s = q.front();
        q.pop_front();
        const std::size_t i = s % ni, k = (s / ni) % nk, j = s / (ni * nk);
        const std::size_t nb[6] = {i > 0 ? s - 1 : s, i + 1 < ni ? s + 1 : s, k > 0 ? s - ni : s, k + 1 < nk ? s + ni : s,
                                   j > 0 ? s - ni * nk : s, j + 1 < nj ? s + ni * nk : s};
        for (std::size_t n : nb)
          if (air[n] && !seen[n]) seen[n] = 1, q.push_back(n);
      }
      for (std::size_t s = 0; s < air.size(); ++s) {
        if (!air[s]) continue;
        const std::size_t i = s % ni, k = (s / ni) % nk, j = s / (ni * nk);
        const int si = int(g.i0) + int(i), sk = int(g.k0) + int(k);
        if (si < 1 || sk < 1 || si >= nx - 1 || sk >= nz - 1) continue;
        const double depth = t.frame.y_m(t.get("height").data[std::size_t(sk) * nx + std::size_t(si)]) -
                             double(g.j0 + std::int64_t(j)) * g.voxel_m;
        if (depth < 10.0) continue;  // deeper than the preset's 5 m cover plus a voxel
        // Inland only (30 m from the sea): air under an overhanging cliff is not a cave.
        if (double(to_sea[std::size_t(sk) * nx + std::size_t(si)]) * t.frame.cell_m() < 30.0) continue;
        (seen[s] ? open_cave : sealed) += 1;
      }
      if (open_cave < 10000) return fmt("cave air voxels open to the sky", double(open_cave)) + fmt(", sealed", double(sealed));
      return "";
    }();
    if (why.empty()) ++pass;
    else failures += "\n  seed " + std::to_string(seed) + ": " + why;
  }
  EXPECT_GE(pass, kMost) << "sea-cliff holds for " << pass << " of " << kSeeds << " seeds" << failures;
}
