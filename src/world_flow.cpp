// The "flow" stage over a tiled world, exact against the whole-map run (relief/world_flow.hpp).
//
// Sources:
//   Barnes 2017, "Parallel non-divergent flow accumulation for trillion cell digital elevation
//     models on desktops or clusters" (local accumulation per tile, a perimeter graph solved
//     globally, tiles then add their inflows);
//   Barnes 2016, "Parallel Priority-Flood depression filling for trillion cell digital elevation
//     models on desktops or clusters" (exchange tile perimeters until nothing changes: used here
//     for the Strahler orders and the carving, which are monotone along the flow graph);
//   Kahn 1962 (topological order of the perimeter graph); Strahler 1957; Leopold & Maddock 1953
//     (river width and carving depth, as src/stage_erosion.cpp).
//
// The per-sample arithmetic below copies apply_flow's (src/stage_erosion.cpp) expression for
// expression, so that every float comes out with the same bits; keep the two in step.
//
// Distributed builds (src/world_farm.hpp): in a build (WorldStageIO::farm) every tile solve of the
// three passes is a farm task ("flow": 'A', 'S', 'F'), run on any rank by the same code. A solve
// reads nothing of rank 0's global state but what its task carries: the heights of the grown ring
// from the bands (ring_of), the fill levels of its window perimeter when the heights are filled
// first, and (passes S and final) its TileView: its perimeter nodes' inflow and channel donors, the
// nodes on the ring around its owned rectangle, its components' fate, and (final) the cover from
// other tiles. Results are the Local* structs; the final pass's tile is stored where it is solved.
// Pass A's "does not drain" is a status in its result, so that world_flow fills first on any rank
// count. Rank 0 merges in the same order as without a farm: the same bytes for any rank count.
#include "relief/world_flow.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <tuple>
#include <type_traits>
#include <unordered_map>

#include "relief/error.hpp"
#include "relief/hydrology.hpp"
#include "world_farm.hpp"
#include "world_internal.hpp"
#include "writer_defs.hpp"

namespace relief {
namespace {

constexpr double kSecondsPerYear = 365.25 * 24 * 3600;  // as src/stage_erosion.cpp
constexpr std::uint32_t kNone = 0xFFFFFFFFu;

// Heights within one sample of every inner tile border (the halo of a tile's D8 receivers).
class Bands {
 public:
  explicit Bands(const WorldGrid& g)
      : nx_(g.nx), nz_(g.nz), t1_(g.tile - 1), tx_(g.tiles_x), tz_(g.tiles_z),
        v_(std::size_t(std::max<std::int64_t>(0, tx_ - 1) * 3 * nz_), std::numeric_limits<float>::quiet_NaN()),
        h_(std::size_t(std::max<std::int64_t>(0, tz_ - 1) * 3 * nx_), std::numeric_limits<float>::quiet_NaN()) {}
  bool has(std::int64_t ix, std::int64_t iz) {
    bool any = false;
    each(ix, iz, [&](float&) { any = true; });
    return any;
  }
  // Sets the slots of (ix, iz) that are not set yet (NaN): a slot once set is never written again,
  // so tiles may read set slots while another tile's slots are being set.
  void set(std::int64_t ix, std::int64_t iz, float v) {
    each(ix, iz, [&](float& s) {
      if (std::isnan(s)) s = v;
    });
  }
  float get(std::int64_t ix, std::int64_t iz) {
    float r = std::numeric_limits<float>::quiet_NaN();
    each(ix, iz, [&](float& s) { r = s; });
    return r;
  }

 private:
  template <class F>
  void each(std::int64_t ix, std::int64_t iz, F f) {
    const std::int64_t kx = (ix + 1) / t1_;
    for (std::int64_t k = kx - 1; k <= kx + 1; ++k) {
      const std::int64_t d = ix - k * t1_;
      if (k < 1 || k > tx_ - 1 || d < -1 || d > 1) continue;
      f(v_[std::size_t(((k - 1) * 3 + d + 1) * nz_ + iz)]);
    }
    const std::int64_t kz = (iz + 1) / t1_;
    for (std::int64_t k = kz - 1; k <= kz + 1; ++k) {
      const std::int64_t d = iz - k * t1_;
      if (k < 1 || k > tz_ - 1 || d < -1 || d > 1) continue;
      f(h_[std::size_t(((k - 1) * 3 + d + 1) * nx_ + ix)]);
    }
  }
  std::int64_t nx_, nz_, t1_, tx_, tz_;
  std::vector<float> v_, h_;
};

// f(i, j) for the window samples that may be in a band: the first and last two rows and columns,
// row-major.
template <class F>
void for_band(const WorldGrid::Window& w, F f) {
  for (int j = 0; j < w.nz; ++j)
    for (int i = 0; i < w.nx; ++i) {
      if (j > 1 && j < w.nz - 2 && i > 1 && i < w.nx - 2) {
        i = w.nx - 3;  // skip the inside of the row
        continue;
      }
      f(i, j);
    }
}

// The perimeter graph: one node per sample on the boundary of a tile's owned rectangle.
struct Nodes {
  // Node ids by arithmetic: the perimeter samples of tile t's owned rectangle are nodes
  // base[t] + k, k running row-major over the perimeter (the first row, then the two ends of each
  // middle row, then the last row; owned rectangles are at least 2 × 2).
  std::int64_t nx = 0, nz = 0, t1 = 0, tx = 0, tz = 0;
  std::vector<std::uint64_t> base;
  std::vector<std::int64_t> cell, link_cell;
  std::vector<std::uint32_t> link, tile, acc;
  std::vector<float> z;
  std::vector<std::uint8_t> cross;
  std::vector<std::uint64_t> ext, inflow;  // inflow from other tiles: at this node (ext), through it
  std::vector<std::uint8_t> channel, strahler, chd;
  std::vector<float> e;                     // input height (the lake floor in a lake)
  std::vector<std::uint8_t> lake;
  std::vector<std::uint32_t> comp;          // global component label (kNone: not raised)
  std::vector<float> carved;
  std::vector<std::uint32_t> dstart, donors;  // cross donors of each node (CSR)
  // The node of world sample c, or kNone when c is not on the perimeter of its owned rectangle.
  std::uint32_t find(std::int64_t c) const {
    if (c < 0 || c >= nx * nz) return kNone;  // (a malformed farm result: never an index out of bounds)
    const std::int64_t ix = c % nx, iz = c / nx;
    const std::int64_t X = std::min(ix / t1, tx - 1), Z = std::min(iz / t1, tz - 1);
    const std::int64_t ox0 = X * t1, oz0 = Z * t1;
    const std::int64_t onx = (X == tx - 1 ? nx : ox0 + t1) - ox0, onz = (Z == tz - 1 ? nz : oz0 + t1) - oz0;
    const std::int64_t oi = ix - ox0, oj = iz - oz0;
    std::int64_t k;
    if (oj == 0) k = oi;
    else if (oj == onz - 1) k = onx + 2 * (onz - 2) + oi;
    else if (oi == 0) k = onx + 2 * (oj - 1);
    else if (oi == onx - 1) k = onx + 2 * (oj - 1) + 1;
    else return kNone;
    return std::uint32_t(base[std::size_t(Z * tx + X)] + std::uint64_t(k));
  }
  std::uint32_t at(std::int64_t c) const {
    const std::uint32_t k = find(c);
    if (k == kNone) throw Error("world", "flow: internal error, sample " + std::to_string(c) + " is not a perimeter node");
    return k;
  }
};

struct Ctx {
  const WorldGrid& g;
  const Frame& f;
  const WorldFlowParams& p;
  float sea;
  double H, cell, cell2, runoff_m_s, threshold_cells;
  std::int64_t t1;
  const TileLoad* filled = nullptr;  // the filled heights, when the input may hold depressions
  // hypot(dx, dy) for 0 <= dx, dy <= hyp_r, at hyp[dy·(hyp_r + 1) + dx] (each_cover's distances;
  // hypot depends on |dx| and |dy| only; hyp_table), or null.
  const double* hyp = nullptr;
  int hyp_r = -1;
};

// Lakes: connected components (8-neighbours) of samples the fill raised, labelled per tile and
// joined across tiles by union-find over the labels of perimeter samples; a component is kept as a
// lake when apply_flow keeps it (max depth and area: order-free aggregates).
struct Components {
  std::vector<std::uint64_t> base;  // first global label of each tile
  std::vector<std::uint32_t> parent;
  std::vector<std::uint64_t> count;
  std::vector<double> depth;
  std::vector<std::uint8_t> kept;  // by root
  std::uint32_t find(std::uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  }
  // After flatten(): every label's root in one step, without writing (tiles read it concurrently).
  std::uint32_t root(std::uint32_t a) const { return parent[a]; }
  void flatten() {
    for (std::uint32_t l = 0; l < parent.size(); ++l) parent[l] = find(l);
  }
  void join(std::uint32_t a, std::uint32_t b) {
    a = find(a), b = find(b);
    if (a == b) return;
    if (a > b) std::swap(a, b);
    parent[b] = a;
    count[a] += count[b];
    depth[a] = std::max(depth[a], depth[b]);
  }
};

// One tile's grown window, its receivers and its local flow order over the owned rectangle. Solves
// are reused (SolvePool): every array is sized and written anew by prepare() and finish(), so a
// reused solve keeps only its capacity (no page faults and no zeroing of fresh memory per solve).
struct Solve {
  std::int64_t X = 0, Z = 0;
  WorldGrid::Window w;
  std::int64_t gx0 = 0, gz0 = 0;  // grown window's first sample (world)
  int gnx = 0, gnz = 0;
  int ox0 = 0, oz0 = 0, onx = 0, onz = 0;  // owned rectangle in grown coordinates
  std::vector<float> zg;  // filled heights (the input when it drains), grown window
  std::vector<float> eo;  // the input heights, owned
  std::vector<std::uint8_t> raised, lake;  // owned: raised by the fill; in a kept lake
  std::vector<std::uint32_t> label;        // owned: local component of raised samples (kNone: not raised)
  std::uint32_t labels = 0;
  bool land = false;       // some owned sample is at or above the sea (filled height)
  std::uint32_t max_acc = 0;  // largest local count
  std::vector<std::uint32_t> rec;                 // grown, hydro::d8_receivers
  std::vector<std::uint32_t> rl, order, acc;      // owned: local receivers (self at exits), order, count
  std::vector<std::uint32_t> perimeter;           // owned indices of the perimeter, row-major (node order)
  // finished (pass S and later)
  std::vector<std::uint64_t> cnt;
  std::vector<std::uint8_t> ch, str, chd, cross_chd;  // channel, Strahler, channel donors (of them in other tiles)
  std::vector<float> ec;
  // scratch
  std::vector<float> z;             // the loaded tile
  std::vector<std::uint64_t> b;     // inflow from other tiles through each sample
  std::vector<std::uint8_t> top;
  std::vector<std::uint32_t> stack;

  std::size_t grown(int oi, int oj) const { return std::size_t(oj + oz0) * std::size_t(gnx) + std::size_t(oi + ox0); }
  std::size_t grown_of(std::uint32_t o) const { return grown(int(o % std::uint32_t(onx)), int(o / std::uint32_t(onx))); }
  bool perim(std::uint32_t o) const {
    const int oi = int(o % std::uint32_t(onx)), oj = int(o / std::uint32_t(onx));
    return oi == 0 || oj == 0 || oi == onx - 1 || oj == onz - 1;
  }
};

// Solves kept for reuse: at most as many as were in flight at once (ordered_tiles bounds those).
class SolvePool {
 public:
  std::unique_ptr<Solve> take() {
    {
      std::lock_guard<std::mutex> lock(m_);
      if (!free_.empty()) {
        std::unique_ptr<Solve> s = std::move(free_.back());
        free_.pop_back();
        return s;
      }
    }
    return std::make_unique<Solve>();
  }
  void give(std::unique_ptr<Solve> s) {
    if (!s) return;
    std::lock_guard<std::mutex> lock(m_);
    free_.push_back(std::move(s));
  }

 private:
  std::mutex m_;
  std::vector<std::unique_ptr<Solve>> free_;
};

// A solve taken from a pool, given back when this handle goes (also when a result is dropped by
// an exception).
class SolveRef {
 public:
  explicit SolveRef(SolvePool& pool) : pool_(&pool), s_(pool.take()) {}
  SolveRef(SolveRef&& o) noexcept : pool_(o.pool_), s_(std::move(o.s_)) {}
  SolveRef& operator=(SolveRef&& o) noexcept {
    if (this != &o) {
      release();
      pool_ = o.pool_, s_ = std::move(o.s_);
    }
    return *this;
  }
  ~SolveRef() { release(); }
  Solve& operator*() const { return *s_; }
  Solve* operator->() const { return s_.get(); }

