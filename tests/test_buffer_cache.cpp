// The process-wide cache of large layer buffers (relief/terrain.hpp, kLayerCacheMinBytes): a
// destroyed layer's buffer comes back to the next layer of that size, the cache keeps to its limit
// and empties on release, concurrent terrains never share a buffer, and no output depends on what a
// recycled buffer held (cached buffers poisoned with NaN give the bytes of a run without the cache).
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "relief/terrain.hpp"
#include "support.hpp"
#include "world_support.hpp"

using namespace relief;

namespace {

// 1025² floats: 4.2 MB, just above kLayerCacheMinBytes.
constexpr int kN = 1025;

Terrain sized(int n) {
  Terrain t;
  t.frame.nx = t.frame.nz = n;
  return t;
}

// Restores the cache's limit and poison mode and empties it, whatever a test did.
struct CacheScope {
  std::size_t limit = buffer_cache_limit();
  CacheScope() { release_cached_buffers(); }
  ~CacheScope() {
    detail::set_buffer_cache_poison(false);
    set_buffer_cache_limit(limit);
    release_cached_buffers();
  }
};

std::vector<unsigned char> bytes_of(const Terrain& t) {
  std::vector<unsigned char> out;
  for (const auto& [name, l] : t.layers) {
    out.insert(out.end(), name.begin(), name.end());
    const auto* p = reinterpret_cast<const unsigned char*>(l.data.data());
    out.insert(out.end(), p, p + l.data.size() * sizeof(float));
  }
  return out;
}

}  // namespace

TEST(BufferCache, DestroyedLayerBufferComesBack) {
  CacheScope scope;
  set_buffer_cache_limit(std::size_t(64) << 20);
  const float* address = nullptr;
  std::size_t capacity = 0;
  {
    Terrain t = sized(kN);
    Layer& l = t.layer_for_overwrite("shade");
    address = l.data.data();
    capacity = l.data.capacity();
    EXPECT_EQ(cached_buffer_count(), 0u);
  }
  EXPECT_EQ(cached_buffer_count(), 1u);
  EXPECT_EQ(cached_buffer_bytes(), capacity * sizeof(float));
  {
    Terrain t = sized(kN);
    Layer& l = t.layer_for_overwrite("other name");
    EXPECT_EQ(l.data.data(), address) << "the next layer of that size takes the cached buffer";
    EXPECT_EQ(l.data.capacity(), capacity);
    EXPECT_EQ(l.data.size(), std::size_t(kN) * kN);
    EXPECT_EQ(cached_buffer_count(), 0u);
    EXPECT_EQ(cached_buffer_bytes(), 0u);
  }
  // layer() zero-fills a recycled buffer (here one poisoned with NaN).
  detail::set_buffer_cache_poison(true);
  {
    Terrain t = sized(kN);
    std::fill(t.layer("h").data.begin(), t.layer("h").data.end(), 5.0f);
  }
  {
    Terrain t = sized(kN);
    const Layer& l = t.layer("h");
    EXPECT_EQ(l.data.data(), address);
    std::size_t nonzero = 0;
    for (float v : l.data) nonzero += v != 0.0f;
    EXPECT_EQ(nonzero, 0u);
  }
  // A layer replaced by assignment gives its buffer too; one re-created with more channels also.
  {
    Terrain t = sized(kN);
    t.layer("a");
    t.layers["a"] = Layer{1, std::vector<float>(10)};
    EXPECT_EQ(cached_buffer_count(), 1u);
    Layer& c = t.layer("a", 3);  // 3x the size: a new buffer; the 10-float one is too small to keep
    EXPECT_EQ(c.data.size(), std::size_t(3) * kN * kN);
    EXPECT_EQ(cached_buffer_count(), 1u);
    Layer& b = t.layer("b");  // takes the cached 1-channel buffer
    EXPECT_EQ(b.data.data(), address);
    EXPECT_EQ(cached_buffer_count(), 0u);
  }
}

