#pragma once
// Internal: the factories of every built-in stage, listed by stage_registry() in stage.cpp.
#include "relief/stage.hpp"

namespace relief::stages {

StageDef noise();        // stage_noise.cpp: fractal noise into a layer (set/add/multiply/…)
StageDef redistribute(); // stage_shape.cpp: e' = clamp(modifier · e^exponent)
StageDef terrace();      // stage_shape.cpp: round(e·n)/n, or smooth terraces with sloped walls
StageDef island();       // stage_shape.cpp: distance functions and circular falloff, mixed
StageDef curve();        // stage_shape.cpp: monotone cubic Hermite remap through control points
StageDef slope();        // stage_color.cpp: slope layers (seed 001's mean abs difference; degrees)
StageDef colorize();     // stage_color.cpp: "color" stage — levels on elevation + slope rules
StageDef hillshade();    // stage_color.cpp: hillshaded colour from albedo
StageDef tilemap();      // stage_tilemap.cpp: inside-outside tile grid for the tilemap writer
StageDef hydraulic();    // stage_erosion.cpp: droplet hydraulic erosion (global)
StageDef thermal();      // stage_erosion.cpp: thermal erosion to a talus angle (global)
StageDef fill();         // stage_erosion.cpp: Priority-Flood+ε depression filling (global)
StageDef flow();         // stage_erosion.cpp: D8 flow, accumulation, rivers, lakes, water layer (global)
StageDef stream_power(); // stage_erosion.cpp: stream-power uplift and incision (global)
StageDef biomes();       // stage_biomes.cpp: Voronoi biome regions with their own rules, blended
StageDef volcano();      // stage_features.cpp: seed 003's volcano
StageDef features();     // stage_features.cpp: craters and single mountains
StageDef jiggle();       // stage_features.cpp: vertex jiggle as an 'offset' layer
StageDef props();        // stage_props.cpp: seed 003's clustered prop placement
StageDef climate();      // stage_climate.cpp: moisture/temperature → Whittaker biomes
StageDef image();        // stage_image.cpp: a raster the user brings into a layer (pointwise)
StageDef mask();         // stage_mask.cpp: 0..1 masks from elevation, slope, curvature, flow, coast distance, biome ids
StageDef mix();          // stage_mask.cpp: two layers combined through a mask
StageDef volume();       // stage_volume.cpp: the density band (voxel size, chunks, closed walls)
StageDef overhangs();    // stage_volume.cpp: 3D warp of steep ground into the volume
StageDef caves();        // stage_volume.cpp: cheese, spaghetti and noodle caves carved into the volume
StageDef amplify();      // stage_amplify.cpp: slope-following fractal detail on a coarse input

// stage_masked.cpp: `d` with the optional `mask` parameter (a 0..1 layer scaling the stage's effect
// on the layer it changes: `layer`, or the value of its string parameter `layer_param`).
StageDef masked(StageDef d, std::string layer = "height", std::string layer_param = "");

}  // namespace relief::stages