 private:
  void release() {
    if (s_ && pool_) pool_->give(std::move(s_));
  }
  SolvePool* pool_;
  std::unique_ptr<Solve> s_;
};

std::int64_t world_index(const Ctx& c, const Solve& s, std::uint32_t gi) {
  const std::int64_t i = s.gx0 + std::int64_t(gi % std::uint32_t(s.gnx)), j = s.gz0 + std::int64_t(gi / std::uint32_t(s.gnx));
  return j * c.g.nx + i;
}

// Owned index of grown index gi, or kNone when outside the owned rectangle.
std::uint32_t owned_of(const Solve& s, std::uint32_t gi) {
  const int i = int(gi % std::uint32_t(s.gnx)) - s.ox0, j = int(gi / std::uint32_t(s.gnx)) - s.oz0;
  if (i < 0 || j < 0 || i >= s.onx || j >= s.onz) return kNone;
  return std::uint32_t(j) * std::uint32_t(s.onx) + std::uint32_t(i);
}

// The local flow order and counts of the owned rectangle (hydro::flow_order).
void local_order(Solve& s) {
  s.acc.resize(s.rl.size());
  hydro::flow_order(s.rl.data(), s.rl.size(), s.order, s.acc.data());
  if (s.order.size() != s.rl.size()) throw Error("world", "flow: internal error, a tile's flow graph has a cycle");
}

// The grown window of tile window `w`: the window and the samples one step around it that lie in
// the world.
struct Grown {
  std::int64_t gx0, gz0;
  int gnx, gnz;
};
Grown grown_of_window(const WorldGrid& g, const WorldGrid::Window& w) {
  Grown r;
  r.gx0 = w.ix0 - (w.ix0 > 0 ? 1 : 0);
  r.gz0 = w.iz0 - (w.iz0 > 0 ? 1 : 0);
  const std::int64_t gx1 = w.ix0 + w.nx + (w.ix0 + w.nx < g.nx ? 1 : 0);
  const std::int64_t gz1 = w.iz0 + w.nz + (w.iz0 + w.nz < g.nz ? 1 : 0);
  r.gnx = int(gx1 - r.gx0), r.gnz = int(gz1 - r.gz0);
  return r;
}
// f(ix, iz, read) for the samples of the grown window outside the window (the grown ring),
// row-major; `read`: whether a solve reads its band height (else it is NaN). `beyond`: the bands
// right of and below the window are read too (the grown ring there: no owned sample's receiver
// depends on it); pass A, which sets the bands as it goes, leaves them NaN.
template <class F>
void for_ring(const WorldGrid& g, const WorldGrid::Window& w, bool beyond, F f) {
  const Grown gr = grown_of_window(g, w);
  const int wx = int(w.ix0 - gr.gx0);
  for (int j = 0; j < gr.gnz; ++j) {
    const std::int64_t iz = gr.gz0 + j, wj = iz - w.iz0;
    if (wj >= 0 && wj < w.nz) {
      for (int i = 0; i < wx; ++i) f(gr.gx0 + i, iz, true);
      for (int i = wx + w.nx; i < gr.gnx; ++i) f(gr.gx0 + i, iz, beyond);
    } else if (wj < 0) {
      for (int i = 0; i < gr.gnx; ++i) f(gr.gx0 + i, iz, beyond || i < wx + w.nx);
    } else {
      for (int i = 0; i < gr.gnx; ++i) f(gr.gx0 + i, iz, beyond);
    }
  }
}
// The grown ring's heights of tile (X, Z) from the bands (for_ring's order; NaN where not read).
std::vector<float> ring_of(const WorldGrid& g, Bands& bands, std::int64_t X, std::int64_t Z, bool beyond) {
  std::vector<float> r;
  for_ring(g, g.window(X, Z), beyond, [&](std::int64_t ix, std::int64_t iz, bool read) {
    r.push_back(read ? bands.get(ix, iz) : std::numeric_limits<float>::quiet_NaN());
  });
  return r;
}

// `ring`: the grown ring's heights (ring_of).
void prepare(const Ctx& c, const std::vector<float>& ring, const TileLoad& load, std::int64_t X, std::int64_t Z, Solve& s) {
  s.X = X, s.Z = Z;
  s.w = c.g.window(X, Z);
  s.z = c.filled ? (*c.filled)(X, Z) : load(X, Z);
  const std::vector<float>& z = s.z;
  if (z.size() != std::size_t(s.w.nx) * std::size_t(s.w.nz))
    throw Error("world", "flow: tile " + std::to_string(X) + "," + std::to_string(Z) + " has " + std::to_string(z.size()) +
                             " heights, expected " + std::to_string(std::size_t(s.w.nx) * std::size_t(s.w.nz)));
  const Grown gr = grown_of_window(c.g, s.w);
  s.gx0 = gr.gx0, s.gz0 = gr.gz0, s.gnx = gr.gnx, s.gnz = gr.gnz;
  s.zg.resize(std::size_t(s.gnx) * std::size_t(s.gnz));
  if (ring.size() != s.zg.size() - z.size())
    throw Error("world", "flow: tile " + std::to_string(X) + "," + std::to_string(Z) + " has a ring of " + std::to_string(ring.size()) +
                             " heights, expected " + std::to_string(s.zg.size() - z.size()));
  // The window's rows copied whole; the grown ring (outside the window) from `ring`.
  const int wx = int(s.w.ix0 - s.gx0);  // window's first column in the grown window
  std::size_t q = 0;
  for (int j = 0; j < s.gnz; ++j) {
    const std::int64_t iz = s.gz0 + j, wj = iz - s.w.iz0;
    float* row = s.zg.data() + std::size_t(j) * std::size_t(s.gnx);
    if (wj >= 0 && wj < s.w.nz) {
      std::memcpy(row + wx, z.data() + std::size_t(wj) * std::size_t(s.w.nx), std::size_t(s.w.nx) * sizeof(float));
      for (int i = 0; i < wx; ++i) row[i] = ring[q++];
      for (int i = wx + s.w.nx; i < s.gnx; ++i) row[i] = ring[q++];
    } else {
      for (int i = 0; i < s.gnx; ++i) row[i] = ring[q++];
    }
  }
  const std::int64_t ox1 = X == c.g.tiles_x - 1 ? c.g.nx : s.w.ix0 + c.t1;
  const std::int64_t oz1 = Z == c.g.tiles_z - 1 ? c.g.nz : s.w.iz0 + c.t1;
  s.ox0 = int(s.w.ix0 - s.gx0), s.oz0 = int(s.w.iz0 - s.gz0);
  s.onx = int(ox1 - s.w.ix0), s.onz = int(oz1 - s.w.iz0);
  s.rec.resize(s.zg.size());
  hydro::d8_receivers<float>(s.zg.data(), s.gnx, s.gnz, c.sea, s.rec.data());
  const std::size_t on = std::size_t(s.onx) * std::size_t(s.onz);
  s.rl.resize(on);
  // Local receivers: a receiver is one of the 8 neighbours (or the sample itself); those outside
  // the owned rectangle make the sample an exit (its own local receiver).
  const std::int64_t gnx = s.gnx;
  s.land = false;
  for (int oj = 0; oj < s.onz; ++oj) {
    const std::size_t g0 = s.grown(0, oj);
    const std::uint32_t o0 = std::uint32_t(oj) * std::uint32_t(s.onx);
    for (int oi = 0; oi < s.onx; ++oi) {
      const std::size_t gi = g0 + std::size_t(oi);
      const std::uint32_t o = o0 + std::uint32_t(oi);
      s.land |= !(s.zg[gi] < c.sea);
      const std::int64_t d = std::int64_t(s.rec[gi]) - std::int64_t(gi);
      if (d == 0) {
        s.rl[o] = o;
        continue;
      }
      const int dj = d > 1 ? 1 : (d < -1 ? -1 : 0);
      const int di = int(d - dj * gnx);
      const int ri = oi + di, rj = oj + dj;
      s.rl[o] = ri < 0 || rj < 0 || ri >= s.onx || rj >= s.onz ? o : std::uint32_t(rj) * std::uint32_t(s.onx) + std::uint32_t(ri);
    }
  }
  local_order(s);
  s.max_acc = on ? *std::max_element(s.acc.begin(), s.acc.end()) : 0;
  s.perimeter.clear();
  for (int oj = 0; oj < s.onz; ++oj) {
    const std::uint32_t o0 = std::uint32_t(oj) * std::uint32_t(s.onx);
    if (oj == 0 || oj == s.onz - 1) {
      for (int oi = 0; oi < s.onx; ++oi) s.perimeter.push_back(o0 + std::uint32_t(oi));
    } else {
      s.perimeter.push_back(o0);
      s.perimeter.push_back(o0 + std::uint32_t(s.onx - 1));
    }
  }
  // The input heights and the components of raised samples (apply_flow's lake search, per tile).
  s.eo.resize(on);
  s.raised.assign(on, 0);
  s.label.assign(on, kNone);
  s.labels = 0;
  if (!c.filled) {
    for (int oj = 0; oj < s.onz; ++oj)
      std::memcpy(s.eo.data() + std::size_t(oj) * std::size_t(s.onx), s.zg.data() + s.grown(0, oj), std::size_t(s.onx) * sizeof(float));
    return;  // nothing raised
  }
  const std::vector<float> raw = load(X, Z);
  for (int oj = 0; oj < s.onz; ++oj)
    for (int oi = 0; oi < s.onx; ++oi) {
      const std::uint32_t o = std::uint32_t(oj) * std::uint32_t(s.onx) + std::uint32_t(oi);
      const float f = s.zg[s.grown(oi, oj)];
      s.eo[o] = raw[std::size_t(oj) * std::size_t(s.w.nx) + std::size_t(oi)];
      s.raised[o] = f > s.eo[o];
    }
  std::vector<std::uint32_t>& stack = s.stack;
  for (std::uint32_t o0 = 0; o0 < on; ++o0) {
    if (!s.raised[o0] || s.label[o0] != kNone) continue;
    s.label[o0] = s.labels;
    stack.assign(1, o0);
    while (!stack.empty()) {
      const std::uint32_t o = stack.back();
      stack.pop_back();
      const int oi = int(o % std::uint32_t(s.onx)), oj = int(o / std::uint32_t(s.onx));
      for (int k = 0; k < 8; ++k) {
        const int a = oi + hydro::kDi[k], b = oj + hydro::kDj[k];
        if (a < 0 || b < 0 || a >= s.onx || b >= s.onz) continue;
        const std::uint32_t m = std::uint32_t(b) * std::uint32_t(s.onx) + std::uint32_t(a);
        if (s.raised[m] && s.label[m] == kNone) s.label[m] = s.labels, stack.push_back(m);
      }
    }
    ++s.labels;
  }
}

// What a solve of pass S or the final pass reads of the global state (the perimeter graph, the
// components), for its tile only: its own perimeter nodes' inflow and channel donors in other tiles,
// the nodes on the one-sample ring around its owned rectangle (they lie on the perimeters of the
// tiles around), and its components' fate. About 4·T values: a task's input (src/world_farm.hpp).
struct RingNode {
  float carved = 0, z = 0;
  std::uint8_t lake = 0, channel = 0, chd = 0;
  std::uint64_t count = 0;     // acc + inflow
  std::uint32_t root = kNone;  // the lake's component root (kNone: not in a kept lake)
};
struct TileView {
  std::vector<std::uint64_t> ext;     // per own perimeter node (node order)
  std::vector<std::uint32_t> donors;  // per own perimeter node: its channel donors in other tiles
  std::vector<std::uint8_t> donor_str;  // their Strahler orders, node after node
  std::vector<RingNode> ring;         // ring_slot order (slots outside the world: default)
  std::vector<std::uint8_t> kept;     // per local component: in a kept lake
  std::vector<std::uint32_t> root;    // per local component: its root
  // The slots of the ring around an owned rectangle of onx × onz: its row above (onx + 2), the
  // left and right samples of each of its rows, its row below.
  static std::size_t slots(int onx, int onz) { return 2 * std::size_t(onx + 2) + 2 * std::size_t(onz); }
  static std::size_t slot(int onx, int onz, int bi, int bj) {  // bi, bj: from the ring box's corner
    if (bj == 0) return std::size_t(bi);
    if (bj == onz + 1) return std::size_t(onx + 2) + 2 * std::size_t(onz) + std::size_t(bi);
    return std::size_t(onx + 2) + 2 * std::size_t(bj - 1) + (bi == 0 ? 0 : 1);
  }
  // The ring node of world sample `cell` (next to tile s's owned rectangle, outside it).
  const RingNode& at(const Ctx& c, const Solve& s, std::int64_t cell) const {
    const std::int64_t bi = cell % c.g.nx - (s.w.ix0 - 1), bj = cell / c.g.nx - (s.w.iz0 - 1);
    const bool inside = bi >= 1 && bi <= s.onx && bj >= 1 && bj <= s.onz;
    if (inside || bi < 0 || bj < 0 || bi > s.onx + 1 || bj > s.onz + 1 || ring.size() != slots(s.onx, s.onz))
      throw Error("world", "flow: internal error, sample " + std::to_string(cell) + " is not on a tile's ring");
    return ring[slot(s.onx, s.onz, int(bi), int(bj))];
  }
};

// Marks the owned samples in kept lakes (after the components are joined).
void mark_lakes(const Ctx& c, const TileView& v, Solve& s) {
  if (v.kept.size() != s.labels || v.root.size() != s.labels) throw Error("world", "flow: internal error, a tile's components");
  s.lake.assign(s.rl.size(), 0);
  if (!c.p.lakes || s.labels == 0) return;
  for (std::size_t o = 0; o < s.rl.size(); ++o)
    if (s.label[o] != kNone) s.lake[o] = v.kept[s.label[o]];
}

// Thrown by check_drains (an Error like any other to flow_tiled's callers; world_flow catches it
// and fills first).
struct NotDraining : Error {
  using Error::Error;
};

// The whole map's hydro::already_drains condition on the owned samples: every sample that is not
// an outlet (world border, or below the sea) has a strictly lower neighbour, so that apply_flow
// fills nothing (a world of fewer than 3 samples along an axis always drains, as there).
void check_drains(const Ctx& c, const Solve& s, const std::string& path) {
  if (c.filled || c.g.nx < 3 || c.g.nz < 3) return;
  for (int oj = 0; oj < s.onz; ++oj)
    for (int oi = 0; oi < s.onx; ++oi) {
      const std::int64_t ix = s.w.ix0 + oi, iz = s.w.iz0 + oj;
      if (ix == 0 || iz == 0 || ix == c.g.nx - 1 || iz == c.g.nz - 1) continue;
      const int gi = oi + s.ox0, gj = oj + s.oz0;
      // A D8 receiver is a strictly lower neighbour (its drop is > 0): only samples without one
      // (below the sea, or pits) need the test.
      const std::size_t c0 = std::size_t(gj) * std::size_t(s.gnx) + std::size_t(gi);
      if (s.rec[c0] != c0) continue;
      float m = std::numeric_limits<float>::infinity();
      for (int k = 0; k < 8; ++k) m = std::min(m, s.zg[std::size_t(gj + hydro::kDj[k]) * std::size_t(s.gnx) + std::size_t(gi + hydro::kDi[k])]);
      const float zc = s.zg[std::size_t(gj) * std::size_t(s.gnx) + std::size_t(gi)];
      if (!(zc < c.sea || m < zc))
        throw NotDraining(path, "the flow stage's world algorithm needs a height that already drains (a fill stage before "
                          "it); sample (" +
                              std::to_string(ix) + ", " + std::to_string(iz) + ") does not");
    }
}

double discharge(const Ctx& c, std::uint64_t count) { return double(count) * c.cell2 * c.runoff_m_s; }
double width(const Ctx& c, std::uint64_t count) {
  return std::max(c.p.min_width_m, c.p.width_coeff * std::pow(discharge(c, count), c.p.width_exponent));
}

// Counts, channels, Strahler orders and carved heights of the owned samples, from the perimeter
// graph as known now. Returns nothing; fills s.cnt, s.ch, s.str, s.ec.
void finish(const Ctx& c, const TileView& v, Solve& s) {
  const std::size_t on = s.rl.size();
  if (v.ext.size() != s.perimeter.size() || v.donors.size() != s.perimeter.size())
    throw Error("world", "flow: internal error, a tile's perimeter nodes");
  s.b.assign(on, 0);
  std::uint64_t* b = s.b.data();
  for (std::size_t k = 0; k < s.perimeter.size(); ++k) b[s.perimeter[k]] = v.ext[k];
  for (std::uint32_t o : s.order)
    if (s.rl[o] != o) b[s.rl[o]] += b[o];
  s.cnt.resize(on);
  s.ch.resize(on);
  s.ec.resize(on);
  for (int oj = 0; oj < s.onz; ++oj) {
    const std::size_t o0 = std::size_t(oj) * std::size_t(s.onx);
    const float* zrow = s.zg.data() + s.grown(0, oj);
    for (int oi = 0; oi < s.onx; ++oi) {
      const std::size_t o = o0 + std::size_t(oi);
      s.cnt[o] = std::uint64_t(s.acc[o]) + b[o];
      // lake floors stay under their water (and are the channel test's height)
      const float e = s.lake[o] ? s.eo[o] : zrow[oi];
      s.ec[o] = e;
      s.ch[o] = double(s.cnt[o]) >= c.threshold_cells && e >= c.sea;
    }
  }
  // Strahler orders (donors first), with channel donors in other tiles as known so far.
  s.str.assign(on, 0);
  s.chd.assign(on, 0);
  s.cross_chd.assign(on, 0);
  s.top.assign(on, 0);
  std::uint8_t* top = s.top.data();
  auto add = [&](std::uint32_t r, std::uint8_t sd) {
    if (sd > s.str[r]) s.str[r] = sd, top[r] = 1;
    else if (sd == s.str[r]) ++top[r];
  };
  std::size_t di = 0;  // v.donor_str's first of node q
  for (std::size_t q = 0; q < s.perimeter.size(); ++q) {
    const std::uint32_t o = s.perimeter[q];
    const std::size_t n = v.donors[q];
    if (v.donor_str.size() - di < n) throw Error("world", "flow: internal error, a tile's channel donors");
    di += n;
    if (!s.ch[o]) continue;
    for (std::size_t k = di - n; k < di; ++k) {
      ++s.chd[o], ++s.cross_chd[o];
      add(o, v.donor_str[k]);
    }
  }
  for (std::uint32_t o : s.order) {
    if (!s.ch[o]) continue;
    if (s.str[o] == 0) s.str[o] = 1;
    else if (top[o] >= 2) ++s.str[o];
    const std::uint32_t r = s.rl[o];
    if (r == o || !s.ch[r]) continue;
    ++s.chd[r];
    add(r, s.str[o]);
  }
  if (c.p.carve_depth_coeff > 0) {
    for (std::size_t q = on; q-- > 0;) {
      const std::uint32_t o = s.order[q];
      if (!s.ch[o] || s.lake[o]) continue;
      const std::size_t gi = s.grown_of(o);
      const std::uint32_t rg = s.rec[gi];
      if (rg == gi) continue;
      const double depth = c.p.carve_depth_coeff * std::pow(discharge(c, s.cnt[o]), 0.4);
      const std::uint32_t ro = owned_of(s, rg);
      float below;  // a lake's surface, else the carved receiver
      if (ro != kNone) {
        below = s.lake[ro] ? s.zg[rg] : s.ec[ro];
      } else {
        const RingNode& k = v.at(c, s, world_index(c, s, rg));
        below = k.lake ? k.z : k.carved;
      }
      const float carved = std::max(float(double(s.ec[o]) - depth / c.H), std::nextafter(below, 2.0f));
      s.ec[o] = std::min(s.ec[o], carved);
    }
  }
}

// A piece of a river inside one tile: from a start sample (a head or a confluence) or from the
// sample where a river enters the tile, down to its end or to the sample (`next`, in another tile)
// where it goes on.
// One sample of a kept lake, as apply_flow's lake record reads it.
struct LakeSample {
  float filled, e;
  std::uint64_t count;
  bool exits;  // its receiver is not in the same lake
};

// apply_flow's Lake record of one lake from all its samples (world index → sample): its
// depth-first order from its first sample in row-major order is replayed, so that every sum
// (volume, centroid) adds the same doubles in the same order and the outlet ties break alike.
Lake lake_record(const Ctx& c, const std::unordered_map<std::int64_t, LakeSample>& cells_of, std::int64_t seed) {
  const Frame& f = c.f;
  std::vector<std::int64_t> cells, stack(1, seed);
  std::unordered_map<std::int64_t, std::uint8_t> seen;
  seen.emplace(seed, 1);
  while (!stack.empty()) {
    const std::int64_t q = stack.back();
    stack.pop_back();
    cells.push_back(q);
    const std::int64_t i = q % c.g.nx, j = q / c.g.nx;
    for (int k = 0; k < 8; ++k) {
      const std::int64_t a = i + hydro::kDi[k], b = j + hydro::kDj[k];
      if (a < 0 || b < 0 || a >= c.g.nx || b >= c.g.nz) continue;
      const std::int64_t m = b * c.g.nx + a;
      if (cells_of.count(m) && seen.emplace(m, 1).second) stack.push_back(m);
    }
  }
  Lake lake;
  float level = 0;
  double max_depth = 0, volume = 0, sx = 0, sz = 0;
  for (const std::int64_t q : cells) {
    const LakeSample& ls = cells_of.at(q);
    level = std::max(level, ls.filled);
    const double depth = (double(ls.filled) - ls.e) * c.H;
    max_depth = std::max(max_depth, depth);
    volume += depth * c.cell2;
  }
  lake.area_m2 = double(cells.size()) * c.cell2;
  lake.level_m = f.y_m(level);
  lake.volume_m3 = volume;
  lake.max_depth_m = max_depth;
  lake.samples = cells.size();
  lake.x0_m = lake.z0_m = 1e300;
  lake.x1_m = lake.z1_m = -1e300;
  std::int64_t outlet = cells[0];
  std::uint64_t outlet_count = 0;
  for (const std::int64_t q : cells) {
    const double x = f.x_m(int(q % c.g.nx)), z = f.z_m(int(q / c.g.nx));
    sx += x, sz += z;
    lake.x0_m = std::min(lake.x0_m, x), lake.x1_m = std::max(lake.x1_m, x);
    lake.z0_m = std::min(lake.z0_m, z), lake.z1_m = std::max(lake.z1_m, z);
    const LakeSample& ls = cells_of.at(q);
    if (ls.exits && ls.count > outlet_count) outlet = q, outlet_count = ls.count;
  }
  lake.x_m = sx / double(cells.size());
  lake.z_m = sz / double(cells.size());
  lake.outlet_x_m = f.x_m(int(outlet % c.g.nx));
  lake.outlet_z_m = f.z_m(int(outlet / c.g.nx));
  return lake;
}

struct Piece {
  std::vector<RiverVertex> vertices;
  std::string end;
  std::int64_t next = -1;
  int order = 1;
};

void trace_pieces(const Ctx& c, const TileView& v, const Solve& s, std::unordered_map<std::int64_t, Piece>& pieces,
                  std::vector<std::int64_t>& starts) {
  const Frame& f = c.f;
  // apply_flow's vertex(): position, surface height (no lakes here), discharge and width.
  auto vertex = [&](std::int64_t ix, std::int64_t iz, float e, std::uint64_t count) {
    RiverVertex v;
    v.x_m = f.x_m(int(ix));
    v.z_m = f.z_m(int(iz));
    v.y_m = std::max(0.0, f.y_m(e));
    v.discharge_m3s = discharge(c, count);
    v.width_m = width(c, count);
    return v;
  };
  const std::uint32_t on = std::uint32_t(s.rl.size());
  for (std::uint32_t o0 = 0; o0 < on; ++o0) {
    if (!s.ch[o0]) continue;
    const bool start = s.chd[o0] != 1;
    if (!start && s.cross_chd[o0] != 1) continue;  // inside a river traced from upstream in this tile
    Piece pc;
    pc.order = s.str[o0];
    std::uint32_t o = o0;
    for (;;) {
      const int oi = int(o % std::uint32_t(s.onx)), oj = int(o / std::uint32_t(s.onx));
      const std::size_t gi = s.grown(oi, oj);
      pc.vertices.push_back(vertex(s.w.ix0 + oi, s.w.iz0 + oj, s.lake[o] ? s.zg[gi] : s.ec[o], s.cnt[o]));
      const std::uint32_t rg = s.rec[gi];
      if (rg == gi) {
        pc.end = "edge";
        break;
      }
      const std::uint32_t ro = owned_of(s, rg);
      const std::int64_t rw = world_index(c, s, rg);
      const std::int64_t rx = rw % c.g.nx, rz = rw / c.g.nx;
      bool r_channel;
      std::uint8_t r_chd;
      float r_e;
      std::uint64_t r_count;
      if (ro != kNone) {
        r_channel = s.ch[ro], r_chd = s.chd[ro], r_e = s.lake[ro] ? s.zg[rg] : s.ec[ro], r_count = s.cnt[ro];
      } else {
        const RingNode& k = v.at(c, s, rw);
        r_channel = k.channel, r_chd = k.chd, r_e = k.lake ? k.z : k.carved, r_count = k.count;
      }
      if (!r_channel) {  // only the sea ends a channel
        RiverVertex mouth = vertex(rx, rz, r_e, r_count);
        mouth.y_m = 0.0;
        mouth.discharge_m3s = pc.vertices.back().discharge_m3s;
        mouth.width_m = pc.vertices.back().width_m;
        pc.vertices.push_back(mouth);
        pc.end = "sea";
        break;
      }
      if (r_chd >= 2) {
        pc.vertices.push_back(vertex(rx, rz, r_e, r_count));
        pc.end = "river";
        break;
      }
      if (ro == kNone) {
        pc.next = rw;
        break;
      }
      o = ro;
    }
    const std::int64_t w0 = (s.w.iz0 + std::int64_t(o0 / std::uint32_t(s.onx))) * c.g.nx + s.w.ix0 + o0 % std::uint32_t(s.onx);
    if (start) starts.push_back(w0);
    pieces.emplace(w0, std::move(pc));
  }
}

template <class F>
void each_cover(const Ctx& c, std::int64_t i, std::int64_t j, std::uint64_t count, F f) {
  // f(ix, iz, value, sea_test): apply_flow's water cover of one channel sample, for the samples it
  // covers (value > 0; apply_flow also visits those of value 0, which change nothing).
  const double w = width(c, count);
  if (w <= c.cell) {
    f(i, j, float(w / c.cell), false);
    return;
  }
  const double r_cells = 0.5 * w / c.cell;
  const int R = int(std::ceil(r_cells + 0.5));
  const bool table = R <= c.hyp_r;
  const std::size_t stride = std::size_t(c.hyp_r + 1);
  for (std::int64_t b = std::max<std::int64_t>(0, j - R); b <= std::min<std::int64_t>(c.g.nz - 1, j + R); ++b) {
    const double* row = table ? c.hyp + std::size_t(std::abs(b - j)) * stride : nullptr;
    for (std::int64_t a = std::max<std::int64_t>(0, i - R); a <= std::min<std::int64_t>(c.g.nx - 1, i + R); ++a) {
      const double h = table ? row[std::abs(a - i)] : std::hypot(double(a - i), double(b - j));
      const double cover = std::clamp(r_cells - h + 0.5, 0.0, 1.0);
      if (cover > 0) f(a, b, float(cover), true);
    }
  }
}

}  // namespace

WorldFlowParams world_flow_params(const json& j) {
  WorldFlowParams p;
  p.lakes = j.value("depressions", std::string("lakes")) == "lakes";
  p.epsilon_m = j.value("epsilon_m", p.epsilon_m);
  p.lake_min_depth_m = j.value("lake_min_depth_m", p.lake_min_depth_m);
  p.lake_min_area_m2 = j.value("lake_min_area_m2", p.lake_min_area_m2);
  p.river_area_km2 = j.value("river_area_km2", p.river_area_km2);
  p.runoff_mm_per_year = j.value("runoff_mm_per_year", p.runoff_mm_per_year);
  p.width_coeff = j.value("width_coeff", p.width_coeff);
  p.width_exponent = j.value("width_exponent", p.width_exponent);
  p.min_width_m = j.value("min_width_m", p.min_width_m);
  p.carve_depth_coeff = j.value("carve_depth_coeff", p.carve_depth_coeff);
  return p;
}

namespace {
// A tile's pass-A result: its perimeter nodes (row-major over its owned rectangle's perimeter,
// the node order) and its components of raised samples; the solve itself goes back to the pool
// before the merge.
struct LocalA {
  std::vector<std::int64_t> cell, link_cell;  // world samples: the node, its link (-1: none)
  std::vector<std::uint32_t> acc, comp;       // local count; local component (kNone: not raised)
  std::vector<float> z, e;                    // filled and input heights
  std::vector<std::uint8_t> cross;            // the link is an exit into another tile
  std::vector<std::uint64_t> comp_count;      // per local component: samples, max depth (m)
  std::vector<double> comp_depth;
  bool land = false;
  std::uint32_t max_acc = 0;
  std::vector<float> band;  // the window's first and last two rows and columns (Bands order)
};

// Pass A's solve of tile t, its grown ring's heights `ring` (ring_of, not beyond). Throws NotDraining
// (check_drains).
LocalA solve_a(const Ctx& c, const std::vector<float>& ring, const TileLoad& load, std::int64_t t, SolvePool& pool,
               const std::string& path) {
  const WorldGrid& g = c.g;
  LocalA r;
  SolveRef sr(pool);
  Solve& s = *sr;
  prepare(c, ring, load, t % g.tiles_x, t / g.tiles_x, s);
  check_drains(c, s, path);
  for_band(s.w, [&](int i, int j) { r.band.push_back(s.z[std::size_t(j) * std::size_t(s.w.nx) + std::size_t(i)]); });
  const std::size_t on = s.rl.size();
  // np: the next perimeter sample downstream inside the tile (kNone: none), receivers first.
  s.top.assign(on, 0);
  for (const std::uint32_t o : s.perimeter) s.top[o] = 1;
  std::vector<std::uint32_t>& np = s.stack;
  np.assign(on, kNone);
  for (std::size_t q = on; q-- > 0;) {
    const std::uint32_t o = s.order[q], rr = s.rl[o];
    if (rr != o) np[o] = s.top[rr] ? rr : np[rr];
  }
  r.land = s.land;
  r.max_acc = s.max_acc;
  r.comp_count.assign(s.labels, 0);
  r.comp_depth.assign(s.labels, 0.0);
  if (s.labels > 0)
    for (std::uint32_t o = 0; o < on; ++o) {
      if (s.label[o] == kNone) continue;
      const std::size_t l = s.label[o];
      ++r.comp_count[l];
      r.comp_depth[l] = std::max(r.comp_depth[l], (double(s.zg[s.grown_of(o)]) - s.eo[o]) * c.H);  // as apply_flow
    }
  const std::size_t pn = s.perimeter.size();
  r.cell.resize(pn), r.link_cell.resize(pn), r.acc.resize(pn), r.comp.resize(pn), r.z.resize(pn), r.e.resize(pn);
  r.cross.resize(pn);
  for (std::size_t k = 0; k < pn; ++k) {
    const std::uint32_t o = s.perimeter[k];
    const int oi = int(o % std::uint32_t(s.onx)), oj = int(o / std::uint32_t(s.onx));
    const std::size_t gi = s.grown(oi, oj);
    r.cell[k] = (s.w.iz0 + oj) * g.nx + s.w.ix0 + oi;
    r.acc[k] = s.acc[o];
    r.z[k] = s.zg[gi];
    r.e[k] = s.eo[o];
    r.comp[k] = s.label[o];
    const std::uint32_t rg = s.rec[gi];
    r.cross[k] = 0;
    if (rg != gi && owned_of(s, rg) == kNone) {
      r.cross[k] = 1;
      r.link_cell[k] = world_index(c, s, rg);
    } else if (np[o] != kNone) {
      const int ri = int(np[o] % std::uint32_t(s.onx)), rj = int(np[o] / std::uint32_t(s.onx));
      r.link_cell[k] = (s.w.iz0 + rj) * g.nx + s.w.ix0 + ri;
    } else {
      r.link_cell[k] = -1;
    }
  }
  return r;
}

// A tile's pass-S result: the values of its perimeter nodes (node order) and, in the first
// round, its cover beyond its owned rectangle.
struct LocalS {
  std::vector<std::uint8_t> chd, str;
  std::vector<float> ec;
  std::vector<std::pair<std::int64_t, float>> cover_sea, cover_any;  // first round: cover beyond the owned rectangle
};

bool strictly_inside(const Solve& s, std::int64_t ix, std::int64_t iz) {
  return ix > s.w.ix0 && iz > s.w.iz0 && ix < s.w.ix0 + s.onx - 1 && iz < s.w.iz0 + s.onz - 1;
}

// A tile's cover list reduced to one entry per sample (the largest cover: max is order-free), in
// sample order; also while it grows, so that overlapping discs along a border hold it to the
// samples they cover.
using CoverList = std::vector<std::pair<std::int64_t, float>>;
constexpr std::size_t compact_at = std::size_t(1) << 20;
void compact(CoverList& cv) {
  std::sort(cv.begin(), cv.end());  // by sample, then value: the last of a sample is its largest
  std::size_t n = 0;
  for (std::size_t q = 0; q < cv.size(); ++q) {
    if (n > 0 && cv[n - 1].first == cv[q].first) cv[n - 1] = cv[q];
    else cv[n++] = cv[q];
  }
  cv.resize(n);
}

LocalS solve_s_tile(const Ctx& c, const std::vector<float>& ring, const TileLoad& load, const TileView& v, std::int64_t t,
                    bool first_round, SolvePool& pool) {
  const WorldGrid& g = c.g;
  LocalS r;
  SolveRef sr(pool);
  Solve& s = *sr;
  prepare(c, ring, load, t % g.tiles_x, t / g.tiles_x, s);
  mark_lakes(c, v, s);
  finish(c, v, s);
  std::size_t limit_sea = compact_at, limit_any = compact_at;
  if (first_round)
    for (std::uint32_t o = 0; o < s.rl.size(); ++o) {
      if (!s.ch[o] || s.lake[o]) continue;
      const std::int64_t i = s.w.ix0 + o % std::uint32_t(s.onx), j = s.w.iz0 + o / std::uint32_t(s.onx);
      each_cover(c, i, j, s.cnt[o], [&](std::int64_t a, std::int64_t b, float cv_v, bool sea_test) {
        if (!(cv_v > 0) || strictly_inside(s, a, b)) return;
        auto& cv = sea_test ? r.cover_sea : r.cover_any;
        std::size_t& limit = sea_test ? limit_sea : limit_any;
        cv.emplace_back(b * g.nx + a, cv_v);
        if (cv.size() >= limit) compact(cv), limit = std::max(compact_at, 2 * cv.size());
      });
    }
  compact(r.cover_sea), compact(r.cover_any);
  const std::size_t pn = s.perimeter.size();
  r.chd.resize(pn), r.str.resize(pn), r.ec.resize(pn);
  for (std::size_t k = 0; k < pn; ++k) {
    const std::uint32_t o = s.perimeter[k];
    r.chd[k] = s.chd[o], r.str[k] = s.str[o], r.ec[k] = s.ec[o];
  }
  return r;
}

struct CoverEntry {
  std::int64_t cell;
  float v;
  bool sea_test;
};

struct LocalF {
  FlowTile out;
  std::uint64_t max_count = 0;
  std::unordered_map<std::int64_t, Piece> pieces;
  std::vector<std::int64_t> starts;
  std::vector<std::tuple<std::uint32_t, std::int64_t, LakeSample>> lake;  // root, world sample, sample
};

LocalF solve_f_tile(const Ctx& c, const std::vector<float>& ring, const TileLoad& load, const TileView& v,
                    const std::vector<CoverEntry>& cover, std::int64_t t, bool rivers, bool lakes, SolvePool& pool) {
  const WorldGrid& g = c.g;
  LocalF r;
  const std::int64_t X = t % g.tiles_x, Z = t / g.tiles_x;
  SolveRef sr(pool);
  Solve& s = *sr;
  prepare(c, ring, load, X, Z, s);
  mark_lakes(c, v, s);
  finish(c, v, s);
  if (!s.cnt.empty()) r.max_count = *std::max_element(s.cnt.begin(), s.cnt.end());
  const WorldGrid::Window& w = s.w;
  const std::size_t n = std::size_t(w.nx) * std::size_t(w.nz);
  FlowTile& out = r.out;
  out.height.resize(n);
  out.flow.resize(n);
  out.water.assign(n, 0.0f);
  for (int j = 0; j < w.nz; ++j)
    for (int i = 0; i < w.nx; ++i) {
      const std::size_t m = std::size_t(j) * std::size_t(w.nx) + std::size_t(i);
      std::uint64_t count;
      if (i < s.onx && j < s.onz) {
        const std::size_t o = std::size_t(j) * std::size_t(s.onx) + std::size_t(i);
        out.height[m] = s.ec[o];
        if (s.lake[o]) out.water[m] = 1.0f;
        count = s.cnt[o];
      } else {
        const RingNode& k = v.at(c, s, (w.iz0 + j) * g.nx + w.ix0 + i);
        out.height[m] = k.carved;
        if (k.lake) out.water[m] = 1.0f;
        count = k.count;
      }
      out.flow[m] = float(double(count) * c.cell2);
    }
  for (std::uint32_t o = 0; o < s.rl.size(); ++o) {
    if (!s.ch[o] || s.lake[o]) continue;
    const std::int64_t i = w.ix0 + o % std::uint32_t(s.onx), j = w.iz0 + o / std::uint32_t(s.onx);
    each_cover(c, i, j, s.cnt[o], [&](std::int64_t a, std::int64_t b, float v, bool sea_test) {
      if (a < w.ix0 || b < w.iz0 || a >= w.ix0 + w.nx || b >= w.iz0 + w.nz) return;
      const std::size_t m = std::size_t(b - w.iz0) * std::size_t(w.nx) + std::size_t(a - w.ix0);
      if (sea_test && out.height[m] < c.sea) return;
      out.water[m] = std::max(out.water[m], v);
    });
  }
  // Cover from channel samples of other tiles (discs may reach deep into this one).
  for (const CoverEntry& ce : cover) {
    const std::size_t m = std::size_t(ce.cell / g.nx - w.iz0) * std::size_t(w.nx) + std::size_t(ce.cell % g.nx - w.ix0);
    if (ce.sea_test && out.height[m] < c.sea) continue;
    out.water[m] = std::max(out.water[m], ce.v);
  }
  if (rivers) trace_pieces(c, v, s, r.pieces, r.starts);
  if (lakes)
    for (std::uint32_t o = 0; o < s.rl.size(); ++o) {
      if (!s.lake[o]) continue;
      const int oi = int(o % std::uint32_t(s.onx)), oj = int(o / std::uint32_t(s.onx));
      const std::uint32_t root = v.root[s.label[o]];
      const std::size_t gi = s.grown(oi, oj);
      const std::uint32_t rg = s.rec[gi];
      bool same = false;
      if (const std::uint32_t ro = owned_of(s, rg); ro != kNone) {
        same = s.lake[ro] && v.root[s.label[ro]] == root;
      } else {
        const RingNode& k = v.at(c, s, world_index(c, s, rg));
        same = k.lake && k.root == root;
      }
      const std::int64_t wc = (w.iz0 + oj) * g.nx + w.ix0 + oi;
      r.lake.emplace_back(root, wc, LakeSample{s.zg[gi], s.eo[o], s.cnt[o], !same});
    }
  return r;
}

Ctx make_ctx(const WorldGrid& g, const Frame& f, const WorldFlowParams& p, const TileLoad* filled) {
  Ctx c{g, f, p, float(f.sea_level), f.height_m, f.cell_m(), 0, 0, 0, g.tile - 1, filled};
  c.cell2 = c.cell * c.cell;
  c.runoff_m_s = p.runoff_mm_per_year * 1e-3 / kSecondsPerYear;
  c.threshold_cells = p.river_area_km2 * 1e6 / c.cell2;
  return c;
}

// The perimeter samples of window `w`.
std::size_t window_perimeter(const WorldGrid::Window& w) {
  return w.nx == 1 || w.nz == 1 ? std::size_t(w.nx) * std::size_t(w.nz) : 2 * std::size_t(w.nx + w.nz) - 4;
}
// Tile (X, Z)'s filled heights from its input heights `z`: one hydro::fill_depressions_tile solve
// seeded with `ring`, its window perimeter's final levels in fill_depressions_tiled (row-major).
std::vector<float> filled_from_ring(const WorldGrid& g, float sea, float eps, std::int64_t X, std::int64_t Z, std::vector<float> z,
                                    const std::vector<float>& ring) {
  const WorldGrid::Window w = g.window(X, Z);
  const std::size_t n = std::size_t(w.nx) * std::size_t(w.nz);
  if (z.size() != n || ring.size() != window_perimeter(w))
    throw Error("world", "flow: tile " + std::to_string(X) + "," + std::to_string(Z) + " has " + std::to_string(z.size()) + " heights and " +
                             std::to_string(ring.size()) + " fill levels, expected " + std::to_string(n) + " and " +
                             std::to_string(window_perimeter(w)));
  std::vector<std::uint8_t> outlet(n);
  std::vector<float> seed(n, std::numeric_limits<float>::infinity());
  std::size_t k = 0;
  for (int j = 0; j < w.nz; ++j)
    for (int i = 0; i < w.nx; ++i) {
      const std::int64_t ix = w.ix0 + i, iz = w.iz0 + j;
      const std::size_t q = std::size_t(j) * std::size_t(w.nx) + std::size_t(i);
      outlet[q] = ix == 0 || iz == 0 || ix == g.nx - 1 || iz == g.nz - 1 || z[q] < sea;  // as fill_depressions_tiled
      if (i == 0 || j == 0 || i == w.nx - 1 || j == w.nz - 1) seed[q] = ring[k++];
    }
  hydro::fill_depressions_tile<float>(z.data(), w.nx, w.nz, outlet.data(), seed.data(), eps);
  return z;
}

// The flow kernel's messages (src/world_farm.hpp): raw integers and floats (the ranks share one
// architecture), vectors as a u64 count and their elements. Every read is bounds-checked: a
// malformed message throws an Error, it never reads beyond its end.
struct Coder {
  std::string s;
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    s.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <class T>
  void put(const std::vector<T>& v) {
    put(std::uint64_t(v.size()));
    s.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
};
struct Decoder {
  std::string_view s;
  std::size_t at = 0;
  [[noreturn]] void bad(const std::string& why) const {
    throw Error("world", "flow: a malformed farm message of " + std::to_string(s.size()) + " bytes (" + why + ")");
  }
  template <class T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>);
    if (s.size() - at < sizeof(T)) bad("it ends at byte " + std::to_string(at) + " inside a field");
    T v;
    std::memcpy(&v, s.data() + at, sizeof v);
    at += sizeof v;
    return v;
  }
  template <class T>
  std::vector<T> vec() {
    const std::uint64_t n = get<std::uint64_t>();
    if (n > (s.size() - at) / sizeof(T)) bad("a count of " + std::to_string(n) + " at byte " + std::to_string(at - 8) + " beyond its end");
    std::vector<T> v(static_cast<std::size_t>(n));
    if (n) std::memcpy(v.data(), s.data() + at, std::size_t(n) * sizeof(T));
    at += std::size_t(n) * sizeof(T);
    return v;
  }
  void end() const {
    if (at != s.size()) bad(std::to_string(s.size() - at) + " bytes after its end");
  }
};

// Pass A's task: 'A', whether the heights are filled from levels, the grown ring, the fill levels.
struct InputA {
  std::vector<float> ring, fill_ring;
  bool filled = false;
};
std::string encode(const InputA& in) {
  Coder c;
  c.put(char('A'));
  c.put(std::uint8_t(in.filled));
  c.put(in.ring);
  c.put(in.fill_ring);
  return std::move(c.s);
}
InputA decode_input_a(Decoder& d) {
  InputA in;
  const std::uint8_t f = d.get<std::uint8_t>();
  if (f > 1) d.bad("a flag of " + std::to_string(f));
  in.filled = f;
  in.ring = d.vec<float>();
  in.fill_ring = d.vec<float>();
  d.end();
  return in;
}
// Pass A's result: 'a', a status (0: solved, then the LocalA; 1: the height does not drain, then
// check_drains' message).
std::string encode(const LocalA& r) {
  Coder c;
  c.put(char('a'));
  c.put(std::uint8_t(0));
  c.put(r.cell), c.put(r.link_cell), c.put(r.acc), c.put(r.comp), c.put(r.z), c.put(r.e), c.put(r.cross);
  c.put(r.comp_count), c.put(r.comp_depth);
  c.put(std::uint8_t(r.land));
  c.put(r.max_acc);
  c.put(r.band);
  return std::move(c.s);
}
std::string encode_not_draining(const std::string& message) {
  Coder c;
  c.put(char('a'));
  c.put(std::uint8_t(1));
  c.put(std::vector<char>(message.begin(), message.end()));
  return std::move(c.s);
}
struct ResultA {
  LocalA r;
  bool drains = true;
  std::string message;  // when it does not
};
ResultA decode_result_a(Decoder& d) {
  ResultA out;
  const std::uint8_t status = d.get<std::uint8_t>();
  if (status == 1) {
    const std::vector<char> m = d.vec<char>();
    out.drains = false;
    out.message.assign(m.begin(), m.end());
    d.end();
    return out;
  }
  if (status != 0) d.bad("a status of " + std::to_string(status));
  LocalA& r = out.r;
  r.cell = d.vec<std::int64_t>(), r.link_cell = d.vec<std::int64_t>(), r.acc = d.vec<std::uint32_t>(), r.comp = d.vec<std::uint32_t>();
  r.z = d.vec<float>(), r.e = d.vec<float>(), r.cross = d.vec<std::uint8_t>();
  r.comp_count = d.vec<std::uint64_t>(), r.comp_depth = d.vec<double>();
  const std::uint8_t land = d.get<std::uint8_t>();
  if (land > 1) d.bad("a flag of " + std::to_string(land));
  r.land = land;
  r.max_acc = d.get<std::uint32_t>();
  r.band = d.vec<float>();
  d.end();
  const std::size_t pn = r.cell.size();
  if (r.link_cell.size() != pn || r.acc.size() != pn || r.comp.size() != pn || r.z.size() != pn || r.e.size() != pn ||
      r.cross.size() != pn || r.comp_depth.size() != r.comp_count.size())
    d.bad("fields of different lengths");
  for (const std::uint32_t l : r.comp)
    if (l != kNone && l >= r.comp_count.size()) d.bad("a component label out of range");
  return out;
}
// Pass S's and the final pass's task: 'S' or 'F', the grown ring (beyond), the fill levels, the
// TileView, the flags, each_cover's table radius and (final pass) the cover from other tiles.
struct InputSF {
  char kind = 'S';
  std::vector<float> ring, fill_ring;
  bool filled = false, first_round = false, rivers = false, lakes = false, same_height = false;
  int hyp_r = -1;
  TileView view;
  std::vector<CoverEntry> cover;
};
std::uint8_t flag(Decoder& d) {
  const std::uint8_t f = d.get<std::uint8_t>();
  if (f > 1) d.bad("a flag of " + std::to_string(f));
  return f;
}
std::string encode(const InputSF& in) {
  Coder c;
  c.put(in.kind);
  c.put(in.ring), c.put(in.fill_ring);
  c.put(std::uint8_t(in.filled)), c.put(std::uint8_t(in.first_round)), c.put(std::uint8_t(in.rivers)), c.put(std::uint8_t(in.lakes));
  c.put(std::uint8_t(in.same_height));
  c.put(std::int32_t(in.hyp_r));
  const TileView& v = in.view;
  c.put(v.ext), c.put(v.donors), c.put(v.donor_str);
  const std::size_t n = v.ring.size();
  std::vector<float> carved(n), z(n);
  std::vector<std::uint8_t> lake(n), channel(n), chd(n);
  std::vector<std::uint64_t> count(n);
  std::vector<std::uint32_t> root(n);
  for (std::size_t k = 0; k < n; ++k) {
    const RingNode& r = v.ring[k];
    carved[k] = r.carved, z[k] = r.z, lake[k] = r.lake, channel[k] = r.channel, chd[k] = r.chd, count[k] = r.count, root[k] = r.root;
  }
  c.put(carved), c.put(z), c.put(lake), c.put(channel), c.put(chd), c.put(count), c.put(root);
  c.put(v.kept), c.put(v.root);
  std::vector<std::int64_t> cell(in.cover.size());
  std::vector<float> value(in.cover.size());
  std::vector<std::uint8_t> sea(in.cover.size());
  for (std::size_t k = 0; k < in.cover.size(); ++k) cell[k] = in.cover[k].cell, value[k] = in.cover[k].v, sea[k] = in.cover[k].sea_test;
  c.put(cell), c.put(value), c.put(sea);
  return std::move(c.s);
}
InputSF decode_input_sf(Decoder& d, char kind) {
  InputSF in;
  in.kind = kind;
  in.ring = d.vec<float>(), in.fill_ring = d.vec<float>();
  in.filled = flag(d), in.first_round = flag(d), in.rivers = flag(d), in.lakes = flag(d), in.same_height = flag(d);
  in.hyp_r = d.get<std::int32_t>();
  if (in.hyp_r < -1 || in.hyp_r > 1447) d.bad("a table radius of " + std::to_string(in.hyp_r));
  TileView& v = in.view;
  v.ext = d.vec<std::uint64_t>(), v.donors = d.vec<std::uint32_t>(), v.donor_str = d.vec<std::uint8_t>();
  std::uint64_t donors = 0;
  for (const std::uint32_t n : v.donors) donors += n;
  if (v.ext.size() != v.donors.size() || donors != v.donor_str.size()) d.bad("perimeter fields of different lengths");
  const std::vector<float> carved = d.vec<float>(), z = d.vec<float>();
  const std::vector<std::uint8_t> lake = d.vec<std::uint8_t>(), channel = d.vec<std::uint8_t>(), chd = d.vec<std::uint8_t>();
  const std::vector<std::uint64_t> count = d.vec<std::uint64_t>();
  const std::vector<std::uint32_t> root = d.vec<std::uint32_t>();
  const std::size_t n = carved.size();
  if (z.size() != n || lake.size() != n || channel.size() != n || chd.size() != n || count.size() != n || root.size() != n)
    d.bad("ring fields of different lengths");
  v.ring.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    if (lake[k] > 1 || channel[k] > 1) d.bad("a flag of a ring node");
    RingNode& r = v.ring[k];
    r.carved = carved[k], r.z = z[k], r.lake = lake[k], r.channel = channel[k], r.chd = chd[k], r.count = count[k], r.root = root[k];
  }
  v.kept = d.vec<std::uint8_t>(), v.root = d.vec<std::uint32_t>();
  if (v.kept.size() != v.root.size()) d.bad("component fields of different lengths");
  const std::vector<std::int64_t> cell = d.vec<std::int64_t>();
  const std::vector<float> value = d.vec<float>();
  const std::vector<std::uint8_t> sea = d.vec<std::uint8_t>();
  if (value.size() != cell.size() || sea.size() != cell.size()) d.bad("cover fields of different lengths");
  in.cover.resize(cell.size());
  for (std::size_t k = 0; k < cell.size(); ++k) {
    if (sea[k] > 1) d.bad("a flag of a cover entry");
    in.cover[k] = CoverEntry{cell[k], value[k], sea[k] != 0};
  }
  d.end();
  return in;
}
// Pass S's result: 's', the LocalS.
std::string encode(const LocalS& r) {
  Coder c;
  c.put(char('s'));
  c.put(r.chd), c.put(r.str), c.put(r.ec);
  for (const CoverList* cv : {&r.cover_sea, &r.cover_any}) {
    std::vector<std::int64_t> cell(cv->size());
    std::vector<float> value(cv->size());
    for (std::size_t k = 0; k < cv->size(); ++k) cell[k] = (*cv)[k].first, value[k] = (*cv)[k].second;
    c.put(cell), c.put(value);
  }
  return std::move(c.s);
}
LocalS decode_result_s(Decoder& d) {
  LocalS r;
  r.chd = d.vec<std::uint8_t>(), r.str = d.vec<std::uint8_t>(), r.ec = d.vec<float>();
  if (r.str.size() != r.chd.size() || r.ec.size() != r.chd.size()) d.bad("perimeter fields of different lengths");
  for (CoverList* cv : {&r.cover_sea, &r.cover_any}) {
    const std::vector<std::int64_t> cell = d.vec<std::int64_t>();
    const std::vector<float> value = d.vec<float>();
    if (value.size() != cell.size()) d.bad("cover fields of different lengths");
    cv->resize(cell.size());
    for (std::size_t k = 0; k < cell.size(); ++k) (*cv)[k] = {cell[k], value[k]};
  }
  d.end();
  return r;
}
// The final pass's result: 'f', the LocalF but its tile (stored by the rank that solved it).
std::string encode(const LocalF& r) {
  Coder c;
  c.put(char('f'));
  c.put(r.max_count);
  c.put(std::uint64_t(r.pieces.size()));
  std::vector<std::int64_t> keys;  // in key order, not the hash map's: a result has one coding
  keys.reserve(r.pieces.size());
  for (const auto& kv : r.pieces) keys.push_back(kv.first);
  std::sort(keys.begin(), keys.end());
  for (const std::int64_t at : keys) {
    const Piece& pc = r.pieces.at(at);
    c.put(at), c.put(std::int32_t(pc.order)), c.put(pc.next);
    c.put(std::vector<char>(pc.end.begin(), pc.end.end()));
    c.put(pc.vertices);
  }
  c.put(r.starts);
  const std::size_t n = r.lake.size();
  std::vector<std::uint32_t> root(n);
  std::vector<std::int64_t> wc(n);
  std::vector<float> filled(n), e(n);
  std::vector<std::uint64_t> count(n);
  std::vector<std::uint8_t> exits(n);
  for (std::size_t k = 0; k < n; ++k) {
    const auto& [rt, w, ls] = r.lake[k];
    root[k] = rt, wc[k] = w, filled[k] = ls.filled, e[k] = ls.e, count[k] = ls.count, exits[k] = ls.exits;
  }
  c.put(root), c.put(wc), c.put(filled), c.put(e), c.put(count), c.put(exits);
  return std::move(c.s);
}
LocalF decode_result_f(Decoder& d) {
  LocalF r;
  r.max_count = d.get<std::uint64_t>();
  const std::uint64_t pieces = d.get<std::uint64_t>();
  if (pieces > d.s.size()) d.bad("a count of " + std::to_string(pieces) + " river pieces");
  for (std::uint64_t q = 0; q < pieces; ++q) {
    const std::int64_t at = d.get<std::int64_t>();
    Piece pc;
    pc.order = d.get<std::int32_t>();
    pc.next = d.get<std::int64_t>();
    const std::vector<char> end = d.vec<char>();
    pc.end.assign(end.begin(), end.end());
    pc.vertices = d.vec<RiverVertex>();
    if (!r.pieces.emplace(at, std::move(pc)).second) d.bad("a river piece twice");
  }
  r.starts = d.vec<std::int64_t>();
  const std::vector<std::uint32_t> root = d.vec<std::uint32_t>();
  const std::vector<std::int64_t> wc = d.vec<std::int64_t>();
  const std::vector<float> filled = d.vec<float>(), e = d.vec<float>();
  const std::vector<std::uint64_t> count = d.vec<std::uint64_t>();
  const std::vector<std::uint8_t> exits = d.vec<std::uint8_t>();
  const std::size_t n = root.size();
  if (wc.size() != n || filled.size() != n || e.size() != n || count.size() != n || exits.size() != n)
    d.bad("lake fields of different lengths");
  for (std::size_t k = 0; k < n; ++k) {
    if (exits[k] > 1) d.bad("a flag of a lake sample");
    r.lake.emplace_back(root[k], wc[k], LakeSample{filled[k], e[k], count[k], exits[k] != 0});
  }
  d.end();
  return r;
}
// each_cover's table for radius r (Ctx::hyp).
std::shared_ptr<const std::vector<double>> hyp_table(int r) {
  const std::size_t stride = std::size_t(r + 1);
  auto t = std::make_shared<std::vector<double>>(stride * stride);
  for (int dy = 0; dy <= r; ++dy)
    for (int dx = 0; dx <= r; ++dx) (*t)[std::size_t(dy) * stride + std::size_t(dx)] = std::hypot(double(dx), double(dy));
  return t;
}

