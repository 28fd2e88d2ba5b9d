#pragma once
// The studio's binary frame ("RLF1"), the format /api/generate and /api/steps answer with and the
// page decodes (web/src/api.js, decodeFrame). Little-endian:
//   magic "RLF1" | u32 header length H | H bytes of JSON | zero padding to a multiple of 8 |
//   blobs, each at the offset the header gives (relative to the frame start, multiple of 8).
// One-channel layers are Float32 (nx·nz values, row-major, x fastest), three-channel layers
// Uint8 RGB (round(clamp(v, 0, 1)·255)), points Float32 × 7 (x, y, z, rotation_deg, scale,
// kind index, type index) with the kind and type names in the header.
#include <cstddef>
#include <string>
#include <utility>

#include "relief/params.hpp"
#include "relief/terrain.hpp"

namespace relief::cli {

class FrameWriter {
 public:
  void expect(std::size_t bytes) { blobs_.reserve(bytes); }
  // Reserves a blob of `bytes` bytes and returns {offset, bytes} (offset relative to the blob
  // area, fixed up to an absolute offset in finish()) and where to write it.
  std::pair<json, char*> reserve(std::size_t bytes);
  json add(const void* data, std::size_t bytes);
  // The whole frame: `header` with every blob offset made absolute, then the blobs.
  std::string finish(json header);

 private:
  static void fix(json& j, std::size_t base);
  std::string blobs_;
};

// The frame's geometry as the page reads it (sizes, spacing, extent, sea level).
json frame_json(const Frame& f);
// Adds layer `name` of `t`: RGB8 for three-channel layers, Float32 (first channel) otherwise.
// Returns the layer's header entry {offset, bytes, type, channels}.
json encode_layer(FrameWriter& w, const Terrain& t, const std::string& name);
// Adds every point of `t` (Float32 × 7 each); returns the header entry with the kind and type names.
json encode_points(FrameWriter& w, const Terrain& t);

}  // namespace relief::cli
