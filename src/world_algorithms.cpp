// The library's world algorithms (relief/world.hpp): which global stage runs how in a world build,
// and what every stage guarantees there (world_guarantee). One table, so that `relief explain`,
// world.json and build_world agree.
#include <algorithm>
#include <string>
#include <vector>

#include "relief/world.hpp"
#include "relief/world_bounded.hpp"
#include "relief/world_features.hpp"
#include "relief/world_flow.hpp"

namespace relief {

namespace {
// The library's world algorithms: stage name → the algorithm, its guarantee and how it works.
struct WorldAlgorithmEntry {
  const char* stage;
  WorldStageAlgorithm (*make)();
  const char* guarantee;
  const char* how;
};
const std::vector<WorldAlgorithmEntry>& world_algorithm_entries() {
  static const std::vector<WorldAlgorithmEntry> all = {
      {"fill", world_fill, "exact",
       "tiles filled alone, then again with the border levels their neighbours found, until no border level changes "
       "(Barnes 2016)"},
      {"flow", [] { return world_flow(); }, "exact",
       "drainage counts accumulated in each tile, joined through a graph of tile perimeters (Barnes 2017); rivers, "
       "Strahler orders and carving exchanged between tiles until nothing changes; lakes joined across tiles by "
       "union-find over perimeter labels; a height that does not drain is filled first (as by the fill stage); "
       "rivers.json and lakes.json for the whole world"},
      {"hydraulic", [] { return world_hydraulic(); }, "exact",
       "the whole map's 16 passes (4 rounds of droplets over 4 checkerboard colours of world blocks) run one after "
       "another over the whole world, each on groups of blocks grown by a droplet's reach; a pass changes only the cells "
       "within that reach of its blocks and depends on nothing else, so each group gives the whole map's bits; the "
       "world's heights wait between passes in a temporary file (4 bytes per sample)"},
      {"volcano", [] { return world_volcano(); }, "exact",
       "placed on land: the 96 candidates' land probes read from the stored tiles, the best chosen as on the whole "
       "map, the lava level read from the shaped tiles at the rim, then every tile within the radius shaped and "
       "coloured (relief/world_features.hpp); placed fixed: neighbourhood (each tile on its window grown by "
       "ceil((radius_m + rim_radius_m) / cell) + 2 samples); its point is the whole map's"},
      {"features", [] { return world_features(); }, "exact",
       "candidates tried in the whole map's attempt order, their land and volcano probes read from the stored tiles "
       "in batches; each feature's height read after the features before it; every tile within a feature's reach "
       "changed in order (relief/world_features.hpp); its points are the whole map's, in order"},
      {"stream_power", [] { return world_stream_power(); }, "bounded",
       "solved once over the whole world on a grid of at most 2049 samples per axis (exact when the world is no "
       "larger), then re-solved at full resolution on world blocks of 1024 samples grown by 192, in 6 sweeps (the later ones "
       "in turns, each block reading its neighbours' latest solves), each "
       "block held at its neighbours' levels and given their drainage, blended across the blocks' seams "
       "(relief/world_bounded.hpp; measured against a whole map: 0.14 % of the relief near seams at 4097², 0.31 % at 8193²); "
       "drainage stays continuous across tiles"},
  };
  return all;
}
}  // namespace

std::map<std::string, WorldStageAlgorithm> default_world_algorithms() {
  std::map<std::string, WorldStageAlgorithm> m;
  for (const WorldAlgorithmEntry& e : world_algorithm_entries()) m.emplace(e.stage, e.make());
  return m;
}

WorldAlgorithmNeeds default_world_algorithm_needs(const RecipeStage& st, const WorldGrid& g, const Frame& world, int threads) {
  WorldAlgorithmNeeds n;
  if (st.def->name == "stream_power") return world_stream_power_needs()(st, g);
  if (st.def->name == "hydraulic") {
    // Its groups in flight; its file of the world's heights between its passes (relief/world_bounded.hpp).
    n.memory_bytes = world_hydraulic_memory_bytes(world, g.tile, st.stage->params(), threads);
    n.scratch_bytes = 4 * std::uint64_t(std::max<std::int64_t>(0, g.nx)) * std::uint64_t(std::max<std::int64_t>(0, g.nz));
  }
  return n;
}

WorldGuarantee world_guarantee(const StageDef& d) {
  for (const WorldAlgorithmEntry& e : world_algorithm_entries())
    if (d.name == e.stage) return {e.guarantee, e.how};
  // Stages that make points: each tile keeps the points it owns, merged into the world's files.
  const std::string points =
      d.name == "props" ? "; its points are those each tile owns, merged into the whole map's files in its order" : "";
  switch (d.locality) {
    case Locality::Pointwise:
      return {"exact", "pointwise: each tile computes its own samples" + points};
    case Locality::Neighbourhood:
      return {"exact", "neighbourhood: each tile is computed on its window grown by the stage's halo" +
                           std::string(d.halo_rule.empty() ? " (" + std::to_string(d.halo) + " samples)" : " (" + d.halo_rule + ")") +
                           points};
    case Locality::Global:
      break;
  }
  return {"none", "not yet in world builds: " + (d.why_global.empty() ? std::string("it needs the whole map") : d.why_global)};
}

}  // namespace relief
