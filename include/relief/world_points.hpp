#pragma once
// Points (props, feature points) in world builds (issue 18): which tile owns a point, and the
// world's props.json / props.csv / features.json from the tiles' points, byte for byte the files of
// the whole-map writers (src/writer_islands.cpp) for the same recipe, seed and size.
//
// How a world build gets its points. A stage that makes points and runs in world builds (today:
// `props`, and `volcano` with placement fixed) is a neighbourhood stage: a point depends on the
// terrain within the stage's halo of its position, and its position is a pure function of the
// seed and its attempt/feature number in world metres. So a tile's run() on its grown window
// (RunOptions::window) makes, among others, every point of the whole map whose position lies in the
// tile's window, with the whole map's bits. Each such point is owned by exactly one tile (below);
// the world's list is the union of the tiles' owned points, ordered as the whole map orders them.
//
// Order of a whole-map run's points: by stage, in recipe order (volcano, features, props); within
// `props`, by position: z, then x (stage_props.cpp emits them so); a volcano stage makes one point.
// Limits: two stages making points of the same kind (two props stages) are merged into one group
// ordered by position (the whole map keeps them apart); `features` and a volcano placed on land are
// world algorithms that hand their points over in whole-map order (WorldStageIO::points; merged by
// stage below);
// a point outside the world (a volcano fixed outside it) is owned by no tile, while a whole-map run
// keeps it. A resumed run (RunOptions::resume, the phases of relief/world.hpp) makes only the points
// of the stages it runs: collect each local phase's owned points.
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "relief/output_interface.hpp"
#include "relief/recipe.hpp"
#include "relief/terrain.hpp"
#include "relief/world.hpp"

namespace relief {

// The rectangle of world positions whose points tile (X, Z) owns, in metres, half-open:
// x_m ∈ [ix0 · s, (ix0 + nx − 1) · s), z_m ∈ [iz0 · s, (iz0 + nz − 1) · s) for the tile's window
// (WorldGrid::window) and the world's spacing s (the products as Frame::x_m computes them, so the
// same doubles as run()'s crop of points), closed at the world's far edges (the last tile column
// owns x_m = (world nx − 1) · s, the last row likewise). Neighbouring tiles' bounds are the same
// doubles, so the rectangles partition the world: every point is owned once.
struct OwnedRect {
  double x0_m = 0, x1_m = 0, z0_m = 0, z1_m = 0;
  bool close_x = false, close_z = false;  // the far edge is included
  bool contains(double x_m, double z_m) const {
    return x_m >= x0_m && (close_x ? x_m <= x1_m : x_m < x1_m) && z_m >= z0_m && (close_z ? z_m <= z1_m : z_m < z1_m);
  }
};
OwnedRect owned_rect(const WorldGrid& grid, double spacing_m, std::int64_t X, std::int64_t Z);

// The points of `tile` (run()'s result for tile (X, Z)'s window, RunResult::terrain — cropped, its
// points those of the grown window inside the tile's window — or the grown window's Terrain: only its
// points and frame.spacing_m are read) that tile (X, Z) owns, in their order in `grown`.
// Throws Error("tile", …) when (X, Z) is outside the grid.
std::vector<Point> owned_world_points(const Terrain& tile, const WorldGrid& grid, std::int64_t X, std::int64_t Z);

// The world's points in the whole-map order (above) from every tile's owned points (any tile order:
// `tiles` may be in any order, each list as owned_world_points returned it). `recipe` gives the
// stage order. Memory: the points themselves.
std::vector<Point> merge_world_points(const Recipe& recipe, const std::vector<std::vector<Point>>& tiles);

// The world's points in the whole-map order from the local stages' points (`tiles`, as above) and
// the global stages' points (`global`: recipe stage index → the list its world algorithm gave,
// WorldStageIO::points, already in whole-map order): stage by stage in recipe order, a global
// stage's list where it stands, the local stages' kinds as merge_world_points orders them where
// the first stage making each kind stands; kinds no stage names come last.
std::vector<Point> merge_world_points(const Recipe& recipe, const std::vector<std::vector<Point>>& tiles,
                                      const std::map<int, std::vector<Point>>& global);

// A world build's point files (relief/world.hpp: points/): the points tile (X, Z) owns after a
// local phase, or a global stage's points (X = Z = −1), with the phase's id, as JSON
//   {"format": 1, "phase": "<id>", "tile": [X, Z], "points": [[kind, type, x_m, y_m, z_m, rotation_deg, scale], …]}
// (numbers printed so that they read back as the same doubles).
std::string encode_world_points(const std::string& phase_id, std::int64_t X, std::int64_t Z, const std::vector<Point>& points);
// Reads a point file. Throws Error("points", …) naming `origin` when it is not such a file, or is
// one of another phase or tile (a stale file: the caller rebuilds).
std::vector<Point> decode_world_points(std::string_view bytes, const std::string& phase_id, std::int64_t X, std::int64_t Z,
                                       const std::string& origin);

// Writes the world's points with the whole-map writers: props.json and props.csv (the "props"
// writer) when any point is a prop, features.json (the "features" writer) when any is not; `world`
// is the world frame (world_frame(recipe, nx, nz)). Bytes equal those of relief::generate of the
// whole map with the same recipe, seed and size. Returns the files written.
std::vector<std::string> write_world_points(const std::vector<Point>& merged, const Frame& world, Output& out);

}  // namespace relief
