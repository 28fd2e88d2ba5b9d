#pragma once
// relief::build_world: a world larger than one map, built tile by tile into a tile store, in memory
// bounded by the tile size, never by the world size (issue 18, phase 1).
//
// The world is the recipe's world at `nx` × `nz` samples (WorldSettings; corners included, cells
// square, as relief/terrain.hpp states): exactly the frame a whole-map run of the same recipe at
// that size uses (World::frame()), so a world may be larger than kMaxSize, the most one map holds.
//
// Tiles. The tile size T is 2ⁿ+1 samples (3 ≤ T ≤ kMaxWorldTile, and not larger than the world
// along both axes). Tiles share their border samples: tile (X, Z) covers the samples
//     ix ∈ [X·(T−1), min(X·(T−1) + T, nx)),   iz ∈ [Z·(T−1), min(Z·(T−1) + T, nz)),
// for X < tiles_x = ceil((nx−1)/(T−1)), Z < tiles_z = ceil((nz−1)/(T−1)). When nx−1 is not a
// multiple of T−1, the last column of tiles is clipped to the world: it has ((nx−1) mod (T−1)) + 1
// samples across (at least 2), still sharing its first column with its left neighbour; the same
// for the last row along z. Nothing lies outside the world: no padding, no extrapolated samples.
//
// What each stage guarantees in a world build (its "world" entry in world.json):
//   exact    pointwise and neighbourhood stages. Each tile is computed by run() on its window
//            (RunOptions::window): the window grows by the recipe's summed halo, stopping at the
//            world's edge, and is cropped, so every sample of every layer equals, bit for bit, the
//            same sample of one whole-map run of the recipe at the world's size, for any tile size
//            and thread count (tests/test_world.cpp checks it against run()).
//   exact    the global stages whose world algorithm is exact (default_world_algorithms(), or
//            WorldSettings::algorithms): `fill` (tiles solved and their border levels exchanged
//            until nothing changes, src/world_fill.cpp), `flow` (drainage, rivers, lakes,
//            relief/world_flow.hpp), a volcano placed on land, `features`
//            (relief/world_features.hpp) and `hydraulic` (the whole map's passes over groups of
//            world blocks, relief/world_bounded.hpp). Each runs as a phase of its own over the stored
//            tiles (see "Phases"), bit for bit as on the whole map.
//   bounded  `stream_power` (relief/world_bounded.hpp): an approximation whose seam error against a
//            whole-map build is measured (tests/test_world_bounded.cpp).
//   refused  the other global stages (today: tilemap): build_world
//            throws Error("stages[i]", …) before any work, saying the stage has no world support yet.
// world_guarantee(stage) says which, and how; world.json and `relief explain` print it.
//
// Tile store (the output folder; every file written atomically: temporary file, rename; world.json,
// overview.png and report.json are flushed (fsync) first, tiles are not — a tile that a power cut
// leaves empty or damaged fails its CRC-32 on the next run and is rebuilt, and skipping the flush
// halves a build's wall time on this machine's disk):
//   world.json          the manifest (below), written before the first tile ("status": "building")
//                       and again at the end ("status": "complete", with every tile's checksum);
//   tiles/x{X}_z{Z}.rtile   one file per tile (X, Z zero-padded to 4+ digits), format below;
//   overview.png        the whole world, point-sampled every `overview_step` samples so that it is
//                       at most 2048 px per side, coloured by height (sea below sea_level) and
//                       hillshaded (8-bit RGB); its samples are kept as 16-bit fixed point in an
//                       unnamed temporary file while building and encoded row by row, so that
//                       memory does not grow with the world (src/world_overview.hpp);
//   report.json         per-stage time (summed over the tiles built), tiles built and skipped,
//                       peak memory, threads, bytes of the store.
//
// Tile file format, version 1 ("rtile"), all integers little-endian:
//   bytes 0..7     magic "RLFTILE1"
//   bytes 8..11    u32 H: length of the header
//   H bytes        header, JSON (UTF-8): {"format": 1, "world_id": "<16 hex>", "tile": [X, Z],
//                  "window": [ix0, iz0, nx, nz], "layers": [{"name": …, "channels": c}, …],
//                  "encoding": "float32le-rowdelta-shuffle-planes", "raw_bytes": R, "payload_bytes": P}
//   P bytes        the layers in the header's order (layer names in ascending byte order), each
//                  coded from its float32 values (row-major, x fastest, channels interleaved: the
//                  Layer layout of relief/terrain.hpp) as
//                    1. row delta: each value's 32 bits as an unsigned integer, minus (mod 2^32)
//                       those of the value `channels` places before it in the same row (the same
//                       channel of the sample to its left); the first sample of each row as is;
//                    2. four byte planes of n bytes each (n values): the least-significant bytes
//                       of the deltas, then the second, third and most-significant bytes;
//                  each plane written as: u8 method (0 = stored, 1 = zlib stream, RFC 1950), u64
//                  length L, L bytes. Lossless. The writer stores a plane when zlib saves < 10 %
//                  on its first 64 KiB (the noisy low bytes of smooth fields), else compresses it
//                  with zlib's RLE strategy at level 1; the planes are coded concurrently. About
//                  half the raw size for heights and colours.
//   4 bytes        u32 CRC-32 (zlib's crc32, ISO-HDLC) of every byte before it.
// world.json lists each tile's checksum (the CRC-32 its trailer holds: of every byte before the
// trailer) and its size.
//
// Resuming. world.json holds a `world_id`: a hash of the format version, the resolved recipe
// (seed, world size and every parameter) and the tile size. A build into a folder whose world.json
// has the same world_id skips every tile whose file is present, has its magic, a matching world_id
// and window and a correct CRC-32; the others are (re)built. Tiles depend only on the recipe,
// seed and window, so a resumed build gives the same bytes as an uninterrupted one. A folder whose
// world.json has another world_id (or is not a world manifest) is refused (Error naming
// `out_path`) unless `force`: then the old world's tile files and world.json, overview.png and
// report.json are removed first (nothing else in the folder is touched). When the recipe has no
// seed and the folder holds a world of the same recipe otherwise, that world's seed is reused, so
// that a rerun without --seed resumes; else a random seed is drawn (WorldReport::seed).
//
// Disk and memory are checked before any work: the store's size is estimated and a world that the
// output's file system cannot hold (minus the tiles already there) is refused (Error naming
// `size_path`, saying the bytes needed and free). The estimate is made from real compressed sizes,
// not from zlib's worst case: before anything is written, the first local phase is run on up to 9
// sample windows (at most 129² samples each, at the world's spacing: windows at the corner of the
// tiles on a 3 × 3 lattice spread over the tile grid, a fixed choice) and each of its layers is
// coded as a tile file codes it; the layers that only later phases make (or when the first phase is
// a world algorithm: every layer) are measured the same way on a small whole-map run (129² samples)
// of the recipe up to that phase's end. Each layer's bytes per sample, times 2 (the safety margin:
// windows are not the whole world, and a global stage may make a layer less compressible than the
// samples show), plus 1 KiB per tile (header and framing), never more than zlib's bound of the raw
// floats, gives each phase store's size; the stores that coexist are the largest two consecutive
// phase stores (each from its own layers); world.json, report.json and overview.png are added at
// their sizes (the overview at 3 bytes per pixel). WorldReport::estimated_bytes is the whole need,
// ::estimated_store_bytes the last store's part (comparable with ::store_bytes). So is a tile whose run
// (estimate_memory_bytes of the grown tile, times the tiles built at once) exceeds the memory budget
// (Error naming `tile_path`), and a grid of more than kMaxWorldTiles tiles.
//
// Threads: tiles are built concurrently, each tile's run on one thread, when there are at least
// twice as many tiles as threads; otherwise one tile at a time with every thread. Bytes never
// depend on it. Peak memory is about (tiles at once) × (one grown tile's run) + three overview
// rows + 12 bytes per tile (checksums and sizes) + the points (rank 0, at the end).
//
// Phases (experimental, for global stages that have a world algorithm: WorldSettings::algorithms).
// The recipe is cut at each such stage: a phase of local stages [a, g) builds every tile as above;
// the global stage g then runs its algorithm over the stored tiles (WorldStageIO); the next local
// phase [g+1, b) computes each tile by run() resumed at stage g+1 (RunOptions::resume) from a
// snapshot of the grown window read from the previous phase's tiles, the global stages before it
// standing in as pointwise placeholders that never run (stage indices, hence seeds, unchanged). So
// every phase is exact when its inputs are. Phases other than the last write into
// `phase-K/` folders (same tile format, world_id + "-pK" in the header, a `complete` marker when
// done, skipped on resume). Lean: a phase's store holds only the layers that later phases read or
// that reach the last store. Local stages may read any layer, so a local phase after it keeps
// everything; only the library's own world algorithms say what they read and overwrite (fill:
// reads and writes height; flow: reads height, writes height, flow and water), so a layer that one
// of them overwrites before any stage reads it is dropped. As soon as phase K+1 is complete, the
// tile files of phase K are removed (its `complete` marker stays, so that a resumed build skips
// it); every phase folder is removed once the build is complete. Disk: the estimate is that of the
// largest two consecutive phase stores (each from its own layers), not their sum over all phases.
//
// Also in the folder: rivers.json and lakes.json when the recipe has a flow stage (its world
// algorithm writes them through WorldStageIO::out); props.json, props.csv and features.json when the
// recipe has stages that make points (props, volcano, features): byte for byte the whole-map files
// (relief/world_points.hpp: each tile keeps the points it owns, merged in the whole map's order).
// Their per-tile sources stay in points/ (points/p{K}/x…_z….json for local phase K, written before
// the tile file and checked with it on resume; points/p{K}.json for a global stage's points): a rerun
// of a complete build needs them. Rank 0 holds every point in memory at the end. Not stored (yet):
// the tilemap, volumes.
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "relief/output_interface.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"

