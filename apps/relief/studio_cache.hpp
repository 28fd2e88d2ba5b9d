#pragma once
// The studio's stage cache (mapgen4's caching: work is keyed by what it depends on).
// The terrain after stage k is stored under key_k = H(key_{k−1}, k, stage name, resolved params),
// key_{−1} = H(seed, frame). A request resumes the pipeline from the deepest cached key
// (RunOptions::resume), so moving a colour slider re-runs only the stages from the colour stage on,
// and moving nothing re-runs nothing. LRU, bounded in bytes. Snapshots are taken where a chain of
// fused row stages ends (RunOptions::after_stage_keeps_fusion), so a cached run keeps fusion: a
// change inside a chain re-runs the chain from its first stage. The stage strip (/api/steps) needs
// every stage's own output and runs unfused.
#include <cstddef>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <unordered_map>
#include <vector>

#include "relief/params.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "relief/terrain.hpp"

namespace relief::cli {

struct Snapshot {
  std::shared_ptr<const Terrain> terrain;
  double ms = 0;  // how long the stage took when it ran
};

// key_k for every stage of `r` on `f` (see the top of the file).
std::vector<std::uint64_t> stage_keys(const Recipe& r, const Frame& f);
// The bytes a terrain holds (layers and points), as the cache counts them.
std::size_t terrain_bytes(const Terrain& t);

// Thread-safe LRU of snapshots, at most `capacity` bytes.
class StageCache {
 public:
  explicit StageCache(std::size_t capacity) : capacity_(capacity) {}
  std::optional<Snapshot> get(std::uint64_t key);
  // Snapshots bigger than an eighth of the budget are not kept (large exports would flush the
  // previews that make dragging fast).
  void put(std::uint64_t key, Snapshot s);

 private:
  struct Entry {
    Snapshot snap;
    std::size_t bytes = 0;
    std::list<std::uint64_t>::iterator pos;
  };
  std::mutex m_;
  std::unordered_map<std::uint64_t, Entry> map_;
  std::list<std::uint64_t> lru_;
  std::size_t bytes_ = 0, capacity_;
};

// A run through the cache.
struct CachedRun {
  std::shared_ptr<const Terrain> terrain;
  std::vector<Snapshot> snaps;  // every stage's snapshot (only when asked for)
  json timings = json::array();  // per stage: {stage, label, cached, ms}
  double run_ms = 0;
  int first_stage = 0;  // stages before it came from the cache
};

// Runs `r` on frame `f` from the deepest cached stage and caches what it computes. `opt` gives
// the threads, cancellation and progress (its window, after_stage and resume are set here). With
// all_snapshots, every stage's snapshot is returned (from the cache or from this run) and the run
// is unfused; a missing early snapshot means running from 0. Throws what run() throws.
CachedRun run_cached(StageCache& cache, const Recipe& r, const Frame& f, RunOptions opt, bool all_snapshots);

}  // namespace relief::cli
