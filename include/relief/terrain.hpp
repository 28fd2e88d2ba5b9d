#pragma once
// The Terrain: the one value that flows through the pipeline.
//
// Coordinates (stated once, relied on everywhere):
//   * The world is the rectangle [0, world_width_m] × [0, world_depth_m] in metres, x east, z south.
//   * A Terrain covers a window of the world: nx × nz samples, corners included, on the world's
//     sample grid of spacing spacing_m = world_width_m / (world nx − 1) (cells are square; the
//     world's depth follows the sample aspect). Sample (i, j) sits at
//       x = (ix0 + i) · cell_m,   z = (iz0 + j) · cell_m,
//     where (ix0, iz0) is the window's integer offset on that grid. Positions are computed from
//     the integer index, never accumulated, so neighbouring windows share their border samples
//     bit for bit and a 2ⁿ+1 preview equals every other sample of the 2ⁿ⁺¹+1 build. nx, nz ≥ 2.
//   * Layers are row-major, x fastest: value (i, j) of channel c is data[(j·nx + i)·channels + c].
//     Image row 0 is the z-min edge, image column 0 the x-min edge.
//   * Elevation ("height" layer) is normalised: 0 is the lowest possible, 1 the highest, with
//     sea_level in between. Metres appear only at the edges: y_m = (e − sea_level) · height_m,
//     so the sea surface sits at y = 0.
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace relief {

struct Frame {
  double world_width_m = 4000.0;  // x extent of the whole world
  double world_depth_m = 4000.0;  // z extent of the whole world
  double spacing_m = 4000.0 / 512;  // sample spacing (square cells) = world_width_m / (world nx − 1)
  int nx = 513, nz = 513;         // samples in this window, corners included (≥ 2 each)
  std::int64_t ix0 = 0, iz0 = 0;  // window offset in samples on the world grid
  double height_m = 600.0;        // metres between elevation 0 and elevation 1
  double sea_level = 0.4;         // normalised elevation of the sea surface

  double cell_m() const { return spacing_m; }
  double width_m() const { return spacing_m * (nx - 1); }   // window extent along x
  double depth_m() const { return spacing_m * (nz - 1); }   // window extent along z
  double x_m(int i) const { return double(ix0 + i) * spacing_m; }
  double z_m(int j) const { return double(iz0 + j) * spacing_m; }
  double x0_m() const { return double(ix0) * spacing_m; }
  double z0_m() const { return double(iz0) * spacing_m; }
  std::size_t count() const { return std::size_t(nx) * std::size_t(nz); }
  // y in metres of a normalised elevation (sea surface at 0).
  double y_m(double e) const { return (e - sea_level) * height_m; }
  // The window of `nx` × `nz` samples starting at sample (ix0, iz0) of this frame's world grid.
  Frame window(std::int64_t ix0, std::int64_t iz0, int nx, int nz) const {
    Frame f = *this;
    f.ix0 = ix0;
    f.iz0 = iz0;
    f.nx = nx;
    f.nz = nz;
    return f;
  }
};

// ---- The process-wide cache of large layer buffers ----
// glibc maps blocks above its mmap threshold afresh and unmaps them when freed (the threshold rises
// to the largest block freed, up to 32 MiB: a 4097² layer, 64 MiB, is always mapped afresh; 4-32 MiB
// layers, tiles of 1025 or 2049, may come back from the heap already mapped), so a run that
// allocates its layers afresh pays the page faults (and the kernel's zeroing) of all of them again:
// for a 4097² float layer about 10-40 ms, as much as a fast stage's whole work. So the buffers of
// kLayerCacheMinBytes (4 MiB) or more that layers give up (a Layer destroyed, or replaced by
// assignment, or a layer re-created at another size) go to one process-wide cache (thread-safe),
// and Terrain::layer(), layer_for_overwrite() and a Layer's copy take from it before allocating:
// the smallest cached buffer whose capacity holds the layer and is at most 1.5x its size.
// Repeated runs in one process (the bench, `relief studio`, the Python module in a loop, a world's
// tiles built one after another) then touch memory that is already mapped.
//
// Bounded by demand: a buffer is kept only if a buffer of its size (to within 1.5x) was asked for
// (each large request of layer(), layer_for_overwrite() or a copy allows one buffer of its size in,
// at most 16 outstanding per size), so the cache holds no more buffers of a size than were asked
// for, and a buffer nobody asks for again (say a world tile's cropped layers) is freed at once.
// A request that finds no buffer (a run of a slightly larger size, e.g. the next world tile's
// grown window) frees the oldest cached buffer a little too small for it (2/3 of it or more), which
// the new buffer replaces. And bounded in bytes: at most buffer_cache_limit(), the oldest first out.
// The default limit is max(256 MiB, 1/8 of the machine's physical memory); the environment
// variable RELIEF_BUFFER_CACHE_MB (read once, at the first use) sets it in MiB, 0 turning the cache
// off. What it holds is only what the last runs gave up and the next have not taken back yet:
// about one terrain's (one tile's) large layers in a sequence of same-size runs (measured: an
// island 4097² world, tiles of 1025 or 2049, 1 thread, peaks 32 and 127 MiB above the uncached
// build's, one tile's layers; per thread building tiles at once).
// Contents: a recycled buffer holds stale values. layer() zero-fills it as before;
// layer_for_overwrite() leaves it to a stage that writes every value (its promise), so no output
// depends on what a buffer held (the tests poison cached buffers with NaN to check that).
inline constexpr std::size_t kLayerCacheMinBytes = std::size_t(4) << 20;
// Frees every cached buffer (back to the OS) and forgets the demand; returns the bytes released.
// Call it when a long-lived process is done generating for a while (or before measuring a first run).
std::size_t release_cached_buffers();
// The cache's byte limit; setting it evicts down to it at once (0: no caching).
void set_buffer_cache_limit(std::size_t bytes);
std::size_t buffer_cache_limit();
// Bytes (capacity) and buffers held now.
std::size_t cached_buffer_bytes();
std::size_t cached_buffer_count();
// Buffers the cache has handed out since the process started (its hits; never reset).
std::size_t cached_buffer_hits();
namespace detail {
// Gives `buffer` to the cache (kept if its capacity is kLayerCacheMinBytes or more, a request of its
// size has a credit left and it fits the limit; freed otherwise). Leaves `buffer` empty. Never throws.
void cache_buffer(std::vector<float>&& buffer) noexcept;
// If `data`'s capacity is below `want` floats and the cache holds a buffer of capacity
// want..1.5 want, swaps it into `data` (its size unchanged: stale values) and gives `data`'s old
// buffer to the cache; returns whether it did.
bool take_cached_buffer(std::vector<float>& data, std::size_t want);
// Records a request of a buffer of `want` floats met otherwise (a Terrain's spare buffer), so that
// the cache may keep that buffer when the layer gives it up (take_cached_buffer records its own).
void note_buffer_request(std::size_t want);
// Test hook: while on, every buffer entering the cache is filled with NaN over its whole capacity
// (size set to its capacity), so that an output reading a stale value shows it. The environment
// variable RELIEF_BUFFER_CACHE_POISON=1 turns it on from the start.
void set_buffer_cache_poison(bool on);
// Test hook: runs `f` holding the cache's lock (a fork() meanwhile waits for it: see buffer_cache.cpp).
void with_buffer_cache_locked(void (*f)());
}  // namespace detail

// A named grid of floats with one or more channels (colour layers have 3, in 0..1 linear-free sRGB).
// Its buffer goes to the process-wide cache above when it is destroyed or replaced by assignment.
struct Layer {
  int channels = 1;
  std::vector<float> data;

  Layer() = default;
  Layer(int channels, std::vector<float> data) : channels(channels), data(std::move(data)) {}
  Layer(const Layer& o);  // a large buffer comes from the cache when it holds one
  Layer(Layer&& o) noexcept = default;
  Layer& operator=(const Layer& o);
  Layer& operator=(Layer&& o) noexcept {
    if (this != &o) {
      if (data.capacity() * sizeof(float) >= kLayerCacheMinBytes) detail::cache_buffer(std::move(data));
      channels = o.channels;
      data = std::move(o.data);
    }
    return *this;
  }
  ~Layer() {
    if (data.capacity() * sizeof(float) >= kLayerCacheMinBytes) detail::cache_buffer(std::move(data));
  }

  float* row(int j, int nx) { return data.data() + std::size_t(j) * nx * channels; }
  const float* row(int j, int nx) const { return data.data() + std::size_t(j) * nx * channels; }
};

// A placed point: props, feature points (volcano centre, peaks) in world metres.
struct Point {
  std::string kind;     // "prop", "volcano", "peak", …
  std::string type;     // prop type or feature name
  double x_m = 0, y_m = 0, z_m = 0;
  double rotation_deg = 0, scale = 1;
};

struct TileMap;  // relief/tilemap.hpp
struct VolumeSpec;  // relief/volume.hpp
// A river polyline (written by the "flow" stage, read by the rivers.json writer). Vertices run
// downstream, in world metres (y above the sea surface), each with the discharge through it and the
// channel width derived from that discharge.
struct RiverVertex {
  double x_m = 0, y_m = 0, z_m = 0;
  double discharge_m3s = 0, width_m = 0;
};
struct River {
  int order = 1;            // Strahler order of the segment
  std::string end;          // where its last vertex lies: "sea", "edge" or "river" (a confluence)
  std::vector<RiverVertex> vertices;
};

// A lake: a depression kept with a flat water surface at its spill level (the "flow" stage).
struct Lake {
  double level_m = 0;                    // water surface, metres above the sea surface
  double area_m2 = 0, volume_m3 = 0, max_depth_m = 0;
  double x_m = 0, z_m = 0;               // centroid of the water surface
  double x0_m = 0, z0_m = 0, x1_m = 0, z1_m = 0;  // bounding box of the lake's sample positions
  double outlet_x_m = 0, outlet_z_m = 0; // the lake sample through which it drains
  std::size_t samples = 0;
};

// One entry of the legend of the "biome" layer (colour components in 0..1).
struct BiomeInfo {
  std::string name;
  float r = 0, g = 0, b = 0;
};

struct Terrain {
  Frame frame;
  std::map<std::string, Layer> layers;
  std::vector<Point> points;
  // Set by the "tilemap" stage: a tile grid of its own size (not a layer of the sample grid).
  std::shared_ptr<const TileMap> tilemap;
  // Set by the volume stages ("overhangs", "caves"): the density volume over the surface band,
  // evaluated chunk by chunk from the height layer and these modifiers by the volume writers
  // (relief/volume.hpp). Null for a pure heightfield.
  std::shared_ptr<const VolumeSpec> volume;
  std::vector<River> rivers;  // empty unless a stage traced rivers
  std::vector<Lake> lakes;    // empty unless a stage kept lakes

  // Float buffers that layer() reuses (by capacity) when it creates a layer, instead of
  // allocating: run() fills it from RunOptions::recycle, so that regenerating a terrain touches
  // memory that is already mapped. Never visible as layers.
  std::vector<std::vector<float>> spare;
  // Legend of the "biome" layer: a sample holding k (an integer stored as float) is biomes[k].
  // Written by the stage that writes "biome"; later stages may append entries (e.g. "lava").
  std::vector<BiomeInfo> biomes;

  bool has(const std::string& name) const { return layers.count(name) != 0; }
  // Returns the layer, creating it (zero-filled) with `channels` channels if missing or if its
  // channel count differs (reusing a spare buffer when one is large enough, else one of the
  // process-wide cache, see kLayerCacheMinBytes). A buffer of 4 MiB or more allocated afresh asks
  // for transparent huge pages first, as layer_for_overwrite() does: on this project's VMs a 4 KiB page fault costs about as much as writing the page three times over,
  // and the island recipe at 4097² (1 thread, in memory) took about 0.65 s without them against 0.41 s.
  Layer& layer(const std::string& name, int channels = 1);
  // As layer(), for a stage that writes every value of the layer before anything reads it: the
  // values are unspecified on return (stale values of an earlier run may be left in it). Used by
  // the slope and hillshade stages. The layer's own buffer, or the smallest spare buffer that
  // holds it, or a cached one (see kLayerCacheMinBytes), is sized without being cleared (shrinking
  // a vector writes nothing; growing one within its capacity value-initialises the added tail only). Only a buffer allocated afresh is
  // zero-filled, because a std::vector<float> cannot hold uninitialised floats; for one of 4 MiB
  // or more, transparent huge pages are requested first (madvise MADV_HUGEPAGE on Linux), which
  // makes the page faults of that first touch up to 512 times fewer. Same results as layer() for
  // every stage that keeps the promise.
  Layer& layer_for_overwrite(const std::string& name, int channels = 1);
  // Returns an existing layer; throws relief::Error naming the layer if it is missing.
  const Layer& get(const std::string& name) const;
  Layer& get(const std::string& name);
};

}  // namespace relief
