// The process-wide cache of large layer buffers (relief/terrain.hpp, kLayerCacheMinBytes).
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <mutex>
#include <vector>

#include "relief/terrain.hpp"

#if defined(__unix__)
#include <pthread.h>
#include <unistd.h>
#endif

namespace relief {

namespace {

struct Cache {
  std::mutex mutex;
  struct Entry {
    std::vector<float> buffer;
    std::uint64_t stamp = 0;  // order of arrival: the oldest leaves first
  };
  std::vector<Entry> entries;
  // Demand: per size asked for (floats), the credits left. Every request of a large buffer
  // (Terrain::layer, layer_for_overwrite, a Layer's copy) gives its size a credit (at most
  // kMaxCredits); a buffer enters the cache only by spending a credit of a size it serves. So the
  // cache holds no more buffers of a size than were asked for: a buffer nobody asks for again (a
  // world tile's cropped layers, say) is freed, and what a sequence of same-size runs keeps
  // between two runs is what one run asked for.
  struct Demand {
    std::size_t floats = 0;
    unsigned credits = 0;
    std::uint64_t stamp = 0;
  };
  static constexpr unsigned kMaxCredits = 16;
  static constexpr std::size_t kMaxSizes = 64;
  std::vector<Demand> demand;
  std::size_t bytes = 0;
  std::size_t hits = 0;
  std::size_t limit = 0;
  std::uint64_t next_stamp = 0;
  std::atomic<bool> poison{false};

  Cache() {
    std::size_t physical = 0;
#if defined(__unix__) && defined(_SC_PHYS_PAGES) && defined(_SC_PAGE_SIZE)
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
    if (pages > 0 && page > 0) physical = std::size_t(pages) * std::size_t(page);
#endif
    limit = std::max(std::size_t(256) << 20, physical / 8);
    if (const char* env = std::getenv("RELIEF_BUFFER_CACHE_MB")) {
      // Plain decimal digits only (strtoull alone would take "+5", " 5" and wrap "-1"); anything
      // else keeps the default and says so once (this runs inside allocations and destructors, where
      // a relief::Error cannot be thrown).
      bool digits = env[0] != '\0' && std::strlen(env) <= 15;
      for (const char* c = env; digits && *c; ++c) digits = *c >= '0' && *c <= '9';
      if (digits)
        limit = std::size_t(std::strtoull(env, nullptr, 10)) << 20;
      else
        std::fprintf(stderr, "relief: RELIEF_BUFFER_CACHE_MB: expected a whole number of MiB (0 turns the cache off), got '%s'; using %zu MiB\n",
                     env, limit >> 20);
    }
    // As detail::set_buffer_cache_poison(true) from the start: to run any test or command with
    // every recycled buffer holding NaN.
    if (const char* env = std::getenv("RELIEF_BUFFER_CACHE_POISON")) poison = env[0] == '1';
  }

  // Records a request of `want` floats.
  void note(std::size_t want) {
    ++next_stamp;
    for (Demand& d : demand)
      if (d.floats == want) {
        d.credits = std::min(d.credits + 1, kMaxCredits);
        d.stamp = next_stamp;
        return;
      }
    if (demand.size() >= kMaxSizes)
      demand.erase(std::min_element(demand.begin(), demand.end(),
                                    [](const Demand& a, const Demand& b) { return a.stamp < b.stamp; }));
    demand.push_back({want, 1, next_stamp});
  }
  // Spends a credit of the size nearest below `capacity` that it serves (capacity ≤ 1.5x size).
  bool spend(std::size_t capacity) {
    Demand* best = nullptr;
    for (Demand& d : demand)
      if (d.credits > 0 && d.floats <= capacity && capacity - d.floats <= d.floats / 2 &&
          (!best || d.floats > best->floats))
        best = &d;
    if (!best) return false;
    --best->credits;
    return true;
  }