// What the rank that runs a task knows: the stage's parameters, the world, its own tiles.
struct FlowKernelState {
  WorldGrid g;
  Frame f;
  WorldFlowParams p;
  TileLoad load;
  std::function<void(std::int64_t X, std::int64_t Z, FlowTile tile, bool same_height)> store;  // the final pass's tiles
  std::function<bool()> cancelled;
  SolvePool pool;
  std::mutex m;  // hyp
  std::shared_ptr<const std::vector<double>> hyp;
  std::shared_ptr<const std::vector<double>> table(int r) {
    std::lock_guard<std::mutex> lock(m);
    if (!hyp || hyp->size() != std::size_t(r + 1) * std::size_t(r + 1)) hyp = hyp_table(r);
    return hyp;
  }
};
std::string run_flow_task(FlowKernelState& k, std::int64_t t, std::string_view input) {
  if (k.cancelled && k.cancelled()) throw Cancelled();
  Decoder d{input};
  const char tag = d.get<char>();
  if (tag != 'A' && tag != 'S' && tag != 'F') d.bad("an unknown task kind " + std::to_string(int(std::uint8_t(tag))));
  if (t < 0 || t >= k.g.count()) d.bad("a tile " + std::to_string(t) + " outside the world");
  const float sea = float(k.f.sea_level), eps = float(k.p.epsilon_m / k.f.height_m);  // as world_flow
  if (tag == 'A') {
    const InputA in = decode_input_a(d);
    const TileLoad filled = [&](std::int64_t x, std::int64_t z) { return filled_from_ring(k.g, sea, eps, x, z, k.load(x, z), in.fill_ring); };
    const Ctx c = make_ctx(k.g, k.f, k.p, in.filled ? &filled : nullptr);
    try {
      return encode(solve_a(c, in.ring, k.load, t, k.pool, ""));
    } catch (const NotDraining& e) {  // a status, not an error: rank 0 then fills first, on any rank count
      return encode_not_draining(e.message());
    }
  }
  const InputSF in = decode_input_sf(d, tag);
  const TileLoad filled = [&](std::int64_t x, std::int64_t z) { return filled_from_ring(k.g, sea, eps, x, z, k.load(x, z), in.fill_ring); };
  Ctx c = make_ctx(k.g, k.f, k.p, in.filled ? &filled : nullptr);
  std::shared_ptr<const std::vector<double>> hyp;
  if (in.hyp_r >= 0) {
    hyp = k.table(in.hyp_r);
    c.hyp = hyp->data(), c.hyp_r = in.hyp_r;
  }
  if (tag == 'S') return encode(solve_s_tile(c, in.ring, k.load, in.view, t, in.first_round, k.pool));
  const std::int64_t X = t % k.g.tiles_x, Z = t / k.g.tiles_x;
  const WorldGrid::Window w = k.g.window(X, Z);
  for (const CoverEntry& ce : in.cover) {
    const std::int64_t ix = ce.cell % k.g.nx, iz = ce.cell / k.g.nx;
    if (ce.cell < 0 || ix < w.ix0 || iz < w.iz0 || ix >= w.ix0 + w.nx || iz >= w.iz0 + w.nz) d.bad("a cover entry outside the tile");
  }
  LocalF r = solve_f_tile(c, in.ring, k.load, in.view, in.cover, t, in.rivers, in.lakes, k.pool);
  if (k.store) k.store(X, Z, std::move(r.out), in.same_height);
  return encode(r);
}
detail::FarmKernel flow_kernel(const WorldGrid& g, const Frame& f, const WorldFlowParams& p, const TileLoad& load,
                               const std::function<void(std::int64_t, std::int64_t, FlowTile, bool)>& store,
                               const std::function<bool()>& cancelled) {
  auto k = std::make_shared<FlowKernelState>();
  k->g = g, k->f = f, k->p = p, k->load = load, k->store = store, k->cancelled = cancelled;
  return [k](std::int64_t t, std::string_view input) { return run_flow_task(*k, t, input); };
}

