#pragma once
// Internal: Voronoi biome regions (the `biomes` stage, stage_biomes.cpp), exposed for tests.
//
// Region points sit on a jittered grid in world coordinates: one point per square cell of
// region_size_m metres, at the cell centre plus jitter · U(−½, ½)² · size, U from a counter-based
// hash of (seed, cell). Every window of the world therefore sees the same points, and the nearest
// point to any location is within √2 · size of it (the point of the location's own cell is).
//
// Assignment of biome types (seed 003 §2.2.1 notes that random assignment puts a desert beside
// snow). Two steps, both pure functions of the cell and its surroundings:
//   1. Climate-driven choice: two low-frequency noise fields, aridity a and ruggedness r, are read
//      at the point; type T scores  log(weight_T) − ((a − a_T)² + (r − r_T)²) / (2 · 0.25²)
//      + variety · G, G a Gumbel variate hashed from (seed, cell, T); the best score wins. Large
//      coherent zones follow the climate, `variety` mixes them.
//   2. Adjacency repair: two types conflict when either lists the other in `avoid`. For every pair
//      of points closer than 3 · region_size_m whose chosen types conflict, the point with the
//      lower hashed priority becomes the `bridge` type, which must conflict with nothing. One pass
//      suffices: a remaining conflict would need two unchanged points with conflicting choices,
//      and the lower of them would have changed. 3 · size bounds the distance between the points
//      of any two Voronoi cells that touch (each cell lies within √2 · size of its point), and also
//      between the points of two samples one spacing apart when the spacing is ≤ size / 6, so no
//      two regions that meet on the map break the rules.
#include <cstdint>
#include <string>
#include <vector>

#include "relief/params.hpp"
#include "shared_tables.hpp"

namespace relief::detail {

// One biome type and its generation rules (seed 003 §3.1): a noise field n ∈ [0, 1], an
// animation-curve remap from n to the lift above sea level (a fraction of the land range
// 1 − sea_level), and a colour gradient on n — or a tiled texture for the whole type.
struct BiomeType {
  static NoiseFields default_noise() {
    NoiseFields n;
    n.octaves = 5;
    n.wavelength_m = 600;
    return n;
  }
  std::string name = "plains";
  double aridity = 0.5, ruggedness = 0.5, weight = 1.0;  // assignment preferences
  std::vector<std::string> avoid;                        // types that must not border this one
  double protect_above = 1.0;  // selective blending leaves samples with lift ≥ this untouched
  NoiseFields noise = default_noise();  // the type's terrain noise (wavelength_m 600, 5 octaves)
  double contrast = 1.6;  // n = clamp(0.5 + contrast · noise / 2, 0, 1)
  std::vector<CurvePoint> curve{{0.0, 0.02}, {1.0, 0.1}};
  std::vector<Level> colors;
  std::string texture;  // "" = colour gradient
  double tile_m = 64;
};

std::vector<BiomeType> default_biome_types();

struct BiomesParams {
  double region_size_m = 700;
  double jitter = 0.9;
  std::vector<BiomeType> types = default_biome_types();
  double climate_wavelength_m = 4000;
  double variety = 0.4;
  std::string bridge = "plains";
  bool flatten_land = true;
  double flatten_keep = 0.03;
  double coast_rise = 0.0;
  double coast_m = 150;
  double coast_slope_deg = 0.0;
  enum class Blend { Interpolate, Selective, None } blend = Blend::Interpolate;
  double border_m = 220;
  double selective_radius_m = 40;
  int selective_passes = 1;
  SeaColors sea;  // sea_shallow, sea_deep, sea_deep_depth, beach_color
  double beach_lift = 0.012;
};

class RegionMap {
 public:
  struct Point {
    std::int64_t cx = 0, cz = 0;  // cell
    double x_m = 0, z_m = 0;
    int initial = 0, type = 0;  // climate choice, type after adjacency repair (indices into types)
    std::uint64_t priority = 0;
  };
  // Covers every query (nearest, contributions) at positions in [x0, x1] × [z0, z1] metres.
  // `seed` is the stage seed. Types must be validated (names unique, bridge conflicts with nothing).
  RegionMap(const BiomesParams& p, std::uint64_t seed, double x0_m, double z0_m, double x1_m, double z1_m);

  double size_m() const { return size_; }
  // Cells searched around a position's own cell (±search): enough for the nearest point and for
  // every point within border_m of it: search · size ≥ √2 · size + border_m.
  int search() const { return search_; }
  std::int64_t cell(double v_m) const;
  const Point& at(std::int64_t cx, std::int64_t cz) const;
  // The nearest region point (ties: the first in row-major cell order of the block searched).
  const Point& nearest(double x_m, double z_m) const;
  // Every point whose type is final (cells within the covered range).
  std::vector<Point> points() const;
  bool conflict(int a, int b) const { return (avoid_[std::size_t(a)] >> b) & 1u; }
  int bridge() const { return bridge_; }

 private:
  double size_ = 1;
  std::int64_t cx0_ = 0, cz0_ = 0;  // first cell of the initial-type range
  int ncx_ = 0, ncz_ = 0;
  int margin_ = 0;  // cells at the range's border whose type is only initial
  int search_ = 2;
  std::vector<Point> cells_;
  std::vector<std::uint64_t> avoid_;  // symmetric conflict masks
  int bridge_ = 0;
};

// Index of the type named `name`, or −1.
int find_type(const std::vector<BiomeType>& types, const std::string& name);

}  // namespace relief::detail