namespace relief {
namespace detail {
class TileFarm;  // src/world_farm.hpp
}

constexpr std::int64_t kMaxWorldSize = 1048577;  // 2^20 + 1 samples per axis
constexpr int kMaxWorldTile = 8193;             // largest tile, samples per axis
constexpr std::int64_t kMaxWorldTiles = 1 << 20;  // most tiles in a world
constexpr int kWorldOverviewMax = 2048;          // overview.png: at most this many pixels per side

// The tile grid of a world (see the top of this file). Pure arithmetic; no files.
struct WorldGrid {
  std::int64_t nx = 0, nz = 0;  // world samples per axis
  int tile = 0;                 // T
  std::int64_t tiles_x = 0, tiles_z = 0;
  // The window of tile (X, Z) on the world grid: first sample and sample counts (clipped at the far
  // edge as documented).
  struct Window {
    std::int64_t ix0 = 0, iz0 = 0;
    int nx = 0, nz = 0;
  };
  Window window(std::int64_t X, std::int64_t Z) const;
  std::int64_t count() const { return tiles_x * tiles_z; }
};
// Validates and makes the grid: throws Error(size_path, …) unless kMinSize ≤ nx, nz ≤ kMaxWorldSize,
// Error(tile_path, …) unless T = 2ⁿ+1 with 3 ≤ T ≤ kMaxWorldTile and T ≤ max(nx, nz), or when the
// grid would have more than kMaxWorldTiles tiles.
WorldGrid world_grid(std::int64_t nx, std::int64_t nz, std::int64_t tile, const std::string& size_path = "world.size",
                     const std::string& tile_path = "tile");

// Relative path of tile (X, Z)'s file in the store: "tiles/x0003_z0012.rtile".
std::string world_tile_path(std::int64_t X, std::int64_t Z);

struct WorldProgress {
  std::int64_t tiles_total = 0;    // tiles × local phases (one phase unless world algorithms run)
  std::int64_t tiles_done = 0;     // finished so far, skipped ones included
  std::int64_t tiles_skipped = 0;  // found finished in the folder (resumed)
  int stage = 0, stages = 0;       // the stage a tile is running now (0-based) and the recipe's count
  std::string_view stage_name;     // "" between tiles
  double fraction = 0;             // 0..1 of the whole build
  // Estimate: the tiles left at the pace of the tiles built so far (time in global phases apart),
  // plus, in a global phase, its rest at its own pace so far (later global phases not counted);
  // −1 before anything can be estimated.
  double seconds_left = -1;
  // While a global stage's world algorithm runs (a phase of its own, see "Phases"): the share of
  // that phase done, 0..1, never decreasing within the phase, and 1 when it ends; stage and
  // stage_name name the stage ("fill", "flow", …). −1 while tiles are being built. The algorithm
  // reports it through WorldStageIO::progress; the library's algorithms report after each tile
  // solve they merge. Their rounds run until a fixpoint, so the share is an estimate (see
  // WorldStageIO::progress). `fraction` counts each global phase as one pass over the tiles.
  double phase_fraction = -1;
};

struct WorldTile {
  std::int64_t X = 0, Z = 0;
  std::string world_id;
  WorldGrid::Window window;
  std::map<std::string, Layer> layers;  // each window.nx × window.nz samples × channels
};

// ---- world algorithms for global stages (experimental; see "Phases" above) -------------------
// What a world algorithm sees: the tile grid and world frame, the state after the stages before it
// (load: every layer of tile (X, Z); load_layers: only the named ones) and where its result goes
// (store: tile (X, Z) with every layer, its own changes applied; update: only the layers it
// changed or added; the last store or update of a tile is final). build_world runs the algorithm
// on rank 0 inside a task arena of `threads` threads (tbb): it may call load, load_layers, store
// and update concurrently for different tiles, and must give the same bits for any thread count.
struct WorldStageIO {
  WorldGrid grid;
  Frame world;  // the whole world's frame
  std::function<WorldTile(std::int64_t X, std::int64_t Z)> load;
  std::function<void(std::int64_t X, std::int64_t Z, WorldTile tile)> store;
  // Tile (X, Z) as load() gives it, but holding only the named layers: the others' byte planes are
  // neither inflated nor decoded (the file's CRC-32 and framing are still checked). Throws
  // Error(WorldSettings::out_path, …) naming the tile and layer when one is missing. Null outside build_world.
  std::function<WorldTile(std::int64_t X, std::int64_t Z, const std::vector<std::string>& layers)> load_layers;
  // Stores tile (X, Z) as the input tile (load's) with the layers of `changed` replaced or added:
  // the other layers' encoded bytes are copied through, neither decoded nor encoded again. The
  // file is byte for byte the one store() writes for the whole tile (each layer's planes are coded
  // on their own). `changed`'s window and world_id are ignored. Null outside build_world.
  std::function<void(std::int64_t X, std::int64_t Z, WorldTile changed)> update;
  int threads = 1;  // the build's thread count (the arena the algorithm runs in)
  std::function<bool()> cancelled;
  // The build's seed (WorldReport::seed: the recipe's, or the one drawn or reused), from which
  // stages seed their randomness with their index, as in a whole-map run (Context::seed).
  std::uint64_t seed = 0;
  // The world folder, for the world files a stage makes besides its tiles (the flow stage's
  // rivers.json and lakes.json: relief/world_flow.hpp); each put() is atomic. Null when the caller
  // runs the algorithm outside build_world.
  Output* out = nullptr;
  // Points the stage makes (a volcano placed on land, features), in the order a whole-map run of
  // the stage makes them; build_world writes them, merged with the points of the local stages in
  // recipe order, as the whole map's props.json / features.json (relief/world_points.hpp). Called
  // at most once per stage; null when the caller runs the algorithm outside build_world.
  std::function<void(std::vector<Point> points)> points;
  // The biome legend (Terrain::biomes) a whole-map run has before this stage (world_legend of
  // relief/world_features.hpp: the legend depends on the stages' params alone). Tiles store no
  // legend; a stage that numbers biomes (the volcano's "volcano" and "lava") reads it here.
  std::vector<BiomeInfo> legend;
  // The algorithm's progress: the share of its work done, 0..1 (build_world keeps the largest value
  // seen, so a late smaller estimate never moves the bar back, and reports 1 when the algorithm
  // returns). Called from one thread at a time (the library's algorithms call it from their
  // in-order merges). Null when nobody listens. The library's algorithms: fill (rounds until no
  // border level changes: round r spans [1 − 2^(1−r), 1 − 2^(−r)), split by the tiles solved in the
  // round), flow (its passes over every tile take fixed spans; its Strahler/carving rounds split
  // their span as fill's rounds do), volcano and features (a step per tile they store, in order),
  // hydraulic (a step per tile read, per group of blocks of each of its 16 passes, per tile written),
  // stream power (refining: its gathering pass [0, 0.1), coarse solve to 0.2, the sweeps' blocks to
  // 0.9, the fill across tiles to 0.97, writing pass [0.97, 1]; not refining: gathering [0, 0.3),
  // coarse solve to 0.4, writing pass [0.4, 1]).
  std::function<void(double fraction)> progress;
  // Distributed builds: the ranks that run the phase's tile solves with this one (src/world_farm.hpp;
  // the fill algorithm uses it). Null outside build_world; one rank without MPI.
  detail::TileFarm* farm = nullptr;
  // A folder on the store's file system for the algorithm's temporary files (the phase's folder;
  // the disk check counts the algorithm's scratch_bytes for it). Empty outside build_world: the system's
  // temporary folder.
  std::string scratch_dir;
};
// Runs one global stage (`stage`, at `index` in the recipe) over the whole stored world.
using WorldStageAlgorithm = std::function<void(const WorldStageIO& io, const RecipeStage& stage, int index)>;
// The world algorithm of the "fill" stage: fill_depressions_tiled (below) of the height layer with
// the stage's epsilon_m. Exact: the same bits as the stage on the whole map.
WorldStageAlgorithm world_fill();
// The world algorithms build_world uses for global stages that WorldSettings::algorithms does not
// name: those that are exact against the stage's whole-map run (by stage name).
std::map<std::string, WorldStageAlgorithm> default_world_algorithms();
// What a stage guarantees in a world build (world.json's stage entries, `relief explain`):
// guarantee "exact" (the same bits as one whole-map build, for any tile size), "bounded" (an
// approximation whose seam error is measured and published) or "none" (refused: build_world throws
// naming the stage), and one line saying how or why. From the stage's locality (pointwise and
// neighbourhood stages are exact through their halo) and default_world_algorithms().
struct WorldGuarantee {
  std::string guarantee, how;
};
WorldGuarantee world_guarantee(const StageDef& stage);
// What a world algorithm needs besides the tiles while its phase runs, for build_world's checks:
// memory (added to one tile's) and disk in WorldStageIO::scratch_dir (added to the stores that
// coexist then).
struct WorldAlgorithmNeeds {
  std::uint64_t memory_bytes = 0, scratch_bytes = 0;
};
// The needs of a stage's algorithm on a world grid (the stage's resolved params: stage.stage->params()).
using WorldAlgorithmNeedsFn = std::function<WorldAlgorithmNeeds(const RecipeStage& stage, const WorldGrid& grid)>;
// The needs of the library's world algorithm of `stage` (default_world_algorithms()) on `grid`, a
// world of frame `world` built with `threads` threads per rank: hydraulic its groups of blocks in
// flight (world_hydraulic_memory_bytes) and the world's heights on disk (4 bytes per sample);
// stream_power its coarse solve and one refined block with its records, and its temporary files
// (world_stream_power_needs with the defaults: the stage's own steps; a masked stage does not
// refine); nothing for the others. build_world's checks use it for every stage run by a world
// algorithm that WorldSettings::algorithm_needs does not name.
WorldAlgorithmNeeds default_world_algorithm_needs(const RecipeStage& stage, const WorldGrid& grid, const Frame& world, int threads);

struct WorldSettings {
  Recipe recipe;  // parsed and validated; world.size is replaced by nx × nz
  std::int64_t nx = 0, nz = 0;  // world samples per axis (0: the recipe's world.size)
  int tile = 257;
  std::string out_dir;  // the tile store's folder (created with its parents if missing)
  int threads = 0;      // 0 = all hardware threads; bytes identical for any count
  bool force = false;   // replace a different world found in out_dir (see "Resuming")
  // How errors name the inputs (the CLI: "--size", "--tile", "--out", "--force").
  std::string size_path = "world.size", tile_path = "tile", out_path = "output", force_name = "force";
  // Progress: called from one thread at a time (serialised), after each stage of a tile being built
  // and after each tile.
  std::function<void(const WorldProgress&)> progress;
  // Checked between stages and row blocks of every tile being built (run()'s RunOptions::cancelled)
  // and between tiles; true stops the build with relief::Cancelled. May be called from several
  // threads at once: make it an atomic read. Finished tiles stay in the store; a rerun resumes.
  std::function<bool()> cancelled;
  std::uint64_t memory_budget_bytes = 0;  // 0: memory_budget_bytes() (generate.hpp)
  // Free bytes assumed for the disk check (0: ask the file system of out_dir's nearest existing
  // folder). Tests set it to exercise the refusal.
  std::uint64_t disk_free_bytes = 0;
  // World algorithms by stage name: a global stage named here runs as a phase of its own over the
  // stored world instead of being refused (see "Phases" at the top of this file).
  std::map<std::string, WorldStageAlgorithm> algorithms;
  // Their needs by stage name, for the disk and memory checks (e.g. world_stream_power_needs for a
  // refining world_stream_power), used by both checks for the stages a world algorithm runs. A stage
  // not named here is checked with the library's figures for its name (default_world_algorithm_needs),
  // which need not be those of the caller's algorithm.
  std::map<std::string, WorldAlgorithmNeedsFn> algorithm_needs;
  // Called after each tile is written, with its (X, Z) (tests kill or cancel builds part way); from
  // several threads at once when tiles are built concurrently.
  std::function<void(std::int64_t X, std::int64_t Z)> after_tile;
  // Distributed build (MPI): the path of the relief_mpi module (src/world_mpi.cpp), loaded with
  // dlopen and started (MPI_Init) by build_world; "": one process, no MPI. Every rank calls
  // build_world with the same settings; out_dir must be one folder of a file system every rank
  // shares. What is distributed: the tiles of every local phase, handed out one at a time by rank 0
  // (each rank builds them `tiles at once` as above, writes them into the shared folder atomically,
  // and sends rank 0 each tile's CRC-32, size, overview samples and stage times). On rank 0 only: the
  // folder checks, the seed, world.json, overview.png, report.json, and the world algorithms of
  // global stages (the other ranks wait). The store's bytes are those of a build without MPI, for
  // any number of ranks. Progress is reported on rank 0 only. An error on any rank is thrown on
  // every rank (Error, Cancelled, or std::runtime_error naming the rank). Error(mpi_path, …) when the
  // module is missing or MPI does not start; MPI starts once per process (one distributed build per
  // process).
  std::string mpi_module;
  std::string mpi_path = "mpi";
  // Checks and estimates only: the input, the folder (a different world is refused as by a build,
  // and --force removes nothing), the disk and memory checks (refused as a build would be); then
  // returns the report — seed, world_id, grid, layers, estimated_bytes, estimated_store_bytes,
  // disk_free_bytes, tile_memory_bytes, tiles_at_once — having written and removed nothing.
  bool dry_run = false;
};

struct WorldReport {
  std::uint64_t seed = 0;
  bool seed_reused = false;  // the seed came from the world already in the folder
  std::string world_id;      // 16 hex digits
  WorldGrid grid;
  std::vector<std::pair<std::string, int>> layers;  // name → channels, in store order
  std::int64_t tiles_built = 0, tiles_skipped = 0;
  std::vector<StageTiming> timings;  // per stage, summed over the tiles built
  double total_ms = 0;
  std::uint64_t peak_memory_bytes = 0;
  std::uint64_t store_bytes = 0;        // tile files, as written or found
  std::uint64_t estimated_bytes = 0;    // the disk check's estimate of the whole need (see "Disk and memory")
  std::uint64_t estimated_store_bytes = 0;  // its part for the last store (tiles/), comparable with store_bytes
  std::uint64_t tile_memory_bytes = 0;  // the memory check's estimate: the largest phase's need
  std::string memory_stage;  // "": the tiles built at once need it most; else the stage whose world algorithm does
  std::uint64_t disk_free_bytes = 0;    // the free space the disk check saw (plus this world's tiles already there)
  bool dry_run = false;                 // WorldSettings::dry_run: nothing was built or written
  int tiles_at_once = 1;
  int overview_step = 1;  // overview.png samples every this many world samples
  json recipe;            // resolved recipe as built (seed and world size set)
  // Distributed builds: this process's rank and the number of ranks (0 and 1 without MPI). On rank 0
  // the report covers every rank (tiles_built: all ranks', peak_memory_bytes: the largest); on the
  // others only seed, seed_reused, world_id, grid, recipe, rank, ranks and tiles_built (its own).
  int rank = 0, ranks = 1;
  // Rank 0: the point files written beside the tiles (props.json, props.csv, features.json) when
  // the recipe has stages that make points; empty otherwise.
  std::vector<std::string> point_files;
};

// Builds (or resumes) the world as described at the top of this file. Throws relief::Error for bad
// input before any tile is built (naming the field), relief::Cancelled when settings.cancelled says
// so (finished tiles stay), and Error("output", …) when a file cannot be written.
WorldReport build_world(WorldSettings settings);

// ---- reading the store ----------------------------------------------------------------------
// Decodes one tile file (bytes as read). Throws Error("tile", …) naming `origin` for a bad magic,
// header, size, zlib stream or CRC-32.
WorldTile decode_world_tile(std::string_view bytes, const std::string& origin = "tile");
// Reads and decodes `dir`/world_tile_path(X, Z).
WorldTile read_world_tile(const std::string& dir, std::int64_t X, std::int64_t Z);
// The manifest of the store in `dir` (Error("output", …) when missing or not a world manifest).
json read_world_manifest(const std::string& dir);
// Every tile file of a complete store checked against world.json's CRC-32 and size: returns the
// paths of the tiles that are missing or differ (empty: the store is intact).
std::vector<std::string> verify_world(const std::string& dir);
// The samples of the window [ix0, ix0+nx) × [iz0, iz0+nz) of the store's world, every layer,
// assembled from the tiles it touches (memory: the window plus one tile). The Terrain's frame is
// the world frame's window. Throws Error("window", …) when it is not inside the world.
Terrain read_world_window(const std::string& dir, std::int64_t ix0, std::int64_t iz0, int nx, int nz);

// The world frame of `r` at nx × nz samples: r.world.frame() with the size replaced (the whole-map
// run's frame at that size, bit for bit).
Frame world_frame(const Recipe& r, std::int64_t nx, std::int64_t nz);

// ---- depression filling over tiles ------------------------------------------------------------
// fill_depressions_tiled: hydro::fill_depressions (relief/hydrology.hpp) of the whole world, bit for
// bit, holding the tiles being solved and the samples on tile borders (about
// 2·(nx·tiles_z + nz·tiles_x) floats). Each round visits the four classes of tiles (X mod 2,
// Z mod 2) in turn and solves the tiles of the class that are waiting for new border levels
// (hydro::fill_depressions_tile, seeded with the border levels known so far); tiles of one class
// share no sample, so they are solved concurrently (tbb, on the calling task arena's threads), and
// their new border levels are exchanged after the class, in tile order. It stops when no border
// level changes. The schedule is fixed, so the stats and the sequence of calls per tile do not
// depend on the thread count (the result is the least fixpoint anyway). `load(X, Z)` returns tile
// (X, Z)'s heights (window.nx × window.nz, as WorldGrid::window); `store(X, Z, f)` receives its
// filled heights after each solve of it (the last call per tile is final; earlier ones may hold
// +inf where no path was known yet). `load` may be called concurrently for different tiles; `store`
// is called from one thread at a time, in the fixed order of the schedule. `progress` (optional) is
// called after each merge with the estimate of WorldStageIO::progress (round r spans
// [1 − 2^(1−r), 1 − 2^(−r))), increasing, from the same thread as `store`; then 1 at the end.
using TileLoad = std::function<std::vector<float>(std::int64_t X, std::int64_t Z)>;
using TileStore = std::function<void(std::int64_t X, std::int64_t Z, std::vector<float> filled)>;
struct TiledFillStats {
  int rounds = 0;               // passes over the dirty tiles (the last one changes nothing)
  std::int64_t tile_solves = 0;  // tile solves in all
};
TiledFillStats fill_depressions_tiled(const WorldGrid& grid, float sea, float epsilon, const TileLoad& load,
                                     const TileStore& store, const std::function<void(double)>& progress = {});

}  // namespace relief
