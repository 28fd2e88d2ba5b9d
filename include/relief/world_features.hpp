#pragma once
// World algorithms for the feature stages (issue 18): a volcano placed on `land`, and `features`
// (craters and peaks), exact in world builds: every layer and every point equals, bit for bit, one
// whole-map run of the same recipe at the world's size, for any tile size.
//
// Why they are global. Both choose their places among seeded candidates scored on the incoming
// heights of the whole map (src/stage_features.cpp): the volcano takes the most land-covered of 96
// candidates spread over the whole world; features take, in attempt order, the first candidates
// wholly on land, clear of the volcano and of each other. The candidates' positions depend only on
// the seed, the stage index and the world frame; their scores read a few samples each. So a world
// algorithm can decide exactly what the whole map decides from the stored tiles:
//
// world_volcano() (the "volcano" stage with placement land; placement fixed is a neighbourhood stage
// and runs in the tiles):
//   1. the 96 candidates' 49 land probes each (bilinear heights) are read from the stored tiles,
//      grouped by the tile holding each probe's 2 × 2 samples, each such tile loaded once; the best
//      candidate is chosen as the whole map chooses it (the same code: detail::VolcanoPlan);
//   2. the lava level reads the heights after the volcano's shape (foundation, lift, crater) at 64
//      rim points and the centre: every tile holding one of those 2 × 2 blocks is loaded, shaped in
//      memory (not stored) and read;
//   3. every tile is stored once: the tiles within radius_m (+ a cell) of the centre are loaded
//      (height, albedo, biome, volcano), shaped and coloured; the others get only the "volcano"
//      footprint layer (created in every tile, 0 outside the volcano, as the whole map creates it),
//      their other layers passed through undecoded (WorldStageIO::update);
//   4. the volcano's point is handed to io.points (one point).
// world_features() (the "features" stage, either placement):
//   1. placement runs the whole map's sequential loop (detail::FeaturesPlan::place); the predicates
//      it asks in attempt order (candidate wholly on land: 49 bilinear heights; clear of the volcano:
//      17 nearest samples of the "volcano" layer, when the tiles have one) are read from the stored
//      tiles for a batch of attempts at a time (64, then doubling up to 4096 attempts; both the
//      crater and the peak size of each attempt), each tile holding a probe loaded once per batch;
//   2. each feature's point height reads the heights (bilinear) at its centre after the features
//      before it: the tiles holding those blocks are loaded, the features applied in order in memory
//      and read before each one's own effect;
//   3. every tile is stored once: those within a feature's reach (3 R of a crater, 1.2 R of a peak,
//      + a cell) loaded (height, albedo) with every feature's effect applied in order, the others
//      passed through unchanged;
//   4. the features' points, in placement order (craters, then peaks), are handed to io.points.
// Every tile is stored exactly once (the phase machinery requires it: relief/world.hpp, "Phases").
// The arithmetic is the whole-map stage's own (one definition in src/stage_features.cpp): positions
// are world metres, bilinear and nearest reads take world-grid indices (detail::sample_bilinear), the
// per-sample effects depend on the sample's world position only, so a tile computes the whole map's
// bits for its samples.
//
// Memory: one tile (every layer, as io.load gives it) plus the probes of one batch (≤ 4096 attempts
// × 2 sizes × 54 probes × ~40 bytes ≈ 18 MB at the largest batch; a few hundred KB for the shipped
// presets) and the plan (circles: iterations × 32 bytes). Tile loads: the tiles holding probes
// (at most 96 × 49 for the volcano's choice), the tiles holding the lava or base probes (a few), then
// the tiles the effects reach; every tile is written once.
//
// The biome legend. The volcano writes its biome ids ("volcano", "lava") into the "biome" layer when
// the tiles have one; the whole map numbers them in Terrain::biomes, the legend of the stages before
// it, appending them when missing. Tiles do not store the legend: build_world gives the legend
// before the stage in WorldStageIO::legend (world_legend below), and a resumed local phase starts from
// world_legend of its first stage. A caller may pass its own: `legend` is then the legend before the
// stage (in) and receives the legend after it (out: "volcano" and "lava" appended as the whole map
// appends them). With neither (null and an empty io.legend) a world whose tiles hold a "biome" layer
// is refused: Error("stages[i]", …) naming the missing legend, before any tile is stored.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "relief/recipe.hpp"
#include "relief/stage.hpp"
#include "relief/terrain.hpp"
#include "relief/world.hpp"

