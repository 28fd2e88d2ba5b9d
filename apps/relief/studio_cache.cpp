// The studio's stage cache: see studio_cache.hpp.
#include "studio_cache.hpp"

#include <chrono>
#include <cstring>
#include <string_view>

#include "relief/random.hpp"

namespace relief::cli {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

std::uint64_t fnv1a(std::string_view s, std::uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}
std::uint64_t hash_double(std::uint64_t h, double v) {
  std::uint64_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  return hash64(h, bits);
}

}  // namespace

std::vector<std::uint64_t> stage_keys(const Recipe& r, const Frame& f) {
  std::uint64_t h = hash64(0x52454c4945460001ull, *r.seed);
  for (double v : {f.world_width_m, f.world_depth_m, f.spacing_m, f.height_m, f.sea_level}) h = hash_double(h, v);
  h = hash64(h, std::uint64_t(f.nx), std::uint64_t(f.nz));
  h = hash64(h, std::uint64_t(f.ix0), std::uint64_t(f.iz0));
  std::vector<std::uint64_t> keys;
  for (std::size_t i = 0; i < r.stages.size(); ++i) {
    h = hash64(h, i, fnv1a(r.stages[i].def->name));
    h = hash64(h, fnv1a(r.stages[i].stage->params().dump()));
    keys.push_back(h);
  }
  return keys;
}

std::size_t terrain_bytes(const Terrain& t) {
  std::size_t b = sizeof(Terrain) + t.points.size() * sizeof(Point);
  for (auto& [name, l] : t.layers) b += name.size() + l.data.size() * sizeof(float);
  return b;
}

std::optional<Snapshot> StageCache::get(std::uint64_t key) {
  std::lock_guard lk(m_);
  auto it = map_.find(key);
  if (it == map_.end()) return std::nullopt;
  lru_.splice(lru_.begin(), lru_, it->second.pos);
  return it->second.snap;
}

void StageCache::put(std::uint64_t key, Snapshot s) {
  const std::size_t b = terrain_bytes(*s.terrain);
  if (b > capacity_ / 8) return;
  std::lock_guard lk(m_);
  if (auto it = map_.find(key); it != map_.end()) {
    lru_.splice(lru_.begin(), lru_, it->second.pos);
    return;
  }
  lru_.push_front(key);
  map_[key] = Entry{std::move(s), b, lru_.begin()};
  bytes_ += b;
  while (bytes_ > capacity_ && !lru_.empty()) {
    auto old = map_.find(lru_.back());
    bytes_ -= old->second.bytes;
    map_.erase(old);
    lru_.pop_back();
  }
}

CachedRun run_cached(StageCache& cache, const Recipe& r, const Frame& f, RunOptions opt, bool all_snapshots) {
  const auto t0 = Clock::now();
  const std::vector<std::uint64_t> keys = stage_keys(r, f);
  const int n = int(r.stages.size());
  CachedRun g;
  g.snaps.resize(std::size_t(n));
  int first = 0;
  if (all_snapshots) {
    while (first < n) {
      auto s = cache.get(keys[std::size_t(first)]);
      if (!s) break;
      g.snaps[std::size_t(first++)] = *s;
    }
  } else {
    for (int k = n - 1; k >= 0; --k)
      if (auto s = cache.get(keys[std::size_t(k)])) {
        g.snaps[std::size_t(k)] = *s;
        first = k + 1;
        break;
      }
  }
  opt.window = f;
  opt.after_stage_keeps_fusion = !all_snapshots;
  if (first > 0) opt.resume = Resume{g.snaps[std::size_t(first - 1)].terrain.get(), first};
  const bool keep = all_snapshots;
  std::vector<double> ms(std::size_t(n), 0.0);
  for (int i = 0; i < first; ++i) ms[std::size_t(i)] = g.snaps[std::size_t(i)].terrain ? g.snaps[std::size_t(i)].ms : 0.0;
  auto stage_t0 = Clock::now();
  opt.after_stage = [&](const Terrain& t, const RecipeStage&, int i) {
    ms[std::size_t(i)] = ms_since(stage_t0);
    if (i < n - 1) {  // the last stage's terrain is the run's result: moved, not copied, below
      Snapshot s{std::make_shared<const Terrain>(t), ms[std::size_t(i)]};
      cache.put(keys[std::size_t(i)], s);
      if (keep) g.snaps[std::size_t(i)] = std::move(s);
    }
    stage_t0 = Clock::now();
  };
  if (first < n || n == 0) {
    stage_t0 = Clock::now();
    RunResult res = run(r, opt);
    // A fused chain's time is on its first stage, 0 on the others (as in the CLI's report).
    for (std::size_t k = 0; k < res.timings.size() && first + int(k) < n; ++k) ms[std::size_t(first) + k] = res.timings[k].ms;
    Snapshot last{std::make_shared<const Terrain>(std::move(res.terrain)), n ? ms[std::size_t(n - 1)] : 0.0};
    if (n == 0) {
      g.snaps.push_back(std::move(last));
    } else {
      cache.put(keys[std::size_t(n - 1)], last);
      g.snaps[std::size_t(n - 1)] = std::move(last);
    }
  }
  g.terrain = g.snaps.back().terrain;
  for (int i = 0; i < n; ++i) {
    const RecipeStage& s = r.stages[std::size_t(i)];
    json e = {{"stage", s.def->name}, {"label", s.label.empty() ? s.def->name : s.label}, {"cached", i < first}};
    e["ms"] = ms[std::size_t(i)];
    g.timings.push_back(e);
  }
  if (n == 0) g.snaps.clear();
  g.first_stage = first;
  g.run_ms = ms_since(t0);
  return g;
}

}  // namespace relief::cli