TEST(BufferCache, OnlyLargeBuffersAndCloseSizes) {
  CacheScope scope;
  set_buffer_cache_limit(std::size_t(256) << 20);
  { Terrain t = sized(513); t.layer("small"); }  // 1 MB: below kLayerCacheMinBytes, freed
  EXPECT_EQ(cached_buffer_count(), 0u);
  { Terrain t = sized(2049); t.layer("big"); }  // 16.8 MB
  EXPECT_EQ(cached_buffer_count(), 1u);
  {
    // A 4.2 MB layer does not take a 16.8 MB buffer (more than 1.5x its size): that memory would
    // stay touched and unused.
    Terrain t = sized(kN);
    t.layer("h");
    EXPECT_EQ(cached_buffer_count(), 1u);
    EXPECT_LT(t.get("h").data.capacity(), std::size_t(2) * kN * kN);
  }
  EXPECT_EQ(cached_buffer_count(), 2u);
  {
    // A layer a little smaller than a cached buffer takes it (a clipped edge tile, say).
    Terrain t = sized(1800);
    EXPECT_GE(t.layer("h").data.capacity(), std::size_t(2049) * 2049);
    EXPECT_EQ(cached_buffer_count(), 1u);
  }
}

// The cache keeps no more buffers of a size than were asked for: one a layer() never asked for
// (here a vector made elsewhere and moved into a layer, as a world tile's cropped layers) is freed.
TEST(BufferCache, KeepsOnlyWhatWasAskedFor) {
  CacheScope scope;
  set_buffer_cache_limit(std::size_t(256) << 20);
  const std::size_t n = std::size_t(kN) * kN;
  { Terrain t = sized(kN); t.layers["made"] = Layer{1, std::vector<float>(n)}; }
  EXPECT_EQ(cached_buffer_count(), 0u) << "nobody asked for a buffer of this size";
  {
    Terrain t = sized(kN);
    t.layer("asked");  // one request of this size: one buffer may come in
    t.layers["made"] = Layer{1, std::vector<float>(n)};
    t.layers["made too"] = Layer{1, std::vector<float>(n)};
  }
  EXPECT_EQ(cached_buffer_count(), 1u);
  {
    Terrain t = sized(kN);
    t.layer("a");  // a hit, and a request: its buffer may come back
    t.layer("b");  // a miss, and a request
  }
  EXPECT_EQ(cached_buffer_count(), 2u);
  // release forgets the demand.
  release_cached_buffers();
  { Terrain t = sized(kN); t.layers["made"] = Layer{1, std::vector<float>(n)}; }
  EXPECT_EQ(cached_buffer_count(), 0u);
}

// A run of a slightly larger size (the next world tile's grown window) misses; the cached buffer a
// little too small for it is freed then, not kept beside the new one.
TEST(BufferCache, AMissReplacesABufferALittleTooSmall) {
  CacheScope scope;
  set_buffer_cache_limit(std::size_t(256) << 20);
  { Terrain t = sized(kN); t.layer("h"); }
  EXPECT_EQ(cached_buffer_count(), 1u);
  {
    Terrain t = sized(kN + 4);
    t.layer("h");
    EXPECT_EQ(cached_buffer_count(), 0u) << "the smaller buffer left on the miss";
  }
  EXPECT_EQ(cached_buffer_count(), 1u);
  // One much smaller (below 2/3 of the request) stays: it serves other layers.
  {
    Terrain t = sized(kN);
    t.layer("c", 3);
    EXPECT_EQ(cached_buffer_count(), 1u);
  }
  EXPECT_EQ(cached_buffer_count(), 2u);
}

TEST(BufferCache, HonoursTheLimitOldestFirstAndReleases) {
  CacheScope scope;
  const std::size_t one = std::size_t(kN) * kN * sizeof(float);
  set_buffer_cache_limit(one * 5 / 2);  // room for two
  std::vector<const float*> order;
  {
    std::vector<Terrain> ts;
    ts.reserve(4);
    for (int k = 0; k < 4; ++k) {
      ts.push_back(sized(kN));
      order.push_back(ts.back().layer("h").data.data());
    }
    for (auto& t : ts) t = Terrain();  // destroyed in order 0, 1, 2, 3
  }
  EXPECT_EQ(cached_buffer_count(), 2u);
  EXPECT_LE(cached_buffer_bytes(), buffer_cache_limit());
  // The two newest (2 and 3) stayed.
  {
    Terrain a = sized(kN), b = sized(kN);
    const float* pa = a.layer("h").data.data();
    const float* pb = b.layer("h").data.data();
    EXPECT_TRUE((pa == order[2] && pb == order[3]) || (pa == order[3] && pb == order[2]));
    EXPECT_EQ(cached_buffer_count(), 0u);
  }
  EXPECT_EQ(cached_buffer_count(), 2u);
  // A buffer larger than the limit is not kept.
  { Terrain t = sized(2049); t.layer("big"); }
  EXPECT_EQ(cached_buffer_count(), 2u);
  // Lowering the limit evicts at once; release empties and reports the bytes.
  set_buffer_cache_limit(one * 3 / 2);
  EXPECT_EQ(cached_buffer_count(), 1u);
  EXPECT_EQ(release_cached_buffers(), one);
  EXPECT_EQ(cached_buffer_count(), 0u);
  EXPECT_EQ(cached_buffer_bytes(), 0u);
  EXPECT_EQ(release_cached_buffers(), 0u);
  // Limit 0: no caching at all.
  set_buffer_cache_limit(0);
  { Terrain t = sized(kN); t.layer("h"); }
  EXPECT_EQ(cached_buffer_count(), 0u);
}

