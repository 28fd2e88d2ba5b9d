// Grid hydrology: Priority-Flood+ε depression filling, flow order and accumulation (D8 receivers
// are in hydrology_d8.cpp).
//
// Sources:
//   * R. Barnes, C. Lehman, D. Mulla, "Priority-Flood: An optimal depression-filling and
//     watershed-labeling algorithm for digital elevation models", Computers & Geosciences 62,
//     2014 — Algorithm 3 (Priority-Flood+ε) and its plain FIFO "pit" queue for cells inside
//     depressions.
//   * G. Zhou, Z. Sun, S. Fu, "An efficient variant of the Priority-Flood algorithm for filling
//     depressions in raster digital elevation models", Computers & Geosciences 90, 2016 — cells
//     reached uphill of the flood front keep their elevation and are traversed at once; only cells
//     bordering lower unvisited cells enter the priority queue.
//   * H. Wei, G. Zhou, S. Fu, "Efficient Priority-Flood depression filling in raster digital
//     elevation models", International Journal of Digital Earth 12(4), 2019 (online 2018) — a cell
//     met on the slope traversal enters the priority queue only when one of its lower unvisited
//     neighbours has no lower visited neighbour of its own (no "spill path"); otherwise that
//     neighbour is reached earlier through the lower cell and the queue entry would be wasted.
//   * R. K. Ahuja, K. Mehlhorn, J. Orlin, R. Tarjan, "Faster algorithms for the shortest path
//     problem", J. ACM 37(2), 1990 — the radix heap: Priority-Flood pops non-decreasing levels, so
//     a monotone integer queue keyed on the order-preserving bits of the float replaces the binary
//     heap.
//   * A. B. Kahn, "Topological sorting of large networks", CACM 5(11), 1962.
#include "relief/hydrology.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>


namespace relief::hydro {
namespace {

// Order-preserving unsigned key of a floating-point value (IEEE 754: flip all bits of negatives,
// set the sign bit of positives), so that integer order equals numeric order.
inline std::uint32_t order_key(float v) {
  std::uint32_t u;
  std::memcpy(&u, &v, sizeof u);
  return (u >> 31) ? ~u : (u | 0x80000000u);
}
inline std::uint64_t order_key(double v) {
  std::uint64_t u;
  std::memcpy(&u, &v, sizeof u);
  return (u >> 63) ? ~u : (u | 0x8000000000000000ull);
}

inline float from_key(std::uint32_t k) {
  const std::uint32_t u = (k >> 31) ? (k & 0x7FFFFFFFu) : ~k;
  float v;
  std::memcpy(&v, &u, sizeof v);
  return v;
}
inline double from_key(std::uint64_t k) {
  const std::uint64_t u = (k >> 63) ? (k & 0x7FFFFFFFFFFFFFFFull) : ~k;
  double v;
  std::memcpy(&v, &u, sizeof v);
  return v;
}

// Monotone radix heap: push keys ≥ the last popped key; pop returns a smallest key. Bucket b
// holds keys whose highest bit differing from `last` is bit b − 1; bucket 0 holds keys equal to
// `last` (popped last-in first-out, which is deterministic because the caller is sequential).
template <class K>
class RadixHeap {
 public:
  static constexpr int kBuckets = int(sizeof(K) * 8) + 1;
  struct Entry {
    K key;
    std::uint32_t value;
  };
  bool empty() const { return size_ == 0; }
  void push(K key, std::uint32_t value) {
    const int b = bucket(key);
    buckets_[b].push_back({key, value});
    ++size_;
    if (b != 0 && b <= hint_bucket_) {  // keep the hint the smallest entry of the lowest bucket
      if (b < hint_bucket_) hint_bucket_ = 0;
      else if (key < hint_.key) hint_ = {key, value};
    }
  }
  // The entry that pop() will return next unless a smaller key is pushed first (nullptr when
  // empty): for prefetching. When bucket 0 is empty it finds the smallest entry of the lowest
  // non-empty bucket, which push() keeps up to date and the next pop() reuses instead of scanning.
  const Entry* peek() {
    if (!buckets_[0].empty()) return &buckets_[0].back();
    if (size_ == 0) return nullptr;
    if (hint_bucket_ == 0) {
      int b = 1;
      while (buckets_[b].empty()) ++b;
      const std::vector<Entry>& v = buckets_[b];
      std::size_t at = 0;
      for (std::size_t x = 1; x < v.size(); ++x) at = v[x].key < v[at].key ? x : at;
      hint_bucket_ = b;
      hint_ = v[at];
    }
    return &hint_;
  }
  Entry pop() {
    if (buckets_[0].empty()) {
      int b = hint_bucket_;
      K lo = hint_.key;
      if (b == 0) {
        b = 1;
        while (buckets_[b].empty()) ++b;
        lo = buckets_[b][0].key;
        for (const Entry& e : buckets_[b]) lo = e.key < lo ? e.key : lo;
      }
      last_ = lo;
      hint_bucket_ = 0;
      for (const Entry& e : buckets_[b]) buckets_[bucket(e.key)].push_back(e);
      buckets_[b].clear();
    }
    const Entry e = buckets_[0].back();
    buckets_[0].pop_back();
    --size_;
    return e;
  }

