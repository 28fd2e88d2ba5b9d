// Depression filling that a tiled world can reproduce exactly (relief/world.hpp, issue 18 phase 2).
//
// Sources:
//   Barnes, Lehman, Mulla 2014, "Priority-Flood: An optimal depression-filling and watershed-
//     labeling algorithm for digital elevation models" (Algorithm 3, Priority-Flood+ε);
//   Barnes 2016, "Parallel Priority-Flood depression filling for trillion cell digital elevation
//     models on desktops or clusters" (tiles solve locally, exchange only their perimeters);
//   Knuth 1977, "A generalization of Dijkstra's algorithm" (superior functions: Dijkstra's order
//     finds the least fixpoint of any path cost that never decreases along a path).
//
// Why not src/hydrology.cpp's fill_depressions: its pit queue raises a depression breadth-first
// from the first spill cell popped, before heap cells of lower or equal keys, so a cell's filled
// value depends on which spill reached it first in that one global order (see
// WorldFill.HydrologyFillDependsOnTheProcessingOrder in tests/test_world.cpp). No tiling can
// replay a global processing order without holding the whole map. Here the filled surface is
// defined as a least fixpoint instead, which any order of relaxation reaches:
//     F(c) = z(c)                                   for outlets (world border, or z < sea),
//     F(c) = min over the 8 neighbours n of g(F(n), z(c))   otherwise,
//     g(L, z) = z if z > L (drains downhill: unchanged), else step(L),
//     step(L) = max(next float above L, L + ε)      (the same step as fill_depressions).
// g never decreases in L and g(L, z) > L, so Dijkstra's order computes it exactly (Knuth), and so
// does any sequence of exact tile solves whose shared border values are exchanged until nothing
// changes: each value is always that of a real path (never below the fixpoint), and at
// convergence every cell satisfies the equation on both sides of every tile border.
#include <algorithm>
#include <cstring>
#include <limits>

#include "relief/error.hpp"
#include "relief/world.hpp"

namespace relief {
namespace {

std::uint32_t key_of(float v) {
  std::uint32_t u;
  std::memcpy(&u, &v, sizeof u);
  return (u >> 31) ? ~u : (u | 0x80000000u);
}
float value_of(std::uint32_t k) {
  const std::uint32_t u = (k >> 31) ? (k & 0x7FFFFFFFu) : ~k;
  float v;
  std::memcpy(&v, &u, sizeof v);
  return v;
}

float step(float l, float eps) {
  float next = value_of(key_of(l) + 1);
  if (!(next > l)) next = value_of(key_of(l) + 2);  // −0 → +0 is not a step
  if (l + eps > next) next = l + eps;
  return next;
}

constexpr int kDi[8] = {1, 1, 0, -1, -1, -1, 0, 1};
constexpr int kDj[8] = {0, 1, 1, 1, 0, -1, -1, -1};
constexpr float kInf = std::numeric_limits<float>::infinity();

// Monotone radix heap (Ahuja, Mehlhorn, Orlin, Tarjan 1990) on 32-bit order keys: every pushed key
// is ≥ the last popped one (Dijkstra's offers only rise), so a key lives in the bucket of the
// highest bit in which it differs from the last popped key, and a pop redistributes one bucket.
class MonotoneHeap {
 public:
  bool empty() const { return size_ == 0; }
  void push(std::uint32_t key, std::uint32_t cell) {
    buckets_[bucket(key)].push_back({key, cell});
    ++size_;
  }
  std::pair<std::uint32_t, std::uint32_t> pop() {
    if (buckets_[0].empty()) {
      int b = 1;
      while (buckets_[b].empty()) ++b;
      std::uint32_t lo = buckets_[b][0].first;
      for (const auto& e : buckets_[b]) lo = std::min(lo, e.first);
      last_ = lo;
      for (const auto& e : buckets_[b]) buckets_[bucket(e.first)].push_back(e);
      buckets_[b].clear();
    }
    const auto e = buckets_[0].back();
    buckets_[0].pop_back();
    --size_;
    return e;
  }

