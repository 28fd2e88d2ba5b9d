#pragma once
// World algorithms for droplet hydraulic erosion (exact: the whole map's bits in any tiling) and
// stream power (bounded, issue 18), and the seam metrics that measure how far a tiled build is from
// one whole-map build.
//
// default_world_algorithms() (relief/world.hpp) registers world_hydraulic() and world_stream_power();
// tests may register others through WorldSettings::algorithms, e.g. world_stream_power(101).
// Each runs as a phase of its own over the stored tiles (world.hpp, "Phases"): it reads the previous
// phase's tiles (io.load, io.load_layers) and writes every tile once (io.store, io.update), every
// layer but "height" passed through unchanged.
//
// hydraulic (exact). The whole-map stage is 16 passes (relief/erosion.hpp: 4 rounds × 4 checkerboard
// phases of world-aligned blocks of 2·reach cells, reach = erosion::hydraulic_reach_cells); a pass
// changes only the cells within `reach` of its blocks, and what it does there depends on those
// cells alone (the blocks of one phase touch disjoint cells; droplets are defined by world
// position, positions in block coordinates, so a droplet's floats are the same in every window that
// holds its block grown by the reach). So the world algorithm runs the passes one after another over
// the whole world, each on groups of G × G blocks (G = group_blocks, or by default
// world_hydraulic_group_blocks), each group on its blocks' cells grown by the reach
// (clipped to the world), running only that group's blocks of the pass
// (erosion::hydraulic_erosion_part): every pass gives, group by group, the whole map's pass bit for
// bit, and so does the result. Between passes the world's heights live in a temporary file (4 bytes
// per world sample, default_world_algorithm_needs) in io.scratch_dir (build_world: the phase's folder, on the
// store's file system; when empty, the temporary folder: std::filesystem::temp_directory_path(),
// $TMPDIR, else /tmp). The file has no name (O_TMPFILE, else mkstemp and unlinked at once), so it
// disappears when the process ends, even when killed: it is filled from the input tiles, updated
// group by group, and the tiles are written from it at the end (io.update with the height layer
// only, else load and store). A killed build redoes the phase from its input tiles.
//   Distributed (WorldStageIO::farm, src/world_farm.hpp): a pass's groups are farm tasks — rank 0
//   sends a group's window of heights as the pass found it, the rank that runs it sends back the
//   samples it changed, and rank 0 writes them into the file in group order (groups of a pass change
//   disjoint samples and read none that another changes, so the order of reading does not matter).
//   With several ranks the automatic G is halved (down to 2) until a pass has 4 groups per rank.
//   Memory: the groups in flight, each a window of (G·block + 2·reach + 2)² floats, and the stage's
//   per-block droplet starts (world_hydraulic_memory_bytes: about 18 bytes per window sample per
//   thread); not the world. The reach is the droplets' path in cells (lifetime · step_m / cell + the
//   brush), so a world of the same width in metres with more samples has a longer reach in cells: the
//   automatic G keeps a group within 2 tiles a side, or one block (2·reach) where the reach alone is
//   larger. So memory per thread is about 18·(max(tile, 2·reach) + 2·reach)² bytes: bounded by the
//   tile while a block fits in one, else by the reach, which grows with the world's samples per
//   metre (the river-island preset's 8 km in tiles of 1025: reach 249, 494 and 986 cells at 4097²,
//   8193² and 16385²). Disk: the temporary file (world samples × 4 bytes) besides the stores;
//   build_world's disk check counts it.
//   Time: the droplets are the whole map's, once each (no grown windows: nothing is computed twice);
//   the passes add 16 reads and writes of the world's heights through the temporary file, each
//   pass draws the starts of its blocks' droplets of its round only, and a group runs only its
//   blocks of the pass's colour at once (G²/4 blocks in the vector lanes and threads); a group with
//   no block of the pass's colour is skipped. Small groups (G of 1 or 2, a long reach) leave vector
//   lanes idle: a 2049² world with 1 m cells and a reach of 108 took 9.0–9.8 s of CPU with G = 1 or
//   2 against 7.5 s with G = 16 (before the skip), the price of the bounded memory. Measured earlier
//   (G ≥ 16) on this 2-core machine (loaded by other work; the hydraulic phase's time
//   in build_world, 2 threads, droplets alone on the eroded-mountains terrain, two runs each): 513²
//   world, tiles of 129: 1.0 s against 3.9 s for the former method (each tile on its window grown
//   by one halo, then blended: 0.26×); tiles of 257: 1.1 s against 1.7 s (0.67×); 1025²: 2.3 s
//   against 10.3 s (0.22×) and 2.0 s against 4.8 s (0.42×). The former method also missed the seam
//   goal (RMS within 2 halos of a seam 0.79 % / 0.50 % of the relief on eroded-mountains, 1.35 % /
//   1.10 % for droplets alone on ridged noise, tiles of 129 / 257, against 0.5 %).
//   Why not grow the windows further: droplet erosion feeds back on itself (a gully draws the
//   droplets that deepen it), and a cell after a pass depends on the cells before it up to 4
//   reaches away (its block grown by the reach), so one window run would have to be grown by up to
//   64 reaches (16 passes) to be exact. Measured with the former method on 513² worlds, RMS within
//   2 halos of a seam over the relief for windows grown by 1, 2, 3, 4 halos: droplets alone, tiles
//   of 129: 1.35, 1.24, 1.10, 0.98 %; tiles of 257: 1.10, 1.17, 1.00, 0.68 %; eroded-mountains,
//   tiles of 129: 0.79, 0.77, 0.42, 0.40 %; tiles of 257: 0.50, 0.34, 0.27, 0.27 % — a slow, uneven
//   decay, while the work per tile grows as the window's area (measured: 3.4× the time at 4 halos
//   for tiles of 129): the goal was out of reach at ≤ 3× the time for droplets alone.
//
// stream_power (bounded; exact when the world has at most kStreamPowerCoarseMax samples per axis).
// Drainage area is global: it accumulates over every sample upstream. So the stage is first solved
// on the whole world at once, on a coarse grid that fits memory: every s-th sample of the world
// (s = ceil((n − 1) / (kStreamPowerCoarseMax − 1)) along both axes, the last row and column of the
// world always included), read tile by tile. The stage runs there with the coarse frame (cells of
// s · cell_m, so drainage areas, slopes and every parameter in world units keep their meaning).
// When s = 1 the coarse grid is the world and the tiles receive the whole map's stage output itself,
// bit for bit. When s > 1 the coarse solve records its heights at kStreamPowerSnapshots + 1 times
// (the start, then evenly spaced steps), and the world is refined at full resolution:
//   * World-aligned blocks (`block` samples: block k's core spans samples [k·block, (k+1)·block]
//     along each axis) are each solved by the stage's own kernel at full resolution on the core grown
//     by `halo` samples (clipped to the world), from the world's input heights filled across tiles
//     as the stage's solver starts (fill_depressions_tiled, ε = 0: the whole map's filled input, bit
//     for bit), so that a lake that a window's ring cuts starts at its level, not drained across the
//     ring by the window's own first fill (erosion::detail::stream_power_window,
//     src/stream_power_detail.hpp), with the coarse solve as
//     boundary: the window's border ring, the solver's outlets, is held at its input height plus the
//     coarse change since the start (bilinear in space, linear in time between snapshots) at every
//     step, and the drainage area of coarse cells outside the window that drain into it (their coarse
//     area in fine cells, s² per coarse cell, from the snapshots' receivers, linear in time) enters at
//     the window's sample nearest to where it crosses the ring.
//   * Sweeps (an overlapping Schwarz iteration; `sweeps`, default kStreamPowerSweeps = 6 since
//     session 19, 4 before; 0 turns the refinement off, see there): the first holds
//     each window's ring at the coarse levels and gives it the coarse inflow, as above; each later
//     sweep holds it, step by step, at the latest solve of the neighbour whose core holds the ring
//     sample (its owner: a shared core end belongs to the lower block), as doubles, and gives it the
//     drainage area crossing it (the owner's receivers and areas on the ring), rounded to whole cells
//     (so that the solver reads A^m from its table). Until session 20 the ring was held at the blend
//     (weights below) of every neighbour whose weight reached the sample, passed as floats: near a
//     core end it mixed a neighbour's levels and routes from as little as halo/2 inside that
//     neighbour's window, and the floats cut the solver's doubles (1025² in blocks of 128, halo 48, 6
//     sweeps, stream power alone: 0.368 % near the seams; 0.291 % as doubles; 0.182 % from the
//     owners). With the
//     whole map's levels and inflow a window is the whole map's inside, bit for bit
//     (tests/test_erosion.cpp). The later sweeps are multiplicative (Gauss-Seidel, since session 19):
//     blocks take turns, in the blocks' row order in odd sweeps and in its reverse in even ones, and
//     a block reads what a neighbour gave in this sweep if the neighbour's turn came first, else
//     what it gave in the previous sweep. So one sweep carries the fine solution along a whole river
//     that runs the way of its turns (areas downstream, levels upstream), where a Jacobi sweep (every
//     block from the previous sweep, before session 19) carried it one block further: 4 such sweeps
//     reached a river crossing 4 blocks but not one crossing 8 (8193² in blocks of 1024). The turns
//     run as waves bx + 2·bz: a block's neighbours before it in the row order (W, NW, N, NE) are in
//     earlier waves, the others in later ones, so a wave's blocks are no neighbours of each other
//     and run at once (a distributed build spreads each wave over the ranks: fewer blocks at once
//     than a Jacobi sweep's: at most min(count_z, ⌈count_x / 2⌉), so a world one block tall or at most
//     two blocks wide runs one block at a time after the first sweep; 2 at 4097² by default). The
//     records a sweep passes on (per block and step its neighbours' weighted ring levels, seen and
//     solved, and the drainage area crossing their rings; only to the neighbours whose turn comes
//     after the giver's, the only ones that read them) are written to a temporary file as each block is solved (sweep s writes file s mod 2,
//     so the previous sweep's records are never overwritten while they are read) and read back by
//     each neighbour in its turn, summed in block order; the coarse inflow's lists too. Memory: one
//     block's records, not the world's.
//   * The last sweep's results are blended by a partition of unity of world position: along each axis
//     a block's weight is 1 on its core, falling by a smoothstep across ± halo/2 of each inner core
//     end where the neighbour's rises (the product of the two axes' weights in 2-D), summed in the
//     last sweep's turns (block order where blocks overlap when the last sweep runs the row order,
//     as with the default 6 sweeps; its reverse after an odd number) into a temporary file of the
//     world's heights. So tiles agree on shared samples, and the
//     bytes do not depend on the tile size, the thread count or the ranks. The blocks of each wave
//     are tasks of the build's tile farm (src/world_farm.hpp, kernel "stream-power"; since session
//     18): rank 0 sends a block's window of the filled input, its ring's coarse change and the
//     records its neighbours gave it (or the coarse inflow), any rank solves it on its threads, one
//     block at a time per rank, and rank 0 merges the results (the records it gives, or its solved
//     window) in their turns' order: in one process the blocks run one after another as before, and a
//     distributed build spreads them over the ranks with the same bytes (tests/test_world_mpi.cpp).
//   What it guarantees: the stage's valleys and ranges at full resolution, their drainage crossing
//   the blocks' seams; against one whole-map run, measured (tests/test_world_bounded.cpp, 513², coarse
//   257², blocks of 128; the figures up to session 18 are of Jacobi sweeps): 0.263 % of the relief
//   (RMS within 2 halos of the seams) with halo 48 and 4 sweeps, 0.389 % with halo 32, against 2.09 %
//   for the coarse change alone (in the same band; 4 multiplicative sweeps, session 19: 0.265 % and
//   0.464 %, 6 sweeps 0.422 % and 8 sweeps 0.388 % with halo 32: where a river crosses at most 4
//   blocks, 4 Jacobi sweeps reached it too, and the multiplicative ones are no better); 1025²
//   (100 steps, coarse 513², blocks 256, halo 64, tiles 257, 4 sweeps): 0.427 % against 2.02 %; 4097²
//   (100 steps, coarse 2049², blocks 1024 and halo 64, the default then, 4 sweeps; tiles 1025): 0.659 %
//   against 2.365 % (2 sweeps: 4.20 %, worse than the coarse change alone); 8193² (session 18, the
//   defaults, with thermal and fill after it, tiles 1025): 2.42 % within 128 samples of a seam and
//   2.2 % over the whole world, the goal of 0.5 % missed, and 2.40 % with a coarse grid of 4097² (every
//   2nd sample, as at 4097²): not the coarse grid but the 8 blocks a river crosses against 4 sweeps,
//   each carrying the fine solution one block further (4097² in blocks of 512, 8 across: 1.91 %
//   against 0.40 % in blocks of 1024). With the multiplicative sweeps (session 19; tiles 1025, with
//   thermal and fill): 4097² in blocks of 512: 4 sweeps 0.904 %, 6 sweeps 0.414 %, 8 sweeps 0.375 %
//   within 128 samples of a seam (0.68 % over the world at 6 and 8); 4097² with the defaults (blocks
//   1024, 6 sweeps): 0.348 %, 0.28 % over the world; 8193² with the defaults 0.816 % (0.74 % over
//   the world), the goal of 0.5 % missed, in blocks of 2048 0.655 % (0.59 %). With each ring sample
//   from its owner as doubles (session 20; tiles 1025, with thermal and fill): 4097² with the
//   defaults 0.274 % (0.225 % over the world), 8193² 0.760 % (0.65 %), the goal still missed there:
//   94 % of the squared difference sits in a few whole hillsides raised by 0.03–0.06, some ending at a
//   block's seam (README). With a halo of 192 (session 21, the default since): 8193² 0.310 % (0.32 %
//   over the world), 4097² 0.143 % (0.17 % over the world; see kStreamPowerHalo). Before
//   the blocks started from the filled input, halo 32 gave 3.3 % and that 1025² world 3.45 %: a lake of
//   the input that a ring cut was drained across the ring by the window's own first fill and never
//   came back (src/stream_power_detail.hpp: given the whole map's filled input, ring levels and
//   inflow a window is exact, lakes included). Not guaranteed: the sweeps need not converge to the
//   whole map; larger halos have helped in every case measured, more Jacobi sweeps not always
//   (4097², halo 64: 4 sweeps 0.666 %, 6 sweeps 0.995 %), more multiplicative sweeps up to 6 (above)
//   but not beyond: the iteration does not settle. On 1025² in blocks of 128 (halo 48, stream power
//   alone, session 20, ring levels as doubles but blended) sweeps 11, 12 and 13 gave 0.290, 0.267 and
//   0.254 % near the seams while each sweep still moved the world by about as much (RMS 1.2e-3 and
//   0.9e-3 of heights, 18 % of the samples by more than 1e-4; a relief of 0.67). With one owner per
//   ring sample (the default) 6 sweeps gave 0.182 % and 12 sweeps 0.222 %, and the error of 6 sweeps
//   is spread over the blocks, not held at their seams (RMS 1.2e-3 within 32 samples of a block seam,
//   0.8e-3 beyond), carried by few samples (0.3 % of them differ by more than 1e-2 and hold 44 % of the
//   squared error): routes that flip between sweeps. (Blended, with 25 steps instead of 100: 6 and 12
//   sweeps gave 0.169 and 0.177 %.)
//   The whole map's
//   stage ends ε-filled, so the world drains: the blend, clamped to [0, 1], is filled across tiles as
//   the world's `fill` stage fills (fill_depressions_tiled, relief/world.hpp: the whole world's
//   fill_depressions, ε = 0, bit for bit).
//   A masked stream power (stage_masked.cpp), or sweeps = 0, is not refined: the tiles get their
//   input plus the coarse change (output − input), interpolated bilinearly at each sample's world
//   position and clamped to [0, 1], as before the refinement (a later `fill` stage removes the
//   sub-coarse-cell pits left by the fine detail).
//   Memory: the coarse grid (≤ kStreamPowerCoarseMax² samples, times the stage's own scratch), its
//   snapshots (kStreamPowerSnapshots + 1 floats per coarse sample), one block's window with the
//   stage's scratch and its records, one tile; the records' index (a few hundred bytes per block).
//   Time: sweeps × the stage at full resolution on the windows (each (block + 2·halo)², so about
//   (1 + 2·halo/block)² × the world's area).
//   Measured (this 2-core machine, loaded by other work, 2 threads): the eroded-mountains stages up
//   to stream power (100 steps) at 4097² in tiles of 1025, coarse 2049², blocks 1024, halo 64, 4
//   sweeps: the stream power phase 182 s and 235 s (two runs; 212 s and 234 s of CPU), peak
//   memory of the build 566 MB with the records in memory (session 16); with them on disk (session
//   17, nice −5, load 1-5): median of 3 runs 160 s (138-289 s; 229 s of CPU, 228-238 s), peak
//   361-378 MB; halo 96: 214 s and 237 s (249 s and 253 s of CPU), peak 364-367 MB; halo 64 with 6
//   sweeps: 354 s, peak 385 MB. The coarse solve alone
//   (sweeps = 0: the phase before the refinement, with its two passes over the tiles) is the stage
//   on 2049², 4.6 s: the refinement costs 35-50× that time. Disk, in io.scratch_dir: two temporary
//   files of 4 bytes per world sample (the filled input, the blended output), the coarse inflow's
//   lists, and with more than one sweep the ring record files (two: world_stream_power_scratch_bytes
//   gives them all). build_world's disk and memory checks take the default algorithms' figures
//   unless WorldSettings::algorithm_needs names the stage: register world_stream_power_needs (the
//   same arguments) beside a refining world_stream_power.
#include <cstdint>
#include <vector>

