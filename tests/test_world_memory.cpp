// A world build's memory is bounded by the tile size, not the world size (relief/world.hpp,
// issue 18): the peak of a 16385² world is within 10 % of a 4097² one with the same small tile
// (16 times the samples and tiles). Label `slow` (a 16385² build: about 20 s here). Each build runs
// in its own `relief world` process, whose report.json gives its peak resident memory; the stream
// power refinement's test runs in this process and counts the heap itself (operator new, below).
#include <gtest/gtest.h>
#include <malloc.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <new>
#include <string>

#include "relief/recipe.hpp"
#include "relief/terrain.hpp"
#include "relief/world.hpp"
#include "relief/world_bounded.hpp"
#include "support.hpp"

// The heap of this test binary, counted: every operator new and delete (the library's containers
// included) adds or takes the block's usable size, and the largest total since a reset is kept.
namespace {
std::atomic<std::int64_t> g_live{0}, g_peak{0};
void* counted(std::size_t n, std::size_t align) {
  void* p = align > alignof(std::max_align_t) ? std::aligned_alloc(align, (std::max<std::size_t>(n, 1) + align - 1) / align * align)
                                              : std::malloc(std::max<std::size_t>(n, 1));
  if (!p) throw std::bad_alloc();
  const std::int64_t size = std::int64_t(malloc_usable_size(p));
  const std::int64_t now = g_live.fetch_add(size, std::memory_order_relaxed) + size;
  std::int64_t peak = g_peak.load(std::memory_order_relaxed);
  while (now > peak && !g_peak.compare_exchange_weak(peak, now, std::memory_order_relaxed)) {
  }
  return p;
}
void uncounted(void* p) noexcept {
  if (!p) return;
  g_live.fetch_sub(std::int64_t(malloc_usable_size(p)), std::memory_order_relaxed);
  std::free(p);
}
}  // namespace

void* operator new(std::size_t n) { return counted(n, 0); }
void* operator new[](std::size_t n) { return counted(n, 0); }
void* operator new(std::size_t n, std::align_val_t a) { return counted(n, std::size_t(a)); }
void* operator new[](std::size_t n, std::align_val_t a) { return counted(n, std::size_t(a)); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted(n, 0);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted(n, 0);
  } catch (...) {
    return nullptr;
  }
}
void operator delete(void* p) noexcept { uncounted(p); }
void operator delete[](void* p) noexcept { uncounted(p); }
void operator delete(void* p, std::size_t) noexcept { uncounted(p); }
void operator delete[](void* p, std::size_t) noexcept { uncounted(p); }
void operator delete(void* p, std::align_val_t) noexcept { uncounted(p); }
void operator delete[](void* p, std::align_val_t) noexcept { uncounted(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { uncounted(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { uncounted(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { uncounted(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { uncounted(p); }

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

// Stream power's refinement (world_stream_power with sweeps, relief/world_bounded.hpp) keeps the
// records its sweeps pass between blocks (every block's ring levels and inflow, every step, and the
// coarse inflow lists) in temporary files, not in memory. On worlds of 16 and 64 blocks (513² and
// 1025², the same cells, blocks of 128 grown by 16, coarse grid 65², 4 sweeps, 20 steps), counted
// on this binary's heap during the phase:
//   * held: the heap in use when a block has been solved (its own records and window's inputs, the
//     index, before it writes its records): the same on both worlds. Measured 0.85 and 0.91 MB; with
//     the records in memory (before session 17) 4.9 and 18.9 MB, every block's records so far.
//   * peak: one block at a time, the largest of the blocks' peaks. It varies from block to block
//     and run to run (1.2 to 3.6 MB on 513²): the solver's buffers grow with the largest drainage
//     basin it meets in the window, per thread, so a world of more blocks meets larger ones, up to
//     the window's size. The bound allows that: one window of basin buffers (48 bytes per sample,
//     up to twice that as they grow, per thread). Measured 2.9-3.5 and 4.9-5.1 MB; with the
//     records in memory 7.4 and 21.5 MB (both checks fail).
TEST(WorldMemory, StreamPowerRefinementIsBoundedByTheBlockNotTheWorld) {
  constexpr int kCoarse = 65, kBlock = 128, kHalo = 16, kSweeps = 4, kSteps = 20, kThreads = 2;
  struct Heap {
    std::int64_t held = 0, peak = 0;
  };
  auto phase_heap = [&](int n) {
    TempDir d("world-memory-sp");
    relief::json doc = relief::load_preset("eroded-mountains");
    doc["world"]["size"] = n;
    doc["world"]["width_m"] = 12000.0 * double(n - 1) / 512;  // the same cells: blocks of the same kind of relief
    doc["seed"] = 7;
    relief::json stages = relief::json::array();
    for (const relief::json& st : doc["stages"]) {
      if (st["stage"] == "hydraulic") continue;
      relief::json c = st;
      if (st["stage"] == "stream_power") c["steps"] = kSteps;
      stages.push_back(c);
      if (st["stage"] == "stream_power") break;
    }
    doc["stages"] = stages;
    relief::WorldSettings s;
    s.recipe = relief::parse_recipe(doc);
    s.tile = 129;
    s.out_dir = (d.path / "w").string();
    s.threads = kThreads;
    const relief::WorldStageAlgorithm sp = relief::world_stream_power(kCoarse, kBlock, kHalo, kSweeps);
    Heap heap;
    int blocks_seen = 0;
    s.algorithms["stream_power"] = [&](const relief::WorldStageIO& io, const relief::RecipeStage& st, int index) {
      relief::release_cached_buffers();
      const std::int64_t base = g_live.load();
      g_peak.store(base);
      relief::WorldStageIO counted = io;
      // The refinement reports progress after each block's solve, within (0.2, 0.9].
      counted.progress = [&](double f) {
        if (f > 0.2 && f <= 0.9) heap.held = std::max(heap.held, g_live.load() - base), ++blocks_seen;
        if (io.progress) io.progress(f);
      };
      sp(counted, st, index);
      heap.peak = g_peak.load() - base;
    };
    relief::build_world(s);
    EXPECT_EQ(blocks_seen, kSweeps * ((n - 1) / kBlock) * ((n - 1) / kBlock));
    std::printf("stream power refinement, world %d^2 (coarse %d^2, blocks %d, halo %d, %d sweeps, %d steps): heap held after a "
                "block %.2f MB, peak %.2f MB (estimate %.2f MB)\n", n, kCoarse, kBlock, kHalo, kSweeps, kSteps, double(heap.held) / 1e6,
                double(heap.peak) / 1e6, double(relief::world_stream_power_memory_bytes(n, n, kSteps, kCoarse, kBlock, kHalo, kSweeps)) / 1e6);
    return heap;
  };
  const Heap small = phase_heap(513), large = phase_heap(1025);
  ASSERT_GT(small.held, 0);
  EXPECT_LE(double(large.held), 1.10 * double(small.held)) << "513²: " << small.held << " bytes, 1025²: " << large.held << " bytes";
  const double window = double(kBlock + 2 * kHalo + 1) * double(kBlock + 2 * kHalo + 1);
  EXPECT_LE(double(large.peak), 1.10 * double(small.peak) + window * 48 * 2 * kThreads)
      << "513²: " << small.peak << " bytes, 1025²: " << large.peak << " bytes";
}