TEST(BufferCache, ConcurrentTerrainsNeverShareABuffer) {
  CacheScope scope;
  const std::size_t one = std::size_t(kN) * kN * sizeof(float);
  set_buffer_cache_limit(one * 6);
  std::atomic<int> wrong{0};
  tbb::parallel_for(0, 96, [&](int k) {
    Terrain t = sized(kN);
    Layer& a = k % 2 ? t.layer("a") : t.layer_for_overwrite("a");
    std::fill(a.data.begin(), a.data.end(), float(k));
    Terrain copy = t;  // a copy takes a cached buffer too
    for (std::size_t i = 0; i < a.data.size(); i += 4097)
      if (a.data[i] != float(k) || copy.get("a").data[i] != float(k)) ++wrong;
    t.layers.erase("a");
    if (copy.get("a").data.back() != float(k)) ++wrong;
  });
  EXPECT_EQ(wrong.load(), 0);
  EXPECT_LE(cached_buffer_bytes(), buffer_cache_limit());
  EXPECT_GT(cached_buffer_count(), 0u);
}

// A recycled buffer's stale contents never reach an output: presets run with every cached buffer
// NaN-poisoned (the cache warmed by an earlier run, also through RunOptions::recycle) give the
// bytes of runs with the cache off, at 1 and 2 threads.
TEST(BufferCache, PoisonedRecycledBuffersChangeNoByte) {
  CacheScope scope;
  for (const char* name : {"island", "hills", "desert", "terraced-valley"}) {
    const Recipe r = test::preset_recipe(name, kN, 7);
    set_buffer_cache_limit(0);
    RunOptions o;
    o.threads = 2;
    const std::vector<unsigned char> plain = bytes_of(run(r, o).terrain);
    set_buffer_cache_limit(std::size_t(1) << 30);
    detail::set_buffer_cache_poison(true);
    for (int threads : {1, 2}) {
      o.threads = threads;
      { RunResult warm = run(r, o); }  // its layers' buffers go to the cache, poisoned
      const std::size_t cached = cached_buffer_count();
      ASSERT_GT(cached, 0u) << name;
      RunResult again = run(r, o);
      EXPECT_LT(cached_buffer_count(), cached) << name << ": the run took cached buffers";
      EXPECT_TRUE(bytes_of(again.terrain) == plain) << name << " threads " << threads;
      RunOptions rec = o;
      rec.recycle = &again.terrain;
      EXPECT_TRUE(bytes_of(run(r, rec).terrain) == plain) << name << " recycled, threads " << threads;
    }
    detail::set_buffer_cache_poison(false);
    release_cached_buffers();
  }
}

// The same for a `slope` stage (no preset has one; it writes its layers through
// layer_for_overwrite, as hillshade does, so a sample it skipped would keep the poison) and for a
// world build, whose tiles after the first take the buffers the earlier tiles (or an earlier run in
// the process) dropped: the store's files are those of a build with the cache off.
TEST(BufferCache, PoisonedBuffersChangeNoByteOfASlopeStageOrAWorldStore) {
  CacheScope scope;
  json doc = load_preset("hills");
  doc["stages"].push_back({{"stage", "slope"}});
  doc["world"]["size"] = kN;
  doc["seed"] = 3;
  const Recipe r = parse_recipe(doc);
  RunOptions o;
  o.threads = 2;
  set_buffer_cache_limit(0);
  const std::vector<unsigned char> plain = bytes_of(run(r, o).terrain);
  test::TempDir d("cache-world");
  build_world(test::world::settings(r, 2 * kN - 1, kN, kN, d / "off"));
  set_buffer_cache_limit(std::size_t(1) << 30);
  detail::set_buffer_cache_poison(true);
  { RunResult warm = run(r, o); }
  ASSERT_GT(cached_buffer_count(), 0u);
  const RunResult again = run(r, o);
  ASSERT_TRUE(again.terrain.has("slope"));
  EXPECT_TRUE(bytes_of(again.terrain) == plain);
  { RunResult warm = run(r, o); }
  const std::size_t hits = cached_buffer_hits();
  build_world(test::world::settings(r, 2 * kN - 1, kN, kN, d / "poisoned"));
  EXPECT_GE(cached_buffer_hits(), hits + 4) << "the world build took few cached buffers: " << cached_buffer_hits() - hits;
  test::world::expect_same_store(d.path / "off", d.path / "poisoned");
}

