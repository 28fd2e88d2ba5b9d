// Depression filling over a tiled world, exactly (relief/world.hpp, issue 18).
//
// Sources:
//   Barnes 2016, "Parallel Priority-Flood depression filling for trillion cell digital elevation
//     models on desktops or clusters", Environmental Modelling & Software 86 (tiles solve locally
//     and exchange only their perimeters);
//   Knuth 1977, "A generalization of Dijkstra's algorithm" (superior functions: Dijkstra's order
//     finds the least fixpoint of any path cost that never decreases along a path).
//
// hydro::fill_depressions defines the filled surface as the least solution of a fixpoint equation
// (relief/hydrology.hpp), which any order of relaxation reaches. So a sequence of exact tile solves
// (hydro::fill_depressions_tile), each seeded with the levels its neighbours found for the samples
// they share, exchanged until no shared level changes, gives the whole map's surface bit for bit:
// every level a tile solve gives is that of a real path (never below the least solution), and at
// convergence every sample satisfies the equation on both sides of every tile border.
//
// Unlike Barnes 2016, which solves a graph of tile-perimeter spill levels on one node and then
// finishes each tile once, this exchanges border levels in rounds: simpler, the same in memory (the
// tiles being solved and the border lines), and each tile is usually solved two or three times.
// Each round visits the four classes of tiles (X mod 2, Z mod 2) in turn, like a red-black
// Gauss-Seidel sweep: the tiles of one class share no sample, so they are solved concurrently, and
// the levels one class finds reach the next class within the same round.
//
// Distributed builds (src/world_farm.hpp): the tile solves of each class run on every rank. A solve's
// input is the tile's perimeter levels known so far (4·(T−1) floats), its result the filled tile's
// perimeter; the rank that solves a tile stores it. Rank 0 keeps the border lines and the schedule.
#include <algorithm>
#include <cstring>
#include <limits>

#include "relief/error.hpp"
#include "relief/hydrology.hpp"
#include "relief/world.hpp"
#include "world_farm.hpp"
#include "world_internal.hpp"

