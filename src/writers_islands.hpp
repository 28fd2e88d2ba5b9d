#pragma once
// Internal: the island writers (writers_islands.cpp), listed by writer_registry() in writers.cpp.
#include "relief/output.hpp"

namespace relief::detail {

WriterDef biomes_writer();    // biome.png (legend colours) + biomes.json (id → name, colour, share)
WriterDef features_writer();  // features.json: every point that is not a prop
WriterDef props_writer();     // props.json + props.csv

}  // namespace relief::detail
