// The studio's binary frame ("RLF1"): see studio_frame.hpp for the layout.
#include "studio_frame.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

namespace relief::cli {

std::pair<json, char*> FrameWriter::reserve(std::size_t bytes) {
  json d;
  d["offset"] = blobs_.size();
  d["bytes"] = bytes;
  const std::size_t at = blobs_.size();
  blobs_.resize(at + bytes + (8 - bytes % 8) % 8, '\0');
  return {d, blobs_.data() + at};
}

json FrameWriter::add(const void* data, std::size_t bytes) {
  auto [d, at] = reserve(bytes);
  if (bytes) std::memcpy(at, data, bytes);
  return d;
}

std::string FrameWriter::finish(json header) {
  // Offsets must be absolute, but the header's length depends on them: iterate to a fixed point
  // (converges in ≤ 3 rounds as digits only grow).
  std::size_t base = 0;
  std::string text;
  for (int round = 0; round < 8; ++round) {
    json h = header;
    fix(h, base);
    text = h.dump();
    const std::size_t need = 8 + text.size(), padded = need + (8 - need % 8) % 8;
    if (padded == base) break;
    base = padded;
  }
  std::string out;
  out.reserve(base + blobs_.size());
  out = "RLF1";
  const std::uint32_t n = std::uint32_t(text.size());
  for (int k = 0; k < 4; ++k) out.push_back(char((n >> (8 * k)) & 255));
  out += text;
  out.append(base - out.size(), '\0');
  out += blobs_;
  return out;
}

void FrameWriter::fix(json& j, std::size_t base) {
  if (j.is_object()) {
    if (j.contains("offset") && j.contains("bytes") && j["offset"].is_number_unsigned())
      j["offset"] = j["offset"].get<std::size_t>() + base;
    for (auto& [k, v] : j.items())
      if (k != "offset") fix(v, base);
  } else if (j.is_array()) {
    for (auto& v : j) fix(v, base);
  }
}

namespace {

// Channel 0 of every sample as Float32.
void write_f32(const Layer& l, std::size_t count, char* out) {
  if (l.channels == 1) {
    std::memcpy(out, l.data.data(), count * 4);
  } else {
    for (std::size_t k = 0; k < count; ++k) std::memcpy(out + 4 * k, &l.data[k * l.channels], 4);
  }
}

// RGB8: round(clamp(v, 0, 1)·255), NaN → 0; rows in parallel (each byte depends on one value).
void write_rgb8(const Layer& l, std::size_t count, char* out) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count * 3, 1 << 16), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t k = r.begin(); k < r.end(); ++k) {
      const float v = l.data[k];
      const float c = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f;
      out[k] = char(std::uint8_t(c * 255.0f + 0.5f));  // c ≥ 0: truncation rounds
    }
  });
}

}  // namespace

json frame_json(const Frame& f) {
  return {{"nx", f.nx},           {"nz", f.nz},           {"cell_m", f.cell_m()},         {"width_m", f.width_m()},
          {"depth_m", f.depth_m()}, {"x0_m", f.x0_m()},   {"z0_m", f.z0_m()},             {"height_m", f.height_m},
          {"sea_level", f.sea_level}, {"world_width_m", f.world_width_m}, {"world_depth_m", f.world_depth_m}};
}

// Adds `name` to the frame: RGB8 for three-channel layers, Float32 (first channel) otherwise.
json encode_layer(FrameWriter& w, const Terrain& t, const std::string& name) {
  const Layer& l = t.layers.at(name);
  const std::size_t n = t.frame.count();
  json d;
  if (l.channels == 3) {
    auto [desc, at] = w.reserve(n * 3);
    write_rgb8(l, n, at);
    d = std::move(desc);
    d["type"] = "rgb8";
  } else {
    auto [desc, at] = w.reserve(n * 4);
    write_f32(l, n, at);
    d = std::move(desc);
    d["type"] = "f32";
  }
  d["channels"] = l.channels;
  return d;
}

json encode_points(FrameWriter& w, const Terrain& t) {
  std::vector<std::string> kinds, types;
  auto index_of = [](std::vector<std::string>& v, const std::string& s) {
    auto it = std::find(v.begin(), v.end(), s);
    if (it != v.end()) return float(it - v.begin());
    v.push_back(s);
    return float(v.size() - 1);
  };
  std::vector<float> data;
  data.reserve(t.points.size() * 7);
  for (const Point& p : t.points) {
    for (double v : {p.x_m, p.y_m, p.z_m, p.rotation_deg, p.scale}) data.push_back(float(v));
    data.push_back(index_of(kinds, p.kind));
    data.push_back(index_of(types, p.type));
  }
  json d = w.add(data.data(), data.size() * sizeof(float));
  d["count"] = t.points.size();
  d["stride"] = 7;
  d["fields"] = {"x_m", "y_m", "z_m", "rotation_deg", "scale", "kind", "type"};
  d["kinds"] = kinds;
  d["types"] = types;
  return d;
}

}  // namespace relief::cli