namespace relief {

// The world algorithm of a volcano placed on land (above). `legend`: see "The biome legend".
WorldStageAlgorithm world_volcano(std::shared_ptr<std::vector<BiomeInfo>> legend = nullptr);
// The world algorithm of the features stage (above).
WorldStageAlgorithm world_features();

// The biome legend (Terrain::biomes) a whole-map run of `r` has after its first `stages` stages, at
// any size: every stage that writes the legend (biomes, climate, volcano) builds it from its params
// alone, never from the terrain, so it is taken from a run of those stages on a 65² world of the
// same recipe (a few milliseconds). For world builds, which store no legend in their tiles: the
// legend before a global stage (world_volcano's `legend`) and the one a resumed phase starts from.
// Throws what run() throws.
std::vector<BiomeInfo> world_legend(const Recipe& r, std::size_t stages);

namespace detail {

// ---- internal: the feature stages' decisions and effects, shared by the whole-map stages
// (src/stage_features.cpp) and the world algorithms (src/world_features.cpp). Not a stable API.

struct XZ {
  double x_m = 0, z_m = 0;
};

// A bilinear read split in two (detail::sample_bilinear is bilinear_mix of bilinear_cell's values):
// the window indices of the 2 × 2 block's first sample (0 ≤ i0 ≤ nx − 2, 0 ≤ j0 ≤ nz − 2) and the
// weights; bilinear_mix takes the block's four values (v10: sample (i0 + 1, j0), v01: (i0, j0 + 1)).
struct BilinearCell {
  int i0 = 0, j0 = 0;
  double tx = 0, tz = 0;
};
BilinearCell bilinear_cell(const Frame& fr, double x_m, double z_m);
double bilinear_mix(const BilinearCell& c, double v00, double v10, double v01, double v11);
// The window indices detail::sample_nearest reads (clamped to the window).
struct NearestSample {
  int i = 0, j = 0;
};
NearestSample nearest_sample(const Frame& fr, double x_m, double z_m);

// The volcano stage, step by step. `params`: the stage's resolved params (Stage::params());
// `frame`: the frame the whole-map stage runs on (the world's, for placement land); `ctx`: the
// recipe's seed and the stage's index. Steps in order: choose (placement land only), set_lava, then
// apply on any window of the frame's world (as often as needed), point.
class VolcanoPlan {
 public:
  VolcanoPlan(const json& params, const Frame& frame, const Context& ctx, const std::string& path);
  ~VolcanoPlan();
  VolcanoPlan(VolcanoPlan&&) noexcept;
  bool on_land() const;
  // Placement land: the candidates' land probes (96 × 49 positions, bilinear heights), and the
  // choice from their heights (in the same order). Placement fixed: none, choose is not needed.
  std::vector<XZ> candidate_probes() const;
  void choose(const std::vector<double>& heights);
  // The heights after shape() (bilinear, in this order: 64 rim points, the centre) set the lava level.
  std::vector<XZ> lava_probes() const;
  void shape(Terrain& window) const;  // foundation, lift, crater: height and the "volcano" layer
  void set_lava(const std::vector<double>& heights_after_shape);
  // shape, then the colours (albedo, biome: ids numbered in window.biomes, appended when missing).
  void apply(Terrain& window) const;
  // False when no sample of `window` lies within radius_m of the centre (with a cell's margin): apply
  // then changes nothing there but creating the zero "volcano" layer.
  bool touches(const Frame& window) const;
  Point point() const;
  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// The features stage, step by step (same arguments). `volcano_layer`: the terrain has a "volcano"
// layer (features keep clear of it). Steps: place, set_base for each feature, apply on any window,
// points.
class FeaturesPlan {
 public:
  FeaturesPlan(const json& params, const Frame& frame, const Context& ctx, const std::string& path, bool volcano_layer);
  ~FeaturesPlan();
  FeaturesPlan(FeaturesPlan&&) noexcept;
  int attempts() const;
  bool on_land() const;  // placement land: land probes decide
  // Attempt `a`'s probes for a crater (true) or a peak (false): land probes (49 positions, bilinear
  // heights: land_ok) and volcano probes (17 positions, nearest samples of "volcano": off_volcano).
  std::vector<XZ> land_probes(int a, bool crater) const;
  std::vector<XZ> volcano_probes(int a, bool crater) const;
  bool land_ok(const std::vector<double>& heights) const;
  static bool off_volcano(const std::vector<float>& values);
  // The whole map's sequential placement; asks land(a, crater) (placement land) and off_volcano(a,
  // crater) (with a volcano layer) in attempt order, never for an attempt before one already asked.
  void place(const std::function<bool(int, bool)>& land, const std::function<bool(int, bool)>& off_volcano);
  int count() const;                           // features placed
  XZ base_probe(int f) const;                  // bilinear height after features [0, f)
  void set_base(int f, double height);
  void apply(Terrain& window, int f) const;    // feature f's effect on any window (height, albedo)
  // False when feature f changes no sample of `window` (farther than its reach, 3 R for a crater and
  // 1.2 R for a peak, plus a cell, from the centre).
  bool touches(const Frame& window, int f) const;
  std::vector<Point> points() const;           // in placement order
  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace detail
}  // namespace relief
