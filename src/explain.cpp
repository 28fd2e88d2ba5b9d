#include "relief/explain.hpp"

#include <algorithm>

#include "relief/export.hpp"
#include "relief/output.hpp"
#include "relief/recipe.hpp"
#include "relief/stage.hpp"
#include "relief/world.hpp"

namespace relief {

json parameter_table_json(std::string_view only_stage) {
  json o;
  json ws = json::array();
  for (auto& p : world_params()) ws.push_back(p.to_json());
  o["world"] = ws;
  json st = json::array();
  for (auto& d : stage_registry())
    if (only_stage.empty() || d.name == only_stage) {
      json j = d.to_json();
      const WorldGuarantee g = world_guarantee(d);
      j["world"] = {{"guarantee", g.guarantee}, {"how", g.how}};  // in `relief world` builds
      st.push_back(std::move(j));
    }
  if (!only_stage.empty() && st.empty()) {
    std::vector<std::string> names;
    for (auto& d : stage_registry()) names.push_back(d.name);
    const std::string near = nearest_name(std::string(only_stage), names);
    throw Error("stage", "unknown stage " + quote(only_stage) +
                             (near.empty() ? "" : " (did you mean '" + near + "'?)"));
  }
  o["stages"] = st;
  json wr = json::array();
  for (auto& w : writer_registry())
    wr.push_back({{"name", w.name}, {"description", w.description}, {"files", w.files}, {"default", w.in_default_set}});
  o["formats"] = wr;
  // Writer options (declared once in export_options_table) with the CLI flag each one has.
  json eo = json::array();
  for (auto& p : export_options_table().infos()) {
    json j = p.to_json();
    std::string flag = "--" + p.name;
    std::replace(flag.begin(), flag.end(), '_', '-');
    j["flag"] = flag;
    eo.push_back(j);
  }
  o["writer_options"] = eo;
  return o;
}

}  // namespace relief