#include "relief/world.hpp"

namespace relief {

constexpr int kStreamPowerCoarseMax = 2049;  // stream power's coarse grid: at most this many samples per axis
constexpr int kStreamPowerBlock = 1024;      // stream power's refinement: world block side, in samples
// Stream power's refinement: samples each block's window adds (96 before session 21, 64 before 17).
// Session 21 (eroded-mountains, tiles 1025, RMS within 128 samples of a seam as a share of the relief):
// 8193² with the other defaults 0.310 % (0.760 % with 96), the goal of 0.5 % met there, 4097² 0.143 %
// (0.274 %); 4097² in blocks
// of 512 and coarse 1025² (8193²'s geometry at half the size), stream power alone: halo 48 0.749 %,
// halo 96 0.288 %. What the halo buys: a ring level is its owner's solve at least a halo inside the
// owner's window, and at fine cells stream power's max-slope clamp holds most hillsides, whose heights
// then follow D8 paths hundreds of samples long to the nearest channel; a narrow halo let a block's
// ring levels and inflow settle on other channels than the whole map's (in the worst blocks at halo 48,
// ring levels off by up to 280 m after the last step; the whole map's ring levels alone, or its
// inflow alone, fixed some blocks and not others). Time: windows of (1024 + 384)² instead of
// (1024 + 192)², 34 % more samples.
constexpr int kStreamPowerHalo = 192;
constexpr int kStreamPowerSnapshots = 8;     // stream power's refinement: coarse snapshots after the start
// Stream power's refinement: passes over the blocks (0: none, the coarse change alone). 4 sweeps beat
// the coarse change alone at every size measured (RMS within 2 halos of the seams, share of the
// relief, eroded-mountains): 513² 0.263 % against 2.09 %, 1025² 0.427 % against 2.02 %, 4097² (the
// other defaults) 0.659 % against 2.365 %; 2 sweeps gave 4.20 % at 4097², worse than none. The
// default since session 17 (4 sweeps, halo 96), once its memory stopped growing with the world; the
// price is time: the refinement takes 35-50× the coarse solve's (see above). Session 17, the stages
// up to stream power at 4097² (tiles 1025, RMS within 128 samples of the seams): halo 64, 4 sweeps
// 0.666 %; halo 96, 4 sweeps 0.413 % (0.387 % within 2 halos), the goal of 0.5 % met; halo 64, 6
// sweeps 0.995 %: more Jacobi sweeps were not always better. Session 19, multiplicative sweeps
// (above), halo 96: 6 sweeps 0.348 % at 4097², and in blocks of 512 (8 across, as 8193² in blocks
// of 1024) 4 sweeps 0.904 %, 6 sweeps 0.414 %, 8 sweeps 0.375 %: hence 6. Its memory no longer
// grows with the world (session 17: the sweeps' ring records, 118 MB at 4097² and 1.9 GB at 16385²
// in memory before, with the inflow lists on top, are in temporary files; tests/
// test_world_memory.cpp).
constexpr int kStreamPowerSweeps = 6;

// The memory world_stream_power(coarse_max, block, halo, sweeps) holds besides the tiles on an
// nx × nz world for a stage of `steps` steps: the coarse solve (its solver's arrays and fill, about
// 40 bytes per coarse sample), its snapshots and the inflow pass (4 · (snapshots + 1) + 20 bytes per
// coarse sample), and when it refines (s > 1, sweeps > 0) one block's window with the solver's arrays
// (about 48 bytes per sample), its coarse inflow and, with more than one sweep, its ring records (what
// it gives its neighbours and what it reads: per step, a few tens of bytes per ring sample), and the
// records' index (a few hundred bytes per block). The records of the other blocks are on disk (below):
// the figure does not grow with the world beyond the coarse grid's cap and the index. An estimate
// for build_world's memory figure, not a bound.
std::uint64_t world_stream_power_memory_bytes(std::int64_t nx, std::int64_t nz, int steps, int coarse_max = kStreamPowerCoarseMax,
                                              int block = kStreamPowerBlock, int halo = kStreamPowerHalo,
                                              int sweeps = kStreamPowerSweeps);
// The disk it uses in WorldStageIO::scratch_dir while it runs, when it refines: two files of 4
// bytes per world sample (the filled input, the blend), the coarse inflow's lists, and with more
// than one sweep two files of ring records (sweep s writes file s mod 2, each holding the records a
// sweep gives the neighbours whose turn comes after the giver's, half the pairs: per block and step
// about 24 bytes per ring sample it gives; together about 108 MB (123 MB before session 20) for a 4097² world of 100 steps in
// blocks of 1024 grown by 64 (about 126 MB grown by 192, the default), 16 times that at 16385²); else
// nothing. An upper estimate.
std::uint64_t world_stream_power_scratch_bytes(std::int64_t nx, std::int64_t nz, int coarse_max = kStreamPowerCoarseMax,
                                               int sweeps = kStreamPowerSweeps, int steps = 100, int block = kStreamPowerBlock,
                                               int halo = kStreamPowerHalo);

constexpr int kHydraulicGroupBlocks = 16;  // hydraulic: at least this many blocks per group side
// The salt of the hydraulic stage's seed (Context::stage_seed; stage_erosion.cpp's apply_hydraulic
// uses this constant, so the tiled world and the whole map seed their droplets alike).
constexpr std::uint64_t kHydraulicSeedSalt = 0x6879647261756cull;

// The world algorithm of the "hydraulic" stage (above). `seed` is the recipe's seed
// (WorldReport::seed; the recipe's seed when it sets one): the stage seeds its droplets from it and
// the stage's index, as the whole-map run does. `group_blocks`: blocks per side of the groups a pass
// runs at once (0: automatic, see above; tests lower it to have many groups on small worlds); the
// bytes do not depend on it. Throws Error("group_blocks", …) when negative. Throws
// Error("hydraulic", …) when the temporary file cannot be made, read or written.
WorldStageAlgorithm world_hydraulic(std::uint64_t seed, int group_blocks = 0);
// The same with the build's seed (WorldStageIO::seed): what default_world_algorithms() registers.
WorldStageAlgorithm world_hydraulic();
// The automatic G of world_hydraulic for tiles of `tile` samples and blocks of `block` (= 2·reach)
// cells: at least one tile's width (rounded up to whole blocks), and kHydraulicGroupBlocks blocks
// when that stays within 2 tiles (at least one block). Before session 16 it was always at least
// kHydraulicGroupBlocks, so a group of a world with a long reach in cells covered most of the world
// (a 16385² river-island world peaked at 2.7 GB). The bytes do not depend on G.
std::int64_t world_hydraulic_group_blocks(std::int64_t tile, std::int64_t block);
// What world_hydraulic holds in memory besides the build's tiles, for build_world's estimate: the
// windows of the groups in flight on `lanes` threads, their results and the merge's window, for a
// stage with resolved params `params` on `world` in tiles of `tile`.
std::uint64_t world_hydraulic_memory_bytes(const Frame& world, std::int64_t tile, const json& params, int lanes);
// The world algorithm of the "stream_power" stage (above), with a coarse grid of at most
// `coarse_max` samples per axis (≥ 3; tests lower it to exercise the coarse path on small worlds),
// refined on world blocks of `block` samples grown by `halo` in `sweeps` passes (tests lower them).
// Throws Error("coarse_max", …) below 3, Error("halo", …) below 4, Error("block", …) below 2 · halo,
// Error("sweeps", …) below 0 (0: no refinement, the coarse change alone).
WorldStageAlgorithm world_stream_power(int coarse_max = kStreamPowerCoarseMax, int block = kStreamPowerBlock,
                                       int halo = kStreamPowerHalo, int sweeps = kStreamPowerSweeps);
// Its needs for build_world's checks (WorldSettings::algorithm_needs["stream_power"], beside
// algorithms["stream_power"] = world_stream_power(the same arguments)): world_stream_power_memory_bytes
// and world_stream_power_scratch_bytes with the stage's steps and these arguments.
WorldAlgorithmNeedsFn world_stream_power_needs(int coarse_max = kStreamPowerCoarseMax, int block = kStreamPowerBlock,
                                               int halo = kStreamPowerHalo, int sweeps = kStreamPowerSweeps);

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
  // The whole-map build's 99.9th percentile at the same places: the reference for seam_jump_p999. The
  // seams' jumps (344 106 at 8193² in tiles of 1025) are a sample of one world apart from the
  // interior's; their percentile differs from the interior's even in the whole map (at 8193² in tiles of 1025, eroded-mountains: 3.90 m/m on the
  // seam lines against 3.55 inside the tiles), so the tiling's own effect is seam_jump_p999 against
  // this, as seam_jump_max against whole_seam_jump_max.
  double whole_seam_jump_p999 = 0;
  // 99.9th percentile of the jumps inside tiles. The goal, read literally, is seam_jump_max ≤
  // this; the whole map itself misses that wherever the seams hold thousands of jumps (12.42 against 3.55
  // m/m at 8193²), so the goal is checked like with like: seam_jump_max ≤ whole_seam_jump_max and
  // seam_jump_p999 ≤ max(interior_jump_p999, whole_seam_jump_p999).
  double interior_jump_p999 = 0;
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
