#include "relief/stage.hpp"

#include "parallel.hpp"
#include "relief/random.hpp"
#include "stages.hpp"

namespace relief {

std::uint64_t Context::stage_seed(std::uint64_t salt) const {
  return hash64(seed, 0x5354414745ull + std::uint64_t(stage_index), salt);
}

std::unique_ptr<RowKernel> Stage::prepare_rows(Terrain&, const Context&) const { return nullptr; }
Reach Stage::reach(const Frame&) const { return pointwise(); }

void apply_rows(Terrain& t, const RowKernel& k) {
  const Frame& f = t.frame;
  Layer& l = t.get(k.layer());
  if (l.channels != 1 || l.data.size() != f.count())
    throw Error("", "layer '" + k.layer() + "' must have one channel and one value per sample");
  detail::parallel_rows(f.nz, [&](int j) { k.apply_row(j, l.row(j, f.nx)); });
}

json StageDef::to_json() const {
  json o;
  o["name"] = name;
  o["summary"] = summary;
  o["locality"] = locality == Locality::Pointwise ? "pointwise" : locality == Locality::Neighbourhood ? "neighbourhood" : "global";
  if (locality == Locality::Neighbourhood || halo > 0) o["halo"] = halo;
  if (!halo_rule.empty()) o["halo_rule"] = halo_rule;
  if (locality == Locality::Global && !why_global.empty()) o["why_global"] = why_global;
  json ps = json::array();
  for (auto& p : params) ps.push_back(p.to_json());
  o["params"] = ps;
  return o;
}

const std::vector<StageDef>& stage_registry() {
  static const std::vector<StageDef> all = {
      // The stages that change height take the optional `mask` (stage_masked.cpp).
      stages::masked(stages::noise(), "height", "layer"),
      stages::masked(stages::redistribute()),
      stages::masked(stages::terrace()),
      stages::masked(stages::island()),
      stages::masked(stages::curve()),
      stages::slope(),    stages::colorize(), stages::hillshade(), stages::tilemap(),
      stages::masked(stages::hydraulic()),
      stages::masked(stages::thermal()),
      stages::fill(),     stages::flow(),
      stages::masked(stages::stream_power()),
      stages::biomes(),   stages::volcano(),      stages::features(), stages::jiggle(),
      stages::props(),    stages::climate(),  stages::image(),
      stages::mask(),     stages::mix(),
      stages::masked(stages::amplify(), "height", "layer"),
      stages::volume(),   stages::overhangs(), stages::caves(),
  };
  return all;
}

const StageDef* find_stage(std::string_view name) {
  for (auto& d : stage_registry())
    if (d.name == name) return &d;
  return nullptr;
}

}  // namespace relief
