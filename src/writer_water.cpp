// rivers.json and lakes.json: the rivers and lakes traced by the "flow" stage, in world metres.
//
// Both writers belong to the default set, which skips them when the recipe has no "flow" stage
// (no "flow" layer); named in --formats without one they are an error (relief::generate).
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "relief/output.hpp"
#include "writer_defs.hpp"

namespace relief {
namespace {

// Millimetre precision keeps the files small and the numbers exact in any JSON reader.
double mm(double v) { return std::round(v * 1000.0) / 1000.0; }
// Six significant digits (discharges span many orders of magnitude).
double sig(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return std::strtod(b, nullptr);
}

json frame_json(const Frame& f) {
  return {{"world_width_m", f.world_width_m}, {"world_depth_m", f.world_depth_m}, {"x0_m", f.x0_m()},
          {"z0_m", f.z0_m()}, {"width_m", f.width_m()}, {"depth_m", f.depth_m()}, {"metres_per_sample", f.cell_m()},
          {"height_m", f.height_m}, {"sea_level", f.sea_level}};
}

void write_rivers(const Terrain& t, const WriteContext& ctx, Output& out) {
  if (!t.has("flow")) return;
  json doc;
  doc["format"] = "relief rivers";
  doc["version"] = 1;
  doc["coordinates"] =
      "world metres: x east, z south, y up with the sea surface at y = 0; vertices run downstream";
  doc["frame"] = frame_json(t.frame);
  doc["columns"] = json::array({"x_m", "y_m", "z_m", "discharge_m3s", "width_m"});
  doc["count"] = t.rivers.size();
  json rivers = json::array();
  for (const River& r : t.rivers) {
    json pts = json::array();
    for (const RiverVertex& v : r.vertices)
      pts.push_back(json::array({mm(v.x_m), mm(v.y_m), mm(v.z_m), sig(v.discharge_m3s), mm(v.width_m)}));
    rivers.push_back({{"order", r.order}, {"end", r.end}, {"points", std::move(pts)}});
  }
  doc["rivers"] = std::move(rivers);
  out.put("rivers.json", doc.dump(1) + "\n");
  if (ctx.progress) ctx.progress("rivers", 1.0);
}

void write_lakes(const Terrain& t, const WriteContext& ctx, Output& out) {
  if (!t.has("flow")) return;
  json doc;
  doc["format"] = "relief lakes";
  doc["version"] = 1;
  doc["coordinates"] = "world metres: x east, z south, y up with the sea surface at y = 0";
  doc["frame"] = frame_json(t.frame);
  doc["count"] = t.lakes.size();
  json lakes = json::array();
  for (std::size_t k = 0; k < t.lakes.size(); ++k) {
    const Lake& l = t.lakes[k];
    lakes.push_back({{"id", k},
                     {"level_m", mm(l.level_m)},
                     {"area_m2", mm(l.area_m2)},
                     {"volume_m3", mm(l.volume_m3)},
                     {"max_depth_m", mm(l.max_depth_m)},
                     {"centroid_m", {mm(l.x_m), mm(l.z_m)}},
                     {"bounds_m", {mm(l.x0_m), mm(l.z0_m), mm(l.x1_m), mm(l.z1_m)}},
                     {"outlet_m", {mm(l.outlet_x_m), mm(l.outlet_z_m)}},
                     {"samples", l.samples}});
  }
  doc["lakes"] = std::move(lakes);
  out.put("lakes.json", doc.dump(1) + "\n");
  if (ctx.progress) ctx.progress("lakes", 1.0);
}

}  // namespace

std::vector<WriterDef> water_writers() {
  std::vector<WriterDef> w = {
      {"rivers", "rivers.json: river polylines in world metres with discharge and width (recipes with a flow stage)",
       {"rivers.json"}, true, write_rivers},
      {"lakes", "lakes.json: lakes with water level, area, volume, depth and outlet (recipes with a flow stage)",
       {"lakes.json"}, true, write_lakes},
  };
  for (WriterDef& d : w) {
    d.applies = [](const Terrain& t) { return t.has("flow"); };
    d.needs = "a 'flow' layer: add a flow stage to the recipe";
  }
  return w;
}

}  // namespace relief
