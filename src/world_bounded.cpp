// World algorithms for hydraulic erosion and stream power, bounded against a whole-map build, and
// the seam metrics that measure them (relief/world_bounded.hpp, issue 18).
//
// Sources:
//   H. T. Beyer 2015 (droplets; src/erosion_hydraulic.cpp), Braun & Willett 2013 (stream power;
//   src/stream_power.cpp) for the stages themselves. The coarse global pass for stream power follows
//   the usual multi-resolution practice of landscape-evolution models (Cordonnier et al. 2016 run
//   their uplift/erosion on a coarse grid and amplify it); here the coarse change is interpolated
//   onto the fine input.
#include "relief/world_bounded.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "relief/error.hpp"
#include "relief/stage.hpp"

namespace relief {
namespace {

void check_cancelled(const WorldStageIO& io) {
  if (io.cancelled && io.cancelled()) throw Cancelled();
}

// The tiles of `g` whose windows intersect the columns [x0, x1) (or rows): first and last index.
std::pair<std::int64_t, std::int64_t> tiles_touching(std::int64_t a0, std::int64_t a1, std::int64_t tiles, int tile) {
  const std::int64_t step = tile - 1;
  // Tile k covers [k·step, k·step + tile); the last one may be clipped.
  std::int64_t lo = a0 >= tile ? (a0 - tile) / step + 1 : 0;
  std::int64_t hi = (a1 - 1) / step;
  lo = std::clamp<std::int64_t>(lo, 0, tiles - 1);
  hi = std::clamp<std::int64_t>(hi, 0, tiles - 1);
  return {lo, hi};
}

// 1 at d = 0, 0 at d = b, smoothstep in between: the neighbour's weight in a blend strip.
float neighbour_weight(int d, int b) {
  const double t = double(d) / double(b);
  return float(1.0 - t * t * (3.0 - 2.0 * t));
}

}  // namespace

WorldStageAlgorithm world_hydraulic() {
  return [](const WorldStageIO& io, const RecipeStage& st, int index) { world_hydraulic(io.seed)(io, st, index); };
}

WorldStageAlgorithm world_hydraulic(std::uint64_t seed) {
  return [seed](const WorldStageIO& io, const RecipeStage& st, int index) {
    const WorldGrid& g = io.grid;
    const Frame& W = io.world;
    const int halo = std::max(0, st.stage->reach(W).halo);
    Context ctx;
    ctx.seed = seed;
    ctx.stage_index = index;
    // From the tile to the left: its run over this tile's first columns (w.nz × b) and its final
    // right column; from the row above, per column of tiles: its run over the first rows (b × w.nx)
    // and its final bottom row.
    std::vector<float> left_strip, left_col;
    int left_b = 0;
    std::vector<std::vector<float>> top_strip(std::size_t(g.tiles_x)), top_row(std::size_t(g.tiles_x));
    std::vector<int> top_b(std::size_t(g.tiles_x), 0);
    for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
      for (std::int64_t X = 0; X < g.tiles_x; ++X) {
        check_cancelled(io);
        const WorldGrid::Window w = g.window(X, Z);
        const std::int64_t gx0 = std::max<std::int64_t>(0, w.ix0 - halo), gz0 = std::max<std::int64_t>(0, w.iz0 - halo);
        const std::int64_t gx1 = std::min<std::int64_t>(g.nx, w.ix0 + w.nx + halo);
        const std::int64_t gz1 = std::min<std::int64_t>(g.nz, w.iz0 + w.nz + halo);
        const int gnx = int(gx1 - gx0), gnz = int(gz1 - gz0);
        Terrain t;
        t.frame = W.window(gx0, gz0, gnx, gnz);
        std::vector<float>& e = t.layer("height", 1).data;
        WorldTile own;
        const auto [X0, X1] = tiles_touching(gx0, gx1, g.tiles_x, g.tile);
        const auto [Z0, Z1] = tiles_touching(gz0, gz1, g.tiles_z, g.tile);
        for (std::int64_t ZZ = Z0; ZZ <= Z1; ++ZZ)
          for (std::int64_t XX = X0; XX <= X1; ++XX) {
            WorldTile in = io.load(XX, ZZ);
            const WorldGrid::Window v = g.window(XX, ZZ);
            const std::vector<float>& src = in.layers.at("height").data;
            const std::int64_t a0 = std::max(gx0, v.ix0), a1 = std::min(gx1, v.ix0 + v.nx);
            const std::int64_t b0 = std::max(gz0, v.iz0), b1 = std::min(gz1, v.iz0 + v.nz);
            for (std::int64_t iz = b0; iz < b1; ++iz)
              for (std::int64_t ix = a0; ix < a1; ++ix)
                e[std::size_t(iz - gz0) * std::size_t(gnx) + std::size_t(ix - gx0)] =
                    src[std::size_t(iz - v.iz0) * std::size_t(v.nx) + std::size_t(ix - v.ix0)];
            if (XX == X && ZZ == Z) own = std::move(in);
          }
        st.stage->apply(t, ctx);
        const std::vector<float>& r = t.get("height").data;
        auto run_at = [&](std::int64_t ix, std::int64_t iz) {
          return r[std::size_t(iz - gz0) * std::size_t(gnx) + std::size_t(ix - gx0)];
        };
        std::vector<float> out(std::size_t(w.nx) * std::size_t(w.nz));
        for (int j = 0; j < w.nz; ++j)
          for (int i = 0; i < w.nx; ++i) out[std::size_t(j) * w.nx + i] = run_at(w.ix0 + i, w.iz0 + j);
        // Blend with the runs of the tiles above and to the left, then take the shared samples from
        // their stored tiles.
        if (Z > 0 && top_b[std::size_t(X)] > 0) {
          const int b = top_b[std::size_t(X)];
          const std::vector<float>& s = top_strip[std::size_t(X)];
          for (int j = 0; j < b; ++j) {
            const float a = neighbour_weight(j, b);
            for (int i = 0; i < w.nx; ++i) {
              float& v = out[std::size_t(j) * w.nx + i];
              v = a * s[std::size_t(j) * w.nx + i] + (1 - a) * v;
            }
          }
        }
        if (X > 0 && left_b > 0) {
          const int b = left_b;
          for (int j = 0; j < w.nz; ++j)
            for (int i = 0; i < b; ++i) {
              const float a = neighbour_weight(i, b);
              float& v = out[std::size_t(j) * w.nx + i];
              v = a * left_strip[std::size_t(j) * b + i] + (1 - a) * v;
            }
        }
        if (X > 0)
          for (int j = 0; j < w.nz; ++j) out[std::size_t(j) * w.nx] = left_col[std::size_t(j)];
        if (Z > 0)
          for (int i = 0; i < w.nx; ++i) out[std::size_t(i)] = top_row[std::size_t(X)][std::size_t(i)];
        // What the next tiles need from this one.
        if (X + 1 < g.tiles_x) {
          const WorldGrid::Window n = g.window(X + 1, Z);
          left_b = std::min(halo, n.nx - 1);
          left_strip.assign(std::size_t(w.nz) * std::size_t(left_b), 0.0f);
          for (int j = 0; j < w.nz; ++j)
            for (int i = 0; i < left_b; ++i) left_strip[std::size_t(j) * left_b + i] = run_at(n.ix0 + i, w.iz0 + j);
          left_col.resize(std::size_t(w.nz));
          for (int j = 0; j < w.nz; ++j) left_col[std::size_t(j)] = out[std::size_t(j) * w.nx + (w.nx - 1)];
        }
        if (Z + 1 < g.tiles_z) {
          const WorldGrid::Window n = g.window(X, Z + 1);
          const int b = std::min(halo, n.nz - 1);
          top_b[std::size_t(X)] = b;
          std::vector<float>& s = top_strip[std::size_t(X)];
          s.assign(std::size_t(b) * std::size_t(w.nx), 0.0f);
          for (int j = 0; j < b; ++j)
            for (int i = 0; i < w.nx; ++i) s[std::size_t(j) * w.nx + i] = run_at(w.ix0 + i, n.iz0 + j);
          top_row[std::size_t(X)].assign(out.end() - w.nx, out.end());
        }
        own.layers.at("height").data = std::move(out);
        io.store(X, Z, std::move(own));
        if (io.progress) io.progress(double(Z * g.tiles_x + X + 1) / double(g.count()));
      }
  };
}

WorldStageAlgorithm world_stream_power(int coarse_max) {
  if (coarse_max < 3) throw Error("coarse_max", "expected at least 3 samples, got " + std::to_string(coarse_max));
  return [coarse_max](const WorldStageIO& io, const RecipeStage& st, int index) {
    const WorldGrid& g = io.grid;
    const Frame& W = io.world;
    const std::int64_t cmax = coarse_max - 1;
    const std::int64_t s = std::max<std::int64_t>({1, (g.nx - 1 + cmax - 1) / cmax, (g.nz - 1 + cmax - 1) / cmax});
    const int cnx = int((g.nx - 1 + s - 1) / s + 1), cnz = int((g.nz - 1 + s - 1) / s + 1);
    // Coarse sample c sits at world sample min(c·s, n − 1).
    auto world_of = [&](std::int64_t c, std::int64_t n) { return std::min(c * s, n - 1); };
    Terrain t;
    t.frame = W;
    t.frame.nx = cnx, t.frame.nz = cnz, t.frame.ix0 = 0, t.frame.iz0 = 0;
    t.frame.spacing_m = W.spacing_m * double(s);
    std::vector<float>& e = t.layer("height", 1).data;
    for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
      for (std::int64_t X = 0; X < g.tiles_x; ++X) {
        check_cancelled(io);
        const WorldGrid::Window w = g.window(X, Z);
        const WorldTile in = io.load(X, Z);
        const std::vector<float>& h = in.layers.at("height").data;
        for (int cz = 0; cz < cnz; ++cz) {
          const std::int64_t iz = world_of(cz, g.nz);
          if (iz < w.iz0 || iz >= w.iz0 + w.nz) continue;
          for (int cx = 0; cx < cnx; ++cx) {
            const std::int64_t ix = world_of(cx, g.nx);
            if (ix < w.ix0 || ix >= w.ix0 + w.nx) continue;
            e[std::size_t(cz) * std::size_t(cnx) + std::size_t(cx)] =
                h[std::size_t(iz - w.iz0) * std::size_t(w.nx) + std::size_t(ix - w.ix0)];
          }
        }
        // Progress: the gathering pass spans [0, 0.3), the coarse solve [0.3, 0.4), the pass that
        // writes the tiles back [0.4, 1] (a step per tile in each pass).
        if (io.progress) io.progress(0.3 * double(Z * g.tiles_x + X + 1) / double(g.count()));
      }
    const std::vector<float> before = e;
    Context ctx;
    ctx.stage_index = index;  // stream power draws no random numbers
    st.stage->apply(t, ctx);
    if (io.progress) io.progress(0.4);
    const std::vector<float>& after = t.get("height").data;
    std::vector<float> delta;
    if (s > 1) {
      delta.resize(after.size());
      for (std::size_t c = 0; c < after.size(); ++c) delta[c] = after[c] - before[c];
    }
    // Interpolation along one axis: the coarse cell holding world sample i and the fraction in it.
    auto locate = [&](std::int64_t i, std::int64_t n, int cn, int& c0, float& f) {
      c0 = int(std::min<std::int64_t>(i / s, cn - 2));
      const std::int64_t a = world_of(c0, n), b = world_of(c0 + 1, n);
      f = float(double(i - a) / double(b - a));
    };
    for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
      for (std::int64_t X = 0; X < g.tiles_x; ++X) {
        check_cancelled(io);
        const WorldGrid::Window w = g.window(X, Z);
        WorldTile tile = io.load(X, Z);
        std::vector<float>& h = tile.layers.at("height").data;
        for (int j = 0; j < w.nz; ++j) {
          int cz = 0;
          float fz = 0;
          if (s > 1) locate(w.iz0 + j, g.nz, cnz, cz, fz);
          for (int i = 0; i < w.nx; ++i) {
            float& v = h[std::size_t(j) * w.nx + i];
            if (s == 1) {
              v = after[std::size_t(w.iz0 + j) * std::size_t(cnx) + std::size_t(w.ix0 + i)];
              continue;
            }
            int cx = 0;
            float fx = 0;
            locate(w.ix0 + i, g.nx, cnx, cx, fx);
            const std::size_t c = std::size_t(cz) * std::size_t(cnx) + std::size_t(cx);
            const float d = (delta[c] * (1 - fx) + delta[c + 1] * fx) * (1 - fz) +
                            (delta[c + std::size_t(cnx)] * (1 - fx) + delta[c + std::size_t(cnx) + 1] * fx) * fz;
            v = std::clamp(v + d, 0.0f, 1.0f);
          }
        }
        io.store(X, Z, std::move(tile));
        if (io.progress) io.progress(0.4 + 0.6 * double(Z * g.tiles_x + X + 1) / double(g.count()));
      }
  };
}

SeamMetrics seam_metrics(const std::vector<float>& tiled, const std::vector<float>& whole, const WorldGrid& g, int band,
                         const Frame& world) {
  const std::size_t n = std::size_t(g.nx) * std::size_t(g.nz);
  if (tiled.size() != n || whole.size() != n)
    throw Error("seam_metrics", "expected " + std::to_string(n) + " heights for both worlds, got " +
                                    std::to_string(tiled.size()) + " and " + std::to_string(whole.size()));
  SeamMetrics m;
  const std::int64_t step = g.tile - 1;
  auto is_seam = [&](std::int64_t i, std::int64_t count) { return i > 0 && i < count - 1 && i % step == 0; };
  // Distance to the nearest seam line along each axis.
  auto near_line = [&](std::int64_t count) {
    std::vector<std::uint8_t> near(std::size_t(count), 0);
    for (std::int64_t i = 0; i < count; ++i)
      if (is_seam(i, count))
        for (std::int64_t d = -band; d <= band; ++d)
          if (i + d >= 0 && i + d < count) near[std::size_t(i + d)] = 1;
    return near;
  };
  const std::vector<std::uint8_t> near_x = near_line(g.nx), near_z = near_line(g.nz);
  float lo = whole[0], hi = whole[0];
  double sum_band = 0, sum_all = 0;
  for (std::int64_t iz = 0; iz < g.nz; ++iz)
    for (std::int64_t ix = 0; ix < g.nx; ++ix) {
      const std::size_t c = std::size_t(iz) * std::size_t(g.nx) + std::size_t(ix);
      lo = std::min(lo, whole[c]), hi = std::max(hi, whole[c]);
      const double d = double(tiled[c]) - double(whole[c]);
      sum_all += d * d;
      m.max_abs_diff = std::max(m.max_abs_diff, std::fabs(d));
      if (near_x[std::size_t(ix)] || near_z[std::size_t(iz)]) {
        sum_band += d * d;
        ++m.band_samples;
      }
    }
  m.relief = double(hi) - double(lo);
  m.rms_all = std::sqrt(sum_all / double(n));
  m.rms_near_seams = m.band_samples ? std::sqrt(sum_band / double(m.band_samples)) : 0.0;
  m.rms_fraction = m.relief > 0 ? m.rms_near_seams / m.relief : 0.0;
  // Slope jumps.
  const double scale = world.height_m / world.cell_m();
  std::vector<float> interior;
  interior.reserve(2 * n);
  auto jump_of = [&](const std::vector<float>& h, std::size_t c, std::size_t stride) {
    return float(std::fabs((double(h[c + stride]) - h[c]) - (double(h[c]) - h[c - stride])) * scale);
  };
  auto at_seam = [&](std::int64_t i, std::int64_t count) {
    return is_seam(i, count) || is_seam(i - 1, count) || is_seam(i + 1, count);
  };
  std::vector<float> seam;
  auto add = [&](std::size_t c, std::size_t stride, bool across) {
    const float j = jump_of(tiled, c, stride);
    if (!across) {
      interior.push_back(j);
      return;
    }
    seam.push_back(j);
    m.seam_jump_max = std::max(m.seam_jump_max, double(j));
    m.whole_seam_jump_max = std::max(m.whole_seam_jump_max, double(jump_of(whole, c, stride)));
  };
  for (std::int64_t iz = 0; iz < g.nz; ++iz)
    for (std::int64_t ix = 0; ix < g.nx; ++ix) {
      const std::size_t c = std::size_t(iz) * std::size_t(g.nx) + std::size_t(ix);
      if (ix > 0 && ix < g.nx - 1) add(c, 1, at_seam(ix, g.nx));
      if (iz > 0 && iz < g.nz - 1) add(c, std::size_t(g.nx), at_seam(iz, g.nz));
    }
  m.seam_jumps = std::int64_t(seam.size());
  if (!seam.empty()) {
    const std::size_t k = std::size_t(0.999 * double(seam.size() - 1));
    std::nth_element(seam.begin(), seam.begin() + std::ptrdiff_t(k), seam.end());
    m.seam_jump_p999 = seam[k];
  }
  m.interior_jumps = std::int64_t(interior.size());
  if (!interior.empty()) {
    const std::size_t k = std::size_t(0.999 * double(interior.size() - 1));
    std::nth_element(interior.begin(), interior.begin() + std::ptrdiff_t(k), interior.end());
    m.interior_jump_p999 = interior[k];
    m.interior_jump_max = *std::max_element(interior.begin(), interior.end());
  }
  return m;
}

}  // namespace relief
