#pragma once
// Internal: the export writers (writers_export.cpp), appended to writer_registry() in writers.cpp.
#include <vector>

#include "relief/output.hpp"

namespace relief {

std::vector<WriterDef> export_writers();
// Engine heightmap files for o.engine (one per tile), <engine>_height.json and <engine>_import.txt.
void write_engine_files(const Terrain& t, const ExportOptions& o, Output& out, const OptionPath& path_of = {});

}  // namespace relief