 private:
  int bucket(std::uint32_t key) const {
    const std::uint32_t x = key ^ last_;
    return x == 0 ? 0 : 32 - __builtin_clz(x);
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> buckets_[33];
  std::uint32_t last_ = 0;
  std::size_t size_ = 0;
};

// Dijkstra on one grid: `f` holds the seeds (finite: a value some path gives; +inf: unknown) and
// becomes the least fixpoint of the equation above restricted to paths inside the grid, with
// `outlet` cells fixed at z. Values are order-independent; the heap's tie order does not matter.
// Zhou, Sun, Fu 2016's observation holds here too: an offer z(m) (a cell above the level that
// reaches it) is the least value m can have at all, so m is final at once and its own uphill
// neighbours are settled by a depth-first walk, without the heap.
void solve(const float* z, float* f, int nx, int nz, const std::vector<std::uint8_t>& outlet, float eps) {
  const std::size_t n = std::size_t(nx) * std::size_t(nz);
  MonotoneHeap open;
  // Seeds: outlets that border a non-outlet cell (the others offer nothing), and known values.
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      const std::size_t c = std::size_t(j) * std::size_t(nx) + std::size_t(i);
      if (outlet[c]) {
        f[c] = z[c];
        bool borders_land = false;
        for (int d = 0; d < 8 && !borders_land; ++d) {
          const int a = i + kDi[d], b = j + kDj[d];
          borders_land = a >= 0 && b >= 0 && a < nx && b < nz && !outlet[std::size_t(b) * std::size_t(nx) + std::size_t(a)];
        }
        if (!borders_land) continue;
      }
      if (f[c] < kInf) open.push(key_of(f[c]), std::uint32_t(c));
    }
  std::vector<std::uint8_t> closed(n, 0);
  std::vector<std::uint32_t> trail;
  // Offers from the final cell c (level l) to its open neighbours; uphill ones close at once.
  auto relax = [&](std::uint32_t c) {
    const float l = f[c];
    const float up = step(l, eps);
    const int i = int(c % std::uint32_t(nx)), j = int(c / std::uint32_t(nx));
    const bool interior = i > 0 && j > 0 && i < nx - 1 && j < nz - 1;
    for (int d = 0; d < 8; ++d) {
      const int a = i + kDi[d], b = j + kDj[d];
      if (!interior && (a < 0 || b < 0 || a >= nx || b >= nz)) continue;
      const std::size_t m = std::size_t(b) * std::size_t(nx) + std::size_t(a);
      if (closed[m] || outlet[m]) continue;
      if (z[m] > l) {
        f[m] = z[m];
        closed[m] = 1;
        trail.push_back(std::uint32_t(m));
      } else if (up < f[m]) {
        f[m] = up;
        open.push(key_of(up), std::uint32_t(m));
      }
    }
  };
  while (!open.empty()) {
    const auto [k, c] = open.pop();
    if (closed[c] || k != key_of(f[c])) continue;  // stale entry
    closed[c] = 1;
    relax(c);
    while (!trail.empty()) {
      const std::uint32_t q = trail.back();
      trail.pop_back();
      relax(q);
    }
  }
}

}  // namespace

void fill_least_fixpoint(float* z, int nx, int nz, float sea, float epsilon) {
  if (nx < 1 || nz < 1) throw Error("size", "expected at least 1x1 samples");
  const std::size_t n = std::size_t(nx) * std::size_t(nz);
  std::vector<std::uint8_t> outlet(n);
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      const std::size_t c = std::size_t(j) * std::size_t(nx) + std::size_t(i);
      outlet[c] = i == 0 || j == 0 || i == nx - 1 || j == nz - 1 || z[c] < sea;
    }
  std::vector<float> f(n, kInf);
  solve(z, f.data(), nx, nz, outlet, epsilon);
  std::copy(f.begin(), f.end(), z);
}

