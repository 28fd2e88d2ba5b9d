#pragma once
// The erosion kernels behind the "hydraulic", "thermal" and "stream_power" stages, for callers
// that time or test a kernel on its own (`relief bench`, the tests). A recipe reaches them through
// the stages; these are the same functions without the stage's parameter parsing and layers.
//
// All three work on a normalised elevation layer `e` (nx·nz floats, row-major, x fastest) of a
// Frame, and do their physics in metres: y_m = (e − sea_level)·height_m vertically, cell_m
// horizontally. Every parameter is in world units, so a 513² preview and a 2049² build of the same
// world erode alike. Results are identical for any thread count.
#include <cstdint>
#include <functional>

#include "relief/terrain.hpp"

namespace relief::erosion {

// ---- droplet hydraulic erosion (Beyer 2015, with Lague's parameter set) ---------------------
struct HydraulicSettings {
  double droplets_per_km2 = 20000;  // droplet starts per km² of the world (land starts only)
  int lifetime = 30;                // maximum steps per droplet
  double step_m = 8;                // distance a droplet moves per step
  double brush_radius_m = 24;       // erosion (and deposition) brush radius
  double inertia = 0.05;            // 0: follow the slope; 1: keep the direction
  double capacity = 0.01;           // sediment capacity factor, s/m (see hydraulic_erosion)
  double min_capacity = 0.001;      // capacity floor, metres of mean brush height
  double erode = 0.3;               // fraction of the free capacity taken per step
  double deposit = 0.3;             // fraction of the excess sediment dropped per step
  double evaporate = 0.01;          // fraction of the water lost per step
  double gravity = 4;               // m/s²: speed² gains gravity · drop (metres) per step
};
struct HydraulicStats {
  double eroded_m3 = 0, deposited_m3 = 0;
  double to_sea_m3 = 0;     // sediment carried into the sea (droplets that reach e < sea_level)
  double off_map_m3 = 0;    // sediment carried over the window's border
  double stranded_m3 = 0;   // sediment a dying droplet could not deposit (cells at elevation 1)
  std::uint64_t droplets = 0;
};
// Each droplet carries water, speed and sediment (a volume in m³). Per step it moves step_m along
// its direction d ← normalise(d·inertia − ∇y·(1 − inertia)) (∇y in metres per metre, bilinear),
// with Δy the change of surface height over the step (metres):
//   capacity = max(−Δy · speed · water · capacity, min_capacity) · A,   A = π·brush_radius_m²
//   uphill (Δy > 0): drop min(Δy·cell², sediment) on the 4 cells around the old position;
//   over capacity:   drop (sediment − capacity)·deposit with the brush;
//   otherwise:       take min((capacity − sediment)·erode, −Δy·A) with the brush;
//   speed ← √max(0, speed² − Δy·gravity),  water ← water·(1 − evaporate).
// The brush spreads a volume V over the cells within r = max(brush_radius_m, 1.5·cell_m) with weights
// ∝ (r − d), so the mean height change over the brush is about V / A whatever the cell size (never
// more: on grids coarser than the brush, the 3×3 cells around the droplet share it). No cell goes below elevation
// 0 or above 1 (the bound applies to normalised heights, not to "positive heights": the sea floor
// erodes correctly). A droplet that reaches the sea stops and its sediment counts as carried into
// the sea; one leaving the window carries its sediment off the map; a droplet that dies on land
// (lifetime over, or no slope) deposits what it carries with the brush. Hence, up to float
// rounding: eroded = deposited + to_sea + off_map + stranded.
//
// Honest limit: droplets resolve features of about brush_radius_m and step_m. On grids much coarser
// than that (cells of several brush radii), a droplet takes several steps inside one cell and digs
// there: previews should keep cell_m within ~2 brush radii of the build's.
//
// Droplets are defined by WORLD position, so that a window of the world (Frame::ix0, iz0) runs the
// same droplets as the whole map over the cells they share. World cell (cx, cz) (the square between
// samples cx, cx+1 and cz, cz+1 of the world grid) starts ⌊λ⌋ droplets, plus one more when
// unit(hash(seed, cx, cz, 'n')) < frac(λ), with λ = droplets_per_km2 · cell_m² · 10⁻⁶; droplet d of
// the cell starts at (cx + u, cz + v), u and v from hash(seed, cx, cz, d). The map is cut into
// square blocks of side 2·reach cells aligned on the world's cell grid (reach = lifetime·step +
// brush radius, in cells, + 2); blocks are processed in 4 rounds, each in 4 phases (a 2×2
// checkerboard by the world block's parity); blocks of one phase touch disjoint cells. A droplet's
// round is the top 2 bits of its order key hash(seed, cx, cz, d, 'o'), and each block runs its
// droplets of the round sequentially in key order. A window therefore runs, in the same order, the
// subset of the whole map's droplets that start inside it (their results differ through what
// droplets starting outside the window did: one run on a window is not exact; run pass by pass,
// block group by block group, it is: hydraulic_erosion_part below, relief/world_bounded.hpp). The
// result depends on the parameters, the seed and the window's world position only, never on the
// thread count.
// progress(fraction), if given, is called on the calling thread as the work advances (16 times).
HydraulicStats hydraulic_erosion(float* e, const Frame& f, const HydraulicSettings& s, std::uint64_t seed,
                                 const std::function<void(double)>& progress = {});
// Part of the above, for world builds that run it exactly over a tiled world (relief/world_bounded.hpp):
// the run is 16 passes, pass = round · 4 + phase (round r runs its droplets of every block of
// checkerboard colour `phase` = (bx & 1) + 2 · (bz & 1), bx and bz the world block indices, blocks of
// hydraulic_block_cells() cells). A pass changes only the cells within hydraulic_reach_cells() of
// its blocks, and what it does there depends only on those cells: hydraulic_erosion() is
// hydraulic_erosion_part() with every pass and block, and a window that holds a block's cells
// grown by the reach (or the world's edge) runs that block's pass with the same bits as the whole map.
struct HydraulicPart {
  int first_pass = 0, passes = 16;  // the passes [first_pass, first_pass + passes) of 0..15, in order
  // World block indices run: [bx0, bx1) × [bz0, bz1); droplets of other blocks are neither started
  // nor drawn.
  std::int64_t bx0 = INT64_MIN, bx1 = INT64_MAX, bz0 = INT64_MIN, bz1 = INT64_MAX;
};
HydraulicStats hydraulic_erosion_part(float* e, const Frame& f, const HydraulicSettings& s, std::uint64_t seed,
                                      const HydraulicPart& part, const std::function<void(double)>& progress = {});
// A droplet's reach in cells of cell_m: lifetime · step_m / cell_m rounded up, plus the brush's
// radius in cells (brush radius at least 1.5 cells), plus 2. The blocks are 2 · reach cells wide.
int hydraulic_reach_cells(const HydraulicSettings& s, double cell_m);
inline int hydraulic_block_cells(const HydraulicSettings& s, double cell_m) { return 2 * hydraulic_reach_cells(s, cell_m); }

// ---- thermal erosion (Musgrave, Kolb, Mace 1989; Olsen 2004) --------------------------------
// One iteration on the von Neumann neighbourhood: with d_k the height difference (metres) to each
// of the 4 neighbours and T = tan(talus_deg)·cell_m, a cell with d_max > T sends
// rate·(d_max − T) to its lower neighbours with d_k > T, in proportion to d_k (Olsen's form of
// Musgrave's rule). All cells move at once (Jacobi), so the result does not depend on scheduling;
// mass is conserved up to float rounding. rate in (0, 0.5] never overshoots. Reads `e` and writes the
// new elevations to `next` (nx·nz floats, not aliasing e), in one fused pass (Highway SIMD,
// bit-identical for every target and thread count).
void thermal_iteration(const float* e, float* next, const Frame& f, double talus_deg, double rate);

// ---- stream power with uplift (Braun & Willett 2013; Cordonnier et al. 2016) ---------------
struct StreamPowerSettings {
  double uplift_mm_per_year = 1.0;  // U
  bool uplift_follows_height = true;  // U scaled by the initial land height (0 at sea, 1 at the top)
  double k = 2e-5;                  // erodibility K, in m^(1−2m)/year
  double m = 0.45, n = 1.0;         // exponents of A^m S^n (θ = m/n at steady state)
  double duration_years = 2e5;
  int steps = 100;
  double rainfall = 1.0;            // scales the drainage area (uniform precipitation)
  double max_slope_deg = 40.0;      // threshold hillslopes: no slope to a receiver exceeds this
};
struct StreamPowerStats {
  int fills = 0;  // steps whose new surface had pits, resolved by Priority-Flood+ε
};
// dh/dt = U − K·A^m·S^n on land (outlets — sea cells and the window's border — are base level),
// solved with Braun & Willett's implicit O(n) scheme along the D8 receiver tree: nodes are visited
// receivers first and h_i ← solution of h_i − (h_i⁰ + U·dt) + K·dt·A^m·((h_i − h_r)/L)^n = 0
// (closed form for n = 1, Newton otherwise), then h_i ← min(h_i, h_r + tan(max_slope_deg)·L): hillslopes
// steeper than the critical angle fail (a threshold-hillslope model, as in landscape-evolution
// models where diffusion alone cannot keep up with uplift), which bounds relief. Lakes are resolved each step: pits (cells without a
// lower neighbour) are detected after the D8 pass and filled with Priority-Flood+ε before routing,
// so flow always reaches base level (Cordonnier et al. reroute across lake passes instead; filling
// is the limit in which lakes fill with sediment). The result is written back to `e`, clamped to
// [0, 1] (raise world.height_m if peaks clip), then ε-filled once more in float so that the stored
// layer drains too. Each step: D8 direction codes and donor masks (SIMD, row-parallel), then every
// drainage basin walked depth-first from its outlet (receivers first), in parallel across basins;
// bit-identical to one global Braun–Willett stack for any thread count.
// progress(fraction), if given, is called on the calling thread after every step.
StreamPowerStats stream_power(float* e, const Frame& f, const StreamPowerSettings& s,
                              const std::function<void(double)>& progress = {});

}  // namespace relief::erosion
