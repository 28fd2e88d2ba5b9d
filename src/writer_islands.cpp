// Writers for the island systems: the biome map and its legend, feature points, props.
//
// biomes.json: {"layer": "biome", "samples": N, "biomes": [{"id", "name", "color": "#rrggbb",
//   "samples", "share"}]} with share = samples / N of this map (shares sum to 1). "color" is always
//   "#rrggbb", each channel rounded to 8 bits: the colour biome.png paints the biome with (a legend,
//   not a recipe value, so it does not keep the bits a resolved recipe's [r, g, b] keeps).
// features.json: {"features": [{"kind", "type", "x_m", "y_m", "z_m", "radius_m"?}]} in metres,
//   y with the sea surface at 0 (the mesh's frame).
// props.json: {"count", "types": {name: count}, "props": [{"type", "x_m", "y_m", "z_m",
//   "rotation_deg", "scale"}]}; props.csv has the same rows under the header
//   type,x_m,y_m,z_m,rotation_deg,scale. Numbers are written with 3 decimals (millimetres, and
//   thousandths of a degree / of the scale): enough for placement, identical for any thread count.
#include "writer_defs.hpp"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cmath>
#include <map>
#include <string>

#include "relief/error.hpp"
#include "relief/params.hpp"

namespace relief::detail {
namespace {

std::string fixed3(double v) {
  char buf[48];
  auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, 3);
  std::string s(buf, r.ptr);
  if (s == "-0.000") s = "0.000";
  return s;
}
// "#rrggbb" with each channel rounded to 8 bits, as encode_png_rgb8 writes it.
std::string hex8(float r, float g, float b) {
  auto c = [](float x) { return int(double(std::clamp(x, 0.0f, 1.0f)) * 255.0 + 0.5); };
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", c(r), c(g), c(b));
  return buf;
}
// JSON number with 3 decimals (a double rounded through its decimal form).
json num3(double v) { return json::parse(fixed3(v)); }

const Layer& biome_layer(const Terrain& t) {
  auto it = t.layers.find("biome");
  if (it == t.layers.end())
    throw Error("formats", "biomes needs a 'biome' layer: add a biomes or climate stage to the recipe");
  if (it->second.channels != 1 || it->second.data.size() != t.frame.count())
    throw Error("formats", "biomes: the 'biome' layer does not match the frame");
  if (t.biomes.empty()) throw Error("formats", "biomes: the 'biome' layer has no legend");
  return it->second;
}

void write_biomes(const Terrain& t, const WriteContext& ctx, Output& out) {
  const Layer& b = biome_layer(t);
  const std::size_t n = t.frame.count(), nb = t.biomes.size();
  std::vector<std::uint64_t> counts(nb, 0);
  Layer rgb;
  rgb.channels = 3;
  rgb.data.resize(n * 3);
  for (std::size_t k = 0; k < n; ++k) {
    const float v = b.data[k];
    const long id = std::lround(v);
    if (!(v >= 0.0f) || id < 0 || std::size_t(id) >= nb || float(id) != v)
      throw Error("formats", "biomes: sample " + std::to_string(k) + " holds " + std::to_string(v) +
                                 ", not an id of the legend (0.." + std::to_string(nb - 1) + ")");
    ++counts[std::size_t(id)];
    const BiomeInfo& bi = t.biomes[std::size_t(id)];
    rgb.data[3 * k] = bi.r, rgb.data[3 * k + 1] = bi.g, rgb.data[3 * k + 2] = bi.b;
  }
  out.put("biome.png", encode_png_rgb8(rgb, t.frame.nx, t.frame.nz));
  json list = json::array();
  for (std::size_t id = 0; id < nb; ++id) {
    const BiomeInfo& bi = t.biomes[id];
    json e;
    e["id"] = id;
    e["name"] = bi.name;
    e["color"] = hex8(bi.r, bi.g, bi.b);
    e["samples"] = counts[id];
    e["share"] = double(counts[id]) / double(n);
    list.push_back(e);
  }
  json doc;
  doc["layer"] = "biome";
  doc["samples"] = n;
  doc["width"] = t.frame.nx;
  doc["height"] = t.frame.nz;
  doc["biomes"] = list;
  out.put("biomes.json", doc.dump(2) + "\n");
  if (ctx.progress) ctx.progress("biomes", 1.0);
}

void write_features(const Terrain& t, const WriteContext& ctx, Output& out) {
  json list = json::array();
  for (const Point& p : t.points) {
    if (p.kind == "prop") continue;
    json e;
    e["kind"] = p.kind;
    e["type"] = p.type;
    e["x_m"] = num3(p.x_m);
    e["y_m"] = num3(p.y_m);
    e["z_m"] = num3(p.z_m);
    if (p.kind == "crater" || p.kind == "peak") e["radius_m"] = num3(p.scale);
    list.push_back(e);
  }
  json doc;
  doc["frame"] = "metres; x east, z south, y up with the sea surface at 0 (as the mesh)";
  doc["features"] = list;
  out.put("features.json", doc.dump(2) + "\n");
  if (ctx.progress) ctx.progress("features", 1.0);
}

void write_props(const Terrain& t, const WriteContext& ctx, Output& out) {
  json list = json::array();
  std::map<std::string, std::uint64_t> types;
  std::string csv = "type,x_m,y_m,z_m,rotation_deg,scale\n";
  for (const Point& p : t.points) {
    if (p.kind != "prop") continue;
    ++types[p.type];
    json e;
    e["type"] = p.type;
    e["x_m"] = num3(p.x_m);
    e["y_m"] = num3(p.y_m);
    e["z_m"] = num3(p.z_m);
    e["rotation_deg"] = num3(p.rotation_deg);
    e["scale"] = num3(p.scale);
    list.push_back(e);
    const bool quote = p.type.find_first_of(",\"\n") != std::string::npos;
    std::string name = p.type;
    if (quote) {
      std::string q = "\"";
      for (char c : name) q += c == '"' ? std::string("\"\"") : std::string(1, c);
      name = q + "\"";
    }
    csv += name + "," + fixed3(p.x_m) + "," + fixed3(p.y_m) + "," + fixed3(p.z_m) + "," + fixed3(p.rotation_deg) + "," +
           fixed3(p.scale) + "\n";
  }
  json doc;
  doc["frame"] = "metres; x east, z south, y up with the sea surface at 0 (as the mesh); rotation about +y";
  doc["count"] = list.size();
  doc["types"] = types;
  doc["props"] = list;
  out.put("props.json", doc.dump(2) + "\n");
  out.put("props.csv", csv);
  if (ctx.progress) ctx.progress("props", 1.0);
}

bool has_kind(const Terrain& t, bool props) {
  for (const Point& p : t.points)
    if ((p.kind == "prop") == props) return true;
  return false;
}

}  // namespace

WriterDef biomes_writer() {
  WriterDef w{"biomes", "biome.png in the legend's colours and biomes.json (id, name, colour, share of the map)",
              {"biome.png", "biomes.json"}, true, write_biomes};
  w.applies = [](const Terrain& t) { return t.has("biome") && !t.biomes.empty(); };
  w.needs = "a 'biome' layer: add a biomes or climate stage to the recipe";
  return w;
}

WriterDef features_writer() {
  WriterDef w{"features", "features.json: volcano, craters, peaks and other feature points in metres", {"features.json"},
              true, write_features};
  w.applies = [](const Terrain& t) { return has_kind(t, false); };
  return w;
}

WriterDef props_writer() {
  WriterDef w{"props", "props.json and props.csv: type, position in metres, rotation and scale of every prop",
              {"props.json", "props.csv"}, true, write_props};
  w.applies = [](const Terrain& t) { return has_kind(t, true); };
  return w;
}

}  // namespace relief::detail