// A distributed build's farm (src/world_farm.hpp) for flow's tile solves, the kernel of this rank
// (flow_farm_kernel), the fill levels of each tile's window perimeter when the heights are filled
// first, and whether the stored height stays as it is (world_flow).
struct FlowFarm {
  detail::TileFarm* farm = nullptr;
  const std::vector<std::vector<float>>* fill_rings = nullptr;
  detail::FarmKernel kernel;
  bool same_height = false;
};

}  // namespace

namespace detail {
std::string flow_message_recoded(std::string_view bytes) {
  Decoder d{bytes};
  const char tag = d.get<char>();
  if (tag == 'A') return encode(decode_input_a(d));
  if (tag == 'a') {
    const ResultA r = decode_result_a(d);
    return r.drains ? encode(r.r) : encode_not_draining(r.message);
  }
  if (tag == 'S' || tag == 'F') return encode(decode_input_sf(d, tag));
  if (tag == 's') return encode(decode_result_s(d));
  if (tag == 'f') return encode(decode_result_f(d));
  d.bad("an unknown kind " + std::to_string(int(std::uint8_t(tag))));
}
}  // namespace detail

namespace {

// flow_tiled with progress (WorldStageIO::progress): the passes over every tile take fixed spans of
// [0, 1] (pass A [0, 0.35), pass S [0.35, 0.7), the final pass [0.7, 1]), each
// split by the tiles it has merged; pass S's rounds split its span as fill_depressions_tiled's
// rounds split [0, 1] (round r: [1 − 2^(1−r), 1 − 2^(−r)) of the span), since their count is not
// known in advance. Reported from the merges (one thread at a time), never decreasing, 1 at the end.
TiledFlowStats flow_tiled_with_progress(const WorldGrid& g, const Frame& f, const WorldFlowParams& p, const TileLoad& load,
                                        const FlowTileStore& store, std::vector<River>* rivers,
                                        const std::function<bool()>& cancelled, const std::string& path, const TileLoad& filled,
                                        std::vector<Lake>* lakes, const std::function<void(double)>& progress, const FlowFarm& ff = {}) {
  auto report = [&](double lo, double hi, std::int64_t done, std::int64_t of) {
    if (progress) progress(lo + (hi - lo) * double(std::min(done, of)) / double(std::max<std::int64_t>(1, of)));
  };
  TiledFlowStats st;
  st.tiles = g.count();
  Ctx c = make_ctx(g, f, p, filled ? &filled : nullptr);
  if (ff.farm && ((filled && !ff.fill_rings) || !ff.kernel))
    throw Error("world", "flow: internal error, a farm without its kernel, or filled heights without their levels");
  auto check = [&] {
    if (cancelled && cancelled()) throw Cancelled();
  };

  // Every pass over the tiles runs their solves concurrently on the calling arena's threads and
  // merges their results in tile order (detail::ordered_tiles), so the bits, the stats and the
  // order of the store calls do not depend on the thread count.
  const std::int64_t tiles = g.count();
  std::vector<std::int64_t> all_tiles(static_cast<std::size_t>(tiles));
  for (std::int64_t t = 0; t < tiles; ++t) all_tiles[std::size_t(t)] = t;

  std::int64_t merged = 0;  // tiles merged in the current pass (progress)
  Bands bands(g);
  // Pass A: local accumulation, perimeter links, components of raised samples, and the bands: the
  // heights within one sample of inner tile borders, which the receivers of a tile's owned samples
  // read from the tiles left of and above it. So the tiles go by anti-diagonals (X + Z), each
  // diagonal's tiles concurrently, reading the bands that earlier diagonals set, setting their own.
  merged = 0;
  Nodes nd;
  nd.nx = g.nx, nd.nz = g.nz, nd.t1 = c.t1, nd.tx = g.tiles_x, nd.tz = g.tiles_z;
  nd.base.assign(std::size_t(g.count()) + 1, 0);
  // Node ids by arithmetic: tile t's perimeter nodes follow those of the tiles before it (row-major).
  for (std::int64_t t = 0; t < tiles; ++t) {
    const std::int64_t X = t % g.tiles_x, Z = t / g.tiles_x;
    const std::int64_t onx = (X == g.tiles_x - 1 ? g.nx : (X + 1) * c.t1) - X * c.t1;
    const std::int64_t onz = (Z == g.tiles_z - 1 ? g.nz : (Z + 1) * c.t1) - Z * c.t1;
    nd.base[std::size_t(t) + 1] = nd.base[std::size_t(t)] + std::uint64_t(2 * onx + 2 * onz - 4);
  }
  if (nd.base[std::size_t(tiles)] >= kNone)
    throw Error("world", "flow: too many tile perimeter samples (more than 2^32 - 1): use larger tiles");
  {
    const std::size_t total = std::size_t(nd.base[std::size_t(tiles)]);
    nd.cell.resize(total), nd.link_cell.resize(total), nd.tile.resize(total), nd.acc.resize(total), nd.comp.resize(total);
    nd.z.resize(total), nd.e.resize(total), nd.cross.resize(total);
  }
  Components comp;
  comp.base.resize(std::size_t(g.count()) + 1, 0);
  SolvePool pool;
  std::vector<std::uint8_t> tile_land(std::size_t(tiles), 0);
  std::vector<std::uint32_t> tile_max_acc(std::size_t(tiles), 0);
  std::vector<std::uint32_t> tile_labels(std::size_t(tiles), 0);  // components of each tile (from comp.base)
  auto merge_a = [&](std::int64_t t, LocalA r) {
    ++st.tile_solves;
    const WorldGrid::Window w = g.window(t % g.tiles_x, t / g.tiles_x);
    std::size_t q = 0;
    for_band(w, [&](int, int) { ++q; });
    if (r.band.size() != q) throw Error("world", "flow: internal error, a tile's band of " + std::to_string(r.band.size()) + " heights");
    q = 0;
    for_band(w, [&](int i, int j) { bands.set(w.ix0 + i, w.iz0 + j, r.band[q++]); });
    tile_land[std::size_t(t)] = r.land;
    tile_max_acc[std::size_t(t)] = r.max_acc;
    const std::size_t node0 = std::size_t(nd.base[std::size_t(t)]);
    if (node0 + r.cell.size() != nd.base[std::size_t(t) + 1])
      throw Error("world", "flow: internal error, perimeter numbering");
    // Every node is the perimeter sample of its place, every link a perimeter node or none (also
    // the check of a result from another rank: nothing below indexes by an unchecked sample).
    for (std::size_t k = 0; k < r.cell.size(); ++k)
      if (nd.find(r.cell[k]) != node0 + k || (r.link_cell[k] != -1 && nd.find(r.link_cell[k]) == kNone))
        throw Error("world", "flow: internal error, perimeter numbering (tile " + std::to_string(t) + ", node " + std::to_string(k) + ")");
    const std::uint64_t base = comp.parent.size();
    comp.base[std::size_t(t)] = base;
    const std::size_t labels = r.comp_count.size();
    if (base + labels >= kNone) throw Error("world", "flow: too many depressions (more than 2^32 - 1)");
    for (std::uint32_t k = 0; k < labels; ++k) comp.parent.push_back(std::uint32_t(base + k));
    tile_labels[std::size_t(t)] = std::uint32_t(labels);
    comp.count.insert(comp.count.end(), r.comp_count.begin(), r.comp_count.end());
    comp.depth.insert(comp.depth.end(), r.comp_depth.begin(), r.comp_depth.end());
    std::copy(r.cell.begin(), r.cell.end(), nd.cell.begin() + std::ptrdiff_t(node0));
    std::fill_n(nd.tile.begin() + std::ptrdiff_t(node0), r.cell.size(), std::uint32_t(t));
    std::copy(r.acc.begin(), r.acc.end(), nd.acc.begin() + std::ptrdiff_t(node0));
    std::copy(r.z.begin(), r.z.end(), nd.z.begin() + std::ptrdiff_t(node0));
    std::copy(r.e.begin(), r.e.end(), nd.e.begin() + std::ptrdiff_t(node0));
    for (std::size_t k = 0; k < r.comp.size(); ++k) nd.comp[node0 + k] = r.comp[k] == kNone ? kNone : std::uint32_t(base + r.comp[k]);
    std::copy(r.cross.begin(), r.cross.end(), nd.cross.begin() + std::ptrdiff_t(node0));
    std::copy(r.link_cell.begin(), r.link_cell.end(), nd.link_cell.begin() + std::ptrdiff_t(node0));
    report(0.0, 0.35, ++merged, tiles);
  };
  std::vector<std::int64_t> diagonal;
  for (std::int64_t d = 0; d < g.tiles_x + g.tiles_z - 1; ++d) {
    diagonal.clear();
    for (std::int64_t Z = std::max<std::int64_t>(0, d - (g.tiles_x - 1)); Z <= std::min(d, g.tiles_z - 1); ++Z)
      diagonal.push_back(Z * g.tiles_x + (d - Z));
    if (ff.farm) {
      // Each solve on whichever rank (src/world_farm.hpp): its ring of band heights (and fill levels)
      // go there, its LocalA comes back; a height that does not drain comes back as a status.
      ff.farm->run(
          "flow", diagonal,
          [&](std::int64_t t) {
            InputA in;
            in.ring = ring_of(g, bands, t % g.tiles_x, t / g.tiles_x, false);
            in.filled = filled != nullptr;
            if (in.filled) in.fill_ring = (*ff.fill_rings).at(std::size_t(t));
            return encode(in);
          },
          ff.kernel, [&](std::int64_t t, std::string bytes) {
            Decoder d{bytes};
            if (d.get<char>() != 'a') d.bad("not a pass-A result");
            ResultA r = decode_result_a(d);
            if (!r.drains) throw NotDraining(path, r.message);
            merge_a(t, std::move(r.r));
          });
      continue;
    }
    detail::ordered_tiles<LocalA>(
        diagonal,
        [&](std::int64_t t) {
          check();
          return solve_a(c, ring_of(g, bands, t % g.tiles_x, t / g.tiles_x, false), load, t, pool, path);
        },
        merge_a);
  }

  // Components across tiles: join raised perimeter samples with their raised neighbours in other
  // tiles (a sample next to an owned rectangle but outside it lies on another's perimeter).
  const std::size_t nn = nd.cell.size();
  comp.base[std::size_t(g.count())] = comp.parent.size();
  for (std::size_t k = 0; k < nn; ++k) {
    if (nd.comp[k] == kNone) continue;
    const std::int64_t i = nd.cell[k] % g.nx, j = nd.cell[k] / g.nx;
    for (int d = 0; d < 8; ++d) {
      const std::int64_t a = i + hydro::kDi[d], b = j + hydro::kDj[d];
      if (a < 0 || b < 0 || a >= g.nx || b >= g.nz) continue;
      const std::uint32_t m = nd.find(b * g.nx + a);
      if (m == kNone || nd.tile[m] == nd.tile[k] || nd.comp[m] == kNone) continue;
      comp.join(nd.comp[k], nd.comp[m]);
    }
  }
  comp.flatten();  // from here on, tiles read roots concurrently (Components::root)
  comp.kept.assign(comp.parent.size(), 0);
  for (std::uint32_t l = 0; l < comp.parent.size(); ++l)
    if (comp.parent[l] == l)
      comp.kept[l] = p.lakes && !(comp.depth[l] < p.lake_min_depth_m || double(comp.count[l]) * c.cell2 < p.lake_min_area_m2);
  nd.lake.assign(nn, 0);
  for (std::size_t k = 0; k < nn; ++k)
    if (nd.comp[k] != kNone) nd.lake[k] = comp.kept[comp.find(nd.comp[k])];
  for (std::uint32_t l = 0; l < comp.parent.size(); ++l)
    if (comp.parent[l] == l && comp.kept[l]) ++st.lakes;

  // Global solve over the perimeter graph (Kahn), 64-bit counts.
  st.perimeter_nodes = std::int64_t(nn);
  nd.link.resize(nn);
  std::vector<std::uint32_t> indeg(nn, 0);
  nd.dstart.assign(nn + 1, 0);
  for (std::size_t k = 0; k < nn; ++k) {
    nd.link[k] = nd.link_cell[k] < 0 ? kNone : nd.at(nd.link_cell[k]);
    if (nd.link[k] == kNone) continue;
    ++indeg[nd.link[k]];
    if (nd.cross[k]) ++nd.dstart[nd.link[k] + 1], ++st.cross_links;
  }
  std::vector<std::int64_t>().swap(nd.link_cell);
  for (std::size_t k = 0; k < nn; ++k) nd.dstart[k + 1] += nd.dstart[k];
  nd.donors.resize(nd.dstart[nn]);
  {
    std::vector<std::uint32_t> fillp(nd.dstart.begin(), nd.dstart.end() - 1);
    for (std::size_t k = 0; k < nn; ++k)
      if (nd.cross[k] && nd.link[k] != kNone) nd.donors[fillp[nd.link[k]]++] = std::uint32_t(k);
  }
  nd.ext.assign(nn, 0);
  nd.inflow.assign(nn, 0);
  std::vector<std::uint32_t> queue;
  queue.reserve(nn);
  for (std::size_t k = 0; k < nn; ++k)
    if (indeg[k] == 0) queue.push_back(std::uint32_t(k));
  for (std::size_t qi = 0; qi < queue.size(); ++qi) {
    const std::uint32_t k = queue[qi], l = nd.link[k];
    if (l == kNone) continue;
    const std::uint64_t out = nd.cross[k] ? std::uint64_t(nd.acc[k]) + nd.inflow[k] : nd.inflow[k];
    nd.inflow[l] += out;
    if (nd.cross[k]) nd.ext[l] += out;
    if (--indeg[l] == 0) queue.push_back(l);
  }
  if (queue.size() != nn) throw Error("world", "flow: internal error, the perimeter graph has a cycle");
  nd.channel.resize(nn);
  for (std::size_t k = 0; k < nn; ++k)
    nd.channel[k] = double(std::uint64_t(nd.acc[k]) + nd.inflow[k]) >= c.threshold_cells && (nd.lake[k] ? nd.e[k] : nd.z[k]) >= c.sea;
  nd.strahler.assign(nn, 0);
  nd.chd.assign(nn, 0);
  nd.carved.resize(nn);
  for (std::size_t k = 0; k < nn; ++k) nd.carved[k] = nd.lake[k] ? nd.e[k] : nd.z[k];

  // Tiles where a channel may be: some land, and a count that may reach the threshold (the largest
  // local count plus all inflow from other tiles bounds every count). The others have no channel
  // whatever their neighbours do: no Strahler order, no carving, no cover, their perimeter values
  // stay the initial ones; pass S never solves them.
  std::vector<std::uint64_t> ext_sum(std::size_t(tiles), 0);
  for (std::size_t k = 0; k < nn; ++k) ext_sum[nd.tile[k]] += nd.ext[k];
  std::vector<std::uint8_t> may_channel(std::size_t(tiles), 0);
  for (std::size_t t = 0; t < std::size_t(tiles); ++t) {
    may_channel[t] = tile_land[t] && double(std::uint64_t(tile_max_acc[t]) + ext_sum[t]) >= c.threshold_cells;
    st.channel_tiles += may_channel[t];
  }
  std::shared_ptr<const std::vector<double>> hyp;  // c.hyp's table
  // each_cover's distances up to the widest river's disc radius (a bound: the largest local count
  // plus all inflow of a tile bounds its counts), when that table is at most 2^21 entries.
  {
    std::uint64_t bound = 0;
    for (std::size_t t = 0; t < std::size_t(tiles); ++t)
      if (may_channel[t]) bound = std::max(bound, std::uint64_t(tile_max_acc[t]) + ext_sum[t]);
    const double wmax = width(c, bound);
    if (bound > 0 && wmax > c.cell) {
      const double r = std::ceil(0.5 * wmax / c.cell + 0.5);
      if (r <= 1447) {
        c.hyp_r = int(r);
        hyp = hyp_table(c.hyp_r);
        c.hyp = hyp->data();
      }
    }
  }
  std::vector<std::uint64_t>().swap(ext_sum);

  // What a solve of tile t reads of the global state now (TileView).
  auto view_of = [&](std::int64_t t) {
    TileView v;
    const std::int64_t X = t % g.tiles_x, Z = t / g.tiles_x;
    const std::size_t node0 = std::size_t(nd.base[std::size_t(t)]), pn = std::size_t(nd.base[std::size_t(t) + 1]) - node0;
    v.ext.assign(nd.ext.begin() + std::ptrdiff_t(node0), nd.ext.begin() + std::ptrdiff_t(node0 + pn));
    v.donors.resize(pn);
    for (std::size_t q = 0; q < pn; ++q) {
      const std::size_t p = node0 + q;
      std::uint32_t n = 0;
      for (std::uint32_t k = nd.dstart[p]; k < nd.dstart[p + 1]; ++k) {
        const std::uint32_t d = nd.donors[k];
        if (!nd.channel[d]) continue;
        v.donor_str.push_back(nd.strahler[d]);
        ++n;
      }
      v.donors[q] = n;
    }
    const WorldGrid::Window w = g.window(X, Z);
    const int onx = int((X == g.tiles_x - 1 ? g.nx : w.ix0 + c.t1) - w.ix0), onz = int((Z == g.tiles_z - 1 ? g.nz : w.iz0 + c.t1) - w.iz0);
    v.ring.resize(TileView::slots(onx, onz));
    auto set = [&](int bi, int bj) {
      const std::int64_t ix = w.ix0 - 1 + bi, iz = w.iz0 - 1 + bj;
      if (ix < 0 || iz < 0 || ix >= g.nx || iz >= g.nz) return;
      const std::uint32_t k = nd.at(iz * g.nx + ix);
      RingNode& r = v.ring[TileView::slot(onx, onz, bi, bj)];
      r.carved = nd.carved[k], r.z = nd.z[k], r.lake = nd.lake[k], r.channel = nd.channel[k], r.chd = nd.chd[k];
      r.count = std::uint64_t(nd.acc[k]) + nd.inflow[k];
      r.root = nd.lake[k] ? comp.root(nd.comp[k]) : kNone;
    };
    for (int bi = 0; bi < onx + 2; ++bi) set(bi, 0), set(bi, onz + 1);
    for (int bj = 1; bj <= onz; ++bj) set(0, bj), set(onx + 1, bj);
    const std::uint64_t l0 = comp.base[std::size_t(t)], l1 = l0 + tile_labels[std::size_t(t)];
    for (std::uint64_t l = l0; l < l1; ++l) {
      const std::uint32_t root = comp.root(std::uint32_t(l));
      v.root.push_back(root);
      v.kept.push_back(comp.kept[root]);
    }
    return v;
  };

  // The tasks of passes S and final (one kind of task per pass, 'S' and 'F'; src/world_farm.hpp).
  auto task_input = [&](char kind, std::int64_t t) {
    InputSF in;
    in.kind = kind;
    in.ring = ring_of(g, bands, t % g.tiles_x, t / g.tiles_x, true);
    in.filled = filled != nullptr;
    if (in.filled) in.fill_ring = (*ff.fill_rings).at(std::size_t(t));
    in.view = view_of(t);
    in.first_round = st.rounds == 1;
    in.rivers = rivers != nullptr, in.lakes = lakes != nullptr, in.same_height = ff.same_height;
    in.hyp_r = c.hyp_r;
    return in;
  };

  // Pass S: Strahler orders downstream and carved heights upstream, until nothing changes. The
  // first round (every tile) also gathers the river cover that reaches beyond the owned rectangle
  // of its channel sample ("pass W"): it depends on counts, channels and lakes only, all known now.
  std::unordered_map<std::int64_t, float> cover_sea, cover_any;  // sea-tested discs, point covers
  // Rounds as the tiled fill's (src/world_fill.cpp): the four classes of tiles (X mod 2, Z mod 2)
  // in turn, each the class's tiles waiting for new perimeter values, solved concurrently. A
  // tile's solve reads the perimeter nodes of its neighbours' owned rectangles and its merge writes
  // those of its own; tiles of one class are never neighbours, so no solve reads what another
  // merge of its class writes. Orders only rise and carved heights only fall, so the rounds end at
  // the same values for any schedule; this one is fixed.
  std::vector<std::uint8_t> pending(may_channel);
  auto wake = [&](std::uint32_t t) {
    if (may_channel[t]) pending[t] = 1;
  };
  auto solve_s = [&](std::int64_t t) {
    check();
    return solve_s_tile(c, ring_of(g, bands, t % g.tiles_x, t / g.tiles_x, true), load, view_of(t), t, st.rounds == 1, pool);
  };
  detail::RoundProgress rounds(0.35, 0.35);  // pass S's rounds (progress)
  auto merge_s = [&](std::int64_t t, LocalS r) {
    ++st.tile_solves;
    if (progress) progress(rounds.step());
    for (auto [cell, v] : r.cover_sea) {
      float& slot = cover_sea.try_emplace(cell, 0.0f).first->second;
      slot = std::max(slot, v);
    }
    for (auto [cell, v] : r.cover_any) {
      float& slot = cover_any.try_emplace(cell, 0.0f).first->second;
      slot = std::max(slot, v);
    }
    const std::uint64_t node0 = nd.base[std::size_t(t)];
    for (std::size_t q = 0; q < r.chd.size(); ++q) {
      const std::uint64_t k = node0 + q;
      nd.chd[k] = r.chd[q];
      if (nd.cross[k] && nd.strahler[k] != r.str[q]) {
        nd.strahler[k] = r.str[q];
        wake(nd.tile[nd.link[k]]);
      }
      if (std::memcmp(&nd.carved[k], &r.ec[q], 4) != 0) {
        nd.carved[k] = r.ec[q];
        for (std::uint32_t d = nd.dstart[k]; d < nd.dstart[k + 1]; ++d) wake(nd.tile[nd.donors[d]]);
      }
    }
  };
  for (bool any = true; any;) {
    ++st.rounds;
    rounds.start(st.rounds, pending);
    for (int cls = 0; cls < 4; ++cls) {
      const std::vector<std::int64_t> batch = detail::take_tile_class(pending, g.tiles_x, cls);
      if (ff.farm)
        ff.farm->run(
            "flow", batch, [&](std::int64_t t) { return encode(task_input('S', t)); }, ff.kernel,
            [&](std::int64_t t, std::string bytes) {
              Decoder d{bytes};
              if (d.get<char>() != 's') d.bad("not a pass-S result");
              LocalS r = decode_result_s(d);
              if (r.chd.size() != std::size_t(nd.base[std::size_t(t) + 1] - nd.base[std::size_t(t)])) d.bad("a perimeter of another length");
              for (const CoverList* cv : {&r.cover_sea, &r.cover_any})
                for (const auto& [cell, v] : *cv)
                  if (cell < 0 || cell >= g.nx * g.nz) d.bad("a cover entry outside the world");
              merge_s(t, std::move(r));
            });
      else
        detail::ordered_tiles<LocalS>(batch, solve_s, merge_s);
    }
    any = std::find(pending.begin(), pending.end(), std::uint8_t(1)) != pending.end();
  }

  st.cover_cells = cover_sea.size() + cover_any.size();
  // The cover map by tile: each entry goes to every tile whose window holds its sample (up to 4:
  // windows share their borders), so that a tile reads its entries only.
  std::vector<std::vector<CoverEntry>> cover_of(static_cast<std::size_t>(tiles));
  auto bucket = [&](std::unordered_map<std::int64_t, float>& m, bool sea_test) {
    for (auto it = m.begin(); it != m.end(); it = m.erase(it)) {  // freed as bucketed
      const std::int64_t cell = it->first;
      const float v = it->second;
      const std::int64_t ix = cell % g.nx, iz = cell / g.nx;
      const std::int64_t X1 = std::min(ix / c.t1, g.tiles_x - 1), Z1 = std::min(iz / c.t1, g.tiles_z - 1);
      for (std::int64_t Z = std::max<std::int64_t>(0, Z1 - 1); Z <= Z1; ++Z)
        for (std::int64_t X = std::max<std::int64_t>(0, X1 - 1); X <= X1; ++X) {
          const WorldGrid::Window w = g.window(X, Z);
          if (ix >= w.ix0 && iz >= w.iz0 && ix < w.ix0 + w.nx && iz < w.iz0 + w.nz)
            cover_of[std::size_t(Z * g.tiles_x + X)].push_back({cell, v, sea_test});
        }
    }
  };
  bucket(cover_any, false);
  bucket(cover_sea, true);
  std::unordered_map<std::int64_t, float>().swap(cover_any);
  std::unordered_map<std::int64_t, float>().swap(cover_sea);

  // Final pass: each tile's layers (and the river pieces, the lakes' samples), solved concurrently;
  // stored and gathered in tile order.
  std::unordered_map<std::int64_t, Piece> pieces;
  std::unordered_map<std::uint32_t, std::unordered_map<std::int64_t, LakeSample>> lake_cells;  // by root
  std::vector<std::int64_t> starts;
  auto solve_f = [&](std::int64_t t) {
    check();
    return solve_f_tile(c, ring_of(g, bands, t % g.tiles_x, t / g.tiles_x, true), load, view_of(t), cover_of[std::size_t(t)], t,
                        rivers != nullptr, lakes != nullptr, pool);
  };
  auto merge_f = [&](std::int64_t t, LocalF r) {
    ++st.tile_solves;
    st.max_count = std::max(st.max_count, r.max_count);
    std::vector<CoverEntry>().swap(cover_of[std::size_t(t)]);
    for (auto& [at, pc] : r.pieces) pieces.emplace(at, std::move(pc));
    starts.insert(starts.end(), r.starts.begin(), r.starts.end());
    for (auto& [root, wc, ls] : r.lake) lake_cells[root].emplace(wc, ls);
    if (store && !ff.farm) store(t % g.tiles_x, t / g.tiles_x, std::move(r.out));  // else stored where solved
    report(0.7, 1.0, ++merged, tiles);
  };
  merged = 0;
  if (ff.farm)
    ff.farm->run(
        "flow", all_tiles,
        [&](std::int64_t t) {
          InputSF in = task_input('F', t);
          in.cover = cover_of[std::size_t(t)];
          return encode(in);
        },
        ff.kernel,
        [&](std::int64_t t, std::string bytes) {
          Decoder d{bytes};
          if (d.get<char>() != 'f') d.bad("not a final-pass result");
          LocalF r = decode_result_f(d);
          // Pieces, starts and lake samples are the tile's own samples (a malformed result is an
          // error here, not a river walk through samples no tile traced).
          const std::int64_t X = t % g.tiles_x, Z = t / g.tiles_x;
          const std::int64_t x1 = X == g.tiles_x - 1 ? g.nx : (X + 1) * c.t1, z1 = Z == g.tiles_z - 1 ? g.nz : (Z + 1) * c.t1;
          auto owned = [&](std::int64_t q) {
            if (q < 0 || q >= g.nx * g.nz) return false;
            const std::int64_t ix = q % g.nx, iz = q / g.nx;
            return ix >= X * c.t1 && ix < x1 && iz >= Z * c.t1 && iz < z1;
          };
          for (const auto& [at, pc] : r.pieces)
            if (!owned(at) || (pc.next != -1 && (pc.next < 0 || pc.next >= g.nx * g.nz))) d.bad("a river piece outside its tile");
          for (const std::int64_t q : r.starts)
            if (!owned(q) || !r.pieces.count(q)) d.bad("a river start outside its tile's pieces");
          for (const auto& lk : r.lake)
            if (!owned(std::get<1>(lk))) d.bad("a lake sample outside its tile");
          merge_f(t, std::move(r));
        });
  else
    detail::ordered_tiles<LocalF>(all_tiles, solve_f, merge_f);
  if (lakes) {
    // Lakes in the order of their first sample (row-major), as apply_flow's scan numbers them.
    std::vector<std::pair<std::int64_t, std::uint32_t>> seeds;
    for (auto& [root, cells_of] : lake_cells) {
      std::int64_t first = std::numeric_limits<std::int64_t>::max();
      for (auto& [q, ls] : cells_of) first = std::min(first, q);
      seeds.emplace_back(first, root);
    }
    std::sort(seeds.begin(), seeds.end());
    lakes->clear();
    for (auto& [first, root] : seeds) lakes->push_back(lake_record(c, lake_cells.at(root), first));
  }
  if (rivers) {
    // Whole polylines: each start's piece, followed into the tiles it continues in; in the order
    // of the start samples (row-major world index), as apply_flow's scan finds them.
    std::sort(starts.begin(), starts.end());
    rivers->clear();
    for (const std::int64_t s0 : starts) {
      River river;
      std::int64_t at = s0;
      for (std::size_t steps = 0;; ++steps) {
        const auto it = pieces.find(at);
        if (it == pieces.end()) throw Error("world", "flow: internal error, a river piece is missing");
        if (steps == pieces.size()) throw Error("world", "flow: internal error, a river's pieces form a loop");
        Piece& pc = it->second;
        if (at == s0) river.order = pc.order;
        river.vertices.insert(river.vertices.end(), pc.vertices.begin(), pc.vertices.end());
        if (pc.next < 0) {
          river.end = pc.end;
          break;
        }
        at = pc.next;
      }
      if (river.vertices.size() >= 2) rivers->push_back(std::move(river));
    }
    st.river_pieces = pieces.size();
  }
  if (progress) progress(1.0);
  return st;
}
}  // namespace

