#pragma once
// Internal: the rivers.json and lakes.json writers (writers_water.cpp), listed by writer_registry().
#include <vector>

#include "relief/output.hpp"

namespace relief {

std::vector<WriterDef> water_writers();

}  // namespace relief