 private:
  int bucket(K key) const {
    const K x = key ^ last_;
    if (x == 0) return 0;
    if constexpr (sizeof(K) == 4) return 32 - __builtin_clz(x);
    else return 64 - __builtin_clzll(x);
  }
  std::vector<Entry> buckets_[kBuckets];
  K last_ = 0;
  std::size_t size_ = 0;
  int hint_bucket_ = 0;  // 0: no hint
  Entry hint_{};
};

// The flood behind fill_depressions and fill_depressions_tile: the least fixpoint of
//     F(c) = z(c) for outlets,   F(c) = min over the 8 neighbours n of g(F(n), z(c)) otherwise,
//     g(L, z) = z when z > L (c drains downhill from n: unchanged), else step(L),
//     step(L) = max(L + ε, the next value above L),
// computed in Dijkstra's order (Knuth 1977: g never decreases in L and g(L, z) > L, so popping
// levels in non-decreasing order finds the least solution, and that solution does not depend on the
// order in which equal levels are popped — which is what lets tiles reproduce it).
//
// The caller sets up `closed` (true for outlets, which keep z, and for cells that are not part of
// the grid: a padding ring) and pushes every outlet that borders an open cell onto `open` with its
// own level. Non-outlet cells are interior (all 8 neighbours exist in the buffer): the map's border
// is made of outlets, a tile's buffer has a closed ring. kSeeded: `seed` holds, per cell, a level
// some path outside the buffer gives it (+inf for none), and every finite seed is on `open` too.
//
// Three sources of levels, merged so that levels are settled in non-decreasing order:
//   * the radix heap `open` (outlets, seeds, and cells whose lower neighbours are still open);
//   * the pit FIFO: cells raised to step(l) by a cell settled at level l. Levels are settled in
//     non-decreasing order and step is monotone, so the FIFO is sorted; each pop takes the lower
//     of its head and the heap's top;
//   * Zhou's slope traversal: a cell reached from level l with z > l is final at z at once (g never
//     gives less than z), and so, transitively, is every cell uphill of it.
// A cell's first raise offer is its least (offers come from settled levels, in order), so it is
// closed when first reached — except a seeded cell whose seed is no higher than the offer: it stays
// open and settles when its seed pops.
template <class T, bool kSeeded>
void flood(T* z, int nx, int nz, bool* closed, RadixHeap<decltype(order_key(T()))>& open, const T* seed, T epsilon) {
  using K = decltype(order_key(T()));
  const std::size_t n = std::size_t(nx) * std::size_t(nz);
  std::vector<std::uint32_t> trail, candidates;
  std::size_t pit_head = 0;
  // The heap's smallest key, kept here so that the pit FIFO's pops compare with a register.
  constexpr K kNone = ~K(0);
  K heap_min = kNone;
  if (const auto* t = open.peek()) heap_min = t->key;
  std::ptrdiff_t off[8];
  for (int k = 0; k < 8; ++k) off[k] = std::ptrdiff_t(kDj[k]) * nx + kDi[k];

  // Zhou's slope traversal from a freshly reached cell m whose level is final (z[m] unchanged):
  // cells uphill of it are final too. A cell q that borders a lower or equal open cell is a
  // candidate for the queue (Zhou pushes them all, at level z[q], so that their raise offers are
  // made in order); after the traversal, when more cells are closed, q is pushed only if some open
  // neighbour r has no closed neighbour below z[q] (Wei's test). Skipping the others changes no
  // level: a closed cell s with z[s] < z[q] settles before level z[q] (it is on the heap, in the
  // pit FIFO, or it is itself a skipped candidate with such a cell below it), and its offer to r,
  // at most step(z[s]) or z[r], is no higher than q's, step(z[q]); so q's entry would find nothing
  // left to improve. (At 4096², 71% of the cells of the mountains preset are candidates and 87% of
  // those are dropped; on the bench's island 95% and 97%.)
  // Whether the 8 neighbours of interior cell q are closed: three 4-byte loads of the rows (the
  // fourth byte of the last row's load may be the first spare entry after the grid).
  auto all_neighbours_closed = [&](std::size_t q) {
    std::uint32_t up, mid, down;
    std::memcpy(&up, closed + q - nx - 1, 4);
    std::memcpy(&mid, closed + q - 1, 4);
    std::memcpy(&down, closed + q + nx - 1, 4);
    return ((up & down & 0x010101u) & (mid | 0x000100u)) == 0x010101u;
  };
  auto traverse = [&](std::uint32_t m) {
    trail.push_back(m);
    while (!trail.empty()) {
      const std::uint32_t q = trail.back();
      trail.pop_back();
      const T zq = z[q];
      bool boundary = false;
      for (int k = 0; k < 8; ++k) {
        const std::size_t r = std::size_t(std::ptrdiff_t(q) + off[k]);
        if (closed[r]) continue;
        if (z[r] > zq) {
          closed[r] = true;
          trail.push_back(std::uint32_t(r));
        } else {
          boundary = true;
        }
      }
      if (boundary) candidates.push_back(q);
    }
    for (const std::uint32_t q : candidates) {
      if (all_neighbours_closed(q)) continue;  // the common case, three loads
      const T zq = z[q];
      bool needed = false;
      for (int k = 0; k < 8 && !needed; ++k) {
        const std::size_t r = std::size_t(std::ptrdiff_t(q) + off[k]);
        if (closed[r]) continue;  // open, so z[r] <= zq and r is interior
        bool spill = false;
        for (int k2 = 0; k2 < 8 && !spill; ++k2) {
          const std::size_t s = std::size_t(std::ptrdiff_t(r) + off[k2]);
          spill = closed[s] && z[s] < zq;
        }
        needed = !spill;
      }
      if (needed) {
        const K key = order_key(zq);
        open.push(key, q);
        heap_min = key < heap_min ? key : heap_min;
      }
    }
    candidates.clear();
  };

  // Pit FIFO entries carry their level, so that popping does not reload it.
  struct PitEntry {
    T level;
    std::uint32_t cell;
  };
  std::vector<PitEntry> pits;
  for (;;) {
    std::uint32_t c;
    T lc;
    bool interior = true;  // cells from the pit FIFO are not outlets: interior
    int i = 0, j = 0;
    if (pit_head < pits.size() && order_key(pits[pit_head].level) <= heap_min) {
      c = pits[pit_head].cell;
      lc = pits[pit_head].level;
      ++pit_head;
      if (pit_head == pits.size()) pits.clear(), pit_head = 0;
    } else {
      if (heap_min == kNone && open.empty()) break;
      const auto e = open.pop();
      const auto* next_top = open.peek();
      heap_min = next_top ? next_top->key : kNone;
      c = e.value;
      lc = from_key(e.key);
      if constexpr (kSeeded) {
        if (!closed[c]) {  // a seed settles: its level is final
          closed[c] = true;
          z[c] = lc;
        } else if (e.key != order_key(z[c])) {
          continue;  // a seed whose cell settled lower
        }
      }
      i = int(c % std::uint32_t(nx));
      j = int(c / std::uint32_t(nx));
      interior = !on_border(i, j, nx, nz);
      if (next_top) {  // its rows will be needed soon
        const std::size_t q = next_top->value;
        __builtin_prefetch(z + q - (q >= std::size_t(nx) ? nx : 0));
        __builtin_prefetch(z + q + (q + nx < n ? nx : 0));
        __builtin_prefetch(closed + q - (q >= std::size_t(nx) ? nx : 0));
        __builtin_prefetch(closed + q + (q + nx < n ? nx : 0));
      }
    }
    // step(lc) = max(lc + ε, the next value above lc).
    T next = from_key(K(order_key(lc) + 1));
    if (!(next > lc)) next = from_key(K(order_key(lc) + 2));  // −0 → +0 is not a step
    if (lc + epsilon > next) next = lc + epsilon;
    for (int k = 0; k < 8; ++k) {
      std::size_t m;
      if (interior) {
        m = std::size_t(std::ptrdiff_t(c) + off[k]);
      } else {
        const int a = i + kDi[k], b = j + kDj[k];
        if (a < 0 || b < 0 || a >= nx || b >= nz) continue;
        m = std::size_t(b) * nx + a;
      }
      if (closed[m]) continue;
      if (z[m] > lc) {  // drains downhill to c: final as it is, and so is everything uphill of it
        closed[m] = true;
        traverse(std::uint32_t(m));
      } else {  // inside a depression (or a flat): raised just above the cell it drains to
        if constexpr (kSeeded) {
          if (!(next < seed[m])) continue;  // its seed is as low: it settles when the seed pops
        }
        closed[m] = true;
        z[m] = next;
        pits.push_back({next, std::uint32_t(m)});
      }
    }
  }
}

}  // namespace

template <class T>
void fill_depressions(T* z, int nx, int nz, T sea, T epsilon) {
  const std::size_t n = std::size_t(nx) * std::size_t(nz);
  if (n == 0) return;
  using K = decltype(order_key(T()));
  // bool, not a byte type: stores to it cannot alias the other state, which stays in registers.
  // Three spare entries after the grid for all_neighbours_closed's 4-byte loads.
  const std::unique_ptr<bool[]> closed_cells(new bool[n + 3]);  // every entry is set below
  bool* const closed = closed_cells.get();
  closed[n] = closed[n + 1] = closed[n + 2] = true;
  RadixHeap<K> open;

  // Outlets (the border, and cells below the sea) are closed from the start; those bordering
  // other cells seed the flood.
  for (int j = 0; j < nz; ++j) {
    bool* row = closed + std::size_t(j) * nx;
    if (j == 0 || j == nz - 1) {
      std::memset(row, 1, std::size_t(nx));
      continue;
    }
    const T* zj = z + std::size_t(j) * nx;
    for (int i = 0; i < nx; ++i) row[i] = zj[i] < sea;
    row[0] = row[nx - 1] = 1;
  }
  for (int j = 0; j < nz; ++j) {
    const bool edge_row = j == 0 || j == nz - 1;
    for (int i = 0; i < nx; ++i) {
      const std::size_t c = std::size_t(j) * nx + i;
      if (!closed[c]) continue;
      bool borders_land = false;
      if (!edge_row && i > 0 && i + 1 < nx) {
        for (int k = 0; k < 8; ++k) borders_land |= !closed[std::size_t(std::ptrdiff_t(c) + std::ptrdiff_t(kDj[k]) * nx + kDi[k])];
      } else {
        for (int k = 0; k < 8 && !borders_land; ++k) {
          const int a = i + kDi[k], b = j + kDj[k];
          if (a >= 0 && b >= 0 && a < nx && b < nz) borders_land = !closed[std::size_t(b) * nx + a];
        }
      }
      if (borders_land) open.push(order_key(z[c]), std::uint32_t(c));
    }
  }
  flood<T, false>(z, nx, nz, closed, open, nullptr, epsilon);
}

template <class T>
void fill_depressions_tile(T* z, int nx, int nz, const std::uint8_t* outlet, const T* seed, T epsilon) {
  if (nx < 1 || nz < 1) return;
  using K = decltype(order_key(T()));
  // The tile in a buffer with a closed ring, so that every cell of the tile is interior.
  const int px = nx + 2, pz = nz + 2;
  const std::size_t pn = std::size_t(px) * std::size_t(pz);
  const T inf = std::numeric_limits<T>::infinity();
  std::vector<T> pzv(pn, inf), pseed(pn, inf);
  const std::unique_ptr<bool[]> closed_cells(new bool[pn + 3]);
  bool* const closed = closed_cells.get();
  std::fill(closed, closed + pn + 3, true);
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      const std::size_t c = std::size_t(j) * std::size_t(nx) + std::size_t(i);
      const std::size_t p = std::size_t(j + 1) * std::size_t(px) + std::size_t(i + 1);
      pzv[p] = z[c];
      closed[p] = outlet[c] != 0;
      if (!outlet[c] && seed[c] < inf) pseed[p] = seed[c] < z[c] ? z[c] : seed[c];  // a level is never below the ground
    }
  RadixHeap<K> open;
  for (int j = 1; j <= nz; ++j)
    for (int i = 1; i <= nx; ++i) {
      const std::size_t p = std::size_t(j) * std::size_t(px) + std::size_t(i);
      if (!closed[p]) {
        if (pseed[p] < inf) open.push(order_key(pseed[p]), std::uint32_t(p));
        continue;
      }
      bool borders_land = false;
      for (int k = 0; k < 8; ++k) borders_land |= !closed[std::size_t(std::ptrdiff_t(p) + std::ptrdiff_t(kDj[k]) * px + kDi[k])];
      if (borders_land) open.push(order_key(pzv[p]), std::uint32_t(p));
    }
  flood<T, true>(pzv.data(), px, pz, closed, open, pseed.data(), epsilon);
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      const std::size_t p = std::size_t(j + 1) * std::size_t(px) + std::size_t(i + 1);
      z[std::size_t(j) * std::size_t(nx) + std::size_t(i)] = closed[p] ? pzv[p] : inf;
    }
}

