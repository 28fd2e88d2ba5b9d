// A world build's memory is bounded by the tile size, not the world size (relief/world.hpp,
// issue 18): the peak of a 16385² world is within 10 % of a 4097² one with the same small tile
// (16 times the samples and tiles). Label `slow` (a 16385² build: about 20 s here). Each build runs
// in its own `relief world` process, whose report.json gives its peak resident memory.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "relief/recipe.hpp"
#include "relief/world_bounded.hpp"
#include "support.hpp"

namespace fs = std::filesystem;
using relief::json;
using relief::test::relief_cli;
using relief::test::slurp;
using relief::test::TempDir;

namespace {

// A cheap recipe (one octave of noise): the build's own machinery is what is measured.
std::uint64_t peak_of(const TempDir& d, int n, const std::string& recipe = "cheap.json", const std::string& extra = "") {
  const std::string out = d / ("w" + std::to_string(n));
  const auto r = relief_cli("world " + (d / recipe) + " --size " + std::to_string(n) + " --tile 129 --seed 1 -j 2 -q -o " + out + extra);
  EXPECT_EQ(r.code, 0) << r.out;
  const json rep = json::parse(slurp(fs::path(out) / "report.json"));
  const std::uint64_t peak = rep["performance"]["peak_memory_bytes"].get<std::uint64_t>();
  std::printf("%s, world %d^2, tiles of 129 (%lld tiles): peak %.1f MB (estimated %.1f MB), store %.1f MB\n", recipe.c_str(), n,
              (long long)rep["tiles"]["total"].get<std::int64_t>(), double(peak) / 1e6,
              double(rep["performance"]["estimated_memory_bytes"].get<std::uint64_t>()) / 1e6, double(rep["store_bytes"].get<std::uint64_t>()) / 1e6);
  fs::remove_all(out);
  return peak;
}

}  // namespace

TEST(WorldMemory, PeakOfA16385WorldIsWithinTenPercentOfA4097One) {
  TempDir d("world-memory");
  relief::test::write_text(d / "cheap.json", R"({"name": "cheap", "world": {"size": 513, "width_m": 4000, "height_m": 160, "sea_level": 0.15},
    "stages": [{"stage": "noise", "basis": "gradient", "fractal": "fbm", "octaves": 1, "frequency": 2.5}]})");
  const std::uint64_t small = peak_of(d, 4097);
  const std::uint64_t large = peak_of(d, 16385);
  ASSERT_GT(small, 0u);
  EXPECT_LE(double(large), 1.10 * double(small)) << "4097²: " << small << " bytes, 16385²: " << large << " bytes";
}

// Droplet erosion's world algorithm runs its passes on groups of blocks of 2·reach cells (relief/
// world_bounded.hpp). With a reach long against the tile (here 108 cells of 1 m, tiles of 129), the
// groups used to be at least 16 blocks a side, so a group covered the whole world up to 3500² and
// the peak grew with the world (a 16385² river-island world in tiles of 1025 peaked at 2.7 GB, its
// estimate 0.33 GB). Now a group is about a tile wide: the same cell size and tile give the same
// peak on a 2049² and a 4097² world, and the build's estimate counts the groups.
TEST(WorldMemory, HydraulicWithALongReachIsBoundedByTheTileNotTheWorld) {
  TempDir d("world-memory-hydraulic");
  relief::test::write_text(d / "rain.json", R"({"name": "rain", "world": {"size": 513, "width_m": 512, "height_m": 300, "sea_level": 0.1},
    "stages": [{"stage": "noise", "basis": "gradient", "fractal": "fbm", "octaves": 4, "frequency": 4},
               {"stage": "hydraulic", "droplets_per_km2": 2000, "lifetime": 20, "step_m": 5, "brush_radius_m": 6}]})");
  // 1 m cells at both sizes: the reach is ceil(20 · 5 / 1) + ceil(6 / 1) + 2 = 108 cells.
  const std::uint64_t small = peak_of(d, 2049, "rain.json", " --set world.width_m=2048");
  const std::uint64_t large = peak_of(d, 4097, "rain.json", " --set world.width_m=4096");
  ASSERT_GT(small, 0u);
  EXPECT_LE(double(large), 1.10 * double(small)) << "2049²: " << small << " bytes, 4097²: " << large << " bytes";
  EXPECT_EQ(relief::world_hydraulic_group_blocks(129, 216), 1);
  EXPECT_EQ(relief::world_hydraulic_group_blocks(1025, 988), 2);   // the 8193² river-island world's
  EXPECT_EQ(relief::world_hydraulic_group_blocks(1025, 20), 52);   // a tile's width
  EXPECT_EQ(relief::world_hydraulic_group_blocks(129, 20), 12);    // within 2 tiles
  EXPECT_EQ(relief::world_hydraulic_group_blocks(129, 4), 32);
}
