#include "relief/stage.hpp"

#include "relief/random.hpp"
#include "stages.hpp"

namespace relief {

std::uint64_t Context::stage_seed(std::uint64_t salt) const {
  return hash64(seed, 0x5354414745ull + std::uint64_t(stage_index), salt);
}

json StageDef::to_json() const {
  json o;
  o["name"] = name;
  o["summary"] = summary;
  o["locality"] = locality == Locality::Pointwise ? "pointwise" : locality == Locality::Neighbourhood ? "neighbourhood" : "global";
  if (locality == Locality::Neighbourhood) o["halo"] = halo;
  json ps = json::array();
  for (auto& p : params) ps.push_back(p.to_json());
  o["params"] = ps;
  return o;
}

const std::vector<StageDef>& stage_registry() {
  static const std::vector<StageDef> all = {
      stages::noise(),    stages::redistribute(), stages::terrace(), stages::island(),
      stages::curve(),    stages::slope(),        stages::colorize(), stages::hillshade(),
      stages::biomes(),   stages::volcano(),      stages::features(), stages::jiggle(),
      stages::props(),    stages::climate(),
  };
  return all;
}

const StageDef* find_stage(std::string_view name) {
  for (auto& d : stage_registry())
    if (d.name == name) return &d;
  return nullptr;
}

}  // namespace relief
