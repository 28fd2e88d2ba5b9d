#pragma once
// The whole parameter table as JSON: what `relief explain --json` prints and what the studio's
// panel is generated from (one source, so the two never disagree).
//
//   {"world":   [ParamInfo::to_json(), …],
//    "stages":  [StageDef::to_json(), …]          // stage_registry() order
//    "formats": [{name, description, files, default}, …]}   // writer_registry() order
#include <string_view>

#include "relief/params.hpp"

namespace relief {

// `only_stage` non-empty: just that stage in "stages"; throws Error("stage", …) with the nearest
// name when it is unknown.
json parameter_table_json(std::string_view only_stage = {});

}  // namespace relief