  // Removes the oldest entries until `bytes` ≤ `cap`; the buffers are moved to `out` (freed by the
  // caller outside the lock).
  void evict_to(std::size_t cap, std::vector<std::vector<float>>& out) {
    while (bytes > cap && !entries.empty()) {
      auto oldest = std::min_element(entries.begin(), entries.end(),
                                     [](const Entry& a, const Entry& b) { return a.stamp < b.stamp; });
      bytes -= oldest->buffer.capacity() * sizeof(float);
      out.push_back(std::move(oldest->buffer));
      entries.erase(oldest);
    }
  }
};

// Never destroyed: layers in static storage may give their buffers back after main returns.
// fork() copies the cache's mutex as it is: had another thread of the parent held it at that
// moment (a layer freed or made on a TBB worker, a Python thread), the child's first large layer
// would wait for it forever (Python's multiprocessing forks by default on Linux). The handlers take
// the lock around the fork, so the child starts with it free.
Cache& cache();
void lock_for_fork() { cache().mutex.lock(); }
void unlock_after_fork() { cache().mutex.unlock(); }

Cache& cache() {
  static Cache* c = [] {
    Cache* made = new Cache();
#if defined(__unix__)
    pthread_atfork(lock_for_fork, unlock_after_fork, unlock_after_fork);  // run at a later fork(), when cache() is set
#endif
    return made;
  }();
  return *c;
}

}  // namespace

std::size_t release_cached_buffers() {
  Cache& c = cache();
  std::vector<Cache::Entry> gone;
  std::size_t bytes = 0;
  {
    std::lock_guard lock(c.mutex);
    gone.swap(c.entries);
    c.demand.clear();
    bytes = c.bytes;
    c.bytes = 0;
  }
  return bytes;  // `gone` frees the buffers here, outside the lock
}

void set_buffer_cache_limit(std::size_t bytes) {
  Cache& c = cache();
  std::vector<std::vector<float>> gone;
  std::lock_guard lock(c.mutex);
  c.limit = bytes;
  c.evict_to(bytes, gone);
}

std::size_t buffer_cache_limit() {
  Cache& c = cache();
  std::lock_guard lock(c.mutex);
  return c.limit;
}

std::size_t cached_buffer_bytes() {
  Cache& c = cache();
  std::lock_guard lock(c.mutex);
  return c.bytes;
}

std::size_t cached_buffer_count() {
  Cache& c = cache();
  std::lock_guard lock(c.mutex);
  return c.entries.size();
}

std::size_t cached_buffer_hits() {
  Cache& c = cache();
  std::lock_guard lock(c.mutex);
  return c.hits;
}

namespace detail {

void with_buffer_cache_locked(void (*f)()) {
  Cache& c = cache();
  std::lock_guard lock(c.mutex);
  f();
}

void cache_buffer(std::vector<float>&& buffer) noexcept {
  std::vector<float> b = std::move(buffer);  // `buffer` is left empty whatever happens
  const std::size_t size = b.capacity() * sizeof(float);
  if (size < kLayerCacheMinBytes) return;
  Cache& c = cache();
  if (c.poison.load(std::memory_order_relaxed)) {
    b.resize(b.capacity());  // within the capacity: no reallocation, cannot throw
    std::fill(b.begin(), b.end(), std::numeric_limits<float>::quiet_NaN());
  }
  std::vector<std::vector<float>> gone;  // freed after the lock is released
  try {
    std::lock_guard lock(c.mutex);
    if (size > c.limit) return;
    c.entries.reserve(c.entries.size() + 1);  // may throw: then `b` is simply freed
    gone.reserve(c.entries.size());
    if (!c.spend(b.capacity())) return;  // nobody asked for a buffer of this size
    c.evict_to(c.limit - size, gone);
    c.entries.push_back({std::move(b), c.next_stamp++});
    c.bytes += size;
  } catch (...) {
  }
}

bool take_cached_buffer(std::vector<float>& data, std::size_t want) {
  if (data.capacity() >= want || want * sizeof(float) < kLayerCacheMinBytes) return false;
  Cache& c = cache();
  std::vector<float> found;
  {
    std::lock_guard lock(c.mutex);
    try {
      c.note(want);
    } catch (...) {  // out of memory for the demand record: the buffer will be freed, not kept
    }
    auto best = c.entries.end();
    for (auto it = c.entries.begin(); it != c.entries.end(); ++it) {
      const std::size_t cap = it->buffer.capacity();
      if (cap >= want && cap - want <= want / 2 && (best == c.entries.end() || cap < best->buffer.capacity())) best = it;
    }
    if (best == c.entries.end()) {
      // A miss: the caller allocates a new buffer. A cached one a little too small for it (2/3 of
      // `want` or more: a run of a slightly larger size, say the next world tile's grown window)
      // is replaced by that one, not kept beside it: the oldest such leaves now.
      auto stale = c.entries.end();
      for (auto it = c.entries.begin(); it != c.entries.end(); ++it) {
        const std::size_t cap = it->buffer.capacity();
        if (cap < want && cap >= want - want / 3 && (stale == c.entries.end() || it->stamp < stale->stamp)) stale = it;
      }
      if (stale != c.entries.end()) {
        c.bytes -= stale->buffer.capacity() * sizeof(float);
        found.swap(stale->buffer);  // freed on return, outside the lock
        c.entries.erase(stale);
      }
      return false;
    }
    c.bytes -= best->buffer.capacity() * sizeof(float);
    ++c.hits;
    found.swap(best->buffer);
    c.entries.erase(best);
  }
  data.swap(found);
  cache_buffer(std::move(found));  // the old (smaller) buffer, if large enough to keep
  return true;
}

void note_buffer_request(std::size_t want) {
  if (want * sizeof(float) < kLayerCacheMinBytes) return;
  Cache& c = cache();
  std::lock_guard lock(c.mutex);
  try {
    c.note(want);
  } catch (...) {
  }
}

void set_buffer_cache_poison(bool on) { cache().poison.store(on, std::memory_order_relaxed); }

}  // namespace detail

}  // namespace relief