TiledFlowStats flow_tiled(const WorldGrid& g, const Frame& f, const WorldFlowParams& p, const TileLoad& load,
                          const FlowTileStore& store, std::vector<River>* rivers, const std::function<bool()>& cancelled,
                          const std::string& path, const TileLoad& filled, std::vector<Lake>* lakes) {
  return flow_tiled_with_progress(g, f, p, load, store, rivers, cancelled, path, filled, lakes, {});
}

namespace {
// Tile (X, Z)'s flow layers stored through a build's io; `same_height`: the stored height stays as
// it is.
void store_flow_tile(const WorldStageIO& io, bool same_height, std::int64_t X, std::int64_t Z, FlowTile ft) {
  WorldTile t;
  if (!io.update) t = io.load(X, Z);
  if (!(same_height && io.update)) t.layers["height"] = Layer{1, std::move(ft.height)};
  t.layers["flow"] = Layer{1, std::move(ft.flow)};
  t.layers["water"] = Layer{1, std::move(ft.water)};
  if (io.update) io.update(X, Z, std::move(t));
  else io.store(X, Z, std::move(t));
}
}  // namespace

WorldStageAlgorithm world_flow(WorldWaterSink water) {
  return [water](const WorldStageIO& io, const RecipeStage& st, int index) {
    const WorldFlowParams p = world_flow_params(st.stage->params());
    const WorldGrid& g = io.grid;
    // Only the height is decoded, and only the layers the stage writes are coded (io.update copies
    // the other layers' coded bytes through), when the build gives those calls.
    const TileLoad load = [&](std::int64_t X, std::int64_t Z) {
      if (io.load_layers) return std::move(io.load_layers(X, Z, {"height"}).layers.at("height").data);
      return io.load(X, Z).layers.at("height").data;
    };
    // Without carving, on a height that drains, the stage's height is its input, bit for bit: the
    // stored height stays as it is (its coded bytes copied through by io.update, not coded again).
    bool same_height = p.carve_depth_coeff <= 0;
    const FlowTileStore store = [&](std::int64_t X, std::int64_t Z, FlowTile ft) { store_flow_tile(io, same_height, X, Z, std::move(ft)); };
    // In a build (src/world_farm.hpp): the tile solves run on every rank (one rank without MPI).
    const detail::FarmKernel kernel = io.farm ? detail::flow_farm_kernel(io, st) : detail::FarmKernel();
    const std::string path = "stages[" + std::to_string(index) + "]";
    std::vector<River> rivers;
    std::vector<Lake> lakes;
    // The world's rivers and lakes go to the sink, else into the world folder (rivers.json, lakes.json).
    const bool want_water = water || io.out;
    // Progress: the first attempt spans [0, 1]; when it finds a height that does not drain, the
    // fill and the second attempt share what is left after the largest share it reported.
    double reached = 0;
    auto span = [&](double lo, double hi) -> std::function<void(double)> {
      if (!io.progress) return {};
      return [&io, &reached, lo, hi](double x) {
        reached = std::max(reached, lo + (hi - lo) * x);
        io.progress(reached);
      };
    };
    try {
      flow_tiled_with_progress(g, io.world, p, load, store, want_water ? &rivers : nullptr, io.cancelled, path, {},
                               want_water ? &lakes : nullptr, span(0.0, 1.0), FlowFarm{io.farm, nullptr, kernel, same_height});
    } catch (const NotDraining&) {
      same_height = false;  // filled, and lake floors under their water
      const double from = reached, mid = reached + (1.0 - reached) * 0.4;
      // No fill stage before this one: fill as apply_flow does (fill_depressions_tiled gives the
      // whole world's hydro::fill_depressions). Only each tile's final border levels are kept; a
      // tile's filled heights are then one tile solve seeded with them (the solve that stored it).
      const float sea = float(io.world.sea_level), eps = float(p.epsilon_m / io.world.height_m);
      auto ring_of = [](const WorldGrid::Window& w, const std::vector<float>& f) {
        std::vector<float> r;
        for (int j = 0; j < w.nz; ++j)
          for (int i = 0; i < w.nx; ++i)
            if (i == 0 || j == 0 || i == w.nx - 1 || j == w.nz - 1) r.push_back(f[std::size_t(j) * std::size_t(w.nx) + std::size_t(i)]);
        return r;
      };
      std::vector<std::vector<float>> rings(std::size_t(g.count()));
      const TileLoad fill_load = [&](std::int64_t X, std::int64_t Z) {
        if (io.cancelled && io.cancelled()) throw Cancelled();
        return load(X, Z);
      };
      if (io.farm) {
        // In a build: the fill's tile solves run on every rank too ("flow-fill": this stage's sea
        // level and epsilon, nothing stored), each result being the ring kept here.
        detail::fill_perimeters_on_farm(g, sea, eps, *io.farm, "flow-fill", detail::flow_fill_farm_kernel(io, st), span(from, mid),
                                        [&](std::int64_t t, std::vector<float> r) { rings[std::size_t(t)] = std::move(r); });
      } else {
        fill_depressions_tiled(
            g, sea, eps, fill_load,
            [&](std::int64_t X, std::int64_t Z, std::vector<float> f) { rings[std::size_t(Z * g.tiles_x + X)] = ring_of(g.window(X, Z), f); },
            span(from, mid));
      }
      const TileLoad filled = [&](std::int64_t X, std::int64_t Z) {
        return filled_from_ring(g, sea, eps, X, Z, load(X, Z), rings[std::size_t(Z * g.tiles_x + X)]);
      };
      flow_tiled_with_progress(g, io.world, p, load, store, want_water ? &rivers : nullptr, io.cancelled, path, filled,
                               want_water ? &lakes : nullptr, span(mid, 1.0), FlowFarm{io.farm, &rings, kernel, same_height});
    }
    if (water) water(io.world, std::move(rivers), std::move(lakes));
    else if (io.out) write_world_water(io.world, rivers, lakes, *io.out);
  };
}

