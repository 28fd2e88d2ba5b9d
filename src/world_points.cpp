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