template <class T>
bool already_drains(const T* z, int nx, int nz, T sea) {
  // z is the fill's least fixpoint when every non-outlet cell has a strictly lower neighbour n:
  // g(z(n), z(c)) = z(c) then, and no level is ever below the ground, so the least solution is z.
  // One minimum over the 3×3 block per cell.
  if (nx < 3 || nz < 3) return true;  // every cell is on the border: an outlet
  std::atomic<bool> ok{true};
  tbb::parallel_for(tbb::blocked_range<int>(1, nz - 1, 16), [&](const tbb::blocked_range<int>& rows) {
    std::vector<T> low(static_cast<std::size_t>(nx));
    for (int j = rows.begin(); j < rows.end() && ok.load(std::memory_order_relaxed); ++j) {
      const T* up = z + std::size_t(j - 1) * nx;
      const T* row = z + std::size_t(j) * nx;
      const T* down = z + std::size_t(j + 1) * nx;
      for (int i = 0; i < nx; ++i) {  // column minimum of the rows above and below, and this row
        const T a = up[i] < down[i] ? up[i] : down[i];
        low[std::size_t(i)] = a;
      }
      bool row_ok = true;
      for (int i = 1; i + 1 < nx; ++i) {
        T m = low[std::size_t(i - 1)] < low[std::size_t(i)] ? low[std::size_t(i - 1)] : low[std::size_t(i)];
        m = m < low[std::size_t(i + 1)] ? m : low[std::size_t(i + 1)];
        m = m < row[i - 1] ? m : row[i - 1];
        m = m < row[i + 1] ? m : row[i + 1];
        const T zc = row[i];
        row_ok &= zc < sea || m < zc;
      }
      if (!row_ok) ok.store(false, std::memory_order_relaxed);
    }
  });
  return ok.load();
}