namespace detail {
FarmKernel flow_farm_kernel(const WorldStageIO& io, const RecipeStage& st) {
  const WorldFlowParams p = world_flow_params(st.stage->params());
  const TileLoad load = [&io](std::int64_t X, std::int64_t Z) {  // as world_flow's
    if (io.load_layers) return std::move(io.load_layers(X, Z, {"height"}).layers.at("height").data);
    return io.load(X, Z).layers.at("height").data;
  };
  return flow_kernel(
      io.grid, io.world, p, load,
      [&io](std::int64_t X, std::int64_t Z, FlowTile ft, bool same_height) { store_flow_tile(io, same_height, X, Z, std::move(ft)); },
      io.cancelled);
}
// world_flow's fallback fill (a height that does not drain): fill_kernel with this stage's sea level
// and epsilon, the heights as world_flow's fill loads them, nothing stored.
FarmKernel flow_fill_farm_kernel(const WorldStageIO& io, const RecipeStage& st) {
  const WorldFlowParams p = world_flow_params(st.stage->params());
  const float sea = float(io.world.sea_level), eps = float(p.epsilon_m / io.world.height_m);  // as world_flow
  const TileLoad load = [&io](std::int64_t X, std::int64_t Z) {
    if (io.cancelled && io.cancelled()) throw Cancelled();
    if (io.load_layers) return std::move(io.load_layers(X, Z, {"height"}).layers.at("height").data);
    return io.load(X, Z).layers.at("height").data;
  };
  return fill_perimeter_kernel(io.grid, sea, eps, load);
}
}  // namespace detail

void write_world_water(const Frame& world, const std::vector<River>& rivers, const std::vector<Lake>& lakes, Output& out) {
  Terrain t;
  t.frame = world;
  t.layers["flow"] = Layer{1, {}};  // the writers' sign of a flow stage; they read no samples
  t.rivers = rivers;
  t.lakes = lakes;
  const WriteContext ctx;
  for (const WriterDef& w : water_writers()) w.write(t, ctx, out);
}

}  // namespace relief