// fork() while another thread holds the cache's lock: the child's cache works (without the fork
// handlers the child inherits the lock held and its first large layer waits forever).
TEST(BufferCache, AForkWhileAnotherThreadHoldsTheCacheLeavesTheChildsCacheUsable) {
  CacheScope scope;
  set_buffer_cache_limit(std::size_t(64) << 20);
  std::atomic<bool> holding{false};
  static std::atomic<bool>* flag;
  flag = &holding;
  std::thread holder([] { detail::with_buffer_cache_locked([] {
    flag->store(true);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }); });
  while (!holding.load()) std::this_thread::yield();
  const pid_t pid = ::fork();
  if (pid == 0) {  // the child: one large layer made and dropped (the cache's lock, twice)
    { Terrain t = sized(kN); t.layer("h", 1); }
    ::_exit(0);
  }
  ASSERT_GT(pid, 0);
  holder.join();
  int status = -1;
  pid_t done = 0;
  for (int k = 0; k < 500 && done == 0; ++k) {  // up to 10 s
    done = ::waitpid(pid, &status, WNOHANG);
    if (done == 0) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (done == 0) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    FAIL() << "the child's cache stayed locked";
  }
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
}

// A layer assigned to itself (copy or move) keeps its samples and its buffer.
TEST(BufferCache, ALayerAssignedToItselfKeepsItsSamples) {
  CacheScope scope;
  set_buffer_cache_limit(std::size_t(64) << 20);
  Terrain t = sized(kN);
  Layer& l = t.layer("h", 1);
  for (std::size_t k = 0; k < l.data.size(); ++k) l.data[k] = float(k % 977);
  const float* address = l.data.data();
  Layer& alias = l;
  l = alias;
  ASSERT_EQ(l.data.size(), std::size_t(kN) * kN);
  EXPECT_EQ(l.data.data(), address);
  l = std::move(alias);
  ASSERT_EQ(l.data.size(), std::size_t(kN) * kN);
  EXPECT_EQ(l.data.data(), address);
  bool same = true;
  for (std::size_t k = 0; k < l.data.size(); ++k) same = same && l.data[k] == float(k % 977);
  EXPECT_TRUE(same);
  EXPECT_EQ(cached_buffer_count(), 0u);
}

// RELIEF_BUFFER_CACHE_MB takes plain decimal digits only: anything else keeps the default and says
// so on stderr, naming the variable (strtoull alone took "+64" and " 64" and wrapped "-1").
TEST(BufferCache, AMalformedLimitInTheEnvironmentIsNamedAndIgnored) {
  test::TempDir d("cache-env");
  for (const std::string v : {"abc", "+64", "-1", "64M", "1e3"}) {
    const auto r = test::sh("RELIEF_BUFFER_CACHE_MB='" + v + "' " + std::string(RELIEF_BINARY) + " generate island --size 1025 -f heightmap -q -o " +
                            (d / "o"));
    EXPECT_EQ(r.code, 0) << v << "\n" << r.out;
    EXPECT_NE(r.out.find("RELIEF_BUFFER_CACHE_MB: expected a whole number of MiB"), std::string::npos) << v << "\n" << r.out;
  }
  const auto ok = test::sh("RELIEF_BUFFER_CACHE_MB=64 " + std::string(RELIEF_BINARY) + " generate island --size 1025 -f heightmap -q -o " + (d / "o"));
  EXPECT_EQ(ok.code, 0) << ok.out;
  EXPECT_EQ(ok.out.find("RELIEF_BUFFER_CACHE_MB"), std::string::npos) << ok.out;
}
