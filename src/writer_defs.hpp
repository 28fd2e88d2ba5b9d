#pragma once
// Internal: the writers defined outside writers.cpp, which lists them all in writer_registry().
//
// File names: writers.cpp is the registry (and the core writers: heightmap, colour, albedo, OBJ,
// report); every other writer file is writer_<what>.cpp: the encoders of one format or family
// (writer_fbx, writer_gltf, writer_stl, writer_maps) and the registry entries of one group
// (writer_export, writer_islands, writer_water). The tilemap's writer lives with its stage.
#include <vector>

#include "relief/output.hpp"

namespace relief {

// writer_export.cpp: glb, fbx, stl, engine, normalmap, splat, hillshade.
std::vector<WriterDef> export_writers();
// Engine heightmap files for o.engine (one per tile), <engine>_height.json and <engine>_import.txt.
void write_engine_files(const Terrain& t, const ExportOptions& o, Output& out, const OptionPath& path_of = {});

// writer_volume.cpp: caves.glb, caves.obj, caves.vdb (the volume stages' density band).
std::vector<WriterDef> volume_writers();

// writer_water.cpp: rivers.json and lakes.json.
std::vector<WriterDef> water_writers();

namespace detail {
// writer_islands.cpp.
WriterDef biomes_writer();    // biome.png (legend colours) + biomes.json (id → name, colour, share)
WriterDef features_writer();  // features.json: every point that is not a prop
WriterDef props_writer();     // props.json + props.csv
WriterDef geotiff_writer();   // writer_geotiff.cpp: height.tif (Float32 metres, GeoTransform)
}  // namespace detail

namespace writers {
WriterDef tilemap();  // stage_tilemap.cpp: tileset atlas, TSX/TMX/TMJ, CSV, map render, sidecar
}  // namespace writers

}  // namespace relief
