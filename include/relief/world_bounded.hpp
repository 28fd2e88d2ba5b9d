#pragma once
// World algorithms for the stages that cannot be exact under any tiling (issue 18, "bounded"):
// droplet hydraulic erosion and stream power, and the seam metrics that measure how far a tiled
// build of them is from one whole-map build.
//
// default_world_algorithms() (relief/world.hpp) registers world_hydraulic() and world_stream_power();
// tests may register others through WorldSettings::algorithms, e.g. world_stream_power(101).
// Each runs as a phase of its own over the stored tiles (world.hpp, "Phases"): it reads the previous
// phase's tiles with io.load and writes every tile once with io.store, every layer but "height"
// passed through unchanged.
//
// hydraulic (bounded). Droplets are defined by world position (relief/erosion.hpp: per world cell
// counts and starts, world-aligned blocks processed in a fixed order), so a window runs the whole
// map's droplets that start inside it, in the same order. Per tile, in row-major tile order:
//   1. the tile's window grown by the stage's halo (Stage::reach: lifetime · step_m + brush_radius_m,
//      in samples; stopping at the world's edge) is assembled from the input tiles it touches;
//   2. the hydraulic stage runs on it with the window's world frame (Frame::window) and the
//      recipe's stage seed (Context{seed, index}), exactly as the whole-map stage would;
//   3. the tile is cropped from it. Its first `halo` columns (rows) after a seam with the tile to
//      its left (above) are blended with what that tile's run computed for the same samples
//      (weight of the neighbour's run 1 at the seam, 0 at `halo` samples, smoothstep), and the
//      shared border samples are copied from the neighbour's stored tile: the tiles agree on every
//      shared sample and the surface has no kink at the seam.
//   What is not exact: droplets that start outside the grown window never run, so what they did to
//   the halo (and, through it, to the droplets that reach the tile) is missing. tests/
//   test_world_bounded.cpp measures the resulting seam error (see seam_metrics).
//   Memory: one grown window and its run, the input tiles it touches one at a time, and the blend
//   strips (halo × tile samples for the tile to the left, halo × world width for the row above).
//   Measured (tests/test_world_bounded.cpp, 513² worlds of the eroded-mountains preset, RMS within 2
//   halos of a seam over the world's relief): stream_power + hydraulic + thermal + fill 0.79 %
//   (tiles of 129) and 0.50 % (257); droplets alone on raw ridged noise 1.35 % and 1.10 % (the
//   issue's goal is 0.5 %). The error is not concentrated at seams (the RMS over the whole world is
//   the same): droplet erosion feeds back on itself, so what the missing droplets did to the halo
//   changes the gullies inside the tile. The largest slope jump across a seam stays below the 99.9th
//   percentile of the jumps inside tiles for the preset's chain.
//
// stream_power (bounded; exact when the world has at most kStreamPowerCoarseMax samples per axis).
// Drainage area is global: it accumulates over every sample upstream. So the stage is solved on the
// whole world at once, on a coarse grid that fits memory: every s-th sample of the world
// (s = ceil((n − 1) / (kStreamPowerCoarseMax − 1)) along both axes, the last row and column of the
// world always included), read tile by tile. The stage runs there with the coarse frame (cells of
// s · cell_m, so drainage areas, slopes and every parameter in world units keep their meaning), and
// each tile then receives its input heights plus the coarse solution's change (output − input)
// interpolated bilinearly at each sample's world position, clamped to [0, 1]. The interpolated
// change is a function of world position only, so tiles agree on shared samples and the valleys
// the coarse solution cut run continuously across tiles and down to base level: drainage is
// continuous by construction (a later `fill` stage removes the sub-coarse-cell pits left by the
// fine detail). When s = 1 the coarse grid is the world and the tiles receive the whole map's stage
// output itself, bit for bit. Memory: the coarse grid (≤ kStreamPowerCoarseMax² samples, times
// the stage's own scratch) and one tile.
#include <cstdint>
#include <vector>

#include "relief/world.hpp"

namespace relief {

constexpr int kStreamPowerCoarseMax = 2049;  // stream power's coarse grid: at most this many samples per axis

// The world algorithm of the "hydraulic" stage (above). `seed` is the recipe's seed
// (WorldReport::seed; the recipe's seed when it sets one): the stage seeds its droplets from it and
// the stage's index, as the whole-map run does.
WorldStageAlgorithm world_hydraulic(std::uint64_t seed);
// The same with the build's seed (WorldStageIO::seed): what default_world_algorithms() registers.
WorldStageAlgorithm world_hydraulic();
// The world algorithm of the "stream_power" stage (above), with a coarse grid of at most
// `coarse_max` samples per axis (≥ 3; tests lower it to exercise the coarse path on small worlds).
WorldStageAlgorithm world_stream_power(int coarse_max = kStreamPowerCoarseMax);

// Seam error of a tiled build against a whole-map build of the same world.
struct SeamMetrics {
  double relief = 0;           // max − min of the whole-map heights (normalised units)
  double rms_near_seams = 0;   // RMS of (tiled − whole) over samples within `band` of a seam
  double rms_fraction = 0;     // rms_near_seams / relief (the goal: ≤ 0.005)
  double rms_all = 0;          // RMS of (tiled − whole) over the whole world
  double max_abs_diff = 0;     // largest |tiled − whole| anywhere
  std::int64_t band_samples = 0;  // samples within `band` of a seam
  // Slope jumps of the tiled world: at sample (ix, iz), along x, |(h[ix+1] − h[ix]) − (h[ix] −
  // h[ix−1])| · height_m / cell_m (the change of slope in m/m from one cell to the next; along z the
  // same). Across a seam: the jumps centred on a seam sample (ix a multiple of tile − 1, inside the
  // world) or next to it (ix ± 1), along the axis crossing the seam. Inside tiles: all other jumps.
  double seam_jump_max = 0;        // largest jump across a seam
  double seam_jump_p999 = 0;       // 99.9th percentile of the jumps across seams
  // The whole-map build's largest jump at the same places: a seam sample is a sample like any other
  // of the whole map, and the largest of thousands of jumps of the same distribution exceeds the
  // 99.9th percentile of all of them by chance; this is the reference for seam_jump_max.
  double whole_seam_jump_max = 0;
  double interior_jump_p999 = 0;   // 99.9th percentile of the jumps inside tiles (the goal: seam_jump_max ≤ this)
  double interior_jump_max = 0;
  std::int64_t seam_jumps = 0, interior_jumps = 0;
};
// `tiled` and `whole`: the world's heights (grid.nx × grid.nz, row-major, x fastest) assembled from
// the tile store and from one whole-map run. `band`: samples on each side of a seam counted as near
// it (e.g. 2 × the stage's halo). `world`: the world frame (height_m, cell size). Throws
// Error("seam_metrics", …) when the sizes do not match the grid. A world of one tile has no seam:
// the seam figures are 0.
SeamMetrics seam_metrics(const std::vector<float>& tiled, const std::vector<float>& whole, const WorldGrid& grid,
                         int band, const Frame& world);

}  // namespace relief
