// World algorithms for the feature stages: a volcano placed on land and `features`, exact over a
// tiled world (relief/world_features.hpp, issue 18).
//
// The decisions and effects are the whole-map stages' own (detail::VolcanoPlan, detail::FeaturesPlan
// in src/stage_features.cpp); this file reads the samples they ask for from the stored tiles, a tile
// at a time, and applies their effects to every tile. Sources: those of src/stage_features.cpp
// (Feldmann 2022, Kamal & Uddin 2007, Melosh 1989).
//
// Reads. A bilinear probe reads the 2 × 2 block whose first sample is (i0, j0) (world indices,
// detail::bilinear_cell on the world's frame, 0 ≤ i0 ≤ nx − 2). Tiles share their border samples, so
// the block lies wholly in tile X = min(i0 / (T − 1), tiles_x − 1) (and likewise along z): the block
// is read there, at the same world indices with the same weights as the whole map reads it. The
// tile is chosen from the block, never from the probe's position, so a probe exactly on a tile border
// (a weight of 0 or 1) reads the whole map's samples, not the neighbour's clamped ones. A nearest
// probe reads one sample (detail::nearest_sample), in the tile holding it.
#include "relief/world_features.hpp"

#include <algorithm>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "relief/error.hpp"
#include "relief/pipeline.hpp"

