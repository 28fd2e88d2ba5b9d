#pragma once
// Writing terrains (umbrella header): the Output interface and MemoryOutput
// (relief/output_interface.hpp), FileOutput and the atomic commit (relief/file_output.hpp), the
// writer registry (relief/writer.hpp), the image encoders (relief/encode_image.hpp) and, through
// relief/export.hpp, writer options, meshes and mesh encoders. Include the narrower headers where
// one concern is enough.
#include "relief/encode_image.hpp"
#include "relief/export.hpp"
#include "relief/file_output.hpp"
#include "relief/output_interface.hpp"
#include "relief/writer.hpp"
