// Points in world builds: ownership by tile, merging into the whole map's order, and the whole-map
// writers over the merged list (relief/world_points.hpp).
#include "relief/world_points.hpp"

#include <algorithm>
#include <map>
#include <set>

#include "relief/error.hpp"
#include "relief/writer.hpp"
#include "writer_defs.hpp"

namespace relief {

OwnedRect owned_rect(const WorldGrid& grid, double spacing_m, std::int64_t X, std::int64_t Z) {
  if (X < 0 || Z < 0 || X >= grid.tiles_x || Z >= grid.tiles_z)
    throw Error("tile", "expected a tile of the " + std::to_string(grid.tiles_x) + " x " + std::to_string(grid.tiles_z) +
                            " grid, got (" + std::to_string(X) + ", " + std::to_string(Z) + ")");
  const WorldGrid::Window w = grid.window(X, Z);
  OwnedRect r;
  r.x0_m = double(w.ix0) * spacing_m;
  r.x1_m = double(w.ix0 + w.nx - 1) * spacing_m;
  r.z0_m = double(w.iz0) * spacing_m;
  r.z1_m = double(w.iz0 + w.nz - 1) * spacing_m;
  r.close_x = w.ix0 + w.nx >= grid.nx;
  r.close_z = w.iz0 + w.nz >= grid.nz;
  return r;
}

std::vector<Point> owned_world_points(const Terrain& tile, const WorldGrid& grid, std::int64_t X, std::int64_t Z) {
  const OwnedRect r = owned_rect(grid, tile.frame.cell_m(), X, Z);
  std::vector<Point> out;
  for (const Point& p : tile.points)
    if (r.contains(p.x_m, p.z_m)) out.push_back(p);
  return out;
}

namespace {
// The kinds of points each point-making stage writes, in the order it writes them.
std::vector<std::string> kinds_of(const std::string& stage) {
  if (stage == "volcano") return {"volcano"};
  if (stage == "features") return {"crater", "peak"};
  if (stage == "props") return {"prop"};
  return {};
}
}  // namespace

std::vector<Point> merge_world_points(const Recipe& recipe, const std::vector<std::vector<Point>>& tiles) {
  std::map<std::string, int> group;  // kind → rank of the first stage making it
  int rank = 0;
  for (const RecipeStage& s : recipe.stages) {
    if (!s.def) continue;
    for (const std::string& k : kinds_of(s.def->name))
      if (!group.count(k)) group[k] = rank++;
  }
  struct Item {
    int group;
    std::string kind;  // unknown kinds: after the known ones, by name
    const Point* p;
  };
  std::vector<Item> items;
  for (const auto& list : tiles)
    for (const Point& p : list) {
      auto it = group.find(p.kind);
      items.push_back({it == group.end() ? rank : it->second, it == group.end() ? p.kind : std::string(), &p});
    }
  std::stable_sort(items.begin(), items.end(), [](const Item& a, const Item& b) {
    if (a.group != b.group) return a.group < b.group;
    if (a.kind != b.kind) return a.kind < b.kind;
    if (a.p->z_m != b.p->z_m) return a.p->z_m < b.p->z_m;
    return a.p->x_m < b.p->x_m;
  });
  std::vector<Point> out;
  out.reserve(items.size());
  for (const Item& i : items) out.push_back(*i.p);
  return out;
}

std::vector<Point> merge_world_points(const Recipe& recipe, const std::vector<std::vector<Point>>& tiles,
                                      const std::map<int, std::vector<Point>>& global) {
  const std::vector<Point> local = merge_world_points(recipe, tiles);
  std::vector<Point> out;
  out.reserve(local.size());
  std::set<std::string> emitted;
  auto emit_kind = [&](const std::string& k) {
    if (!emitted.insert(k).second) return;
    for (const Point& p : local)
      if (p.kind == k) out.push_back(p);
  };
  for (std::size_t i = 0; i < recipe.stages.size(); ++i) {
    const auto g = global.find(int(i));
    if (g != global.end()) {
      out.insert(out.end(), g->second.begin(), g->second.end());
      continue;
    }
    if (recipe.stages[i].def)
      for (const std::string& k : kinds_of(recipe.stages[i].def->name)) emit_kind(k);
  }
  for (const Point& p : local)  // kinds no stage names, in merge_world_points' order
    if (!emitted.count(p.kind)) out.push_back(p);
  return out;
}

std::string encode_world_points(const std::string& phase_id, std::int64_t X, std::int64_t Z, const std::vector<Point>& points) {
  json list = json::array();
  for (const Point& p : points) list.push_back(json::array({p.kind, p.type, p.x_m, p.y_m, p.z_m, p.rotation_deg, p.scale}));
  return json({{"format", 1}, {"phase", phase_id}, {"tile", {X, Z}}, {"points", std::move(list)}}).dump() + "\n";
}

std::vector<Point> decode_world_points(std::string_view bytes, const std::string& phase_id, std::int64_t X, std::int64_t Z,
                                       const std::string& origin) {
  auto bad = [&](const std::string& what) { return Error("points", "point file " + origin + ": " + what); };
  const json doc = json::parse(bytes.begin(), bytes.end(), nullptr, false);
  if (!doc.is_object()) throw bad("expected a JSON object");
  auto field = [&](const char* k) -> const json& {
    const auto it = doc.find(k);
    if (it == doc.end()) throw bad(std::string("missing \"") + k + "\"");
    return *it;
  };
  const json& format = field("format");
  if (!format.is_number_integer() || format.get<std::int64_t>() != 1) throw bad("expected \"format\": 1, got " + format.dump());
  const json& phase = field("phase");
  if (!phase.is_string() || phase.get<std::string>() != phase_id) throw bad("of another world or phase (expected " + phase_id + ")");
  const json& tile = field("tile");
  if (!tile.is_array() || tile.size() != 2 || !tile[0].is_number_integer() || !tile[1].is_number_integer() ||
      tile[0].get<std::int64_t>() != X || tile[1].get<std::int64_t>() != Z)
    throw bad("expected \"tile\": [" + std::to_string(X) + ", " + std::to_string(Z) + "], got " + tile.dump().substr(0, 60));
  const json& list = field("points");
  if (!list.is_array()) throw bad("expected \"points\" to be an array");
  std::vector<Point> out;
  out.reserve(list.size());
  for (std::size_t i = 0; i < list.size(); ++i) {
    const json& e = list[i];
    if (!e.is_array() || e.size() != 7 || !e[0].is_string() || !e[1].is_string())
      throw bad("points[" + std::to_string(i) + "]: expected [kind, type, x_m, y_m, z_m, rotation_deg, scale]");
    for (std::size_t k = 2; k < 7; ++k)
      if (!e[k].is_number()) throw bad("points[" + std::to_string(i) + "][" + std::to_string(k) + "]: expected a number");
    Point p;
    p.kind = e[0].get<std::string>();
    p.type = e[1].get<std::string>();
    p.x_m = e[2].get<double>();
    p.y_m = e[3].get<double>();
    p.z_m = e[4].get<double>();
    p.rotation_deg = e[5].get<double>();
    p.scale = e[6].get<double>();
    out.push_back(std::move(p));
  }
  return out;
}

std::vector<std::string> write_world_points(const std::vector<Point>& merged, const Frame& world, Output& out) {
  Terrain t;
  t.frame = world;
  t.points = merged;
  WriteContext ctx;
  std::vector<std::string> files;
  for (const WriterDef& w : {detail::props_writer(), detail::features_writer()}) {
    if (w.applies && !w.applies(t)) continue;
    w.write(t, ctx, out);
    files.insert(files.end(), w.files.begin(), w.files.end());
  }
  return files;
}

}  // namespace relief