void flow_order(const std::uint32_t* rec, std::size_t n, std::vector<std::uint32_t>& order, std::uint32_t* count) {
  // Donor counts (at most 8 in D8; 0xFF marks a cell already placed in the order).
  std::vector<std::uint8_t> donors(n, 0);
  for (std::size_t c = 0; c < n; ++c)
    if (rec[c] != c) ++donors[rec[c]];
  if (count)
    for (std::size_t c = 0; c < n; ++c) count[c] = 1;
  order.resize(n);
  std::size_t w = 0;
  for (std::size_t c = 0; c < n; ++c) {
    if (donors[c] != 0) continue;
    // A source: follow the chain downstream while each next cell has received all its donors.
    std::uint32_t x = std::uint32_t(c);
    for (;;) {
      donors[x] = 0xFF;
      order[w++] = x;
      const std::uint32_t r = rec[x];
      if (r == x) break;
      if (count) count[r] += count[x];
      if (--donors[r] != 0) break;
      x = r;
    }
  }
  order.resize(w);  // == n for an acyclic graph
}

template <class T>
std::size_t count_pits(const T* z, int nx, int nz, T sea) {
  std::size_t pits = 0;
  for (int j = 1; j + 1 < nz; ++j)
    for (int i = 1; i + 1 < nx; ++i) {
      const std::size_t c = std::size_t(j) * nx + i;
      if (z[c] < sea) continue;
      bool lower = false;
      for (int k = 0; k < 8 && !lower; ++k) lower = z[std::size_t(j + kDj[k]) * nx + std::size_t(i + kDi[k])] < z[c];
      pits += !lower;
    }
  return pits;
}

template void fill_depressions<float>(float*, int, int, float, float);
template void fill_depressions<double>(double*, int, int, double, double);
template void fill_depressions_tile<float>(float*, int, int, const std::uint8_t*, const float*, float);
template bool already_drains<float>(const float*, int, int, float);
template bool already_drains<double>(const double*, int, int, double);
template std::size_t count_pits<float>(const float*, int, int, float);
template std::size_t count_pits<double>(const double*, int, int, double);

}  // namespace relief::hydro
