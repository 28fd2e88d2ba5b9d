#pragma once
// Engine-ready exports (umbrella header): writer options and engine profiles
// (relief/export_options.hpp), terrain and prop meshes with their conventions (relief/mesh.hpp),
// the mesh encoders behind the glb, fbx and stl writers (relief/encode_mesh.hpp) and the image
// encoders behind the engine, normalmap, splat and hillshade writers (relief/encode_image.hpp).
// Include the narrower headers where one concern is enough.
#include "relief/encode_image.hpp"
#include "relief/encode_mesh.hpp"
#include "relief/export_options.hpp"
#include "relief/mesh.hpp"