namespace relief {
namespace {
constexpr float kInf = std::numeric_limits<float>::infinity();

bool on_perimeter(const WorldGrid::Window& w, int i, int j) { return i == 0 || j == 0 || i == w.nx - 1 || j == w.nz - 1; }

// Tile (X, Z)'s heights `filled` (as load gives them) filled, its perimeter seeded with `border`
// (the levels known for the window's perimeter samples, in row-major order).
void solve_tile(const WorldGrid& g, float sea, float epsilon, std::int64_t X, std::int64_t Z, std::vector<float>& filled,
                const float* border) {
  const WorldGrid::Window w = g.window(X, Z);
  const std::size_t n = std::size_t(w.nx) * std::size_t(w.nz);
  if (filled.size() != n)
    throw Error("world", "fill: tile " + std::to_string(X) + "," + std::to_string(Z) + " has " + std::to_string(filled.size()) +
                             " heights, expected " + std::to_string(n));
  std::vector<std::uint8_t> outlet(n);
  std::vector<float> f(n, kInf);
  std::size_t b = 0;
  for (int j = 0; j < w.nz; ++j)
    for (int i = 0; i < w.nx; ++i) {
      const std::int64_t ix = w.ix0 + i, iz = w.iz0 + j;
      const std::size_t c = std::size_t(j) * std::size_t(w.nx) + std::size_t(i);
      outlet[c] = ix == 0 || iz == 0 || ix == g.nx - 1 || iz == g.nz - 1 || filled[c] < sea;
      if (on_perimeter(w, i, j)) f[c] = border[b++];
    }
  hydro::fill_depressions_tile<float>(filled.data(), w.nx, w.nz, outlet.data(), f.data(), epsilon);
}

// The perimeter samples of tile (X, Z)'s window in row-major order, from its values `f`, as bytes.
std::string perimeter_bytes(const WorldGrid& g, std::int64_t X, std::int64_t Z, const std::vector<float>& f) {
  const WorldGrid::Window w = g.window(X, Z);
  std::vector<float> p;
  p.reserve(2 * std::size_t(w.nx + w.nz));
  for (int j = 0; j < w.nz; ++j)
    for (int i = 0; i < w.nx; ++i)
      if (on_perimeter(w, i, j)) p.push_back(f[std::size_t(j) * std::size_t(w.nx) + std::size_t(i)]);
  return std::string(reinterpret_cast<const char*>(p.data()), p.size() * sizeof(float));
}
std::size_t perimeter_count(const WorldGrid::Window& w) {
  return w.nx == 1 || w.nz == 1 ? std::size_t(w.nx) * std::size_t(w.nz) : 2 * std::size_t(w.nx + w.nz) - 4;
}
std::vector<float> floats_of(std::string_view bytes, std::size_t count, const char* what) {
  if (bytes.size() != count * sizeof(float))
    throw Error("world", std::string("fill: a malformed farm message: ") + what + " of " + std::to_string(bytes.size()) + " bytes, expected " +
                             std::to_string(count * sizeof(float)));
  std::vector<float> v(count);
  std::memcpy(v.data(), bytes.data(), bytes.size());
  return v;
}

// The farm kernel of a fill solve (src/world_farm.hpp): input and result are perimeter levels; the
// filled tile goes to `store` here.
detail::FarmKernel fill_kernel(const WorldGrid& g, float sea, float epsilon, const TileLoad& load, const TileStore& store) {
  return [=](std::int64_t t, std::string_view input) {
    if (t < 0 || t >= g.count()) throw Error("world", "fill: a malformed farm task for tile " + std::to_string(t) + ", outside the world");
    const std::int64_t X = t % g.tiles_x, Z = t / g.tiles_x;
    const std::vector<float> border = floats_of(input, perimeter_count(g.window(X, Z)), "a fill task's perimeter");
    std::vector<float> filled = load(X, Z);
    solve_tile(g, sea, epsilon, X, Z, filled, border.data());
    std::string out = perimeter_bytes(g, X, Z, filled);
    if (store) store(X, Z, std::move(filled));
    return out;
  };
}

// `farm`: the solves run as its tasks named `kernel_name`, here by `local` (if empty, fill_kernel with
// `store`); `ring` (if any) gets each solve's filled perimeter (row-major), in merge order.
TiledFillStats fill_tiled(const WorldGrid& g, float sea, float epsilon, const TileLoad& load, const TileStore& store,
                          const std::function<void(double)>& progress, detail::TileFarm* farm, const std::string& kernel_name = "fill",
                          const detail::FarmKernel& local = {}, const std::function<void(std::int64_t, std::vector<float>)>& ring = {}) {
  TiledFillStats st;
  detail::RoundProgress rounds(0.0, 1.0);  // progress (relief/world.hpp)
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
  auto known = [&](std::int64_t ix, std::int64_t iz) -> float {
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
  // Tiles waiting for a solve with new border levels; at first, every tile.
  std::vector<std::uint8_t> pending(std::size_t(tiles), 1);
  // One tile's solve: its heights filled from the border levels known now. Tiles of one class
  // (X mod 2, Z mod 2) share no sample: while a class is solved, only the merges of the class's
  // tiles change border levels, each those of its own samples, which no other tile of the class reads.
  // The levels known now for tile t's perimeter samples, in row-major order.
  auto border_of = [&](std::int64_t t) {
    const WorldGrid::Window w = g.window(t % g.tiles_x, t / g.tiles_x);
    std::vector<float> b;
    b.reserve(perimeter_count(w));
    for (int j = 0; j < w.nz; ++j)
      for (int i = 0; i < w.nx; ++i)
        if (on_perimeter(w, i, j)) b.push_back(known(w.ix0 + i, w.iz0 + j));
    return b;
  };
  auto solve = [&](std::int64_t t) {
    std::vector<float> filled = load(t % g.tiles_x, t / g.tiles_x);
    solve_tile(g, sea, epsilon, t % g.tiles_x, t / g.tiles_x, filled, border_of(t).data());
    return filled;
  };
  // After a solve, in tile order: new border levels (`f`: the filled perimeter in row-major order)
  // wake the neighbours that share them.
  auto merge_border = [&](std::int64_t t, const std::vector<float>& f) {
    const std::int64_t X = t % g.tiles_x, Z = t / g.tiles_x;
    const WorldGrid::Window w = g.window(X, Z);
    ++st.tile_solves;
    std::size_t b = 0;
    for (int j = 0; j < w.nz; ++j)
      for (int i = 0; i < w.nx; ++i) {
        if (!on_perimeter(w, i, j)) continue;
        const std::int64_t ix = w.ix0 + i, iz = w.iz0 + j;
        if (!lower(ix, iz, f[b++])) continue;
        for (std::int64_t dz = -1; dz <= 1; ++dz)
          for (std::int64_t dx = -1; dx <= 1; ++dx) {
            const std::int64_t XX = X + dx, ZZ = Z + dz;
            if ((dx == 0 && dz == 0) || XX < 0 || ZZ < 0 || XX >= g.tiles_x || ZZ >= g.tiles_z) continue;
            const WorldGrid::Window o = g.window(XX, ZZ);
            if (ix >= o.ix0 && ix < o.ix0 + o.nx && iz >= o.iz0 && iz < o.iz0 + o.nz) pending[std::size_t(ZZ * g.tiles_x + XX)] = 1;
          }
      }
    if (progress) progress(rounds.step());
  };
  auto merge = [&](std::int64_t t, std::vector<float> f) {
    const std::int64_t X = t % g.tiles_x, Z = t / g.tiles_x;
    const WorldGrid::Window w = g.window(X, Z);
    std::vector<float> p;
    p.reserve(perimeter_count(w));
    for (int j = 0; j < w.nz; ++j)
      for (int i = 0; i < w.nx; ++i)
        if (on_perimeter(w, i, j)) p.push_back(f[std::size_t(j) * std::size_t(w.nx) + std::size_t(i)]);
    if (store) store(X, Z, std::move(f));
    merge_border(t, p);
  };
  // In a build (src/world_farm.hpp): the solves run on every rank (one rank without MPI), each storing its
  // tile; only perimeters come back here.
  const bool spread = farm != nullptr;
  const detail::FarmKernel kernel = !spread ? detail::FarmKernel() : local ? local : fill_kernel(g, sea, epsilon, load, store);
  auto border_input = [&](std::int64_t t) {
    const std::vector<float> b = border_of(t);
    return std::string(reinterpret_cast<const char*>(b.data()), b.size() * sizeof(float));
  };
  auto merge_result = [&](std::int64_t t, std::string bytes) {
    std::vector<float> f = floats_of(bytes, perimeter_count(g.window(t % g.tiles_x, t / g.tiles_x)), "a fill result's perimeter");
    merge_border(t, f);
    if (ring) ring(t, std::move(f));
  };
  // Rounds: the four classes in turn, each the pending tiles of the class in tile order (a fixed
  // schedule: the same solves and calls for any thread count).
  for (bool any = true; any;) {
    ++st.rounds;
    rounds.start(st.rounds, pending);
    for (int cls = 0; cls < 4; ++cls) {
      const std::vector<std::int64_t> batch = detail::take_tile_class(pending, g.tiles_x, cls);
      if (spread)
        farm->run(kernel_name, batch, border_input, kernel, merge_result);
      else
        detail::ordered_tiles<std::vector<float>>(batch, solve, merge);
    }
    any = std::find(pending.begin(), pending.end(), std::uint8_t(1)) != pending.end();
  }
  if (progress) progress(1.0);
  return st;
}
}  // namespace

TiledFillStats fill_depressions_tiled(const WorldGrid& g, float sea, float epsilon, const TileLoad& load, const TileStore& store,
                                      const std::function<void(double)>& progress) {
  return fill_tiled(g, sea, epsilon, load, store, progress, nullptr);
}

}  // namespace relief

namespace relief {

namespace {
// The fill stage's reading and writing of tiles through a build's io.
struct FillIO {
  float eps = 0, sea = 0;
  TileLoad load;
  TileStore store;
};
FillIO fill_io(const WorldStageIO& io, const RecipeStage& st) {
  FillIO f;
  const json p = st.stage->params();
  // As the fill stage converts its parameter (src/stage_erosion.cpp).
  f.eps = float(p.value("epsilon_m", 0.0) / io.world.height_m);
  f.sea = float(io.world.sea_level);
  // Only the height is decoded, and only it is coded again (io.update copies the other layers'
  // coded bytes through), when the build gives those calls.
  f.load = [&io](std::int64_t X, std::int64_t Z) {
    if (io.cancelled && io.cancelled()) throw Cancelled();
    if (io.load_layers) return std::move(io.load_layers(X, Z, {"height"}).layers.at("height").data);
    return io.load(X, Z).layers.at("height").data;
  };
  f.store = [&io](std::int64_t X, std::int64_t Z, std::vector<float> h) {
    if (io.update) {
      WorldTile t;
      t.layers["height"] = Layer{1, std::move(h)};
      io.update(X, Z, std::move(t));
      return;
    }
    WorldTile t = io.load(X, Z);  // every other layer as the stages before left it
    t.layers.at("height").data = std::move(h);
    io.store(X, Z, std::move(t));
  };
  return f;
}
}  // namespace

WorldStageAlgorithm world_fill() {
  return [](const WorldStageIO& io, const RecipeStage& st, int) {
    const FillIO f = fill_io(io, st);
    fill_tiled(io.grid, f.sea, f.eps, f.load, f.store, io.progress, io.farm);
  };
}

namespace detail {
FarmKernel fill_perimeter_kernel(const WorldGrid& g, float sea, float epsilon, const TileLoad& load) {
  return fill_kernel(g, sea, epsilon, load, TileStore());
}
TiledFillStats fill_perimeters_on_farm(const WorldGrid& g, float sea, float epsilon, TileFarm& farm, const std::string& kernel,
                                       const FarmKernel& local, const std::function<void(double)>& progress,
                                       const std::function<void(std::int64_t, std::vector<float>)>& ring) {
  if (!local) throw Error("world", "fill: internal error, a farm without its kernel");
  return fill_tiled(g, sea, epsilon, TileLoad(), TileStore(), progress, &farm, kernel, local, ring);
}
FarmKernel fill_farm_kernel(const WorldStageIO& io, const RecipeStage& st) {
  const FillIO f = fill_io(io, st);
  return fill_kernel(io.grid, f.sea, f.eps, f.load, f.store);
}
}  // namespace detail

}  // namespace relief