namespace relief {
namespace {

using detail::XZ;

void check_cancelled(const WorldStageIO& io) {
  if (io.cancelled && io.cancelled()) throw Cancelled();
}

// A loaded tile as a Terrain on the world's frame (its layers moved in, then back out).
Terrain as_terrain(const WorldStageIO& io, WorldTile& tile) {
  Terrain t;
  t.frame = io.world.window(tile.window.ix0, tile.window.iz0, tile.window.nx, tile.window.nz);
  t.layers = std::move(tile.layers);
  return t;
}

// The tile holding a world sample as the first of a block (bilinear) or alone (nearest).
std::int64_t tile_index(const WorldGrid& g, std::int64_t ix, std::int64_t iz) {
  const std::int64_t X = std::min(ix / (g.tile - 1), g.tiles_x - 1), Z = std::min(iz / (g.tile - 1), g.tiles_z - 1);
  return Z * g.tiles_x + X;
}

const Layer& layer_of(const Terrain& t, const std::string& name, const std::string& path) {
  const auto it = t.layers.find(name);
  if (it == t.layers.end()) throw Error(path, "the stored tiles have no layer '" + name + "'");
  if (it->second.data.size() != t.frame.count() * std::size_t(it->second.channels))
    throw Error(path, "layer '" + name + "' of a stored tile does not match the tile");
  return it->second;
}

// The whole map's bilinear read of `l` (channel 0) at `p`, from a window that holds its block.
double bilinear_in(const Frame& world, const Terrain& t, const Layer& l, XZ p) {
  const detail::BilinearCell c = detail::bilinear_cell(world, p.x_m, p.z_m);
  const std::int64_t i = c.i0 - t.frame.ix0, j = c.j0 - t.frame.iz0;
  if (i < 0 || j < 0 || i + 1 >= t.frame.nx || j + 1 >= t.frame.nz) throw Error("world", "a bilinear probe outside its tile");
  auto at = [&](std::int64_t a, std::int64_t b) {
    return double(l.data[(std::size_t(b) * std::size_t(t.frame.nx) + std::size_t(a)) * std::size_t(l.channels)]);
  };
  return detail::bilinear_mix(c, at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
}

// Tile (X, Z) holding only the named layers (load_layers when the build gives it, else load).
WorldTile load_some(const WorldStageIO& io, std::int64_t X, std::int64_t Z, const std::vector<std::string>& names) {
  if (io.load_layers) return io.load_layers(X, Z, names);
  WorldTile t = io.load(X, Z);
  std::map<std::string, Layer> kept;
  for (const std::string& n : names)
    if (t.layers.count(n)) kept[n] = std::move(t.layers.at(n));
  t.layers = std::move(kept);
  return t;
}

// Probes of the stored world, read a tile at a time: each probe a bilinear read of one layer or a
// nearest read of another, grouped by the tile holding its samples; every such tile loaded once.
class Probes {
 public:
  Probes(const WorldStageIO& io, std::string path) : io_(io), path_(std::move(path)) {
    if (io.world.ix0 != 0 || io.world.iz0 != 0) throw Error(path_, "the world frame must start at sample (0, 0)");
  }
  std::size_t bilinear(XZ p) { return add(p, false); }
  std::size_t nearest(XZ p) { return add(p, true); }
  std::size_t size() const { return probes_.size(); }
  // The values of every probe, in the order added: bilinear reads of `bilinear_layer`, nearest reads
  // of `nearest_layer` (as doubles: a float converts exactly). `before` transforms each loaded tile
  // first (to read the heights after an effect).
  std::vector<double> read(const std::string& bilinear_layer, const std::string& nearest_layer,
                           const std::function<void(Terrain&)>& before = {}) const {
    std::vector<double> out(probes_.size());
    std::vector<std::string> layers;
    for (const Probe& q : probes_) {
      const std::string& name = q.nearest ? nearest_layer : bilinear_layer;
      if (std::find(layers.begin(), layers.end(), name) == layers.end()) layers.push_back(name);
    }
    std::vector<std::size_t> order(probes_.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return probes_[a].tile < probes_[b].tile; });
    for (std::size_t k = 0; k < order.size();) {
      const std::int64_t tile = probes_[order[k]].tile;
      check_cancelled(io_);
      WorldTile wt = load_some(io_, tile % io_.grid.tiles_x, tile / io_.grid.tiles_x, layers);
      Terrain t = as_terrain(io_, wt);
      if (before) before(t);
      for (; k < order.size() && probes_[order[k]].tile == tile; ++k) {
        const Probe& q = probes_[order[k]];
        if (q.nearest) {
          const Layer& l = layer_of(t, nearest_layer, path_);
          const detail::NearestSample n = detail::nearest_sample(io_.world, q.at.x_m, q.at.z_m);
          const std::size_t i = std::size_t(n.i - t.frame.ix0), j = std::size_t(n.j - t.frame.iz0);
          out[order[k]] = double(l.data[(j * std::size_t(t.frame.nx) + i) * std::size_t(l.channels)]);
        } else {
          out[order[k]] = bilinear_in(io_.world, t, layer_of(t, bilinear_layer, path_), q.at);
        }
      }
    }
    return out;
  }

 private:
  struct Probe {
    XZ at;
    bool nearest = false;
    std::int64_t tile = 0;
  };
  std::size_t add(XZ p, bool nearest) {
    Probe q{p, nearest, 0};
    if (nearest) {
      const detail::NearestSample n = detail::nearest_sample(io_.world, p.x_m, p.z_m);
      q.tile = tile_index(io_.grid, n.i, n.j);
    } else {
      const detail::BilinearCell c = detail::bilinear_cell(io_.world, p.x_m, p.z_m);
      q.tile = tile_index(io_.grid, c.i0, c.j0);
    }
    probes_.push_back(q);
    return probes_.size() - 1;
  }
  const WorldStageIO& io_;
  std::string path_;
  std::vector<Probe> probes_;
};

// Every tile, in row-major order: the named layers loaded, transformed by `f`, and the tile stored
// once with the layers `f` left (the loaded ones and any it made) in place of the input's; the
// other layers pass through unchanged (update when the build gives it, else load and store). A tile
// that `touches` says `f` would leave unchanged loads no layer: `untouched` gets it empty (to add
// what `f` would create there) and only what it adds is stored in place. Progress
// (WorldStageIO::progress): from `from` (reported first: the work before this pass) to 1, a step
// per tile stored.
void each_tile(const WorldStageIO& io, const std::vector<std::string>& names, const std::function<void(Terrain&)>& f,
               const std::function<bool(const Frame&)>& touches, const std::function<void(Terrain&)>& untouched, double from) {
  if (io.progress) io.progress(from);
  std::int64_t stored = 0;
  for (std::int64_t Z = 0; Z < io.grid.tiles_z; ++Z)
    for (std::int64_t X = 0; X < io.grid.tiles_x; ++X) {
      check_cancelled(io);
      const WorldGrid::Window w = io.grid.window(X, Z);
      const bool touched = touches(io.world.window(w.ix0, w.iz0, w.nx, w.nz));
      WorldTile wt = load_some(io, X, Z, touched ? names : std::vector<std::string>{});
      Terrain t = as_terrain(io, wt);
      if (touched)
        f(t);
      else
        untouched(t);
      if (io.update) {
        wt.layers = std::move(t.layers);
        io.update(X, Z, std::move(wt));
      } else {
        WorldTile full = io.load(X, Z);
        for (auto& [name, l] : t.layers) full.layers[name] = std::move(l);
        io.store(X, Z, std::move(full));
      }
      if (io.progress) io.progress(from + (1.0 - from) * double(++stored) / double(io.grid.count()));
    }
}

// The names among `wanted` of the layers the stored tiles hold (tile (0, 0)'s: every tile holds the
// same ones).
std::vector<std::string> stored_layers(const WorldStageIO& io, const std::vector<std::string>& wanted) {
  const WorldTile t = io.load(0, 0);
  std::vector<std::string> out;
  for (const std::string& n : wanted)
    if (t.layers.count(n)) out.push_back(n);
  return out;
}

Context context_of(const WorldStageIO& io, int index) {
  Context ctx;
  ctx.seed = io.seed;
  ctx.stage_index = index;
  return ctx;
}

}  // namespace

WorldStageAlgorithm world_volcano(std::shared_ptr<std::vector<BiomeInfo>> legend) {
  return [legend](const WorldStageIO& io, const RecipeStage& st, int index) {
    const std::string path = "stages[" + std::to_string(index) + "]";
    detail::VolcanoPlan plan(st.stage->params(), io.world, context_of(io, index), path);
    const std::vector<std::string> layers = stored_layers(io, {"height", "volcano", "albedo", "biome"});
    // The legend before the stage: the caller's, else the one build_world gives (WorldStageIO::legend).
    const std::vector<BiomeInfo>& before = legend ? *legend : io.legend;
    if (before.empty() && std::find(layers.begin(), layers.end(), "biome") != layers.end())
      throw Error(path, "the volcano numbers its biomes in the legend of the stages before it, which this world build "
                        "does not give (WorldStageIO::legend, or world_volcano(legend), relief/world_features.hpp)");
    // 1. The place: the candidates' land probes.
    if (plan.on_land()) {
      Probes probes(io, path);
      for (const XZ& p : plan.candidate_probes()) probes.bilinear(p);
      plan.choose(probes.read("height", ""));
    }
    // 2. The lava level: heights after the volcano's shape at the rim and the centre.
    {
      Probes probes(io, path);
      for (const XZ& p : plan.lava_probes()) probes.bilinear(p);
      plan.set_lava(probes.read("height", "", [&](Terrain& t) { plan.shape(t); }));
    }
    // 3. Every tile, shaped and coloured; the legend grows as the whole map's does (the same ids in
    // every tile).
    std::vector<BiomeInfo> biomes = before;
    const bool has_mask = std::find(layers.begin(), layers.end(), "volcano") != layers.end();
    each_tile(
        io, layers,
        [&](Terrain& t) {
          t.biomes = biomes;
          plan.apply(t);
          biomes = std::move(t.biomes);
        },
        [&](const Frame& w) { return plan.touches(w); },
        [&](Terrain& t) {
          if (!has_mask) t.layer("volcano", 1);  // the footprint the volcano creates everywhere: 0 here
        },
        0.1);  // the probes before: a few tiles' reads
    if (legend) *legend = std::move(biomes);
    if (io.points) io.points({plan.point()});
  };
}

WorldStageAlgorithm world_features() {
  return [](const WorldStageIO& io, const RecipeStage& st, int index) {
    const std::string path = "stages[" + std::to_string(index) + "]";
    const std::vector<std::string> layers = stored_layers(io, {"height", "albedo", "volcano"});
    const bool volcano = std::find(layers.begin(), layers.end(), "volcano") != layers.end();
    detail::FeaturesPlan plan(st.stage->params(), io.world, context_of(io, index), path, volcano);
    // 1. Placement: the predicates of a batch of attempts read at once (both sizes of each attempt).
    const std::size_t n_land = plan.land_probes(0, true).size(), n_volcano = plan.volcano_probes(0, true).size();
    int a0 = 0, a1 = 0, batch = 64;
    std::vector<char> land[2], clear[2];  // [crater ? 1 : 0][attempt − a0]
    auto ensure = [&](int a) {
      if (a >= a0 && a < a1) return;
      a0 = a;
      a1 = std::min(plan.attempts(), a + batch);
      batch = std::min(4096, 2 * batch);
      Probes probes(io, path);
      std::vector<std::size_t> first_land[2], first_clear[2];
      for (int k = a0; k < a1; ++k)
        for (int c = 0; c < 2; ++c) {
          if (plan.on_land()) {
            const std::vector<XZ> ps = plan.land_probes(k, c == 1);
            first_land[c].push_back(probes.size());
            for (const XZ& p : ps) probes.bilinear(p);
          }
          if (volcano) {
            const std::vector<XZ> ps = plan.volcano_probes(k, c == 1);
            first_clear[c].push_back(probes.size());
            for (const XZ& p : ps) probes.nearest(p);
          }
        }
      const std::vector<double> v = probes.read("height", "volcano");
      for (int c = 0; c < 2; ++c) {
        land[c].assign(std::size_t(a1 - a0), 1);
        clear[c].assign(std::size_t(a1 - a0), 1);
        for (int k = 0; k < a1 - a0; ++k) {
          if (plan.on_land()) {
            const std::size_t s = first_land[c][std::size_t(k)];
            const std::vector<double> e(v.begin() + std::ptrdiff_t(s), v.begin() + std::ptrdiff_t(s + n_land));
            land[c][std::size_t(k)] = plan.land_ok(e);
          }
          if (volcano) {
            const std::size_t s = first_clear[c][std::size_t(k)];
            std::vector<float> f;
            for (std::size_t q = s; q < s + n_volcano; ++q) f.push_back(float(v[q]));
            clear[c][std::size_t(k)] = detail::FeaturesPlan::off_volcano(f);
          }
        }
      }
    };
    plan.place(
        [&](int a, bool crater) {
          ensure(a);
          return land[crater ? 1 : 0][std::size_t(a - a0)] != 0;
        },
        [&](int a, bool crater) {
          ensure(a);
          return clear[crater ? 1 : 0][std::size_t(a - a0)] != 0;
        });
    const int n = plan.count();
    // 2. Each feature's base: the height at its centre after the features before it, in the tile
    // holding its block, with those features applied in memory.
    if (n > 0) {
      std::map<std::int64_t, std::vector<int>> by_tile;  // tile → features whose block it holds, in order
      for (int f = 0; f < n; ++f) {
        const XZ p = plan.base_probe(f);
        const detail::BilinearCell c = detail::bilinear_cell(io.world, p.x_m, p.z_m);
        by_tile[tile_index(io.grid, c.i0, c.j0)].push_back(f);
      }
      for (const auto& [tile, fs] : by_tile) {
        check_cancelled(io);
        WorldTile wt = load_some(io, tile % io.grid.tiles_x, tile / io.grid.tiles_x, {"height"});
        Terrain t = as_terrain(io, wt);
        const Layer& h = layer_of(t, "height", path);
        for (int f = 0, next = 0; f <= fs.back(); ++f) {
          if (fs[std::size_t(next)] == f) {
            plan.set_base(f, bilinear_in(io.world, t, h, plan.base_probe(f)));
            ++next;
          }
          if (f < fs.back()) plan.apply(t, f);
        }
      }
    }
    // 3. Every tile, every feature in order.
    std::vector<std::string> changed = layers;  // height and albedo: what the features change
    std::erase(changed, std::string("volcano"));
    each_tile(
        io, changed,
        [&](Terrain& t) {
          for (int f = 0; f < n; ++f) plan.apply(t, f);
        },
        [&](const Frame& w) {
          for (int f = 0; f < n; ++f)
            if (plan.touches(w, f)) return true;
          return false;
        },
        [](Terrain&) {}, 0.3);  // the placement's and bases' probes before
    if (io.points) io.points(plan.points());
  };
}

std::vector<BiomeInfo> world_legend(const Recipe& r, std::size_t stages) {
  Recipe q = r;
  q.stages.resize(std::min(stages, q.stages.size()));
  q.world.nx = q.world.nz = 65;
  if (!q.seed) q.seed = 0;  // the legend depends on no seed either; run() would draw one
  RunOptions opt;
  opt.threads = 1;
  return run(q, opt).terrain.biomes;
}

}  // namespace relief