TiledFillStats fill_least_fixpoint_tiled(const WorldGrid& g, float sea, float epsilon, const TileLoad& load, const TileStore& store) {
  TiledFillStats st;
  const std::int64_t tiles = g.count();
  // Known values of the samples on tile borders, per tile perimeter (shared between neighbours by
  // world position): one map from world sample index to value, for border samples only.
  // Border samples: ix a multiple of tile−1 or ix = nx−1 (same for z); there are O(world / tile).
  const std::int64_t step_n = g.tile - 1;
  auto is_border_x = [&](std::int64_t ix) { return ix % step_n == 0 || ix == g.nx - 1; };
  auto is_border_z = [&](std::int64_t iz) { return iz % step_n == 0 || iz == g.nz - 1; };
  // Vertical lines (all iz at border columns) and horizontal lines (all ix at border rows).
  const std::int64_t cols = g.tiles_x + 1, rows = g.tiles_z + 1;
  std::vector<float> vline(std::size_t(cols * g.nz), kInf), hline(std::size_t(rows * g.nx), kInf);
  auto col_index = [&](std::int64_t ix) { return ix == g.nx - 1 ? g.tiles_x : ix / step_n; };
  auto row_index = [&](std::int64_t iz) { return iz == g.nz - 1 ? g.tiles_z : iz / step_n; };
  auto known = [&](std::int64_t ix, std::int64_t iz) -> float& {
    if (is_border_x(ix)) return vline[std::size_t(col_index(ix) * g.nz + iz)];
    return hline[std::size_t(row_index(iz) * g.nx + ix)];
  };
  // Keep a border sample's two copies (vertical and horizontal line at corners) equal.
  auto lower = [&](std::int64_t ix, std::int64_t iz, float v) {
    bool changed = false;
    if (is_border_x(ix)) {
      float& a = vline[std::size_t(col_index(ix) * g.nz + iz)];
      if (v < a) a = v, changed = true;
    }
    if (is_border_z(iz)) {
      float& b = hline[std::size_t(row_index(iz) * g.nx + ix)];
      if (v < b) b = v, changed = true;
    }
    return changed;
  };
  std::vector<std::uint8_t> dirty(std::size_t(tiles), 1);
  bool any = true;
  while (any) {
    any = false;
    ++st.rounds;
    std::vector<std::uint8_t> next_dirty(std::size_t(tiles), 0);
    for (std::int64_t t = 0; t < tiles; ++t) {
      if (!dirty[std::size_t(t)]) continue;
      const std::int64_t X = t % g.tiles_x, Z = t / g.tiles_x;
      const WorldGrid::Window w = g.window(X, Z);
      const std::vector<float> z = load(X, Z);
      const std::size_t n = std::size_t(w.nx) * std::size_t(w.nz);
      std::vector<std::uint8_t> outlet(n);
      std::vector<float> f(n, kInf);
      for (int j = 0; j < w.nz; ++j)
        for (int i = 0; i < w.nx; ++i) {
          const std::int64_t ix = w.ix0 + i, iz = w.iz0 + j;
          const std::size_t c = std::size_t(j) * std::size_t(w.nx) + std::size_t(i);
          outlet[c] = ix == 0 || iz == 0 || ix == g.nx - 1 || iz == g.nz - 1 || z[c] < sea;
          if (i == 0 || j == 0 || i == w.nx - 1 || j == w.nz - 1) f[c] = known(ix, iz);
        }
      solve(z.data(), f.data(), w.nx, w.nz, outlet, epsilon);
      ++st.tile_solves;
      // New border values wake the neighbours that share them.
      for (int j = 0; j < w.nz; ++j)
        for (int i = 0; i < w.nx; ++i) {
          if (!(i == 0 || j == 0 || i == w.nx - 1 || j == w.nz - 1)) continue;
          const std::int64_t ix = w.ix0 + i, iz = w.iz0 + j;
          if (!lower(ix, iz, f[std::size_t(j) * std::size_t(w.nx) + std::size_t(i)])) continue;
          any = true;
          for (std::int64_t dz = -1; dz <= 1; ++dz)
            for (std::int64_t dx = -1; dx <= 1; ++dx) {
              const std::int64_t XX = X + dx, ZZ = Z + dz;
              if ((dx == 0 && dz == 0) || XX < 0 || ZZ < 0 || XX >= g.tiles_x || ZZ >= g.tiles_z) continue;
              const WorldGrid::Window o = g.window(XX, ZZ);
              if (ix >= o.ix0 && ix < o.ix0 + o.nx && iz >= o.iz0 && iz < o.iz0 + o.nz) next_dirty[std::size_t(ZZ * g.tiles_x + XX)] = 1;
            }
        }
      if (store) store(X, Z, std::move(f));
    }
    // A tile solved this round whose own border did not change needs no other solve unless a
    // neighbour changed one of its border samples (next_dirty).
    dirty = std::move(next_dirty);
    if (!any) break;
  }
  return st;
}

}  // namespace relief

namespace relief {

WorldStageAlgorithm world_fill_least_fixpoint() {
  return [](const WorldStageIO& io, const RecipeStage& st, int) {
    const json p = st.stage->params();
    // As the fill stage converts its parameter (src/stage_erosion.cpp).
    const float eps = float(p.value("epsilon_m", 0.0) / io.world.height_m);
    const float sea = float(io.world.sea_level);
    const TileLoad load = [&](std::int64_t X, std::int64_t Z) {
      if (io.cancelled && io.cancelled()) throw Cancelled();
      return io.load(X, Z).layers.at("height").data;
    };
    const TileStore store = [&](std::int64_t X, std::int64_t Z, std::vector<float> f) {
      WorldTile t = io.load(X, Z);  // every other layer as the stages before left it
      t.layers.at("height").data = std::move(f);
      io.store(X, Z, std::move(t));
    };
    fill_least_fixpoint_tiled(io.grid, sea, eps, load, store);
  };
}

}  // namespace relief

namespace relief {

std::map<std::string, WorldStageAlgorithm> default_world_algorithms() { return {}; }

}  // namespace relief
