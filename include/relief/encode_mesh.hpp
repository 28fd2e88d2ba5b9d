#pragma once
// Mesh encoders: the bytes of the glb, fbx and stl writers (relief/mesh.hpp gives the conventions).
// Every encoder here:
//   Threads: reads its arguments only, so any number of encoders may run at once on the same
//            terrain; its own work may spread over the caller's oneTBB arena.
//   Bytes:   a function of its arguments alone: the same for any thread count, run and machine with
//            the same build (no time stamps, no pointers, no unordered containers in the output).
//   Throws:  relief::Error naming the field (below), std::bad_alloc; nothing is returned on a throw.
#include <string>
#include <vector>

#include "relief/export_options.hpp"
#include "relief/mesh.hpp"
#include "relief/terrain.hpp"

namespace relief {

struct GlbFiles {
  std::string base;               // terrain.glb
  std::vector<std::string> lods;  // terrain_lod1.glb …
};
// The terrain as binary glTF 2.0: Y up, metres, one mesh per chunk (options chunk_size, style,
// simplify_error_m / triangle_budget), the albedo embedded as a PNG texture, the props as shared
// meshes or EXT_mesh_gpu_instancing (instancing), and with lod_levels > 0 one terrain_lodK.glb per
// level (also linked from the base file's chunks with MSFT_lod when lod_msft is set).
//   Reads:   the "height" layer (required, one channel, frame-sized); "albedo", else "color"
//            (three channels) for the texture or the low-poly face colours, when present; the
//            points of kind "prop". Other layers, rivers, lakes and the tilemap are not read.
//   Throws:  Error("height", …) on a missing or malformed height layer; Error("points[k].type", …)
//            for a prop type prop_mesh() does not know; Error("output", …) if serialisation fails;
//            std::bad_alloc. Nothing is returned or written on a throw.
//   Threads: reads `t` and `o` only, so any number of encoders may run at once on the same
//            terrain; meshing and simplification run row-parallel on the caller's oneTBB arena.
//   Bytes:   a function of (t, o) alone: the same for any thread count, run and machine with the
//            same build (no time stamps, no pointers, no unordered containers in the output).
GlbFiles encode_glb(const Terrain& t, const ExportOptions& o);
// The terrain as binary FBX 7.4 (the base mesh in chunks, Y up, metres through UnitScaleFactor 100;
// props as models sharing one geometry per type), with the albedo embedded as albedo.png.
//   Reads:   as encode_glb (no LOD chain: lod_levels and lod_msft are not read).
//   Throws:  as encode_glb, and Error("output", …) when the file would pass FBX 7.4's 4 GiB limit
//            or compression fails.
//   Threads, bytes: as encode_glb (the FBX time stamps are fixed values, not the clock).
std::string encode_fbx(const Terrain& t, const ExportOptions& o);
// Binary STL of a closed solid (top surface, skirt, base), millimetres, Z up, x east, y north; the
// longer side measures stl_size_mm, heights × stl_exaggeration, the lowest point stl_base_mm above
// the base.
//   Reads:   the "height" layer and the optional "offset" layer (vertex jiggle); options stl_size_mm,
//            stl_exaggeration, stl_base_mm. Nothing else.
//   Throws:  Error("formats", …) without a height layer; Error("height", …) for a malformed one (size,
//            fewer than 2×2 samples, a non-finite value); Error("offset", …) for a malformed offset
//            layer; Error("output", …) past 2³² triangles.
//   Threads, bytes: as encode_glb.
std::string encode_stl(const Terrain& t, const ExportOptions& o);

}  // namespace relief
