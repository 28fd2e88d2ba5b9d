// A world build's memory is bounded by the tile size, not the world size (relief/world.hpp,
// issue 18): the peak of a 16385² world is within 10 % of a 4097² one with the same small tile
// (16 times the samples and tiles). Label `slow` (a 16385² build: about 20 s here). Each build runs
// in its own `relief world` process, whose report.json gives its peak resident memory.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "relief/recipe.hpp"
#include "support.hpp"

namespace fs = std::filesystem;
using relief::json;
using relief::test::relief_cli;
using relief::test::slurp;
using relief::test::TempDir;

namespace {

// A cheap recipe (one octave of noise): the build's own machinery is what is measured.
std::uint64_t peak_of(const TempDir& d, int n) {
  const std::string out = d / ("w" + std::to_string(n));
  const auto r = relief_cli("world " + (d / "cheap.json") + " --size " + std::to_string(n) + " --tile 129 --seed 1 -j 2 -q -o " + out);
  EXPECT_EQ(r.code, 0) << r.out;
  const json rep = json::parse(slurp(fs::path(out) / "report.json"));
  const std::uint64_t peak = rep["performance"]["peak_memory_bytes"].get<std::uint64_t>();
  std::printf("world %d^2, tiles of 129 (%lld tiles): peak %.1f MB, store %.1f MB\n", n, (long long)rep["tiles"]["total"].get<std::int64_t>(),
              double(peak) / 1e6, double(rep["store_bytes"].get<std::uint64_t>()) / 1e6);
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
