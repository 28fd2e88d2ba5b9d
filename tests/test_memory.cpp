// estimate_memory_bytes (relief/pipeline.hpp), which the CLI and the studio use to refuse sizes the
// machine cannot hold, against the peak resident memory the CLI measures for real runs.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "support.hpp"

namespace fs = std::filesystem;
using relief::json;
using relief::test::slurp;

// Held within a factor of 2 of the peak resident size (getrusage's ru_maxrss, the measure `relief
// bench` uses; report.json's performance.peak_memory_bytes) for presets whose layers differ: the
// plain island with its OBJ, biomes + volcano + jiggle, climate, erosion and flow, and a tilemap
// whose map render is larger than the terrain.
TEST(MemoryEstimate, WithinAFactorOfTwoOfTheMeasuredPeak) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's shadow memory and quarantine inflate the resident size";
#endif
  struct Case {
    std::string args;
    bool mesh;
  };
  const std::vector<Case> cases = {
      {"island --size 1025", true},
      {"volcanic-island --size 1025 --formats heightmap,color,albedo,biomes,props,report", false},
      {"archipelago --size 1025 --formats heightmap,color,albedo,biomes,report", false},
      {"river-island --size 513 --formats heightmap,color,albedo,rivers,report", false},
      {"island --size 257 --tile-size 32 --map-tiles 256 --formats heightmap,tilemap,report", false},
  };
  const relief::test::TempDir tmp("relief-memory");
  const fs::path dir = tmp.path / "out";
  for (const Case& c : cases) {
    fs::remove_all(dir);
    const auto r = relief::test::relief_cli("generate " + c.args + " --seed 4 -j 2 -q -o '" + dir.string() +
                      "' --save-recipe '" + (dir / "r.json").string() + "'");
    ASSERT_EQ(r.code, 0) << c.args << "\n" << r.out;
    const double measured = json::parse(slurp(dir / "report.json"))["performance"]["peak_memory_bytes"].get<double>();
    const relief::Recipe recipe = relief::parse_recipe_text(slurp(dir / "r.json"));
    const double estimate = double(relief::estimate_memory_bytes(recipe, c.mesh));
    std::printf("[memory] %-85s measured %7.1f MiB, estimated %7.1f MiB (%.2fx)\n", c.args.c_str(), measured / 1048576,
                estimate / 1048576, estimate / measured);
    EXPECT_GE(estimate, measured / 2) << c.args;
    EXPECT_LE(estimate, measured * 2) << c.args;
  }
}
