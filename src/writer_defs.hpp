#pragma once
// Internal: factories of writers defined outside writers.cpp, listed by writer_registry().
#include "relief/output.hpp"

namespace relief::writers {

WriterDef tilemap();  // stage_tilemap.cpp: tileset atlas, TSX/TMX/TMJ, CSV, map render, sidecar

}  // namespace relief::writers
